"""The final gather: one bounce traced from every visible point over the radiosity solution.

At a shaded point the renderer asks for the indirect light G arriving there. Instead of
interpolating the patches (whose size then shows at every shadow edge and whose flat
facets stand in for curved objects), the point sends cosine-distributed rays, traces them
with the full shader — direct light exact, emission, reflections, the sky where they
escape — and the surfaces they meet read the patch solution for the light beyond (the
second and further bounces). This is POV-Ray's first radiosity level, taken at every
point instead of an irradiance cache's sample points, so it matches POV-Ray's estimate
where the patches cannot (ambient objects without patches, the sky through openings).

Deterministic: the ray pattern is a fixed lattice rotated per point by a hash of the
point's coordinates, so an image does not depend on tiles, threads or batch order.
Bounded: `rays` per point, capped by `Options.gather_cap` and by a budget of ray casts
per point that counts the shadow rays each gather ray's hit sends (`rays_per_point`).
"""

from __future__ import annotations

import numpy as np

from runtime.context import RADIOSITY_RAYS

# POV-Ray's radiosity rays start one trace level down, at half the weight (its
# recursion settings for the first bounce: trace level 1, weight 0.5 × brightness).
GATHER_LEVEL = 1
GATHER_WEIGHT = 0.5

_GOLDEN = (np.sqrt(5.0) - 1.0) / 2.0

# Ray casts per shaded point the gather may spend (gather rays and their shadow rays):
# 64 gather rays under two point lights. Never fewer than MIN_RAYS gather rays.
WORK_PER_POINT = 192
MIN_RAYS = 16


def rays_per_point(count: int, cap: int, lights) -> int:
    """Gather rays per point: the scene's count, at most `cap`, fewer where every hit
    sends many shadow rays (area lights: one per grid sample, an upper bound)."""
    cost = 1
    for light in lights:
        if light.shadowless:
            continue
        cost += light.area.size1 * light.area.size2 if light.area is not None else 1
    return max(1, min(count, cap, max(MIN_RAYS, WORK_PER_POINT // cost)))


def lattice(k: int) -> np.ndarray:
    """(k,2) points of a Fibonacci lattice in the unit square: stratified in both
    directions for any k."""
    i = np.arange(k)
    return np.stack([(i + 0.5) / k, (i * _GOLDEN) % 1.0], axis=1)


def point_hash(points: np.ndarray) -> np.ndarray:
    """(M,2) uniforms in [0,1) from the bits of each point's coordinates (splitmix64)."""
    bits = np.ascontiguousarray(points, dtype=np.float64).view(np.uint64).reshape(-1, 3)
    with np.errstate(over="ignore"):
        h = bits[:, 0] * np.uint64(0x9E3779B97F4A7C15)
        h ^= bits[:, 1] * np.uint64(0xBF58476D1CE4E5B9)
        h ^= bits[:, 2] * np.uint64(0x94D049BB133111EB)
        out = []
        for _ in range(2):
            h = h + np.uint64(0x9E3779B97F4A7C15)
            z = h
            z = (z ^ (z >> np.uint64(30))) * np.uint64(0xBF58476D1CE4E5B9)
            z = (z ^ (z >> np.uint64(27))) * np.uint64(0x94D049BB133111EB)
            z = z ^ (z >> np.uint64(31))
            out.append((z >> np.uint64(11)).astype(np.float64) / float(1 << 53))
    return np.stack(out, axis=1)


def directions(points: np.ndarray, normals: np.ndarray, rays: int) -> np.ndarray:
    """(M,rays,3) cosine-distributed unit directions about each unit normal: the lattice
    rotated (Cranley–Patterson) by the point's hash."""
    u = (lattice(rays)[None] + point_hash(points)[:, None]) % 1.0
    r, phi = np.sqrt(u[..., 0]), 2 * np.pi * u[..., 1]
    z = np.sqrt(np.maximum(0.0, 1.0 - u[..., 0]))
    n = normals
    a = np.where(np.abs(n[:, :1]) < 0.9, [[1.0, 0, 0]], [[0, 1.0, 0]])
    t = np.cross(n, a)
    t /= np.linalg.norm(t, axis=1, keepdims=True)
    b = np.cross(n, t)
    d = (r * np.cos(phi))[..., None] * t[:, None] + (r * np.sin(phi))[..., None] * b[:, None]
    return d + z[..., None] * n[:, None]


def final_gather(ctx, points: np.ndarray, normals: np.ndarray, rays: int) -> np.ndarray:
    """(M,3) the light arriving at each point from the hemisphere about its normal (POV
    units: mean of the traced colours over cosine-distributed rays), before brightness."""
    return gather_rays(ctx, points, normals, rays, depths=False)[0]


def gather_rays(ctx, points: np.ndarray, normals: np.ndarray, rays: int, depths: bool = True):
    """`final_gather`'s light, and the (M,rays,3) directions and (M,rays) distances (inf:
    the ray escaped) of its rays, which an irradiance cache record needs; the distances
    only when `depths` (None otherwise)."""
    from runtime import integrate  # the tracer; it imports nothing of radiosity

    m = len(points)
    if m == 0 or rays <= 0:
        return np.zeros((m, 3)), np.zeros((m, max(rays, 0), 3)), np.zeros((m, max(rays, 0)))
    d = directions(points, normals, rays)
    o = np.repeat(points, rays, axis=0)
    flat = d.reshape(-1, 3)
    token = RADIOSITY_RAYS.set(True)
    try:
        t = np.full(len(o), np.inf) if depths else None
        col = integrate.trace(ctx, o, flat, np.full(len(o), GATHER_WEIGHT), GATHER_LEVEL, None,
                              depth=t)  # fmt: skip
    finally:
        RADIOSITY_RAYS.reset(token)
    ctx.count("radiosity_rays", len(o))
    return col.reshape(m, rays, 3).mean(axis=1), d, None if t is None else t.reshape(m, rays)
