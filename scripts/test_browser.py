#!/usr/bin/env python3
"""refrakt serve in a real browser: headless Chromium driven over WebDriver.

Starts `refrakt serve` on a tiny scene, loads the page in Chromium (through chromedriver, with
the W3C WebDriver protocol spoken over plain HTTP: the standard library is enough, no
Selenium to install), waits for frames, drags the mouse across the image, checks that the
camera orbited (the page sent a move, the next frame shows it and differs), and checks a
screenshot of the page for a frame that is not blank. With --screenshot PATH the screenshot is
kept (docs/live.md's picture is made this way).

With --measure SECONDS it then drags the camera round for that long and prints the frames per
second the page drew, with the medians of the frame headers' times (the browser half of
`refrakt bench --scenes serve`).

Usage: test_browser.py REFRAKT_BINARY [--scene FILE] [--screenshot PATH] [--size WxH] [--volume N] [--measure SECONDS]
"""

import argparse
import base64
import json
import os
import shutil
import socket
import struct
import subprocess
import sys
import tempfile
import time
import urllib.request
import zlib

SCENE = """local r = require("refrakt")
local scene = r.scene{
  camera = r.camera{ position = {0, 0.5, 3}, target = {0, 0, 0}, fov = 35, size = {160, 128} },
  environment = r.environment{ color = {0.15, 0.17, 0.22} },
  volume = { resolution = 32 },
  photons = 4000,
  samples = 1,
}
scene:add(r.node{ name = "ball", shape = r.sphere{ radius = 0.4 }, material = r.glass{ ior = 1.5 } })
scene:add(r.node{ name = "floor", translation = {0, -0.5, 0}, shape = r.plane{ size = {4, 4} },
                  material = r.diffuse{ color = {0.8, 0.8, 0.8} } })
scene:add(r.node{ name = "key", translation = {0.5, 2, 0.5}, light = r.spot{ target = {0, -0.5, 0}, intensity = 3000, angle = 30 } })
return scene
"""

PATIENCE = 120  # seconds for anything that must happen (lavapipe on a loaded 2-core machine)


def fail(message):
    print(f"test_browser: FAIL: {message}", file=sys.stderr)
    sys.exit(1)


class WebDriver:
    """The few W3C WebDriver commands the test needs."""

    def __init__(self, port):
        self.base = f"http://127.0.0.1:{port}"
        caps = {"capabilities": {"alwaysMatch": {"browserName": "chrome", "goog:chromeOptions": {
            "args": ["--headless=new", "--no-sandbox", "--disable-gpu", "--disable-dev-shm-usage", "--window-size=1280,800"]}}}}
        self.session = self.call("POST", "/session", caps)["sessionId"]

    def call(self, method, path, body=None):
        data = None if body is None else json.dumps(body).encode()
        req = urllib.request.Request(self.base + path, data=data, method=method, headers={"Content-Type": "application/json"})
        try:
            with urllib.request.urlopen(req, timeout=PATIENCE) as r:
                return json.load(r)["value"]
        except urllib.error.HTTPError as e:
            fail(f"WebDriver {method} {path}: {e.read().decode(errors='replace')[:500]}")

    def s(self, method, path, body=None):
        return self.call(method, f"/session/{self.session}{path}", body)

    def js(self, script, *args):
        return self.s("POST", "/execute/sync", {"script": script, "args": list(args)})

    def wait(self, what, script, timeout=PATIENCE):
        until = time.time() + timeout
        while time.time() < until:
            value = self.js(script)
            if value:
                return value
            time.sleep(0.2)
        stats = self.js("return document.getElementById('stats').textContent")
        fail(f"{what}: not within {timeout} s; page stats: {stats!r}")

    def drag(self, element, dx, dy, steps=10, step_ms=30):
        origin = {"element-6066-11e4-a52e-4f735466cecf": element}
        actions = [{"type": "pointerMove", "duration": 0, "origin": origin, "x": 0, "y": 0}, {"type": "pointerDown", "button": 0}]
        for i in range(1, steps + 1):
            actions.append({"type": "pointerMove", "duration": step_ms, "origin": origin, "x": dx * i // steps, "y": dy * i // steps})
        actions.append({"type": "pointerUp", "button": 0})
        self.s("POST", "/actions", {"actions": [{"type": "pointer", "id": "mouse", "parameters": {"pointerType": "mouse"}, "actions": actions}]})

    def quit(self):
        try:
            self.s("DELETE", "")
        except SystemExit:
            pass


def png_pixels(data):
    """Decodes an 8-bit RGB or RGBA PNG (what Chromium's screenshots are): width, height, rows."""
    assert data[:8] == b"\x89PNG\r\n\x1a\n", "not a PNG"
    pos, idat, width = 8, b"", None
    while pos < len(data):
        length, kind = struct.unpack(">I4s", data[pos:pos + 8])
        chunk = data[pos + 8:pos + 8 + length]
        if kind == b"IHDR":
            width, height, depth, color = struct.unpack(">IIBB", chunk[:10])
            assert depth == 8 and color in (2, 6), f"PNG depth {depth}, colour type {color}"
            bpp = 3 if color == 2 else 4
        elif kind == b"IDAT":
            idat += chunk
        pos += 12 + length
    raw, stride, rows, prev = zlib.decompress(idat), width * bpp, [], bytearray(width * bpp)
    for y in range(height):
        f, line = raw[y * (stride + 1)], bytearray(raw[y * (stride + 1) + 1:(y + 1) * (stride + 1)])
        for i in range(stride):
            a = line[i - bpp] if i >= bpp else 0
            b, c = prev[i], prev[i - bpp] if i >= bpp else 0
            if f == 1:
                line[i] = (line[i] + a) & 255
            elif f == 2:
                line[i] = (line[i] + b) & 255
            elif f == 3:
                line[i] = (line[i] + (a + b) // 2) & 255
            elif f == 4:
                p = a + b - c
                pa, pb, pc = abs(p - a), abs(p - b), abs(p - c)
                line[i] = (line[i] + (a if pa <= pb and pa <= pc else b if pb <= pc else c)) & 255
        rows.append([tuple(line[x * bpp:x * bpp + 3]) for x in range(width)])
        prev = line
    return width, height, rows


def measure(wd, canvas, seconds):
    """Drags back and forth for `seconds`; prints what the page drew and the headers' times."""
    wd.js("window.refrakt.log = []; const f = window.refrakt; const old = f.last; "
          "setInterval(() => { if (f.last && f.last !== old && f.log[f.log.length - 1] !== f.last) f.log.push(f.last); }, 1)")
    frames, start = wd.js("return window.refrakt.frames"), time.time()
    sign = 1
    while time.time() - start < seconds:
        wd.drag(canvas, 200 * sign, 0, steps=60, step_ms=16)
        sign = -sign
    elapsed = time.time() - start
    drawn = wd.js("return window.refrakt.frames") - frames
    log = wd.js("return window.refrakt.log.map(h => h.times)")
    med = lambda k: sorted(t[k] for t in log)[len(log) // 2] if log else None
    print(json.dumps({"browser_orbit": {"frames_per_second": drawn / elapsed, "frames": drawn, "seconds": elapsed,
                                        "render_ms": med("render_ms"), "readback_ms": med("readback_ms"), "encode_ms": med("encode_ms")}}))


def free_port():
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("refrakt")
    ap.add_argument("--scene")
    ap.add_argument("--screenshot")
    ap.add_argument("--size")
    ap.add_argument("--volume")
    ap.add_argument("--measure", type=float)
    args = ap.parse_args()
    chromedriver = shutil.which("chromedriver") or "/usr/bin/chromedriver"
    with tempfile.TemporaryDirectory() as tmp:
        scene = args.scene
        if not scene:
            scene = os.path.join(tmp, "scene.lua")
            with open(scene, "w") as f:
                f.write(SCENE)
        extra = (["--size", args.size] if args.size else []) + (["--volume", args.volume] if args.volume else [])
        server = subprocess.Popen([args.refrakt, "serve", scene, "--port", "0", *extra], stdout=subprocess.PIPE, text=True)
        driver_port = free_port()
        driver = subprocess.Popen([chromedriver, f"--port={driver_port}"], stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        wd = None
        try:
            url = json.loads(server.stdout.readline())["url"]
            for _ in range(100):
                try:
                    socket.create_connection(("127.0.0.1", driver_port), timeout=1).close()
                    break
                except OSError:
                    time.sleep(0.1)
            wd = WebDriver(driver_port)
            wd.s("POST", "/url", {"url": url})
            wd.wait("the first frame", "return window.refrakt && window.refrakt.frames >= 1")
            before = wd.js("return document.getElementById('frame').toDataURL('image/png')")
            frames = wd.js("return window.refrakt.frames")
            canvas = wd.s("POST", "/element", {"using": "css selector", "value": "#frame"})
            canvas = canvas["element-6066-11e4-a52e-4f735466cecf"]
            wd.drag(canvas, 120, 30)
            sent = wd.wait("the drag's camera move", "return window.refrakt.nextId > 1 && window.refrakt.nextId - 1")
            wd.wait("a frame of the orbited camera", f"return window.refrakt.last && window.refrakt.last.input >= {sent} && window.refrakt.frames > {frames}")
            time.sleep(0.3)  # the frame is drawn when it is decoded
            after = wd.js("return document.getElementById('frame').toDataURL('image/png')")
            if after == before:
                fail("the frame after the drag is the same as before it")
            shot = base64.b64decode(wd.s("GET", "/screenshot"))
            if args.screenshot:
                with open(args.screenshot, "wb") as f:
                    f.write(shot)
            box = wd.js("const r = document.getElementById('frame').getBoundingClientRect(); "
                        "return [r.left * devicePixelRatio, r.top * devicePixelRatio, r.width * devicePixelRatio, r.height * devicePixelRatio]")
            width, height, rows = png_pixels(shot)
            x0, y0, w, h = (int(v) for v in box)
            inside = [rows[y][x] for y in range(y0 + 2, min(height, y0 + h) - 2, 4) for x in range(x0 + 2, min(width, x0 + w) - 2, 4)]
            levels = [sum(p) / 3 for p in inside]
            mean = sum(levels) / len(levels)
            spread = (sum((v - mean) ** 2 for v in levels) / len(levels)) ** 0.5
            if mean < 8 or spread < 4:
                fail(f"the screenshot's frame looks blank (mean {mean:.1f}, spread {spread:.1f} over {len(levels)} samples)")
            if args.measure:
                measure(wd, canvas, args.measure)
            print(f"test_browser: ok: {wd.js('return window.refrakt.frames')} frames; the drag orbited "
                  f"(input {sent}); screenshot's frame mean {mean:.1f}, spread {spread:.1f}")
        finally:
            if wd:
                wd.quit()
            driver.terminate()
            server.terminate()
            server.wait(timeout=30)
            driver.wait(timeout=30)


if __name__ == "__main__":
    main()
