"""POV-Ray's julia_fractal: the points of a 3-D slice of 4-D space whose orbit under
z -> f(z) + c stays within the escape radius for `max_iteration` steps.

A point (x, y, z) is the 4-D point (x, y, z, w) on the slice hyperplane s . (x, y, z, w) = D.
Two algebras: quaternions (Hamilton's product; f = z² or z³) and hypercomplex numbers
(commutative, isomorphic to pairs of complex numbers through the duplex form
(x - w + i(y + z), x + w + i(y - z)); f = z², 1/z or a complex function of both halves).

Rays are traced as POV-Ray traces them (its fractal.cpp, quatern.cpp, hcmplx.cpp), so the
same thin filaments are found or missed:
- clip the ray to the bounding sphere about the origin and start at its entry (or just past
  the ray's origin), stepping 2·1e-7 on if that point is inside;
- march with steps of at least 1/precision: the distance estimate |z|/|z'| log|z| of the
  escaping orbit for quaternions, for hypercomplex numbers |z|² over twice the slope of the
  orbit's normal along the ray when that lies within 1 to 30 steps, else the minimum step;
- a change of inside/outside between two samples is bisected to 1e-7 with the plain
  iteration (POV-Ray's hypercomplex function iteration starts from z = y there: kept);
- the hit is the last inside point, its normal the derivative of the orbit there.
A lone fractal reports its first crossing only, and POV-Ray drops a crossing closer to the
ray's origin than its MIN_ISECT_DEPTH: a shadow ray leaving the surface it starts inside
therefore sees nothing of the fractal beyond (POV-Ray's fractals do not shadow themselves
there). In CSG or under clipped_by (`first_only` off, set by runtime.prepare) every crossing
counts, as POV-Ray's child objects report them.
"""

from __future__ import annotations

import threading
import weakref
from collections.abc import Callable

import numpy as np

from lang import ir
from lang.extents import JULIA_TOLERANCE, julia_radius
from runtime import tolerances as tol

INF = np.inf
Pair = tuple[np.ndarray, np.ndarray]  # a complex number's real and imaginary parts

# POV-Ray's EPSILON, below which its sphere test counts a ray as missing the bound.
SPHERE_EPS = 1e-10


# ------------------------------------------------------------------ complex functions
# POV-Ray's complex functions, on (re, im) pairs of arrays, formula for formula (their
# branch cuts and special cases are its, which numpy's complex functions do not all share).
def _mul(a: Pair, b: Pair) -> Pair:
    return a[0] * b[0] - a[1] * b[1], a[0] * b[1] + a[1] * b[0]


def _div(a: Pair, b: Pair) -> Pair:
    mod = b[0] * b[0] + b[1] * b[1]
    good = mod != 0
    mod = np.where(good, mod, 1.0)
    bx, by = b[0] / mod, -b[1] / mod
    nan = np.full_like(mod, np.nan)
    return np.where(good, a[0] * bx - a[1] * by, nan), np.where(good, a[0] * by + a[1] * bx, nan)


def _ln(a: Pair) -> Pair:
    return np.log(np.sqrt(a[0] * a[0] + a[1] * a[1])), np.arctan2(a[1], a[0])


def _sqrt(a: Pair) -> Pair:
    mag = np.sqrt(np.sqrt(a[0] * a[0] + a[1] * a[1]))
    theta = np.arctan2(a[1], a[0]) / 2
    zero = (a[0] == 0) & (a[1] == 0)
    return np.where(zero, 0.0, mag * np.cos(theta)), np.where(zero, 0.0, mag * np.sin(theta))


def _exp(a: Pair, e: Pair) -> Pair:
    ex = np.exp(a[0])
    return ex * np.cos(a[1]), ex * np.sin(a[1])


def _log(a: Pair, e: Pair) -> Pair:
    return _ln(a)


def _sin(a: Pair, e: Pair) -> Pair:
    return np.sin(a[0]) * np.cosh(a[1]), np.cos(a[0]) * np.sinh(a[1])


def _sinh(a: Pair, e: Pair) -> Pair:
    return np.sinh(a[0]) * np.cos(a[1]), np.cosh(a[0]) * np.sin(a[1])


def _cos(a: Pair, e: Pair) -> Pair:
    return np.cos(a[0]) * np.cosh(a[1]), -np.sin(a[0]) * np.sinh(a[1])


def _cosh(a: Pair, e: Pair) -> Pair:
    return np.cosh(a[0]) * np.cos(a[1]), np.sinh(a[0]) * np.sin(a[1])


def _tan(a: Pair, e: Pair) -> Pair:
    x, y = 2 * a[0], 2 * a[1]
    den = np.cos(x) + np.cosh(y)
    return np.sin(x) / den, np.sinh(y) / den


def _tanh(a: Pair, e: Pair) -> Pair:
    x, y = 2 * a[0], 2 * a[1]
    den = np.cosh(x) + np.cos(y)
    return np.sinh(x) / den, np.sin(y) / den


def _asin(a: Pair, e: Pair) -> Pair:
    # -i ln(i z + sqrt(1 - z²))
    sx, sy = _mul(a, a)
    rx, ry = _sqrt((1 - sx, -sy))
    lx, ly = _ln((rx - a[1], ry + a[0]))
    return ly, -lx


def _acos(a: Pair, e: Pair) -> Pair:
    # -i ln(z + sqrt(z² - 1))
    sx, sy = _mul(a, a)
    rx, ry = _sqrt((sx - 1, sy))
    lx, ly = _ln((rx + a[0], ry + a[1]))
    return ly, -lx


def _asinh(a: Pair, e: Pair) -> Pair:
    sx, sy = _mul(a, a)
    rx, ry = _sqrt((sx + 1, sy))
    return _ln((rx + a[0], ry + a[1]))


def _acosh(a: Pair, e: Pair) -> Pair:
    sx, sy = _mul(a, a)
    rx, ry = _sqrt((sx - 1, sy))
    return _ln((a[0] + rx, a[1] + ry))


def _atanh(a: Pair, e: Pair) -> Pair:
    # 1/2 ln((1 + z) / (1 - z)), with POV-Ray's shortcuts on the axes
    x, y = a
    gx, gy = _ln(_div((1 + x, y), (1 - x, -y)))
    ox, oy = 0.5 * gx, 0.5 * gy
    on_real = y == 0
    with np.errstate(divide="ignore", invalid="ignore"):
        real = np.log((1 + x) / (1 - x)) / 2
    ox = np.where(on_real & (np.abs(x) < 1), real, ox)
    oy = np.where(on_real & (np.abs(x) < 1), 0.0, oy)
    # |x| = 1 on the real axis: POV-Ray leaves its result unset
    ox = np.where(on_real & (np.abs(x) == 1), np.nan, ox)
    oy = np.where(on_real & (np.abs(x) == 1), np.nan, oy)
    ox = np.where(x == 0, 0.0, ox)
    oy = np.where(x == 0, np.arctan(y), oy)
    return ox, oy


def _atan(a: Pair, e: Pair) -> Pair:
    # i/2 ln((1 - iz) / (1 + iz)), with POV-Ray's shortcuts on the axes
    x, y = a
    tx, ty = -y, x
    qx, qy = _ln(_div((1 - tx, -ty), (1 + tx, ty)))
    ox, oy = -0.5 * qy, 0.5 * qx
    hx, hy = _atanh((y, np.zeros_like(y)), e)
    imag_axis = (x == 0) & (y != 0)
    ox = np.where(imag_axis, -hy, ox)
    oy = np.where(imag_axis, hx, oy)
    real_axis = (x != 0) & (y == 0)
    ox = np.where(real_axis, np.arctan(x), ox)
    oy = np.where(real_axis, 0.0, oy)
    zero = (x == 0) & (y == 0)
    return np.where(zero, 0.0, ox), np.where(zero, 0.0, oy)


def _pwr(a: Pair, e: Pair) -> Pair:
    lx, ly = _ln(a)
    tx, ty = _mul((lx, ly), e)
    e2x = np.where(tx < -690, 0.0, np.exp(np.minimum(tx, 709.0)))
    zero = (a[0] == 0) & (a[1] == 0)
    return np.where(zero, 0.0, e2x * np.cos(ty)), np.where(zero, 0.0, e2x * np.sin(ty))


COMPLEX: dict[str, Callable[[Pair, Pair], Pair]] = {
    "exp": _exp, "ln": _log, "sin": _sin, "asin": _asin, "cos": _cos, "acos": _acos,
    "tan": _tan, "atan": _atan, "sinh": _sinh, "asinh": _asinh, "cosh": _cosh,
    "acosh": _acosh, "tanh": _tanh, "atanh": _atanh, "pwr": _pwr,
}  # fmt: skip


# ------------------------------------------------------------------ the algebras
# Both algebras hold a number as a (4, M) array of x, y, z, w, and follow POV-Ray's formulas
# in its order of operations: the orbits are chaotic, and rounding otherwise would move
# specks of a noisy set. A hypercomplex number's duplex form (x - w + i(y + z),
# x + w + i(y - z)) is where its functions act: on each half as on a complex number.
def hmul(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """The hypercomplex product (commutative)."""
    x1, y1, z1, w1 = a
    x2, y2, z2, w2 = b
    return np.stack(
        [
            x1 * x2 - y1 * y2 - z1 * z2 + w1 * w2,
            y1 * x2 + x1 * y2 - w1 * z2 - z1 * w2,
            z1 * x2 - w1 * y2 + x1 * z2 - y1 * w2,
            w1 * x2 + z1 * y2 + y1 * z2 + x1 * w2,
        ]
    )


def hsqr(q: np.ndarray) -> np.ndarray:
    x, y, z, w = q
    return np.stack(
        [x * x - y * y - z * z + w * w, 2.0 * (x * y - z * w), 2.0 * (z * x - w * y),
         2.0 * (w * x + z * y)]
    )  # fmt: skip


def hreciprocal(q: np.ndarray) -> np.ndarray:
    x, y, z, w = q
    det = ((x - w) * (x - w) + (y + z) * (y + z)) * ((x + w) * (x + w) + (y - z) * (y - z))
    mod = x * x + y * y + z * z + w * w
    xt_yz = x * w - y * z
    return np.stack(
        [x * mod - 2 * w * xt_yz, -y * mod - 2 * z * xt_yz, -z * mod - 2 * y * xt_yz,
         w * mod - 2 * x * xt_yz]
    ) / det  # fmt: skip


def hfunc(q: np.ndarray, f: Callable[[Pair, Pair], Pair], e: Pair) -> np.ndarray:
    """A complex function applied to both halves of the duplex form, and back."""
    x, y, z, w = q
    ax, ay = f((x - w, y + z), e)
    bx, by = f((x + w, y - z), e)
    return np.stack([0.5 * (ax + bx), 0.5 * (ay + by), 0.5 * (ay - by), 0.5 * (bx - ax)])


class JuliaPrim:
    def __init__(self, shape: ir.JuliaFractal):
        self.shape = shape
        self.quaternion = shape.algebra == "quaternion"
        self.function = shape.function
        self.radius = julia_radius(shape)
        self.r2 = self.radius**2
        # POV-Ray's escape bound: just past the bounding radius for quaternions
        self.exit = self.r2 + JULIA_TOLERANCE if self.quaternion else 16.0
        self.c = np.array(shape.parameter, dtype=np.float64)[:, None]
        self.n = int(shape.max_iteration)
        self.step = 1.0 / float(shape.precision)
        self.slice = tuple(float(v) for v in shape.slice)
        self.slice_d = float(shape.slice_distance)
        self.size = 2.0 * self.radius
        self.first_only = True
        self.complex = COMPLEX.get(self.function)
        self.e: Pair = (np.asarray(shape.exponent[0], float), np.asarray(shape.exponent[1], float))
        # the quaternion distance estimate's factor per iteration: 1/2 for z², 1/3 for z³
        self.base = 0.5 if self.function == "sqr" else 1.0 / 3.0

    def bounds(self):
        return np.full(3, -self.radius), np.full(3, self.radius)

    # ------------------------------------------------------------------ the orbit
    def _start(self, p: np.ndarray, plain: bool) -> np.ndarray:
        q = np.empty((4, len(p)))
        q[:3] = p.T
        if plain and self.complex is not None:
            q[2] = q[1]  # POV-Ray's Iteration_HCompl_Func reads y for z (w follows it)
        if self.slice == (0.0, 0.0, 0.0, 1.0) and self.slice_d == 0.0:
            q[3] = 0.0
        else:
            sx, sy, sz, st = self.slice
            q[3] = (self.slice_d - sx * q[0] - sy * q[1] - sz * q[2]) / st
        return q

    def _step(self, s: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(|z|², f(z) + c): the norm POV-Ray tests against the escape bound, and the next
        point of the orbit."""
        x = s[0]
        if self.quaternion:
            y, z, w = s[1], s[2], s[3]
            d = y * y
            d += z * z
            d += w * w
            x2 = x * x
            out = np.empty_like(s)
            if self.function == "cube":
                np.multiply(s[1:], 3.0 * x2 - d, out=out[1:])
                np.multiply(x, x2 - 3.0 * d, out=out[0])
            else:
                np.multiply(s[1:], 2.0 * x, out=out[1:])
                np.subtract(x2, d, out=out[0])
            out += self.c
            d += x2
            return d, out
        f = np.einsum("ij,ij->j", s, s)
        if self.complex is not None:
            out = hfunc(s, self.complex, self.e)
        elif self.function == "reciprocal":
            out = hreciprocal(s)
        elif self.function == "cube":
            out = hsqr(s)  # POV-Ray 3.7's hypercomplex cube iterates z²
        else:
            y, z, w = s[1], s[2], s[3]
            out = np.empty_like(s)
            out[0] = (x * x + w * w) - (y * y + z * z)
            out[1] = 2.0 * (x * y - z * w)
            out[2] = 2.0 * (x * z - w * y)
            out[3] = 2.0 * (x * w + y * z)
        out += self.c
        return f, out

    def orbit(self, p: np.ndarray, plain: bool = True) -> tuple[np.ndarray, list[np.ndarray]]:
        """(written, orbit) of POV-Ray's Iteration (D_Iteration unless `plain`) for points
        (M,3): z_0 … z_n, a point standing still once it has escaped, and how many of them
        POV-Ray writes to its orbit stack (n + 1: the point is inside)."""
        s = self._start(p, plain)
        live = np.ones(len(p), dtype=bool)
        written = np.ones(len(p), dtype=np.int64)
        out = [s]
        with np.errstate(all="ignore"):
            for _ in range(self.n):
                f, ns = self._step(s)
                live &= ~(f > self.exit)
                written += live
                s = np.where(live, ns, s)
                out.append(s)
        return written, out

    def escapes(self, p: np.ndarray) -> np.ndarray:
        """True where the orbit of p (POV-Ray's Iteration) escapes: p is outside the set."""
        s = self._start(p, plain=True)
        idx = np.arange(len(p))
        out = np.zeros(len(p), dtype=bool)
        with np.errstate(all="ignore"):
            for _ in range(self.n):
                f, s = self._step(s)
                esc = f > self.exit
                if esc.any():
                    out[idx[esc]] = True
                    keep = ~esc
                    idx, s = idx[keep], s[:, keep]
                    if not len(idx):
                        break
        return out

    def estimate(self, p: np.ndarray, u: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(inside, step): POV-Ray's D_Iteration at points p (M,3) along unit directions u:
        the orbit, and where it escapes a lower bound of the distance to the set."""
        m = len(p)
        s = self._start(p, plain=False)
        inside = np.ones(m, dtype=bool)
        dist = np.full(m, self.step)
        idx = np.arange(m)
        # quaternions: |z_0 z_1 … z_(i-1)|², the product of the norms (POV-Ray's product is
        # a quaternion product, whose norm is the product of the norms); hypercomplex: the
        # running product of the normal, z_0 times each later point's factor but the last,
        # whose escapes are gathered to find their steps at once
        run = np.ones(m) if self.quaternion else s
        hyper: list[tuple[np.ndarray, ...]] = []
        with np.errstate(all="ignore"):
            for i in range(1, self.n + 1):
                f, ns = self._step(s)
                if self.quaternion:
                    run = run * f
                esc = f > self.exit
                if esc.any():
                    r = idx[esc]
                    fe = f[esc]
                    if self.quaternion:
                        dist[r] = self.base**i * np.sqrt(fe / run[esc]) * np.log(fe)
                    else:
                        hyper.append((r, run[:, esc], s[:, esc], fe, np.full(len(r), i - 1)))
                    inside[r] = False
                    keep = ~esc
                    idx = idx[keep]
                    if not len(idx):
                        break
                    ns, run = ns[:, keep], run[..., keep]
                    if not self.quaternion:
                        s = s[:, keep]
                if not self.quaternion and i >= 2:
                    run = hmul(run, self._factor(s, ns))
                s = ns
            if hyper:
                r, rn, last, fe, n_max = (
                    np.concatenate(c, axis=-1) for c in zip(*hyper, strict=True)
                )
                dist[r] = self._slope_step(rn, last, n_max, fe, u[r])
        return inside, dist

    def _factor(self, z: np.ndarray, z_next: np.ndarray) -> np.ndarray:
        """The factor an orbit point z contributes to POV-Ray's hypercomplex normal (z_next
        is f(z) + c): z itself for z² (the 2 of 2z is a scale), -(1/z)² for 1/z, and for a
        function f(z) itself (as POV-Ray has it, not f'(z))."""
        if self.complex is not None:
            return z_next - self.c
        if self.function == "reciprocal":
            return -hsqr(z_next - self.c)
        return z

    def _hyper_normal(self, run: np.ndarray, last: np.ndarray, n_max) -> np.ndarray:
        """POV-Ray's hypercomplex normal (M,3) from the running product and z_(n_max)
        (`n_max` an int or one per point)."""
        scale = 2.0 ** np.maximum(n_max, 1) if self.function == "sqr" else 1.0
        x, y, z, w = run
        n1, n2, n3, n4 = last * scale
        return np.stack(
            [
                x * n1 + y * n2 + z * n3 + w * n4,
                -y * n1 + x * n2 - w * n3 + z * n4,
                -z * n1 - w * n2 + x * n3 + y * n4,
            ],
            axis=1,
        )

    def _slope_step(self, run, last, n_max, f, u) -> np.ndarray:
        """The hypercomplex step: |z|² over twice the normal's slope against the ray, where
        that lies within 1 to 30 minimum steps; else the minimum step."""
        slope = np.einsum("ij,ij->i", self._hyper_normal(run, last, n_max), u)
        s = -2.0 * slope
        window = (slope < -tol.JULIA_SLOPE_TOLERANCE) & (f > self.step * s)
        window &= f < 30 * self.step * s
        return np.where(window, f / np.where(window, s, 1.0), self.step)

    # ------------------------------------------------------------------ protocol
    def crossings(self, o, d):
        n = len(o)
        length = np.sqrt(np.einsum("ij,ij->i", d, d))
        good = length > 0
        u = d / np.where(good, length, 1.0)[:, None]
        oc2 = np.einsum("ij,ij->i", o, o)
        tca = -np.einsum("ij,ij->i", o, u)
        half2 = self.r2 - oc2 + tca * tca
        hit = good & ~((oc2 >= self.r2) & (tca < SPHERE_EPS)) & (half2 > SPHERE_EPS)
        half = np.sqrt(np.where(hit, half2, 0.0))
        near, far = tca - half, tca + half
        hit &= far >= JULIA_TOLERANCE
        rows = np.nonzero(hit)[0]
        t = np.full((n, 1), INF)
        if not len(rows):
            return t, np.zeros((n, 1), dtype=np.int8)
        start = np.maximum(near[rows], JULIA_TOLERANCE)
        cut = tol.MIN_ISECT_DEPTH * length[rows]
        ray, depth, normals = self._march(o[rows], u[rows], start, far[rows], cut)
        dist = depth / length[rows][ray]
        # POV-Ray drops a crossing this close to the ray's origin (and a lone fractal has
        # reported only that one)
        keep = dist >= tol.MIN_ISECT_DEPTH
        if normals is not None:
            _cache_normals(self, normals[0][keep], normals[1][keep])
        ray, dist = rows[ray[keep]], dist[keep]
        if not len(ray):
            return t, np.zeros((n, 1), dtype=np.int8)
        order = np.lexsort((dist, ray))
        ray, dist = ray[order], dist[order]
        counts = np.bincount(ray, minlength=n)
        first = np.concatenate([[0], np.cumsum(counts)[:-1]])
        col = np.arange(len(ray)) - first[ray]
        t = np.full((n, max(1, int(counts.max()))), INF)
        t[ray, col] = dist
        return t, np.zeros(t.shape, dtype=np.int8)

    def _march(self, o, u, depth, dmax, cut):
        """(ray, depth, normals) of every crossing found along the unit rays (object
        distances); normals (points, normals) only where the orbit stack's history sets
        them (see _bisect_stack), else None."""
        cur, dist = self.estimate(o + depth[:, None] * u, u)
        # a ray that starts inside steps just past its start first
        depth = np.where(cur, depth + 2.0 * JULIA_TOLERANCE, depth)
        again = np.nonzero(cur & (depth <= dmax))[0]
        if len(again):
            cur[again], dist[again] = self.estimate(
                o[again] + depth[again, None] * u[again], u[again]
            )
        ray = np.nonzero(depth <= dmax)[0]
        o, u, depth, dmax, dist, cur = o[ray], u[ray], depth[ray], dmax[ray], dist[ray], cur[ray]
        found: list[tuple[np.ndarray, ...]] = []
        while len(ray):
            step = np.maximum(dist, self.step)
            nd = depth + step
            go = nd <= dmax
            if not go.all():
                ray, o, u, dmax, depth, step, nd, cur = (
                    a[go] for a in (ray, o, u, dmax, depth, step, nd, cur)
                )
                if not len(ray):
                    break
            nxt, dist = self.estimate(o + nd[:, None] * u, u)
            crossed = nxt != cur
            if crossed.any():
                found.append(tuple(a[crossed] for a in (ray, o, u, depth, step, cur)))
                if self.first_only:
                    stay = ~crossed
                    ray, o, u, dmax, nd, nxt, dist = (
                        a[stay] for a in (ray, o, u, dmax, nd, nxt, dist)
                    )
            depth, cur = nd, nxt
        if not found:
            return np.zeros(0, dtype=np.int64), np.zeros(0), None
        ray, o, u, depth, step, cur = (np.concatenate(c) for c in zip(*found, strict=True))
        if self.complex is None:
            return ray, self._bisect(o, u, depth, step, cur, cut[ray]), None
        hit, nrm = self._bisect_stack(o, u, depth, step, cur, cut[ray])
        return ray, hit, (o + hit[:, None] * u, nrm)

    def _bisect(self, o, u, a, s, inside, cut) -> np.ndarray:
        """POV-Ray's polish of each bracket [a, a + s] to JULIA_TOLERANCE with the plain
        iteration; the crossing is the inside end. A bracket that shrinks below `cut` (the
        crossing will be dropped: a ray leaving the surface) stops there, at 0."""
        s = s.copy()
        a = a.copy()
        wide = np.nonzero(s > JULIA_TOLERANCE)[0]
        while len(wide):
            s[wide] *= 0.5
            mid = a[wide] + s[wide]
            same = ~self.escapes(o[wide] + mid[:, None] * u[wide]) == inside[wide]
            a[wide[same]] = mid[same]
            near = a[wide] + s[wide] < cut[wide]
            a[wide[near]] = s[wide[near]] = 0.0
            wide = wide[(s[wide] > JULIA_TOLERANCE) & ~near]
        return np.where(inside, a, a + s)

    def _bisect_stack(self, o, u, a, s, inside, cut) -> tuple[np.ndarray, np.ndarray]:
        """_bisect, and the normal POV-Ray computes there, for the function iterations,
        whose plain iteration (starting from z = y) is not the one the march used: the
        bracket's inside end may escape it, and then POV-Ray's normal reads the orbit stack
        beyond the escape where earlier iterations left their points. The stack is followed
        through the march's last two points and every bisection step."""
        n1 = self.n + 1
        stack = self.orbit(o + a[:, None] * u, plain=False)[1]
        self._write(stack, *self.orbit(o + (a + s)[:, None] * u, plain=False))
        s = s.copy()
        a = a.copy()
        last = inside.copy()
        wide = np.nonzero(s > JULIA_TOLERANCE)[0]
        while len(wide):
            s[wide] *= 0.5
            mid = a[wide] + s[wide]
            written, orb = self.orbit(o[wide] + mid[:, None] * u[wide])
            self._write(stack, written, orb, wide)
            last[wide] = written == n1
            same = last[wide] == inside[wide]
            a[wide[same]] = mid[same]
            near = a[wide] + s[wide] < cut[wide]
            a[wide[near]] = s[wide[near]] = 0.0
            wide = wide[(s[wide] > JULIA_TOLERANCE) & ~near]
        hit = np.where(inside, a, a + s)
        redo = np.nonzero(~inside | (last != inside))[0]
        if len(redo):
            self._write(stack, *self.orbit(o[redo] + hit[redo, None] * u[redo]), redo)
        return hit, self._orbit_normal(stack, o + hit[:, None] * u)

    @staticmethod
    def _write(stack: list[np.ndarray], written, orb: list[np.ndarray], rows=None) -> None:
        """An iteration's writes to the orbit stacks of `rows` (all): its first points."""
        for k, q in enumerate(orb):
            w = written > k
            if rows is None:
                stack[k] = np.where(w, q, stack[k])
            else:
                stack[k][:, rows] = np.where(w, q, stack[k][:, rows])

    def normal(self, p, face):
        if self.complex is not None:
            found = _cached_normals(self, p)
            if found is not None:
                return found
        return self._orbit_normal(self.orbit(p)[1], p)

    def _orbit_normal(self, orb: list[np.ndarray], p: np.ndarray) -> np.ndarray:
        """POV-Ray's normal (M,3) from an orbit stack z_0 … z_n."""
        with np.errstate(all="ignore"):
            if self.quaternion:
                rows = np.zeros((3, 4, len(p)))
                rows[0, 0] = rows[1, 1] = rows[2, 2] = 1.0
                for q in orb[: self.n]:
                    rows = self._derive(rows, q)
                nrm = np.einsum("rkm,km->mr", rows, orb[self.n])
            else:
                run = orb[0]
                for k in range(1, self.n):
                    # each point's own factor: a stack may hold points of several orbits
                    run = hmul(self._factor(orb[k], self._step(orb[k])[1]), run)
                nrm = self._hyper_normal(run, orb[self.n], self.n)
        bad = ~np.isfinite(nrm).all(axis=1) | ~(np.abs(nrm).sum(axis=1) > 0)
        if bad.any():
            nrm[bad] = p[bad]  # a degenerate orbit: the radial direction
        return nrm

    def _derive(self, n: np.ndarray, q: np.ndarray) -> np.ndarray:
        """One step of POV-Ray's quaternion normal for the three rows n (3, 4, M) of the
        orbit's Jacobian at orbit point q (4, M)."""
        x, y, z, w = q
        n1, n2, n3, n4 = n[:, 0], n[:, 1], n[:, 2], n[:, 3]
        out = np.empty_like(n)
        if self.function == "cube":
            x2 = x * x
            t = y * y + z * z + w * w
            x3, x4 = x2 - t, 3.0 * x2 - t
            d1 = 2.0 * (n2 * y + n3 * z + n4 * w)
            d2 = 6.0 * x * n1 - d1
            out[:, 0] = (n1 * x3 - x * d1) * 3.0
            out[:, 1:] = n[:, 1:] * x4 + q[1:] * d2[:, None]
        else:
            out[:, 0] = n1 * x - n2 * y - n3 * z - n4 * w
            out[:, 1:] = n1[:, None] * q[1:] + x * n[:, 1:]
        return out

    def inside(self, p):
        return ~self.escapes(p)

    def outside(self, p):
        return self.escapes(p)


# The normals crossings() found for the function iterations (see _bisect_stack), per thread
# (tiles trace in parallel): the tracer asks for a hit's normal after the crossings, by
# point, and the normal is a function of the ray's history, not of the point alone.
_NORMALS = threading.local()


def _cache_normals(prim: JuliaPrim, points: np.ndarray, normals: np.ndarray) -> None:
    order = np.argsort(points[:, 0], kind="stable")
    cache = getattr(_NORMALS, "by_prim", None)
    if cache is None:  # weak: a finished render's primitives go
        cache = _NORMALS.by_prim = weakref.WeakKeyDictionary()
    cache[prim] = (points[order], normals[order])


def _cached_normals(prim: JuliaPrim, p: np.ndarray) -> np.ndarray | None:
    """The cached normals of points p, or None unless every one of them is cached (a hit
    point comes back through the object's transform, off by rounding only)."""
    cache = getattr(_NORMALS, "by_prim", None)
    entry = None if cache is None else cache.get(prim)
    if entry is None or not len(entry[0]):
        return None
    pts, nrm = entry
    near = tol.NORMAL_CACHE_REL * (1.0 + np.abs(p).max(axis=1))
    pos = np.searchsorted(pts[:, 0], p[:, 0] - near)
    best = np.full(len(p), -1)
    best_d = np.full(len(p), np.inf)
    for k in range(4):  # the neighbours in x: a hit sits alone at this scale
        idx = np.minimum(pos + k, len(pts) - 1)
        dd = np.abs(pts[idx] - p).max(axis=1)
        better = (dd < near) & (dd < best_d)
        best = np.where(better, idx, best)
        best_d = np.where(better, dd, best_d)
    if (best < 0).any():
        return None
    return nrm[best]
