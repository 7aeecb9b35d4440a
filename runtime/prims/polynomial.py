"""POV-Ray's polynomial surfaces (`quadric`, `cubic`, `quartic`, `poly`, `polynomial`):
sum(c · x^i y^j z^k) = 0, inside where the sum is negative.

Along a ray the sum is a univariate polynomial in the distance. The ray origin is first
moved along the ray to the point nearest the object's origin and the direction made unit
(so the coefficients stay of the object's size however far the camera is), the polynomial
is expanded exactly term by term, and then:

- order 2 (quadrics): the stable quadratic formula on the whole line, as `runtime.shapes`;
- order >= 3: every real root in a bound that contains them all (Fujiwara's bound, capped
  at `POLY_REACH` object sizes), by `roots.roots_in` (derivative-isolated monotone pieces,
  Newton/bisection to float64 precision). `sturm` changes nothing: the isolation is exact.

A polynomial surface is unbounded in general: `bounds()` is infinite and POV-Ray scenes
limit it with `clipped_by` (or `bounded_by`).
"""

from __future__ import annotations

import numpy as np

from lang import ir
from runtime import tolerances as tol
from runtime.prims import roots
from runtime.shapes import dot, recentre, stable_quadratic

INF = np.inf


def _mul(p: np.ndarray, q: np.ndarray) -> np.ndarray:
    """Product of batched polynomials p (N, a) and q (N, b), lowest power first."""
    out = np.zeros((p.shape[0], p.shape[1] + q.shape[1] - 1))
    for k in range(q.shape[1]):
        out[:, k : k + p.shape[1]] += p * q[:, k : k + 1]
    return out


class PolyPrim:
    """The primitive of an `ir.Poly`: object space is the polynomial's own space."""

    def __init__(self, shape: ir.Poly):
        terms = [t for t in shape.terms if t[3] != 0.0]
        self.i = np.array([t[0] for t in terms], dtype=np.int64)
        self.j = np.array([t[1] for t in terms], dtype=np.int64)
        self.k = np.array([t[2] for t in terms], dtype=np.int64)
        self.c = np.array([t[3] for t in terms], dtype=np.float64)
        total = self.i + self.j + self.k
        self.degree = int(total.max()) if len(terms) else 0
        # POV-Ray's quadric keeps its surface inside (<= 0); its poly accepts values up to
        # its INSIDE_TOLERANCE (the surface of a poly, cubic or quartic is inside too).
        self.inside_eps = 0.0 if self.degree <= 2 else tol.POLY_INSIDE
        self.size = self._size(total)
        self.K = max(self.degree, 1)

    def _size(self, total: np.ndarray) -> float:
        """A length for the self-hit floor: (|constant| / |top-degree terms|)^(1/degree)
        is the radius of a sphere, torus or cylinder written as a polynomial; 1 (object
        units, which POV-Ray's polynomials are written in) when that says nothing."""
        if self.degree == 0:
            return 1.0
        const = float(np.abs(self.c[total == 0]).sum())
        top = float(np.abs(self.c[total == self.degree]).max())
        if const > 0 and top > 0:
            size = (const / top) ** (1.0 / self.degree)
            if np.isfinite(size) and size > 0:
                return 2 * size
        return 1.0

    def bounds(self):
        return np.full(3, -INF), np.full(3, INF)

    # ----------------------------------------------------------------- evaluation
    def _powers(self, p: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """x^0..x^degree (and y, z) per point, by repeated products: pow() of every
        exponent was most of an inside test's cost (CSG of polys tests every crossing)."""
        out = []
        for a in range(3):
            pw = np.empty((len(p), self.degree + 1))
            pw[:, 0] = 1.0
            for e in range(1, self.degree + 1):
                np.multiply(pw[:, e - 1], p[:, a], out=pw[:, e])
            out.append(pw)
        return out[0], out[1], out[2]

    def value(self, p: np.ndarray) -> np.ndarray:
        x, y, z = self._powers(p)
        return (x[:, self.i] * y[:, self.j] * z[:, self.k]) @ self.c

    def gradient(self, p: np.ndarray) -> np.ndarray:
        x, y, z = self._powers(p)
        im, jm, km = (np.maximum(e - 1, 0) for e in (self.i, self.j, self.k))
        gx = (x[:, im] * y[:, self.j] * z[:, self.k]) @ (self.c * self.i)
        gy = (x[:, self.i] * y[:, jm] * z[:, self.k]) @ (self.c * self.j)
        gz = (x[:, self.i] * y[:, self.j] * z[:, km]) @ (self.c * self.k)
        return np.stack([gx, gy, gz], axis=1)

    def along(self, o: np.ndarray, d: np.ndarray) -> np.ndarray:
        """Coefficients (N, degree+1), lowest power first, of the polynomial at o + u d."""
        n = len(o)
        pw = []
        for a in range(3):
            lin = np.stack([o[:, a], d[:, a]], axis=1)
            powers = [np.ones((n, 1))]
            for _ in range(self.degree):
                powers.append(_mul(powers[-1], lin))
            pw.append(powers)
        # Nested like Horner's rule: for each x power i, the sum over j of y^j times the sum
        # over k of c z^k; one product per distinct (i, j) and per i instead of per term.
        out = np.zeros((n, self.degree + 1))
        for i in np.unique(self.i):
            in_i = self.i == i
            ysum = np.zeros((n, 1))
            for j in np.unique(self.j[in_i]):
                sel = in_i & (self.j == j)
                kmax = int(self.k[sel].max())
                zsum = np.zeros((n, kmax + 1))
                for k, c in zip(self.k[sel], self.c[sel], strict=True):
                    zsum[:, : k + 1] += c * pw[2][k]
                term = _mul(pw[1][j], zsum)
                if term.shape[1] > ysum.shape[1]:
                    ysum = np.pad(ysum, ((0, 0), (0, term.shape[1] - ysum.shape[1])))
                ysum[:, : term.shape[1]] += term
            prod = _mul(pw[0][i], ysum)
            out[:, : prod.shape[1]] += prod
        return out

    # ------------------------------------------------------------------- protocol
    def crossings(self, o, d):
        n = len(o)
        if self.degree == 0:
            return np.full((n, 1), INF), np.zeros((n, 1), dtype=np.int8)
        dl = np.sqrt(dot(d, d))
        ok = dl > 0
        du = d / np.where(ok, dl, 1.0)[:, None]
        oc, t0 = recentre(o, d, np.zeros(3))
        cf = self.along(oc, du)
        if self.degree == 1:
            with np.errstate(divide="ignore", invalid="ignore"):
                u = (-cf[:, 0] / cf[:, 1])[:, None]
            u = np.where(np.isfinite(u), u, INF)
        elif self.degree == 2:
            u = np.stack(stable_quadratic(cf[:, 2], 0.5 * cf[:, 1], cf[:, 0]), axis=1)
        else:
            bound = np.minimum(
                _fujiwara(cf), tol.POLY_REACH * (self.size + np.linalg.norm(oc, axis=1))
            )
            u = roots.roots_in(cf, -bound, bound)
        with np.errstate(invalid="ignore"):
            t = np.where(
                ok[:, None] & np.isfinite(u), u / np.where(ok, dl, 1.0)[:, None] + t0[:, None], INF
            )
        return roots.compact(t)

    def normal(self, p, face):
        return self.gradient(p)

    def inside(self, p):
        if self.degree == 0:
            return np.full(len(p), False)
        v = self.value(p)
        return v <= 0 if self.inside_eps == 0 else v < self.inside_eps

    def outside(self, p):
        return ~self.inside(p)


def _fujiwara(c: np.ndarray) -> np.ndarray:
    """An upper bound on |root| of each polynomial c (N, n+1), lowest power first:
    2 max_k |a_{n-k} / a_n|^(1/k) (the last term halved), with the leading coefficient
    the highest one that is not negligible (an exactly vanishing one lowers the degree;
    one below 1e-14 of the largest would only add roots beyond the cap)."""
    a = np.abs(c)
    big = a.max(axis=1)
    n = c.shape[1] - 1
    lead = np.zeros(len(c))
    deg = np.zeros(len(c), dtype=np.int64)
    for k in range(n, 0, -1):
        take = (deg == 0) & (a[:, k] > tol.POLY_LEAD_REL * big)
        lead = np.where(take, a[:, k], lead)
        deg = np.where(take, k, deg)
    bound = np.zeros(len(c))
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        for k in range(1, n + 1):
            idx = deg - k
            valid = idx >= 0
            ak = np.where(valid, a[np.arange(len(c)), np.maximum(idx, 0)], 0.0)
            ratio = ak / lead
            ratio = np.where(valid & (idx == 0), ratio / 2, ratio)
            r = np.where(valid, ratio ** (1.0 / k), 0.0)
            bound = np.maximum(bound, np.nan_to_num(r, nan=0.0, posinf=INF))
    bound = 2 * bound * (1 + 1e-9) + tol.ABS_FLOOR
    return np.where(deg > 0, bound, 0.0)
