"""``refrakt-farm render SCENE --frames A..B --chunk N --address ray://head:10001 --out DIR``."""

from __future__ import annotations

import argparse
import signal
import sys
from pathlib import Path

from refrakt_farm.driver import FarmJob, render
from refrakt_farm.frames import parse_range, split_options


def parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="refrakt-farm", description="Render a refrakt animation on a Ray cluster.")
    sub = p.add_subparsers(dest="command", required=True)
    r = sub.add_parser("render", help="render a frame range in chunks on the cluster's workers",
                       epilog="Options after -- go to every `refrakt render` (e.g. -- --size 1920x1080 --photons 2e6).")
    r.add_argument("scene", type=Path, help="a .lua/.gltf/.glb scene (packed here with refrakt pack) or a .tar.zst bundle")
    r.add_argument("--frames", required=True, help="frames A..B (inclusive)")
    r.add_argument("--chunk", type=int, default=24, help="frames per task (default 24)")
    r.add_argument("--address", default=None, help="Ray address: ray://HEAD:10001, auto, or none for a local Ray")
    r.add_argument("--out", "-o", type=Path, required=True, help="folder for the frames (on this machine)")
    r.add_argument("--name", help="base name of the frame files (default: the scene's file name)")
    r.add_argument("--format", default="exr,png", help="output formats, comma separated (default exr,png)")
    r.add_argument("--refrakt", default="refrakt", help="refrakt on this machine, to pack the scene (default: from PATH)")
    r.add_argument("--worker-refrakt", help="refrakt on the workers (default: the same as --refrakt, from each worker's PATH)")
    r.add_argument("--allow-read", type=Path, action="append", default=[], help="let the scene read below this folder too (packed with it)")
    r.add_argument("--resource", default="GPU",
                   help='Ray resource a chunk takes one of: GPU (default), or a custom one for workers without GPUs '
                        '(ray start --resources=\'{"refrakt": 1}\' and --resource refrakt)')
    r.add_argument("--retries", type=int, default=3, help="times a failed or lost chunk is run again (default 3)")
    r.add_argument("--progress", choices=["bar", "json", "quiet"], default="bar",
                   help="a bar with frames/s and the time left (default), refrakt's JSON events on stdout, or nothing")
    return p


def main(argv: list[str] | None = None) -> int:
    argv, extra = split_options(sys.argv[1:] if argv is None else argv)
    args = parser().parse_args(argv)
    try:
        first, last = parse_range(args.frames)
    except ValueError as e:
        print(f"refrakt-farm: --frames: {e}", file=sys.stderr)
        return 2
    if args.chunk < 1 or args.retries < 0:
        print("refrakt-farm: --chunk must be at least 1 and --retries at least 0", file=sys.stderr)
        return 2
    if not args.scene.is_file():
        print(f"refrakt-farm: {args.scene}: no such scene file", file=sys.stderr)
        return 2
    job = FarmJob(
        scene=args.scene, first=first, last=last, out=args.out, chunk=args.chunk, address=args.address, name=args.name,
        formats=[f.strip() for f in args.format.split(",") if f.strip()], refrakt=args.refrakt,
        worker_refrakt=args.worker_refrakt, render_args=extra, allow_read=args.allow_read, resource=args.resource,
        retries=args.retries, progress=args.progress,
    )
    # SIGTERM (the Blender add-on's Cancel) stops like Ctrl-C: chunks still out are cancelled.
    signal.signal(signal.SIGTERM, signal.default_int_handler)
    try:
        summary = render(job)
    except KeyboardInterrupt:
        return 130
    for line in summary.lines():
        print(line, file=sys.stderr)
    return 1 if summary.failed else 0


if __name__ == "__main__":
    sys.exit(main())
