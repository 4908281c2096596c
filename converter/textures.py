"""Whether a texture file is an image Mitsuba's ``bitmap`` texture can read, decided without
Mitsuba, so that a bad texture is reported with its scene file and line when the scene is
parsed. The format is told from the first bytes, as Mitsuba does, then the file is read as it.
"""

from __future__ import annotations

import io
import os
import re
import warnings
import zlib
from pathlib import Path

#: an image's first bytes -> its format, as Mitsuba detects it
_MAGIC = ((b"BM", "BMP"), (b"#?", "RGBE"), (b"PF", "PFM"), (b"Pf", "PFM"), (b"P6", "PPM"),
          (b"\xff\xd8", "JPEG"), (b"\x89PNG\r\n\x1a\n", "PNG"), (b"\x76\x2f\x31\x01", "OpenEXR"))
#: the last 18 bytes of a TGA 2.0 file (Mitsuba's test for TGA, the one format without a magic)
_TGA_FOOTER = b"TRUEVISION-XFILE.\0"
_RGBE_NUMBER = re.compile(rb"\s*\+?(\d+)")
_PFM_HEADER = re.compile(rb"P([Ff])\s+(\d+)\s+(\d+)\s+([-+]?[0-9.]+(?:[eE][-+]?\d+)?)\s")


def image_problem(path: Path) -> str | None:
    """Why Mitsuba could not use ``path`` as a texture (one line that names it), or None."""
    if not path.exists():
        return f"no such file {path}"
    if path.is_dir():
        return f"{path} is a folder, not an image"
    if not path.is_file():
        return f"{path} is not a regular file"
    if not os.access(path, os.R_OK):
        return f"cannot read {path}: permission denied"
    try:
        kind = image_format(path)
        if kind is None:
            raise ValueError("unknown file format: not PNG, JPEG, OpenEXR, RGBE, PFM, PPM, BMP or TGA")
        _decode(path, kind)
    except Exception as error:  # each decoder has its own exceptions; any means "cannot read"
        reason = " ".join(str(error).split()) or type(error).__name__
        return f"{path} is not an image Mitsuba can read ({reason.replace(str(path), 'the file')[:160]})"
    return None


def image_format(path: Path) -> str | None:
    """The format Mitsuba reads ``path`` as (a name of :data:`_MAGIC`, or "TGA"), or None."""
    with open(path, "rb") as file:
        start = file.read(8)
        for magic, kind in _MAGIC:
            if start.startswith(magic):
                return kind
        size = file.seek(0, os.SEEK_END)
        if size >= len(_TGA_FOOTER):
            file.seek(size - len(_TGA_FOOTER))
            if file.read() == _TGA_FOOTER:
                return "TGA"
    return None


def _decode(path: Path, kind: str) -> None:
    """Read the whole image ``path`` as ``kind``; an exception when that fails."""
    if kind == "OpenEXR":
        _check_exr(path)
    elif kind == "PFM":
        _check_pfm(path)
    elif kind == "RGBE":
        _check_rgbe(path)
    else:
        from PIL import Image
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", Image.DecompressionBombWarning)
            try:
                source = io.BytesIO(_png_as_libpng_reads_it(path)) if kind == "PNG" else path
                with Image.open(source, formats=[kind]) as image:
                    image.load()
            except Image.DecompressionBombError:
                pass                       # a valid header, too large to decode twice: Mitsuba will
            except OSError as error:
                # libjpeg, as Mitsuba uses it, reads a truncated JPEG (with a warning)
                if not (kind == "JPEG" and "truncated" in str(error)):
                    raise


def _png_as_libpng_reads_it(path: Path) -> bytes:
    """The PNG ``path`` without the ancillary chunks whose CRC is wrong (libpng, as Mitsuba
    uses it, warns and drops them); a wrong CRC of a critical chunk, or a name that is not
    four letters, is an error there, up to the end of the pixels."""
    data = path.read_bytes()
    kept, at, pixels = [data[:8]], 8, False
    while at + 12 <= len(data):
        size = int.from_bytes(data[at:at + 4], "big")
        chunk = data[at:at + 12 + size]
        if pixels and chunk[4:8] != b"IDAT":
            break                              # past the pixels: not read there
        if len(chunk) < 12 + size:
            raise ValueError("truncated PNG file")
        pixels = chunk[4:8] == b"IDAT"
        if not chunk[4:8].isalpha():
            raise ValueError(f"a chunk named {chunk[4:8]!r}: not four letters")
        if zlib.crc32(chunk[4:8 + size]) == int.from_bytes(chunk[8 + size:], "big"):
            kept.append(chunk)
        elif not chunk[4] & 0x20:              # critical: its name's first letter is upper case
            raise ValueError(f"CRC error in its {chunk[4:8].decode('latin-1')} chunk")
        at += 12 + size
    return b"".join(kept) + data[at:]


def _check_pfm(path: Path) -> None:
    with open(path, "rb") as file:
        head = file.read(256)
        size = file.seek(0, os.SEEK_END)
    match = _PFM_HEADER.match(head)
    if not match:
        raise ValueError("malformed PFM header")
    channels, width, height = (3 if match[1] == b"F" else 1), int(match[2]), int(match[3])
    if not (width and height and float(match[4])):
        raise ValueError("PFM header with a zero size or scale")
    if size < match.end() + 4 * channels * width * height:
        raise ValueError("PFM file shorter than its header says")


def _check_rgbe(path: Path) -> None:
    """The header as Mitsuba's ``read_rgbe`` reads it (a ``FORMAT=32-bit_rle_rgbe`` or ``xyze``
    line before the size line, which must be ``-Y H +X W``), then the scanlines (flat, or
    run-length encoded)."""
    data = path.read_bytes()
    at, known = data.find(b"\n") + 1, False
    while True:
        end = data.find(b"\n", at)
        if not at or end < 0:
            raise ValueError("malformed RGBE header (no '-Y H +X W' line)")
        line, at = data[at:end], end + 1
        tokens = [token for token in re.split(rb"[, ]", line) if token]   # Mitsuba's tokenize
        if line.startswith((b"FORMAT=32-bit_rle_rgbe", b"FORMAT=32-bit_rle_xyze")):
            known = True
        elif len(tokens) == 4 and tokens[0] == b"-Y" and tokens[2] == b"+X":
            break
    if not known:
        raise ValueError("RGBE header without FORMAT=32-bit_rle_rgbe or 32-bit_rle_xyze")
    numbers = [_RGBE_NUMBER.match(token) for token in (tokens[1], tokens[3])]   # as std::stoull
    if not all(numbers):
        raise ValueError("RGBE header with a size that is not a number")
    height, width = (int(number[1]) for number in numbers)
    if not (width and height):
        raise ValueError("RGBE header with a zero size")
    for row in range(height):
        head = data[at:at + 4]
        if not 8 <= width <= 0x7FFF or head[:2] != b"\2\2" or head[2] & 0x80:
            at += 4 * width * (height - row)   # flat from here on
            break
        if (head[2] << 8 | head[3]) != width:
            raise ValueError(f"RGBE scanline {row} has the wrong width")
        at += 4
        for _ in range(4):                     # R, G, B and E, each in runs
            filled = 0
            while filled < width:
                if at >= len(data):
                    raise ValueError("truncated RGBE file")
                count = data[at]
                run = count - 128 if count > 128 else count
                if run == 0 or filled + run > width:
                    raise ValueError(f"bad RGBE scanline data (row {row})")
                at += 2 if count > 128 else 1 + count
                filled += run
    if at > len(data):
        raise ValueError("truncated RGBE file")


#: rows per chunk of a scanline EXR, by compression (0 none, 1 RLE, 2 ZIPS, 3 ZIP, 4 PIZ,
#: 5 PXR24, 6 B44, 7 B44A, 8 DWAA, 9 DWAB)
_EXR_ROWS = {0: 1, 1: 1, 2: 1, 3: 16, 4: 32, 5: 16, 6: 32, 7: 32, 8: 32, 9: 256}


def _check_exr(path: Path) -> None:
    """The header, the chunk table (the bindings only warn about a truncated file) and the
    pixels of an OpenEXR image."""
    data = path.read_bytes()
    version = int.from_bytes(data[4:8], "little")
    attributes, at = {}, 8
    while True:
        end = data.index(b"\0", at)
        if end == at:
            break
        name, type_end = data[at:end], data.index(b"\0", end + 1)
        size = int.from_bytes(data[type_end + 1:type_end + 5], "little", signed=True)
        attributes[name] = data[type_end + 5:type_end + 5 + size]
        at = type_end + 5 + size
    at += 1
    if at > len(data) or b"dataWindow" not in attributes or b"compression" not in attributes:
        raise ValueError("malformed OpenEXR header")
    rows = _EXR_ROWS.get(attributes[b"compression"][0])
    if rows and not version & 0x1600:      # single-part scanline images: check the chunk table
        window = [int.from_bytes(attributes[b"dataWindow"][k:k + 4], "little", signed=True)
                  for k in range(0, 16, 4)]
        chunks = -(-(window[3] - window[1] + 1) // rows)
        for k in range(chunks):
            offset = int.from_bytes(data[at + 8 * k:at + 8 * k + 8], "little")
            size = int.from_bytes(data[offset + 4:offset + 8], "little", signed=True)
            if at + 8 * k + 8 > len(data) or not 0 < offset <= len(data) - 8 or offset + 8 + size > len(data):
                raise ValueError(f"truncated OpenEXR file (chunk {k} of {chunks})")
    import OpenEXR
    parts = OpenEXR.File(str(path)).parts  # decodes every channel
    if not parts or any(channel.pixels is None for channel in parts[0].channels.values()):
        raise ValueError("OpenEXR cannot decode its pixels")
