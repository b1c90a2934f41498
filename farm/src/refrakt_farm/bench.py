"""Frames/s of refrakt-farm on a local Ray cluster of 1, 2, … worker nodes on this machine
(each node one "refrakt" slot, so the workers share this machine's GPU, or its CPU driver).

    python -m refrakt_farm.bench SCENE --frames 0..47 --chunk 4 --workers 1,2 --refrakt BIN -- --size 480x270

Prints one JSON line per cluster size: workers, frames, seconds, frames_per_s. Each size renders
into a fresh folder; the first size's frames are the reference the others must equal.
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
from pathlib import Path

from refrakt_farm.driver import FarmJob, render
from refrakt_farm.frames import parse_range, split_options


def run(workers: int, job: FarmJob) -> float:
    import ray
    from ray.cluster_utils import Cluster

    cluster = Cluster(initialize_head=True, head_node_args={"num_cpus": 0, "include_dashboard": False})
    try:
        for _ in range(workers):
            cluster.add_node(num_cpus=1, resources={"refrakt": 1})
        cluster.wait_for_nodes()
        ray.init(address=cluster.address, log_to_driver=False)
        summary = render(job)
        if summary.failed:
            raise SystemExit(f"bench: chunks failed: {summary.failed}")
        return summary.seconds
    finally:
        ray.shutdown()
        cluster.shutdown()  # type: ignore[no-untyped-call]


def main(argv: list[str] | None = None) -> int:
    argv, extra = split_options(sys.argv[1:] if argv is None else argv)
    p = argparse.ArgumentParser(prog="python -m refrakt_farm.bench")
    p.add_argument("scene", type=Path)
    p.add_argument("--frames", default="0..23")
    p.add_argument("--chunk", type=int, default=4)
    p.add_argument("--workers", default="1,2")
    p.add_argument("--refrakt", default="refrakt")
    p.add_argument("--format", default="png")
    args = p.parse_args(argv)
    first, last = parse_range(args.frames)
    reference: dict[str, bytes] | None = None
    for n in [int(w) for w in args.workers.split(",")]:
        with tempfile.TemporaryDirectory(prefix="refrakt-farm-bench-") as out:
            job = FarmJob(scene=args.scene, first=first, last=last, out=Path(out), chunk=args.chunk, refrakt=args.refrakt,
                          render_args=extra, resource="refrakt", progress="quiet", formats=args.format.split(","))
            seconds = run(n, job)
            frames = {f.name: f.read_bytes() for f in sorted(Path(out).iterdir())}
        same = reference is None or frames == reference
        reference = reference or frames
        frame_count = last - first + 1
        print(json.dumps({"workers": n, "frames": frame_count, "seconds": round(seconds, 2),
                          "frames_per_s": round(frame_count / seconds, 3), "identical_to_first": same}), flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
