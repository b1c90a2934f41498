"""A minimal OpenEXR writer (single part, scanlines, uncompressed, 32-bit float) in plain
Python, so the fake `refrakt` used by the tests writes real EXR files without any library.

Only what the tests need: any channel names (refrakt's `R G B A`, `depth.Z`, `caustic.R` …),
one value per channel per pixel, written through a temporary name and renamed, like refrakt.
"""

import os
import struct


def _attribute(name, kind, value):
    return name.encode() + b"\0" + kind.encode() + b"\0" + struct.pack("<i", len(value)) + value


def encode(width, height, planes):
    """EXR bytes of `planes`: {channel name: flat list of width*height floats, rows top first}."""
    names = sorted(planes)
    chlist = b"".join(n.encode() + b"\0" + struct.pack("<iB3xii", 2, 0, 1, 1) for n in names) + b"\0"
    box = struct.pack("<iiii", 0, 0, width - 1, height - 1)
    header = b"".join(
        [
            struct.pack("<ii", 20000630, 2),
            _attribute("channels", "chlist", chlist),
            _attribute("compression", "compression", b"\0"),
            _attribute("dataWindow", "box2i", box),
            _attribute("displayWindow", "box2i", box),
            _attribute("lineOrder", "lineOrder", b"\0"),
            _attribute("pixelAspectRatio", "float", struct.pack("<f", 1.0)),
            _attribute("screenWindowCenter", "v2f", struct.pack("<ff", 0.0, 0.0)),
            _attribute("screenWindowWidth", "float", struct.pack("<f", 1.0)),
            b"\0",
        ]
    )
    line_bytes = 4 * width * len(names)
    first = len(header) + 8 * height
    offsets = b"".join(struct.pack("<Q", first + y * (8 + line_bytes)) for y in range(height))
    lines = []
    for y in range(height):
        row = b"".join(struct.pack(f"<{width}f", *planes[n][y * width:(y + 1) * width]) for n in names)
        lines.append(struct.pack("<ii", y, line_bytes) + row)
    return header + offsets + b"".join(lines)


def write(path, width, height, planes):
    """Writes atomically: a hidden temporary in the same folder, then a rename."""
    folder, name = os.path.split(path)
    tmp = os.path.join(folder, f".{name}.tmp-{os.getpid()}.exr")
    with open(tmp, "wb") as f:
        f.write(encode(width, height, planes))
    os.replace(tmp, path)
