"""A reader of the EXR files Blender writes, in numpy and the standard library alone, for a
Python without the OpenEXR module (Blender's own, where the installed extension fits to a
render): scanline images, single- or multi-part, uncompressed or ZIP (one or sixteen lines
per chunk, what ``layered-brdf render`` and Blender's defaults write), half, float or uint
channels.  Other compressions and tiled or deep files are refused naming what they are.

The layout is the OpenEXR file format's ("OpenEXR file layout", openexr.com): magic and
version, the headers (attributes ``name\\0 type\\0 size value``, one header per part), the
offset tables, then the chunks (``[part] y size data``).  ZIP chunks are zlib streams of the
bytes split into even and odd halves and delta-coded (the predictor), undone here.
tests/test_exr_reader.py compares it with OpenEXR on Blender's own renders.
"""
from __future__ import annotations

import os
import struct
import zlib

import numpy as np

MAGIC = 20000630
_TILED, _NON_IMAGE, _MULTIPART = 0x200, 0x800, 0x1000
_LINES_PER_CHUNK = {0: 1, 2: 1, 3: 16}  # NONE, ZIPS, ZIP
_COMPRESSION_NAMES = ("none", "RLE", "ZIPS", "ZIP", "PIZ", "PXR24", "B44", "B44A", "DWAA", "DWAB", "HTJ2K")
_PIXEL_TYPES = {0: np.dtype("<u4"), 1: np.dtype("<f2"), 2: np.dtype("<f4")}


class ExrError(ValueError):
    """The file is not an EXR this reader can read; the message says why."""


class _Bytes:
    def __init__(self, data: bytes, path):
        self.data, self.pos, self.path = data, 0, path

    def take(self, n: int) -> bytes:
        if n < 0 or self.pos + n > len(self.data):
            raise ExrError(f"{self.path} ends early (at byte {len(self.data)})")
        out = self.data[self.pos:self.pos + n]
        self.pos += n
        return out

    def unpack(self, fmt: str):
        return struct.unpack("<" + fmt, self.take(struct.calcsize("<" + fmt)))

    def name(self) -> str:
        end = self.data.find(b"\0", self.pos)
        if end < 0:
            raise ExrError(f"{self.path} ends early (in a header)")
        out = self.data[self.pos:end].decode("latin-1")
        self.pos = end + 1
        return out


def _channels(value: bytes) -> list[tuple[str, int]]:
    out, pos = [], 0
    while value[pos:pos + 1] not in (b"\0", b""):
        end = value.index(b"\0", pos)
        name = value[pos:end].decode("latin-1")
        pixel_type, _, _, x_sampling, y_sampling = struct.unpack_from("<iB3sii", value, end + 1)
        if pixel_type not in _PIXEL_TYPES or (x_sampling, y_sampling) != (1, 1):
            raise ExrError(f"channel {name}: pixel type {pixel_type}, sampling {x_sampling}x{y_sampling} "
                           "(half, float or uint at every pixel are read)")
        out.append((name, pixel_type))
        pos = end + 1 + 16
    return out


def _header(stream: _Bytes) -> dict | None:
    """One part's header (``None`` at the empty header ending a multi-part file's)."""
    header = {}
    while True:
        name = stream.name()
        if not name:
            return header or None
        kind = stream.name()
        (size,) = stream.unpack("i")
        value = stream.take(size)
        if kind == "chlist":
            header[name] = _channels(value)
        elif kind == "compression":
            header[name] = value[0]
        elif kind == "box2i":
            header[name] = struct.unpack("<4i", value)
        elif kind in ("int", "lineOrder"):
            header[name] = struct.unpack("<i", value[:4])[0] if kind == "int" else value[0]
        elif kind == "string":
            header[name] = value.decode("latin-1")
        elif name == "type":
            header[name] = value.decode("latin-1")


def _unzip(data: bytes, expected: int, where: str) -> bytes:
    try:
        raw = np.frombuffer(zlib.decompress(data), dtype=np.uint8)
    except zlib.error as e:
        raise ExrError(f"{where}: {e}") from None
    if raw.size != expected:
        raise ExrError(f"{where}: {raw.size} bytes unpacked, {expected} expected")
    # The predictor: t[0] = d[0], t[i] = t[i-1] + d[i] - 128 (mod 256); then the halves interleaved.
    t = ((np.cumsum(np.concatenate([[raw[0]], raw[1:].astype(np.int64) - 128]))) % 256).astype(np.uint8)
    half = (t.size + 1) // 2
    out = np.empty_like(t)
    out[0::2], out[1::2] = t[:half], t[half:]
    return out.tobytes()


def read_exr(path: str | os.PathLike) -> dict[str, dict[str, np.ndarray]]:
    """Every part of the EXR at ``path``: ``{part name: {channel name: float32 array (H, W)}}``,
    row 0 at the top (a single-part file's part is named by its ``name`` attribute, else "").
    Raises :class:`ExrError` saying why a file cannot be read."""
    with open(path, "rb") as f:
        stream = _Bytes(f.read(), path)
    magic, version = stream.unpack("ii")
    if magic != MAGIC:
        raise ExrError(f"{path} is not an EXR file")
    if version & (_TILED | _NON_IMAGE):
        raise ExrError(f"{path} is a tiled or deep EXR; scanline images are read")
    multipart = bool(version & _MULTIPART)
    headers = []
    while True:
        header = _header(stream)
        if header is None:
            break
        headers.append(header)
        if not multipart:
            break
    if not headers:
        raise ExrError(f"{path} has no image part")
    plans = []
    for header in headers:
        if header.get("type", "scanlineimage") != "scanlineimage":
            raise ExrError(f"{path}: part {header.get('name', '')!r} is {header['type']}; scanline images are read")
        compression = header.get("compression", 0)
        if compression not in _LINES_PER_CHUNK:
            name = _COMPRESSION_NAMES[compression] if compression < len(_COMPRESSION_NAMES) else compression
            raise ExrError(f"{path} is {name}-compressed; this reader takes ZIP, ZIPS or none "
                           "(as layered-brdf render writes)")
        x0, y0, x1, y1 = header["dataWindow"]
        width, height = x1 - x0 + 1, y1 - y0 + 1
        lines = _LINES_PER_CHUNK[compression]
        count = header.get("chunkCount", -(-height // lines))
        plans.append((header, width, height, lines, compression, count))
    tables = [stream.unpack(f"{count}Q") for *_, count in plans]
    out = {}
    for index, ((header, width, height, lines, compression, _), offsets) in enumerate(zip(plans, tables)):
        channels = header["channels"]
        planes = {name: np.zeros((height, width), np.float32) for name, _ in channels}
        y_min = header["dataWindow"][1]
        for offset in offsets:
            stream.pos = offset
            if multipart:
                (part,) = stream.unpack("i")
                if part != index:
                    raise ExrError(f"{path}: a chunk of part {part} in part {index}'s table")
            y, size = stream.unpack("ii")
            row = y - y_min
            n = min(lines, height - row)
            if row < 0 or n <= 0:
                raise ExrError(f"{path}: a chunk at line {y}, outside the image")
            expected = n * width * sum(_PIXEL_TYPES[t].itemsize for _, t in channels)
            data = stream.take(size)
            if size != expected:  # a chunk that compression did not shrink is stored as it is
                data = _unzip(data, expected, f"{path}: the chunk at line {y}") if compression else data
            if len(data) != expected:
                raise ExrError(f"{path}: the chunk at line {y} holds {len(data)} bytes, {expected} expected")
            pos = 0
            for r in range(n):
                for name, t in channels:
                    dtype = _PIXEL_TYPES[t]
                    planes[name][row + r] = np.frombuffer(data, dtype, width, pos)
                    pos += width * dtype.itemsize
        out[header.get("name", "")] = planes
    return out
