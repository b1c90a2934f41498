#!/usr/bin/env python3
"""A stand-in for the `refrakt` executable that keeps refrakt's command-line contract (`info`,
`render … --progress json`, `watch … --progress json`) without a GPU, so the add-on's side can be
tested exactly: timing, events, cancellation, errors.

Each frame k is a small EXR with refrakt's channels (R G B A, depth.Z, caustic.*, direct.*,
volume.*) whose R channel holds k, written through a temporary name and a rename. The
environment variables below steer it:

  FAKE_REFRAKT_DELAY   seconds per frame (default 0.05)
  FAKE_REFRAKT_ALPHA   the frames' alpha (default 1)
  FAKE_REFRAKT_FAIL_AT frame at which to fail with refrakt's kind of error
  FAKE_REFRAKT_LOG     file to which each invocation's argv is appended as a JSON line
  FAKE_REFRAKT_WATCH_LOG  file to which `watch` appends, for each reload, the files that
                       changed and the Lua scene's text (the recording stand-in of the viewport)
"""

import json
import os
import re
import signal
import sys
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import exr_writer  # noqa: E402

stop = False


def on_term(_signum, _frame):
    global stop
    stop = True


def emit(**event):
    print(json.dumps(event), flush=True)


def option(args, name, default=None):
    return args[args.index(name) + 1] if name in args else default


def frame_planes(k, w, h, layers="all"):
    """A frame's channels, only those of `layers` (`--layers`: `all` or names)."""
    n = w * h
    keep = None if layers == "all" else set(layers.split(","))
    planes = {"R": [float(k)] * n, "G": [0.5] * n, "B": [0.25] * n, "A": [float(os.environ.get("FAKE_REFRAKT_ALPHA", "1"))] * n}
    if keep is None or "depth" in keep:
        planes["depth.Z"] = [2.0] * n
    for layer, value in (("caustic", 0.1), ("direct", 0.2), ("indirect", 0.15), ("volume", 0.3)):
        for c in "RGB":
            if keep is None or layer in keep:
                planes[f"{layer}.{c}"] = [value] * n
    return planes


def fail(message, frame=None):
    emit(event="error", message=message, frame=frame)
    print(f"error: {message}", file=sys.stderr)
    sys.exit(1)


def check_scene(scene):
    if not os.path.isfile(scene):
        fail(f"{scene}: no such file")
    with open(scene, "rb") as f:
        head = f.read(4)
    if scene.endswith(".glb") and head != b"glTF":
        fail(f"{scene}: not a binary glTF file")


def render(args):
    scene = args[0]
    check_scene(scene)
    first, last = (int(x) for x in option(args, "--frames", "0..0").split(".."))
    out = option(args, "--out", "render")
    name = option(args, "--name", os.path.splitext(os.path.basename(scene))[0])
    w, h = (int(x) for x in option(args, "--size", "8x4").split("x"))
    if "--region" in args:  # as refrakt: the images are the region's size
        w, h = (int(x) for x in option(args, "--region").split(",")[2:])
    delay = float(os.environ.get("FAKE_REFRAKT_DELAY", "0.05"))
    fail_at = os.environ.get("FAKE_REFRAKT_FAIL_AT")
    os.makedirs(out, exist_ok=True)
    total = last - first + 1
    emit(event="start", frames=total, first=first, last=last)
    started = time.monotonic()
    for i, k in enumerate(range(first, last + 1)):
        if stop:
            # As refrakt: the frame in hand was finished; say so and exit like Ctrl-C.
            emit(event="error", message=f"interrupted after {i} frame(s); the frames written are whole", frame=None)
            print(f"error: interrupted after {i} frame(s); the frames written are whole", file=sys.stderr)
            sys.exit(130)
        if fail_at is not None and k == int(fail_at):
            fail(f"frame {k} (t = {k / 24:.4f} s): {scene}: node \"Cube\": scale has a zero component", k)
        path = os.path.join(out, f"{name}.{k:04d}.exr")
        if "--skip-existing" in args and os.path.exists(path):
            emit(event="skip", frame=k, done=i + 1, total=total)
            continue
        t0 = time.monotonic()
        time.sleep(delay)  # "rendering": a SIGTERM now ends the loop after this frame
        exr_writer.write(path, w, h, frame_planes(k, w, h, option(args, "--layers", "all")))
        emit(event="frame", frame=k, done=i + 1, total=total, seconds=time.monotonic() - t0, files=[path])
    emit(event="done", frames=total, seconds=time.monotonic() - started)


def watched_files(scene):
    """The scene and, for a Lua scene, the glTF files it imports (as refrakt watches them)."""
    files = [scene]
    if scene.endswith(".lua"):
        with open(scene, encoding="utf-8") as f:
            names = re.findall(r'r\.gltf\("([^"]+)"\)', f.read())
        files += [os.path.join(os.path.dirname(scene), n) for n in names]
    return files


def stamp(path):
    try:
        st = os.stat(path)
    except OSError:
        return None
    return st.st_ino, st.st_mtime_ns, st.st_size  # a rename into place is a new inode


def watch(args):
    scene = args[0]
    check_scene(scene)
    out = option(args, "--out")
    k = int(option(args, "--frame", "0"))
    w, h = (int(x) for x in option(args, "--size", "8x4").split("x"))
    seen = {}
    while not stop:
        files = watched_files(scene)
        now = {f: stamp(f) for f in files}
        changed = [f for f in files if now[f] != seen.get(f)]
        if changed:
            first, seen = not seen, now
            record = {"changed": [os.path.basename(f) for f in changed]}
            if scene.endswith(".lua"):
                with open(scene, encoding="utf-8") as f:
                    record["script"] = f.read()
            if os.environ.get("FAKE_REFRAKT_WATCH_LOG"):
                with open(os.environ["FAKE_REFRAKT_WATCH_LOG"], "a") as f:
                    f.write(json.dumps(record) + "\n")
            exr_writer.write(out, w, h, frame_planes(k, w, h))
            # As refrakt: only a changed view (the script, not the glTF) reuses volume and photons.
            view_only = not first and changed == [scene]
            reused = {"volume": view_only, "photons": view_only}
            emit(event="frame", frame=k, done=1, total=1, seconds=0.01, files=[out], quality="final",
                 stats={"reused": reused})
        time.sleep(0.02)


def main():
    signal.signal(signal.SIGTERM, on_term)
    signal.signal(signal.SIGINT, on_term)
    args = sys.argv[1:]
    log = os.environ.get("FAKE_REFRAKT_LOG")
    if log:
        with open(log, "a") as f:
            f.write(json.dumps(args) + "\n")
    if not args:
        fail("no command")
    command, rest = args[0], args[1:]
    if command == "info":
        print("adapter:  fake refrakt for the add-on's tests (no GPU)")
    elif command == "render":
        render(rest)
    elif command == "watch":
        watch(rest)
    else:
        fail(f"unknown command {command}")
    sys.exit(130 if stop else 0)


if __name__ == "__main__":
    main()
