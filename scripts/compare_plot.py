"""The figures of scripts/compare_cycles.py, drawn with numpy and written as PNG with zlib and
struct alone (bpy's venv has no matplotlib): error against wall time, log-log, with a 3×5 pixel
font; sRGB previews of linear images; the reference beside each renderer's image."""

import math
import os
import pathlib
import struct
import zlib


FONT = {
    "0": "111101101101111", "1": "010110010010111", "2": "111001111100111", "3": "111001111001111",
    "4": "101101111001001", "5": "111100111001111", "6": "111100111101111", "7": "111001010010010",
    "8": "111101111101111", "9": "111101111001111", ".": "000000000000010", "%": "101001010100101",
    "-": "000000111000000", " ": "000000000000000", "S": "111100111001111", "T": "111010010010010",
    "I": "111010010010111", "M": "101111101101101", "E": "111100111100111", "R": "110101110101101",
    "C": "111100100100111", "Y": "101101010010010", "L": "100100100100111", "F": "111100110100100",
    "A": "010101111101101", "K": "101101110101101", "O": "111101101101111", "H": "101101111101101",
    "X": "101101010101101", "(": "010100100100010", ")": "010001001001010", "/": "001001010100100",
    "W": "101101101111101", "N": "110101101101101", "D": "110101101101110", "P": "111101111100100",
    "U": "101101101101111", "V": "101101101101010", "G": "111100101101111", "B": "110101110101110",
}


def draw_text(img, x, y, text, color, scale=2):
    for ch in text.upper():
        bits = FONT.get(ch, FONT[" "])
        for k, b in enumerate(bits):
            if b == "1":
                r, c = divmod(k, 3)
                img[y + r * scale:y + (r + 1) * scale, x + c * scale:x + (c + 1) * scale] = color
        x += 4 * scale
    return x


def draw_line(img, p0, p1, color, width=2):
    n = int(max(abs(p1[0] - p0[0]), abs(p1[1] - p0[1]))) + 1
    for k in range(n + 1):
        t = k / n
        x, y = int(round(p0[0] + t * (p1[0] - p0[0]))), int(round(p0[1] + t * (p1[1] - p0[1])))
        img[max(0, y - width // 2):y + (width + 1) // 2, max(0, x - width // 2):x + (width + 1) // 2] = color


def write_png(path, rgb):
    """An 8-bit RGB PNG (H×W×3 uint8) with zlib and struct alone."""
    h, w, _ = rgb.shape
    raw = b"".join(b"\x00" + rgb[r].tobytes() for r in range(h))

    def chunk(kind, data):
        return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data) & 0xFFFFFFFF)

    data = b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", w, h, 8, 2, 0, 0, 0))
    data += chunk(b"IDAT", zlib.compress(raw, 9)) + chunk(b"IEND", b"")
    tmp = pathlib.Path(str(path) + ".tmp")
    tmp.write_bytes(data)
    os.replace(tmp, path)


def amount(p):
    """A run's photons (refrakt) or samples (Cycles)."""
    return p.get("photons", p.get("samples", 0))


def short(n):
    return f"{n / 1e6:g}M" if n >= 1e6 else f"{n / 1e3:g}K" if n >= 1e4 else str(n)


COLORS = [(230, 120, 20), (40, 90, 200), (200, 40, 120), (30, 150, 60)]


def plot(path, series, baseline=None):
    """Relative caustic error (y) against wall seconds (x), log-log, one polyline per renderer;
    a dashed line at `baseline` (the error of an image without caustics)."""
    import numpy as np

    W, H, L, R, T, B = 720, 440, 70, 20, 40, 50
    img = np.full((H, W, 3), 255, np.uint8)
    series = {k: [p for p in s if p["relative"] > 0] for k, s in series.items()}
    pts = [p for s in series.values() for p in s]
    xs = [math.log10(p["seconds"]) for p in pts]
    ys = [math.log10(p["relative"]) for p in pts] + ([math.log10(baseline)] if baseline else [])
    x0, x1 = math.floor(min(xs)), math.ceil(max(xs))
    y0, y1 = math.floor((min(ys) - 0.05) * 2) / 2, math.ceil((max(ys) + 0.05) * 2) / 2

    def px(lt, le):
        return L + (lt - x0) / (x1 - x0) * (W - L - R), T + (y1 - le) / (y1 - y0) * (H - T - B)

    for d in range(x0, x1 + 1):
        for m in range(1, 10):
            v = d + math.log10(m)
            if v <= x1:
                x, _ = px(v, y0)
                img[T:H - B, int(x)] = (225, 225, 225) if m > 1 else (170, 170, 170)
        x, _ = px(d, y0)
        label = f"{10.0 ** d:g}"
        draw_text(img, int(x) - 4 * len(label), H - B + 8, label, (0, 0, 0))
    for d in range(math.floor(y0), math.ceil(y1) + 1):
        for m in range(1, 10):
            v = d + math.log10(m)
            if y0 <= v <= y1:
                _, y = px(x0, v)
                img[int(y), L:W - R] = (225, 225, 225) if m > 1 else (170, 170, 170)
                if m in (1, 2, 5):
                    label = f"{100 * 10.0 ** v:g}%"
                    draw_text(img, L - 8 - 8 * len(label), int(y) - 5, label, (0, 0, 0))
    img[T:H - B, L] = img[H - B, L:W - R] = (0, 0, 0)
    if baseline:
        _, y = px(x0, math.log10(baseline))
        for x in range(L, W - R, 12):
            img[int(y), x:x + 6] = (90, 90, 90)
        draw_text(img, L + 6, int(y) - 14, "NO CAUSTICS", (90, 90, 90))
    draw_text(img, W // 2 - 100, H - 22, "WALL TIME (S)", (0, 0, 0))
    draw_text(img, 8, 10, "CAUSTIC RMSE / REFERENCE MEAN", (0, 0, 0))
    lx = W - R - 260
    for k, (name, s) in enumerate(series.items()):
        color = COLORS[k % len(COLORS)]
        s = sorted(s, key=amount)
        coords = [px(math.log10(p["seconds"]), math.log10(p["relative"])) for p in s]
        for a, b in zip(coords, coords[1:]):
            draw_line(img, a, b, color)
        free = 0  # the first column a label may start at (labels must not overlap)
        for p, (x, y) in zip(s, coords):
            img[int(y) - 3:int(y) + 4, int(x) - 3:int(x) + 4] = color
            if int(x) + 5 >= free:
                free = draw_text(img, int(x) + 5, int(y) + 6, short(amount(p)), color) + 4
        img[12 + 16 * k:20 + 16 * k, lx:lx + 16] = color
        draw_text(img, lx + 22, 11 + 16 * k, name, (0, 0, 0))
    write_png(path, img)


def srgb8(rgb, exposure=0.5):
    """8-bit sRGB of a linear image."""
    import numpy as np

    x = np.clip(rgb * exposure, 0, 1)
    s = np.where(x <= 0.0031308, 12.92 * x, 1.055 * x ** (1 / 2.4) - 0.055)
    return (s * 255 + 0.5).astype(np.uint8)


def png_of_image(path, rgb):
    write_png(path, srgb8(rgb))


def image_strip(path, ref, outline, images):
    """The reference with `outline` (a mask) in red, then each (name, image) beside it."""
    import numpy as np

    outlined = srgb8(ref)
    outlined[outline] = (255, 40, 40)
    tiles = [outlined] + [srgb8(im) for _, im in images]
    strip = np.concatenate(tiles, axis=1)
    band = np.full((16, strip.shape[1], 3), 255, np.uint8)
    for k, name in enumerate(["reference"] + [n for n, _ in images]):
        draw_text(band, k * ref.shape[1] + 3, 3, name, (0, 0, 0), scale=2)
    write_png(path, np.concatenate([strip, band], axis=0))
