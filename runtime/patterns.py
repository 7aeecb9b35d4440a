"""Pigment and normal patterns, vectorised over hit points: (N,3) world points → (N,5)
RGBFT colours (`evaluate`) or perturbed normals (`perturb_normal`).

A pigment is evaluated at inverse(pigment.transform) @ p_world (see `ir`); every pigment in
the tree carries its own fully composed transform, so sub-pigments are evaluated at world
points too. Pattern values follow POV-Ray 3.7:
- list patterns (checker, hexagon, brick) give an integer index into their colour list and
  never go through frequency/phase/wave (POV-Ray sets their frequency to 0);
- continuous patterns give a value that goes through `frequency` and `phase`
  (fmod(v*f + p, 1.00001), negatives wrapped), then the wave type, then the colour map or
  pigment map (linear interpolation between neighbouring entries, clamped at the ends),
  or POV-Ray's default map for the pattern;
- image_map pigments look up an image file (planar, spherical, cylindrical mapping).
Supported: solid, checker, hexagon, brick, gradient, onion, spherical, cylindrical, planar,
boxed, leopard, radial, spiral1/2, quilted, bozo, spotted, bumps, dents, granite, marble,
wood, agate, wrinkles, ripples, waves, cells, crackle, mandel, julia, magnet
(runtime.fractal_patterns), slope (runtime.slope), average, image_map.
Unknown patterns render as the pattern's first colour with one warning each.

`Pigment.params` keys read here: "orientation" (gradient vector), "brick_size", "mortar",
"frequency", "phase", "wave" ("ramp_wave", "sine_wave", "triangle_wave", "scallop_wave",
"cubic_wave", "poly_wave"), "wave_exponent" (poly_wave), "arms" (spirals), "control0",
"control1" (quilted), "agate_turb", "form"/"metric" (crackle), "max_iteration"/"complex"
(fractals), the image_map keys ("path", "map_type", "interpolate", "once", "filter",
"transmit", "use_alpha", "gamma"), and the classic turbulence warp "turbulence" (vector
or float), "octaves" (6), "omega" (0.5), "lambda" (2.0).

Noise: POV-Ray's own noise (runtime.noise: its hash and value tables rebuilt the way POV-Ray
built them, generators 1-3, 2 by default), so bozo, spotted, granite, wrinkles, dents, marble,
wood, agate, turbulence and the bump normals give POV-Ray's values, not just its look.
"""

from __future__ import annotations

import math
from functools import cache, lru_cache

import numpy as np

from lang import ir
from runtime import bump_map, notices
from runtime import transform as tf
from runtime.density import density_file
from runtime.fractal_patterns import exponent as fractal_exponent
from runtime.fractal_patterns import julia, magnet, mandel
from runtime.material_map import material_index
from runtime.noise import (
    DEFAULT_GENERATOR,
    dnoise,
    dturbulence,
    hash3d,
    noise,
    turbulence,
)
from runtime.noise import tables as noise_tables
from runtime.slope import slope
from runtime.tiling import tiling

# POV-Ray adds a tiny epsilon to every coordinate before flooring, so a plane at an integer
# coordinate (y = 0, the classic floor) does not flicker between cells. 1e-6 matches POV-Ray
# 3.7's renders pixel for pixel (1e-3 shifts cell edges visibly; tests/test_checker_povray.py).
CHECKER_OFFSET: float = 1e-6

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
    "object": (_BLACK, _WHITE),  # outside, inside
}
# Without a colour map, continuous patterns ramp from black to white …
DEFAULT_MAP: tuple[tuple[float, ir.Color], ...] = ((0.0, _BLACK), (1.0, _WHITE))


def _c(r: float, g: float, b: float) -> ir.Color:
    return (r, g, b, 0.0, 0.0)


# … except these, which POV-Ray gives their own default colour maps (checked against its
# renders: marble's ramp and wood's two colours measured, radial's hue circle).
DEFAULT_MAPS: dict[str, tuple[tuple[float, ir.Color], ...]] = {
    "bozo": (
        (0.4, _c(1, 1, 1)),
        (0.4, _c(0, 1, 0)),
        (0.6, _c(0, 1, 0)),
        (0.6, _c(0, 0, 1)),
        (0.8, _c(0, 0, 1)),
        (0.8, _c(1, 0, 0)),
    ),
    "wood": ((0.6, _c(0.666, 0.312, 0.2)), (0.6, _c(0.4, 0.1333, 0.066))),
    "marble": ((0.0, _c(0.9, 0.8, 0.8)), (0.9, _c(0.9, 0.08, 0.08)), (0.9, _c(0, 0, 0))),
    "radial": (
        (0.0, _c(0, 1, 1)),
        (0.333, _c(1, 1, 0)),
        (0.666, _c(1, 0, 1)),
        (1.0, _c(0, 1, 1)),
    ),
    "agate": (
        (0.0, _c(1.0, 1.0, 1.0)),
        (0.5, _c(0.95, 0.75, 0.5)),
        (0.5, _c(0.9, 0.7, 0.5)),
        (0.6, _c(0.9, 0.7, 0.4)),
        (0.6, _c(1.0, 0.7, 0.4)),
        (1.0, _c(0.6, 0.3, 0.0)),
    ),
    "mandel": (
        (0.001, _c(0, 0, 0)),
        (0.001, _c(0, 1, 1)),
        (0.012, _c(1, 1, 0)),
        (0.015, _c(1, 0, 1)),
        (0.1, _c(0, 1, 1)),
    ),
}


def _warn(msg: str, span=None) -> None:
    """Once per message; blames the source (file:line:col) when the caller knows it."""
    notices.warn_once(msg, span)


def _untransform(m: ir.Matrix, points: np.ndarray) -> np.ndarray:
    inv = tf.cached_inverse(m)
    if inv is None:
        return points
    return points @ inv[:3, :3].T + inv[:3, 3]


def pattern_points(pigment: ir.Pigment | ir.Normal, points: np.ndarray) -> np.ndarray:
    """Pattern-space points: POV-Ray's Warp_EPoint. The pattern's transforms and warps form
    one list applied from the last written to the first; `params["warps"]` holds each warp
    with the transform written before it, `transform` what was written after the last."""
    p = _untransform(pigment.transform, points)
    warps = pigment.params.get("warps")
    if warps:
        for data, before in reversed(warps):
            p = warp_points(data, p)
            p = _untransform(before, p)
        p = np.clip(p, -COORDINATE_LIMIT, COORDINATE_LIMIT)
    return p


def pattern_linear(pigment: ir.Pigment | ir.Normal) -> np.ndarray | None:
    """The linear part of all the pattern's transforms (its warps left out, as POV-Ray's
    Warp_Normal does), None for the identity."""
    mats = [pigment.transform, *(before for _, before in pigment.params.get("warps", ()))]
    out = None
    for m in mats:
        if tf.cached_inverse(m) is None:
            continue
        lin = np.asarray(m, dtype=np.float64)[:3, :3]
        out = lin if out is None else lin @ out
    return out


# POV-Ray clamps warped coordinates to this.
COORDINATE_LIMIT: float = 1.0e17
_WARP_EPSILON: float = 1.0e-10


def _vec(v, default) -> np.ndarray:
    return np.broadcast_to(np.asarray(default if v is None else v, dtype=np.float64), (3,))


def warp_points(w: dict, p: np.ndarray) -> np.ndarray:
    """One `warp { … }` applied to (N,3) points, as POV-Ray 3.7's warps do."""
    kind = w.get("warp", "turbulence")
    if kind == "turbulence":
        vec = _vec(w.get("turbulence"), 0.0)
        if not vec.any():
            return p
        octaves = int(w.get("octaves", 6))
        omega = float(w.get("omega", 0.5))
        lam = float(w.get("lambda", 2.0))
        return p + dturbulence(p, octaves, omega, lam) * vec
    if kind == "black_hole":
        return _black_hole(w, p)
    if kind == "repeat":
        return _repeat(w, p)
    if kind in ("planar", "cylindrical", "spherical", "toroidal"):
        return _mapping_warp(kind, w, p)
    if kind == "cubic":
        return _cubic_warp(p)
    _warn(f"warp `{kind}` is not supported yet: ignored")
    return p


@lru_cache(maxsize=1)
def warp_rands() -> np.ndarray:
    """POV-Ray's WarpRands: 32768 doubles in [0, 1) from a default-seeded (5489) 32-bit
    Mersenne Twister, one draw each divided by 2^32 (boost's uniform_real)."""
    raw = np.random.RandomState(5489).randint(0, 2**32, size=32768, dtype=np.uint32)
    return raw.astype(np.float64) / 2.0**32


def _black_hole(w: dict, p: np.ndarray) -> np.ndarray:
    """Points within `radius` of the centre move toward it (away with `inverse`) by
    ((radius - d) / radius)^falloff * strength of their offset, at most all of it; `repeat`
    copies the hole every repeat vector, `turbulence` jitters each copy's centre."""
    centre = np.broadcast_to(_vec(w.get("center"), 0.0), p.shape).copy()
    radius = float(w.get("radius", 1.0))
    if w.get("repeat") is not None:
        rep = _vec(w.get("repeat"), 0.0)
        block = np.zeros(p.shape, dtype=np.int64)
        for i in range(3):
            if rep[i] >= _WARP_EPSILON:
                block[:, i] = np.floor(p[:, i] / rep[i]).astype(np.int64)
        if w.get("turbulence") is not None:
            jitter = _vec(w.get("turbulence"), 0.0)
            seed = hash3d(block[:, 0], block[:, 1], block[:, 2])
            rands = warp_rands()
            for i in range(3):
                centre[:, i] += rands[(seed + i) % len(rands)] * jitter[i]
        centre += rep * block
    if float(w.get("type", 0.0)) != 0.0:
        return p
    delta = p - centre
    length = np.linalg.norm(delta, axis=1)
    inside = length < radius
    k = np.minimum(
        np.power(np.clip((radius - length) / radius, 0.0, None), float(w.get("falloff", 2.0)))
        * float(w.get("strength", 1.0)),
        1.0,
    )
    if w.get("inverse"):
        k = -k
    return np.where(inside[:, None], p + delta * k[:, None], p)


def _repeat(w: dict, p: np.ndarray) -> np.ndarray:
    """Copies of the unit between 0 and the repeat width along its axis, each shifted by
    `offset` times its number; odd copies mirrored along the axes `flip` names."""
    rep = _vec(w.get("repeat"), 0.0)
    axis = int(np.nonzero(rep)[0][0])
    width = float(rep[axis])
    flip = np.where(_vec(w.get("flip"), 0.0) != 0.0, -1.0, 1.0)
    offset = _vec(w.get("offset"), 0.0)
    q = p.copy()
    block = np.floor(q[:, axis] / width).astype(np.float32).astype(np.float64)
    q[:, axis] -= block * width
    odd = (block.astype(np.int64) & 1) == 1
    if (flip < 0).any():
        q[odd] *= flip
        if flip[axis] < 0:
            q[odd, axis] += width
    return q + block[:, None] * offset


def _turn(theta: np.ndarray | None, x: np.ndarray, z: np.ndarray, length: np.ndarray) -> np.ndarray:
    """POV-Ray's angle of (x, z) from +x toward +z as a fraction of a turn, from acos."""
    with np.errstate(invalid="ignore", divide="ignore"):
        a = np.arccos(np.clip(x / np.where(length > 0, length, 1.0), -1.0, 1.0))
    a = np.where(z == 0.0, np.where(x > 0, 0.0, math.pi), np.where(z < 0.0, 2 * math.pi - a, a))
    return a


def _orient(w: dict, x: np.ndarray, y: np.ndarray, z: np.ndarray) -> np.ndarray:
    o = _vec(w.get("orientation"), (0.0, 0.0, 1.0))
    n = np.linalg.norm(o)
    o = o / n if n > 0 else np.array([0.0, 0.0, 1.0])
    if o[0] == 0.0 and o[1] == 0.0 and o[2] == 1.0:
        return np.stack([x, y, z], axis=1)
    return np.stack(
        [
            o[0] * z + o[1] * x + o[2] * x,
            o[0] * y - o[1] * z + o[2] * y,
            -o[0] * x + o[1] * y + o[2] * z,
        ],
        axis=1,
    )


def _mapping_warp(kind: str, w: dict, p: np.ndarray) -> np.ndarray:
    """planar, cylindrical, spherical and toroidal warps: the point's surface coordinates
    (angle as a fraction of a turn, height or latitude, distance) as the new point, scaled
    by distance^dist_exp, in the frame of `orientation`. Points where the mapping has no
    angle (on the axis) keep their place, as in POV-Ray."""
    x, y, z = p[:, 0], p[:, 1], p[:, 2]
    exp = float(w.get("dist_exp", 0.0))
    if kind == "planar":
        return _orient(w, x, y, np.full(len(p), float(w.get("offset", 0.0))))
    if kind == "cylindrical":
        length = np.hypot(x, z)
        theta = _turn(None, x, z, length) / (2 * math.pi)
        if exp != 0.0:
            theta = theta * length**exp
        out = _orient(w, theta, y, length)
        return np.where((length == 0.0)[:, None], p, out)
    if kind == "spherical":
        dist = np.linalg.norm(p, axis=1)
        safe = np.where(dist > 0, dist, 1.0)
        ux, uy, uz = x / safe, y / safe, z / safe
        phi = 0.5 + np.arcsin(np.clip(uy, -1.0, 1.0)) / math.pi
        length = np.hypot(ux, uz)
        theta = np.where(length == 0.0, 0.0, _turn(None, ux, uz, length) / (2 * math.pi))
        if exp != 0.0:
            scale = dist**exp
            theta, phi = theta * scale, phi * scale
        out = _orient(w, theta, phi, dist)
        return np.where((dist == 0.0)[:, None], p, out)
    # toroidal
    r0 = float(w.get("major_radius", 1.0))
    length = np.hypot(x, z)
    theta = -_turn(None, x, z, length)
    xr = length - r0
    rl = np.hypot(xr, y)
    with np.errstate(invalid="ignore", divide="ignore"):
        phi = np.arccos(np.clip(-xr / np.where(rl > 0, rl, 1.0), -1.0, 1.0))
    phi = np.where(y > 0.0, 2 * math.pi - phi, phi)
    theta = theta / (-2 * math.pi)
    phi = phi / (2 * math.pi)
    if exp != 0.0:
        scale = rl**exp
        theta, phi = theta * scale, phi * scale
    out = _orient(w, theta, phi, rl)
    return np.where((length == 0.0)[:, None], p, out)


def _cubic_warp(p: np.ndarray) -> np.ndarray:
    """The cubic warp: each point onto the face of the cube it looks through, unfolded as a
    cross (POV-Ray's CubicWarp)."""
    x, y, z = p[:, 0], p[:, 1], p[:, 2]
    ax, ay, az = np.abs(x), np.abs(y), np.abs(z)
    third = 1.0 / 3.0
    out = np.empty_like(p)
    with np.errstate(invalid="ignore", divide="ignore"):
        faces = [
            ((x >= 0) & (x >= ay) & (x >= az), 0.75 - 0.25 * (z / x + 1) / 2,
             third + third * (y / x + 1) / 2, x),
            ((y >= 0) & (y >= ax) & (y >= az), 0.25 + 0.25 * (x / y + 1) / 2,
             1.0 - third * (z / y + 1) / 2, y),
            ((z >= 0) & (z >= ax) & (z >= ay), 0.25 + 0.25 * (x / z + 1) / 2,
             third + third * (y / z + 1) / 2, z),
            ((x < 0) & (x <= -ay) & (x <= -az), 0.25 * (z / -x + 1) / 2,
             third + third * (y / -x + 1) / 2, -x),
            ((y < 0) & (y <= -ax) & (y <= -az), 0.25 + 0.25 * (x / -y + 1) / 2,
             third * (z / -y + 1) / 2, -y),
        ]  # fmt: skip
        done = np.zeros(len(p), dtype=bool)
        for cond, u, v, d in faces:
            sel = cond & ~done
            out[sel] = np.stack([u, v, d], axis=1)[sel]
            done |= sel
        rest = ~done
        out[rest] = np.stack(
            [1.0 - 0.25 * (x / -z + 1) / 2, third + third * (y / -z + 1) / 2, -z], axis=1
        )[rest]
    return out


def evaluate(
    pigment: ir.Pigment,
    points: np.ndarray,
    gamma: float | None = 1.0,
    normals: np.ndarray | None = None,
    uv: np.ndarray | None = None,
) -> np.ndarray:
    """(N,5) float64 RGBFT colours of `pigment` at world points (N,3). `gamma` is the scene's
    working gamma (None: legacy, no gamma handling), used to bring image files into the
    working colour space. `normals` (N,3), the shaded surface's, are what the slope pattern
    reads (None off a surface: slope is 0 there). `uv` (N,3), the surface's <u, v, 0>
    (runtime.uvmap), is where a uv-mapped pigment (and all inside it) is evaluated instead
    of the points (None: not on a surface, the points serve)."""
    if uv is not None and pigment.params.get("uv_mapping"):
        points = uv
    points = np.asarray(points, dtype=np.float64).reshape(-1, 3)
    n = len(points)
    kind = pigment.pattern
    if kind == "solid":
        return np.broadcast_to(np.asarray(pigment.color, dtype=np.float64), (n, 5)).copy()
    p = pattern_points(pigment, points)
    if kind not in BUILT_IN_TURBULENCE:
        p = turbulence_warp(p, pigment.params)
    if kind in LIST_PATTERNS:
        index = LIST_PATTERNS[kind](p, pigment.params)
        return _select(pigment, kind, index, points, gamma, normals, uv)
    if kind == "image_map":
        return image_map(pigment.params, p, gamma, pigment.span)
    if kind == "average" and pigment.pigment_map:
        # The weighted mean of the map's pigments (their map values are the weights), at
        # the point after the average's own warps (POV-Ray averages at the warped point; the
        # entries already carry the average's transforms, so only the warps are added).
        at = map_points(pigment, points, p)
        total = sum(w for w, _ in pigment.pigment_map) or 1.0
        mean = sum(w * evaluate(q, at, gamma, normals, uv) for w, q in pigment.pigment_map)
        return np.asarray(mean) / total
    at = map_points(pigment, points, p) if pigment.pigment_map else points
    if kind == "slope":
        value = apply_wave(slope(p, points, normals, pigment.params), pigment.params, kind)
        return _map(pigment, value, at, gamma, normals, uv)
    fn = CONTINUOUS_PATTERNS.get(kind)
    if fn is None:
        _warn(
            f"pigment pattern `{kind}` is not supported yet: using its first colour", pigment.span
        )
        return _fallback(pigment, points, gamma)
    value = apply_wave(fn(p, pigment.params), pigment.params, kind)
    return _map(pigment, value, at, gamma, normals, uv)


def map_points(pigment: ir.Pigment, points: np.ndarray, p: np.ndarray) -> np.ndarray:
    """Where a pigment map's entries are evaluated: POV-Ray hands them the point after
    the outer pattern's warps (its turbulence too), `p`. The entries already carry the outer
    pattern's transforms, so `p` goes back through them to world space; without warps or
    turbulence that is `points` itself."""
    if not pigment.params.get("warps") and turb_params(pigment.params)[0] is None:
        return points
    # pattern_points undoes the transform, then each warp's `before` from the last warp
    full = np.asarray(pigment.transform, dtype=np.float64)
    for _, before in reversed(pigment.params.get("warps", ())):
        full = full @ np.asarray(before, dtype=np.float64)
    return p @ full[:3, :3].T + full[:3, 3]


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


def object_pattern(p: np.ndarray, params: dict) -> np.ndarray:
    """1 where the point is inside `params["object"]`, else 0 (POV-Ray's object pattern; a
    shape without an inside, such as a mesh, is outside everywhere)."""
    obj = params.get("object")
    if obj is None:
        return np.zeros(len(p), dtype=np.int64)
    # Lazily, both: the object's isosurfaces compile their functions with runtime.functions
    # (the circle the language makes: a function may hold a pigment), handed to the inside
    # test so that runtime.inside and the primitives never import the function compiler.
    from runtime.functions import compile_xyz
    from runtime.inside import inside_points

    return inside_points(obj, p, compile_xyz).astype(np.int64)


LIST_PATTERNS = {
    "checker": checker,
    "hexagon": hexagon,
    "brick": brick,
    "object": object_pattern,
    # a texture's only: the image's index picks the texture (runtime.material_map)
    "material_map": material_index,
}


def _select(
    pigment: ir.Pigment,
    kind: str,
    index: np.ndarray,
    points: np.ndarray,
    gamma: float | None,
    normals: np.ndarray | None,
    uv: np.ndarray | None = None,
) -> np.ndarray:
    entries: tuple = pigment.list or tuple(ir.Pigment(color=c) for c in DEFAULT_LISTS[kind])
    out = np.zeros((len(points), 5))
    index = np.minimum(index, len(entries) - 1)
    for i, sub in enumerate(entries):
        rows = np.nonzero(index == i)[0]
        if len(rows):
            out[rows] = evaluate(sub, points[rows], gamma, _rows(normals, rows), _rows(uv, rows))
    return out


def _rows(normals: np.ndarray | None, rows: np.ndarray) -> np.ndarray | None:
    return None if normals is None else normals[rows]


# --------------------------------------------------------- continuous patterns
def gradient(p: np.ndarray, params: dict) -> np.ndarray:
    g = np.asarray(params.get("orientation", (1.0, 0.0, 0.0)), dtype=np.float64)
    return p @ g


def onion(p: np.ndarray, params: dict) -> np.ndarray:
    return np.fmod(np.linalg.norm(p, axis=1), 1.0)


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


# -------------------------------------------------------------------- image maps
@lru_cache(maxsize=64)
def _load_image(path: str, file_gamma: float | None, gamma: float | None) -> np.ndarray:
    """(H, W, 4) RGBA float64 of an image file in the working colour space. Integer files
    are sRGB unless `gamma` is given in the image_map; float files (EXR, HDR) are linear.
    Legacy scenes (no working gamma) use the file's values unchanged, as POV-Ray does."""
    import OpenImageIO as oiio  # runtime may use it; imported only by scenes with images

    inp = oiio.ImageInput.open(path)
    if inp is None:
        raise OSError(oiio.geterror() or f"cannot read {path}")
    try:
        spec = inp.spec()
        pixels = np.asarray(inp.read_image(oiio.FLOAT), dtype=np.float64)
        is_float = spec.format.basetype in (oiio.FLOAT, oiio.HALF, oiio.DOUBLE)
    finally:
        inp.close()
    if pixels.ndim == 2:
        pixels = pixels[:, :, None]
    ch = pixels.shape[2]
    rgb = np.repeat(pixels[:, :, :1], 3, axis=2) if ch < 3 else pixels[:, :, :3]
    alpha = pixels[:, :, 3] if ch >= 4 else (pixels[:, :, 1] if ch == 2 else None)
    if gamma is not None:
        if is_float:
            linear = rgb
        elif file_gamma is not None:
            linear = np.clip(rgb, 0, None) ** file_gamma
        else:
            from runtime.color import srgb_decode

            linear = srgb_decode(rgb)
        rgb = np.clip(linear, 0, None) ** (1.0 / gamma) if gamma != 1.0 else linear
    a = np.ones(rgb.shape[:2]) if alpha is None else alpha
    return np.concatenate([rgb, a[:, :, None]], axis=2)


def image_uv(p: np.ndarray, map_type: int) -> tuple[np.ndarray, np.ndarray]:
    """Image coordinates (u, v) of pattern-space points: planar (0) maps the x-y unit square,
    spherical (1) longitude/latitude around the y axis, cylindrical (2) the angle around y
    and the height y, torus (5) the angle around y and the angle around the tube of a torus
    of major radius 1 in the x-z plane."""
    x, y, z = p[:, 0], p[:, 1], p[:, 2]
    if map_type in (1, 2, 5):
        # The angle around y from +x toward +z, as a fraction of a turn (POV-Ray's theta).
        u = np.mod(np.arctan2(z, x) / (2.0 * math.pi), 1.0)
        if map_type == 2:
            return u, y
        if map_type == 5:
            # the tube's angle from its inner side, turning over the top (POV-Ray's phi)
            d = np.hypot(x, z) - 1.0
            phi = np.arctan2(y, -d)
            return u, np.mod(-phi / (2.0 * math.pi), 1.0)
        r = np.linalg.norm(p, axis=1)
        safe = np.where(r > 0, r, 1.0)
        v = np.arcsin(np.clip(y / safe, -1.0, 1.0)) / math.pi + 0.5
        return u, v
    # every other map_type is planar, as POV-Ray's map_pos reads it
    return x, y


@lru_cache(maxsize=16)
def _with_palette_entries(
    path: str,
    file_gamma: float | None,
    gamma: float | None,
    every: tuple[float | None, float | None],
    entries: tuple,
) -> np.ndarray | None:
    """The image with two more channels, filter and transmit: every colour's (`every`),
    then the palette entries' (`entries`: (channel, (index, amount))); None if it is no
    palette PNG. Made once per image and settings."""
    img = _load_image(path, file_gamma, gamma)
    h, w = img.shape[:2]
    index = bump_map.palette_indices(path)
    if index is None or index.shape != (h, w):
        return None
    ft = np.zeros((h, w, 2))
    for col, value in enumerate(every):
        if value is not None:
            ft[..., col] = float(value)
    for col, (entry, amount) in entries:
        ft[index == entry, col] = amount
    return np.concatenate([img, ft], axis=2)


def image_pixels(params: dict, gamma: float | None, span=None) -> np.ndarray | None:
    """An `image_map`'s pixels, (H, W, 4) RGBA in the working colour space, or (H, W, 6)
    with each pixel's filter and transmit when palette entries set them; None (with a
    warning naming `span`, the pigment's source) when the image cannot be had: it renders
    black. Read by the numpy path (image_map) and the kernel's packing (runtime.whitted)."""
    path = params.get("path")
    if not path:
        _warn(f"image `{params.get('file')}` was not found: rendering it black", span)
        return None
    file_gamma = params.get("gamma")
    try:
        img = _load_image(str(path), None if file_gamma is None else float(file_gamma), gamma)
    except OSError as e:
        _warn(f"image `{path}` could not be read ({e}): rendering it black", span)
        return None
    entries = tuple(
        (c, e) for c, k in enumerate(("filter", "transmit")) for e in params.get(f"{k}_entries", ())
    )
    if entries:
        fg = None if file_gamma is None else float(file_gamma)
        every = (params.get("filter"), params.get("transmit"))
        with_entries = _with_palette_entries(str(path), fg, gamma, every, entries)
        if with_entries is None:
            _warn("image_map filter/transmit of a palette entry needs a palette PNG: ignored", span)
        else:
            img = with_entries
    return img


def image_map(params: dict, p: np.ndarray, gamma: float | None, span=None) -> np.ndarray:
    """(N,5) colours of an `image_map` pigment at pattern-space points; `span` (the
    pigment's source) is named when the image cannot be had."""
    n = len(p)
    img = image_pixels(params, gamma, span)
    if img is None:
        return np.zeros((n, 5))
    h, w = img.shape[:2]
    u, v = image_uv(p, int(params.get("map_type", 0)))
    inside = (u >= 0) & (u < 1) & (v >= 0) & (v < 1)
    u = u - np.floor(u)
    v = v - np.floor(v)
    # Image row 0 is the top (v = 1).
    fx = u * w
    fy = (1.0 - v) * h
    if int(params.get("interpolate", 0)) in (2, 4):
        x0f = np.floor(fx - 0.5)
        y0f = np.floor(fy - 0.5)
        tx = (fx - 0.5) - x0f
        ty = (fy - 0.5) - y0f
        x0 = x0f.astype(np.int64) % w
        y0 = y0f.astype(np.int64) % h
        x1 = (x0 + 1) % w
        y1 = (y0 + 1) % h
        rgba = (
            img[y0, x0] * ((1 - tx) * (1 - ty))[:, None]
            + img[y0, x1] * (tx * (1 - ty))[:, None]
            + img[y1, x0] * ((1 - tx) * ty)[:, None]
            + img[y1, x1] * (tx * ty)[:, None]
        )
    else:
        xi = np.clip(fx.astype(np.int64), 0, w - 1)
        yi = np.clip(fy.astype(np.int64), 0, h - 1)
        rgba = img[yi, xi]
    out = np.zeros((n, 5))
    out[:, :3] = rgba[:, :3]
    if img.shape[2] == 6:  # per-pixel filter and transmit (palette entries)
        out[:, 3:5] = rgba[:, 4:6]
    else:
        for col, key in ((3, "filter"), (4, "transmit")):
            if params.get(key) is not None:
                out[:, col] = float(params[key])
    if params.get("use_alpha"):
        out[:, 4] = np.maximum(out[:, 4], 1.0 - rgba[:, 3])
    if params.get("once"):
        # Outside the single copy the pigment is clear (POV-Ray: no colour found).
        out[~inside] = (0.0, 0.0, 0.0, 0.0, 1.0)
    return out


# ------------------------------------------------------------------------ noise
# POV-Ray's own noise (runtime.noise); `noise_generator` in a pattern picks the generator.
def noise_generator(params: dict) -> int:
    """The pattern's noise generator (1, 2 or 3; POV-Ray 3.7's default 2), as the numpy
    path and the compiled one (runtime.whitted) read it."""
    return int(params.get("noise_generator", DEFAULT_GENERATOR) or DEFAULT_GENERATOR)


def turb_params(params: dict) -> tuple[np.ndarray | None, int, float, float]:
    """A pattern's turbulence (vector or None), octaves, omega and lambda, with POV-Ray's
    defaults (read by the compiled path too: runtime.whitted)."""
    t = params.get("turbulence")
    octaves = int(params.get("octaves", 6))
    omega = float(params.get("omega", 0.5))
    lam = float(params.get("lambda", 2.0))
    if t is None:
        return None, octaves, omega, lam
    vec = np.broadcast_to(np.asarray(t, dtype=np.float64), (3,))
    if not vec.any():
        return None, octaves, omega, lam
    return vec, octaves, omega, lam


def turbulence_warp(p: np.ndarray, params: dict) -> np.ndarray:
    """The classic `turbulence` warp: displace the point by turbulence * DTurbulence(p)."""
    vec, octaves, omega, lam = turb_params(params)
    if vec is None:
        return p
    return p + dturbulence(p, octaves, omega, lam) * vec


def _builtin_turb(p: np.ndarray, params: dict, axis: int) -> np.ndarray | float:
    vec, octaves, omega, lam = turb_params(params)
    if vec is None:
        return 0.0
    return vec[axis] * turbulence(p, octaves, omega, lam, noise_generator(params))


def _triangle(v: np.ndarray) -> np.ndarray:
    f = v - np.floor(v)
    return np.where(f < 0.5, 2.0 * f, 2.0 - 2.0 * f)


def _cycloidal(v: np.ndarray) -> np.ndarray:
    """POV-Ray's cycloidal(): sin(2 pi v)."""
    return np.sin(2.0 * math.pi * (v - np.floor(v)))


def bozo(p: np.ndarray, params: dict) -> np.ndarray:
    """bozo, spotted and bumps as pigments: the noise itself."""
    return noise(p, noise_generator(params))


def granite(p: np.ndarray, params: dict) -> np.ndarray:
    """Six octaves of noise at 4x scale, each half as strong: |0.5 - n| for the original
    generator, min(|1 - 2n|, 0.5) for the others."""
    gen = noise_generator(params)
    total = np.zeros(len(p))
    freq = 1.0
    for _ in range(6):
        n = noise(p * (4.0 * freq), gen)
        if gen == 1:
            t = np.abs(0.5 - n)
        else:
            t = np.minimum(np.abs(1.0 - 2.0 * n), 0.5)
        total += t / freq
        freq *= 2.0
    return total


def marble(p: np.ndarray, params: dict) -> np.ndarray:
    """x bent by the pattern's own turbulence (its wave, triangle by default, makes bands)."""
    return p[:, 0] + _builtin_turb(p, params, 0)


def wood(p: np.ndarray, params: dict) -> np.ndarray:
    """The distance from the z axis (rings through the triangle wave). Turbulence bends the
    rings the way POV-Ray's wood does: x += sin(2 pi (x + DTurbulence.x) turbulence.x),
    the same for y."""
    x, y = p[:, 0], p[:, 1]
    vec, octaves, omega, lam = turb_params(params)
    if vec is not None:
        d = dturbulence(p, octaves, omega, lam)
        x = x + _cycloidal((x + d[:, 0]) * vec[0])
        y = y + _cycloidal((y + d[:, 1]) * vec[1])
    return np.hypot(x, y)


def wrinkles(p: np.ndarray, params: dict) -> np.ndarray:
    """Ten octaves of noise, each twice as fine and half as strong, halved (POV-Ray's
    wrinkles pigment); generators 2 and 3 stretch each octave to 2n - 0.5, clipped."""
    gen = noise_generator(params)

    def octave(q: np.ndarray) -> np.ndarray:
        n = noise(q, gen)
        return n if gen == 1 else np.clip(2.0 * n - 0.5, 0.0, 1.0)

    total = octave(p)
    lam, omega = 2.0, 0.5
    for _ in range(1, 10):
        total += omega * octave(p * lam)
        lam *= 2.0
        omega *= 0.5
    return total / 2.0


def radial(p: np.ndarray, params: dict) -> np.ndarray:
    """The angle around the y axis as a fraction of a turn (0.25 where x = z = 0)."""
    x, z = p[:, 0], p[:, 2]
    on_axis = (np.abs(x) < 0.001) & (np.abs(z) < 0.001)
    return np.where(on_axis, 0.25, 0.25 + (np.arctan2(x, z) + math.pi) / (2.0 * math.pi))


def _spiral_arg(p: np.ndarray, params: dict) -> tuple[np.ndarray, np.ndarray]:
    """(distance from the z axis, z + distance + arms * angle / 2 pi + turbulence)."""
    x, y, z = p[:, 0], p[:, 1], p[:, 2]
    arms = float(params.get("arms", 1.0))
    rad = np.hypot(x, y)
    safe = np.where(rad > 0, rad, 1.0)
    s = np.arcsin(np.clip(y / safe, -1.0, 1.0))
    phi = np.where(rad == 0, 0.0, np.where(x < 0, 1.5 * math.pi - s, 0.5 * math.pi + s))
    return rad, z + rad + arms * phi / (2.0 * math.pi) + _builtin_turb(p, params, 0)


def spiral1(p: np.ndarray, params: dict) -> np.ndarray:
    """Spirals around the z axis with `arms` arms (through the triangle wave by default)."""
    return _spiral_arg(p, params)[1]


def spiral2(p: np.ndarray, params: dict) -> np.ndarray:
    rad, arg = _spiral_arg(p, params)
    return _triangle(rad) + _triangle(arg)


def ripples(p: np.ndarray, params: dict) -> np.ndarray:
    """Concentric sine waves from POV-Ray's wave sources (10 unless global_settings'
    number_of_waves says), averaged to [0, 1]."""
    total = np.zeros(len(p))
    sources, _ = wave_tables(wave_count(params))
    for src in sources:
        length = np.linalg.norm(p - src, axis=1)
        total += _cycloidal(length)
    return 0.5 + total / (2.0 * len(sources))


def waves(p: np.ndarray, params: dict) -> np.ndarray:
    """Cosine waves of varied frequencies from POV-Ray's wave sources."""
    total = np.zeros(len(p))
    sources, freqs = wave_tables(wave_count(params))
    for src, f in zip(sources, freqs, strict=True):
        length = np.linalg.norm(p - src, axis=1)
        length = np.where(length == 0.0, 1.0, length)
        total += _cycloidal(length * f) / f
    return 0.2 * (2.5 + total / len(sources))


def dents(p: np.ndarray, params: dict) -> np.ndarray:
    return noise(p, noise_generator(params)) ** 3


def agate(p: np.ndarray, params: dict) -> np.ndarray:
    """0.5 (1 + sin(2 pi (1.3 agate_turb turbulence + 1.1 z)))^0.77; the turbulence uses
    the pattern's octaves/omega/lambda (6, 0.5, 2 unless given)."""
    turb = float(params.get("agate_turb", 1.0))
    _, octaves, omega, lam = turb_params(params)
    t = turb * turbulence(p, octaves, omega, lam, noise_generator(params))
    value = 0.5 * (_cycloidal(1.3 * t + 1.1 * p[:, 2]) + 1.0)
    return np.clip(value, 0.0, 1.0) ** 0.77


def cells(p: np.ndarray, params: dict) -> np.ndarray:
    """One random value per unit cube (POV-Ray's table entry for the cube's hash)."""
    c = np.floor(p + CHECKER_OFFSET).astype(np.int64)
    return noise_tables().pattern_rands[hash3d(c[:, 0], c[:, 1], c[:, 2])]


# The cubes whose random points can be nearest: the 3x3x3 block around the point's cube and
# the 3x3 squares beyond each of its faces (81 in all).
_CRACKLE_CUBES = np.array(
    [
        (dx, dy, dz)
        for dx in range(-2, 3)
        for dy in range(-2, 3)
        for dz in range(-2, 3)
        if (abs(dx) == 2) + (abs(dy) == 2) + (abs(dz) == 2) <= 1
    ],
    dtype=np.int64,
)


def crackle(p: np.ndarray, params: dict) -> np.ndarray:
    """Voronoi cells around one random point per unit cube (POV-Ray's points: cube corner
    plus three table entries from the cube's hash): `form` weights the distances to the
    nearest, second and third points (default <-1, 1, 0>: the cracks are 0), measured with
    the `metric` exponent and `offset` added as POV-Ray does; `solid` gives every cell the
    noise at its point instead."""
    form = np.broadcast_to(np.asarray(params.get("form", (-1.0, 1.0, 0.0)), float), (3,))
    metric = float(params.get("metric", 2.0))
    offset = float(params.get("offset", 0.0))
    base = np.floor(p - 1.0e-10).astype(np.int64)
    rands = noise_tables().pattern_rands
    n = len(p)
    sums = np.empty((n, len(_CRACKLE_CUBES)))
    points = np.empty((n, len(_CRACKLE_CUBES), 3))
    for j, d in enumerate(_CRACKLE_CUBES):
        c = base + d
        seed = hash3d(c[:, 0], c[:, 1], c[:, 2])
        pt = c + np.stack([rands[seed + k] for k in range(3)], axis=1)
        points[:, j] = pt
        diff = np.abs(pt - p)
        if metric == 2.0:
            sums[:, j] = (diff * diff).sum(axis=1)
        elif metric == 1.0:
            sums[:, j] = diff.sum(axis=1)
        else:
            sums[:, j] = (diff**metric).sum(axis=1)
    order = np.argpartition(sums, 2, axis=1)[:, :3]
    three = np.take_along_axis(sums, order, axis=1)
    rank = np.argsort(three, axis=1)
    three = np.take_along_axis(three, rank, axis=1)
    nearest = order[np.arange(n), rank[:, 0]]
    if offset:
        three = three + (offset * offset if metric == 2.0 else offset**metric)
    if params.get("solid"):
        return noise(points[np.arange(n), nearest], noise_generator(params))
    dist = three if metric == 1.0 else three ** (1.0 / metric)
    return np.clip(dist @ form, 0.0, 1.0)


def quilted(p: np.ndarray, params: dict) -> np.ndarray:
    """Cushions in every unit cube: the offset from the cube's centre scaled by a cubic
    Bezier of its length (control points control0, control1; default 1, 1), then the mean
    of its absolute components."""
    return np.abs(_quilt_offset(p, params)).sum(axis=1) / 3.0


def _quilt_offset(p: np.ndarray, params: dict) -> np.ndarray:
    """(N,3) the quilted pattern's offset from each unit cube's centre, scaled by the
    cubic of its length; as a normal it is the bump itself (normal.cpp's quilted)."""
    c0 = float(params.get("control0", 1.0))
    c1 = float(params.get("control1", 1.0))
    v = p - np.floor(p) - 0.5
    t = np.linalg.norm(v, axis=1)
    it = 1.0 - t
    # POV-Ray scales the Bezier by 1/sqrt(3/4) (2/sqrt(3) printed to ten digits).
    k = (t**3 + 3.0 * t * it * it * c0 + 3.0 * t * t * it * c1) * 1.154700538
    return v * k[:, None]


# Patterns whose turbulence is part of the pattern, not a warp of the point.
def function_pattern(p: np.ndarray, params: dict) -> np.ndarray:
    """`function { … }` as a pattern: the user function at the point; values above 1 wrap
    (fmod 1) as POV-Ray's function pattern does, negatives wrap in `apply_wave`."""
    fn = params.get("function")
    if fn is None:
        return np.zeros(len(p))
    value = _compiled_function(fn)(p)
    value = np.where(np.isfinite(value), value, 0.0)
    return np.where(value > 1.0, np.fmod(value, 1.0), value)


_FUNCTIONS: dict[int, tuple[ir.Function, object]] = {}


def pigment_pattern(p: np.ndarray, params: dict) -> np.ndarray:
    """`pigment_pattern { … }`: the grey value of the pigment at the pattern-space point
    (POV-Ray's weights 0.297, 0.589, 0.114), the pigment's own transforms on top."""
    pig = params.get("pigment")
    if pig is None:
        return np.zeros(len(p))
    return evaluate(pig, p)[:, :3] @ np.array([0.297, 0.589, 0.114])


def _compiled_function(fn: ir.Function):
    hit = _FUNCTIONS.get(id(fn))
    if hit is None:
        from runtime.functions import compile_xyz

        hit = _FUNCTIONS[id(fn)] = (fn, compile_xyz(fn))  # fn kept alive: its id stays unique
    return hit[1]


def pattern_value(
    pattern: ir.Pigment, points: np.ndarray, normals: np.ndarray | None = None
) -> np.ndarray:
    """(N,) the pattern's value at world points, as `function { pattern { … } }` gives it:
    the pattern's transform and turbulence applied, then frequency, phase and wave; no map.
    List patterns give their index (checker 0 or 1, brick 0 mortar or 1 brick …).
    `normals`: the surface's at the points, for the slope pattern (as `evaluate`)."""
    points = np.asarray(points, dtype=np.float64).reshape(-1, 3)
    kind = pattern.pattern
    if kind == "solid":
        return np.zeros(len(points))
    p = pattern_points(pattern, points)
    if kind not in BUILT_IN_TURBULENCE:
        p = turbulence_warp(p, pattern.params)
    if kind in LIST_PATTERNS:
        return LIST_PATTERNS[kind](p, pattern.params).astype(np.float64)
    if kind == "slope":
        return apply_wave(slope(p, points, normals, pattern.params), pattern.params, kind)
    fn = CONTINUOUS_PATTERNS.get(kind)
    if fn is None:
        _warn(f"pattern `{kind}` is not supported yet in a function: its value is 0", pattern.span)
        return np.zeros(len(points))
    return apply_wave(fn(p, pattern.params), pattern.params, kind)


def entry_weights(
    pattern: ir.Pigment, keys: np.ndarray, points: np.ndarray, normals: np.ndarray | None = None
) -> np.ndarray:
    """(N, K) weights of the K entries of a patterned texture (or any blend map) at world
    points, each row summing to 1: list patterns pick their entry (index clamped to the
    list), `average` weights every entry by its key, other patterns blend the two map
    entries around the pattern's value as POV-Ray's Search_Blend_Map does. `normals`: the
    surface's at the points (turned toward the ray), for the slope pattern."""
    points = np.asarray(points, dtype=np.float64).reshape(-1, 3)
    n, k = len(points), len(keys)
    out = np.zeros((n, k))
    if k == 0:
        return out
    kind = pattern.pattern
    if kind == "average":
        total = float(np.sum(keys)) or 1.0
        out[:] = np.asarray(keys, dtype=np.float64) / total
        return out
    value = pattern_value(pattern, points, normals)
    rows = np.arange(n)
    if kind in LIST_PATTERNS:
        index = np.clip(value.astype(np.int64), 0, k - 1)
        out[rows, index] = 1.0
        return out
    lo, hi, frac = blend_indices(np.asarray(keys, dtype=np.float64), value)
    np.add.at(out, (rows, lo), 1.0 - frac)
    np.add.at(out, (rows, hi), frac)
    return out


BUILT_IN_TURBULENCE = {"marble", "wood", "spiral1", "spiral2", "agate"}


CONTINUOUS_PATTERNS = {
    "gradient": gradient,
    "onion": onion,
    "spherical": spherical,
    "cylindrical": cylindrical,
    "planar": planar,
    "boxed": boxed,
    "leopard": leopard,
    "bozo": bozo,
    "spotted": bozo,
    "bumps": bozo,
    "granite": granite,
    "marble": marble,
    "wood": wood,
    "wrinkles": wrinkles,
    "radial": radial,
    "spiral1": spiral1,
    "spiral2": spiral2,
    "ripples": ripples,
    "tiling": tiling,
    "waves": waves,
    "dents": dents,
    "agate": agate,
    "cells": cells,
    "crackle": crackle,
    "mandel": mandel,
    "julia": julia,
    "magnet": magnet,
    "quilted": quilted,
    "function": function_pattern,
    "density_file": density_file,
    "pigment_pattern": pigment_pattern,
}


# Patterns whose wave is a triangle unless the scene names one (POV-Ray's parser sets it).
TRIANGLE_BY_DEFAULT = frozenset({"marble", "wood", "spiral1", "spiral2"})


def apply_wave(value: np.ndarray, params: dict, kind: str = "") -> np.ndarray:
    """POV-Ray's frequency/phase wrap, then the wave type."""
    freq = float(params.get("frequency", 1.0))
    phase = float(params.get("phase", 0.0))
    if freq != 0.0:
        value = np.fmod(value * freq + phase, WAVE_MODULUS)
    value = np.where(value < 0.0, value - np.floor(value), value)
    wave = params.get("wave", "triangle_wave" if kind in TRIANGLE_BY_DEFAULT else "ramp_wave")
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
        value = np.power(value, float(params.get("wave_exponent", params.get("exponent", 1.0))))
    return value


def _map(
    pigment: ir.Pigment,
    value: np.ndarray,
    points: np.ndarray,
    gamma: float | None,
    normals: np.ndarray | None = None,
    uv: np.ndarray | None = None,
) -> np.ndarray:
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
            col = evaluate(sub, points[rows], gamma, _rows(normals, rows), _rows(uv, rows))
            w = np.where(use_lo[rows], 1.0 - frac[rows], 0.0) + np.where(
                use_hi[rows], frac[rows], 0.0
            )
            out[rows] += w[:, None] * col
        return out
    cmap = colour_map(pigment)
    keys = np.array([k for k, _ in cmap], dtype=np.float64)
    cols = np.array([c for _, c in cmap], dtype=np.float64)
    lo, hi, frac = blend_indices(keys, value)
    return cols[lo] * (1.0 - frac[:, None]) + cols[hi] * frac[:, None]


def colour_map(pigment: ir.Pigment) -> tuple[tuple[float, ir.Color], ...]:
    """The colour map a pattern blends: its own, or POV-Ray's default for its kind."""
    if pigment.color_map:
        return tuple(pigment.color_map)
    kind = pigment.pattern
    if kind == "mandel" and fractal_exponent(pigment.params) != 2:
        kind = "mandel3"  # POV-Ray's default map is the type MANDEL_PATTERN's alone
    return DEFAULT_MAPS.get(kind, DEFAULT_MAP)


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


def _fallback(pigment: ir.Pigment, points: np.ndarray, gamma: float | None) -> np.ndarray:
    if pigment.list:
        return evaluate(pigment.list[0], points, gamma)
    if pigment.color_map:
        c = pigment.color_map[0][1]
    elif pigment.pigment_map:
        return evaluate(pigment.pigment_map[0][1], points, gamma)
    else:
        c = pigment.color
    return np.broadcast_to(np.asarray(c, dtype=np.float64), (len(points), 5)).copy()


# --------------------------------------------------------------- properties
def may_transmit(pigment: ir.Pigment) -> bool:
    """Can any point of this pigment let light through (filter or transmit not 0: POV-Ray
    traces behind a negative transmit too, which subtracts what is behind)?"""
    if pigment.pattern == "image_map":
        prm = pigment.params
        return bool(
            prm.get("once")
            or prm.get("use_alpha")
            or prm.get("filter")
            or prm.get("transmit")
            or any(a for _, a in prm.get("filter_entries", ()) + prm.get("transmit_entries", ()))
        )
    if pigment.pattern == "solid":
        return pigment.color[3] != 0 or pigment.color[4] != 0
    if any(c[3] != 0 or c[4] != 0 for _, c in pigment.color_map):
        return True
    return any(may_transmit(q) for q in pigment.list) or any(
        may_transmit(q) for _, q in pigment.pigment_map
    )


# --------------------------------------------------------------- normal patterns
# POV-Ray's sampling distance for the slope of a pattern used as a normal.
NORMAL_DELTA: float = 0.02


def wave_count(params: dict) -> int:
    # global_settings' number_of_waves, which the evaluator gives every pattern
    return max(1, int(params.get("number_of_waves", 10) or 10))


@cache
def wave_tables(count: int = 10) -> tuple[np.ndarray, np.ndarray]:
    """POV-Ray's ripple/wave sources and frequencies: source i is DNoise(<i, 0, 0>)
    normalised, frequency i a draw of POV-Ray's LCG (seeded -560851967) in [0.01, 1.01]."""
    sources = dnoise(np.array([[float(i), 0.0, 0.0] for i in range(count)]))
    sources /= np.linalg.norm(sources, axis=1, keepdims=True)
    x = -560851967 & 0xFFFFFFFF
    freqs = []
    for _ in range(count):
        x = (x * 1812433253 + 12345) & 0xFFFFFFFF
        freqs.append(((x >> 16) & 0x7FFF) / 32767.0 + 0.01)
    return sources, np.array(freqs)


def perturb_normal(
    normal: ir.Normal,
    points: np.ndarray,
    n_world: np.ndarray,
    no_bump_scale: bool = False,
    unit: bool = True,
    uv: np.ndarray | None = None,
) -> np.ndarray:
    """(N,3) unit normals after a `normal { … }` pattern at world points. The perturbation
    happens in pattern space (so scaling a bump pattern scales its bumps), then the normal
    goes back to world space.

    `no_bump_scale` (the texture's flag, or the normal's own `params["no_bump_scale"]`;
    a normal_map passes it to its entries) is POV-Ray's DONT_SCALE_BUMPS_FLAG: Warp_Normal
    and UnWarp_Normal then leave the normal's length alone, so a pattern scaled up by s
    perturbs it 1/s as much. `unit` False (a normal_map's entry with the flag) returns the
    perturbed normal unnormalised, as POV-Ray's Perturb_Normal leaves it to the blend.
    `uv`: the surface's <u, v, 0>, where a uv-mapped normal is evaluated instead."""
    if uv is not None and normal.params.get("uv_mapping"):
        points = uv
    keep = no_bump_scale or bool(normal.params.get("no_bump_scale"))
    p = pattern_points(normal, points)
    lin = pattern_linear(normal)
    # Normals map with the inverse transpose: world -> pattern space is M^T n, normalised
    # there as POV-Ray does, so the bump strength does not depend on the pattern's scale.
    n = n_world if lin is None else n_world @ lin
    if not keep:
        n = n / np.maximum(np.linalg.norm(n, axis=1, keepdims=True), 1e-300)
    amount = float(normal.depth)
    kind = normal.pattern
    if kind == "none" or amount == 0.0:
        return n_world
    if kind not in BUILT_IN_TURBULENCE:
        p = turbulence_warp(p, normal.params)
    nmap = normal.params.get("normal_map")
    if nmap:
        n = _normal_map(normal, nmap, p, n, keep, (points, n_world), uv)
        # POV-Ray normalises a normal_map's blend whatever the flag says
        unit = unit or kind != "average"
    elif kind == "bumps":
        n = n + amount * dnoise(p)
    elif kind == "dents":
        k = noise(p, noise_generator(normal.params)) ** 3 * amount
        n = n + k[:, None] * dnoise(p)
    elif kind == "wrinkles":
        total = np.zeros_like(p)
        scale = 1.0
        for _ in range(10):
            total += np.abs(dnoise(p * scale)) / scale
            scale *= 2.0
        n = n + amount * total
    elif kind == "bump_map":
        n = bump_map.perturb(normal.params.get("image", {}), amount, p, n)
    elif kind == "quilted":
        # one of POV-Ray's normal-only patterns: the offset is added, not differentiated
        n = n + amount * _quilt_offset(p, normal.params)
    elif kind in ("ripples", "waves"):
        freq = float(normal.params.get("frequency", 1.0))
        phase = float(normal.params.get("phase", 0.0))
        count = wave_count(normal.params)
        # normal.cpp's ripples and waves: both are sines (POV-Ray's cycloidal)
        for src, f in zip(*wave_tables(count), strict=True):
            d = p - src
            length = np.linalg.norm(d, axis=1)
            length = np.where(length > 0, length, 1.0)
            if kind == "ripples":
                s = _cycloidal(length * freq + phase) * amount / count
            else:
                s = _cycloidal(length * freq * f + phase) * amount / (count * f)
            n = n + (d / length[:, None]) * s[:, None]
    else:
        fn = CONTINUOUS_PATTERNS.get(kind)
        if fn is None and kind not in LIST_PATTERNS and kind != "slope":
            _warn(
                f"normal pattern `{kind}` is not supported yet: the surface stays smooth",
                normal.span,
            )
            return n_world
        n = n + (SLOPE_GAIN * amount) * _slope(kind, p, normal.params, (points, n_world))
    if lin is not None:
        n = n @ np.linalg.inv(lin)
    if keep and not unit:
        return n
    length = np.linalg.norm(n, axis=1, keepdims=True)
    return np.where(length > 0, n / np.where(length > 0, length, 1.0), n_world)


def _normal_map(
    normal: ir.Normal,
    entries,
    p: np.ndarray,
    n: np.ndarray,
    keep: bool = False,
    at: _Surface | None = None,
    uv: np.ndarray | None = None,
) -> np.ndarray:
    """A normal_map (POV-Ray's Perturb_Normal): the normals of the two entries around the
    pattern's value, each perturbing the normal at the pattern-space point, blended by
    weight; with `average`, every entry's normal weighted by its value (Do_Average_Normals).
    The entries live in this normal's pattern space (their transforms come on top); `keep`
    (no_bump_scale) passes on to them, as POV-Ray's NormalBlendMap::Post does. `at`: the
    world points and normals, for a slope pattern; `uv` the surface's, for a uv-mapped
    entry."""
    keys = np.array([k for k, _ in entries], dtype=np.float64)
    kind = normal.pattern
    if kind == "average":
        total = float(keys.sum()) or 1.0
        out = np.zeros_like(n)
        for k, sub in entries:
            out += (k / total) * perturb_normal(sub, p, n, keep, unit=False, uv=uv)
        return out
    if kind not in LIST_PATTERNS and kind not in CONTINUOUS_PATTERNS and kind != "slope":
        _warn(
            f"normal pattern `{kind}` is not supported yet: the surface stays smooth", normal.span
        )
        return n
    value = _pattern_value(kind, p, normal.params, at)
    lo, hi, frac = blend_indices(keys, value)
    out = np.zeros_like(n)
    for i, (_, sub) in enumerate(entries):
        rows = np.nonzero((lo == i) | (hi == i))[0]
        if not len(rows):
            continue
        f = frac[rows]
        w = np.where(lo[rows] == i, 1.0 - f, 0.0) + np.where(hi[rows] == i, f, 0.0)
        out[rows] += w[:, None] * perturb_normal(
            sub, p[rows], n[rows], keep, unit=False, uv=_rows(uv, rows)
        )
    return out


def slope_map(value: np.ndarray, entries) -> np.ndarray:
    """POV-Ray's Do_Slope_Map: the height between the two entries around the value, a cubic
    Hermite curve through their <height, slope> pairs (the slope per unit of the interval
    between them); at or beyond an end, the end's height."""
    keys = np.array([k for k, _ in entries], dtype=np.float64)
    ps = np.array([s for _, s in entries], dtype=np.float64)
    lo, hi, t = blend_indices(keys, value)
    h1, s1 = ps[lo, 0], ps[lo, 1]
    h2, s2 = ps[hi, 0], ps[hi, 1]
    tt = t * t
    rv = tt * t * (s1 + s2 + 2.0 * (h1 - h2)) - tt * (2.0 * s1 + s2 + 3.0 * (h1 - h2)) + t * s1 + h1
    return np.where(lo == hi, h2, rv)


# The world points and surface normals a normal pattern is evaluated at (for slope).
_Surface = tuple[np.ndarray, np.ndarray]


def _pattern_value(
    kind: str, p: np.ndarray, params: dict, at: _Surface | None = None
) -> np.ndarray:
    if kind in LIST_PATTERNS:
        value = LIST_PATTERNS[kind](p, params).astype(np.float64)
    elif kind == "slope":
        points, normals = at if at is not None else (p, None)
        value = apply_wave(slope(p, points, normals, params), params, kind)
    else:
        value = apply_wave(CONTINUOUS_PATTERNS[kind](p, params), params, kind)
    slopes = params.get("slope_map")
    return slope_map(value, slopes) if slopes else value


# A regular tetrahedron of unit vectors: POV-Ray samples a pattern used as a normal at
# these four offsets (NORMAL_DELTA away) and adds value * direction to the normal.
_PYRAMID = np.array(
    [
        [2.0 * math.sqrt(2.0) / 3.0, -1.0 / 3.0, 0.0],
        [-math.sqrt(2.0) / 3.0, -1.0 / 3.0, math.sqrt(6.0) / 3.0],
        [-math.sqrt(2.0) / 3.0, -1.0 / 3.0, -math.sqrt(6.0) / 3.0],
        [0.0, 1.0, 0.0],
    ]
)
# POV-Ray's fudge factor for pattern slopes (the depth is multiplied by -5).
SLOPE_GAIN: float = -5.0


def _slope(kind: str, p: np.ndarray, params: dict, at: _Surface | None = None) -> np.ndarray:
    """(N,3) sum of value(p + delta u_i) u_i over the tetrahedron (≈ 4/3 delta grad),
    delta the normal's `accuracy` (0.02); scaled by 0.02 / delta as POV-Ray scales the
    amount, so a finer accuracy samples closer without flattening the bumps."""
    delta = float(params.get("accuracy", NORMAL_DELTA))
    g = np.zeros_like(p)
    for u in _PYRAMID:
        g += _pattern_value(kind, p + delta * u, params, at)[:, None] * u
    return g if delta == NORMAL_DELTA else g * (NORMAL_DELTA / delta)
