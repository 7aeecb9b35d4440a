"""POV-Ray's anti-aliasing method 2 (+AM2): adaptive, recursive subdivision of each pixel.

A ray goes through every pixel corner (not its centre). A pixel whose four corners are all
alike (each of the six pairs closer than the threshold, +A) is the mean of its corners;
otherwise five more rays (the middles of its edges and its centre) split it into four
squares, each judged the same way, down to depth − 1 levels (+R, default 3: at most 4×4
squares, 25 rays a pixel); a square's colour is the mean of its four sub-squares'. Colours
are compared as method 1 compares them (`color.aa_metric_space`, gamma +AG).

The rays that subdivide are jittered (+J, POV-Ray's default 1.0): moved by up to ±½ of
amount / (2^depth + 1) pixels in each axis, by a hash of the sample's position, so the same
point always gets the same ray (a shared edge's middle is one ray for both pixels). The
hash is strala's, so jittered images match POV-Ray's to within the jitter, not exactly.

Squares are judged a whole level at a time (all squares of a tile at once), the rays of a
level traced as one batch, known points looked up by their position on the finest grid.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from lang import ir
from runtime import color

DEFAULT_JITTER: float = 1.0  # POV-Ray 3.7's Jitter_Amount, on by default


class _Samples:
    """Colours of the points traced so far, keyed by their position on the finest grid."""

    def __init__(self, keys: np.ndarray, colours: np.ndarray, metric: np.ndarray):
        order = np.argsort(keys)
        self.keys, self.colours, self.metric = keys[order], colours[order], metric[order]

    def index(self, keys: np.ndarray) -> np.ndarray:
        return np.searchsorted(self.keys, keys)

    def missing(self, keys: np.ndarray) -> np.ndarray:
        keys = np.unique(keys)
        at = np.minimum(np.searchsorted(self.keys, keys), len(self.keys) - 1)
        return keys[self.keys[at] != keys]

    def add(self, keys: np.ndarray, colours: np.ndarray, metric: np.ndarray) -> None:
        self.__init__(  # type: ignore[misc]
            np.concatenate([self.keys, keys]),
            np.concatenate([self.colours, colours]),
            np.concatenate([self.metric, metric]),
        )


def jitter_offsets(gx: np.ndarray, gy: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Two numbers in [-½, ½) per integer grid position, the same for the same position."""
    h = gx.astype(np.uint64) * np.uint64(0x9E3779B97F4A7C15)
    h ^= gy.astype(np.uint64) * np.uint64(0xC2B2AE3D27D4EB4F)
    with np.errstate(over="ignore"):
        for shift, mul in ((31, 0xBF58476D1CE4E5B9), (29, 0x94D049BB133111EB)):
            h ^= h >> np.uint64(shift)
            h *= np.uint64(mul)
    h ^= h >> np.uint64(32)
    jx = (h & np.uint64(0xFFFF)).astype(np.float64) / 65536.0 - 0.5
    jy = ((h >> np.uint64(16)) & np.uint64(0xFFFF)).astype(np.float64) / 65536.0 - 0.5
    return jx, jy


def antialias_tile(
    tile: tuple[int, int, int, int],
    settings: ir.Settings,
    threshold: float,
    depth: int,
    shoot: Callable[[np.ndarray, np.ndarray], np.ndarray],
    *,
    jitter: float = DEFAULT_JITTER,
    gamma: float = color.AA_GAMMA,
) -> tuple[np.ndarray, int]:
    """(h, w, 3) colours of the tile (left, top, right, bottom) and how many of its pixels
    were subdivided. shoot(xs, ys) traces rays through continuous pixel coordinates (a
    pixel's corners are whole numbers)."""
    x0, y0, x1, y1 = tile
    w, h = x1 - x0, y1 - y0
    depth = max(1, int(depth))
    n = 1 << depth  # finest grid steps per pixel (POV-Ray's subdivision buffer)
    stride = (w + 1) * n + 1  # keys are gy * stride + gx, tile-relative

    def encode(colours: np.ndarray) -> np.ndarray:
        return color.aa_metric_space(colours, settings, gamma)

    cy, cx = np.mgrid[0 : h + 1, 0 : w + 1]
    corners = shoot((cx.ravel() + x0).astype(np.float64), (cy.ravel() + y0).astype(np.float64))
    keys = (cy.ravel() * n) * stride + cx.ravel() * n
    samples = _Samples(keys, corners, encode(corners))

    py, px = np.mgrid[0:h, 0:w]
    pixel = (py * w + px).ravel()  # the pixel each square belongs to
    bx, by = px.ravel() * n, py.ravel() * n  # top-left corner on the finest grid
    step, weight = n, 1.0  # every square of a level has the same size and weight
    out = np.zeros((h * w, 3))
    split_first = np.zeros(h * w, dtype=bool)
    scale = jitter / (n + 1)
    for level in range(depth - 1, -1, -1):
        quad = [(bx, by), (bx, by + step), (bx + step, by), (bx + step, by + step)]
        at = [samples.index(y * stride + x) for x, y in quad]
        col = [samples.colours[i] for i in at]
        met = [samples.metric[i] for i in at]
        split = np.zeros(len(pixel), dtype=bool)
        if level > 0:
            for a in range(4):
                for b in range(a + 1, 4):
                    split |= color.colour_distance(met[a], met[b]) >= threshold
        leaf = ~split
        np.add.at(out, pixel[leaf], weight * 0.25 * sum(c[leaf] for c in col))
        if not split.any():
            break
        if level == depth - 1:
            split_first[pixel[split]] = True
        half = step // 2
        sx, sy, sp = bx[split], by[split], pixel[split]
        mids = [(sx, sy + half), (sx + half, sy), (sx + step, sy + half),
                (sx + half, sy + step), (sx + half, sy + half)]  # fmt: skip
        new = samples.missing(np.concatenate([y * stride + x for x, y in mids]))
        if len(new):
            gx, gy = new % stride, new // stride
            xs, ys = gx / n + x0, gy / n + y0
            if scale > 0.0:  # the hash is of the image-wide position
                jx, jy = jitter_offsets(gx + x0 * n, gy + y0 * n)
                xs, ys = xs + jx * scale, ys + jy * scale
            colours = shoot(xs, ys)
            samples.add(new, colours, encode(colours))
        bx = np.concatenate([sx, sx, sx + half, sx + half])
        by = np.concatenate([sy, sy + half, sy, sy + half])
        pixel = np.concatenate([sp, sp, sp, sp])
        step, weight = half, weight * 0.25
    return out.reshape(h, w, 3), int(split_first.sum())
