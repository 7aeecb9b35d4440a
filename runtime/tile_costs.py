"""What each tile of a render will cost, to weigh the progress bar by (runtime.render).

Tiles of one image differ by a factor of hundreds (biscuit.pov at 320x240 with +A0.3:
0.04 s to 16 s); counted by pixels, the ETA was 0.4 to 88 times the time left. A sparse
sample of each tile's pixels says what it will cost:

- on the compiled kernel, the rays and shadow rays a one-pixel tile at each sample point
  traces with the render's own anti-aliasing (counted, not timed: a call takes
  microseconds). Measured in rays at 640x480 +A0.3, the ETA's ratio to the rays left over
  the middle 80% of the work: spheres_on_checker 0.75-0.97 (by pixels 0.77-2.13), ex3
  0.94-1.20 (0.46-1.19), csg_gallery 0.91-1.06 (0.82-1.21).
- on the numpy path, the seconds a batch of first rays takes (where the time a ray takes
  varies most: isosurfaces, blobs, media). Sampling each point's neighbours too, to see
  where anti-aliasing will supersample, cost twice the time and estimated no better
  (pawn_lathe 320x240 +A0.3: 0.81-1.69 against 0.84-1.42, blobs_in_fog 640x480:
  0.74-1.62 against 0.71-1.23), so the tiles are weighed by their first rays; the time
  anti-aliasing adds shows in the rate the bar measures as tiles finish.

The counters of the rays are left as they were: the sample is not the image's.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable

import numpy as np

from runtime.antialias import Sampling
from runtime.context import Context

Tile = tuple[int, int, int, int]

NUMPY_STRIDE = 8  # one sample per 8 x 8 pixels: ~1/64 of the camera rays
KERNEL_STRIDE = 16  # one per 16 x 16 at least: each traces 3 x 3 first rays with AA …
KERNEL_SAMPLES = 1500  # … and this many in all, at most (each call costs ~10 µs)


def tile_costs(
    ctx: Context,
    shoot: Callable[[np.ndarray, np.ndarray], object],
    tiles: list[Tile],
    sampling: Sampling,
) -> list[float]:
    """Each tile's estimated cost: seconds on the numpy path, rays on the kernel's (only
    their ratios matter for the weights). shoot(xs, ys) traces camera rays through pixel
    coordinates on the numpy path."""
    counters = dict(ctx.stats)
    try:
        if ctx.kernel is not None:
            area = sum((x1 - x0) * (y1 - y0) for x0, y0, x1, y1 in tiles)
            stride = max(KERNEL_STRIDE, math.ceil(math.sqrt(area / KERNEL_SAMPLES)))
            return [_kernel_cost(ctx, tile, sampling, stride) for tile in tiles]
        with np.errstate(over="ignore", invalid="ignore"):
            # once untimed: the first rays of a render build what later ones reuse (it
            # made blobs_in_fog's first tile look twenty times as dear)
            _numpy_cost(shoot, tiles[0])
            return [_numpy_cost(shoot, t) for t in tiles]
    finally:
        ctx.stats.clear()
        ctx.stats.update(counters)


def sample_points(tile: Tile, stride: int) -> tuple[np.ndarray, np.ndarray]:
    """Pixel centres on a grid of `stride`, at least the tile's middle one."""
    x0, y0, x1, y1 = tile
    ys, xs = np.mgrid[y0 + stride // 2 : y1 : stride, x0 + stride // 2 : x1 : stride]
    if not xs.size:
        return np.array([(x0 + x1) // 2]), np.array([(y0 + y1) // 2])
    return xs.ravel(), ys.ravel()


def _numpy_cost(shoot, tile: Tile) -> float:
    x0, y0, x1, y1 = tile
    xs, ys = sample_points(tile, NUMPY_STRIDE)
    t0 = time.perf_counter()
    shoot(xs + 0.5, ys + 0.5)
    return max(time.perf_counter() - t0, 1e-9) / len(xs) * (x1 - x0) * (y1 - y0)


def _kernel_cost(ctx, tile: Tile, sampling: Sampling, stride: int) -> float:
    x0, y0, x1, y1 = tile
    xs, ys = sample_points(tile, stride)
    threshold = sampling.threshold if sampling.method else None
    extra = float(max(1, int(sampling.depth)) ** 2)  # a supersampled pixel's grid
    cost = 0.0
    for x, y in zip(xs.tolist(), ys.tolist(), strict=True):
        before = ctx.stats.get("rays", 0) + ctx.stats.get("shadow_rays", 0)
        _, n = ctx.kernel.render_tile((x, y, x + 1, y + 1), threshold, sampling.depth,
                                      sampling.gamma)  # fmt: skip
        rays = ctx.stats.get("rays", 0) + ctx.stats.get("shadow_rays", 0) - before
        if threshold is None:
            cost += rays
        else:  # its 3 x 3 first rays and its supersampling, if any, for one pixel's
            cost += rays * (1.0 + n * extra) / (9.0 + n * extra)
    return cost / len(xs) * (x1 - x0) * (y1 - y0)
