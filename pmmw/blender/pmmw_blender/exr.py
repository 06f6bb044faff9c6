"""pmmw's EXR images read without OpenImageIO (Blender has none to offer an add-on, and its own
EXR reader takes only R, G, B, A-like channel names, not pmmw's ``I``, ``Ex2``, ``ideal.I``).

Reads what pmmw writes (`pmmw.io.exr`): one part, scanlines, channels of 32-bit float (or
half, or uint), compression none, ZIPS or ZIP, the layout of the OpenEXR file format
(openexr.com, "OpenEXR File Layout": header attributes, the line offset table, chunks of 1 or 16
scanlines, each scanline the channels in the header's order; ZIP's byte predictor and the split
into even and odd bytes undone after zlib). Needs only numpy, which Blender ships.
"""

from __future__ import annotations

import struct
import zlib

import numpy as np

MAGIC = 20000630
_COMPRESSIONS = {0: ("none", 1), 2: ("zips", 1), 3: ("zip", 16)}
_DTYPES = {0: np.dtype("<u4"), 1: np.dtype("<f2"), 2: np.dtype("<f4")}


class ExrError(ValueError):
    """Not an EXR this reader takes (the message says what)."""


def _header(buf: bytes) -> tuple[dict, int]:
    magic, version = struct.unpack_from("<ii", buf, 0)
    if magic != MAGIC:
        raise ExrError("not an OpenEXR file")
    if version & 0x1200:  # tiled (0x200) or multi-part (0x1000)
        raise ExrError("tiled or multi-part EXR files are not read here")
    attrs, pos = {}, 8
    while True:
        end = buf.index(b"\0", pos)
        name = buf[pos:end].decode()
        pos = end + 1
        if not name:
            return attrs, pos
        end = buf.index(b"\0", pos)
        kind = buf[pos:end].decode()
        (size,) = struct.unpack_from("<i", buf, end + 1)
        value = buf[end + 5 : end + 5 + size]
        pos = end + 5 + size
        if kind == "chlist":
            channels, p = [], 0
            while value[p : p + 1] != b"\0":
                e = value.index(b"\0", p)
                cname = value[p:e].decode()
                ptype, _, xs, ys = struct.unpack_from("<iB3xii", value, e + 1)
                if (xs, ys) != (1, 1):
                    raise ExrError(f"channel {cname!r} is subsampled")
                channels.append((cname, ptype))
                p = e + 17
            attrs[name] = channels
        elif kind == "compression":
            attrs[name] = value[0]
        elif kind == "box2i":
            attrs[name] = struct.unpack("<iiii", value)
        else:
            attrs[name] = (kind, value)


def _unzip(data: bytes, raw_size: int) -> bytes:
    if len(data) == raw_size:  # OpenEXR stores a chunk as it is when compressing would not shrink it
        return data
    t = np.frombuffer(zlib.decompress(data), dtype=np.uint8).astype(np.int64)
    t[1:] -= 128
    t = (np.cumsum(t) & 0xFF).astype(np.uint8)  # the predictor: each byte the previous plus a delta
    half = (len(t) + 1) // 2
    out = np.empty_like(t)
    out[0::2], out[1::2] = t[:half], t[half:]
    return out.tobytes()


def read(path) -> dict[str, np.ndarray]:
    """The channels of a pmmw EXR.

    Parameters
    ----------
    path : str or Path

    Returns
    -------
    dict
        channel name -> (height, width) float32 array [K for pmmw's channels], row 0 the top of
        the image.

    Raises
    ------
    ExrError
        Not an EXR, or a layout this reader does not take.
    """
    with open(path, "rb") as f:
        buf = f.read()
    attrs, pos = _header(buf)
    x0, y0, x1, y1 = attrs["dataWindow"]
    width, height = x1 - x0 + 1, y1 - y0 + 1
    compression = attrs.get("compression", 0)
    if compression not in _COMPRESSIONS:
        raise ExrError(f"compression {compression} is not read here (none, ZIPS and ZIP are)")
    _, lines = _COMPRESSIONS[compression]
    channels = attrs["channels"]
    dtypes = [_DTYPES[t] for _, t in channels]
    row_bytes = width * sum(d.itemsize for d in dtypes)
    n_chunks = -(-height // lines)
    offsets = struct.unpack_from(f"<{n_chunks}Q", buf, pos)
    out = {name: np.empty((height, width), np.float32) for name, _ in channels}
    for off in offsets:
        y, size = struct.unpack_from("<ii", buf, off)
        rows = min(lines, y1 + 1 - y)
        data = buf[off + 8 : off + 8 + size]
        block = data if compression == 0 else _unzip(data, rows * row_bytes)
        p = 0
        for r in range(rows):
            for (name, _), dt in zip(channels, dtypes):
                n = width * dt.itemsize
                out[name][y - y0 + r] = np.frombuffer(block, dtype=dt, count=width, offset=p)
                p += n
    return out
