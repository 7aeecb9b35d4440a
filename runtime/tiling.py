"""The `tiling N` pattern: POV-Ray 3.7's tilings of the x-z plane (pattern.cpp), over
arrays of pattern-space points.

Each tiling folds the point into one cell by its symmetries and gives a value from the
tile's edge: with one kind of tile, 1 on the outline and 0 deepest inside; with two or
three kinds, each kind keeps to its own band of [0, 1] (two: [0, 1/2] and [1/2, 1];
three: thirds), so a colour map can tell the tiles apart. The value then goes through
frequency, phase, wave and the map as any continuous pattern's.

Rendered so far: 1 square, 2 hexagon, 3 triangle, 4 lozenge, 5 rhombus, 6 rectangle,
7 octagon and square, 8 square and triangle, 9 hexagon and triangle, 10 offset squares
(`RENDERED`); the other numbers give 0.
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np

SQRT3 = math.sqrt(3.0)
SQRT3_2 = SQRT3 / 2.0
SQRT2 = math.sqrt(2.0)
SQRT2_2 = SQRT2 / 2.0


def _fold(v: np.ndarray, period: float) -> np.ndarray:
    """v into [0, period), as POV-Ray's v - period * floor(v / period)."""
    return v - period * np.floor(v / period)


def _square(x: np.ndarray, z: np.ndarray) -> np.ndarray:
    x = np.abs(x)
    x = 2.0 * np.abs(x - np.floor(x) - 0.5)
    z = np.abs(z)
    z = 2.0 * np.abs(z - np.floor(z) - 0.5)
    return np.maximum(x, z)


def _hexagon(x: np.ndarray, z: np.ndarray) -> np.ndarray:
    x = _fold(x + 0.5, 3.0)
    z = _fold(z, SQRT3)
    z = np.where(z > SQRT3_2, SQRT3 - z, z)
    right = x > 1.5
    x = np.where(right, x - 1.5, x)
    z = np.where(right, SQRT3_2 - z, z)
    corner = SQRT3 * x + z < SQRT3_2
    x = np.where(corner, 0.5 - x, x)
    z = np.where(corner, SQRT3_2 - z, z)
    x = np.where(x > 1.0, 2.0 - x, x)
    d1 = 1.0 - z / SQRT3_2
    d2 = 1.0 - (SQRT3 * x + z - SQRT3_2) / SQRT3
    return np.clip(np.maximum(d1, d2), 0.0, 1.0)


def _steep(x: np.ndarray, z: np.ndarray) -> np.ndarray:
    """Where the slope z/x is over sqrt 3 (x = 0 counts only where the caller says)."""
    with np.errstate(divide="ignore", invalid="ignore"):
        return (x != 0.0) & (z / np.where(x != 0.0, x, 1.0) > SQRT3)


def _triangle(x: np.ndarray, z: np.ndarray) -> np.ndarray:
    x = x - np.floor(x)
    z = _fold(z, SQRT3)
    delta = np.zeros_like(x)
    top = z > SQRT3_2
    z = np.where(top, SQRT3 - z, z)
    delta = np.where(top, 1.0 - delta, delta)
    x = np.where(x > 0.5, 1.0 - x, x)
    steep = _steep(x, z)
    # on x = 0 POV-Ray mirrors too, but keeps the parity
    flip = steep | (x == 0.0)
    z = np.where(flip, SQRT3_2 - z, z)
    x = np.where(flip, np.where(x == 0.0, 0.5, 0.5 - x), x)
    delta = np.where(steep, 1.0 - delta, delta)
    d1 = 1.0 - z * 2.0 * SQRT3
    d2 = 1.0 - (SQRT3 * x - z) * SQRT3
    return delta / 2.0 + 0.5 * np.maximum(d1, d2)


def _lozenge_core(x: np.ndarray, z: np.ndarray) -> np.ndarray:
    """The lozenge's last folds and value, shared with the rhombus."""
    high = 2.0 * z > SQRT3_2
    z = np.where(high, SQRT3_2 - z, z)
    x = np.where(high, 1.5 - x, x)
    x = np.where(x > 0.75, x - 1.0, x)
    flip = _steep(x, z)
    z = np.where(flip, SQRT3_2 - z, z)
    x = np.where(flip, 0.5 - x, x)
    d1 = 1.0 - z * 4.0 * SQRT3 / 3.0
    d2 = 1.0 - np.abs(SQRT3 * x - z) * SQRT3 * 2.0 / 3.0
    return np.maximum(d1, d2)


def _lozenge(x: np.ndarray, z: np.ndarray) -> np.ndarray:
    x = x - np.floor(x)
    z = _fold(z, SQRT3)
    top = z > SQRT3_2
    z = np.where(top, z - SQRT3_2, z)
    x = np.where(top, x + 0.5, x)
    return _lozenge_core(x, z)


def _rhombus(x: np.ndarray, z: np.ndarray) -> np.ndarray:
    x = _fold(x + 0.5, 3.0)
    z = _fold(z, SQRT3)
    delta = np.zeros_like(x)
    top = z > SQRT3_2
    z = np.where(top, SQRT3 - z, z)
    delta = np.where(top, 2.0 - delta, delta)
    right = x > 1.5
    x = np.where(right, x - 1.5, x)
    z = np.where(right, SQRT3_2 - z, z)
    delta = np.where(right, 2.0 - delta, delta)
    left = x < 0.5
    x = np.where(left, 1.0 - x, x)
    delta = np.where(left, 2.0 - delta, delta)
    x = x - 0.5
    turn = _steep(x, z) | (x == 0.0)
    # the vertical rhombus turned onto the horizontal one on its right
    tx = x / 2.0 + z * SQRT3_2
    tz = z / 2.0 - x * SQRT3_2
    x = np.where(turn, tx, x)
    z = np.where(turn, tz, z)
    delta = np.where(turn, 1.0, delta)
    answer = _lozenge_core(x, z) / 3.0 + delta / 3.0
    return np.clip(answer, 0.0, 1.0)


# The rectangle tiling's 16 unit cells of its 4 x 4 block: the shift to the cell's
# rectangle and whether that rectangle lies along z (1) or along x (0)
_RECTANGLE_CELLS = {
    0: (0, -1, 1), 4: (0, -1, 1), 1: (-2, 0, 0), 2: (-2, 0, 0), 3: (-3, 0, 1),
    5: (-1, -2, 1), 9: (-1, -2, 1), 6: (-3, -1, 0), 7: (-3, -1, 0), 8: (0, -2, 0),
    10: (-2, -3, 1), 14: (-2, -3, 1), 11: (-4, -2, 0), 12: (-1, -3, 0), 13: (-1, -3, 0),
    15: (-3, -4, 1),
}  # fmt: skip
# a fold that rounds up to 4 (a coordinate a hair below a multiple of 4) gives a cell past
# the block, which POV-Ray leaves unshifted along z, values past 1 and all
_RECT_TABLE = np.array([_RECTANGLE_CELLS.get(k, (0, 0, 1)) for k in range(21)], dtype=np.float64)


def _rectangle(x: np.ndarray, z: np.ndarray) -> np.ndarray:
    x = _fold(x, 4.0)
    z = _fold(z, 4.0)
    cell = (x.astype(np.int64) + 4 * z.astype(np.int64)).clip(0, 20)
    shift = _RECT_TABLE[cell]
    x = x + shift[:, 0]
    z = z + shift[:, 1]
    delta = shift[:, 2]
    along_z = delta == 1.0
    ax = np.where(along_z, 2.0 * np.abs(x - 0.5), 2.0 * (np.maximum(np.abs(x), 0.5) - 0.5))
    az = np.where(along_z, 2.0 * (np.maximum(np.abs(z), 0.5) - 0.5), 2.0 * np.abs(z - 0.5))
    return np.abs(np.maximum(ax, az) / 2.0 + delta / 2.0)


def _octa_square(x: np.ndarray, z: np.ndarray) -> np.ndarray:
    period = SQRT2 + 1.0
    z = np.abs(_fold(z, period) - (SQRT2_2 + 0.5))
    x = np.abs(_fold(x, period) - (SQRT2_2 + 0.5))
    x, z = np.maximum(x, z), np.minimum(x, z)
    square = x + z < SQRT2_2
    d1 = 1.0 - z
    d2 = (SQRT2 + SQRT2_2 - (x + z)) / SQRT2
    # POV-Ray keeps the octagons just above one half
    octagon = np.maximum(0.500000000001, np.maximum(d1, d2))
    return np.where(square, (x + z) / SQRT2, octagon)


def _square_triangle(x: np.ndarray, z: np.ndarray) -> np.ndarray:
    x = x - np.floor(x)
    z = _fold(z, 2.0 + SQRT3)
    upper = z > SQRT3_2 + 1.0
    z = np.where(upper, z - (SQRT3_2 + 1.0), z)
    x = np.where(upper, x + np.where(x > 0.5, -0.5, 0.5), x)
    x = np.where(x > 0.5, 1.0 - x, x)
    z = z - 1.0
    # the triangles (z > 0)
    flip = _steep(x, z) | (x == 0.0)
    tz = np.where(flip, SQRT3_2 - z, z)
    tx = np.where(flip, np.where(x == 0.0, 0.5, 0.5 - x), x)
    delta = np.where(flip, 1.0, 0.0)
    d1 = 1.0 - 2.0 * tz * SQRT3
    d2 = 1.0 - (SQRT3 * tx - tz) * SQRT3
    triangle = (delta + np.maximum(d1, d2)) / 3.0
    # the squares
    sz = np.where(z < -0.5, -1.0 - z, z)
    sx = np.where(x > 0.5, 1.0 - x, x)
    e1 = np.minimum(2.0 + 2.0 * SQRT3 * np.abs(sx), 3.0)
    e2 = np.minimum(2.0 + 2.0 * SQRT3 * np.abs(sz), 3.0)
    square = (5.0000001 - np.minimum(e1, e2)) / 3.0
    return np.where(z > 0.0, triangle, square)


def _hexa_triangle(x: np.ndarray, z: np.ndarray) -> np.ndarray:
    x = _fold(x + 0.5, 2.0)
    z = _fold(z, 2.0 * SQRT3)
    upper = z > SQRT3
    z = np.where(upper, z - SQRT3, z)
    x = np.where(upper, x + np.where(x < 1.0, 1.0, -1.0), x)
    top = z > SQRT3_2
    z = np.where(top, SQRT3 - z, z)
    delta = np.where(top, 1.0, 0.0)
    x = np.where(x > 1.0, 2.0 - x, x)
    corner = SQRT3 * x + z < SQRT3_2
    d1 = 1.0 - z * 2.0 * SQRT3
    d2 = 1.0 + (SQRT3 * x + z - SQRT3_2) * SQRT3
    triangle = (delta + np.maximum(d1, d2)) / 3.0
    e1 = 2.0 + 2.0 * z * SQRT3
    e2 = 2.0 + 2.0 * (SQRT3 * x + z - SQRT3_2) * SQRT3_2
    hexagon = np.maximum(5.0 - np.minimum(e1, e2), 2.0000001) / 3.0
    return np.where(corner, triangle, hexagon)


def _square_offset(x: np.ndarray, z: np.ndarray) -> np.ndarray:
    z = _fold(z, 2.0)
    upper = z > 1.0
    x = np.where(upper, x + 0.5, x)
    z = np.where(upper, z - 1.0, z)
    x = 2.0 * np.abs(x - np.floor(x) - 0.5)
    z = 2.0 * np.abs(z - 0.5)
    return np.maximum(x, z)


_TILINGS: dict[int, Callable[[np.ndarray, np.ndarray], np.ndarray]] = {
    1: _square,
    2: _hexagon,
    3: _triangle,
    4: _lozenge,
    5: _rhombus,
    6: _rectangle,
    7: _octa_square,
    8: _square_triangle,
    9: _hexa_triangle,
    10: _square_offset,
}
RENDERED = frozenset(_TILINGS)


def tiling(p: np.ndarray, params: dict) -> np.ndarray:
    """(N,) the tiling's value at pattern-space points (POV-Ray: numbers past 27 or
    below 1 are the square tiling)."""
    number = int(params.get("value", 1))
    if not 1 <= number <= 27:
        number = 1
    fn = _TILINGS.get(number)
    if fn is None:
        return np.zeros(len(p))
    return fn(p[:, 0].astype(np.float64), p[:, 2].astype(np.float64))
