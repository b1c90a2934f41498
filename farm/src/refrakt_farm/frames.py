"""Frame names, resume and chunks: what the driver decides before anything runs."""

from __future__ import annotations

import os
import re
import tempfile
from dataclasses import dataclass
from pathlib import Path


@dataclass(frozen=True)
class Chunk:
    """Frames ``first`` to ``last`` (inclusive), rendered by one ``refrakt render``."""

    first: int
    last: int

    @property
    def frames(self) -> range:
        return range(self.first, self.last + 1)

    def __str__(self) -> str:
        return f"{self.first}..{self.last}"


def parse_range(text: str) -> tuple[int, int]:
    """``A..B`` (inclusive) or ``K``, as refrakt reads ``--frames``."""
    parts = text.split("..")
    try:
        first, last = (int(parts[0]), int(parts[-1].lstrip("="))) if len(parts) <= 2 else (-1, -2)
    except ValueError:
        raise ValueError(f'"{text}" is not a frame range like 0..2399 or 12') from None
    if first < 0 or last < first:
        raise ValueError(f"frame range {text}: frames must be >= 0 and the range must not run backwards")
    return first, last


def frame_digits(last: int) -> int:
    """Digits of frame numbers in file names, as refrakt pads them: those of the range's last
    frame, and at least 4."""
    return max(4, len(str(max(last, 0))))


def frame_file(name: str, frame: int, ext: str, digits: int) -> str:
    return f"{name}.{frame:0{digits}d}.{ext}"


def missing_frames(out: Path, name: str, first: int, last: int, formats: list[str]) -> list[int]:
    """Frames of ``first..last`` not all of whose files are in ``out`` (resume skips the rest)."""
    digits = frame_digits(last)
    return [k for k in range(first, last + 1) if not all((out / frame_file(name, k, f, digits)).is_file() for f in formats)]


def chunks(frames: list[int], size: int) -> list[Chunk]:
    """Runs of consecutive ``frames`` cut into chunks of at most ``size`` frames."""
    if size < 1:
        raise ValueError("--chunk must be at least 1")
    out: list[Chunk] = []
    for k in sorted(frames):
        last = out[-1] if out else None
        if last is not None and k == last.last + 1 and len(last.frames) < size:
            out[-1] = Chunk(last.first, k)
        else:
            out.append(Chunk(k, k))
    return out


def rendered_frames(folder: Path, name: str) -> dict[int, dict[str, bytes]]:
    """The frames refrakt wrote into ``folder`` as ``NAME.<k>.<ext>``: frame -> ext -> bytes."""
    pattern = re.compile(re.escape(name) + r"\.(\d+)\.([a-z]+)")
    found: dict[int, dict[str, bytes]] = {}
    for path in folder.iterdir():
        m = pattern.fullmatch(path.name)
        if m:
            found.setdefault(int(m.group(1)), {})[m.group(2)] = path.read_bytes()
    return found


def write_atomically(path: Path, data: bytes) -> None:
    """Writes ``path`` under a temporary name beside it and renames it into place, so an
    interrupted run leaves only whole frames."""
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=".farm-tmp")
    try:
        with os.fdopen(fd, "wb") as f:
            f.write(data)
            f.flush()
            os.fsync(f.fileno())
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise


def split_options(argv: list[str]) -> tuple[list[str], list[str]]:
    """The command's own arguments, and those after `--` (refrakt's scene options)."""
    if "--" not in argv:
        return argv, []
    i = argv.index("--")
    return argv[:i], argv[i + 1:]
