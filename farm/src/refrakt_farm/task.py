"""What runs on a worker: one chunk of frames as one ``refrakt render`` of the bundle."""

from __future__ import annotations

import os
import shutil
import socket
import subprocess
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path

from refrakt_farm.frames import Chunk, rendered_frames


@dataclass(frozen=True)
class ChunkSpec:
    """How to render every chunk of one job (the same for all of them)."""

    name: str
    formats: list[str]
    #: The refrakt binary on the workers: a path, or a name looked up on the worker's PATH.
    refrakt: str
    #: Further ``refrakt render`` options (``--size``, ``--photons``, ``--fps`` …).
    render_args: list[str]


@dataclass(frozen=True)
class ChunkResult:
    chunk: Chunk
    #: frame -> file extension -> the file's bytes.
    frames: dict[int, dict[str, bytes]]
    node_id: str
    host: str
    seconds: float


class ChunkFailed(RuntimeError):
    """``refrakt render`` failed on a worker (its message included)."""


def gpu_adapter() -> str | None:
    """The adapter index for refrakt's ``--adapter``: the GPU Ray gave this task, if any.

    Ray hands out node-local GPU indices and sets CUDA_VISIBLE_DEVICES, which Vulkan ignores;
    refrakt counts its usable adapters best first, which on a node of identical GPUs is the
    driver's order (see docs/farm.md for checking that it matches)."""
    import ray

    ids = ray.get_gpu_ids()
    return str(int(ids[0])) if ids else None


def render_chunk(bundle: bytes, chunk: Chunk, spec: ChunkSpec) -> ChunkResult:
    """Renders ``chunk`` of the scene in ``bundle`` in a temporary folder and returns its frames."""
    import ray

    started = time.monotonic()
    binary = shutil.which(spec.refrakt) or spec.refrakt
    with tempfile.TemporaryDirectory(prefix="refrakt-farm-") as tmp:
        work = Path(tmp)
        (work / "shot.tar.zst").write_bytes(bundle)
        command = [
            binary, "render", str(work / "shot.tar.zst"), "--frames", str(chunk), "--out", str(work / "out"),
            "--name", spec.name, "--format", ",".join(spec.formats), "--progress", "quiet", *spec.render_args,
        ]
        adapter = gpu_adapter()
        if adapter is not None:
            command += ["--adapter", adapter]
        try:
            done = subprocess.run(command, capture_output=True, text=True, env=os.environ.copy())
        except OSError as e:
            raise ChunkFailed(f"cannot run refrakt ({binary}) on {socket.gethostname()}: {e}") from None
        if done.returncode != 0:
            raise ChunkFailed(f"refrakt render --frames {chunk} failed on {socket.gethostname()} (exit {done.returncode}): {done.stderr.strip()[-2000:]}")
        frames = rendered_frames(work / "out", spec.name)
    missing = [k for k in chunk.frames if set(frames.get(k, {})) != set(spec.formats)]
    if missing:
        raise ChunkFailed(f"refrakt render --frames {chunk} on {socket.gethostname()} left frames {missing} unwritten")
    return ChunkResult(chunk, frames, ray.get_runtime_context().get_node_id(), socket.gethostname(), time.monotonic() - started)
