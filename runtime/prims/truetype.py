"""A minimal TrueType reader for `text`: the glyph outlines (simple and composite glyphs
from glyf/loca), the character map (cmap formats 0, 4 and 6), advance widths and left side
bearings (hmtx), horizontal kerning pairs (kern format 0) and unitsPerEm (head).

Outlines come out as quadratic segments (lines are degenerate quadratics) in em units
(font units / unitsPerEm), the form POV-Ray sweeps. Parsed fonts are cached by path.
"""

from __future__ import annotations

import functools
import struct
from dataclasses import dataclass, field

import numpy as np

from lang import font_metrics
from lang.font_metrics import FontError

ON_CURVE = 0x01
X_SHORT, Y_SHORT, REPEAT = 0x02, 0x04, 0x08
X_SAME, Y_SAME = 0x10, 0x20
ARG_WORDS, ARGS_XY, HAVE_SCALE, MORE, HAVE_XY_SCALE, HAVE_2X2, MY_METRICS = (
    0x0001,
    0x0002,
    0x0008,
    0x0020,
    0x0040,
    0x0080,
    0x0200,
)


@dataclass
class Glyph:
    """Outline of one glyph: contours as lists of (x, y, on_curve) in em units, the
    bounding box's xMin (em) and the glyph whose metrics apply."""

    contours: list[list[tuple[float, float, bool]]] = field(default_factory=list)
    xmin: float = 0.0
    metrics: int = 0


class Font:
    def __init__(self, data: bytes):
        self.data = data
        self.tables = font_metrics.table_directory(data)
        head = self.tables["head"][0]
        self.units_per_em = self._u16(head + 18)
        if not 16 <= self.units_per_em <= 16384:
            raise FontError(f"unitsPerEm {self.units_per_em} is out of range")
        long_loca = self._i16(head + 50) == 1
        self.num_glyphs = self._u16(self.tables["maxp"][0] + 4)
        loca = self.tables["loca"][0]
        n = self.num_glyphs + 1
        if long_loca:
            self.loca = np.frombuffer(data, dtype=">u4", count=n, offset=loca).astype(np.int64)
        else:
            self.loca = np.frombuffer(data, dtype=">u2", count=n, offset=loca).astype(np.int64) * 2
        n_metrics = self._u16(self.tables["hhea"][0] + 34)
        hmtx = self.tables["hmtx"][0]
        pairs = np.frombuffer(data, dtype=">i2", count=2 * n_metrics, offset=hmtx).reshape(-1, 2)
        self.advance = pairs[:, 0].astype(np.int64) & 0xFFFF
        lsb = list(pairs[:, 1].astype(np.int64))
        extra = self.num_glyphs - n_metrics
        if extra > 0:
            more = np.frombuffer(data, dtype=">i2", count=extra, offset=hmtx + 4 * n_metrics)
            lsb.extend(more.astype(np.int64))
        self.lsb = np.array(lsb, dtype=np.int64)
        self.cmap = font_metrics.read_cmap(data, self.tables["cmap"][0])
        self.kern = font_metrics.read_kern(data, self.tables.get("kern", (None,))[0])
        self._glyphs: dict[int, Glyph] = {}

    # ------------------------------------------------------------------ reading
    def _u16(self, at: int) -> int:
        return struct.unpack_from(">H", self.data, at)[0]

    def _i16(self, at: int) -> int:
        return struct.unpack_from(">h", self.data, at)[0]

    def _u32(self, at: int) -> int:
        return struct.unpack_from(">I", self.data, at)[0]

    # ------------------------------------------------------------------- glyphs
    def glyph_index(self, char: str) -> int:
        return self.cmap.get(ord(char), 0)

    def glyph(self, index: int) -> Glyph:
        if index not in self._glyphs:
            self._glyphs[index] = self._read_glyph(index, depth=0)
        return self._glyphs[index]

    def _read_glyph(self, index: int, depth: int) -> Glyph:
        g = Glyph(metrics=index)
        if not 0 <= index < self.num_glyphs or depth > 8:
            return g
        start = self.tables["glyf"][0] + int(self.loca[index])
        if self.loca[index + 1] <= self.loca[index]:
            return g  # no outline (a space)
        nc = self._i16(start)
        em = float(self.units_per_em)
        g.xmin = self._i16(start + 2) / em
        if nc > 0:
            g.contours = self._simple(start, nc)
        elif nc < 0:
            self._composite(start + 10, g, depth)
        if g.contours:
            g.xmin = min(g.xmin, min(x for c in g.contours for x, _, _ in c))
        return g

    def _simple(self, start: int, nc: int) -> list[list[tuple[float, float, bool]]]:
        data = self.data
        ends = [self._u16(start + 10 + 2 * i) for i in range(nc)]
        pos = start + 10 + 2 * nc
        pos += 2 + self._u16(pos)  # skip the instructions
        n = ends[-1] + 1
        flags: list[int] = []
        while len(flags) < n:
            f = data[pos]
            pos += 1
            flags.append(f)
            if f & REPEAT:
                flags.extend([f] * data[pos])
                pos += 1
        flags = flags[:n]
        coords = []
        for short, same in ((X_SHORT, X_SAME), (Y_SHORT, Y_SAME)):
            v = 0
            vals = []
            for f in flags:
                if f & short:
                    d = data[pos]
                    pos += 1
                    v += d if f & same else -d
                elif not f & same:
                    v += self._i16(pos)
                    pos += 2
                vals.append(v)
            coords.append(vals)
        em = float(self.units_per_em)
        contours, first = [], 0
        for e in ends:
            contours.append(
                [
                    (coords[0][i] / em, coords[1][i] / em, bool(flags[i] & ON_CURVE))
                    for i in range(first, e + 1)
                ]
            )
            first = e + 1
        return contours

    def _composite(self, pos: int, g: Glyph, depth: int) -> None:
        em = float(self.units_per_em)
        while True:
            flags = self._u16(pos)
            sub = self._u16(pos + 2)
            pos += 4
            if flags & ARG_WORDS:
                a1, a2 = self._i16(pos), self._i16(pos + 2)
                pos += 4
            else:
                a1, a2 = struct.unpack_from(">bb", self.data, pos)
                pos += 2
            m = [1.0, 0.0, 0.0, 1.0]
            if flags & HAVE_SCALE:
                m[0] = m[3] = self._i16(pos) / 16384
                pos += 2
            elif flags & HAVE_XY_SCALE:
                m[0], m[3] = self._i16(pos) / 16384, self._i16(pos + 2) / 16384
                pos += 4
            elif flags & HAVE_2X2:
                m = [self._i16(pos + 2 * i) / 16384 for i in range(4)]
                pos += 8
            if flags & MY_METRICS:
                g.metrics = sub
            # Point-matched placement (args are point numbers) is skipped, as POV-Ray does.
            if flags & ARGS_XY:
                part = self._read_glyph(sub, depth + 1)
                dx, dy = a1 / em, a2 / em
                for c in part.contours:
                    g.contours.append(
                        [(m[0] * x + m[2] * y + dx, m[1] * x + m[3] * y + dy, on) for x, y, on in c]
                    )
            if not flags & MORE:
                break


@functools.lru_cache(maxsize=16)
def load_font(path: str) -> Font:
    with open(path, "rb") as fh:
        data = fh.read()
    try:
        return Font(data)
    except (struct.error, IndexError, ValueError) as exc:
        if isinstance(exc, FontError):
            raise FontError(f"font `{path}`: {exc}") from None
        raise FontError(f"`{path}` is not a readable TrueType font (truncated or corrupt)") from exc


def contour_segments(contour: list[tuple[float, float, bool]]) -> np.ndarray:
    """(S, 2, 4) polynomial segments (lines and quadratic Béziers, as cubic coefficients
    [a, b, c, d] per axis) of one closed TrueType contour. Two off-curve points in a row
    imply the on-curve point halfway between them."""
    pts = [(np.array([x, y]), on) for x, y, on in contour]
    if not pts:
        return np.zeros((0, 2, 4))
    # Start on an on-curve point (or the midpoint of the first two off-curve points).
    k = next((i for i, (_, on) in enumerate(pts) if on), None)
    if k is None:
        start = 0.5 * (pts[0][0] + pts[1][0]) if len(pts) > 1 else pts[0][0]
        seq = pts + [pts[0]]
    else:
        start = pts[k][0]
        seq = pts[k + 1 :] + pts[: k + 1]
    segs = []
    cur = start
    ctrl = None
    for p, on in seq:
        if on:
            segs.append(_line(cur, p) if ctrl is None else _quad(cur, ctrl, p))
            cur, ctrl = p, None
        elif ctrl is None:
            ctrl = p
        else:
            mid = 0.5 * (ctrl + p)
            segs.append(_quad(cur, ctrl, mid))
            cur, ctrl = mid, p
    if ctrl is not None:  # the contour ended on a control point: close through it
        segs.append(_quad(cur, ctrl, start))
    elif np.any(cur != start):
        segs.append(_line(cur, start))
    out = np.array(segs).reshape(-1, 2, 4)
    # Zero-length lines carry no wall.
    length = np.abs(out[:, :, :3]).sum(axis=(1, 2))
    return out[length > 0]


def _line(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    return np.stack([[0.0, 0.0, b[i] - a[i], a[i]] for i in range(2)])


def _quad(a: np.ndarray, c: np.ndarray, b: np.ndarray) -> np.ndarray:
    return np.stack([[0.0, a[i] - 2 * c[i] + b[i], 2 * (c[i] - a[i]), a[i]] for i in range(2)])
