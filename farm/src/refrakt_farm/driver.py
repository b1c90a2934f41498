"""The driver: pack, skip what is done, submit chunks, retry failures, write frames, report."""

from __future__ import annotations

import json
import logging
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from refrakt_farm.frames import Chunk, chunks, frame_digits, frame_file, missing_frames, write_atomically
from refrakt_farm.task import ChunkResult, ChunkSpec, render_chunk


@dataclass
class FarmJob:
    """One ``refrakt-farm render``."""

    scene: Path
    first: int
    last: int
    out: Path
    chunk: int = 24
    #: Ray's address: ``ray://head:10001``, ``auto`` (a cluster this machine belongs to), or
    #: None for an already connected Ray or a new local one.
    address: str | None = None
    name: str | None = None
    formats: list[str] = field(default_factory=lambda: ["exr", "png"])
    #: refrakt on this machine (to pack the scene) and on the workers.
    refrakt: str = "refrakt"
    worker_refrakt: str | None = None
    render_args: list[str] = field(default_factory=list)
    allow_read: list[Path] = field(default_factory=list)
    #: Ray resource each chunk takes one of: "GPU" (one GPU per task), or a custom resource
    #: the worker nodes were started with (e.g. ``ray start --resources='{"refrakt": 1}'``)
    #: for workers without GPUs.
    resource: str = "GPU"
    #: Times a failed or lost chunk is run again before the job gives up on it.
    retries: int = 3
    #: "bar" (one bar with frames/s and the time left), "json" (refrakt's progress events on
    #: stdout, for the Blender add-on) or "quiet".
    progress: str = "bar"


@dataclass
class NodeStats:
    host: str
    frames: int = 0
    chunks: int = 0
    seconds: float = 0.0


@dataclass
class Summary:
    frames: int = 0
    skipped: int = 0
    retries: int = 0
    seconds: float = 0.0
    nodes: dict[str, NodeStats] = field(default_factory=dict)
    #: Chunks that failed every attempt, with the last error.
    failed: dict[str, str] = field(default_factory=dict)
    #: Errors of the attempts that were retried.
    retried_errors: list[str] = field(default_factory=list)

    def lines(self) -> list[str]:
        rate = self.frames / self.seconds if self.seconds > 0 else 0.0
        out = [
            f"refrakt-farm: {self.frames} frame(s) rendered, {self.skipped} already there, "
            f"{self.retries} failed chunk attempt(s) retried, {len(self.failed)} chunk(s) failed; "
            f"{self.seconds:.1f} s, {rate:.2f} frames/s"
        ]
        for node_id, n in sorted(self.nodes.items(), key=lambda kv: kv[1].host + kv[0]):
            per = n.frames / n.seconds if n.seconds > 0 else 0.0
            out.append(f"  node {n.host} ({node_id[:12]}): {n.frames} frame(s) in {n.chunks} chunk(s), {per:.2f} frames/s while busy")
        for chunk, error in self.failed.items():
            out.append(f"  chunk {chunk} failed: {error}")
        return out


def default_name(scene: Path) -> str:
    """Frames are named after the scene file (``shot.lua`` -> ``shot.0001.exr``) as refrakt names
    them; a bundle ``shot.tar.zst`` names them ``shot``."""
    n = scene.name
    return n[: -len(".tar.zst")] if n.lower().endswith(".tar.zst") else scene.stem


#: `refrakt render` options that `refrakt pack` takes too (how the scene is evaluated, and so
#: which files it reads), each with its value.
SCENE_OPTIONS = {
    "--fps", "--size", "--volume", "--photons", "--samples", "--camera", "--scene", "--animation",
    "--allow-read", "--script-timeout", "--script-memory",
}


def split_render_args(args: list[str]) -> tuple[list[str], list[str]]:
    """``render_args`` as (what `refrakt pack` also needs, what the workers' `refrakt render`
    gets). `--allow-read` goes only to pack: the bundle holds those files, and the folder
    does not exist on the workers."""
    pack_args: list[str] = []
    worker_args: list[str] = []
    i = 0
    while i < len(args):
        option = args[i].split("=", 1)[0]
        takes_value = option in SCENE_OPTIONS and "=" not in args[i] and i + 1 < len(args)
        group = args[i : i + 2] if takes_value else args[i : i + 1]
        if option in SCENE_OPTIONS:
            pack_args += group
        if option != "--allow-read":
            worker_args += group
        i += len(group)
    return pack_args, worker_args


def pack(job: FarmJob, folder: Path) -> bytes:
    """The scene as a bundle: the file itself if it is one, else ``refrakt pack``'s output."""
    if job.scene.name.lower().endswith(".tar.zst"):
        return job.scene.read_bytes()
    bundle = folder / "scene.tar.zst"
    command = [job.refrakt, "pack", str(job.scene), "-o", str(bundle), "--frames", f"{job.first}..{job.last}"]
    for d in job.allow_read:
        command += ["--allow-read", str(d)]
    command += split_render_args(job.render_args)[0]
    try:
        done = subprocess.run(command, capture_output=True, text=True)
    except OSError as e:
        raise SystemExit(f"refrakt-farm: cannot run refrakt ({job.refrakt}) to pack the scene: {e}") from None
    if done.returncode != 0:
        raise SystemExit(f"refrakt-farm: refrakt pack failed:\n{done.stderr.strip()}")
    return bundle.read_bytes()


def render(job: FarmJob, on_chunk: Callable[[ChunkResult], None] | None = None) -> Summary:
    """Runs ``job`` on Ray; ``on_chunk`` sees each chunk once its frames are written."""
    import ray

    started = time.monotonic()
    job.out.mkdir(parents=True, exist_ok=True)
    name = job.name or default_name(job.scene)
    summary = Summary()
    todo = missing_frames(job.out, name, job.first, job.last, job.formats)
    summary.skipped = job.last - job.first + 1 - len(todo)
    if not todo:
        summary.seconds = time.monotonic() - started
        return summary
    with tempfile.TemporaryDirectory(prefix="refrakt-farm-") as tmp:
        bundle = pack(job, Path(tmp))
    if not ray.is_initialized():
        ray.init(address=job.address, logging_level=logging.WARNING, log_to_driver=False)
    spec = ChunkSpec(name, job.formats, job.worker_refrakt or job.refrakt, split_render_args(job.render_args)[1])
    options: dict[str, Any] = {"max_retries": 0, "num_cpus": 1}
    if job.resource == "GPU":
        options["num_gpus"] = 1
    else:
        options["resources"] = {job.resource: 1}
    if not ray.cluster_resources().get(job.resource, 0):  # type: ignore[no-untyped-call]
        # An autoscaling cluster may still add such nodes: say so, and wait for them.
        print(
            f"refrakt-farm: warning: the Ray cluster has no {job.resource} resource now, so chunks wait until a node "
            f"with one joins; on workers without GPUs start them with ray start --resources='{{\"refrakt\": 1}}' and "
            "pass --resource refrakt",
            file=sys.stderr,
        )
    task = ray.remote(render_chunk).options(**options)
    bundle_ref = ray.put(bundle)
    digits = frame_digits(job.last)
    attempts: dict[Chunk, int] = {}
    pending: dict[Any, Chunk] = {}

    def submit(c: Chunk) -> None:
        attempts[c] = attempts.get(c, 0) + 1
        pending[task.remote(bundle_ref, c, spec)] = c

    for c in chunks(todo, job.chunk):
        submit(c)
    bar = progress_bar(job.progress, job.first, job.last, len(todo), name, job.out, digits)
    try:
        while pending:
            ready, _ = ray.wait(list(pending), num_returns=1)
            c = pending.pop(ready[0])
            try:
                result: ChunkResult = ray.get(ready[0])
            except (ray.exceptions.RayError, OSError) as e:
                message = f"{type(e).__name__}: {str(e).strip().splitlines()[-1] if str(e).strip() else ''}"
                if attempts[c] <= job.retries:
                    summary.retries += 1
                    summary.retried_errors.append(f"chunk {c}: {message}")
                    bar.write(f"refrakt-farm: chunk {c} failed ({message}); running it again")
                    submit(c)
                else:
                    summary.failed[str(c)] = message
                continue
            for k, files in sorted(result.frames.items()):
                for ext, data in files.items():
                    write_atomically(job.out / frame_file(name, k, ext, digits), data)
            stats = summary.nodes.setdefault(result.node_id, NodeStats(result.host))
            stats.frames += len(result.frames)
            stats.chunks += 1
            stats.seconds += result.seconds
            summary.frames += len(result.frames)
            bar.chunk_done(result)
            if on_chunk is not None:
                on_chunk(result)
    except KeyboardInterrupt:
        # Ctrl-C or SIGTERM (the Blender add-on's Cancel): stop the chunks still out; the
        # frames written are whole.
        for ref in pending:
            ray.cancel(ref, force=True)
        bar.error(f"interrupted; {summary.frames} frame(s) written are whole (run again to render the rest)")
        raise
    finally:
        bar.close()
    summary.seconds = time.monotonic() - started
    bar.done(summary)
    return summary


class Progress:
    """Progress on stderr (a tqdm bar with frames/s and the time left) or as refrakt's JSON
    events on stdout (start, frame, done, error; see refrakt's src/progress.rs)."""

    def __init__(self, mode: str, first: int, last: int, total: int, name: str, out: Path, digits: int) -> None:
        self.mode, self.total, self.done_frames = mode, total, 0
        self.name, self.out, self.digits = name, out, digits
        self.last_time = time.monotonic()
        self.bar: Any = None
        if mode == "bar":
            from tqdm import tqdm

            self.bar = tqdm(total=total, unit="frame", desc="refrakt-farm", file=sys.stderr, smoothing=0.1, dynamic_ncols=True)
        elif mode == "json":
            self.emit(event="start", frames=total, first=first, last=last)

    @staticmethod
    def emit(**event: Any) -> None:
        print(json.dumps(event), flush=True)

    def chunk_done(self, result: ChunkResult) -> None:
        if self.bar is not None:
            self.bar.update(len(result.frames))
        if self.mode != "json":
            return
        for k, files in sorted(result.frames.items()):
            self.done_frames += 1
            now = time.monotonic()
            paths = [str(self.out / frame_file(self.name, k, ext, self.digits)) for ext in sorted(files)]
            self.emit(event="frame", frame=k, done=self.done_frames, total=self.total, seconds=now - self.last_time, files=paths)
            self.last_time = now

    def write(self, line: str) -> None:
        if self.bar is not None:
            self.bar.write(line, file=sys.stderr)
        elif self.mode != "quiet":
            print(line, file=sys.stderr)

    def error(self, message: str) -> None:
        if self.mode == "json":
            self.emit(event="error", message=message, frame=None)
        self.write(f"refrakt-farm: {message}")

    def done(self, summary: "Summary") -> None:
        if self.mode == "json":
            if summary.failed:
                self.emit(event="error", message="; ".join(f"chunk {c}: {e}" for c, e in summary.failed.items()), frame=None)
            self.emit(event="done", frames=summary.frames, skipped=summary.skipped, retries=summary.retries, seconds=summary.seconds)

    def close(self) -> None:
        if self.bar is not None:
            self.bar.close()


def progress_bar(mode: str, first: int, last: int, total: int, name: str, out: Path, digits: int) -> Progress:
    return Progress(mode, first, last, total, name, out, digits)
