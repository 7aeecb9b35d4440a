"""POV-Ray's anti-aliasing method 1 (+AM1, the default): non-adaptive supersampling.

Every pixel gets one ray through its centre. A pixel whose colour differs from its left or
top neighbour by at least the threshold (+A, default 0.3) is supersampled, and so is that
neighbour: a grid of depth×depth rays (+R, default 3) spread evenly over the pixel, averaged
together with the first ray (depth² + 1 samples). Colours are compared the way POV-Ray 3.7
does: the sum of the absolute channel differences after encoding the linear value with
gamma 1/2.5 (`color.aa_metric_space`). Jitter is off.

POV-Ray walks the pixels in order, so a pixel already supersampled is compared with its new
colour; here all comparisons use the first-ray colours, which makes the result independent
of tiling and vectorises (the supersampled set differs only in rare order-dependent cases).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from lang import ir
from runtime import color

DEFAULT_THRESHOLD: float = 0.3
DEFAULT_DEPTH: int = 3


@dataclass(frozen=True)
class Sampling:
    """How a render samples its pixels: POV-Ray's +AM (0: one ray per pixel, 1 or 2), +A,
    +R, +J (None: POV-Ray's default) and +AG."""

    method: int = 0
    threshold: float = DEFAULT_THRESHOLD
    depth: int = DEFAULT_DEPTH
    jitter: float | None = None
    gamma: float = color.AA_GAMMA


def grid_offsets(depth: int) -> np.ndarray:
    """(depth², 2) sub-pixel offsets (dx, dy) from the pixel centre: a regular grid whose
    cells tile the pixel, as POV-Ray's SupersampleOnePixel lays them out."""
    depth = max(1, int(depth))
    step = 1.0 / depth
    r = np.arange(depth) * step - (0.5 - 0.5 * step)
    dx, dy = np.meshgrid(r, r, indexing="xy")
    return np.stack([dx.ravel(), dy.ravel()], axis=1)


def edge_mask(metric: np.ndarray, threshold: float) -> np.ndarray:
    """Which pixels to supersample, given first-ray colours in the comparison space.

    `metric` is (h+1+b, w+1+r, C) with one extra row on top and one extra column on the
    left (the neighbours POV-Ray compares the tile's first row/column with), plus an optional
    extra row at the bottom (b) and column at the right (r) when the image continues there.
    The inner (h, w) pixels are judged: differing from the left or top neighbour, or being
    the left/top neighbour of a pixel that differs (POV-Ray supersamples both)."""
    diff_left = color.colour_distance(metric[:, 1:], metric[:, :-1]) >= threshold
    diff_top = color.colour_distance(metric[1:, :], metric[:-1, :]) >= threshold
    # diff_left[y, x] compares pixel (x+1, y) with (x, y) in extended coordinates.
    h_ext, w_ext = metric.shape[:2]
    mask_ext = np.zeros((h_ext, w_ext), dtype=bool)
    mask_ext[:, 1:] |= diff_left  # the right pixel of a differing pair
    mask_ext[:, :-1] |= diff_left  # and its left neighbour
    mask_ext[1:, :] |= diff_top
    mask_ext[:-1, :] |= diff_top
    return mask_ext


def antialias_tile(
    first: np.ndarray,
    settings: ir.Settings,
    threshold: float,
    depth: int,
    inner: tuple[slice, slice],
    pixel_xy: tuple[np.ndarray, np.ndarray],
    shoot: Callable[[np.ndarray, np.ndarray], np.ndarray],
    gamma: float = color.AA_GAMMA,
) -> tuple[np.ndarray, int]:
    """Supersample the inner part of an extended tile.

    first: (H_ext, W_ext, 3) first-ray colours; inner: the slices of the tile proper inside
    it; pixel_xy: (H_ext, W_ext) integer pixel coordinates; shoot(xs, ys) traces rays
    through continuous pixel coordinates. Returns the tile's (h, w, 3) colours and the number
    of supersampled pixels."""
    metric = color.aa_metric_space(first, settings, gamma)
    mask = edge_mask(metric, threshold)[inner]
    out = first[inner].copy()
    rows, cols = np.nonzero(mask)
    if len(rows) == 0:
        return out, 0
    px = pixel_xy[0][inner][rows, cols].astype(np.float64)
    py = pixel_xy[1][inner][rows, cols].astype(np.float64)
    offs = grid_offsets(depth)
    k = len(offs)
    xs = (px[:, None] + 0.5 + offs[None, :, 0]).ravel()
    ys = (py[:, None] + 0.5 + offs[None, :, 1]).ravel()
    samples = shoot(xs, ys).reshape(len(rows), k, 3)
    out[rows, cols] = (out[rows, cols] + samples.sum(axis=1)) / (k + 1)
    return out, len(rows)
