"""Pigment evaluation, vectorised over hit points: (N,3) world points → (N,5) RGBFT colours.

A pigment is evaluated at inverse(pigment.transform) @ p_world (see `ir`); every pigment in
the tree carries its own fully composed transform, so sub-pigments are evaluated at world
points too. Pattern values follow POV-Ray 3.7:
- list patterns (checker, hexagon, brick) give an integer index into their colour list and
  never go through frequency/phase/wave (POV-Ray sets their frequency to 0);
- continuous patterns give a value that goes through `frequency` and `phase`
  (fmod(v*f + p, 1.00001), negatives wrapped), then the wave type, then the colour map or
  pigment map (linear interpolation between neighbouring entries, clamped at the ends).
Unknown patterns render as the pattern's first colour with one warning each.
"""

from __future__ import annotations

import math
from functools import lru_cache

import numpy as np

from lang import ir

# POV-Ray's Small_Tolerance: checker adds it to every coordinate before flooring, so a
# plane at an integer coordinate (y = 0, the classic floor) does not flicker between cells.
CHECKER_OFFSET: float = 1e-3

# POV-Ray wraps frequency/phase with fmod(…, 1.00001) so that a value of exactly 1.0 (the
# last colour map entry) stays reachable.
WAVE_MODULUS: float = 1.00001

_BLUE = (0.0, 0.0, 1.0, 0.0, 0.0)
_GREEN = (0.0, 1.0, 0.0, 0.0, 0.0)
_RED = (1.0, 0.0, 0.0, 0.0, 0.0)
_WHITE = (1.0, 1.0, 1.0, 0.0, 0.0)
_BLACK = (0.0, 0.0, 0.0, 0.0, 0.0)

# POV-Ray's default colours for list patterns written without a list.
DEFAULT_LISTS: dict[str, tuple[ir.Color, ...]] = {
    "checker": (_BLUE, _GREEN),
    "hexagon": (_BLUE, _GREEN, _RED),
    "brick": (_WHITE, _RED),  # mortar, brick
}
# Without a colour map, continuous patterns ramp from black to white.
DEFAULT_MAP: tuple[tuple[float, ir.Color], ...] = ((0.0, _BLACK), (1.0, _WHITE))

_warned: set[str] = set()


def _warn(msg: str) -> None:
    if msg not in _warned:
        _warned.add(msg)
        print(f"strala: warning: {msg}")


@lru_cache(maxsize=4096)
def _inverse(m: ir.Matrix) -> np.ndarray | None:
    """Inverse of a pattern transform (None for the identity, the common case)."""
    a = np.asarray(m, dtype=np.float64)
    if np.array_equal(a, np.eye(4)):
        return None
    return np.linalg.inv(a)


def pattern_points(pigment: ir.Pigment | ir.Normal, points: np.ndarray) -> np.ndarray:
    inv = _inverse(pigment.transform)
    if inv is None:
        return points
    return points @ inv[:3, :3].T + inv[:3, 3]


def evaluate(pigment: ir.Pigment, points: np.ndarray) -> np.ndarray:
    """(N,5) float64 RGBFT colours of `pigment` at world points (N,3)."""
    points = np.asarray(points, dtype=np.float64).reshape(-1, 3)
    n = len(points)
    kind = pigment.pattern
    if kind == "solid":
        return np.broadcast_to(np.asarray(pigment.color, dtype=np.float64), (n, 5)).copy()
    p = pattern_points(pigment, points)
    if kind in LIST_PATTERNS:
        index = LIST_PATTERNS[kind](p, pigment.params)
        return _select(pigment, kind, index, points)
    fn = CONTINUOUS_PATTERNS.get(kind)
    if fn is None:
        _warn(f"pigment pattern `{kind}` is not supported yet: using its first colour")
        return _fallback(pigment, points)
    value = apply_wave(fn(p, pigment.params), pigment.params)
    return _map(pigment, value, points)


# --------------------------------------------------------------- list patterns
def checker(p: np.ndarray, params: dict) -> np.ndarray:
    s = np.floor(p + CHECKER_OFFSET).sum(axis=1)
    return (s.astype(np.int64) & 1).astype(np.int64)


_SQRT3 = math.sqrt(3.0)


def hexagon(p: np.ndarray, params: dict) -> np.ndarray:
    """Hexagons of side 1 in the x-z plane, a corner pointing along x, the one at the
    origin coloured by the first entry; three colours so no neighbours share one."""
    x = p[:, 0]
    z = p[:, 2]
    # Axial coordinates of the hexagonal lattice (centres 1.5 apart in x, sqrt(3) in z),
    # then cube rounding to the nearest centre.
    q = (2.0 / 3.0) * x
    r = -x / 3.0 + z / _SQRT3
    cx, cz = q, r
    cy = -cx - cz
    rx, ry, rz = np.round(cx), np.round(cy), np.round(cz)
    dx, dy, dz = np.abs(rx - cx), np.abs(ry - cy), np.abs(rz - cz)
    fix_x = (dx > dy) & (dx > dz)
    fix_y = ~fix_x & (dy > dz)
    rx = np.where(fix_x, -ry - rz, rx)
    ry = np.where(fix_y, -rx - rz, ry)
    rz = np.where(~fix_x & ~fix_y, -rx - ry, rz)
    return np.mod(2 * rx + rz, 3).astype(np.int64)


def brick(p: np.ndarray, params: dict) -> np.ndarray:
    """0 = mortar, 1 = brick, laid out as POV-Ray does: bricks `brick_size` (default
    <8,3,4.5>) with joints `mortar` thick (default 0.5), everything shifted by mortar plus
    Small_Tolerance so the joints do not sit on the axes; in even courses (counting in y) the
    end joints (x) are on the grid and the face joints (z) half a brick off, in odd courses
    the other way round."""
    size = np.broadcast_to(np.asarray(params.get("brick_size", (8.0, 3.0, 4.5)), float), (3,))
    mortar = float(params.get("mortar", 0.5))
    q = p + (CHECKER_OFFSET + mortar)
    x, y, z = (q[:, i] / size[i] for i in range(3))
    frac = lambda v: v - np.floor(v)  # noqa: E731
    bed = frac(y) <= mortar / size[1]
    odd = frac(0.5 * y) > 0.5
    end_x = np.where(odd, frac(x + 0.5), frac(x)) <= mortar / size[0]
    face_z = np.where(odd, frac(z), frac(z + 0.5)) <= mortar / size[2]
    return np.where(bed | end_x | face_z, 0, 1).astype(np.int64)


LIST_PATTERNS = {"checker": checker, "hexagon": hexagon, "brick": brick}


def _select(pigment: ir.Pigment, kind: str, index: np.ndarray, points: np.ndarray) -> np.ndarray:
    entries: tuple = pigment.list or tuple(ir.Pigment(color=c) for c in DEFAULT_LISTS[kind])
    out = np.zeros((len(points), 5))
    index = np.minimum(index, len(entries) - 1)
    for i, sub in enumerate(entries):
        rows = np.nonzero(index == i)[0]
        if len(rows):
            out[rows] = evaluate(sub, points[rows])
    return out


# --------------------------------------------------------- continuous patterns
def gradient(p: np.ndarray, params: dict) -> np.ndarray:
    g = np.asarray(params.get("orientation", (1.0, 0.0, 0.0)), dtype=np.float64)
    return p @ g


def onion(p: np.ndarray, params: dict) -> np.ndarray:
    return np.linalg.norm(p, axis=1)


def spherical(p: np.ndarray, params: dict) -> np.ndarray:
    return np.clip(1.0 - np.linalg.norm(p, axis=1), 0.0, 1.0)


def cylindrical(p: np.ndarray, params: dict) -> np.ndarray:
    return np.clip(1.0 - np.hypot(p[:, 0], p[:, 2]), 0.0, 1.0)


def planar(p: np.ndarray, params: dict) -> np.ndarray:
    return np.clip(1.0 - np.abs(p[:, 1]), 0.0, 1.0)


def boxed(p: np.ndarray, params: dict) -> np.ndarray:
    return np.clip(1.0 - np.abs(p).max(axis=1), 0.0, 1.0)


def leopard(p: np.ndarray, params: dict) -> np.ndarray:
    return (np.sin(p).sum(axis=1) / 3.0) ** 2


CONTINUOUS_PATTERNS = {
    "gradient": gradient,
    "onion": onion,
    "spherical": spherical,
    "cylindrical": cylindrical,
    "planar": planar,
    "boxed": boxed,
    "leopard": leopard,
}


def apply_wave(value: np.ndarray, params: dict) -> np.ndarray:
    """POV-Ray's frequency/phase wrap, then the wave type."""
    freq = float(params.get("frequency", 1.0))
    phase = float(params.get("phase", 0.0))
    if freq != 0.0:
        value = np.fmod(value * freq + phase, WAVE_MODULUS)
    value = np.where(value < 0.0, value - np.floor(value), value)
    wave = params.get("wave", "ramp_wave")
    if wave == "sine_wave":
        value = (1.0 + np.sin(value * 2.0 * math.pi)) * 0.5
    elif wave == "triangle_wave":
        f = value - np.floor(value)
        value = np.where(f < 0.5, 2.0 * f, 2.0 - 2.0 * f)
    elif wave == "scallop_wave":
        value = np.abs(np.sin(value * math.pi))
    elif wave == "cubic_wave":
        value = value * value * (3.0 - 2.0 * value)
    elif wave == "poly_wave":
        value = np.power(value, float(params.get("exponent", 1.0)))
    return value


def _map(pigment: ir.Pigment, value: np.ndarray, points: np.ndarray) -> np.ndarray:
    if pigment.pigment_map:
        keys = np.array([k for k, _ in pigment.pigment_map], dtype=np.float64)
        lo, hi, frac = blend_indices(keys, value)
        out = np.zeros((len(value), 5))
        for i, (_, sub) in enumerate(pigment.pigment_map):
            use_lo = lo == i
            use_hi = hi == i
            rows = np.nonzero(use_lo | use_hi)[0]
            if not len(rows):
                continue
            col = evaluate(sub, points[rows])
            w = np.where(use_lo[rows], 1.0 - frac[rows], 0.0) + np.where(
                use_hi[rows], frac[rows], 0.0
            )
            out[rows] += w[:, None] * col
        return out
    cmap = pigment.color_map or DEFAULT_MAP
    keys = np.array([k for k, _ in cmap], dtype=np.float64)
    cols = np.array([c for _, c in cmap], dtype=np.float64)
    lo, hi, frac = blend_indices(keys, value)
    return cols[lo] * (1.0 - frac[:, None]) + cols[hi] * frac[:, None]


def blend_indices(keys: np.ndarray, value: np.ndarray):
    """POV-Ray's Search_Blend_Map, vectorised: for each value the two entries to blend
    (lo, hi) and the weight of hi. Below the first key: the first entry; at or above the
    last: the last; otherwise the first key >= value and its predecessor."""
    n = len(keys)
    hi = np.searchsorted(keys, value, side="left")
    hi = np.clip(hi, 0, n - 1)
    lo = np.maximum(hi - 1, 0)
    at_or_past_end = value >= keys[-1]
    hi = np.where(at_or_past_end, n - 1, hi)
    exact = keys[hi] == value
    lo = np.where(at_or_past_end | exact | (value <= keys[0]), hi, lo)
    span = keys[hi] - keys[lo]
    with np.errstate(divide="ignore", invalid="ignore"):
        frac = np.where(span > 0, (value - keys[lo]) / np.where(span > 0, span, 1.0), 0.0)
    return lo, hi, frac


def _fallback(pigment: ir.Pigment, points: np.ndarray) -> np.ndarray:
    if pigment.list:
        return evaluate(pigment.list[0], points)
    if pigment.color_map:
        c = pigment.color_map[0][1]
    elif pigment.pigment_map:
        return evaluate(pigment.pigment_map[0][1], points)
    else:
        c = pigment.color
    return np.broadcast_to(np.asarray(c, dtype=np.float64), (len(points), 5)).copy()


# --------------------------------------------------------------- properties
def may_transmit(pigment: ir.Pigment) -> bool:
    """Can any point of this pigment let light through (filter or transmit > 0)?"""
    if pigment.pattern == "solid":
        return pigment.color[3] > 0 or pigment.color[4] > 0
    if any(c[3] > 0 or c[4] > 0 for _, c in pigment.color_map):
        return True
    return any(may_transmit(q) for q in pigment.list) or any(
        may_transmit(q) for _, q in pigment.pigment_map
    )
