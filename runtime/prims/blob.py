"""POV-Ray's blob: the surface where the summed density of its components equals the
threshold; inside where the density is greater.

A component of radius r and strength s adds s (1 - (d/r)^2)^2 within distance d < r of its
centre (`sphere`) or of its axis segment (`cylinder`, whose field ends in hemispheres, as
POV-Ray builds it from a cylinder and two hemispheres). Each component has its own
transform, so it is an ellipsoid or an elliptic capsule in blob space.

Every field piece (a sphere; a cylinder's middle and its two end caps) lives in a local
frame where its radius is 1. Along a ray, d^2 / r^2 of a piece is a quadratic in the
distance, so its density is a quartic on the interval where the ray is within the piece.
The exact method, as POV-Ray's: the ends of all those intervals cut the ray into pieces on
each of which the density is one quartic (the sum over the pieces active there); each is
re-expressed on [0, 1] from its own left end (no cancellation from a far-away origin),
skipped when the active strengths cannot reach the threshold or its Bernstein coefficients
show no sign change, and otherwise solved exactly by `roots.roots_in`. The signs at shared
interval ends are taken once, so the crossings always alternate between outside and inside.

Component textures are not used: the whole blob wears the blob's texture.

The compiled kernel (kernel/blob.h) traces blobs from `table()` with the same formulas: so
that both round alike, sums over a point's three coordinates and over the pieces are taken
in order (`_apply`, `_dot3`, `_in_order`; numpy's einsum and matmul pick their own order)
and powers are products.
"""

from __future__ import annotations

import numpy as np

from lang import ir
from runtime import tolerances as tol
from runtime import transform as tf
from runtime.prims import roots
from runtime.shapes import stable_quadratic

INF = np.inf

# Rays are processed in chunks so that (rays x sub-intervals x pieces) arrays stay a few
# million entries (memory, not accuracy).
_CHUNK_ENTRIES = 2_000_000

# binomial(i, k) / binomial(4, k): power basis on [0, 1] to Bernstein coefficients
_BERNSTEIN = np.array(
    [
        [1, 0, 0, 0, 0],
        [1, 1 / 4, 0, 0, 0],
        [1, 2 / 4, 1 / 6, 0, 0],
        [1, 3 / 4, 3 / 6, 1 / 4, 0],
        [1, 1, 1, 1, 1],
    ],
    dtype=np.float64,
)


# the kernel's row per piece: the 3x4 frame, whether z counts, the cap's shift, the
# piece's z range, its strength
PIECE = 17


def _apply(w: np.ndarray, p: np.ndarray, offset: bool = True) -> np.ndarray:
    """(N, P, 3): each piece's affine rows w (P, 3, 4) at points p (N, 3), summed in order
    (the translation last; without `offset`, the linear part only: a direction)."""
    out = (
        w[None, :, :, 0] * p[:, None, None, 0]
        + w[None, :, :, 1] * p[:, None, None, 1]
        + w[None, :, :, 2] * p[:, None, None, 2]
    )
    return out + w[None, :, :, 3] if offset else out


def _dot3(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """a . b over the last axis (of 3), summed in order."""
    return a[..., 0] * b[..., 0] + a[..., 1] * b[..., 1] + a[..., 2] * b[..., 2]


def _in_order(x: np.ndarray) -> np.ndarray:
    """The sum over axis 1, piece after piece (a running sum: numpy's sum pairs them)."""
    if x.shape[1] == 0:
        return np.zeros(x.shape[:1] + x.shape[2:])
    return np.cumsum(x, axis=1)[:, -1]


class BlobPrim:
    def __init__(self, shape: ir.Blob):
        self.threshold = float(shape.threshold)
        w, use_z, shift, zlo, zhi, s, boxes = [], [], [], [], [], [], []
        for comp in shape.components:
            r = abs(float(comp.radius))
            if r == 0 or comp.strength == 0:
                continue
            m = tf.as_matrix(comp.transform)
            if not abs(np.linalg.det(m[:3, :3])) > 0:
                continue  # scaled flat: a field of zero volume adds nothing
            to_comp = tf.inverse(m)
            a = np.asarray(comp.a, dtype=np.float64)
            b = np.asarray(comp.b, dtype=np.float64)
            axis = b - a
            h = float(np.linalg.norm(axis)) / r
            if comp.kind != "cylinder" or h == 0:
                frame = np.diag([1 / r, 1 / r, 1 / r, 1.0]) @ tf.translation(-a)
                parts = [(True, 0.0, -INF, INF)]
            else:
                frame = np.diag([1 / r, 1 / r, 1 / r, 1.0]) @ tf.inverse(tf.frame_to(a, axis))
                # half-open ranges so a point on a seam belongs to exactly one piece
                parts = [(False, 0.0, 0.0, h), (True, 0.0, -INF, 0.0), (True, h, h, INF)]
            local = frame @ to_comp
            for uz, sh, lo, hi in parts:
                w.append(local[:3])
                use_z.append(uz)
                shift.append(sh)
                zlo.append(lo)
                zhi.append(hi)
                s.append(float(comp.strength))
            if comp.strength > 0 or self.threshold <= 0:
                boxes.append(
                    tf.aabb_transform(
                        tf.inverse(local), np.array([-1, -1, -1.0]), np.array([1, 1, h + 1])
                    )
                )
        self.w = np.array(w, dtype=np.float64).reshape(-1, 3, 4)
        self.use_z = np.array(use_z, dtype=bool)
        self.shift = np.array(shift, dtype=np.float64)
        self.zlo = np.array(zlo, dtype=np.float64)
        self.zhi = np.array(zhi, dtype=np.float64)
        self.s = np.array(s, dtype=np.float64)
        if boxes:
            self.lo = np.min([b[0] for b in boxes], axis=0)
            self.hi = np.max([b[1] for b in boxes], axis=0)
        else:
            self.lo, self.hi = np.zeros(3), np.zeros(3)
        if self.threshold <= 0:
            # every point away from the components is inside: there is no finite bound
            self.lo, self.hi = np.full(3, -INF), np.full(3, INF)
            self.size = 1.0
        else:
            self.size = float(np.linalg.norm(self.hi - self.lo)) or 1.0
        self.centre = 0.5 * (self.lo + self.hi) if np.all(np.isfinite(self.lo)) else np.zeros(3)

    def bounds(self):
        return self.lo, self.hi

    def table(self) -> np.ndarray:
        """(P, PIECE) rows of the pieces for the compiled kernel (kernel/blob.h)."""
        n = len(self.s)
        cols = [self.w.reshape(n, 12), self.use_z, self.shift, self.zlo, self.zhi, self.s]
        return np.column_stack([np.asarray(c, dtype=np.float64).reshape(n, -1) for c in cols])

    # ------------------------------------------------------------------ the field
    def _local(self, p: np.ndarray) -> np.ndarray:
        """(N, P, 3) piece-local coordinates of points p, each relative to its piece's
        centre (the cap's centre for the far hemisphere)."""
        lp = _apply(self.w, p)
        lp[..., 2] -= self.shift
        return lp

    def _active(self, p: np.ndarray):
        lp = self._local(p)
        z = lp[..., 2] + self.shift
        lp[..., 2] = np.where(self.use_z, lp[..., 2], 0.0)
        d2 = _dot3(lp, lp)
        inside = (d2 < 1) & (z >= self.zlo) & (z < self.zhi)
        return lp, np.where(inside, 1 - d2, 0.0)

    def density(self, p: np.ndarray) -> np.ndarray:
        out = np.zeros(len(p))
        for sl in self._chunks(len(p), len(self.s)):
            _, w = self._active(p[sl])
            out[sl] = _in_order(w * w * self.s)
        return out

    def normal(self, p, face):
        """-grad density: sum of 4 s (1 - d^2) W^T (local offset), in blob space."""
        out = np.zeros((len(p), 3))
        for sl in self._chunks(len(p), len(self.s)):
            lp, w = self._active(p[sl])
            g = (4 * self.s * w)[..., None] * lp
            wt = self.w
            each = (
                g[..., 0, None] * wt[None, :, 0, :3]
                + g[..., 1, None] * wt[None, :, 1, :3]
                + g[..., 2, None] * wt[None, :, 2, :3]
            )
            out[sl] = _in_order(each)
        return out

    def inside(self, p):
        # POV-Ray: density > threshold - INSIDE_TOLERANCE, so the surface is inside.
        return self.density(p) > self.threshold - tol.BLOB_INSIDE

    def outside(self, p):
        return ~self.inside(p)

    @staticmethod
    def _chunks(n: int, per_row: int):
        step = max(1, _CHUNK_ENTRIES // max(per_row, 1))
        return [slice(i, min(i + step, n)) for i in range(0, n, step)]

    # ----------------------------------------------------------------- crossings
    def crossings(self, o, d):
        n = len(o)
        parts = []
        dd = _dot3(d, d)
        dl = np.sqrt(dd)
        good = dl > 0
        du = d / np.where(good, dl, 1.0)[:, None]
        # shapes.recentre, its sums in order
        with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
            t0 = np.where(dd > 0, _dot3(self.centre - o, d) / dd, 0.0)
        oc = o + t0[:, None] * d
        for sl in self._chunks(n, max(1, 4 * len(self.s))):
            u = self._chunk_crossings(oc[sl], du[sl])
            parts.append(u)
        k = max(p.shape[1] for p in parts) if parts else 1
        u = np.full((n, k), INF)
        row = 0
        for p in parts:
            u[row : row + len(p), : p.shape[1]] = p
            row += len(p)
        t = np.where(
            good[:, None] & np.isfinite(u), u / np.where(good, dl, 1.0)[:, None] + t0[:, None], INF
        )
        return roots.compact(t)

    def _chunk_crossings(self, o: np.ndarray, d: np.ndarray) -> np.ndarray:
        n = len(o)
        if len(self.s) == 0 or n == 0:
            return np.full((n, 1), INF)
        # Each piece's d^2 along the ray: A t^2 + 2 B t + C (local units).
        lo = _apply(self.w, o)
        ld = _apply(self.w, d, offset=False)
        z0, dz = lo[..., 2].copy(), ld[..., 2].copy()
        lo[..., 2] -= self.shift
        mask = np.where(self.use_z, 1.0, 0.0)
        lo[..., 2] *= mask
        ld[..., 2] *= mask
        qa, qb, qc = _dot3(ld, ld), _dot3(lo, ld), _dot3(lo, lo)
        t1, t2 = stable_quadratic(qa, qb, qc - 1)
        # a ray along a cylinder's axis: its distance to the axis never changes
        along = qa <= 0
        t1 = np.where(along, np.where(qc < 1, -INF, INF), t1)
        t2 = np.where(along, np.where(qc < 1, INF, -INF), t2)
        with np.errstate(divide="ignore", invalid="ignore"):
            za, zb = (self.zlo - z0) / dz, (self.zhi - z0) / dz
        flat = dz == 0
        in_slab = (z0 >= self.zlo) & (z0 < self.zhi)
        zin = np.where(flat, np.where(in_slab, -INF, INF), np.fmin(za, zb))
        zout = np.where(flat, np.where(in_slab, INF, -INF), np.fmax(za, zb))
        tin = np.maximum(t1, zin)
        tout = np.minimum(t2, zout)
        # (a ray along a cylinder's axis inside it meets the middle piece where the slab is)
        valid = np.isfinite(tin) & (tin < tout)
        counts = valid.sum(axis=1)
        pmax = int(counts.max())
        if pmax == 0:
            return np.full((n, 1), INF)
        # Keep, per ray, only the pieces it meets (most rays meet few of many components).
        rows = np.nonzero(counts)[0]
        order = np.argsort(~valid[rows], axis=1, kind="stable")[:, :pmax]
        take = np.take_along_axis
        v = take(valid[rows], order, 1)
        tin_r = np.where(v, take(tin[rows], order, 1), INF)
        tout_r = np.where(v, take(tout[rows], order, 1), INF)
        qa_r, qb_r, qc_r = (take(q[rows], order, 1) for q in (qa, qb, qc))
        s_r = np.where(v, self.s[order], 0.0)
        u = np.full((n, 4 * (2 * pmax - 1)), INF)
        u[rows] = self._solve(tin_r, tout_r, qa_r, qb_r, qc_r, s_r)
        return u

    def _solve(self, tin, tout, qa, qb, qc, s) -> np.ndarray:
        """Crossings of rays (M rows) given their pieces (M, P): intervals, quadratics
        and strengths (0 for padding)."""
        m, p = tin.shape
        thr = self.threshold
        # Each piece's density s (1 - d^2)^2 as a quartic in t; entering adds it, leaving
        # subtracts it, so running sums over the sorted ends give each sub-interval's sum.
        w0, w1, w2 = 1 - qc, -2 * qb, -qa
        quart = s[..., None] * np.stack(
            [w0 * w0, 2 * w0 * w1, w1 * w1 + 2 * w0 * w2, 2 * w1 * w2, w2 * w2], -1
        )
        quart = np.where(np.isfinite(tin)[..., None], quart, 0.0)
        ev = np.concatenate([tin, tout], axis=1)
        order = np.argsort(ev, axis=1, kind="stable")
        ev = np.take_along_axis(ev, order, 1)
        delta = np.take_along_axis(np.concatenate([quart, -quart], axis=1), order[..., None], 1)
        sums = np.cumsum(delta, axis=1)[:, :-1]  # (M, 2P-1, 5): sub-interval k = [ev_k, ev_k+1]
        pos = np.maximum(s, 0.0)
        reach = np.cumsum(
            np.take_along_axis(np.concatenate([pos, -pos], axis=1), order, 1), axis=1
        )[:, :-1]
        left, right = ev[:, :-1], ev[:, 1:]
        ok = np.isfinite(right) & (right > left)
        # the running sum of strengths only filters: a rounding margin keeps borderline ones
        cand = ok & (reach > thr - tol.BLOB_INSIDE * (1 + np.abs(thr)))
        out = np.full((m, 4 * (2 * p - 1)), INF)
        if not cand.any():
            return out
        ci, cj = np.nonzero(cand)
        l = left[ci, cj]
        w = right[ci, cj] - l
        coef = _taylor_shift(sums[ci, cj], l)
        coef[:, 0] -= thr
        w2 = w * w
        coef[:, 1] *= w
        coef[:, 2] *= w2
        coef[:, 3] *= w2 * w
        coef[:, 4] *= w2 * w2
        # Signs at the interval ends, shared between neighbours: a neighbour that is not a
        # candidate (or no neighbour: no piece active) has density below the threshold.
        outside = -1.0 if thr > 0 else -thr
        f0 = np.full(cand.shape, outside)
        f0[ci, cj] = coef[:, 0]
        # Neighbours are the nearest sub-intervals of positive width: an empty one (a seam
        # between a cylinder and its cap, two equal ends) counts both or neither piece.
        k = cand.shape[1]
        cols = np.broadcast_to(np.arange(k), cand.shape)
        prev = np.maximum.accumulate(np.where(ok, cols, -1), axis=1)
        prev = np.concatenate([np.full((m, 1), -1), prev[:, :-1]], axis=1)
        nxt = np.minimum.accumulate(np.where(ok, cols, k)[:, ::-1], axis=1)[:, ::-1]
        nxt = np.concatenate([nxt[:, 1:], np.full((m, 1), k)], axis=1)
        pj, nj = prev[ci, cj], nxt[ci, cj]
        prev_cand = (pj >= 0) & cand[ci, np.maximum(pj, 0)]
        next_cand = (nj < k) & cand[ci, np.minimum(nj, k - 1)]
        f_lo = np.where(prev_cand, coef[:, 0], outside)
        f_hi = np.where(next_cand, f0[ci, np.minimum(nj, k - 1)], outside)
        # Bernstein hull: no sign change in the control values and none at the ends → no root
        bern = coef[:, :1] * _BERNSTEIN[:, 0]
        for i in range(1, 5):
            bern = bern + coef[:, i, None] * _BERNSTEIN[:, i]
        all_pos = (bern > 0).all(1) & (f_lo >= 0) & (f_hi >= 0)
        all_neg = (bern < 0).all(1) & (f_lo < 0) & (f_hi < 0)
        keep = ~(all_pos | all_neg)
        if not keep.any():
            return out
        ci, cj, l, w = ci[keep], cj[keep], l[keep], w[keep]
        x = roots.roots_in(coef[keep], np.zeros(len(ci)), np.ones(len(ci)), f_lo[keep], f_hi[keep])
        t = l[:, None] + w[:, None] * x
        cols = 4 * cj[:, None] + np.arange(4)
        out[ci[:, None], cols] = t
        return out


def _taylor_shift(c: np.ndarray, l: np.ndarray) -> np.ndarray:
    """Coefficients of p(l + x) from those of p (M, n+1), lowest power first (repeated
    synthetic division)."""
    c = c.copy()
    n = c.shape[1] - 1
    for i in range(n):
        for k in range(n - 1, i - 1, -1):
            c[:, k] += l * c[:, k + 1]
    return c
