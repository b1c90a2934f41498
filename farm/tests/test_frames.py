"""Frame names, resume and chunking (no Ray, no GPU)."""

from __future__ import annotations

from pathlib import Path

import pytest

from refrakt_farm.cli import main
from refrakt_farm.frames import Chunk, chunks, frame_digits, missing_frames, parse_range, rendered_frames, write_atomically


def test_ranges_read_like_refrakt() -> None:
    assert parse_range("0..2399") == (0, 2399)
    assert parse_range("12") == (12, 12)
    assert parse_range("3..=5") == (3, 5)
    for bad in ["5..3", "-1..4", "a..b", "1..2..3"]:
        with pytest.raises(ValueError):
            parse_range(bad)


def test_digits_follow_refrakt_padding() -> None:
    assert frame_digits(23) == 4
    assert frame_digits(12345) == 5


def test_chunks_cover_each_missing_frame_once_and_stop_at_gaps() -> None:
    frames = [0, 1, 2, 3, 4, 7, 8, 20]
    got = chunks(frames, 3)
    assert got == [Chunk(0, 2), Chunk(3, 4), Chunk(7, 8), Chunk(20, 20)]
    assert sorted(k for c in got for k in c.frames) == frames
    with pytest.raises(ValueError):
        chunks(frames, 0)


def test_missing_frames_need_every_format(tmp_path: Path) -> None:
    for k in (0, 1, 2):
        (tmp_path / f"s.{k:04d}.exr").write_bytes(b"x")
    (tmp_path / "s.0001.png").write_bytes(b"x")
    assert missing_frames(tmp_path, "s", 0, 3, ["exr", "png"]) == [0, 2, 3]
    assert missing_frames(tmp_path, "s", 0, 3, ["exr"]) == [3]


def test_rendered_frames_are_found_by_name_whatever_the_padding(tmp_path: Path) -> None:
    (tmp_path / "s.0007.png").write_bytes(b"a")
    (tmp_path / "s.00012.exr").write_bytes(b"b")
    (tmp_path / "other.0001.png").write_bytes(b"c")
    assert rendered_frames(tmp_path, "s") == {7: {"png": b"a"}, 12: {"exr": b"b"}}


def test_atomic_writes_leave_only_the_file(tmp_path: Path) -> None:
    target = tmp_path / "s.0001.png"
    write_atomically(target, b"frame")
    write_atomically(target, b"again")
    assert target.read_bytes() == b"again"
    assert [p.name for p in tmp_path.iterdir()] == ["s.0001.png"]


def test_bad_arguments_are_refused_with_a_message(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["render", str(tmp_path / "none.lua"), "--frames", "0..3", "--out", str(tmp_path)]) == 2
    assert "no such scene file" in capsys.readouterr().err
    (tmp_path / "s.lua").write_text("")
    assert main(["render", str(tmp_path / "s.lua"), "--frames", "9..3", "--out", str(tmp_path)]) == 2
    assert "backwards" in capsys.readouterr().err


def test_scene_options_go_to_pack_and_allow_read_only_there() -> None:
    from refrakt_farm.driver import split_render_args

    args = ["--size", "32x18", "--exposure", "1", "--allow-read", "/assets", "--fps=30", "--tonemap", "agx", "--photons", "0"]
    pack_args, worker_args = split_render_args(args)
    assert pack_args == ["--size", "32x18", "--allow-read", "/assets", "--fps=30", "--photons", "0"]
    assert worker_args == ["--size", "32x18", "--exposure", "1", "--fps=30", "--tonemap", "agx", "--photons", "0"]
