#!/usr/bin/env python3
"""A stand-in for `refrakt-farm` that keeps its command-line contract (`render SCENE --frames
A..B --chunk N [--address A] --out DIR --name NAME --format exr --progress json --refrakt BIN
-- REFRAKT OPTIONS`) without Ray: it renders the chunks one after another with the refrakt
given by --refrakt (here fake_refrakt.py) and reports refrakt's JSON events over the whole
range, as the real driver does. FAKE_FARM_LOG: a file to which each invocation's argv is
appended as a JSON line.
"""

import json
import os
import subprocess
import sys


def option(args, name, default=None):
    return args[args.index(name) + 1] if name in args else default


def main():
    argv = sys.argv[1:]
    if os.environ.get("FAKE_FARM_LOG"):
        with open(os.environ["FAKE_FARM_LOG"], "a") as f:
            f.write(json.dumps(argv) + "\n")
    own, extra = (argv[: argv.index("--")], argv[argv.index("--") + 1:]) if "--" in argv else (argv, [])
    if own[:1] != ["render"] or "--frames" not in own or "--out" not in own:
        print("refrakt-farm: usage: refrakt-farm render SCENE --frames A..B --out DIR …", file=sys.stderr)
        return 2
    scene = own[1]
    first, last = (int(x) for x in option(own, "--frames").split(".."))
    chunk = int(option(own, "--chunk", "24"))
    total, done = last - first + 1, 0
    print(json.dumps({"event": "start", "frames": total, "first": first, "last": last}), flush=True)
    # As the real farm: --allow-read is for packing only.
    worker = [a for i, a in enumerate(extra) if a != "--allow-read" and (i == 0 or extra[i - 1] != "--allow-read")]
    for a in range(first, last + 1, chunk):
        b = min(a + chunk - 1, last)
        command = [option(own, "--refrakt"), "render", scene, "--frames", f"{a}..{b}", "--out", option(own, "--out"),
                   "--name", option(own, "--name"), "--format", option(own, "--format", "exr"), "--progress", "json", *worker]
        run = subprocess.run(command, capture_output=True, text=True)
        for line in run.stdout.splitlines():
            event = json.loads(line)
            if event.get("event") == "frame":
                done += 1
                event.update(done=done, total=total)
                print(json.dumps(event), flush=True)
        if run.returncode != 0:
            message = f"chunk {a}..{b}: {run.stderr.strip()}"
            print(json.dumps({"event": "error", "message": message, "frame": None}), flush=True)
            print(f"refrakt-farm: {message}", file=sys.stderr)
            return 1
    print(json.dumps({"event": "done", "frames": done, "skipped": 0, "retries": 0}), flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
