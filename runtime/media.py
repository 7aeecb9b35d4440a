"""Participating media along ray segments: POV-Ray's ComputeMedia over numpy batches.

Where a ray runs between its origin and its hit, each region it crosses adds its media:
the inside of a hollow object whose interior holds media (found from the object's surface
crossings along the ray and an inside test between them), and the atmosphere (the
scene-wide `media`); none inside a non-hollow object. Every region is sampled at
S stratified, jittered depths per piece; all samples of a ray are sorted by depth, so

    colour = colour_behind * exp(-tau(0, T)) + sum_k source_k * ds_k * exp(-tau(0, t_k))

with tau the optical depth (extinction = absorption + extinction * scattering, times the
densities), and source = emission + scattering * sum over lights of the phase function
times the light reaching the sample (shadow rays; `media_attenuation` dims that light by
the media on its way; lights with `media_interaction off` are left out). The phase
functions are POV-Ray's (isotropic 1, Mie haze and murky, Rayleigh, Henyey-Greenstein),
not normalised, averaged over every media the point is in. Method 3 (POV-Ray's default)
samples POV-Ray's own depths (runtime.adaptive_media); methods 1 and 2 are random in
POV-Ray, and here the stratified depths above reach the same expected value.

Light reaching a sample comes through runtime.lights (shadow rays), which reaches back here
only through the context: `ctx.media.transmittance` dims light by the media on its way.
"""

from __future__ import annotations

import numpy as np

from lang import ir
from runtime import adaptive_media, patterns, ray_random, shading
from runtime.lights import shadow

# Rays that hit nothing cross this much atmosphere (POV-Ray's MAX_DISTANCE).
MAX_DISTANCE: float = 1.0e7
# Samples per piece of a ray inside one region: at least MIN_SAMPLES, at most MAX_SAMPLES.
MIN_SAMPLES: int = 16
MAX_SAMPLES: int = 64
# Samples per piece along shadow rays (extinction only; constant media need only one).
SHADOW_SAMPLES: int = 4


class Region:
    """Media of one region: `node` (a tracer node whose inside holds them) or the atmosphere."""

    def __init__(self, media: tuple[ir.Media, ...], node=None, beams: bool = False):
        self.media = media
        self.node = node
        self.constant = all(not m.density for m in media)
        self.scatters = any(max(m.scattering) != 0 for m in media)
        # POV-Ray's method 3 (adaptive, at fixed depths) or its random depths (1 and 2).
        # Scattering media under spot or cylinder lights stay with the random depths:
        # POV-Ray puts method 3's intervals where those beams light the ray, which
        # adaptive_media does not do, and a few fixed depths would miss the beams.
        self.adaptive = adaptive_media.uses_method_3(media) and not (beams and self.scatters)
        self.samples = min(
            MAX_SAMPLES, max(MIN_SAMPLES, max(m.intervals * m.samples[0] * 4 for m in media))
        )


class MediaScene:
    def __init__(self, prepared):
        objs = prepared.objects
        beams = any(
            light.kind in ("spotlight", "cylinder") and light.media_interaction
            for light in prepared.scene.lights
        )
        self.regions: list[Region] = []
        for node in prepared.tracer.nodes:
            leaf = node.leaves[0]
            o = objs[leaf]
            if o.interior.media and o.hollow:
                self.regions.append(Region(tuple(o.interior.media), node, beams))
        media = tuple(prepared.scene.media)
        self.atmosphere = Region(media, None, beams) if media else None
        self.nonhollow = np.array([not o.hollow for o in objs], dtype=bool)

    @property
    def active(self) -> bool:
        return bool(self.regions) or self.atmosphere is not None

    def transmittance(self, ctx, points, dirs, dist, atmosphere: bool = True) -> np.ndarray:
        """(N,3) share of light let through by the media between points and points + dist*dirs.
        As POV-Ray's shadow rays: an object's media up to the last of its surfaces the ray
        crosses (each surface hit adds the media behind it); the stretch from there to the
        light, and the atmosphere, only when `atmosphere` (the light's media_attenuation). A
        light inside a media container is not dimmed by it by default."""
        n = len(points)
        tau = np.zeros((n, 3))
        t_end = np.minimum(dist, MAX_DISTANCE)
        key = ray_random.keys(points, dirs, salt=_SHADOW_SALT)
        allowed = np.ones(n, dtype=bool)
        regions = _all_regions(self) if atmosphere else self.regions
        for i, region in enumerate(regions):
            if region.adaptive and not region.constant:

                def extinction(rows, t, region=region):
                    ext = coefficients(region, points[rows] + t[:, None] * dirs[rows], ctx.gamma)[0]
                    return ext, np.zeros_like(ext)

                a = _adaptive(
                    region, points, dirs, t_end, allowed, key, i, extinction, not atmosphere
                )
                if a is None:
                    continue
                r, _, ds, ext, _ = a
            else:
                count = _count(region, True)
                s = _samples(region, points, dirs, t_end, allowed, count, key, i, not atmosphere)
                if s is None:
                    continue
                r, t, ds = s
                p = points[r] + t[:, None] * dirs[r]
                ext, _, _ = coefficients(region, p, ctx.gamma)
            for ch in range(3):
                tau[:, ch] += np.bincount(r, ext[:, ch] * ds, minlength=n)
        return np.exp(-tau)


def build(prepared) -> MediaScene | None:
    m = MediaScene(prepared)
    return m if m.active else None


def phase(media: ir.Media, alpha: np.ndarray) -> np.ndarray:
    """POV-Ray's phase functions at alpha = cos(angle between the ray and the light)."""
    t = media.scattering_type
    if t == 2:
        return 0.576655375 * (1.0 + 9.0 * np.power(0.5 * (1.0 + alpha), 8.0))
    if t == 3:
        return 0.495714547 * (1.0 + 50.0 * np.power(0.5 * (1.0 + alpha), 32.0))
    if t == 4:
        return 0.799372013 * (1.0 + alpha * alpha)
    if t == 5:
        g = media.eccentricity
        return (1.0 - g * g) / np.power(1.0 + g * g - 2.0 * g * alpha, 1.5)
    return np.ones_like(alpha)


def coefficients(region: Region, points: np.ndarray, gamma) -> tuple[np.ndarray, ...]:
    """(extinction, emission, scattering), each (M,3), of the region's media at points."""
    m_count = len(points)
    ext = np.zeros((m_count, 3))
    emis = np.zeros((m_count, 3))
    scat = np.zeros((m_count, 3))
    for m in region.media:
        dens = np.ones((m_count, 3))
        for pig in m.density:
            dens = dens * patterns.evaluate(pig, points, gamma)[:, :3]
        sc = np.asarray(m.scattering, dtype=np.float64)
        ext += dens * (np.asarray(m.absorption, dtype=np.float64) + m.extinction * sc)
        emis += dens * np.asarray(m.emission, dtype=np.float64)
        scat += dens * sc
    return ext, emis, scat


def _pieces(region: Region, o, d, t_end, allowed, open_end: bool = False):
    """(N,J) starts, ends and a mask of the pieces of each ray inside the region; with
    `open_end`, without the piece that reaches t_end inside the region (no surface there)."""
    n = len(o)
    if region.node is None:
        t0 = np.zeros((n, 1))
        t1 = t_end[:, None].copy()
        return t0, t1, (allowed & (t_end > 0))[:, None]
    c = region.node.crossings(o, d)
    t = np.where((c.t > 1e-9) & (c.t < t_end[:, None]), c.t, t_end[:, None])
    t = np.sort(t, axis=1)
    bounds = np.concatenate([np.zeros((n, 1)), t, t_end[:, None]], axis=1)
    t0, t1 = bounds[:, :-1], bounds[:, 1:]
    mask = (t1 > t0 + 1e-9) & allowed[:, None]
    rows, cols = np.nonzero(mask)
    if len(rows):
        mid = 0.5 * (t0[rows, cols] + t1[rows, cols])
        inside = region.node.inside(o[rows] + mid[:, None] * d[rows])
        mask[rows[~inside], cols[~inside]] = False
    if open_end:
        mask &= t1 < t_end[:, None]  # the others end at a crossing: crossings past t_end are t_end
    return t0, t1, mask


# Shadow rays and eye rays may coincide (a point lit along the way it was seen): their
# jitter streams stay apart.
_SHADOW_SALT = 1


def _samples(region: Region, o, d, t_end, allowed, count: int, key: np.ndarray, which: int,
             open_end: bool = False):  # fmt: skip
    """Flat (ray, depth, ds) of `count` stratified jittered samples per piece; the jitter
    of a piece comes from its ray's `key`, the region's number `which` and the piece's
    (runtime.ray_random), never from the batch the ray is in."""
    t0, t1, mask = _pieces(region, o, d, t_end, allowed, open_end)
    rows, cols = np.nonzero(mask)
    if not len(rows):
        return None
    a, b = t0[rows, cols], t1[rows, cols]
    ds = (b - a) / count
    piece = ray_random.derive(key[rows], cols.astype(np.uint64) * np.uint64(1 << 16) + which)
    u = (np.arange(count)[None, :] + ray_random.uniforms(piece, count)) * ds[:, None]
    t = (a[:, None] + u).ravel()
    return np.repeat(rows, count), t, np.repeat(ds, count)


def _adaptive(region: Region, o, d, t_end, allowed, key, which: int, evaluate,
              open_end: bool = False):  # fmt: skip
    """Method 3's slabs of the region's pieces of the rays: (ray, depth, length,
    extinction, source), or None where no ray crosses the region."""
    t0, t1, mask = _pieces(region, o, d, t_end, allowed, open_end)
    rows, cols = np.nonzero(mask)
    if not len(rows):
        return None
    piece = ray_random.derive(key[rows], cols.astype(np.uint64) * np.uint64(1 << 16) + which)
    one = region.constant and not region.scatters
    return adaptive_media.sample(region.media, rows, t0[rows, cols], t1[rows, cols], one,
                                 evaluate, piece)  # fmt: skip


def _count(region: Region, shadow: bool) -> int:
    if shadow:
        return 1 if region.constant else SHADOW_SAMPLES
    return region.samples


def _all_regions(ms: MediaScene) -> list[Region]:
    return [*ms.regions, *([ms.atmosphere] if ms.atmosphere is not None else [])]


def _in_scattered(ctx, region: Region, p, ray_dir, scat) -> np.ndarray:
    """(M,3) light from the lights scattered toward the viewer at points p (per unit
    scattering coefficient times scat)."""
    out = np.zeros((len(p), 3))
    rows = np.nonzero(np.abs(scat).max(axis=1) > 0)[0]
    if not len(rows):
        return out
    pts, rd = p[rows], ray_dir[rows]
    acc = np.zeros((len(rows), 3))
    # a light group's lights light its objects only, not the media (POV-Ray's media
    # takes the scene's lights)
    for light in ctx.scene.lights[: ctx.prepared.scene_lights]:
        if not light.media_interaction:
            continue
        ls = shading.sample_light(light, pts)
        col = ls.colour
        lit = np.nonzero(np.abs(col).max(axis=1) > shading.EPSILON)[0]
        if not len(lit):
            continue
        col = col[lit]
        if not light.shadowless:
            col = col * shadow(ctx, light, pts[lit], ls.direction[lit], ls.distance[lit])
            col = col * ctx.media.transmittance(
                ctx, pts[lit], ls.direction[lit], ls.distance[lit], light.media_attenuation
            )
        alpha = np.einsum("ij,ij->i", ls.direction[lit], rd[lit])
        acc[lit] += _phase(ctx.media, region, pts[lit], alpha)[:, None] * col
    out[rows] = acc * scat[rows]
    return out


def _phase(ms: MediaScene, region: Region, p: np.ndarray, alpha: np.ndarray) -> np.ndarray:
    """The phase function at points p of a region: as POV-Ray's, the average over every
    media the ray is in there, so where containers overlap each one's scattering takes
    the phase of all of them."""
    total = np.asarray(sum(phase(m, alpha) for m in region.media), dtype=np.float64)
    count = np.full(len(p), float(len(region.media)))
    if region.node is not None:
        for other in ms.regions:
            if other is region:
                continue
            inside = other.node.inside(p)
            if inside.any():
                total = total + inside * sum(phase(m, alpha) for m in other.media)
                count += inside * len(other.media)
    return total / count


def apply(ctx, o, d, t_hit, hit_obj, normal, col) -> np.ndarray:
    """The colours `col` seen along rays (origins o, unit directions d) at depth t_hit
    (inf on a miss) with the media of the regions the rays cross in between."""
    ms: MediaScene = ctx.media
    n = len(o)
    t_end = np.where(np.isfinite(t_hit), t_hit, MAX_DISTANCE)
    hit = hit_obj >= 0
    leaving = hit & (np.einsum("ij,ij->i", normal, d) > 0)
    # No media at all inside a non-hollow object (a ray leaving one was inside it): POV-Ray
    # computes a ray's media only while every object it is inside is hollow, so a solid
    # object within a media container blanks the container's media too.
    in_solid = np.zeros(n, dtype=bool)
    in_solid[leaving] = ms.nonhollow[hit_obj[leaving]]
    allowed = ~in_solid
    key = ray_random.keys(o, d)
    parts = []
    for i, region in enumerate(_all_regions(ms)):

        def evaluate(r, t, region=region):
            p = o[r] + t[:, None] * d[r]
            ext, emis, scat = coefficients(region, p, ctx.gamma)
            if region.scatters:
                emis = emis + _in_scattered(ctx, region, p, d[r], scat)
            return ext, emis

        if region.adaptive:
            a = _adaptive(region, o, d, t_end, allowed, key, i, evaluate)
            if a is not None:
                r, t, ds, ext, src = a
                parts.append((r, t, ds, ext, src, np.ones(len(r), dtype=bool)))
            continue
        s = _samples(region, o, d, t_end, allowed, _count(region, False), key, i)
        if s is None:
            continue
        r, t, ds = s
        ext, src = evaluate(r, t)
        parts.append((r, t, ds, ext, src, np.zeros(len(r), dtype=bool)))
    if not parts:
        return col
    r = np.concatenate([x[0] for x in parts])
    t = np.concatenate([x[1] for x in parts])
    ds = np.concatenate([x[2] for x in parts])
    ext = np.concatenate([x[3] for x in parts])
    src = np.concatenate([x[4] for x in parts])
    flat = np.concatenate([x[5] for x in parts])
    order = np.lexsort((t, r))
    r, ds, ext, src, flat = r[order], ds[order], ext[order], src[order], flat[order]
    od = ext * ds[:, None]
    cum = np.cumsum(od, axis=0)
    start = np.searchsorted(r, np.arange(n))
    first = np.concatenate([np.zeros((1, 3)), cum])[start]  # optical depth before each ray
    before = cum - od - first[r]
    # Each sample stands for a slab of constant media ds long: its source, attenuated
    # across the slab itself, gives src (1 - exp(-ext ds)) / ext (src ds where ext = 0);
    # method 3's slabs are not attenuated inside (POV-Ray's sum).
    with np.errstate(divide="ignore", invalid="ignore"):
        slab = np.where(od > 1e-12, -np.expm1(-od) / np.where(od > 1e-12, od, 1.0), 1.0)
    slab[flat] = 1.0
    light = src * (ds[:, None] * slab) * np.exp(-before)
    out = col.copy()
    tau = np.zeros((n, 3))
    added = np.zeros((n, 3))
    for ch in range(3):
        tau[:, ch] = np.bincount(r, od[:, ch], minlength=n)
        added[:, ch] = np.bincount(r, light[:, ch], minlength=n)
    return out * np.exp(-tau) + added
