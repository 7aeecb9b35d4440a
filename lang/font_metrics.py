"""What the evaluator needs of a TrueType font without reading outlines: for each character,
its glyph's advance width, left side bearing and bounding box (the glyf header), and the
kerning between pairs; enough for `min_extent`/`max_extent` of `text`. Pure Python (the
renderer's reader, runtime.prims.truetype, reads the outlines with numpy and shares the
table directory, cmap and kern readers below).
"""

from __future__ import annotations

import functools
import struct
from dataclasses import dataclass

# cmap subtables in POV-Ray 3.7's order of preference for its default (UTF-8) strings:
# Unicode, Microsoft Unicode, Macintosh Roman, Microsoft symbol.
CMAP_ORDER = ((0, 3), (3, 1), (1, 0), (3, 0))


class FontError(ValueError):
    """The file is not a TrueType font this reader understands."""


@dataclass(frozen=True)
class GlyphMetrics:
    """In em units: advance width, left side bearing and the glyph's box (None: no outline)."""

    index: int
    advance: float
    lsb: float
    box: tuple[float, float, float, float] | None  # xmin, ymin, xmax, ymax


class FontMetrics:
    def __init__(self, data: bytes):
        self._data = data
        self._tables = {tag: at for tag, (at, _) in table_directory(data).items()}
        head = self._tables["head"]
        self.units_per_em = self._u16(head + 18)
        if not 16 <= self.units_per_em <= 16384:
            raise FontError(f"unitsPerEm {self.units_per_em} is out of range")
        self._long_loca = self._i16(head + 50) == 1
        self.num_glyphs = self._u16(self._tables["maxp"] + 4)
        self._n_metrics = self._u16(self._tables["hhea"] + 34)
        self.cmap = read_cmap(data, self._tables["cmap"])
        self.kern = read_kern(data, self._tables.get("kern"))

    def _u16(self, at: int) -> int:
        return struct.unpack_from(">H", self._data, at)[0]

    def _i16(self, at: int) -> int:
        return struct.unpack_from(">h", self._data, at)[0]

    def _u32(self, at: int) -> int:
        return struct.unpack_from(">I", self._data, at)[0]

    def _loca(self, i: int) -> int:
        at = self._tables["loca"]
        return self._u32(at + 4 * i) if self._long_loca else 2 * self._u16(at + 2 * i)

    def glyph(self, char: str) -> GlyphMetrics:
        index = self.cmap.get(ord(char), 0)
        em = float(self.units_per_em)
        hmtx = self._tables["hmtx"]
        m = min(index, self._n_metrics - 1)
        advance = self._u16(hmtx + 4 * m)
        if index < self._n_metrics:
            lsb = self._i16(hmtx + 4 * index + 2)
        elif index < self.num_glyphs:
            lsb = self._i16(hmtx + 4 * self._n_metrics + 2 * (index - self._n_metrics))
        else:
            lsb = 0
        box = None
        if 0 <= index < self.num_glyphs and self._loca(index + 1) > self._loca(index):
            at = self._tables["glyf"] + self._loca(index)
            head = [self._i16(at + 2 + 2 * k) for k in range(4)]
            if self._i16(at) > 0:
                head = self._grow_to_points(at, self._i16(at), head)
            box = tuple(v / em for v in head)
        return GlyphMetrics(index, advance / em, lsb / em, box)  # type: ignore[arg-type]

    def _grow_to_points(self, at: int, nc: int, head: list[int]) -> list[int]:
        """A simple glyph's header box grown to its outline points, as POV-Ray does (some
        fonts' headers are wrong: timrom.ttf's and cyrvetic.ttf's xMax is the glyph's
        width, so their points reach xMin further right than the header says)."""
        data = self._data
        n = self._u16(at + 10 + 2 * (nc - 1)) + 1
        pos = at + 10 + 2 * nc
        pos += 2 + self._u16(pos)  # skip the instructions
        flags = bytearray()
        while len(flags) < n:
            f = data[pos]
            pos += 1
            flags.append(f)
            if f & 0x08:  # repeat
                flags.extend([f] * data[pos])
                pos += 1
        del flags[n:]
        x0, y0, x1, y1 = head
        for axis, (short, same) in enumerate(((0x02, 0x10), (0x04, 0x20))):
            v = 0
            lo, hi = (x0, x1) if axis == 0 else (y0, y1)
            for f in flags:
                if f & short:
                    v += data[pos] if f & same else -data[pos]
                    pos += 1
                elif not f & same:
                    v += self._i16(pos)
                    pos += 2
                lo, hi = min(lo, v), max(hi, v)
            if axis == 0:
                x0, x1 = lo, hi
            else:
                y0, y1 = lo, hi
        return [x0, y0, x1, y1]


@functools.lru_cache(maxsize=16)
def load(path: str) -> FontMetrics:
    with open(path, "rb") as f:
        return FontMetrics(f.read())


def text_box(
    path: str, string: str, thickness: float, offset: tuple[float, float, float]
) -> tuple[tuple[float, float, float], tuple[float, float, float]] | None:
    """The box of the glyph boxes of `text { ttf path string thickness, offset }`, laid out
    as the renderer does (runtime.prims.text: the first glyph's left edge at x = 0, the pen
    advancing by advance widths, kerning and the offset); None when nothing has an outline.
    The glyph boxes are POV-Ray's: the glyph header's box grown to the outline's points."""
    font = load(path)
    em = font.units_per_em
    pen_x = pen_y = 0.0
    last = 0
    xs: list[float] = []
    ys: list[float] = []
    for i, ch in enumerate(string):
        g = font.glyph(ch)
        box = (0.0, 0.0, 0.0, 0.0) if ch == " " else g.box  # POV-Ray reads no header
        xmin = box[0] if box else 0.0
        if i == 0:
            x0 = -xmin
            pen_x = g.advance - g.lsb
        else:
            kern = max(font.kern.get((last, g.index), 0), -em) / em
            x0 = pen_x + g.lsb + kern - xmin
            pen_x += g.advance + kern
        y0 = pen_y
        pen_x += offset[0]
        pen_y += offset[1]
        last = g.index
        if box:
            xs += [x0 + box[0], x0 + box[2]]
            ys += [y0 + box[1], y0 + box[3]]
    if not xs:
        return None
    return (min(xs), min(ys), 0.0), (max(xs), max(ys), float(thickness))


# ------------------------------------------------- tables both font readers share
def _u16(data: bytes, at: int) -> int:
    return struct.unpack_from(">H", data, at)[0]


def _i16(data: bytes, at: int) -> int:
    return struct.unpack_from(">h", data, at)[0]


def _u32(data: bytes, at: int) -> int:
    return struct.unpack_from(">I", data, at)[0]


def table_directory(data: bytes) -> dict[str, tuple[int, int]]:
    """Each table's (offset, length); a collection (ttcf) gives its first font's tables."""
    base = _u32(data, 12) if data[:4] == b"ttcf" else 0
    tables: dict[str, tuple[int, int]] = {}
    for i in range(_u16(data, base + 4)):
        rec = base + 12 + 16 * i
        tables[data[rec : rec + 4].decode("latin-1")] = (_u32(data, rec + 8), _u32(data, rec + 12))
    for need in ("head", "cmap", "glyf", "loca", "hhea", "hmtx", "maxp"):
        if need not in tables:
            raise FontError(f"the font has no `{need}` table")
    return tables


def read_cmap(data: bytes, cmap: int) -> dict[int, int]:
    """Character code → glyph index from the first usable subtable in CMAP_ORDER."""
    subtables: dict[tuple[int, int], int] = {}
    for i in range(_u16(data, cmap + 2)):
        rec = cmap + 4 + 8 * i
        subtables.setdefault((_u16(data, rec), _u16(data, rec + 2)), cmap + _u32(data, rec + 4))
    for key in CMAP_ORDER:
        if key in subtables:
            table = _cmap_table(data, subtables[key])
            if table is not None:
                return table
    return {}


def _cmap_table(data: bytes, at: int) -> dict[int, int] | None:
    """One cmap subtable of format 0, 4 or 6 (None for the others)."""
    fmt = _u16(data, at)
    out: dict[int, int] = {}
    if fmt == 0:
        for c in range(256):
            out[c] = data[at + 6 + c]
    elif fmt == 4:
        segs = _u16(data, at + 6) // 2
        ends = at + 14
        starts = ends + 2 * segs + 2
        deltas = starts + 2 * segs
        ranges = deltas + 2 * segs
        for s in range(segs):
            end, start = _u16(data, ends + 2 * s), _u16(data, starts + 2 * s)
            delta, roff = _i16(data, deltas + 2 * s), _u16(data, ranges + 2 * s)
            for c in range(start, min(end, 0xFFFE) + 1):
                if roff == 0:
                    out[c] = (c + delta) & 0xFFFF
                else:
                    g = _u16(data, ranges + 2 * s + roff + 2 * (c - start))
                    out[c] = (g + delta) & 0xFFFF if g else 0
    elif fmt == 6:
        first, count = _u16(data, at + 6), _u16(data, at + 8)
        for i in range(count):
            out[first + i] = _u16(data, at + 10 + 2 * i)
    else:
        return None
    return out


def read_kern(data: bytes, kern: int | None) -> dict[tuple[int, int], int]:
    """Horizontal format-0 kerning pairs, in font units (later subtables add, or override
    when their coverage says so; Apple's long header is not read)."""
    out: dict[tuple[int, int], int] = {}
    if kern is None or _u16(data, kern) != 0:
        return out
    pos = kern + 4
    for _ in range(_u16(data, kern + 2)):
        length, coverage = _u16(data, pos + 2), _u16(data, pos + 4)
        if coverage >> 8 == 0 and coverage & 0x01 and not coverage & 0x06:
            for i in range(_u16(data, pos + 6)):
                rec = pos + 14 + 6 * i
                key = (_u16(data, rec), _u16(data, rec + 2))
                val = _i16(data, rec + 4)
                out[key] = val if coverage & 0x08 else out.get(key, 0) + val
        pos += length
    return out
