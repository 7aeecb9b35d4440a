"""The palette indices of a GIF image (its first image), decoded here because image
libraries hand out colours only, while POV-Ray's height fields, bump maps and Fractint's
`pot` files (a GIF whose right half holds the low bytes of 16-bit values) use the indices.
"""

from __future__ import annotations

import numpy as np

GIF_SIGNATURES = (b"GIF87a", b"GIF89a")
MAX_CODE_BITS = 12  # LZW codes are at most 12 bits: a table of 4096 strings


class GifError(ValueError):
    pass


def gif_indices(data: bytes) -> np.ndarray | None:
    """(H, W) uint8 palette indices of the file's first image; None if it is not a GIF."""
    if data[:6] not in GIF_SIGNATURES:
        return None
    if len(data) < 13:
        raise GifError("GIF file without a screen descriptor")
    packed = data[10]
    pos = 13 + (3 << ((packed & 7) + 1) if packed & 0x80 else 0)
    while pos < len(data):
        kind = data[pos]
        if kind == 0x3B:  # trailer before any image
            break
        if kind == 0x21:  # extension: label, then sub-blocks
            _, pos = _sub_blocks(data, pos + 2)
            continue
        if kind != 0x2C:
            raise GifError(f"unknown GIF block 0x{kind:02x}")
        if pos + 11 > len(data):
            raise GifError("truncated GIF image descriptor")
        width = data[pos + 5] | data[pos + 6] << 8
        height = data[pos + 7] | data[pos + 8] << 8
        flags = data[pos + 9]
        pos += 10
        if flags & 0x80:
            pos += 3 << ((flags & 7) + 1)
        min_bits = data[pos]
        if not 1 <= min_bits <= 11:
            raise GifError(f"GIF LZW code size {min_bits} out of range")
        stream, _ = _sub_blocks(data, pos + 1)
        pixels = np.frombuffer(_lzw(stream, min_bits, width * height), dtype=np.uint8)
        if pixels.size < width * height:  # a short stream: the rest stays index 0
            pixels = np.concatenate([pixels, np.zeros(width * height - pixels.size, np.uint8)])
        rows = pixels[: width * height].reshape(height, width)
        return _deinterlace(rows) if flags & 0x40 else rows
    raise GifError("GIF file without an image")


def _sub_blocks(data: bytes, pos: int) -> tuple[bytes, int]:
    """The joined sub-blocks from `pos` and the position after their terminator."""
    parts: list[bytes] = []
    while pos < len(data):
        n = data[pos]
        pos += 1
        if n == 0:
            return b"".join(parts), pos
        parts.append(data[pos : pos + n])
        pos += n
    raise GifError("truncated GIF data")


def _lzw(stream: bytes, min_bits: int, limit: int) -> bytes:
    """GIF's variable-width LZW (codes packed least significant bit first)."""
    clear, end = 1 << min_bits, (1 << min_bits) + 1
    base = [bytes([i]) for i in range(clear)] + [b"", b""]
    table = list(base)
    bits, acc, nacc = min_bits + 1, 0, 0
    out = bytearray()
    prev = b""
    for byte in stream:
        acc |= byte << nacc
        nacc += 8
        while nacc >= bits:
            code = acc & ((1 << bits) - 1)
            acc >>= bits
            nacc -= bits
            if code == clear:
                table, bits, prev = list(base), min_bits + 1, b""
                continue
            if code == end:
                return bytes(out)
            if code < len(table):
                entry = table[code]
                if prev and len(table) < 1 << MAX_CODE_BITS:
                    table.append(prev + entry[:1])
            elif code == len(table) and prev:
                entry = prev + prev[:1]
                table.append(entry)
            else:
                raise GifError("corrupt GIF LZW data")
            out += entry
            prev = entry
            if len(table) == 1 << bits and bits < MAX_CODE_BITS:
                bits += 1
            if len(out) >= limit:
                return bytes(out)
    return bytes(out)


def _deinterlace(rows: np.ndarray) -> np.ndarray:
    """Interlaced rows come in four passes: every 8th from 0, every 8th from 4, every 4th
    from 2, every 2nd from 1."""
    order = np.concatenate([np.arange(s, rows.shape[0], k) for s, k in _PASSES])
    out = np.empty_like(rows)
    out[order] = rows
    return out


_PASSES = ((0, 8), (4, 8), (2, 4), (1, 2))
