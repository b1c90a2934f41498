#!/usr/bin/env python3
"""Turns rendered PNG frames into a looping GIF for the guide (needs Pillow).

    python3 scripts/frames_to_gif.py OUT.gif FRAME.png… [--fps 24]

All frames share one palette, taken from a few of them, so colors do not flicker.
"""
import argparse

from PIL import Image


def main():
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("out")
    p.add_argument("frames", nargs="+")
    p.add_argument("--fps", type=float, default=24)
    p.add_argument("--colors", type=int, default=128)
    a = p.parse_args()
    frames = [Image.open(f).convert("RGB") for f in sorted(a.frames)]
    w, h = frames[0].size
    picks = frames[:: max(1, len(frames) // 4)][:4]
    sample = Image.new("RGB", (w, h * len(picks)))
    for i, f in enumerate(picks):
        sample.paste(f, (0, h * i))
    palette = sample.quantize(colors=a.colors, method=Image.Quantize.MEDIANCUT)
    indexed = [f.quantize(palette=palette, dither=Image.Dither.NONE) for f in frames]
    indexed[0].save(a.out, save_all=True, append_images=indexed[1:], duration=round(1000 / a.fps), loop=0, optimize=True)


if __name__ == "__main__":
    main()
