"""Analytic ray intersection, vectorised over ray batches, float64, in object space.

Every primitive answers three questions for rays o + t*d (o, d: (N,3); d need not be unit,
which keeps t equal to the world distance parameter under any object transform):

- `crossings(o, d) -> (t, face)`: all K surface crossings along the whole line, (N,K)
  float64 (inf where there is none) and a small int face id per crossing (which box side,
  cylinder cap …). The tracer filters them by (tmin, tmax); CSG filters them by `inside`.
- `normal(p, face) -> (N,3)`: outward object-space normal (not necessarily unit).
- `inside(p) -> (N,) bool`: POV-Ray's inside test (flat shapes are never inside, except
  planes and discs, which use their half space as POV-Ray does).

`bounds()` gives the object-space box (inf for infinite shapes), `size` a characteristic
length for the self-intersection floor.

This module holds the common shapes' primitives (`primitive_for` picks one of them; the
rarer shapes are runtime.prims', whose `primitive_for` covers every shape) and the helpers
the primitives share (`dot`, `recentre`, `stable_quadratic`, `barycentric` …).
"""

from __future__ import annotations

import numpy as np

from lang import ir
from runtime import tolerances as tol
from runtime import transform as tf

INF = np.inf


def dot(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """(N,) row-wise dot products of two (N,3) arrays."""
    return np.einsum("ij,ij->i", a, b)


def stable_quadratic(a, b, c, disc=None) -> tuple[np.ndarray, np.ndarray]:
    """Roots of a t^2 + 2 b t + c = 0 (the seed's form), sorted, inf where none.

    Uses q = -(b + sign(b) sqrt(b^2 - a c)), t = q/a and c/q, so neither root suffers
    cancellation. `disc` (= b^2 - a c) may be supplied when the caller can compute it more
    accurately (Hearn's recentring)."""
    if disc is None:
        disc = b * b - a * c
    real = disc >= 0
    sq = np.sqrt(np.where(real, disc, 0.0))
    q = -(b + np.copysign(sq, b))
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        t1 = q / a
        t2 = c / q
        # Linear case (a == 0): 2 b t + c = 0; q == 0 only for b == disc == 0 (t = 0 double).
        lin = a == 0
        t1 = np.where(lin, -c / (2 * b), t1)
        t2 = np.where(lin, INF, t2)
        t2 = np.where((q == 0) & ~lin, t1, t2)
    t1 = np.where(real & np.isfinite(t1), t1, INF)
    t2 = np.where(real & np.isfinite(t2), t2, INF)
    return np.minimum(t1, t2), np.maximum(t1, t2)


def recentre(o: np.ndarray, d: np.ndarray, centre) -> tuple[np.ndarray, np.ndarray]:
    """Move each ray origin along its line to the point closest to `centre`; returns the new
    origins and the t offset. Far-away origins then no longer cancel in the polynomial."""
    dd = dot(d, d)
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        t0 = np.where(dd > 0, dot(centre - o, d) / dd, 0.0)
    return o + t0[:, None] * d, t0


# --------------------------------------------------------------------------- sphere
class SpherePrim:
    K = 2

    def __init__(self, center, radius: float):
        self.c = np.asarray(center, dtype=np.float64)
        self.r = float(abs(radius))
        self.size = 2 * self.r

    def bounds(self):
        return self.c - self.r, self.c + self.r

    def bounds_lists(self) -> tuple[list[float], list[float]]:
        """bounds() as plain floats (the same numbers): a scene's thousands of spheres."""
        c, r = self.c.tolist(), self.r
        return [v - r for v in c], [v + r for v in c]

    def crossings(self, o, d):
        # The seed's A t^2 + 2B t + C with A = d.d, B = (o-M).d, C = |o-M|^2 - r^2.
        oc = o - self.c
        a = dot(d, d)
        b = dot(oc, d)
        c = dot(oc, oc) - self.r * self.r
        # Hearn's recentring: B^2 - AC = A (r^2 - |l|^2) with l the perpendicular from the
        # centre to the line; exact for far-away and grazing rays.
        with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
            lv = oc - (b / a)[:, None] * d
        lnorm = np.sqrt(dot(lv, lv))
        disc = a * (self.r - lnorm) * (self.r + lnorm)
        t1, t2 = stable_quadratic(a, b, c, disc)
        return np.stack([t1, t2], axis=1), np.zeros((len(o), 2), dtype=np.int8)

    def normal(self, p, face):
        return (p - self.c) / self.r

    def inside(self, p):
        q = p - self.c
        return dot(q, q) < self.r * self.r

    def outside(self, p):
        # POV-Ray: a point on the sphere is neither inside it nor inside its inverse.
        q = p - self.c
        return dot(q, q) > self.r * self.r


# ---------------------------------------------------------------------------- plane
class PlanePrim:
    """n . p = D with n normalised and D kept: the plane lies at distance D along the unit
    normal. That is what POV-Ray 3.7 renders (checked against `povray`: plane { <0,2,0>, 1 }
    is the plane y = 1, not y = 0.5)."""

    K = 1

    def __init__(self, normal, distance: float):
        n = np.asarray(normal, dtype=np.float64)
        length = float(np.linalg.norm(n))
        self.n = n / length
        self.dist = float(distance)
        # A plane is linear in t: its self-hit error is covered by the ray-origin offset, and
        # a size-relative floor would grow with its distance from the world origin.
        self.size = 0.0

    def bounds(self):
        return np.full(3, -INF), np.full(3, INF)

    def crossings(self, o, d):
        denom = d @ self.n
        with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
            t = (self.dist - o @ self.n) / denom
        t = np.where(np.abs(denom) > tol.PARALLEL_EPS, t, INF)
        return t[:, None], np.zeros((len(o), 1), dtype=np.int8)

    def normal(self, p, face):
        return np.broadcast_to(self.n, p.shape).copy()

    def inside(self, p):
        return p @ self.n - self.dist < tol.INSIDE_EPS

    def outside(self, p):
        # The inverse of a plane is the flipped plane: points on it count for both.
        return p @ self.n - self.dist > -tol.INSIDE_EPS


# ------------------------------------------------------------------------------ box
class BoxPrim:
    """Axis-aligned box; face id = 2*axis + (1 if the normal points along +axis)."""

    K = 2

    def __init__(self, corner1, corner2):
        c1 = np.asarray(corner1, dtype=np.float64)
        c2 = np.asarray(corner2, dtype=np.float64)
        self.lo = np.minimum(c1, c2)
        self.hi = np.maximum(c1, c2)
        self.size = float(np.linalg.norm(self.hi - self.lo))

    def bounds(self):
        return self.lo, self.hi

    def bounds_lists(self) -> tuple[list[float], list[float]]:
        """bounds() as plain floats (see SpherePrim.bounds_lists)."""
        return self.lo.tolist(), self.hi.tolist()

    def crossings(self, o, d):
        with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
            t1 = (self.lo - o) / d
            t2 = (self.hi - o) / d
        par = d == 0
        inslab = (o >= self.lo) & (o <= self.hi)
        tn_ax = np.where(par, np.where(inslab, -INF, INF), np.minimum(t1, t2))
        tf_ax = np.where(par, np.where(inslab, INF, -INF), np.maximum(t1, t2))
        an = np.argmax(tn_ax, axis=1)
        af = np.argmin(tf_ax, axis=1)
        r = np.arange(len(o))
        tn = tn_ax[r, an]
        tfar = tf_ax[r, af]
        hit = (tn <= tfar) & np.isfinite(tn) & np.isfinite(tfar)
        # Entering through the face that looks at the ray, leaving through the opposite one.
        dn = d[r, an]
        dfa = d[r, af]
        face_n = 2 * an + (dn < 0)
        face_f = 2 * af + (dfa > 0)
        t = np.stack([np.where(hit, tn, INF), np.where(hit, tfar, INF)], axis=1)
        face = np.stack([face_n, face_f], axis=1).astype(np.int8)
        return t, face

    def normal(self, p, face):
        f = face.astype(np.int64)
        n = np.zeros_like(p)
        n[np.arange(len(p)), f // 2] = np.where(f % 2 == 1, 1.0, -1.0)
        return n

    def inside(self, p):
        # POV-Ray: the box's surface belongs to the box, not to its inverse.
        return np.all((p >= self.lo) & (p <= self.hi), axis=1)

    def outside(self, p):
        return ~self.inside(p)


# -------------------------------------------------------------------------- polygon
def polygon_edges(points: np.ndarray) -> np.ndarray:
    """POV-Ray's sub-polygon rule: a sub-polygon closes when a point repeats its first
    point; an unclosed tail is closed automatically. Returns (E,2,3) edges."""
    edges = []
    start = 0
    i = 1
    n = len(points)
    while i < n:
        if np.array_equal(points[i], points[start]):
            for k in range(start, i):
                edges.append((points[k], points[k + 1]))
            start = i + 1
            i = start + 1
            continue
        i += 1
    if start < n - 1:
        tail = list(points[start:]) + [points[start]]
        for k in range(len(tail) - 1):
            edges.append((tail[k], tail[k + 1]))
    return np.array(edges, dtype=np.float64).reshape(-1, 2, 3)


class PolygonPrim:
    """Planar polygon: the seed's ray-plane formula, then an even-odd crossing test in the
    plane projected along its dominant normal axis."""

    K = 1

    def __init__(self, points):
        pts = np.asarray(points, dtype=np.float64).reshape(-1, 3)
        self.edges = polygon_edges(pts)
        # Newell's normal: robust for any (even non-convex) planar polygon.
        a, b = self.edges[:, 0], self.edges[:, 1]
        n = np.array(
            [
                np.sum((a[:, 1] - b[:, 1]) * (a[:, 2] + b[:, 2])),
                np.sum((a[:, 2] - b[:, 2]) * (a[:, 0] + b[:, 0])),
                np.sum((a[:, 0] - b[:, 0]) * (a[:, 1] + b[:, 1])),
            ]
        )
        length = np.linalg.norm(n)
        self.degenerate = not length > 0
        self.n = n / length if length > 0 else np.array([0.0, 0.0, 1.0])
        # Plane A x + B y + C z + D = 0 as in the seed.
        self.D = -float(self.n @ pts.mean(axis=0))
        drop = int(np.argmax(np.abs(self.n)))
        self.keep = [i for i in range(3) if i != drop]
        self.e2 = self.edges[:, :, self.keep]  # (E,2,2)
        self.lo = pts.min(axis=0)
        self.hi = pts.max(axis=0)
        self.size = float(np.linalg.norm(self.hi - self.lo))

    def bounds(self):
        return self.lo, self.hi

    def plane_t(self, o, d):
        # Seed: t = (A S1 + B S2 + C S3 + D) / -(A D1 + B D2 + C D3).
        denom = -(d @ self.n)
        with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
            t = (o @ self.n + self.D) / denom
        return np.where(np.abs(denom) > tol.PARALLEL_EPS, t, INF)

    def contains(self, q: np.ndarray) -> np.ndarray:
        """Even-odd point-in-polygon for points q (N,3) on the plane."""
        px = q[:, self.keep[0], None]
        py = q[:, self.keep[1], None]
        ax, ay = self.e2[:, 0, 0], self.e2[:, 0, 1]
        bx, by = self.e2[:, 1, 0], self.e2[:, 1, 1]
        straddle = (ay > py) != (by > py)
        with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
            xint = ax + (py - ay) * (bx - ax) / (by - ay)
        cross = straddle & (px < xint)
        return (np.count_nonzero(cross, axis=1) % 2) == 1

    def crossings(self, o, d):
        t = self.plane_t(o, d)
        ok = np.isfinite(t)
        if self.degenerate:
            ok[:] = False
        rows = np.nonzero(ok)[0]
        if len(rows):
            q = o[rows] + t[rows, None] * d[rows]
            ok[rows] = self.contains(q)
        t = np.where(ok, t, INF)
        return t[:, None], np.zeros((len(o), 1), dtype=np.int8)

    def normal(self, p, face):
        return np.broadcast_to(self.n, p.shape).copy()

    def inside(self, p):
        return np.zeros(len(p), dtype=bool)

    def outside(self, p):
        # Flat shapes have no inside, and neither has their inverse (as in POV-Ray).
        return np.zeros(len(p), dtype=bool)


# ------------------------------------------------------------------------- triangle
class TrianglePrim:
    """One (smooth) triangle in float64, used where Embree cannot serve (inside CSG)."""

    K = 1

    def __init__(self, p1, p2, p3, normals=None):
        self.v = np.array([p1, p2, p3], dtype=np.float64)
        self.e1 = self.v[1] - self.v[0]
        self.e2 = self.v[2] - self.v[0]
        ng = np.cross(self.e1, self.e2)
        length = np.linalg.norm(ng)
        self.ng = ng / length if length > 0 else np.array([0.0, 0.0, 1.0])
        self.vn = None if normals is None else np.asarray(normals, dtype=np.float64)
        self.size = float(np.linalg.norm(self.v.max(axis=0) - self.v.min(axis=0)))

    def bounds(self):
        return self.v.min(axis=0), self.v.max(axis=0)

    def crossings(self, o, d):
        t, _, _ = moller_trumbore(o, d, self.v[0], self.e1, self.e2)
        return t[:, None], np.zeros((len(o), 1), dtype=np.int8)

    def normal(self, p, face):
        if self.vn is None:
            return np.broadcast_to(self.ng, p.shape).copy()
        u, v = barycentric(p, self.v[0], self.e1, self.e2)
        return (1 - u - v)[:, None] * self.vn[0] + u[:, None] * self.vn[1] + v[:, None] * self.vn[2]

    def inside(self, p):
        return np.zeros(len(p), dtype=bool)

    def outside(self, p):
        # Flat shapes have no inside, and neither has their inverse (as in POV-Ray).
        return np.zeros(len(p), dtype=bool)


def moller_trumbore(o, d, v0, e1, e2):
    """Ray/triangle in float64, (N,) arrays; v0, e1, e2 are (3,) or (N,3). Returns t (inf on a
    miss) and barycentrics u, v (weights of vertex 1 and 2)."""
    pv = np.cross(d, e2)
    det = np.einsum("...j,...j->...", e1, pv) * np.ones(len(o))
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        inv = 1.0 / det
        tv = o - v0
        u = np.einsum("ij,ij->i", tv, pv) * inv
        qv = np.cross(tv, e1)
        v = np.einsum("ij,ij->i", d, qv) * inv
        t = np.einsum("...j,...j->...", e2 * np.ones_like(o), qv) * inv
    ok = (det != 0) & (u >= 0) & (v >= 0) & (u + v <= 1) & np.isfinite(t)
    return np.where(ok, t, INF), u, v


def barycentric(p, v0, e1, e2):
    """Barycentric weights (u of vertex 1, v of vertex 2) of points p in the triangle plane."""
    w = p - v0
    d00 = np.einsum("...j,...j->...", e1, e1)
    d01 = np.einsum("...j,...j->...", e1, e2)
    d11 = np.einsum("...j,...j->...", e2, e2)
    d20 = np.einsum("...j,...j->...", w, e1 * np.ones_like(w))
    d21 = np.einsum("...j,...j->...", w, e2 * np.ones_like(w))
    den = d00 * d11 - d01 * d01
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        u = (d11 * d20 - d01 * d21) / den
        v = (d00 * d21 - d01 * d20) / den
    return u, v


# ----------------------------------------------------------------------------- disc
class DiscPrim:
    K = 1
    # POV-Ray's disc is inside on the side its normal points away from (Inside_Disc): a
    # half space, which the disc's box does not hold (see trace.Leaf.boxes_inside).
    INSIDE_BOUNDED = False

    def __init__(self, center, normal, radius: float, hole_radius: float = 0.0):
        self.c = np.asarray(center, dtype=np.float64)
        n = np.asarray(normal, dtype=np.float64)
        self.n = n / np.linalg.norm(n)
        self.r2 = float(radius) ** 2
        self.h2 = float(hole_radius) ** 2
        self.r = abs(float(radius))
        self.size = 2 * self.r

    def bounds(self):
        # Extent of a disc along axis i is r * sqrt(1 - n_i^2).
        ext = self.r * np.sqrt(np.clip(1 - self.n**2, 0, 1))
        return self.c - ext, self.c + ext

    def crossings(self, o, d):
        denom = d @ self.n
        with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
            t = ((self.c - o) @ self.n) / denom
        t = np.where(np.abs(denom) > tol.PARALLEL_EPS, t, INF)
        fin = np.isfinite(t)
        q = o + np.where(fin, t, 0.0)[:, None] * d - self.c
        r2 = dot(q, q)
        ok = fin & (r2 <= self.r2) & (r2 >= self.h2)
        return np.where(ok, t, INF)[:, None], np.zeros((len(o), 1), dtype=np.int8)

    def normal(self, p, face):
        return np.broadcast_to(self.n, p.shape).copy()

    def inside(self, p):
        # POV-Ray's disc is "inside" on the side its normal points away from.
        return (p - self.c) @ self.n < 0

    def outside(self, p):
        return ~self.inside(p)


# ----------------------------------------------------------------- cylinder and cone
class ConePrim:
    """Cone (and cylinder) in a canonical frame: axis +z from 0 (base) to 1 (cap), radius
    r0 + (r1 - r0) z, xy in world units. `frame` maps canonical to object space; the
    tracer's Leaf composes it with the object's transform through `matrix_in`.
    face: 0/1 the lateral surface, 2 the base cap, 3 the top cap."""

    K = 4

    def __init__(self, base, cap, r0: float, r1: float, open_: bool):
        base = np.asarray(base, dtype=np.float64)
        cap = np.asarray(cap, dtype=np.float64)
        axis = cap - base
        self.h = float(np.linalg.norm(axis))
        self.frame = tf.frame_to(base, axis) @ np.diag([1.0, 1.0, self.h, 1.0])
        self.frame_inv = tf.inverse(self.frame)
        self.r0 = float(r0)
        self.r1 = float(r1)
        self.k = self.r1 - self.r0
        self.open = open_
        rmax = max(abs(self.r0), abs(self.r1))
        self.size = float(max(self.h, 2 * rmax))
        pts = np.array([base, cap])
        self.lo = pts.min(axis=0) - rmax
        self.hi = pts.max(axis=0) + rmax

    def bounds(self):
        return self.lo, self.hi

    def _canon(self, o, d):
        return tf.apply_points(self.frame_inv, o), tf.apply_dirs(self.frame_inv, d)

    def crossings(self, o, d):
        o, d = self._canon(o, d)
        oc, t0 = recentre(o, d, np.array([0.0, 0.0, 0.5]))
        r0, k = self.r0, self.k
        rho = r0 + k * oc[:, 2]
        a = d[:, 0] ** 2 + d[:, 1] ** 2 - (k * d[:, 2]) ** 2
        b = oc[:, 0] * d[:, 0] + oc[:, 1] * d[:, 1] - k * d[:, 2] * rho
        c = oc[:, 0] ** 2 + oc[:, 1] ** 2 - rho**2
        disc = None
        if k == 0:
            # Cylinder: 2D Hearn recentring of the discriminant, as for the sphere.
            with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
                lx = oc[:, 0] - b / a * d[:, 0]
                ly = oc[:, 1] - b / a * d[:, 1]
            ln = np.hypot(lx, ly)
            disc = a * (abs(r0) - ln) * (abs(r0) + ln)
        t1, t2 = stable_quadratic(a, b, c, disc)
        out = []
        for ts in (t1, t2):
            z = oc[:, 2] + np.where(np.isfinite(ts), ts, 0.0) * d[:, 2]
            ok = np.isfinite(ts) & (z >= 0) & (z <= 1)
            if k != 0:
                # The double cone's mirror nappe lies where the radius turns negative.
                ok &= (r0 + k * z) >= 0
            out.append(np.where(ok, ts + t0, INF))
        for zc, rc in ((0.0, self.r0), (1.0, self.r1)):
            if self.open or rc == 0:
                out.append(np.full(len(o), INF))
                continue
            with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
                tc = (zc - o[:, 2]) / d[:, 2]
            fin = np.isfinite(tc) & (np.abs(d[:, 2]) > tol.PARALLEL_EPS)
            tcz = np.where(fin, tc, 0.0)
            with np.errstate(over="ignore", invalid="ignore"):  # far cap planes: inf, no hit
                x = o[:, 0] + tcz * d[:, 0]
                y = o[:, 1] + tcz * d[:, 1]
                ok = fin & (x * x + y * y <= rc * rc)
            out.append(np.where(ok, tc, INF))
        t = np.stack(out, axis=1)
        face = np.broadcast_to(np.array([0, 1, 2, 3], dtype=np.int8), t.shape).copy()
        return t, face

    def normal(self, p, face):
        q = tf.apply_points(self.frame_inv, p)
        rho = self.r0 + self.k * q[:, 2]
        n = np.stack([q[:, 0], q[:, 1], -self.k * rho], axis=1)
        n = np.where((face == 2)[:, None], np.array([0.0, 0.0, -1.0]), n)
        n = np.where((face == 3)[:, None], np.array([0.0, 0.0, 1.0]), n)
        # Canonical normal to object space: inverse transpose of `frame`.
        return n @ self.frame_inv[:3, :3]

    def inside(self, p):
        # POV-Ray: a closed cylinder / cone keeps its surface outside, an open one inside.
        q = tf.apply_points(self.frame_inv, p)
        rho = self.r0 + self.k * q[:, 2]
        e = tol.INSIDE_EPS if self.open else -tol.INSIDE_EPS
        w2 = q[:, 0] ** 2 + q[:, 1] ** 2
        return (q[:, 2] >= -e) & (q[:, 2] <= 1 + e) & (w2 <= rho * rho + e)

    def outside(self, p):
        return ~self.inside(p)


# ---------------------------------------------------------------------------- torus
class TorusPrim:
    """POV-Ray's torus: around the y axis, in the x-z plane. Quartic roots by batched
    companion-matrix eigenvalues on a recentred ray, then Newton-polished in float64."""

    K = 4

    def __init__(self, major: float, minor: float):
        self.R = float(major)
        self.r = float(minor)
        e = abs(self.R) + abs(self.r)
        self.lo = np.array([-e, -abs(self.r), -e])
        self.hi = -self.lo
        self.size = 2 * e

    def bounds(self):
        return self.lo, self.hi

    def crossings(self, o, d):
        n = len(o)
        dl = np.linalg.norm(d, axis=1)
        du = d / np.where(dl > 0, dl, 1.0)[:, None]
        oc, t0 = recentre(o, d, np.zeros(3))
        R2 = self.R**2
        H = 2 * dot(oc, du)
        I = dot(oc, oc) + R2 - self.r**2
        J2 = du[:, 0] ** 2 + du[:, 2] ** 2
        J1 = oc[:, 0] * du[:, 0] + oc[:, 2] * du[:, 2]
        J0 = oc[:, 0] ** 2 + oc[:, 2] ** 2
        c3 = 2 * H
        c2 = H * H + 2 * I - 4 * R2 * J2
        c1 = 2 * H * I - 8 * R2 * J1
        c0 = I * I - 4 * R2 * J0
        # Only rays passing within the bounding sphere can hit; skip the eigen solve for
        # the others (it is the expensive part).
        near = dot(oc, oc) <= ((abs(self.R) + abs(self.r)) * (1 + tol.BOX_PAD_REL)) ** 2
        roots = np.full((n, 4), INF)
        rows = np.nonzero(near)[0]
        if len(rows):
            m = np.zeros((len(rows), 4, 4))
            m[:, 0, 0] = -c3[rows]
            m[:, 0, 1] = -c2[rows]
            m[:, 0, 2] = -c1[rows]
            m[:, 0, 3] = -c0[rows]
            m[:, 1, 0] = m[:, 2, 1] = m[:, 3, 2] = 1.0
            ev = np.linalg.eigvals(m)
            scale = abs(self.R) + abs(self.r)
            real = np.abs(ev.imag) <= tol.QUARTIC_IMAG_REL * (np.abs(ev) + scale)
            u = np.where(real, ev.real, np.nan)
            oo, dd = oc[rows], du[rows]
            for _ in range(tol.NEWTON_STEPS + 1):
                p = oo[:, None, :] + u[..., None] * dd[:, None, :]
                s = np.sum(p * p, axis=-1) + R2 - self.r**2
                f = s * s - 4 * R2 * (p[..., 0] ** 2 + p[..., 2] ** 2)
                # df/du = 2 s * 2 p.d - 8 R^2 (px dx + pz dz)
                pd = np.sum(p * dd[:, None, :], axis=-1)
                fp = 4 * s * pd - 8 * R2 * (p[..., 0] * dd[:, None, 0] + p[..., 2] * dd[:, None, 2])
                with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
                    step = np.where(fp != 0, f / fp, 0.0)
                # Newton near a double root can jump; only accept small corrections.
                u = np.where(np.abs(step) < tol.NEWTON_MAX_STEP_REL * scale, u - step, u)
            u = np.sort(np.where(np.isnan(u), INF, u), axis=1)
            roots[rows] = u / dl[rows, None] + t0[rows, None]
        return roots, np.zeros((n, 4), dtype=np.int8)

    def normal(self, p, face):
        s = np.sum(p * p, axis=1) + self.R**2 - self.r**2
        n = p * s[:, None]
        n[:, 0] -= 2 * self.R**2 * p[:, 0]
        n[:, 2] -= 2 * self.R**2 * p[:, 2]
        return n

    def inside(self, p):
        # Distance to the core circle, surface included (as POV-Ray).
        rho = np.hypot(p[:, 0], p[:, 2])
        return p[:, 1] ** 2 + (rho - self.R) ** 2 <= self.r**2

    def outside(self, p):
        return ~self.inside(p)


def gather(prims: list, which: np.ndarray):
    """One primitive of the same kind whose parameters are per-ray arrays: prims[which[i]]'s
    parameters on row i (their formulas broadcast, so crossings work unchanged)."""
    first = prims[0]
    out = object.__new__(type(first))
    if isinstance(first, SpherePrim):
        out.c = np.array([p.c for p in prims])[which]
        out.r = np.array([p.r for p in prims])[which]
    elif isinstance(first, BoxPrim):
        out.lo = np.array([p.lo for p in prims])[which]
        out.hi = np.array([p.hi for p in prims])[which]
    else:
        raise TypeError(f"{type(first).__name__} cannot be gathered")
    return out


# ------------------------------------------------------------------------- dispatch
def degenerate(shape) -> str | None:
    """Why an IR shape cannot be intersected (zero axis, zero normal …), or None."""

    def zero(v) -> bool:
        return not np.linalg.norm(np.asarray(v, dtype=np.float64)) > 0

    if isinstance(shape, ir.Plane | ir.Disc) and zero(shape.normal):
        return "its normal is the zero vector"
    if isinstance(shape, ir.Cylinder | ir.Cone) and zero(np.subtract(shape.cap, shape.base)):
        return "its base and cap points coincide"
    if isinstance(shape, ir.Sphere) and shape.radius == 0:
        return "its radius is 0"
    return None


def flat_triangle(shape: ir.Triangle) -> bool:
    """POV-Ray's DEGENERATE_FLAG: the corners span no area, or (smooth) a normal is zero.
    Such a triangle is never hit; the front end has warned about it."""
    p1, p2, p3 = (np.asarray(p, dtype=np.float64) for p in (shape.p1, shape.p2, shape.p3))
    if not np.any(np.cross(p1 - p2, p3 - p2)):
        return True
    return shape.normals is not None and any(not np.any(n) for n in shape.normals)


def primitive_for(shape):
    """The analytic primitive for one of the common IR shapes, or None for any other
    (runtime.prims.primitive_for picks the primitive of every shape)."""
    if isinstance(shape, ir.Sphere):
        return SpherePrim(shape.center, shape.radius)
    if isinstance(shape, ir.Plane):
        return PlanePrim(shape.normal, shape.distance)
    if isinstance(shape, ir.Box):
        return BoxPrim(shape.corner1, shape.corner2)
    if isinstance(shape, ir.Polygon):
        return PolygonPrim(shape.points)
    if isinstance(shape, ir.Triangle):
        return TrianglePrim(shape.p1, shape.p2, shape.p3, shape.normals)
    if isinstance(shape, ir.Disc):
        return DiscPrim(shape.center, shape.normal, shape.radius, shape.hole_radius)
    if isinstance(shape, ir.Cylinder):
        return ConePrim(shape.base, shape.cap, shape.radius, shape.radius, shape.open)
    if isinstance(shape, ir.Cone):
        return ConePrim(shape.base, shape.cap, shape.base_radius, shape.cap_radius, shape.open)
    if isinstance(shape, ir.Torus):
        return TorusPrim(shape.major, shape.minor)
    return None
