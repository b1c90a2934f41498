"""refrakt-farm on a local Ray cluster started here: a head with no workers' resources and two
worker nodes with one "refrakt" slot each (custom resource: no GPUs on CI), real refrakt on
lavapipe. 24 frames in chunks of 4 come back complete and byte-identical to one `refrakt
render`; a second run skips everything; a worker node killed in the middle of a chunk has that
chunk run again elsewhere, and the result is still complete and identical.
"""

from __future__ import annotations

import subprocess
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest

ray = pytest.importorskip("ray")
from ray.cluster_utils import Cluster  # noqa: E402

from refrakt_farm import FarmJob, render  # noqa: E402
from refrakt_farm.task import ChunkResult  # noqa: E402

STORE = 80 * 1024 * 1024


@pytest.fixture(scope="module")
def cluster() -> Iterator[tuple[Any, list[Any]]]:
    # Quick health checks: a removed node is declared dead in about a second, not 30.
    c = Cluster(
        initialize_head=True,
        head_node_args={
            "num_cpus": 0, "object_store_memory": STORE, "include_dashboard": False,
            "_system_config": {"health_check_period_ms": 500, "health_check_failure_threshold": 2, "health_check_timeout_ms": 500},
        },
    )
    workers = [c.add_node(num_cpus=1, resources={"refrakt": 1}, object_store_memory=STORE) for _ in range(2)]
    c.wait_for_nodes()
    ray.init(address=c.address, log_to_driver=False)
    yield c, workers
    ray.shutdown()
    c.shutdown()


def files(folder: Path) -> dict[str, bytes]:
    return {p.name: p.read_bytes() for p in sorted(folder.iterdir())}


@pytest.fixture(scope="module")
def reference(refrakt_bin: str, scene_dir: Path, tmp_path_factory: pytest.TempPathFactory) -> dict[str, bytes]:
    """The 24 frames rendered by one `refrakt render` on this machine."""
    out = tmp_path_factory.mktemp("reference")
    subprocess.run([refrakt_bin, "render", str(scene_dir / "gem.lua"), "--frames", "0..23", "--out", str(out), "--progress", "quiet"], check=True)
    got = files(out)
    assert len(got) == 48, sorted(got)
    return got


def job(refrakt_bin: str, scene_dir: Path, out: Path) -> FarmJob:
    return FarmJob(scene=scene_dir / "gem.lua", first=0, last=23, out=out, chunk=4, refrakt=refrakt_bin, resource="refrakt", progress="quiet")


def test_chunks_on_two_workers_equal_one_render_and_a_rerun_skips_all(
    cluster: Any, refrakt_bin: str, scene_dir: Path, reference: dict[str, bytes], tmp_path: Path
) -> None:
    summary = render(job(refrakt_bin, scene_dir, tmp_path))
    assert files(tmp_path) == reference, "every frame present and byte-identical to one refrakt render"
    assert summary.frames == 24 and summary.retries == 0 and not summary.failed
    assert len(summary.nodes) == 2, f"both worker nodes rendered chunks: {summary.lines()}"
    assert sum(n.chunks for n in summary.nodes.values()) == 6
    mtimes = {p.name: p.stat().st_mtime_ns for p in tmp_path.iterdir()}
    again = render(job(refrakt_bin, scene_dir, tmp_path))
    assert again.frames == 0 and again.skipped == 24 and not again.nodes
    assert {p.name: p.stat().st_mtime_ns for p in tmp_path.iterdir()} == mtimes, "nothing rewritten"


def test_the_command_line_forwards_options_and_reports_json_events(
    cluster: Any, refrakt_bin: str, scene_dir: Path, reference: dict[str, bytes], tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
) -> None:
    import json

    from refrakt_farm.cli import main

    code = main([
        "render", str(scene_dir / "gem.lua"), "--frames", "0..23", "--chunk", "6", "--out", str(tmp_path),
        "--refrakt", refrakt_bin, "--resource", "refrakt", "--progress", "json", "--", "--photons", "0",
    ])
    out, err = capsys.readouterr()
    assert code == 0, err
    events = [json.loads(line) for line in out.splitlines()]
    assert events[0] == {"event": "start", "frames": 24, "first": 0, "last": 23}
    frames = sorted(e["frame"] for e in events if e["event"] == "frame")
    assert frames == list(range(24)) and events[-1]["event"] == "done" and events[-1]["frames"] == 24
    assert [e["done"] for e in events if e["event"] == "frame"] == list(range(1, 25))
    assert "24 frame(s) rendered" in err and "frames/s while busy" in err, err
    assert files(tmp_path) == reference


def test_a_worker_killed_mid_chunk_has_its_chunk_retried(
    cluster: Any, refrakt_bin: str, scene_dir: Path, reference: dict[str, bytes], tmp_path: Path
) -> None:
    c, workers = cluster
    killed: list[str] = []

    def kill_the_node_that_took_the_next_chunk(result: ChunkResult) -> None:
        # The node that just finished a chunk has already been handed the next one (6 chunks, 2
        # slots); give its refrakt a moment to start on it, then kill the whole node.
        if killed:
            return
        time.sleep(0.5)
        node = next(w for w in workers if w.node_id == result.node_id)
        c.remove_node(node, allow_graceful=False)
        killed.append(result.node_id)

    summary = render(job(refrakt_bin, scene_dir, tmp_path), on_chunk=kill_the_node_that_took_the_next_chunk)
    assert killed, "a node was killed"
    assert summary.retries >= 1, f"the killed node's chunk was run again: {summary.lines()}"
    assert not summary.failed
    assert files(tmp_path) == reference, "complete and identical after the retry"
    survivor = [n for node_id, n in summary.nodes.items() if node_id != killed[0]]
    assert survivor and survivor[0].chunks >= 4, summary.lines()
