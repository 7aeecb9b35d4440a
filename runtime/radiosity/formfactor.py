"""Form factors between planar polygonal patches.

F_ij = 1/A_i ∫_{A_i} F(dA → A_j) dA, with the inner factor in closed form: the
differential-area-to-polygon form factor is Lambert's contour integral (Nusselt's analogue:
the polygon's solid angle projected onto the receiver's tangent plane, divided by π)

    F(dA → A_j) = 1/(2π) |Σ_k γ_k n · (R_k × R_{k+1}) / |R_k × R_{k+1}||,

R_k the unit vectors from the point to the vertices, γ_k the angle between R_k and R_{k+1}.
The polygon is first clipped to the receiver's hemisphere (Sutherland–Hodgman), so the
formula holds for any placement. The outer integral is a Gauss rule over the source patch
(tensor Gauss–Legendre through the bilinear map of a quad, collapsed on triangles, any
order), so by default

- a patch's row sum equals the quadrature of Σ_j F(dA → A_j), which is exactly 1 at every
  point that sees a closed polyhedron: closed scenes conserve energy to rounding, whatever
  the quadrature order;
- reciprocity A_i F_ij = A_j F_ji holds to the outer quadrature error (exact for the inner
  integral, O(h^{2n}) for smooth integrands; adjacent patches converge more slowly because
  the kernel has an x·log x term at a shared edge).

`symmetric=True` swaps the two: reciprocity exact, row sums to the quadrature error, for
half the work. `far_order` lowers the order for distant pairs (row sums then hold to the
far-field quadrature error).

Patches are one-sided: a patch sends light only to the side its normal faces
(normal = right-hand rule over its vertices) and receives only on that side.

Visibility is supplied by the caller: `visible(origins, targets) -> (N,) float` in [0, 1]
(1 where the open segment is free). `tracer_visibility` builds it from the runtime tracer
(Embree for triangles, analytic shapes otherwise). The visible fraction between a source
fan triangle and a target patch is estimated with `vis_samples` stratified segment pairs
and multiplies that triangle's share of the kernel.
"""

from __future__ import annotations

import os
from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor

import numpy as np

from runtime import transform as tf

Visibility = Callable[[np.ndarray, np.ndarray], np.ndarray]

# Below this |R_k × R_{k+1}| an edge is degenerate (padding vertex or an edge seen end-on):
# its contribution γ·ĉ/|c| → c itself, which is ~0; far below any real edge's sine.
_DEGENERATE_SINE = 1e-14

# Points closer than this (relative to the coordinates' size) to a target patch's plane are
# coplanar with it: float64 plane offsets are good to ~1e-15 relative, so 1e-10 is safe.
_COPLANAR_REL = 1e-10

# Memory budget for one batch of kernel evaluations (bytes of the largest temporary).
_CHUNK_BYTES = 32 * 2**20

# Visibility segments per batch (one batch per thread at a time).
_VIS_BATCH_RAYS = 2**20


# ------------------------------------------------------------------- geometry


def polygon_normal_area(verts: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Unit normals (...,3) and areas (...) of planar polygons (...,K,3) (Newell's method,
    exact for planar polygons and robust to repeated padding vertices)."""
    nxt = np.roll(verts, -1, axis=-2)
    twice = np.cross(verts, nxt).sum(axis=-2)
    area = 0.5 * np.linalg.norm(twice, axis=-1)
    return tf.normalize(twice), area


def polygon_centroid(verts: np.ndarray) -> np.ndarray:
    """Area centroids (N,3) of convex polygons (N,K,3); repeated (padding) vertices add
    nothing, unlike a plain vertex mean."""
    a = verts[:, :1]
    b, c = verts[:, 1:-1], verts[:, 2:]
    w = np.linalg.norm(np.cross(b - a, c - a), axis=-1)  # twice the fan triangles' areas
    cen = (a + b + c) / 3.0
    total = w.sum(axis=1, keepdims=True)
    out = (w[..., None] * cen).sum(axis=1) / np.maximum(total, 1e-300)
    return np.where(total > 0, out, verts.mean(axis=1))


def clip_to_hemisphere(rel: np.ndarray, normal: np.ndarray) -> np.ndarray:
    """Clip polygons to the half-space above the receiver's tangent plane.

    rel: (...,K,3) vertices relative to the receiving point; normal: (...,3) broadcastable.
    Returns (...,2K,3): the clipped polygon, padded by repeating vertices (repeated vertices
    add nothing to the contour integral); all-zero where nothing is above the plane."""
    d = np.einsum("...kc,...c->...k", rel, normal)
    inside = d >= 0.0
    if inside.all():
        return rel
    shape = np.broadcast_shapes(rel.shape[:-2], d.shape[:-1])
    k = rel.shape[-2]
    rel = np.broadcast_to(rel, shape + (k, 3))
    nxt = np.roll(rel, -1, axis=-2)
    dn = np.roll(d, -1, axis=-1)
    crossing = inside != np.roll(inside, -1, axis=-1)
    with np.errstate(divide="ignore", invalid="ignore"):
        t = np.where(crossing, d / (d - dn), 0.0)
    x = rel + t[..., None] * (nxt - rel)
    out = np.empty(shape + (2 * k, 3))
    out[..., 0::2, :] = rel
    out[..., 1::2, :] = x
    valid = np.empty(shape + (2 * k,), dtype=bool)
    valid[..., 0::2] = inside
    valid[..., 1::2] = crossing
    # Forward-fill dropped slots with the previous kept vertex; leading slots wrap around to
    # the last kept one (the polygon is cyclic, so this only repeats a vertex).
    idx = np.where(valid, np.arange(2 * k), -1)
    idx = np.maximum.accumulate(idx, axis=-1)
    last = idx[..., -1:]
    idx = np.where(idx < 0, last, idx)
    none = last[..., 0] < 0
    out = np.take_along_axis(out, np.maximum(idx, 0)[..., None], axis=-2)
    out[none] = 0.0
    return out


def projected_solid_angle(rel: np.ndarray, normal: np.ndarray) -> np.ndarray:
    """Lambert's contour integral / π for polygons already above the tangent plane:
    (...,K,3) relative vertices, (...,3) normal → (...) form factor in [0, 1]."""
    u = tf.normalize(rel)
    v = np.roll(u, -1, axis=-2)
    c = np.cross(u, v)
    s = np.linalg.norm(c, axis=-1)
    cosang = np.einsum("...kc,...kc->...k", u, v)
    gamma = np.arctan2(s, cosang)
    # γ/sin γ is smooth (→ 1) as an edge degenerates: no 0/0 for padding vertices.
    f = np.where(s > _DEGENERATE_SINE, gamma / np.maximum(s, _DEGENERATE_SINE), 1.0)
    total = np.einsum("...kc,...c->...", c * f[..., None], normal)
    return np.abs(total) / (2.0 * np.pi)


def point_polygon(points: np.ndarray, normals: np.ndarray, polygon: np.ndarray) -> np.ndarray:
    """Form factor from differential areas (points (N,3), unit normals (N,3)) to a polygon
    ((K,3) shared, or (N,K,3) one per point). The polygon is treated as two-sided here
    (pure geometry); `form_factors` applies the one-sided rule for patches."""
    points = np.asarray(points, dtype=np.float64).reshape(-1, 3)
    normals = np.asarray(normals, dtype=np.float64).reshape(-1, 3)
    polygon = np.asarray(polygon, dtype=np.float64)
    rel = polygon - points[:, None, :]  # (K,3) broadcasts against (N,1,3) as (N,K,3)
    return projected_solid_angle(clip_to_hemisphere(rel, normals), normals)


# ------------------------------------------------------------------ quadrature


def _gauss_legendre01(n: int) -> tuple[np.ndarray, np.ndarray]:
    x, w = np.polynomial.legendre.leggauss(n)
    return 0.5 * (x + 1.0), 0.5 * w


def fan_triangles(verts: np.ndarray) -> np.ndarray:
    """(N,K,3) convex polygons → (N,K-2,3,3) fan triangles (v0, v_k, v_k+1)."""
    k = verts.shape[1]
    a = np.repeat(verts[:, :1], k - 2, axis=1)
    return np.stack([a, verts[:, 1 : k - 1], verts[:, 2:k]], axis=2)


def polygon_quadrature(verts: np.ndarray, order: int) -> tuple[np.ndarray, np.ndarray]:
    """Gauss points on convex polygons (N,K,3): points (N,Q,3) and weights (N,Q) summing to
    each polygon's area. Four corners (quads, and triangles padded by a repeated vertex):
    the bilinear map of an n×n Gauss–Legendre grid, Q = n² (a collapsed edge makes it the
    Duffy rule on the triangle). More corners: the Duffy rule on each fan triangle,
    Q = (K-2)·n². n = `order`; exact for polynomials of degree 2n-1 per direction."""
    verts = np.asarray(verts, dtype=np.float64)
    x, w = _gauss_legendre01(order)
    if verts.shape[1] == 4:
        s = np.repeat(x, order)  # s fastest in the second index below
        t = np.tile(x, order)
        ww = np.repeat(w, order) * np.tile(w, order)
        p00, p10, p11, p01 = (verts[:, i, None, :] for i in range(4))
        s_, t_ = s[None, :, None], t[None, :, None]
        pts = (1 - s_) * (1 - t_) * p00 + s_ * (1 - t_) * p10 + s_ * t_ * p11 + (1 - s_) * t_ * p01
        ds = (1 - t_) * (p10 - p00) + t_ * (p11 - p01)
        dt = (1 - s_) * (p01 - p00) + s_ * (p11 - p10)
        jac = np.linalg.norm(np.cross(ds, dt), axis=-1)
        return pts, jac * ww[None, :]
    tri = fan_triangles(verts)
    u = x[:, None]
    v = x[None, :]
    wu = (w[:, None] * w[None, :] * 2.0 * u).reshape(-1)  # Jacobian of the collapse: 2·A·u
    uu = np.broadcast_to(u, (order, order)).reshape(-1)
    uv = (u * v).reshape(-1)
    a, b, c = tri[:, :, 0], tri[:, :, 1], tri[:, :, 2]
    pts = a[:, :, None] + uu[:, None] * (b - a)[:, :, None] + uv[:, None] * (c - b)[:, :, None]
    area = 0.5 * np.linalg.norm(np.cross(b - a, c - a), axis=-1)
    weights = area[:, :, None] * wu
    n = len(verts)
    return pts.reshape(n, -1, 3), weights.reshape(n, -1)


def stratified_points(verts: np.ndarray, count: int, rng: np.random.Generator) -> np.ndarray:
    """(N,count,3) Latin-hypercube points on each convex polygon: both parameters are
    stratified into `count` strata (any count, each marginal evenly covered). Four corners:
    the bilinear map (uniform by area on parallelograms); a repeated corner (a padded
    triangle) or three corners: the area-preserving square-root map of the triangle; more
    corners: fan triangles chosen by area with the first parameter."""
    verts = np.asarray(verts, dtype=np.float64)
    n, k = verts.shape[:2]
    s = (np.argsort(rng.random((n, count)), axis=1) + rng.random((n, count))) / count
    t = (np.argsort(rng.random((n, count)), axis=1) + rng.random((n, count))) / count
    tri_like = np.zeros(n, dtype=bool)
    if k == 4:
        same = np.all(np.isclose(verts, np.roll(verts, -1, axis=1), rtol=0, atol=0), axis=2)
        tri_like = same.any(axis=1)
    out = np.empty((n, count, 3))
    if k == 4 and (~tri_like).any():
        v = verts[~tri_like]
        ss, tt = s[~tri_like, :, None], t[~tri_like, :, None]
        out[~tri_like] = (
            (1 - ss) * (1 - tt) * v[:, None, 0]
            + ss * (1 - tt) * v[:, None, 1]
            + ss * tt * v[:, None, 2]
            + (1 - ss) * tt * v[:, None, 3]
        )
    if k == 3 or tri_like.any():
        rows = np.nonzero(tri_like)[0] if k == 4 else np.arange(n)
        v = verts[rows]
        if k == 4:
            # Drop the repeated corner: keep the three distinct ones in winding order.
            dup = np.argmax(same[rows], axis=1)
            keep = (dup[:, None] + np.array([1, 2, 3])) % 4
            v = np.take_along_axis(v, keep[:, :, None], axis=1)
        out[rows] = _sqrt_map(v[:, 0], v[:, 1], v[:, 2], s[rows], t[rows])
    if k > 4:
        tri = fan_triangles(verts)
        a, b, c = tri[:, :, 0], tri[:, :, 1], tri[:, :, 2]
        area = 0.5 * np.linalg.norm(np.cross(b - a, c - a), axis=-1)
        cdf = np.cumsum(area, axis=1)
        cdf /= np.maximum(cdf[:, -1:], 1e-300)
        which = np.minimum((s[:, :, None] > cdf[:, None, :]).sum(axis=2), k - 3)
        lo = np.where(which > 0, np.take_along_axis(cdf, np.maximum(which - 1, 0), axis=1), 0.0)
        hi = np.take_along_axis(cdf, which, axis=1)
        su = (s - lo) / np.maximum(hi - lo, 1e-300)  # re-use the stratum inside the triangle
        r = np.arange(n)[:, None]
        out = _sqrt_map(a[r, which], b[r, which], c[r, which], su, t)
    return out


def _sqrt_map(a, b, c, s, t) -> np.ndarray:
    """Area-preserving map of the unit square onto triangles (a, b, c): (…,count,3)."""
    r = np.sqrt(s)[..., None]
    tt = t[..., None]
    if a.ndim == s.ndim + 1:  # per-point corners already
        return (1 - r) * a + r * (1 - tt) * b + r * tt * c
    return (1 - r) * a[:, None] + r * (1 - tt) * b[:, None] + r * tt * c[:, None]


# ------------------------------------------------------------------ visibility


def tracer_visibility(tracer, rel_gap: float = 1e-6) -> Visibility:
    """`visible(origins, targets)` from a runtime.trace.Tracer: 1 where nothing that casts
    shadows lies strictly between the two points. Both ends sit on surfaces, so the tested
    segment is shortened by `rel_gap` of its length at each end (scale-free, and far larger
    than the tracer's float64 hit error)."""

    def visible(origins: np.ndarray, targets: np.ndarray) -> np.ndarray:
        d = targets - origins
        dist = np.linalg.norm(d, axis=1)
        safe = np.maximum(dist, 1e-300)
        d = d / safe[:, None]
        blocked = tracer.occluded(origins, d, tmax=dist * (1 - rel_gap), tmin=dist * rel_gap)
        return (~blocked).astype(np.float64)

    return visible


# -------------------------------------------------------------- form factors


def form_factors(
    src: np.ndarray,
    dst: np.ndarray | None = None,
    *,
    order: int = 3,
    far_order: int | None = None,
    far_ratio: float = 3.0,
    visible: Visibility | None = None,
    vis_samples: int = 4,
    seed: int = 0,
    chunk_bytes: int = _CHUNK_BYTES,
    vis_points: tuple[np.ndarray, np.ndarray] | None = None,
    workers: int | None = None,
    symmetric: bool = False,
    point_ratio: float | None = None,
    progress: Callable[[float], None] | None = None,
) -> np.ndarray:
    """Form factors F[i, j] from convex patches `src` (Ns,K,3) to `dst` (Nd,K',3)
    (default: src itself). Patches are one-sided (see the module docstring).

    `far_order` (default: `order`) is used for pairs whose centroids are more than
    `far_ratio` times the sum of their radii apart, where the inner factor varies slowly
    over the source (error O((size/distance)^2·far_order)). Mixing orders costs the exact
    row sums, which then hold to the far-field quadrature error.

    `vis_points` = (on src (Ns,S,3), on dst (Nd,S,3)) replaces the stratified segment ends:
    curved surfaces must give points on the true surface, since a point on an inscribed
    facet lies inside the object and every ray from it would be blocked by the object.

    With `visible`, F[i, j] is multiplied by the fraction of `vis_samples` stratified
    segments between the two patches that `visible` reports free (one estimate per pair,
    shared by both directions when dst is src, so reciprocity survives); pairs that
    exchange no light cast no rays.

    Row chunks run on `workers` threads (default: one per core); numpy releases the GIL
    in the large elementwise kernels, so the kernel scales with cores.

    `symmetric` (dst is src only) integrates each pair once, from the patch with the
    lower index, and fills the other direction by reciprocity: half the kernel work, and
    A_i F_ij = A_j F_ji exactly; the row sums then hold to the quadrature error only
    (instead of to rounding).

    `point_ratio`: pairs more than that many times the sum of their radii apart use the
    point-to-point kernel A_i A_j cos θ_i cos θ_j / (π r²) between centroids (relative
    error O((radius/distance)²), under 2% at a ratio of 8; several times cheaper than the
    contour integral, and most pairs of a fine mesh are that far apart).

    `progress(share)`, called on this thread as chunks finish: the share of the work done,
    the integrals (by their pairs) the first half and the visibility rays the second
    (VISIBILITY_SHARE)."""
    src = np.asarray(src, dtype=np.float64)
    same = dst is None
    dst = src if dst is None else np.asarray(dst, dtype=np.float64)
    ns = len(src)
    nd, kd = dst.shape[:2]
    n_src, a_src = polygon_normal_area(src)
    n_dst, _ = polygon_normal_area(dst)
    geo = _Targets(dst, n_dst, float(np.abs(dst).max()) + float(np.abs(src).max()))
    rules = [polygon_quadrature(src, order)]
    tiered = far_order is not None and far_order != order
    if tiered and far_order is not None:  # (tiered says it is not None)
        rules.append(polygon_quadrature(src, far_order))
    if tiered or point_ratio is not None:
        c_src, r_src = polygon_centroid(src), _radius(src)
        c_dst, r_dst = polygon_centroid(dst), _radius(dst)
        a_dst = polygon_normal_area(dst)[1]
    q = rules[0][0].shape[1]
    out = np.zeros((ns, nd))
    # Largest temporaries: a few (pairs·q, kd) float64 arrays.
    rows_per_chunk = max(1, int(chunk_bytes // (q * nd * kd * 8 * 12)))

    symmetric = symmetric and same

    def chunk(start: int) -> None:
        sl = slice(start, min(ns, start + rows_per_chunk))
        point = None
        masks: list[np.ndarray | None]
        if len(rules) == 1 and point_ratio is None:
            masks = [None]
        else:
            d = np.linalg.norm(c_src[sl, None] - c_dst[None], axis=2)
            reach = r_src[sl, None] + r_dst[None]
            if point_ratio is not None:
                point = d > point_ratio * reach
            far = d > far_ratio * reach if tiered else np.zeros_like(d, dtype=bool)
            if point is not None:
                far &= ~point
            near = ~far if point is None else ~far & ~point
            masks = [near, far] if tiered else [near]
        if symmetric:
            upper = np.arange(nd)[None, :] > np.arange(sl.start, sl.stop)[:, None]
            masks = [upper if m is None else m & upper for m in masks]
            if point is not None:
                point &= upper
        acc = np.zeros((sl.stop - sl.start, nd))
        for (pts, w), mask in zip(rules, masks, strict=True):
            acc += _kernel_rows(pts[sl], w[sl], n_src[sl], geo, mask)
        if point is not None:
            acc += _point_rows(c_src[sl], n_src[sl], a_src[sl], c_dst, n_dst, a_dst, point)
        out[sl] = acc / np.maximum(a_src[sl], 1e-300)[:, None]

    starts = range(0, ns, rows_per_chunk)
    integrals = 1.0 - VISIBILITY_SHARE if visible is not None else 1.0
    pairs = [_pairs(s, min(ns, s + rows_per_chunk), nd, symmetric) for s in starts]
    said = _shares(progress, pairs, 0.0, integrals)
    _run_chunks(chunk, starts, workers, said)
    if symmetric:
        g = out * a_src[:, None]  # A_i F_ij on the upper triangle
        out = (g + g.T) / np.maximum(a_src, 1e-300)[:, None]
    if visible is not None:
        rays_said = None
        if progress is not None:

            def rays_said(share: float) -> None:
                progress(integrals + share * VISIBILITY_SHARE)

        out *= pair_visibility(
            src, dst, out, visible, vis_samples, seed, same, vis_points, workers, rays_said
        )
    if progress is not None:
        progress(1.0)
    return out


# The visibility rays' share of form_factors' time (measured on two rooms of 450 to 3000
# patches: 0.3 to 0.57; the integrals took the rest).
VISIBILITY_SHARE = 0.5


def _pairs(start: int, stop: int, nd: int, symmetric: bool) -> int:
    """The pairs rows start..stop integrate: all nd, or those above the diagonal."""
    if not symmetric:
        return (stop - start) * nd
    return sum(max(nd - i - 1, 0) for i in range(start, stop)) + (stop - start)


def _shares(progress, weights: list[int], base: float, span: float):
    """A callback for _run_chunks: progress(base + span * the weight done so far)."""
    if progress is None or not weights:
        return None
    total = float(sum(weights))
    done = [0.0]

    def said(i: int) -> None:
        done[0] += weights[i]
        progress(base + span * done[0] / total)

    return said


def _run_chunks(fn, starts, workers: int | None, done=None) -> None:
    """Call fn(start) for every chunk, on a thread pool when there is more than one;
    done(index), when given, after each chunk, on this thread, in order."""
    starts = list(starts)
    workers = min(len(starts), workers or os.cpu_count() or 1)
    if workers <= 1:
        for i, s in enumerate(starts):
            fn(s)
            if done is not None:
                done(i)
        return
    with ThreadPoolExecutor(workers) as pool:
        for i, f in enumerate([pool.submit(fn, s) for s in starts]):
            f.result()  # re-raise a worker's exception here
            if done is not None:
                done(i)


def _radius(verts: np.ndarray) -> np.ndarray:
    c = polygon_centroid(verts)[:, None]
    return np.linalg.norm(verts - c, axis=2).max(axis=1)


class _Targets:
    """Target polygons as structure of arrays (fast elementwise kernels)."""

    def __init__(self, dst: np.ndarray, normal: np.ndarray, scale: float):
        self.v = dst
        # Components with the first vertex repeated at the end: edge k runs from column k
        # to column k+1, so the kernel needs no rolled copies.
        ext = np.concatenate([dst, dst[:, :1]], axis=1)
        self.x, self.y, self.z = (np.ascontiguousarray(ext[..., c]) for c in range(3))
        self.normal = normal
        self.off = np.einsum("nc,nc->n", normal, dst[:, 0])
        # Coplanarity margin (see _COPLANAR_REL) in this scene's coordinates.
        self.margin = _COPLANAR_REL * (np.abs(self.off) + scale)


def _kernel_rows(p, w, nrm, geo: _Targets, pair_mask) -> np.ndarray:
    """Σ_q w_q F(dA_q → A_j) for source rows (r,q,3) against every target (or the pairs
    in `pair_mask` (r, nd)): (r, nd). Works on the list of pairs, so a rule used for few
    pairs (near ones) costs in proportion to them."""
    r, q = p.shape[:2]
    nd = len(geo.v)
    out = np.zeros((r, nd))
    if pair_mask is None:
        ri, ji = np.divmod(np.arange(r * nd), nd)
    else:
        ri, ji = np.nonzero(pair_mask)
    if len(ri) == 0:
        return out
    pr, nr = p[ri], nrm[ri]  # (m,q,3), (m,3)
    # One-sided receivers/senders: the point must lie in front of the target patch, by a
    # margin: a coplanar polygon around the point is the contour integral's degenerate
    # limit (it returns 1, not 0), and rounding puts coplanar points on either side.
    height = np.einsum("mqc,mc->mq", pr, geo.normal[ji]) - geo.off[ji, None]
    active = height > geo.margin[ji, None]
    # Heights of the target's vertices above the receiver's tangent plane.
    vn = np.einsum("mkc,mc->mk", geo.v[ji], nr)  # (m,kd)
    pn = np.einsum("mqc,mc->mq", pr, nr)  # (m,q)
    active &= vn.max(axis=1)[:, None] > pn
    mi, qi = np.nonzero(active)
    if len(mi) == 0:
        return out
    below = (vn[mi] < pn[mi, qi][:, None]).any(axis=1)
    vals = np.empty(len(mi))
    up = np.nonzero(~below)[0]
    if len(up):
        a, b, j = mi[up], qi[up], ji[mi[up]]
        pts = pr[a, b]
        vals[up] = _contour_soa(
            geo.x[j] - pts[:, 0:1], geo.y[j] - pts[:, 1:2], geo.z[j] - pts[:, 2:3], nr[a]
        )
    dn = np.nonzero(below)[0]
    if len(dn):
        a, b, j = mi[dn], qi[dn], ji[mi[dn]]
        rel = geo.v[j] - pr[a, b][:, None, :]
        vals[dn] = projected_solid_angle(clip_to_hemisphere(rel, nr[a]), nr[a])
    per_pair = np.bincount(mi, weights=w[ri[mi], qi] * vals, minlength=len(ri))
    out[ri, ji] = per_pair
    return out


def _point_rows(c_src, n_src, a_src, c_dst, n_dst, a_dst, mask) -> np.ndarray:
    """A_i·F_ij ≈ A_i A_j cos θ_i cos θ_j / (π r²) between centroids, where `mask` (r, nd);
    one-sided both ways (each must face the other)."""
    rows, cols = np.nonzero(mask)
    out = np.zeros(mask.shape)
    if len(rows) == 0:
        return out
    v = c_dst[cols] - c_src[rows]
    d2 = np.einsum("mc,mc->m", v, v)
    ci = np.einsum("mc,mc->m", v, n_src[rows])
    cj = -np.einsum("mc,mc->m", v, n_dst[cols])
    val = np.maximum(ci, 0.0) * np.maximum(cj, 0.0) / (np.pi * d2 * d2)
    out[rows, cols] = val * a_src[rows] * a_dst[cols]
    return out


def _contour_soa(rx, ry, rz, n) -> np.ndarray:
    """`projected_solid_angle` on component arrays (M,K+1) whose last column repeats the
    first: the same formula with fewer temporaries (this is the hot loop of the
    form-factor matrix)."""
    inv = 1.0 / np.sqrt(rx * rx + ry * ry + rz * rz)
    ux, uy, uz = rx * inv, ry * inv, rz * inv
    ax, ay, az = ux[:, :-1], uy[:, :-1], uz[:, :-1]
    bx, by, bz = ux[:, 1:], uy[:, 1:], uz[:, 1:]
    cx = ay * bz - az * by
    cy = az * bx - ax * bz
    cz = ax * by - ay * bx
    s = np.sqrt(cx * cx + cy * cy + cz * cz)
    c = ax * bx + ay * by + az * bz
    g = np.arctan2(s, c)
    f = np.where(s > _DEGENERATE_SINE, g / np.maximum(s, _DEGENERATE_SINE), 1.0)
    dot = cx * n[:, :1] + cy * n[:, 1:2] + cz * n[:, 2:3]
    return np.abs((f * dot).sum(axis=1)) / (2.0 * np.pi)


def point_form_factors(
    points: np.ndarray,
    normals: np.ndarray,
    dst: np.ndarray,
    *,
    visible: Visibility | None = None,
    targets: np.ndarray | None = None,
    chunk_bytes: int = _CHUNK_BYTES,
) -> np.ndarray:
    """(P, Nd) form factors from differential areas (points, unit normals) to one-sided
    patches: the exact kernel, times the fraction of segments from the point to
    `targets` (Nd,S,3) on each patch that `visible` reports free. Used to gather the light
    arriving at mesh vertices for display."""
    points = np.asarray(points, dtype=np.float64).reshape(-1, 3)
    normals = np.asarray(normals, dtype=np.float64).reshape(-1, 3)
    dst = np.asarray(dst, dtype=np.float64)
    nd, kd = dst.shape[:2]
    n_dst, _ = polygon_normal_area(dst)
    geo = _Targets(dst, n_dst, float(np.abs(dst).max()) + float(np.abs(points).max()))
    out = np.zeros((len(points), nd))
    per = max(1, int(chunk_bytes // (nd * kd * 8 * 12)))
    for s in range(0, len(points), per):
        sl = slice(s, min(len(points), s + per))
        p = points[sl, None, :]
        out[sl] = _kernel_rows(p, np.ones((len(p), 1)), normals[sl], geo, None)
    if visible is not None and targets is not None:
        ii, jj = np.nonzero(out > 0)
        k = targets.shape[1]
        batch = max(1, 2**20 // k)
        for b in range(0, len(ii), batch):
            i, j = ii[b : b + batch], jj[b : b + batch]
            o = np.repeat(points[i], k, axis=0)
            v = np.asarray(visible(o, targets[j].reshape(-1, 3)), dtype=np.float64)
            out[i, j] *= v.reshape(-1, k).mean(axis=1)
    return out


def pair_visibility(
    src,
    dst,
    unoccluded,
    visible,
    vis_samples,
    seed,
    same,
    points=None,
    workers=None,
    progress: Callable[[float], None] | None = None,
) -> np.ndarray:
    """(Ns,Nd) visible fraction for every pair with a nonzero unoccluded form factor: the
    mean of `visible` over `vis_samples` stratified segments (origins on the source patch,
    targets on the target patch, strata paired by a random permutation). progress(share)
    as the batches of rays finish."""  # fmt: skip
    rng = np.random.default_rng(seed)
    need = unoccluded > 0.0
    if same:
        need = need | need.T
        need = np.triu(need, 1)  # one estimate per unordered pair, mirrored below
    ii, jj = np.nonzero(need)
    frac = np.ones(unoccluded.shape)
    if len(ii) == 0:
        return frac
    if points is None:
        o = stratified_points(src, vis_samples, rng)
        t = o if same else stratified_points(dst, vis_samples, rng)
    else:
        o, t = points
        vis_samples = o.shape[1]
    batch = max(1, _VIS_BATCH_RAYS // vis_samples)
    # Strata are paired by a random permutation per pair: drawn from a table of all
    # permutations when that is small (sorting random keys per pair costs more than the
    # rays), else by sorting.
    table = None
    if vis_samples <= 5:
        import itertools

        table = np.array(list(itertools.permutations(range(vis_samples))), dtype=np.int64)
    # Permutations are drawn here, in order, so the result does not depend on threads.
    jobs = []
    for b in range(0, len(ii), batch):
        n_b = min(batch, len(ii) - b)
        if table is not None:
            perm = table[rng.integers(0, len(table), n_b)]
        else:
            perm = np.argsort(rng.random((n_b, vis_samples)), axis=1)
        jobs.append((b, perm))

    def run(job) -> None:
        b, perm = job
        i, j = ii[b : b + len(perm)], jj[b : b + len(perm)]
        tg = t[j[:, None], perm]
        v = np.asarray(visible(o[i].reshape(-1, 3), tg.reshape(-1, 3)), dtype=np.float64)
        frac[i, j] = v.reshape(-1, vis_samples).mean(axis=1)

    # Batches on threads: Embree and the large numpy passes release the GIL.
    _run_chunks(run, jobs, workers, _shares(progress, [len(p) for _, p in jobs], 0.0, 1.0))
    if same:
        frac[jj, ii] = frac[ii, jj]
    return frac
