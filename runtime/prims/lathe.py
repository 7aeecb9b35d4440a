"""POV-Ray's lathe (a 2D spline of (radius, height) points turned about the y axis) and sor
(a surface of revolution whose radius squared is a cubic of the height).

Lathe: on segment (X(u), Y(u)) the ray P + k D meets the surface where
|P_xz + k D_xz|^2 = X(u)^2 and P_y + k D_y = Y(u); eliminating k leaves a polynomial in u of
twice the spline's degree, solved for every ray and every segment whose bounding cylinder
the ray passes (every root of u in -0.2..1.2, by roots.roots_in), then (u, k) are
Newton-polished together on the two equations. The arithmetic is written out column by
column, in the order the compiled kernel (kernel/lathe.h) repeats.
Sor: x^2 + z^2 = f(y) with f cubic on each segment is a cubic in k.
"""

from __future__ import annotations

import numpy as np

from lang import ir
from runtime import tolerances as tol
from runtime.prims import roots
from runtime.prims import spline2d as sp

# Lathe face id = segment index mod LATHE_MOD (an int8 holds no segment index); normal()
# finds the segment among those matching.
LATHE_MOD = 127
# the segment parameters whose roots are polished (past the ends: kept by in_window or not)
LATHE_WINDOW = (-0.2, 1.2)


def _unit_recentred(o, d, centre):
    """Unit directions, origins moved to the point of the line nearest `centre`, and the
    map back: t = t0 + k / |d|."""
    dl = np.sqrt(d[:, 0] * d[:, 0] + d[:, 1] * d[:, 1] + d[:, 2] * d[:, 2])
    dl = np.where(dl > 0, dl, 1.0)
    D = d / dl[:, None]
    c = centre - o
    k0 = c[:, 0] * D[:, 0] + c[:, 1] * D[:, 1] + c[:, 2] * D[:, 2]
    P = o + k0[:, None] * D
    return P, D, k0 / dl, dl


def _cylinder_pairs(P, D, h1, h2, rmin, rmax):
    """(N, S) mask: can the line P + k D (unit D) meet the cylindrical shell rmin..rmax
    between heights h1..h2 of each segment? (exact interval test, slightly padded)"""
    pad = tol.BOX_PAD_REL * (1.0 + np.abs(h2 - h1)) + tol.BOX_PAD_ABS
    Py, Dy = P[:, 1, None], D[:, 1, None]
    flat = np.abs(Dy) <= tol.PARALLEL_EPS
    with np.errstate(divide="ignore", invalid="ignore"):
        ka = np.where(flat, -np.inf, (h1 - pad - Py) / Dy)
        kb = np.where(flat, np.inf, (h2 + pad - Py) / Dy)
    ka, kb = np.minimum(ka, kb), np.maximum(ka, kb)
    within = ~flat | ((Py >= h1 - pad) & (Py <= h2 + pad))
    r = D[:, 0, None] ** 2 + D[:, 2, None] ** 2
    m = P[:, 0, None] * D[:, 0, None] + P[:, 2, None] * D[:, 2, None]
    rho0 = P[:, 0, None] ** 2 + P[:, 2, None] ** 2

    def rho2(k):
        with np.errstate(invalid="ignore", over="ignore"):
            finite = r * k * k + 2 * m * k + rho0
            return np.where(np.isinf(k), np.where(r > 0, np.inf, rho0), finite)

    with np.errstate(divide="ignore", invalid="ignore"):
        kstar = np.where(r > 0, -m / np.where(r > 0, r, 1.0), 0.0)
    kstar = np.clip(kstar, ka, kb)
    lo = rho2(kstar)
    hi = np.maximum(rho2(ka), rho2(kb))
    rpad = 1.0 + 1e-6  # radius squared compared with a relative margin
    return within & (lo <= rmax**2 * rpad + pad) & (hi >= rmin**2 / rpad - pad)


class LathePrim:
    def __init__(self, shape: ir.Lathe):
        self.curve = sp.Curve(sp.lathe_segments(shape.spline, shape.points))
        c = self.curve
        self.degenerate = len(c) == 0
        if self.degenerate:
            self.lo = self.hi = np.zeros(3)
            self.size = self.ylo = self.yhi = 0.0
            return
        xl, xh = c.lo[:, 0], c.hi[:, 0]
        self.rmax = np.maximum(np.abs(xl), np.abs(xh))
        self.rmin = np.where((xl <= 0) & (xh >= 0), 0.0, np.minimum(np.abs(xl), np.abs(xh)))
        self.h1, self.h2 = c.lo[:, 1], c.hi[:, 1]
        R = float(self.rmax.max())
        self.ylo, self.yhi = float(self.h1.min()), float(self.h2.max())
        self.lo = np.array([-R, self.ylo, -R])
        self.hi = np.array([R, self.yhi, R])
        self.size = float(np.linalg.norm(self.hi - self.lo))

    def bounds(self):
        return self.lo, self.hi

    def crossings(self, o, d):
        n = len(o)
        if self.degenerate or n == 0:
            return np.full((n, 1), np.inf), np.zeros((n, 1), dtype=np.int8)
        P, D, t0, dl = _unit_recentred(o, d, 0.5 * (self.lo + self.hi))
        pair = _cylinder_pairs(P, D, self.h1, self.h2, self.rmin, self.rmax)
        ri, si = np.nonzero(pair)
        if len(ri) == 0:
            return np.full((n, 1), np.inf), np.zeros((n, 1), dtype=np.int8)
        cf = self.curve.coef[si]  # (M, 2, 4)
        Pr, Dr = P[ri], D[ri]
        Dy = Dr[:, 1]
        flat = np.abs(Dy) <= tol.LATHE_FLAT_DIR
        u = np.full((len(ri), 6), np.nan)
        k = np.full((len(ri), 6), np.nan)
        W = cf[:, 1].copy()
        W[:, 3] -= Pr[:, 1]  # Y(u) - P_y
        X = cf[:, 0]
        r = Dr[:, 0] ** 2 + Dr[:, 2] ** 2
        m = Pr[:, 0] * Dr[:, 0] + Pr[:, 2] * Dr[:, 2]
        rho0 = Pr[:, 0] ** 2 + Pr[:, 2] ** 2
        g = np.nonzero(~flat)[0]
        if len(g):
            # r W^2 + 2 Dy m W + Dy^2 (rho0 - X^2) = 0 (k = W / Dy eliminated).
            Wg = W[g]
            poly = r[g, None] * sp.polymul(Wg, Wg)
            poly[:, 3:] += 2 * (Dy[g] * m[g])[:, None] * Wg
            poly -= (Dy[g] ** 2)[:, None] * sp.polymul(X[g], X[g])
            poly[:, 6] += Dy[g] ** 2 * rho0[g]
            # every root near the segment (_polish refines u and k together)
            ends = np.broadcast_to(np.array(LATHE_WINDOW), (len(g), 2))
            ug = roots.roots_in(poly[:, ::-1], ends[:, 0], ends[:, 1])
            ug = np.where(np.isfinite(ug), ug, np.nan)
            u[g] = ug
            k[g] = sp.polyval(Wg[:, None, :], np.nan_to_num(ug)) / Dy[g, None]
        h = np.nonzero(flat)[0]
        if len(h):
            # Height fixed: Y(u) = P_y, then the circle of radius X(u) along the ray.
            uh = sp.real_roots(W[h])  # (H, 3)
            xr = sp.polyval(X[h][:, None, :], np.nan_to_num(uh))
            a, b = r[h, None], m[h, None]
            disc = b * b - a * (rho0[h, None] - xr * xr)
            sq = np.sqrt(np.where(disc >= 0, disc, np.nan))
            with np.errstate(divide="ignore", invalid="ignore"):
                k[h] = np.concatenate([(-b - sq) / a, (-b + sq) / a], axis=1)
            u[h] = np.concatenate([uh, uh], axis=1)
        # Polish only the candidates near the segment (most columns are empty); the margin
        # keeps the roots an eigenvalue near a double root misplaces.
        lo, hi = LATHE_WINDOW
        pi, ci = np.nonzero(np.isfinite(u) & np.isfinite(k) & (u > lo) & (u < hi))
        uq, kq = self._polish(cf[pi], Pr[pi], Dr[pi], u[pi, ci], k[pi, ci])
        ok = sp.in_window(uq, self.curve.joined[si[pi]]) & np.isfinite(kq)
        t = np.where(ok, t0[ri[pi]] + kq / dl[ri[pi]], np.inf)
        face = (si[pi] % LATHE_MOD).astype(np.int8)
        return sp.pairs_to_rows(n, ri[pi], t[:, None], face[:, None])

    def _polish(self, cf, P, D, u, k):
        """Joint Newton on Y(u) - P_y - k D_y = 0 and |P_xz + k D_xz|^2 - X(u)^2 = 0; roots
        that do not settle on the surface are dropped."""
        X, Y = cf[:, 0], cf[:, 1]
        dX, dY = sp.polyder(cf[:, 0]), sp.polyder(cf[:, 1])
        Px, Py, Pz = P.T
        Dx, Dy, Dz = D.T
        scale = max(self.size, tol.ABS_FLOOR)
        for _ in range(tol.NEWTON_STEPS + 1):
            x, y = sp.polyval(X, u), sp.polyval(Y, u)
            xp, yp = sp.polyval(dX, u), sp.polyval(dY, u)
            qx, qz = Px + k * Dx, Pz + k * Dz
            f1 = y - Py - k * Dy
            f2 = qx * qx + qz * qz - x * x
            j11, j12 = yp, -Dy
            j21, j22 = -2 * x * xp, 2 * (qx * Dx + qz * Dz)
            det = j11 * j22 - j12 * j21
            with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
                du = (f1 * j22 - j12 * f2) / det
                dk = (j11 * f2 - j21 * f1) / det
            good = (
                np.isfinite(du)
                & np.isfinite(dk)
                & (np.abs(du) < tol.NEWTON_MAX_STEP_REL)
                & (np.abs(dk) < tol.NEWTON_MAX_STEP_REL * scale)
            )
            u = np.where(good, u - du, u)
            k = np.where(good, k - dk, k)
        x, y = sp.polyval(X, u), sp.polyval(Y, u)
        qx, qz = Px + k * Dx, Pz + k * Dz
        f1 = np.abs(y - Py - k * Dy)
        f2 = np.abs(np.sqrt(qx * qx + qz * qz) - np.abs(x))
        settled = (f1 <= tol.SWEEP_SIDE_REL * scale) & (f2 <= tol.SWEEP_SIDE_REL * scale)
        return np.where(settled, u, np.nan), k

    def _profile_point(self, p):
        return np.stack([np.hypot(p[:, 0], p[:, 2]), p[:, 1]], axis=1)

    def inside(self, p):
        # POV-Ray: an odd number of profile crossings to the right of (r, y).
        if self.degenerate:
            return np.zeros(len(p), dtype=bool)
        q = self._profile_point(p)
        res = (q[:, 1] >= self.ylo) & (q[:, 1] <= self.yhi)
        rows = np.nonzero(res)[0]
        res[rows] = self.curve.contains(q[rows])
        return res

    def outside(self, p):
        return ~self.inside(p)

    def normal(self, p, face):
        q = self._profile_point(p)
        seg, u = self.curve.locate(face.astype(np.int64) % LATHE_MOD, LATHE_MOD, q)
        tan = self.curve.tangent(seg, u)
        n2 = np.stack([tan[:, 1], -tan[:, 0]], axis=1)
        length = np.linalg.norm(n2, axis=1)
        n2 = n2 / np.where(length > 0, length, 1.0)[:, None]
        # Outward: just off the surface along n2 lies outside the solid.
        step = tol.SWEEP_SIDE_REL * max(self.size, tol.ABS_FLOOR)
        side = q + step * n2
        flip = self.curve.contains(np.stack([np.abs(side[:, 0]), side[:, 1]], axis=1))
        n2 = np.where(flip[:, None], -n2, n2)
        r = q[:, 0]
        on_axis = r <= tol.ABS_FLOOR
        rs = np.where(on_axis, 1.0, r)
        n = np.stack([n2[:, 0] * p[:, 0] / rs, n2[:, 1], n2[:, 0] * p[:, 2] / rs], axis=1)
        # On the axis the surface is a pole (or a flat end): its normal is along y.
        pole = np.zeros_like(n)
        pole[:, 1] = np.where(n2[:, 1] >= 0, 1.0, -1.0)
        return np.where(on_axis[:, None], pole, n)


class SorPrim:
    """x^2 + z^2 = f(y), f a cubic per segment between the heights of points i+1 and i+2
    with the slopes POV-Ray derives from points i and i+3; capped unless `open`.
    Faces: 0 base cap, 1 top cap, 2 the curved surface."""

    def __init__(self, shape: ir.Sor):
        P = np.asarray(shape.points, dtype=np.float64).reshape(-1, 2)
        coefs, heights = [], []
        for i in range(len(P) - 3):
            x0, x1, x2, x3 = P[i : i + 4, 0]
            y0, y1, y2, y3 = P[i : i + 4, 1]
            # r^2 and its slope at both ends (POV-Ray's Hermite conditions).
            s1 = 2 * x1 * (x2 - x0) / (y2 - y0)
            s2 = 2 * x2 * (x3 - x1) / (y3 - y1)
            m = np.array(
                [
                    [y1**3, y1**2, y1, 1.0],
                    [y2**3, y2**2, y2, 1.0],
                    [3 * y1**2, 2 * y1, 1.0, 0.0],
                    [3 * y2**2, 2 * y2, 1.0, 0.0],
                ]
            )
            c = np.linalg.solve(m, np.array([x1 * x1, x2 * x2, s1, s2]))
            c[np.abs(c) < tol.SPLINE_CLOSE_EPS] = 0.0  # as POV-Ray does
            coefs.append(c)
            heights.append((y1, y2))
        self.coef = np.array(coefs).reshape(-1, 4)
        self.y = np.array(heights).reshape(-1, 2)
        self.open = bool(shape.open)
        S = len(self.coef)
        self.degenerate = S == 0
        # Largest radius per segment: f at the ends and where f' = 0.
        ends = [self.y[:, 0], self.y[:, 1]]
        crit = sp.real_roots(sp.polyder(self.coef)) if S else np.zeros((0, 2))
        for j in range(crit.shape[1]):
            ends.append(np.clip(np.nan_to_num(crit[:, j], nan=0.0), self.y[:, 0], self.y[:, 1]))
        f = np.stack([sp.polyval(self.coef, e) for e in ends], axis=1) if S else np.zeros((0, 1))
        self.rmax = np.sqrt(np.maximum(f.max(axis=1), 0.0))
        self.rmin = np.sqrt(np.maximum(f.min(axis=1), 0.0))
        if self.degenerate:
            self.lo = self.hi = np.zeros(3)
            self.size = self.ylo = self.yhi = self.base_r2 = self.cap_r2 = 0.0
            return
        R = float(self.rmax.max())
        self.ylo, self.yhi = float(self.y[0, 0]), float(self.y[-1, 1])
        self.lo = np.array([-R, self.ylo, -R])
        self.hi = np.array([R, self.yhi, R])
        self.size = float(np.linalg.norm(self.hi - self.lo))
        self.base_r2 = max(float(sp.polyval(self.coef[0], self.ylo)), 0.0)
        self.cap_r2 = max(float(sp.polyval(self.coef[-1], self.yhi)), 0.0)

    def bounds(self):
        return self.lo, self.hi

    def crossings(self, o, d):
        n = len(o)
        if self.degenerate or n == 0:
            return np.full((n, 1), np.inf), np.zeros((n, 1), dtype=np.int8)
        P, D, t0, dl = _unit_recentred(o, d, 0.5 * (self.lo + self.hi))
        pair = _cylinder_pairs(P, D, self.y[:, 0], self.y[:, 1], self.rmin, self.rmax)
        ri, si = np.nonzero(pair)
        ts, fs = [], []
        if len(ri):
            A, B, C, Dc = (self.coef[si, j] for j in range(4))
            Pr, Dr = P[ri], D[ri]
            py, dy = Pr[:, 1], Dr[:, 1]
            r = Dr[:, 0] ** 2 + Dr[:, 2] ** 2
            m = Pr[:, 0] * Dr[:, 0] + Pr[:, 2] * Dr[:, 2]
            rho0 = Pr[:, 0] ** 2 + Pr[:, 2] ** 2
            # f(P_y + k D_y) - |P_xz + k D_xz|^2 as a cubic in k = s kappa, s the shape's
            # size (the roots that matter then lie within about 1 of 0).
            s = max(self.size, tol.ABS_FLOOR)
            # (products, not powers: the kernel's lathe.h repeats them)
            poly = np.stack(
                [
                    A * (dy * dy * dy) * (s * s * s),
                    (dy * dy * (3 * A * py + B) - r) * (s * s),
                    (dy * (py * (3 * A * py + 2 * B) + C) - 2 * m) * s,
                    py * (py * (A * py + B) + C) + Dc - rho0,
                ],
                axis=1,
            )
            k = sp.real_roots(poly) * s
            hgt = py[:, None] + k * dy[:, None]
            y1, y2 = self.y[si, 0, None], self.y[si, 1, None]
            last = (si == len(self.coef) - 1)[:, None]
            ok = (hgt >= y1) & ((hgt < y2) | (last & (hgt <= y2))) & np.isfinite(k)
            t = np.where(ok, t0[ri, None] + k / dl[ri, None], np.inf)
            tt, ff = sp.pairs_to_rows(n, ri, t, np.full(t.shape, 2, dtype=np.int8))
            ts.append(tt)
            fs.append(ff)
        if not self.open:
            for face, h, r2 in ((0, self.ylo, self.base_r2), (1, self.yhi, self.cap_r2)):
                t = np.full(n, np.inf)
                # POV-Ray skips caps narrower than its depth tolerance (1e-4 squared radius).
                if r2 > tol.SOR_CAP_MIN_R2:
                    ok = np.abs(D[:, 1]) > tol.PARALLEL_EPS
                    with np.errstate(divide="ignore", invalid="ignore"):
                        k = np.where(ok, (h - P[:, 1]) / D[:, 1], 0.0)
                    x = P[:, 0] + k * D[:, 0]
                    z = P[:, 2] + k * D[:, 2]
                    hit = ok & (x * x + z * z <= r2)
                    t = np.where(hit, t0 + k / dl, np.inf)
                ts.append(t[:, None])
                fs.append(np.full((n, 1), face, dtype=np.int8))
        if not ts:
            return np.full((n, 1), np.inf), np.zeros((n, 1), dtype=np.int8)
        return sp.compact(np.concatenate(ts, axis=1), np.concatenate(fs, axis=1))

    def segment_of(self, y):
        return np.clip(np.searchsorted(self.y[:, 1], y, side="left"), 0, len(self.coef) - 1)

    def inside(self, p):
        if self.degenerate:
            return np.zeros(len(p), dtype=bool)
        y = p[:, 1]
        rho2 = p[:, 0] * p[:, 0] + p[:, 2] * p[:, 2]
        f = sp.polyval(self.coef[self.segment_of(y)], y)
        return (y >= self.ylo) & (y <= self.yhi) & (rho2 <= f)

    def outside(self, p):
        return ~self.inside(p)

    def normal(self, p, face):
        f = face.astype(np.int64)
        y = p[:, 1]
        c = self.coef[self.segment_of(y)]
        slope = sp.polyval(sp.polyder(c), y)
        n = np.stack([p[:, 0], -0.5 * slope, p[:, 2]], axis=1)
        n[f == 0] = (0.0, -1.0, 0.0)
        n[f == 1] = (0.0, 1.0, 0.0)
        return n
