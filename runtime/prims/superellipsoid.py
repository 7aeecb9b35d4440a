"""POV-Ray's superellipsoid: f(x, y, z) = (|x|^(2/e) + |y|^(2/e))^(e/n) + |z|^(2/n) - 1,
inside where f < 0, within the box [-1, 1]^3 (f > 0 everywhere outside it).

There is no closed form along a ray, so the ray is clipped to the box and f is searched:

- e, n <= 2: f is convex (a power >= 1 of a p-norm plus a convex power), so along a line it
  has one minimum. Bisection on the sign of f' finds it; the ray hits exactly when f is
  negative there, and each side of it holds one crossing. Nothing is missed, however thin
  the sliver a grazing ray cuts off a nearly square shape.
- otherwise (the pinched, star-like shapes): the chord is cut where the ray crosses the
  planes x=0, y=0, z=0, x=±y, x=±z, y=±z (where f has cusps and creases, as POV-Ray cuts it)
  and into `SUPERELLIPSOID_CELLS` equal cells; an extremum inside a cell (f' changes sign
  between just inside its ends) is found as above and splits it (a minimum may dip inside,
  a maximum rise outside between two inside stretches). f at a cut point on x=0, y=0 or z=0
  is taken on the plane itself: there f has the membranes of the pinched shapes, thinner
  than rounding for large e or n, which a point computed in floats would meet by chance.

Crossings are then the sign changes between the sorted points, refined by Newton/bisection
(`roots.bracketed`) to float64 precision. f is evaluated in POV-Ray's stable form
g^(2/n) + |z|^(2/n) - 1 with g = max(|x|,|y|) (1 + (min/max)^(2/e))^(e/2), which neither
underflows nor overflows for tiny e, n.
"""

from __future__ import annotations

import numpy as np

from lang import ir
from runtime import tolerances as tol
from runtime.prims import roots
from runtime.shapes import dot, recentre

INF = np.inf

# The planes through the axes that POV-Ray also cuts along: (a, b, c) . p = 0.
_PLANES = np.array(
    [
        [1, 0, 0],
        [0, 1, 0],
        [0, 0, 1],
        [1, 1, 0],
        [1, -1, 0],
        [1, 0, 1],
        [1, 0, -1],
        [0, 1, 1],
        [0, 1, -1],
    ],
    dtype=np.float64,
)
# the axis each plane zeroes (-1: a diagonal plane, on which f has no cusp)
_PLANE_AXIS = np.array([0, 1, 2, -1, -1, -1, -1, -1, -1])


class SuperellipsoidPrim:
    def __init__(self, shape: ir.Superellipsoid):
        self.e = float(shape.e)
        self.n = float(shape.n)
        self.p = 2.0 / self.e  # the exponent of the x-y norm
        self.q = 2.0 / self.n  # the exponent applied to that norm and to |z|
        self.convex = self.p >= 1.0 and self.q >= 1.0
        self.size = 2.0 * np.sqrt(3.0)

    def bounds(self):
        return np.full(3, -1.0), np.full(3, 1.0)

    # ----------------------------------------------------------------- the field
    def _g(self, ax: np.ndarray, ay: np.ndarray) -> np.ndarray:
        big = np.maximum(ax, ay)
        small = np.minimum(ax, ay)
        with np.errstate(divide="ignore", invalid="ignore", under="ignore"):
            ratio = np.where(big > 0, small / np.where(big > 0, big, 1.0), 0.0)
            return big * (1.0 + ratio**self.p) ** (1.0 / self.p)

    def value(self, p: np.ndarray) -> np.ndarray:
        ax, ay, az = np.abs(p[..., 0]), np.abs(p[..., 1]), np.abs(p[..., 2])
        with np.errstate(under="ignore", over="ignore"):
            return self._g(ax, ay) ** self.q + az**self.q - 1.0

    def gradient(self, p: np.ndarray) -> np.ndarray:
        """The direction of grad f, scaled so its largest component is 1 (its length blows
        up at the cusps of e, n > 2 and vanishes at flat spots of tiny e, n). A coordinate
        that is exactly 0 contributes 0 (f is symmetric there), unless f has a cusp across
        that plane (x and y for e > 2, z for n > 2): grad f is infinite there from either
        side, and the direction is that axis (+: the side is unknown on the plane; shading
        turns the normal to the viewer). Near the plane it is that axis already, and a
        membrane's hit lands on either side of it or on it, as rounding has it."""
        x, y, z = p[..., 0], p[..., 1], p[..., 2]
        ax, ay, az = np.abs(x), np.abs(y), np.abs(z)
        g = self._g(ax, ay)
        with np.errstate(divide="ignore", invalid="ignore", under="ignore", over="ignore"):
            lg = np.log(g)
            # log of |df/dx| / q: (q-1) log g + (p-1) log(|x| / g); same for y; (q-1) log|z|
            lx = (self.q - 1) * lg + (self.p - 1) * (np.log(ax) - lg)
            ly = (self.q - 1) * lg + (self.p - 1) * (np.log(ay) - lg)
            lz = (self.q - 1) * np.log(az)
            lx = np.where(ax > 0, lx, -INF)
            ly = np.where(ay > 0, ly, -INF)
            lz = np.where(az > 0, lz, -INF)
            logs = np.stack([lx, ly, lz], axis=-1)
            top = logs.max(axis=-1, keepdims=True)
            top = np.where(np.isfinite(top), top, 0.0)
            mag = np.exp(logs - top)
            # two infinite logs (a cusp on an edge): share the direction between them
            mag = np.where(np.isnan(mag), 1.0, mag)
            n = mag * np.sign(p)
        pinched = self.p < 1, self.p < 1, self.q < 1
        cusp = np.stack([(a == 0) & c for a, c in zip((ax, ay, az), pinched, strict=True)], -1)
        on_cusp = np.any(cusp, axis=-1, keepdims=True)
        if np.any(on_cusp):
            n = np.where(on_cusp, cusp.astype(np.float64), n)
        flat = ~np.any(n != 0, axis=-1)
        if np.any(flat):
            n = np.where(flat[..., None], np.array([0.0, 0.0, 1.0]), n)
        return n

    def _slope(self, o: np.ndarray, d: np.ndarray, t: np.ndarray) -> np.ndarray:
        """The sign-carrying slope of f along the ray (grad direction . d, positive scale):
        enough to bisect for the minimum, whose location does not depend on the scale.
        A convex f has a finite gradient everywhere, and its plain form is cheaper."""
        p = o + t[:, None] * d
        return dot(self.exact_gradient(p) if self.convex else self.gradient(p), d)

    # ------------------------------------------------------------------- protocol
    def crossings(self, o, d):
        n = len(o)
        dl = np.sqrt(dot(d, d))
        good = dl > 0
        du = d / np.where(good, dl, 1.0)[:, None]
        oc, t0 = recentre(o, d, np.zeros(3))
        lo, hi = _box_chord(oc, du, 1.0 + tol.SUPERELLIPSOID_BOX_PAD)
        rows = np.nonzero(good & (lo < hi))[0]
        t = np.full((n, 2), INF)
        if len(rows):
            u = self._chord_crossings(oc[rows], du[rows], lo[rows], hi[rows])
            t = np.full((n, u.shape[1]), INF)
            t[rows] = u / dl[rows, None] + t0[rows, None]
        return roots.compact(t)

    def _chord_crossings(self, o, d, lo, hi) -> np.ndarray:
        m = len(o)
        # on_plane: the axis (0, 1, 2) of the plane x=0, y=0 or z=0 a cut point lies on (-1:
        # none); f is taken there with that coordinate 0. Computed in floats the point is off
        # the plane by rounding, and the membranes a pinched shape has there (as thin as
        # 1e-40 for e = 50: f is negative on the plane itself) would be hit by chance.
        if self.convex:
            pts = np.stack([lo, hi], axis=1)
            on_plane = np.full((m, 2), -1)
        else:
            cells = tol.SUPERELLIPSOID_CELLS
            frac = np.linspace(0.0, 1.0, cells + 1)
            even = lo[:, None] + (hi - lo)[:, None] * frac
            with np.errstate(divide="ignore", invalid="ignore"):
                tp = -(o @ _PLANES.T) / (d @ _PLANES.T)
            cut = (tp > lo[:, None]) & (tp < hi[:, None])
            tp = np.where(cut, tp, hi[:, None])
            axes = np.where(cut, _PLANE_AXIS, -1)
            pts, on_plane = _sorted(
                np.concatenate([even, tp], axis=1),
                np.concatenate([np.full((m, cells + 1), -1), axes], axis=1),
            )
        # an extremum inside a cell (the slope changes sign) splits it: a minimum may dip
        # inside, a maximum (pinched shapes are concave between the axis planes) may rise
        # outside between two inside stretches
        # The slopes are taken just inside each cell: at a cusp (a point on an axis plane)
        # the two sides slope differently.
        k = pts.shape[1]
        inset = tol.SUPERELLIPSOID_INSET * (hi - lo)
        a, b = pts[:, :-1] + inset[:, None], pts[:, 1:] - inset[:, None]
        s_a, s_b = np.empty_like(a), np.empty_like(b)
        for c in range(k - 1):
            s_a[:, c] = self._slope(o, d, a[:, c])
            s_b[:, c] = self._slope(o, d, b[:, c])
        with np.errstate(over="ignore"):  # slopes of tiny e, n: the product's sign holds
            turn = (s_a * s_b < 0) & (b > a)
        mins = np.full((m, k - 1), INF)
        ri, ci = np.nonzero(turn)
        if len(ri):
            ext = self._extremum(o[ri], d[ri], a[ri, ci], b[ri, ci], s_a[ri, ci] < 0)
            mins[ri, ci] = ext
        allp, on_plane = _sorted(
            np.concatenate([pts, np.where(np.isfinite(mins), mins, hi[:, None])], axis=1),
            np.concatenate([on_plane, np.full(mins.shape, -1)], axis=1),
        )
        vals = np.empty_like(allp)
        for c in range(allp.shape[1]):
            p = o + allp[:, c, None] * d
            rows = np.nonzero(on_plane[:, c] >= 0)[0]
            p[rows, on_plane[rows, c]] = 0.0
            vals[:, c] = self.value(p)
        neg = vals < 0
        change = neg[:, :-1] != neg[:, 1:]
        out = np.full((m, allp.shape[1] - 1), INF)
        ri, ci = np.nonzero(change)
        if len(ri):
            oo, dd = o[ri], d[ri]

            def fdf(sel, x):
                # Solve S^(1/q) - 1 = 0 (S = f + 1): the same surface and signs, but a
                # norm-like function (degree-1 homogeneous), nearly linear along the ray,
                # where f itself is flat and then a wall for small e, n; Newton then
                # converges in a few steps.
                p = oo[sel] + x[:, None] * dd[sel]
                with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
                    big = self.value(p) + 1.0
                    root = big ** (1.0 / self.q)
                    slope = root / (self.q * big) * dot(self.exact_gradient(p), dd[sel])
                return root - 1.0, slope

            out[ri, ci] = roots.bracketed(
                fdf, allp[ri, ci], allp[ri, ci + 1], neg[ri, ci], tol.ABS_FLOOR, cusp_ends=True
            )
        return out

    def _extremum(self, o, d, a, b, falling) -> np.ndarray:
        """The extremum of f along each ray between a and b, where the slope changes sign
        (from negative when `falling`: a minimum)."""
        for _ in range(tol.SUPERELLIPSOID_MIN_ITER):
            mid = 0.5 * (a + b)
            s = self._slope(o, d, mid)
            left = (s < 0) == falling
            a = np.where(left, mid, a)
            b = np.where(left, b, mid)
        return 0.5 * (a + b)

    def exact_gradient(self, p: np.ndarray) -> np.ndarray:
        """grad f itself (for Newton steps; may be inf at cusps, where the solver bisects)."""
        ax, ay, az = np.abs(p[:, 0]), np.abs(p[:, 1]), np.abs(p[:, 2])
        g = self._g(ax, ay)
        with np.errstate(divide="ignore", invalid="ignore", under="ignore", over="ignore"):
            common = self.q * g ** (self.q - 1)
            gx = np.where(ax > 0, common * (ax / g) ** (self.p - 1), 0.0)
            gy = np.where(ay > 0, common * (ay / g) ** (self.p - 1), 0.0)
            gz = np.where(az > 0, self.q * az ** (self.q - 1), 0.0)
        return np.stack([gx, gy, gz], axis=1) * np.sign(p)

    def normal(self, p, face):
        return self.gradient(p)

    def inside(self, p):
        # POV-Ray: f < EPSILON (1e-10) is inside, so the surface itself is inside.
        return self.value(p) < tol.SUPERELLIPSOID_INSIDE

    def outside(self, p):
        return ~self.inside(p)


def _sorted(t: np.ndarray, tags: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Each row of t ascending, its tags along (stable: equal values keep their order)."""
    order = np.argsort(t, axis=1, kind="stable")
    return np.take_along_axis(t, order, axis=1), np.take_along_axis(tags, order, axis=1)


def _box_chord(o: np.ndarray, d: np.ndarray, h: float) -> tuple[np.ndarray, np.ndarray]:
    """Entry and exit distances of lines o + u d through the box [-h, h]^3 (lo >= hi: miss)."""
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        inv = 1.0 / d
        t1 = (-h - o) * inv
        t2 = (h - o) * inv
    par = np.abs(d) <= tol.PARALLEL_EPS
    inside_slab = np.abs(o) <= h
    t1 = np.where(par, np.where(inside_slab, -INF, INF), t1)
    t2 = np.where(par, np.where(inside_slab, INF, -INF), t2)
    lo = np.minimum(t1, t2).max(axis=1)
    hi = np.maximum(t1, t2).min(axis=1)
    return lo, hi
