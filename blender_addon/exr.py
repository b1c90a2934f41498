"""Reading refrakt's OpenEXR files into numpy arrays, channel by channel.

Blender's Python API loads an EXR only as an image whose pixels are its first pass, so the
render engine reads refrakt's frames itself: one part, scan lines, HALF or FLOAT channels,
uncompressed (`refrakt watch`'s preview) or ZIP/ZIPS (`refrakt render`'s frames). That is the
whole of what refrakt writes (see refrakt's src/output/exr.rs); anything else is refused with
a message saying what was found.
"""

import struct
import zlib

import numpy as np

MAGIC = 20000630
# Compression ids (OpenEXR's ImfCompression.h) and the scan lines of one block.
_LINES = {0: 1, 2: 1, 3: 16}  # NONE, ZIPS, ZIP
_NAMES = {0: "none", 1: "RLE", 2: "ZIPS", 3: "ZIP", 4: "PIZ", 5: "PXR24", 6: "B44", 7: "B44A", 8: "DWAA", 9: "DWAB"}
_TYPES = {1: np.dtype("<f2"), 2: np.dtype("<f4")}  # HALF, FLOAT (UINT is not refrakt's)


class ExrError(Exception):
    """The file is not an EXR refrakt could have written; the message says why."""


def _cstring(data, at):
    end = data.index(b"\0", at)
    return data[at:end].decode("latin-1"), end + 1


def _header(data, path):
    if len(data) < 8 or struct.unpack_from("<i", data, 0)[0] != MAGIC:
        raise ExrError(f"{path} is not an OpenEXR file")
    flags = struct.unpack_from("<I", data, 4)[0]
    if flags & 0x1E00:  # tiled, long names, deep, multi-part
        raise ExrError(f"{path}: tiled, deep or multi-part EXRs are not read here (refrakt writes one part of scan lines)")
    attrs, at = {}, 8
    while data[at] != 0:
        name, at = _cstring(data, at)
        kind, at = _cstring(data, at)
        size = struct.unpack_from("<i", data, at)[0]
        attrs[name] = (kind, data[at + 4:at + 4 + size])
        at += 4 + size
    return attrs, at + 1


def _channels(raw):
    out, at = [], 0
    while raw[at] != 0:
        name, at = _cstring(raw, at)
        kind, _, _, xs, ys = struct.unpack_from("<iB3sii", raw, at)
        at += 16
        if kind not in _TYPES or (xs, ys) != (1, 1):
            raise ExrError(f"channel {name}: only HALF or FLOAT channels without subsampling are read here")
        out.append((name, _TYPES[kind]))
    return out


def _unzip(block, expected):
    """ZIP/ZIPS: zlib, then OpenEXR's byte predictor and the two halves interleaved."""
    t = np.frombuffer(zlib.decompress(block), np.uint8).astype(np.int64)
    if t.size != expected:
        raise ExrError(f"a ZIP block holds {t.size} bytes, {expected} expected")
    t[1:] -= 128
    t = (np.cumsum(t) & 0xFF).astype(np.uint8)
    out = np.empty_like(t)
    half = (t.size + 1) // 2
    out[0::2], out[1::2] = t[:half], t[half:]
    return out.tobytes()


def read(path):
    """The file's channels as {name: float32 array of shape (height, width)}, rows from the
    top of the image, as EXR stores them."""
    with open(path, "rb") as f:
        data = f.read()
    try:
        attrs, at = _header(data, path)
        compression = attrs["compression"][1][0]
        if compression not in _LINES:
            raise ExrError(f"{path}: {_NAMES.get(compression, compression)} compression is not read here (refrakt writes none or ZIP)")
        channels = _channels(attrs["channels"][1])
        x0, y0, x1, y1 = struct.unpack("<4i", attrs["dataWindow"][1])
    except (KeyError, IndexError, struct.error, ValueError) as e:
        raise ExrError(f"{path}: a damaged EXR header ({e})") from None
    width, height = x1 - x0 + 1, y1 - y0 + 1
    lines = _LINES[compression]
    blocks = -(-height // lines)
    offsets = struct.unpack_from(f"<{blocks}Q", data, at)
    planes = {name: np.empty((height, width), np.float32) for name, _ in channels}
    row_bytes = sum(width * t.itemsize for _, t in channels)
    for offset in offsets:
        y, size = struct.unpack_from("<ii", data, offset)
        first = y - y0
        count = min(lines, height - first)
        block = data[offset + 8:offset + 8 + size]
        expected = count * row_bytes
        if compression and size < expected:
            block = _unzip(block, expected)
        if len(block) != expected:
            raise ExrError(f"{path}: the block at row {y} is cut short ({len(block)} of {expected} bytes)")
        _scatter(block, channels, planes, first, count, width)
    return planes


def _scatter(block, channels, planes, first, count, width):
    """A block's rows: for each row, each channel's `width` samples in turn."""
    at = 0
    for row in range(first, first + count):
        for name, dtype in channels:
            n = width * dtype.itemsize
            planes[name][row] = np.frombuffer(block, dtype, width, at)
            at += n
