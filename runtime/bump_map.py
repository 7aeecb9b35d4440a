"""`normal { bump_map { png "file" … } }`: an image as heights, as POV-Ray's bump_map
(imageutil.cpp) derives a normal from it.

The pattern-space point is mapped to image pixel coordinates (map_type 0 planar, 1
spherical, 2 cylindrical, 5 torus; others planar; `once` leaves points off the single copy
unbumped). Three samples, at the point and one pixel down to the left and to the right
(wrapping round the image), are heights: bump_size times the grey value of the colour
(0.297 r + 0.589 g + 0.114 b, the file's values with no gamma unless the block gives one),
or with `use_index` times the palette index of a palette PNG. The normal of the triangle
through them, in a frame whose y axis is the surface normal, is the new normal.
`interpolate` 2 (bilinear), 3 (bicubic) and 4 (normalised distance) blend neighbouring
pixels (and indices, then truncated) as POV-Ray's image lookup does. Lengths are written
out component by component, in the order the compiled kernel repeats (kernel/bump_map.h).
"""

from __future__ import annotations

import math
import zlib
from functools import lru_cache
from typing import NamedTuple

import numpy as np

from runtime.gif import gif_indices
from runtime.heightfield import png_palette_indices

# POV-Ray's EPSILON, added to the pixel coordinates before they wrap
_NUDGE = 1.0e-10
# POV-Ray's greyscale weights (RED_INTENSITY, GREEN_INTENSITY, BLUE_INTENSITY)
GREY = np.array([0.297, 0.589, 0.114])
# below this the frame's x axis (normal × y) is too short: the normal is along ±y
_PARALLEL = 1.0e-10


def _norm(v: np.ndarray) -> np.ndarray:
    """(N,) lengths of (N, 3) vectors, summed x, y, z in that order."""
    return np.sqrt(v[:, 0] * v[:, 0] + v[:, 1] * v[:, 1] + v[:, 2] * v[:, 2])


class Heights(NamedTuple):
    """An image's per-pixel grey and red values (H, W) and, for a palette image, its
    indices (material_map reads the red channel, runtime.material_map)."""

    grey: np.ndarray
    red: np.ndarray
    indices: np.ndarray | None


def perturb(params: dict, amount: float, p: np.ndarray, n: np.ndarray) -> np.ndarray:
    """(N,3) normals after the bump_map with image settings `params` (lang's
    params["image"]) and height `amount` (bump_size), at pattern-space points p, for the
    pattern-space normals n. Points off the image (`once`) or unmappable keep n."""
    table = height_table(params)
    if table is None:
        return n
    h, w = table.shape
    once = bool(params.get("once"))
    x, y, ok = map_pos(p, int(params.get("map_type", 0)), w, h, once)
    out = n.copy()
    rows = np.nonzero(ok)[0]
    if not len(rows):
        return out
    x, y = x[rows], y[rows]
    interp = int(params.get("interpolate", 0))
    use_index = uses_index(params)
    # the samples: at the point, then one pixel on (y grows downward) to either side
    x2 = _wrap_once(x - 1.0, w)
    y2 = _wrap_once(y + 1.0, h)
    x3 = _wrap_once(x2 + 2.0, w)
    h1, h2, h3 = (
        amount * _height(table, sx, sy, interp, once, use_index)
        for sx, sy in ((x, y), (x2, y2), (x3, y2))
    )
    # the triangle (0, h1, 0), (-1, h2, 1), (1, h3, 1) and its normal
    xp = np.stack([np.ones_like(h1), h1 - h2, -np.ones_like(h1)], axis=1)
    yp = np.stack([2.0 * np.ones_like(h1), h3 - h2, np.zeros_like(h1)], axis=1)
    bump = np.cross(yp, xp)
    bump /= _norm(bump)[:, None]
    out[rows] = in_frame(n[rows], bump)
    return out


def height_table(params: dict) -> np.ndarray | None:
    """(H, W) the heights a bump_map reads: the palette indices with `use_index` (of a
    palette image), else the grey values; None without an image. Read by perturb and the
    kernel's packing (runtime.kernel_patterns)."""
    heights = image_heights(params)
    if heights is None:
        return None
    return heights.indices if uses_index(params) else heights.grey


def uses_index(params: dict) -> bool:
    """Whether the bump_map's heights are palette indices (use_index, of a palette image)."""
    heights = image_heights(params)
    return bool(params.get("use_index")) and heights is not None and heights.indices is not None


def in_frame(n: np.ndarray, bump: np.ndarray) -> np.ndarray:
    """bump (in a frame with y along n, x along n × y, z along x × n) in n's space; the
    z component enters negated, as POV-Ray adds it."""
    yp = n
    xp = np.cross(yp, np.array([0.0, 1.0, 0.0]))
    length = _norm(xp)
    flat = length < _PARALLEL
    if flat.any():
        up = np.abs(n[flat, 1] - 1.0) < _PARALLEL
        yp = yp.copy()
        yp[flat] = np.where(up[:, None], [0.0, 1.0, 0.0], [0.0, -1.0, 0.0])
        xp[flat] = (1.0, 0.0, 0.0)
        length = np.where(flat, 1.0, length)
    xp = xp / length[:, None]
    zp = np.cross(xp, yp)
    zp /= _norm(zp)[:, None]
    return bump[:, :1] * xp + bump[:, 1:2] * yp - bump[:, 2:3] * zp


def _wrap(v: np.ndarray, size: float) -> np.ndarray:
    """POV-Ray's wrap(): into [0, size)."""
    r = np.fmod(v, size)
    r = np.where(r < 0.0, r + size, r)
    return np.where(r >= size, 0.0, r)


def _wrap_once(v: np.ndarray, size: float) -> np.ndarray:
    """One step back into [0, size) (the neighbour samples move a pixel at most)."""
    return np.where(v < 0.0, v + size, np.where(v >= size, v - size, v))


def _theta(x: np.ndarray, z: np.ndarray, length: np.ndarray) -> np.ndarray:
    """The angle around y from +x toward +z in [0, 2 pi), from acos as POV-Ray takes it."""
    safe = np.where(length > 0, length, 1.0)
    t = np.arccos(np.clip(x / safe, -1.0, 1.0))
    t = np.where(z < 0.0, 2.0 * math.pi - t, t)
    return np.where(z == 0.0, np.where(x > 0, 0.0, math.pi), t)


def map_pos(p: np.ndarray, map_type: int, w: int, h: int, once: bool):
    """Pixel coordinates (x right, y down from the top row) of pattern-space points and
    which points map onto the image (POV-Ray's map_pos and its image mappers)."""
    x, y, z = p[:, 0], p[:, 1], p[:, 2]
    ok = np.ones(len(p), dtype=bool)
    with np.errstate(invalid="ignore", divide="ignore"):
        if map_type == 1:  # spherical
            r = _norm(p)
            ok &= r > 0
            rs = np.where(r > 0, r, 1.0)
            v = 0.5 + np.arcsin(np.clip(y / rs, -1.0, 1.0)) / math.pi
            ring = np.hypot(x / rs, z / rs)
            t = np.where(ring > 0, _theta(x / rs, z / rs, ring), 0.0)
            u = t / (2.0 * math.pi) * w
            v = v * h
        elif map_type == 2:  # cylindrical
            if once:
                ok &= (y >= 0.0) & (y <= 1.0)
            v = np.fmod(y * h, float(h))
            r = _norm(p)
            rs = np.where(r > 0, r, 1.0)
            ring = np.hypot(x / rs, z / rs)
            ok &= (r > 0) & (ring > 0)
            u = _theta(x / rs, z / rs, ring) / (2.0 * math.pi) * w
        elif map_type == 5:  # torus of major radius 1
            ring = np.hypot(x, z)
            ok &= ring > 0
            theta = -_theta(x, z, ring)
            dx = ring - 1.0
            tube = np.hypot(dx, y)
            ok &= tube > 0
            phi = np.arccos(np.clip(-dx / np.where(tube > 0, tube, 1.0), -1.0, 1.0))
            phi = np.where(y > 0.0, 2.0 * math.pi - phi, phi)
            u = -theta / (2.0 * math.pi) * w
            v = phi / (2.0 * math.pi) * h
        else:  # planar: x across, y up the unit square
            if once:
                ok &= (x >= 0.0) & (x <= 1.0) & (y >= 0.0) & (y <= 1.0)
            u = np.fmod(x * w, float(w))
            v = np.fmod(y * h, float(h))
    u = u + _NUDGE
    v = v + _NUDGE
    if once:
        ok &= (u >= 0) & (u < w) & (v >= 0) & (v < h)
    ok &= np.isfinite(u) & np.isfinite(v)
    u = np.where(ok, u, 0.0)
    v = np.where(ok, v, 0.0)
    # the image's rows run down from the top
    return _wrap(u, float(w)), _wrap(-v, float(h)), ok


def _pixels(table: np.ndarray, ix: np.ndarray, iy: np.ndarray, once: bool):
    """Values at whole pixel coordinates: clamped to the edge for `once`, else wrapped."""
    h, w = table.shape
    if once:
        ix = np.clip(ix, 0, w - 1)
        iy = np.clip(iy, 0, h - 1)
    else:
        ix = np.mod(ix, w)
        iy = np.mod(iy, h)
    return table[iy, ix]


def _height(table: np.ndarray, x, y, interp: int, once: bool, use_index: bool) -> np.ndarray:
    value = sample(table, x, y, interp, once)
    # POV-Ray truncates a blended index to a whole one
    return np.trunc(value) if use_index and interp in (2, 3, 4) else value


def sample(table: np.ndarray, x, y, interp: int, once: bool) -> np.ndarray:
    """The (H, W) table's value at pixel coordinates (map_pos's), interpolated as asked:
    POV-Ray's image lookup, which blends a palette image's indices as it blends colours."""
    if interp in (2, 3, 4):
        x = x + 0.5
        y = y + 0.5
        ix = x.astype(np.int64)
        iy = y.astype(np.int64)
        p, q = x - ix, y - iy
        if interp == 3:
            total = np.zeros(len(x))
            fx, fy = cubic_weights(p), cubic_weights(q)
            for i in range(4):
                for j in range(4):
                    val = _pixels(table, ix + i - 2, iy + j - 2, once)
                    total += fx[i] * fy[j] * val
        else:
            corners = ((0, 0), (-1, 0), (0, -1), (-1, -1))
            factors: tuple[np.ndarray, ...]
            if interp == 2:
                factors = (p * q, (1 - p) * q, p * (1 - q), (1 - p) * (1 - q))
            else:
                factors = norm_dist_weights(p, q)
            total = np.zeros(len(x))
            for (dx, dy), f in zip(corners, factors, strict=True):
                total += f * _pixels(table, ix + dx, iy + dy, once)
        return total
    return _pixels(table, x.astype(np.int64), y.astype(np.int64), once)


def cubic_weights(p: np.ndarray) -> tuple[np.ndarray, ...]:
    q = 1.0 - p
    return (
        -0.5 * p * q * q,
        0.5 * q * (q * (3 * p + 1) + 1),
        0.5 * p * (p * (3 * q + 1) + 1),
        -0.5 * q * p * p,
    )


def norm_dist_weights(p: np.ndarray, q: np.ndarray) -> tuple[np.ndarray, ...]:
    """Inverse squared distances to the four corners, normalised; a sample on a pixel's
    centre takes that pixel alone."""
    d = np.stack([(1 - p) ** 2 + (1 - q) ** 2, p**2 + (1 - q) ** 2, (1 - p) ** 2 + q**2,
                  p**2 + q**2])  # fmt: skip
    on = d <= 0.0
    with np.errstate(divide="ignore"):
        wts = np.where(on, 0.0, 1.0 / np.where(on, 1.0, d))
    wts = np.where(on.any(axis=0), on.astype(np.float64), wts)
    return tuple(wts / wts.sum(axis=0))


def image_heights(params: dict) -> Heights | None:
    """The image's heights (None when it is missing or unreadable: lang warned)."""
    path = params.get("path")
    if not path:
        return None
    gamma = params.get("gamma")
    try:
        return _load(
            str(path), None if gamma is None else float(gamma), bool(params.get("use_index"))
        )
    except OSError:
        return None


@lru_cache(maxsize=16)
def _load(path: str, gamma: float | None, use_index: bool) -> Heights:
    import OpenImageIO as oiio  # imported only by scenes with images

    inp = oiio.ImageInput.open(path)
    if inp is None:
        raise OSError(oiio.geterror() or f"cannot read {path}")
    try:
        pixels = np.asarray(inp.read_image(oiio.FLOAT), dtype=np.float64)
    finally:
        inp.close()
    if pixels.ndim == 2:
        pixels = pixels[:, :, None]
    rgb = np.repeat(pixels[:, :, :1], 3, axis=2) if pixels.shape[2] < 3 else pixels[:, :, :3]
    if gamma is not None:  # the block's `gamma` decodes the file; without it, none
        rgb = np.clip(rgb, 0.0, None) ** gamma
    depth = _grey_png_depth(path)
    if depth:
        rgb = _grey_levels(pixels[:, :, 0], depth, gamma)
    index = palette_indices(path) if use_index else None
    if index is not None and index.shape != rgb.shape[:2]:
        index = None
    return Heights(rgb @ GREY, rgb[:, :, 0], index)


def _grey_png_depth(path: str) -> int:
    """The bit depth of a grey PNG of 8 bits or fewer without alpha (0 for any other file)."""
    try:
        with open(path, "rb") as f:
            head = f.read(33)
    except OSError:
        return 0
    if not head.startswith(b"\x89PNG\r\n\x1a\n") or head[12:16] != b"IHDR" or len(head) < 26:
        return 0
    depth, colour = head[24], head[25]
    return depth if colour == 0 and depth <= 8 else 0


def _grey_levels(values: np.ndarray, depth: int, gamma: float | None) -> np.ndarray:
    """(H, W, 3) the grey PNG's levels as POV-Ray holds them: its reader makes each level a
    colour (decoded by `gamma`), stores that colour's grey (0.297 r + 0.589 g + 0.114 b in
    single precision, whose weights sum to a shade under 1) in a byte, truncated; so some
    levels come out one step lower (3 of 255 reads as 2)."""
    top = (1 << depth) - 1
    f = np.float32
    level = np.arange(top + 1, dtype=f) / f(top)
    if gamma is not None:
        level = (level.astype(np.float64) ** gamma).astype(f)
    grey = level * f(0.297) + level * f(0.589) + level * f(0.114)
    stored = np.trunc(np.clip(grey, 0, 1) * f(255)).astype(np.float64) / 255.0
    codes = np.clip(np.rint(values * top), 0, top).astype(np.int64)
    return np.repeat(stored[codes][:, :, None], 3, axis=2)


def palette_indices(path: str) -> np.ndarray | None:
    """(H, W) palette indices of a palette PNG (colour type 3, not interlaced) or a GIF,
    as float64; None for any other file. Image libraries hand out the colours only, so the
    height field's PNG decoder reads them."""
    try:
        with open(path, "rb") as f:
            data = f.read()
    except OSError:
        return None
    try:
        index = png_palette_indices(data)
        if index is None:
            index = gif_indices(data)
    except (ValueError, zlib.error):  # no header, interlaced, truncated or corrupt
        return None
    return None if index is None else index.astype(np.float64)
