#!/usr/bin/env python3
"""refrakt serve in a real browser: headless Chromium driven over WebDriver.

Starts `refrakt serve` on a tiny scene, loads the page in Chromium (through chromedriver, with
the W3C WebDriver protocol spoken over plain HTTP: the standard library is enough, no
Selenium to install), waits for frames, drags the mouse across the image, checks that the
camera orbited (the page sent a move, the next frame shows it and differs), that the busy
indicator showed while that frame rendered, and checks a screenshot of the page for a frame
that is not blank. Then it switches the layer to `caustic` and reloads the page: the reloaded
page must show the same camera and layer (the server keeps the state). Then a second window
opens the page and the first one orbits again: the second must follow. With --screenshot PATH
the first screenshot is kept (docs/live.md's picture is made this way), with --pair PATH the
two windows side by side after the second orbit.

With --measure SECONDS it then drags the camera round for that long and prints the frames per
second the page drew, with the medians of the frame headers' times (the browser half of
`refrakt bench --scenes serve`).

Usage: test_browser.py REFRAKT_BINARY [--scene FILE] [--screenshot PATH] [--pair PATH] [--size WxH] [--volume N]
                       [--refine SAMPLES] [--measure SECONDS]
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

    def __init__(self, port, size="1280,800"):
        self.base = f"http://127.0.0.1:{port}"
        caps = {"capabilities": {"alwaysMatch": {"browserName": "chrome", "goog:chromeOptions": {
            "args": ["--headless=new", "--no-sandbox", "--disable-gpu", "--disable-dev-shm-usage", f"--window-size={size}"]}}}}
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


def png_encode(width, height, rows):
    """An 8-bit RGB PNG of rows of (r, g, b) tuples."""
    raw = b"".join(b"\x00" + bytes(c for p in row for c in p) for row in rows)
    chunk = lambda kind, data: struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data) & 0xFFFFFFFF)
    header = struct.pack(">IIBBBBB", width, height, 8, 2, 0, 0, 0)
    return b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", header) + chunk(b"IDAT", zlib.compress(raw, 9)) + chunk(b"IEND", b"")


def side_by_side(shots, gap=8):
    """Screenshots (PNG bytes) next to each other on a dark ground, as one PNG."""
    decoded = [png_pixels(s) for s in shots]
    height = max(h for _, h, _ in decoded)
    width = sum(w for w, _, _ in decoded) + gap * (len(decoded) - 1)
    rows = []
    for y in range(height):
        row = []
        for i, (w, h, pixels) in enumerate(decoded):
            if i:
                row += [(40, 40, 44)] * gap
            row += pixels[y] if y < h else [(40, 40, 44)] * w
        rows.append(row)
    return png_encode(width, height, rows)


def element(wd, css):
    return wd.s("POST", "/element", {"using": "css selector", "value": css})["element-6066-11e4-a52e-4f735466cecf"]


def orbit_and_wait(wd, canvas, dx, dy):
    """Drags to orbit; waits for the frame of the move and returns the id of the page's last edit."""
    frames = wd.js("return window.refrakt.frames")
    wd.drag(canvas, dx, dy)
    sent = wd.wait("the drag's camera move", "return window.refrakt.nextId > 1 && window.refrakt.nextId - 1")
    wd.wait("a frame of the orbited camera", f"return window.refrakt.last && window.refrakt.last.input >= {sent} && window.refrakt.frames > {frames}")
    return sent


def same_camera(camera):
    """A JavaScript expression: whether the page's camera is `camera`."""
    return (f"((a, b) => !!b && ['position', 'target'].every(k => a[k].every((v, i) => Math.abs(v - b[k][i]) < 1e-5)) "
            f"&& Math.abs(a.fov - b.fov) < 1e-5)({json.dumps(camera)}, window.refrakt.camera)")


def reload_keeps_camera_and_layer(wd, canvas):
    """Switches to the caustic layer, reloads: the page comes back with the same camera and layer."""
    wd.js("const l = document.getElementById('layer'); l.value = 'caustic'; l.dispatchEvent(new Event('input'))")
    wd.wait("the server's state with the caustic layer", "const s = window.refrakt.server; return s && s.display.layer === 'caustic' && s.camera")
    wd.wait("a caustic frame", "return window.refrakt.last.layer === 'caustic'")
    camera = wd.js("return window.refrakt.server.camera")
    wd.s("POST", "/refresh", {})
    wd.wait("the first frame after the reload", "return window.refrakt && window.refrakt.frames >= 1 && window.refrakt.server")
    wd.wait("the reloaded page's state", "return window.refrakt.frames >= 1 && window.refrakt.camera")
    if not wd.js(f"return {same_camera(camera)}"):
        fail(f"the reloaded page's camera {wd.js('return window.refrakt.camera')} is not the session's {camera}")
    shown = wd.js("return [document.getElementById('layer').value, window.refrakt.last.layer]")
    if shown != ["caustic", "caustic"]:
        fail(f"the reloaded page shows the layer {shown}, not the session's caustic")
    return camera


def second_window_follows(wd, driver_port, url, canvas, pair):
    """A second window opens the page; the first orbits; the second's camera and frame follow."""
    other = WebDriver(driver_port, size="900,640")
    try:
        other.s("POST", "/url", {"url": url})
        other.wait("the second window's first frame", "return window.refrakt && window.refrakt.frames >= 1")
        wd.js("const l = document.getElementById('layer'); l.value = 'beauty'; l.dispatchEvent(new Event('input'))")
        other.wait("the second window's layer following the first's", "return document.getElementById('layer').value === 'beauty'")
        sent = orbit_and_wait(wd, canvas, -90, 20)
        camera = wd.js("return window.refrakt.camera")
        other.wait("the second window following the first's orbit",
                   f"return {same_camera(camera)}")
        if pair:
            # Both windows idle on the same frame (a still view refines first).
            shown = "const r = window.refrakt; return r.last && !r.activity.busy && r.last.layer === 'beauty' && r.last.frame"
            until = time.time() + PATIENCE
            while time.time() < until and not (wd.js(shown) and wd.js(shown) == other.js(shown)):
                time.sleep(0.3)
            time.sleep(0.5)
            first = base64.b64decode(wd.s("GET", "/screenshot"))
            with open(pair, "wb") as f:
                f.write(side_by_side([first, base64.b64decode(other.s("GET", "/screenshot"))]))
    finally:
        other.quit()


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
    ap.add_argument("--pair")
    ap.add_argument("--refine")
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
        extra += ["--refine", args.refine] if args.refine else []
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
            canvas = element(wd, "#frame")
            wd.js("window.refrakt.busySeen = []")
            sent = orbit_and_wait(wd, canvas, 120, 30)
            busy = wd.js("return window.refrakt.busySeen")
            if not any(b.startswith("rendering:") for b in busy):
                fail(f"no busy indicator while the orbited frame rendered (seen: {busy})")
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
            reload_keeps_camera_and_layer(wd, canvas)
            canvas = element(wd, "#frame")
            second_window_follows(wd, driver_port, url, canvas, args.pair)
            if args.measure:
                measure(wd, canvas, args.measure)
            print(f"test_browser: ok: the drag orbited (input {sent}) with the busy indicator up; screenshot's frame mean "
                  f"{mean:.1f}, spread {spread:.1f}; a reload kept the camera and the caustic layer; a second window followed")
        finally:
            if wd:
                wd.quit()
            driver.terminate()
            server.terminate()
            server.wait(timeout=30)
            driver.wait(timeout=30)


if __name__ == "__main__":
    main()
