#!/usr/bin/env python3
"""Runs refrakt on each bad input of issue #16 and prints a Markdown table: input, exit code,
the message as the user sees it (stderr). Needs a GPU adapter (lavapipe will do) for the one
small render that makes the seed EXR.

    python3 scripts/bad_inputs.py target/debug/refrakt"""
import os, struct, subprocess, sys, tempfile

BIN = os.path.abspath(sys.argv[1])
work = tempfile.mkdtemp(prefix="refrakt-table-")
os.chdir(work)

HEAD = 'local r = require("refrakt")\nlocal scene = r.scene{ camera = r.camera{ size = {16, 12} }, volume = { resolution = 16 } }\n'
def script(name, body):
    open(name, "w").write(HEAD + body + "\nreturn scene\n")
    return name

script("ok.lua", 'scene:add(r.node{ shape = r.luneburg{ radius = 0.5 } })')
# A small EXR from refrakt itself, then its dataWindow rewritten.
subprocess.run([BIN, "render", "ok.lua", "--out", "seed", "--format", "exr", "--progress", "quiet"], check=True)
exr = open("seed/ok.exr", "rb").read()
def exr_claiming(w, h):
    key = b"dataWindow\0box2i\0"
    at = exr.index(key) + len(key) + 4
    return exr[:at] + struct.pack("<4i", 0, 0, w - 1, h - 1) + exr[at + 16:]
open("huge.exr", "wb").write(exr_claiming(200000, 200000))
open("short16k.exr", "wb").write(exr_claiming(16384, 8192))
open("huge.hdr", "wb").write(b"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y 200000 +X 200000\n\x01\x02\x03\x04")
script("env_huge.lua", 'scene.environment = r.environment{ image = "huge.exr" }')
script("env_short.lua", 'scene.environment = r.environment{ image = "short16k.exr" }')
script("env_hdr.lua", 'scene.environment = r.environment{ image = "huge.hdr" }')
script("bomb.lua", 'local s = string.rep("x", 1 << 40)')
script("bomb2.lua", 'local big = table.concat({string.rep("x", 600 << 20), string.rep("y", 600 << 20)})')
script("box.lua", 'scene.volume = { resolution = 16, min = {1, -1, -1}, max = {-1, 1, 1} }')
open("taken", "w").write("a file")

cases = [
    ("environment EXR (16×12 pixels) whose dataWindow claims 200000²", ["render", "env_huge.lua", "--progress", "quiet"]),
    ("environment EXR (16×12 pixels, ~1 kB) whose dataWindow claims 16384×8192", ["render", "env_short.lua", "--progress", "quiet"]),
    ("environment HDR claiming 200000²", ["render", "env_hdr.lua", "--progress", "quiet"]),
    ("`--out` an existing file", ["render", "ok.lua", "--out", "taken"]),
    ("`--name ../escape`", ["render", "ok.lua", "--name", "../escape"]),
    ('`--name ""`', ["render", "ok.lua", "--name", ""]),
    ("`--name .hidden`", ["render", "ok.lua", "--name", ".hidden"]),
    ("`--photons -1`", ["render", "ok.lua", "--photons", "-1"]),
    ("`--size -5x10`", ["render", "ok.lua", "--size", "-5x10"]),
    ("`--samples 1e9`", ["render", "ok.lua", "--samples", "1e9"]),
    ("`--volume big`", ["render", "ok.lua", "--volume", "big"]),
    ("`--photons 0`", ["render", "ok.lua", "--photons", "0", "--out", "out0", "--progress", "quiet"]),
    ('`string.rep("x", 1 << 40)` in a script', ["render", "bomb.lua"]),
    ("two 600 MiB strings (past --script-memory 1024)", ["render", "bomb2.lua"]),
    ("`volume = {min = {1,-1,-1}, max = {-1,1,1}}`", ["render", "box.lua"]),
    ("`watch --out taken/p.exr` (a file as folder)", ["watch", "ok.lua", "--out", "taken/p.exr"]),
]
print("| bad input | exit | message as the user sees it |")
print("| --- | --- | --- |")
for label, args in cases:
    p = subprocess.run([BIN] + args, capture_output=True, text=True, timeout=300)
    msg = " ".join(p.stderr.strip().split("\n")).replace("|", "\\|").replace(work + "/", "")
    print(f"| {label} | {p.returncode} | {msg} |")
