#!/usr/bin/env python3
"""Builds the Blender extension zip from blender_addon/: dist/refrakt-<version>.zip, installable
with Blender's Preferences > Get Extensions > Install from Disk (Blender 4.2 or later).

Usage: python3 scripts/build_blender_addon.py [--out DIR]
"""

import argparse
import pathlib
import sys
import tomllib
import zipfile

ROOT = pathlib.Path(__file__).resolve().parent.parent
SOURCE = ROOT / "blender_addon"


def build(out_dir):
    manifest = tomllib.loads((SOURCE / "blender_manifest.toml").read_text())
    out_dir = pathlib.Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    target = out_dir / f"{manifest['id']}-{manifest['version']}.zip"
    files = sorted(
        p for p in SOURCE.rglob("*")
        if p.is_file() and "__pycache__" not in p.parts and not p.name.startswith(".") and p.suffix != ".pyc"
    )
    tmp = target.with_name("." + target.name + ".tmp")
    with zipfile.ZipFile(tmp, "w", zipfile.ZIP_DEFLATED) as z:
        for p in files:
            z.write(p, p.relative_to(SOURCE).as_posix())
    tmp.replace(target)
    return target


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", default=str(ROOT / "dist"), help="folder for the zip (default: dist/)")
    print(build(parser.parse_args().out))


if __name__ == "__main__":
    sys.exit(main())
