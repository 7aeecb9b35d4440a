"""POV-Ray's prism: closed 2D spline curves in the x-z plane swept along y between two
heights, straight (linear_sweep) or scaled by y towards the origin (conic_sweep).

`Sweep` does the work for any closed curve set and axis choice (text glyphs use it too):
walls are where the ray's line (projected along the sweep; for a conic sweep, projected
from the apex onto the plane w = 1) crosses a segment — one polynomial root problem of the
segment's degree per ray and segment — and caps are hits on the end planes that fall inside
the curves by the even-odd rule. Several groups of curves (glyphs) form a union: a point is
inside when some group holds it.
"""

from __future__ import annotations

import numpy as np

from lang import ir
from runtime import tolerances as tol
from runtime.prims import spline2d as sp

# Face ids: 0 the low cap, 1 the high cap, 2 + (segment index mod WALL_MOD) a wall. A face
# id is an int8, too small for a segment index; normal() finds the segment among the few
# whose index matches modulo WALL_MOD.
WALL_MOD = 126


class Sweep:
    """Closed curves in the (u, v) plane swept along w from h1 to h2; `axes` gives the
    object-space axes of u, v and w. `groups`: one Curve per separately filled region."""

    def __init__(
        self,
        groups: list[sp.Curve],
        h1: float,
        h2: float,
        axes: tuple[int, int, int],
        conic: bool = False,
        open_: bool = False,
    ):
        self.groups = [g for g in groups if len(g)]
        self.coef = (
            np.concatenate([g.coef for g in self.groups]) if self.groups else np.zeros((0, 2, 4))
        )
        self.offsets = np.cumsum([0] + [len(g) for g in self.groups])
        self.all = sp.Curve(self.coef)
        self.h1, self.h2 = min(h1, h2), max(h1, h2)
        self.axes = axes
        self.conic = conic
        self.open = open_
        if self.groups:
            self.glo = np.array([g.lo.min(axis=0) for g in self.groups])  # (G, 2)
            self.ghi = np.array([g.hi.max(axis=0) for g in self.groups])
            lo2, hi2 = self.glo.min(axis=0), self.ghi.max(axis=0)
        else:
            self.glo = self.ghi = np.zeros((0, 2))
            lo2 = hi2 = np.zeros(2)
        if conic:  # the curve scaled by every height between h1 and h2
            ends = np.array([lo2 * self.h1, lo2 * self.h2, hi2 * self.h1, hi2 * self.h2])
            lo2, hi2 = ends.min(axis=0), ends.max(axis=0)
        lo = np.zeros(3)
        hi = np.zeros(3)
        lo[list(axes)] = [lo2[0], lo2[1], self.h1]
        hi[list(axes)] = [hi2[0], hi2[1], self.h2]
        self.lo, self.hi = lo, hi
        self.size = float(np.linalg.norm(hi - lo))
        self.degenerate = not self.groups or self.h1 == self.h2

    def bounds(self):
        return self.lo, self.hi

    # ---------------------------------------------------------------- region tests
    def in_region(self, q: np.ndarray) -> np.ndarray:
        """(N,) is the 2D point q (N, 2) inside some group's curves (even-odd)?"""
        inside = np.zeros(len(q), dtype=bool)
        for g, curve in enumerate(self.groups):
            rows = np.nonzero(
                ~inside & np.all(q >= self.glo[g], axis=1) & np.all(q <= self.ghi[g], axis=1)
            )[0]
            if len(rows):
                inside[rows] = curve.contains(q[rows])
        return inside

    def _uvw(self, p: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        iu, iv, iw = self.axes
        return p[:, iu], p[:, iv], p[:, iw]

    def _scaled(self, p: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The curve-plane point of p (for a conic sweep, divided by its height) and
        whether it is defined."""
        u, v, w = self._uvw(p)
        q = np.stack([u, v], axis=1)
        if not self.conic:
            return q, np.ones(len(p), dtype=bool)
        ok = np.abs(w) > tol.PARALLEL_EPS
        return q / np.where(ok, w, 1.0)[:, None], ok

    def inside(self, p):
        # POV-Ray: h1 <= w < h2 and inside the curves.
        _, _, w = self._uvw(p)
        q, ok = self._scaled(p)
        res = ok & (w >= self.h1) & (w < self.h2)
        rows = np.nonzero(res)[0]
        res[rows] = self.in_region(q[rows])
        return res

    def outside(self, p):
        return ~self.inside(p)

    # ------------------------------------------------------------------ crossings
    def crossings(self, o, d):
        n = len(o)
        if self.degenerate or n == 0:
            return np.full((n, 1), np.inf), np.zeros((n, 1), dtype=np.int8)
        # Recentre the origins on the shape (far origins would cancel in the line terms).
        centre = 0.5 * (self.lo + self.hi)
        dd = np.einsum("ij,ij->i", d, d)
        with np.errstate(divide="ignore", invalid="ignore"):
            t0 = np.where(dd > 0, np.einsum("ij,ij->i", centre - o, d) / dd, 0.0)
        oc = o + t0[:, None] * d
        P = np.stack(self._uvw(oc), axis=1)  # (N, 3) as (u, v, w)
        D = np.stack(self._uvw(d), axis=1)
        tw, fw = self._walls(P, D)
        ts, fs = [tw], [fw]
        if not self.open:
            for face, h in ((0, self.h1), (1, self.h2)):
                t, f = self._cap(P, D, h, face)
                ts.append(t)
                fs.append(f)
        t = np.concatenate(ts, axis=1) + t0[:, None]
        f = np.concatenate(fs, axis=1)
        return sp.compact(t, f)

    def _cap(self, P, D, h, face):
        n = len(P)
        t = np.full(n, np.inf)
        if self.conic and abs(h) <= tol.PARALLEL_EPS:
            return t[:, None], np.full((n, 1), face, dtype=np.int8)
        ok = np.abs(D[:, 2]) > tol.PARALLEL_EPS
        with np.errstate(divide="ignore", invalid="ignore"):
            k = np.where(ok, (h - P[:, 2]) / D[:, 2], np.inf)
        rows = np.nonzero(np.isfinite(k))[0]
        q = P[rows, :2] + k[rows, None] * D[rows, :2]
        if self.conic:
            q = q / h
        inside = self.in_region(q)
        t[rows[inside]] = k[rows[inside]]
        return t[:, None], np.full((n, 1), face, dtype=np.int8)

    def _walls(self, P, D):
        n = len(P)
        if self.conic:
            # The plane through the apex and the ray meets w = 1 in the line n.(x, y, 1) = 0.
            line = np.cross(P, D)  # (u, v, w) components: a, b, c
        else:
            line = np.stack([D[:, 1], -D[:, 0], D[:, 0] * P[:, 1] - D[:, 1] * P[:, 0]], axis=1)
        scale = np.max(np.abs(line[:, :2]), axis=1)
        usable = scale > tol.PARALLEL_EPS * (1.0 + np.abs(line[:, 2]))
        line = line / np.where(usable, scale, 1.0)[:, None]
        ri_all, seg_all, k_all = [], [], []
        for g, curve in enumerate(self.groups):
            rows = np.nonzero(usable & self._line_meets_box(line, g))[0]
            if len(rows) == 0:
                continue
            ri, si, u = curve.line_roots(line, rows)
            if len(ri) == 0:
                continue
            k = self._wall_k(curve, P[ri], D[ri], si, u)
            ri_all.append(ri)
            seg_all.append(np.repeat((si + self.offsets[g])[:, None], u.shape[1], axis=1))
            k_all.append(k)
        if not ri_all:
            return np.full((n, 1), np.inf), np.zeros((n, 1), dtype=np.int8)
        ri = np.concatenate(ri_all)
        seg = np.concatenate(seg_all)
        k = np.concatenate(k_all)
        face = (2 + seg % WALL_MOD).astype(np.int8)
        return sp.pairs_to_rows(n, ri, k, face)

    def _line_meets_box(self, line, g):
        lo, hi = self.glo[g], self.ghi[g]
        a, b, c = line[:, 0], line[:, 1], line[:, 2]
        vals = [a * x + b * y + c for x in (lo[0], hi[0]) for y in (lo[1], hi[1])]
        mn = np.minimum.reduce(vals)
        mx = np.maximum.reduce(vals)
        return (mn <= 0) & (mx >= 0)

    def _wall_k(self, curve, P, D, si, u):
        """Ray parameters (M, K) of the wall points at segment parameters u (M, K), inf
        where u is nan or the point lies outside the height range."""
        ok = np.isfinite(u)
        uu = np.where(ok, u, 0.0)
        cf = curve.coef[si]  # (M, 2, 4)
        X = sp.polyval(cf[:, 0][:, None, :], uu)
        Y = sp.polyval(cf[:, 1][:, None, :], uu)
        Pe = P[:, None, :]
        De = D[:, None, :]
        if self.conic:
            # P + k D = s (X, Y, 1): k = -((P x V).(D x V)) / |D x V|^2.
            V = np.stack([X, Y, np.ones_like(X)], axis=-1)
            pv = np.cross(np.broadcast_to(Pe, V.shape), V)
            dv = np.cross(np.broadcast_to(De, V.shape), V)
            den = np.sum(dv * dv, axis=-1)
            with np.errstate(divide="ignore", invalid="ignore"):
                k = -np.sum(pv * dv, axis=-1) / den
        else:
            den = De[..., 0] ** 2 + De[..., 1] ** 2
            with np.errstate(divide="ignore", invalid="ignore"):
                k = ((X - Pe[..., 0]) * De[..., 0] + (Y - Pe[..., 1]) * De[..., 1]) / den
        w = Pe[..., 2] + k * De[..., 2]
        ok &= np.isfinite(k) & (w >= self.h1) & (w <= self.h2)
        return np.where(ok, k, np.inf)

    # -------------------------------------------------------------------- normals
    def normal(self, p, face):
        n = np.zeros_like(p)
        iu, iv, iw = self.axes
        f = face.astype(np.int64)
        n[f == 0, iw] = -1.0
        n[f == 1, iw] = 1.0
        wall = np.nonzero(f >= 2)[0]
        if len(wall) == 0 or len(self.all) == 0:
            return n
        q, _ = self._scaled(p[wall])
        seg, t = self.all.locate(f[wall] - 2, WALL_MOD, q)
        tan = self.all.tangent(seg, t)
        n2 = np.stack([tan[:, 1], -tan[:, 0]], axis=1)
        length = np.linalg.norm(n2, axis=1)
        n2 = n2 / np.where(length > 0, length, 1.0)[:, None]
        # Outward: the side just off the wall along n2 must be outside the curves.
        step = tol.SWEEP_SIDE_REL * max(self.size, tol.ABS_FLOOR)
        if self.conic:
            _, _, w = self._uvw(p[wall])
            step = (step / np.maximum(np.abs(w), tol.ABS_FLOOR))[:, None]
        flip = self.in_region(q + step * n2)
        n2 = np.where(flip[:, None], -n2, n2)
        n[wall, iu] = n2[:, 0]
        n[wall, iv] = n2[:, 1]
        if self.conic:
            u, v, w = self._uvw(p[wall])
            with np.errstate(divide="ignore", invalid="ignore"):
                nw = -(u * n2[:, 0] + v * n2[:, 1]) / w
            n[wall, iw] = np.where(np.abs(w) > tol.PARALLEL_EPS, nw, 0.0)
        return n


class PrismPrim(Sweep):
    """ir.Prism: curves in x (u) and z (v), swept along y."""

    def __init__(self, shape: ir.Prism):
        coef = sp.prism_segments(shape.spline, shape.points)
        super().__init__(
            [sp.Curve(coef)],
            float(shape.height1),
            float(shape.height2),
            axes=(0, 2, 1),
            conic=shape.sweep == "conic_sweep",
            open_=bool(shape.open),
        )
