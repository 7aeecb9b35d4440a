"""The box of a CSG intersection from what bounds its children's insides together.

An intersection's box is the overlap of its children's (trace.CsgNode), and a plane's or an
infinite quadric's box is all of space: `intersection { object { Hyperboloid_Y } plane { y,
5.5 } plane { -y, -2.5 } }`, the way shapes.inc's quadrics are meant to be used, had no
box, and every ray of the scene tested it (a chess set of them: 44 such pieces, most of
the tracing). POV-Ray bounds these (csg.cpp's Compute_BBox: a plane along an axis bounds
that axis, and a quadric is bounded within the box of the others). Here:

- a plane whose normal lies along an axis bounds that axis by its half space;
- a quadric's inside, Q(x) <= 0, is tightened within the box of the others by interval
  arithmetic on Q as a quadratic in each coordinate in turn (a hyperboloid between two
  planes, an ellipsoid, a paraboloid under a plane: any orientation).

Every box here holds the child's inside (padded for the inside tests' tolerance and
rounding), so the intersection's box holds its inside and its crossings, as CsgNode's
`tight` and `boxes_inside` say."""

from __future__ import annotations

import itertools
import math

import numpy as np

from runtime import shapes
from runtime import tolerances as tol
from runtime.prims.polynomial import PolyPrim

# A normal component below this (of a unit normal) is taken as along the axes.
AXIS_EPS = 1e-12
# Rounds of tightening the three coordinates (each uses the others' latest bounds).
ROUNDS = 6
# Each side of a box found is moved out by this much of its coordinates' size (and the
# absolute floor): the inside tests' tolerance and the arithmetic's rounding.
PAD_REL = 1e-7

Interval = tuple[float, float]


def intersection_box(children: list, lo: np.ndarray, hi: np.ndarray) -> tuple:
    """(lo, hi) holding the intersection of the children's insides, starting from the
    overlap of their boxes (lo, hi)."""
    box = [(float(a), float(b)) for a, b in zip(lo, hi, strict=True)]
    quadrics, planes = [], []
    for child in children:
        prim = getattr(child, "prim", None)
        if isinstance(prim, shapes.PlanePrim):
            box = _meet(box, _half_space(child))
            planes.append(child)
        elif isinstance(prim, PolyPrim) and prim.degree == 2 and not child.inverse:
            quadrics.append(_world_quadric(child))
    if len(planes) >= 3 and not all(math.isfinite(v) for side in box for v in side):
        box = _meet(box, _polyhedron(planes, box))
    for _ in range(2 if quadrics else 0):  # a second pass: each quadric within the others'
        for form in quadrics:
            found = _tighten(*form, box)
            if found is None:  # an empty inside: keep the box as it was (nothing is lost)
                break
            box = found
    out_lo = np.array([a for a, _ in box])
    out_hi = np.array([b for _, b in box])
    size = np.abs(np.where(np.isfinite(out_lo), out_lo, 0.0))
    size += np.abs(np.where(np.isfinite(out_hi), out_hi, 0.0))
    pad = PAD_REL * size + tol.ABS_FLOOR
    return np.maximum(out_lo - pad, lo), np.minimum(out_hi + pad, hi)


def _meet(box: list[Interval], other: list[Interval] | None) -> list[Interval]:
    if other is None:
        return box
    return [(max(a, c), min(b, d)) for (a, b), (c, d) in zip(box, other, strict=True)]


def _half_space(leaf) -> list[Interval] | None:
    """The box of a plane's inside (n . x < d in its own space) when its world normal lies
    along an axis, else None."""
    prim: shapes.PlanePrim = leaf.prim
    m = np.asarray(leaf.m, dtype=np.float64)
    m_inv = np.asarray(leaf.m_inv, dtype=np.float64)
    # world normal: the inverse transposed; a point of the plane carried into the world
    n = m_inv[:3, :3].T @ prim.n
    length = float(np.linalg.norm(n))
    if not length > 0:
        return None
    n = n / length
    axis = int(np.argmax(np.abs(n)))
    if np.abs(np.delete(n, axis)).max() > AXIS_EPS:
        return None
    at = float((m[:3, :3] @ (prim.n * prim.dist) + m[:3, 3])[axis])
    # the inside tests' tolerance, in world units along the axis
    slack = tol.INSIDE_EPS / length
    up = (n[axis] > 0) != bool(leaf.inverse)  # the inside lies below `at` along the axis
    out: list[Interval] = [(-math.inf, math.inf)] * 3
    out[axis] = (-math.inf, at + slack) if up else (at - slack, math.inf)
    return out


# Stand-in faces for an unbounded side: a vertex this far out says the side is unbounded.
FAR = 1e30


def _plane_rows(leaf) -> tuple[np.ndarray, float]:
    """(n, d): the plane's inside as n . x <= d in world space (n unit)."""
    prim: shapes.PlanePrim = leaf.prim
    m = np.asarray(leaf.m, dtype=np.float64)
    m_inv = np.asarray(leaf.m_inv, dtype=np.float64)
    n = m_inv[:3, :3].T @ prim.n
    n = n / np.linalg.norm(n)
    at = m[:3, :3] @ (prim.n * prim.dist) + m[:3, 3]
    if leaf.inverse:
        n = -n
    return n, float(n @ at)


def _polyhedron(planes: list, box: list[Interval]) -> list[Interval] | None:
    """The box of the planes' half spaces together (and the box so far): the extremes of
    its vertices, every three faces solved, with faces FAR out standing for unbounded
    sides (a vertex out there: that side stays unbounded)."""
    rows = [_plane_rows(p) for p in planes]
    for k in range(3):
        for sign, end in ((1.0, box[k][1]), (-1.0, box[k][0])):
            e = np.zeros(3)
            e[k] = sign
            rows.append((e, sign * end if math.isfinite(end) else FAR))
    if len(rows) > 24:  # the vertices grow as the cube of the faces
        return None
    n = np.array([r[0] for r in rows])
    d = np.array([r[1] for r in rows])
    if not np.all(np.isfinite(n)) or not np.all(np.isfinite(d)):
        return None
    triples = np.array(list(itertools.combinations(range(len(rows)), 3)))
    mats = n[triples]  # (T, 3, 3), every three faces at once
    keep = np.abs(np.linalg.det(mats)) >= 1e-9
    if not keep.any():
        return None
    x = np.linalg.solve(mats[keep], d[triples[keep]][..., None])[..., 0]  # (T', 3)
    slack = 1e-7 * (np.abs(d)[None, :] + np.abs(x).max(axis=1, keepdims=True) + 1.0)
    pts = x[np.all(x @ n.T <= d[None, :] + slack, axis=1)]
    if not len(pts):
        return None
    out: list[Interval] = []
    for k in range(3):
        lo, hi = float(pts[:, k].min()), float(pts[:, k].max())
        out.append((-math.inf if lo <= -FAR / 10 else lo, math.inf if hi >= FAR / 10 else hi))
    return out


def _world_quadric(leaf) -> tuple[np.ndarray, np.ndarray, float]:
    """(A, b, c) with Q(x) = x.A.x + b.x + c in world space (the leaf's inside Q <= 0)."""
    prim: PolyPrim = leaf.prim
    a = np.zeros((3, 3))
    b = np.zeros(3)
    c = 0.0
    for i, j, k, coef in zip(prim.i, prim.j, prim.k, prim.c, strict=True):
        powers = [0] * i + [1] * j + [2] * k  # the axes of the monomial's factors
        if len(powers) == 2:
            p, q = powers
            a[p, q] += coef / 2.0
            a[q, p] += coef / 2.0
        elif len(powers) == 1:
            b[powers[0]] += coef
        else:
            c += float(coef)
    m_inv = np.asarray(leaf.m_inv, dtype=np.float64)
    lin, t = m_inv[:3, :3], m_inv[:3, 3]
    # x_object = lin x + t
    aw = lin.T @ a @ lin
    bw = 2.0 * (t @ a @ lin) + b @ lin
    cw = float(t @ a @ t + b @ t + c)
    return aw, bw, cw


def _tighten(a: np.ndarray, b: np.ndarray, c: float, box: list[Interval]):
    """The box narrowed to where Q <= 0 can hold, or None where it cannot anywhere."""
    # About the quadric's centre (a least-squares one where A is singular) the linear terms
    # vanish but along A's null space (a paraboloid's axis): a term b x over an unbounded
    # x would leave the others unbounded below, though b x + a x^2 is not.
    # a turn by 180 degrees leaves cross terms of 1e-32: over an unbounded box they would
    # bound nothing
    a = np.where(np.abs(a) <= 1e-12 * np.abs(a).max(), 0.0, a)
    centre = -0.5 * (np.linalg.pinv(a, rcond=1e-12) @ b)
    if not np.all(np.isfinite(centre)):
        return box
    c = float(centre @ a @ centre + b @ centre + c)
    b = b + 2.0 * (a @ centre)
    b = np.where(np.abs(b) <= 1e-12 * (np.abs(b).max() + 1.0), 0.0, b)
    at = [(lo - x0, hi - x0) for (lo, hi), x0 in zip(box, centre.tolist(), strict=True)]
    eig = np.linalg.eigvalsh(a)
    if eig.min() > 1e-9 * np.abs(eig).max():
        # an ellipsoid u.A.u <= -c in any turn: its box's half sides sqrt(-c (A^-1)_kk)
        reach = np.sqrt(max(-c, 0.0) * np.diag(np.linalg.inv(a)))
        at = [(max(lo, -r), min(hi, r)) for (lo, hi), r in zip(at, reach.tolist(), strict=True)]
        if any(lo > hi for lo, hi in at):
            return None
    for _ in range(ROUNDS):
        changed = False
        for k in range(3):
            others = [j for j in range(3) if j != k]
            # Q = a_kk u_k^2 + beta u_k + gamma, beta and gamma intervals over the box
            beta = (float(b[k]), float(b[k]))
            for j in others:
                beta = _add(beta, _scale(2.0 * float(a[k, j]), at[j]))
            gamma = (c, c)
            for j in others:
                gamma = _add(gamma, _quadratic(float(a[j, j]), float(b[j]), at[j]))
            p, q = others
            gamma = _add(gamma, _scale(2.0 * float(a[p, q]), _mul(at[p], at[q])))
            span = _solve(float(a[k, k]), beta, gamma)
            if span is None:
                return None
            lo, hi = max(at[k][0], span[0]), min(at[k][1], span[1])
            if lo > hi:
                return None
            if (lo, hi) != at[k]:
                changed = True
                at[k] = (lo, hi)
        if not changed:
            break
    return [(lo + x0, hi + x0) for (lo, hi), x0 in zip(at, centre.tolist(), strict=True)]


def _quadratic(alpha: float, beta: float, x: Interval) -> Interval:
    """The range of alpha u^2 + beta u over u in x."""
    lo, hi = x
    ends = [_times(alpha, u * u) + _times(beta, u) if math.isfinite(u) else _far(alpha, beta, u)
            for u in (lo, hi)]  # fmt: skip
    inner = []
    if alpha != 0.0:
        vertex = -beta / (2.0 * alpha)
        if lo <= vertex <= hi:
            inner.append(alpha * vertex * vertex + beta * vertex)
    values = ends + inner
    return (min(values), max(values))


def _far(alpha: float, beta: float, u: float) -> float:
    """alpha u^2 + beta u as u goes to +-inf."""
    if alpha != 0.0:
        return math.copysign(math.inf, alpha)
    if beta != 0.0:
        return math.copysign(math.inf, beta * u)
    return 0.0


def _solve(a: float, beta: Interval, gamma: Interval) -> Interval | None:
    """The x for which a x^2 + beta x + gamma <= 0 for some beta, gamma in the intervals
    (a hull of them; None: no x)."""
    g = gamma[0]
    if math.isnan(g) or math.isnan(beta[0]) or math.isnan(beta[1]) or g == -math.inf:
        return (-math.inf, math.inf)
    if a > 0.0:
        # a (x + beta / 2a)^2 <= beta^2 / 4a - gamma
        most = max(beta[0] ** 2, beta[1] ** 2) / (4.0 * a) - g
        if most < 0.0:
            return None
        r = math.sqrt(most / a)
        return (-beta[1] / (2.0 * a) - r, -beta[0] / (2.0 * a) + r)
    if a == 0.0 and (beta[0] > 0.0 or beta[1] < 0.0):
        # beta x <= -gamma: one side bounded (a paraboloid's axis)
        if beta[0] > 0.0:
            return (-math.inf, -g / beta[0] if g <= 0.0 else -g / beta[1])
        return (-g / beta[1] if g <= 0.0 else -g / beta[0], math.inf)
    return (-math.inf, math.inf)


def _add(x: Interval, y: Interval) -> Interval:
    return (x[0] + y[0], x[1] + y[1])


def _times(u: float, v: float) -> float:
    return 0.0 if u == 0.0 or v == 0.0 else u * v


def _scale(s: float, x: Interval) -> Interval:
    lo, hi = _times(s, x[0]), _times(s, x[1])
    return (min(lo, hi), max(lo, hi))


def _mul(x: Interval, y: Interval) -> Interval:
    ends = [_times(u, v) for u in x for v in y]
    return (min(ends), max(ends))
