"""NURBS curves and surfaces: basis functions, points, derivatives and normals, vectorised.

The algorithms are the standard ones of Piegl & Tiller, *The NURBS Book* (find span A2.1,
non-zero basis functions A2.2, their derivatives A2.3, surface derivatives A3.6, rational
derivatives from the homogeneous form A4.2/A4.4), rewritten so that every loop runs over the
degree (a handful of iterations) while the parameters travel as numpy arrays: one call
evaluates thousands of (u, v) pairs.

Conventions (the IR's, see `lang.ir.Nurbs`): control points are Euclidean with one weight each,
u varies fastest; knot vectors are complete (n + degree + 1 values). Evaluation is
right-continuous at interior knots (the span with knots[s] <= u < knots[s+1]) and the domain end
belongs to the last non-empty span, as in A2.1.

Precision: the net is evaluated relative to the centre of its bounding box (stored in
`origin`), so a surface a million units from the world origin keeps its digits in the
derivatives; only the final positions get the offset back.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from math import comb
from typing import Literal

import numpy as np

from lang import ir

# A tangent shorter than this fraction of the net's own scale (its size over the parameter
# length) is a degenerate direction, e.g. dP/du at the pole of a sphere where a whole row of
# control points coincides: the rational quotient leaves only float noise (~1e-16 of the
# coordinates) there, far below 1e-9, while real tangents are of order one.
DEGENERATE_REL = 1e-9

# Two tangents whose cross product is below this fraction of |Su||Sv| are parallel (a cusp):
# the normal is then taken a little inside the domain instead.
PARALLEL_REL = 1e-12

# How far inside the domain (fraction of its length) the last-resort normal is sampled.
NUDGE_REL = (1e-6, 1e-4, 1e-2)

# Rows per batch of the pointwise evaluators: bounds the (K, q+1, p+1, 4) gather in memory.
BATCH = 1 << 15


# ----------------------------------------------------------------------- knot helpers
def clamped_uniform_knots(n: int, degree: int) -> tuple[float, ...]:
    """The default knot vector for `n` control points: `degree + 1` equal knots at each end
    and unit steps between (0, …, 0, 1, 2, …, n - degree, …): integers, so exact in floats."""
    if n < degree + 1 or degree < 1:
        raise ValueError(f"{n} control points cannot carry a degree-{degree} curve")
    inner = n - degree
    return (0.0,) * degree + tuple(float(i) for i in range(inner + 1)) + (float(inner),) * degree


def validate(shape: ir.Nurbs) -> list[str]:
    """Messages (empty when the shape is sound) for every count, knot and weight problem the
    evaluator and the runtime would trip over, worded for the scene author.

    Pure Python on purpose (no numpy): the language side may call it, or move it, without
    breaking the rule that `lang` never imports numpy."""
    msgs: list[str] = []
    curve = shape.nv == 0
    what = "curve" if curve else "surface"
    dirs = [("u", shape.u_degree, shape.nu, shape.u_knots)]
    if not curve:
        dirs.append(("v", shape.v_degree, shape.nv, shape.v_knots))
    for name, p, n, knots in dirs:
        label = "degree" if curve else f"{name}_degree"
        kname = f"{name}_knots"
        if p < 1:
            msgs.append(f"{label} must be at least 1, got {p}")
            continue
        if n < p + 1:
            msgs.append(
                f"a degree-{p} {what} needs at least {p + 1} control points"
                f"{'' if curve else ' in ' + name}, got {n}"
            )
            continue
        if len(knots) != n + p + 1:
            msgs.append(
                f"{kname} has {len(knots)} values; {n} points of degree {p} need {n + p + 1}"
            )
            continue
        k = [float(x) for x in knots]
        if not all(math.isfinite(x) for x in k):
            msgs.append(f"{kname} contains a non-finite value")
            continue
        drop = next((i for i in range(len(k) - 1) if k[i + 1] < k[i]), None)
        if drop is not None:
            msgs.append(f"{kname} must not decrease: {k[drop]:g} is followed by {k[drop + 1]:g}")
            continue
        lo, hi = k[p], k[n]
        if not lo < hi:
            msgs.append(f"{kname} leave an empty domain [{lo:g}, {hi:g}]")
            continue
        for val in sorted(set(k[p : n + 1])):
            mult = k.count(val)
            if lo < val < hi and mult > p:
                msgs.append(
                    f"interior knot {val:g} is repeated {mult} times; more than the degree"
                    f" ({p}) breaks the {what} apart"
                )
            elif val in (lo, hi) and mult > p + 1:
                msgs.append(f"end knot {val:g} is repeated {mult} times; at most {p + 1}")
    count = shape.nu * (1 if curve else shape.nv)
    if len(shape.points) != count:
        msgs.append(f"expected {count} control points, got {len(shape.points)}")
    if len(shape.weights) != len(shape.points):
        msgs.append(f"expected {len(shape.points)} weights, got {len(shape.weights)}")
    for i, w in enumerate(shape.weights):
        if not (math.isfinite(w) and w > 0):
            msgs.append(f"weights must be positive and finite: weight {i} is {w:g}")
            break
    pts = [tuple(float(c) for c in q) for q in shape.points]
    if pts:
        if not all(math.isfinite(c) for q in pts for c in q):
            msgs.append("a control point has a non-finite coordinate")
        elif len(pts) > 1 and all(q == pts[0] for q in pts):
            msgs.append("all control points coincide: the net is degenerate")
    if curve and not shape.radius > 0:
        msgs.append(f"a nurbs curve needs a positive tube radius, got {shape.radius:g}")
    if shape.tolerance is not None and not shape.tolerance > 0:
        msgs.append(f"tolerance must be positive, got {shape.tolerance:g}")
    return msgs


# -------------------------------------------------------------------- basis functions
class KnotVector:
    """A validated knot vector with its degree: span lookup and basis functions (with
    derivatives) for arrays of parameters."""

    def __init__(self, knots, degree: int, n: int):
        self.knots = np.asarray(knots, dtype=np.float64)
        self.degree = degree
        self.n = n  # number of control points
        self.lo = float(self.knots[degree])
        self.hi = float(self.knots[n])
        spans = np.arange(degree, n)
        # Only non-empty spans are ever chosen (A2.1's span is always non-empty): a
        # parameter on a repeated knot, or at the domain end, falls into the neighbour.
        self.spans = spans[self.knots[spans] < self.knots[spans + 1]]
        self.starts = self.knots[self.spans]

    def span(self, u: np.ndarray, left: bool = False) -> np.ndarray:
        """A2.1 for many parameters: the index s with knots[s] <= u < knots[s+1] (the last
        non-empty span at the domain end); parameters outside the domain are clamped. With
        `left`, knots[s] < u <= knots[s+1] instead: the left-hand limit at a knot (the start
        of the domain keeps the first span)."""
        side: Literal["left", "right"] = "left" if left else "right"
        k = np.searchsorted(self.starts, u, side=side) - 1
        return self.spans[np.clip(k, 0, len(self.spans) - 1)]

    def clamp(self, u) -> np.ndarray:
        return np.clip(np.asarray(u, dtype=np.float64), self.lo, self.hi)

    def ders(self, u: np.ndarray, nd: int, left: bool = False) -> tuple[np.ndarray, np.ndarray]:
        """A2.3 vectorised: (span (K,), ders (nd+1, K, p+1)); ders[k, :, j] is the k-th
        derivative of basis function span-p+j. Derivatives above the degree are zero."""
        u = self.clamp(u)
        s = self.span(u, left)
        return s, basis_ders(self.knots, self.degree, s, u, nd)


def basis_funs(knots: np.ndarray, p: int, span: np.ndarray, u: np.ndarray) -> np.ndarray:
    """A2.2 vectorised: the p+1 non-zero basis functions at each u, shape (K, p+1)."""
    K = u.shape[0]
    N = np.zeros((K, p + 1))
    N[:, 0] = 1.0
    left = np.empty((K, p + 1))
    right = np.empty((K, p + 1))
    for j in range(1, p + 1):
        left[:, j] = u - knots[span + 1 - j]
        right[:, j] = knots[span + j] - u
        saved = np.zeros(K)
        for r in range(j):
            # right[r+1] + left[j-r] is a knot difference spanning the (non-empty) span.
            temp = N[:, r] / (right[:, r + 1] + left[:, j - r])
            N[:, r] = saved + right[:, r + 1] * temp
            saved = left[:, j - r] * temp
        N[:, j] = saved
    return N


def basis_ders(knots: np.ndarray, p: int, span: np.ndarray, u: np.ndarray, nd: int) -> np.ndarray:
    """A2.3 vectorised: basis functions and their derivatives up to `nd`, (nd+1, K, p+1)."""
    K = u.shape[0]
    ndu = np.empty((p + 1, p + 1, K))  # upper triangle: basis values, lower: knot differences
    ndu[0, 0] = 1.0
    left = np.empty((p + 1, K))
    right = np.empty((p + 1, K))
    for j in range(1, p + 1):
        left[j] = u - knots[span + 1 - j]
        right[j] = knots[span + j] - u
        saved = np.zeros(K)
        for r in range(j):
            ndu[j, r] = right[r + 1] + left[j - r]
            temp = ndu[r, j - 1] / ndu[j, r]
            ndu[r, j] = saved + right[r + 1] * temp
            saved = left[j - r] * temp
        ndu[j, j] = saved
    ders = np.zeros((nd + 1, K, p + 1))
    for j in range(p + 1):
        ders[0, :, j] = ndu[j, p]
    top = min(nd, p)
    a = np.empty((2, p + 1, K))
    for r in range(p + 1):
        s1, s2 = 0, 1
        a[0, 0] = 1.0
        for k in range(1, top + 1):
            d = np.zeros(K)
            rk, pk = r - k, p - k
            if r >= k:
                a[s2, 0] = a[s1, 0] / ndu[pk + 1, rk]
                d = a[s2, 0] * ndu[rk, pk]
            j1 = 1 if rk >= -1 else -rk
            j2 = k - 1 if r - 1 <= pk else p - r
            for j in range(j1, j2 + 1):
                a[s2, j] = (a[s1, j] - a[s1, j - 1]) / ndu[pk + 1, rk + j]
                d = d + a[s2, j] * ndu[rk + j, pk]
            if r <= pk:
                a[s2, k] = -a[s1, k - 1] / ndu[pk + 1, r]
                d = d + a[s2, k] * ndu[r, pk]
            ders[k, :, r] = d
            s1, s2 = s2, s1
    fac = float(p)
    for k in range(1, top + 1):
        ders[k] *= fac
        fac *= p - k
    return ders


def cox_de_boor(knots, p: int, i: int, u: np.ndarray) -> np.ndarray:
    """The textbook recursion N_{i,p}(u) (0/0 = 0), right-continuous, with the domain end
    closed. Slow and simple on purpose: the independent check of `basis_funs`."""
    knots = np.asarray(knots, dtype=np.float64)
    u = np.asarray(u, dtype=np.float64)
    hi = knots[len(knots) - p - 1]
    if p == 0:
        inside = (knots[i] <= u) & (u < knots[i + 1])
        # The last non-empty span also owns the domain end.
        last = (knots[i] < knots[i + 1]) & (knots[i + 1] == hi) & (u == hi)
        return (inside | last).astype(np.float64)
    out = np.zeros_like(u)
    d1 = knots[i + p] - knots[i]
    if d1 > 0:
        out = out + (u - knots[i]) / d1 * cox_de_boor(knots, p - 1, i, u)
    d2 = knots[i + p + 1] - knots[i + 1]
    if d2 > 0:
        out = out + (knots[i + p + 1] - u) / d2 * cox_de_boor(knots, p - 1, i + 1, u)
    return out


def uniform_cubic_b(t: np.ndarray) -> np.ndarray:
    """The seed's uniform cubic B-spline blending function B(t) (NOTES.md section 7):
    (2-|t|)^3/6 for 1 <= |t| <= 2, [1 + 3(1-|t|) + 3(1-|t|)^2 - 3(1-|t|)^3]/6 for |t| <= 1."""
    a = np.abs(np.asarray(t, dtype=np.float64))
    s = 1.0 - a
    inner = (1.0 + 3.0 * s + 3.0 * s**2 - 3.0 * s**3) / 6.0
    outer = (2.0 - a) ** 3 / 6.0
    return np.where(a <= 1.0, inner, np.where(a <= 2.0, outer, 0.0))


# ------------------------------------------------------------------ rational helpers
def _rational(hom: np.ndarray) -> np.ndarray:
    """A4.2/A4.4: Euclidean derivatives S[k, l] from homogeneous ones A[k, l] (last axis
    x, y, z, w). hom has shape (du+1, dv+1, K, 4); returns (du+1, dv+1, K, 3)."""
    du, dv = hom.shape[0] - 1, hom.shape[1] - 1
    A = hom[..., :3]
    w = hom[..., 3]
    S = np.empty(A.shape)
    inv_w = 1.0 / w[0, 0]
    for k in range(du + 1):
        for l in range(dv + 1):
            v = A[k, l].copy()
            for j in range(1, l + 1):
                v -= comb(l, j) * w[0, j, :, None] * S[k, l - j]
            for i in range(1, k + 1):
                v -= comb(k, i) * w[i, 0, :, None] * S[k - i, l]
                for j in range(1, l + 1):
                    v -= comb(k, i) * comb(l, j) * w[i, j, :, None] * S[k - i, l - j]
            S[k, l] = v * inv_w[:, None]
    return S


# ----------------------------------------------------------------------------- curves
@dataclass(frozen=True)
class Curve:
    """A NURBS curve with its net stored relative to `origin` (see the module note)."""

    degree: int
    kv: KnotVector
    pw: np.ndarray  # (n, 4): weighted points w*(P - origin), w
    origin: np.ndarray  # (3,)

    @property
    def domain(self) -> tuple[float, float]:
        return self.kv.lo, self.kv.hi

    @classmethod
    def from_arrays(cls, degree: int, knots, points, weights=None) -> Curve:
        pts = np.asarray(points, dtype=np.float64).reshape(-1, 3)
        w = np.ones(len(pts)) if weights is None else np.asarray(weights, dtype=np.float64)
        origin = 0.5 * (pts.min(axis=0) + pts.max(axis=0))
        pw = np.concatenate([(pts - origin) * w[:, None], w[:, None]], axis=1)
        return cls(degree, KnotVector(knots, degree, len(pts)), pw, origin)

    @classmethod
    def from_ir(cls, shape: ir.Nurbs) -> Curve:
        return cls.from_arrays(shape.u_degree, shape.u_knots, shape.points, shape.weights)

    def derivatives(self, t, nd: int = 0, left: bool = False) -> np.ndarray:
        """C^(k)(t) for k = 0..nd, shape (nd+1, K, 3); C^(0) includes the origin. `left`
        takes left-hand limits at knots (the incoming tangent at a kink)."""
        t = np.atleast_1d(np.asarray(t, dtype=np.float64))
        out = np.empty((nd + 1, t.shape[0], 3))
        p = self.degree
        for a in range(0, t.shape[0], BATCH):
            tt = t[a : a + BATCH]
            span, N = self.kv.ders(tt, nd, left)
            idx = span[:, None] - p + np.arange(p + 1)
            hom = np.einsum("dkj,kjc->dkc", N, self.pw[idx])
            out[:, a : a + BATCH] = _rational(hom[:, None])[:, 0]
        out[0] += self.origin
        return out

    def points(self, t) -> np.ndarray:
        return self.derivatives(t, 0)[0]


# --------------------------------------------------------------------------- surfaces
@dataclass(frozen=True)
class Surface:
    """A NURBS surface; `pw` is the weighted net (nv, nu, 4) relative to `origin`."""

    u_degree: int
    v_degree: int
    ukv: KnotVector
    vkv: KnotVector
    pw: np.ndarray
    origin: np.ndarray

    @property
    def domain(self) -> tuple[tuple[float, float], tuple[float, float]]:
        return (self.ukv.lo, self.ukv.hi), (self.vkv.lo, self.vkv.hi)

    @classmethod
    def from_arrays(cls, u_degree, v_degree, u_knots, v_knots, points, weights=None) -> Surface:
        """`points` (nv, nu, 3) (u fastest when flattened), `weights` (nv, nu) or None."""
        pts = np.asarray(points, dtype=np.float64)
        nv, nu = pts.shape[:2]
        w = np.ones((nv, nu)) if weights is None else np.asarray(weights, dtype=np.float64)
        w = w.reshape(nv, nu)
        flat = pts.reshape(-1, 3)
        origin = 0.5 * (flat.min(axis=0) + flat.max(axis=0))
        pw = np.concatenate([(pts - origin) * w[..., None], w[..., None]], axis=2)
        return cls(
            u_degree,
            v_degree,
            KnotVector(u_knots, u_degree, nu),
            KnotVector(v_knots, v_degree, nv),
            pw,
            origin,
        )

    @classmethod
    def from_ir(cls, shape: ir.Nurbs) -> Surface:
        pts = np.asarray(shape.points, dtype=np.float64).reshape(shape.nv, shape.nu, 3)
        w = np.asarray(shape.weights, dtype=np.float64).reshape(shape.nv, shape.nu)
        return cls.from_arrays(shape.u_degree, shape.v_degree, shape.u_knots, shape.v_knots, pts, w)

    @property
    def scale(self) -> float:
        """Size of the net (bounding-box diagonal): the yardstick for degeneracy tests."""
        pts = self.pw[..., :3] / self.pw[..., 3:]
        return float(np.linalg.norm(np.ptp(pts.reshape(-1, 3), axis=0)))

    # ----- pointwise (A3.6 + A4.4)
    def derivatives(self, u, v, nd: int = 0) -> np.ndarray:
        """S_{k,l}(u, v) for k, l = 0..nd (full square), shape (nd+1, nd+1, K, 3)."""
        u = np.atleast_1d(np.asarray(u, dtype=np.float64))
        v = np.atleast_1d(np.asarray(v, dtype=np.float64))
        u, v = np.broadcast_arrays(u, v)
        p, q = self.u_degree, self.v_degree
        out = np.empty((nd + 1, nd + 1, u.shape[0], 3))
        for a in range(0, u.shape[0], BATCH):
            us, Nu = self.ukv.ders(u[a : a + BATCH], nd)
            vs, Nv = self.vkv.ders(v[a : a + BATCH], nd)
            rows = vs[:, None] - q + np.arange(q + 1)
            cols = us[:, None] - p + np.arange(p + 1)
            net = self.pw[rows[:, :, None], cols[:, None, :]]  # (K, q+1, p+1, 4)
            hom = np.einsum("xka,ykb,kbac->xykc", Nu, Nv, net, optimize=True)
            out[:, :, a : a + BATCH] = _rational(hom)
        out[0, 0] += self.origin
        return out

    def points(self, u, v) -> np.ndarray:
        return self.derivatives(u, v, 0)[0, 0]

    # ----- on a tensor grid (dense basis matrices: one matrix product per derivative)
    def grid_derivatives(self, us, vs, nd: int = 0) -> np.ndarray:
        """S_{k,l} on the grid us x vs, shape (nd+1, nd+1, len(vs), len(us), 3)."""
        us = np.asarray(us, dtype=np.float64)
        vs = np.asarray(vs, dtype=np.float64)
        Bu = _dense_basis(self.ukv, us, nd)  # (nd+1, m, nu)
        Bv = _dense_basis(self.vkv, vs, nd)  # (nd+1, n, nv)
        # T[x, j, m, c] = sum_i Bu[x, m, i] pw[j, i, c], then contract over j.
        T = np.einsum("xmi,jic->xjmc", Bu, self.pw, optimize=True)
        hom = np.einsum("ynj,xjmc->xynmc", Bv, T, optimize=True)
        sh = hom.shape
        S = _rational(hom.reshape(sh[0], sh[1], -1, 4)).reshape(sh[0], sh[1], sh[2], sh[3], 3)
        S[0, 0] += self.origin
        return S

    # ----- normals
    def normals(self, u, v) -> np.ndarray:
        """Unit normals S_u x S_v at (u, v), never NaN (see `normals_from_derivatives`)."""
        u = np.atleast_1d(np.asarray(u, dtype=np.float64))
        v = np.atleast_1d(np.asarray(v, dtype=np.float64))
        u, v = np.broadcast_arrays(u, v)
        # nd = 1 already gives the full square, S_uv included (needed at poles).
        d = self.derivatives(u, v, 1)
        return self.normals_from_derivatives(d, u, v)

    def normals_at_uv(self, uv) -> np.ndarray:
        """Exact normals at normalised parameters (uv in [0, 1]^2, as the tessellation's uvs),
        e.g. at a ray hit's barycentric mix of its triangle's `corner_uvs`."""
        uv = np.asarray(uv, dtype=np.float64).reshape(-1, 2)
        (u0, u1), (v0, v1) = self.domain
        return self.normals(u0 + uv[:, 0] * (u1 - u0), v0 + uv[:, 1] * (v1 - v0))

    def normals_from_derivatives(self, d: np.ndarray, u: np.ndarray, v: np.ndarray) -> np.ndarray:
        """Normals from derivatives d (>= (2, 2, K, 3)) at parameters u, v (K,).

        Regular points: S_u x S_v. Where one tangent vanishes (a row of coincident control
        points: the pole of a sphere) the normal is the limit from inside the domain: with
        S_u = 0 along v = v0, S_u(u, v0 + e) ~ e S_uv, so n ~ sign(e) S_uv x S_v (likewise for
        S_v = 0). Whatever remains degenerate (a cusp, both tangents zero) takes the normal of
        a point nudged into the domain; a last resort keeps the result finite and unit."""
        (u0, u1), (v0, v1) = self.domain
        su, sv = d[1, 0], d[0, 1]
        suv = d[1, 1] if d.shape[0] > 1 and d.shape[1] > 1 else np.zeros_like(su)
        ref = self.scale
        ru = DEGENERATE_REL * ref / (u1 - u0)
        rv = DEGENERATE_REL * ref / (v1 - v0)
        lu = np.linalg.norm(su, axis=-1)
        lv = np.linalg.norm(sv, axis=-1)
        n = np.cross(su, sv)
        ln = np.linalg.norm(n, axis=-1)
        bad_u = lu <= ru
        bad_v = lv <= rv
        # Inward direction from a boundary: toward the domain's middle.
        sgn_v = np.where(v >= 0.5 * (v0 + v1), -1.0, 1.0)
        sgn_u = np.where(u >= 0.5 * (u0 + u1), -1.0, 1.0)
        only_u = bad_u & ~bad_v
        only_v = bad_v & ~bad_u
        if only_u.any():
            n[only_u] = sgn_v[only_u, None] * np.cross(suv[only_u], sv[only_u])
        if only_v.any():
            n[only_v] = sgn_u[only_v, None] * np.cross(su[only_v], suv[only_v])
        ln = np.linalg.norm(n, axis=-1)
        good = ln > PARALLEL_REL * np.maximum(lu * lv, 1e-300)
        good &= ~(bad_u & bad_v)
        good &= np.isfinite(ln) & (ln > 0)
        out = np.zeros_like(n)
        out[good] = n[good] / ln[good, None]
        rest = np.flatnonzero(~good)
        for frac in NUDGE_REL:
            if rest.size == 0:
                break
            uu = u[rest] + sgn_u[rest] * frac * (u1 - u0)
            vv = v[rest] + sgn_v[rest] * frac * (v1 - v0)
            dd = self.derivatives(uu, vv, 1)
            m = np.cross(dd[1, 0], dd[0, 1])
            lm = np.linalg.norm(m, axis=-1)
            ok = np.isfinite(lm) & (lm > 0)
            ok &= lm > PARALLEL_REL * np.linalg.norm(dd[1, 0], axis=-1) * np.linalg.norm(
                dd[0, 1], axis=-1
            )
            out[rest[ok]] = m[ok] / lm[ok, None]
            rest = rest[~ok]
        if rest.size:
            out[rest] = (0.0, 1.0, 0.0)  # a fully collapsed net: any unit vector is honest
        return out


def _dense_basis(kv: KnotVector, t: np.ndarray, nd: int) -> np.ndarray:
    """Basis function derivatives as dense matrices (nd+1, len(t), n)."""
    span, N = kv.ders(t, nd)
    B = np.zeros((nd + 1, t.shape[0], kv.n))
    cols = span[:, None] - kv.degree + np.arange(kv.degree + 1)
    rows = np.broadcast_to(np.arange(t.shape[0])[:, None], cols.shape)
    for k in range(nd + 1):
        B[k, rows, cols] = N[k]
    return B


# ------------------------------------------------------------------------ constructors
_R2 = math.sqrt(0.5)
# The seed's quadratic circle: a square's corners (weight 1/sqrt 2) and edge midpoints.
_CIRCLE_XY = ((1, 0), (1, 1), (0, 1), (-1, 1), (-1, 0), (-1, -1), (0, -1), (1, -1), (1, 0))
_CIRCLE_W = (1.0, _R2, 1.0, _R2, 1.0, _R2, 1.0, _R2, 1.0)
CIRCLE_KNOTS = (0.0, 0.0, 0.0, 1.0, 1.0, 2.0, 2.0, 3.0, 3.0, 4.0, 4.0, 4.0)
# Half circle from the south pole to the north pole (in the profile plane: radius, height).
_HALF_RY = ((0, -1), (1, -1), (1, 0), (1, 1), (0, 1))
_HALF_W = (1.0, _R2, 1.0, _R2, 1.0)
HALF_KNOTS = (0.0, 0.0, 0.0, 1.0, 1.0, 2.0, 2.0, 2.0)


def exact_circle(
    center: ir.Vec3 = (0.0, 0.0, 0.0), radius: float = 1.0, tube: float = 0.05
) -> ir.Nurbs:
    """The seed's exact circle in the xy plane: 9 points, knots {0,0,0,1,1,2,2,3,3,4,4,4},
    weights 1 on the edge midpoints and 1/sqrt(2) on the corners; a tube of radius `tube`."""
    cx, cy, cz = center
    pts = tuple((cx + radius * x, cy + radius * y, cz) for x, y in _CIRCLE_XY)
    return ir.Nurbs(
        u_degree=2,
        v_degree=0,
        nu=9,
        nv=0,
        points=tuple((float(a), float(b), float(c)) for a, b, c in pts),
        weights=_CIRCLE_W,
        u_knots=CIRCLE_KNOTS,
        radius=tube,
    )


def _revolve(profile, pw, v_knots, center) -> ir.Nurbs:
    """A surface of revolution about the y axis: `profile` (radius, height) points with
    weights `pw`, swept by the exact circle in the xz plane (u fastest, u = angle)."""
    cx, cy, cz = center
    points = []
    weights = []
    for (r, h), wj in zip(profile, pw, strict=True):
        for (cxu, czu), wi in zip(_CIRCLE_XY, _CIRCLE_W, strict=True):
            points.append((cx + r * cxu, cy + h, cz + r * czu))
            weights.append(wi * wj)
    return ir.Nurbs(
        u_degree=2,
        v_degree=2,
        nu=9,
        nv=len(profile),
        points=tuple((float(a), float(b), float(c)) for a, b, c in points),
        weights=tuple(weights),
        u_knots=CIRCLE_KNOTS,
        v_knots=tuple(v_knots),
    )


def nurbs_sphere(center: ir.Vec3 = (0.0, 0.0, 0.0), r: float = 1.0) -> ir.Nurbs:
    """An exact rational sphere (9 x 5 net, poles on the y axis as POV-Ray's torus axis)."""
    profile = [(r * a, r * b) for a, b in _HALF_RY]
    return _revolve(profile, _HALF_W, HALF_KNOTS, center)


def nurbs_torus(R: float = 1.0, r: float = 0.25, center: ir.Vec3 = (0.0, 0.0, 0.0)) -> ir.Nurbs:
    """An exact rational torus about the y axis like POV-Ray's `torus { R, r }` (9 x 9 net)."""
    profile = [(R + r * a, r * b) for a, b in _CIRCLE_XY]
    return _revolve(profile, _CIRCLE_W, CIRCLE_KNOTS, center)
