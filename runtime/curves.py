"""Subdivision curves and their tubes.

Schemes (open curves keep their end points; closed curves wrap):
- midpoint(m), the seed's midpoint method: refine Q[2i+1] = (P[i] + P[i+1])/2, smooth
  Q[2i] = (P[i-1] + (m-2)P[i] + P[i+1])/m. Its mask is (1, m/2, m-2, m/2, 1)/m, which is
  the cubic B-spline's (1, 4, 6, 4, 1)/8 for m = 8. With fixed end points the limit is
  the uniform cubic B-spline of the polygon extended by the phantom points 2P0 − P1 and
  2Pn − Pn−1. (The seed says m = 6 gives the cubic B-spline; m = 6's mask
  (1, 3, 4, 3, 1)/6 is a different curve that stays close to it, see tests/test_curves.py.)
- chaikin: corner cutting at 1/4 and 3/4; the open variant splits the end edges at their
  midpoints, which is exactly knot insertion on the clamped quadratic B-spline.
- four_point: Dyn–Levin–Gregory interpolating scheme, (−1, 9, 9, −1)/16; open ends use
  the linearly extrapolated phantom points.
- bezier: one Bézier curve of degree n on all points, split at t = 1/2 by de Casteljau.

Tubes sweep a circle along the polyline with rotation-minimising frames: the frame
rotations are composed by a parallel prefix product of quaternions (log2 N array steps,
no loop per point).

`SubdivisionError`, what a subdivision shape that cannot be built raises, is defined here
for both kinds (runtime.subdivide builds its curves with this module).
"""

from __future__ import annotations

import math

import numpy as np

from lang import ir
from runtime import transform as tf


class SubdivisionError(ValueError):
    """A subdivision shape (a surface, runtime.subdivide, or a curve) that cannot be built;
    `code` matches runtime.subdivide.validate's codes. Defined here, the lower of the two
    modules: the surfaces' module builds its curves with this one."""

    def __init__(self, code: str, message: str):
        super().__init__(message)
        self.code = code
        self.message = message


# Largest tube (vertices) a curve may produce before it is refused as a memory error.
MAX_TUBE_VERTICES = 50_000_000
DEFAULT_SIDES = 16


# ----------------------------------------------------------------- schemes
def midpoint_once(P: np.ndarray, m: float = 6.0, closed: bool = False) -> np.ndarray:
    P = np.asarray(P, dtype=np.float64)
    n = len(P)
    if closed:
        Q = np.empty((2 * n, P.shape[1]))
        nxt = np.roll(P, -1, axis=0)
        Q[1::2] = 0.5 * (P + nxt)
        Q[0::2] = (np.roll(P, 1, axis=0) + (m - 2.0) * P + nxt) / m
        return Q
    Q = np.empty((2 * n - 1, P.shape[1]))
    Q[1::2] = 0.5 * (P[:-1] + P[1:])
    Q[0::2] = P
    Q[2:-1:2] = (P[:-2] + (m - 2.0) * P[1:-1] + P[2:]) / m
    return Q


def chaikin_once(P: np.ndarray, closed: bool = False) -> np.ndarray:
    P = np.asarray(P, dtype=np.float64)
    a = P
    b = np.roll(P, -1, axis=0) if closed else P[1:]
    a = a[: len(b)]
    cuts = np.stack([0.75 * a + 0.25 * b, 0.25 * a + 0.75 * b], axis=1)
    if closed:
        return cuts.reshape(-1, P.shape[1])
    if len(P) == 2:
        return np.stack([P[0], 0.5 * (P[0] + P[1]), P[1]])
    inner = cuts[1:-1].reshape(-1, P.shape[1])
    return np.concatenate([P[:1], 0.5 * (P[:1] + P[1:2]), inner, 0.5 * (P[-2:-1] + P[-1:]), P[-1:]])


def four_point_once(P: np.ndarray, closed: bool = False) -> np.ndarray:
    P = np.asarray(P, dtype=np.float64)
    if closed:
        ext = np.concatenate([P[-1:], P, P[:2]])
    else:
        ext = np.concatenate([2 * P[:1] - P[1:2], P, 2 * P[-1:] - P[-2:-1]])
    # inserted point between ext[i+1] and ext[i+2]
    new = (-ext[:-3] + 9.0 * ext[1:-2] + 9.0 * ext[2:-1] - ext[3:]) / 16.0
    n = len(P)
    count = 2 * n if closed else 2 * n - 1
    Q = np.empty((count, P.shape[1]))
    Q[0::2] = P
    Q[1::2] = new[: len(Q[1::2])]
    return Q


def de_casteljau_split(segments: np.ndarray, t: float = 0.5) -> tuple[np.ndarray, np.ndarray]:
    """Split Bézier segments (S, n+1, D) at t: (left, right) control polygons."""
    rows = segments
    left, right = [rows[:, 0]], [rows[:, -1]]
    for _ in range(segments.shape[1] - 1):
        rows = (1.0 - t) * rows[:, :-1] + t * rows[:, 1:]
        left.append(rows[:, 0])
        right.append(rows[:, -1])
    return np.stack(left, axis=1), np.stack(right[::-1], axis=1)


def bezier_polyline(P: np.ndarray, levels: int) -> np.ndarray:
    """Points of the Bézier curve at t = j / 2**levels, by repeated midpoint splits."""
    seg = np.asarray(P, dtype=np.float64)[None]
    for _ in range(levels):
        left, right = de_casteljau_split(seg)
        seg = np.stack([left, right], axis=1).reshape(-1, *seg.shape[1:])
    return np.concatenate([seg[:, 0], seg[-1:, -1]])


def refine_curve(
    points, scheme: str, levels: int, m: float = 6.0, closed: bool = False
) -> np.ndarray:
    """The polyline after `levels` steps of `scheme` (a closed curve's polyline does not
    repeat its first point)."""
    P = np.asarray(points, dtype=np.float64).reshape(-1, 3)
    if scheme == "bezier":
        return bezier_polyline(np.concatenate([P, P[:1]]) if closed else P, levels)
    step = {
        "midpoint": lambda q: midpoint_once(q, m, closed),
        "chaikin": lambda q: chaikin_once(q, closed),
        "four_point": lambda q: four_point_once(q, closed),
    }.get(scheme)
    if step is None:
        raise SubdivisionError("subdiv.unknown_scheme", f"unknown curve scheme `{scheme}`")
    for _ in range(levels):
        P = step(P)
    return P


# ------------------------------------------------------------------- tubes
def _qmul(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    aw, ax, ay, az = a[..., 0], a[..., 1], a[..., 2], a[..., 3]
    bw, bx, by, bz = b[..., 0], b[..., 1], b[..., 2], b[..., 3]
    return np.stack(
        [
            aw * bw - ax * bx - ay * by - az * bz,
            aw * bx + ax * bw + ay * bz - az * by,
            aw * by - ax * bz + ay * bw + az * bx,
            aw * bz + ax * by - ay * bx + az * bw,
        ],
        axis=-1,
    )


def _qrotate(q: np.ndarray, v: np.ndarray) -> np.ndarray:
    w, u = q[..., :1], q[..., 1:]
    t = 2.0 * np.cross(u, v)
    return v + w * t + np.cross(u, t)


def _min_rotation(t0: np.ndarray, t1: np.ndarray) -> np.ndarray:
    """Unit quaternions turning unit vectors t0 onto t1 about t0 × t1 (the minimal turn)."""
    d = np.einsum("ij,ij->i", t0, t1)
    q = np.concatenate([(1.0 + d)[:, None], np.cross(t0, t1)], axis=1)
    flip = 1.0 + d < 1e-12
    if flip.any():  # a U-turn: any axis perpendicular to t0
        q[flip] = np.concatenate([np.zeros((flip.sum(), 1)), _perpendicular(t0[flip])], axis=1)
    return q / np.linalg.norm(q, axis=1, keepdims=True)


def _perpendicular(t: np.ndarray) -> np.ndarray:
    axis = np.where((np.abs(t[:, 0]) < 0.9)[:, None], [[1.0, 0.0, 0.0]], [[0.0, 1.0, 0.0]])
    p = np.cross(t, axis)
    return p / np.linalg.norm(p, axis=1, keepdims=True)


def _prefix_rotations(q: np.ndarray) -> np.ndarray:
    """out[i] = q[i] q[i-1] … q[0] (Hillis–Steele scan; quaternion products do not
    commute, so the later rotation stays on the left)."""
    out = q.copy()
    shift = 1
    while shift < len(out):
        out[shift:] = _qmul(out[shift:], out[:-shift])
        shift *= 2
    return out


def tube_frames(P: np.ndarray, closed: bool) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Unit tangents T and rotation-minimising normals U, binormals W = T × U per point."""
    seg = np.roll(P, -1, axis=0) - P if closed else P[1:] - P[:-1]
    d = tf.normalize(seg)
    if closed:
        T = tf.normalize(d + np.roll(d, 1, axis=0))
    else:
        T = np.concatenate([d[:1], tf.normalize(d[:-1] + d[1:]), d[-1:]])
    fallback = d if closed else np.concatenate([d, d[-1:]])  # at a U-turn
    T = np.where(np.linalg.norm(T, axis=1, keepdims=True) > 0.5, T, fallback)
    rot = _min_rotation(T[:-1], T[1:])
    acc = _prefix_rotations(rot)
    u0 = _perpendicular(T[:1])
    U = np.concatenate([u0, _qrotate(acc, np.repeat(u0, len(acc), axis=0))])
    if closed and len(P) > 2:
        # close the frame: the twist left after going round is spread evenly
        back = _qrotate(_min_rotation(T[-1:], T[:1]), U[-1:])[0]
        twist = math.atan2(np.dot(np.cross(back, u0[0]), T[0]), np.dot(back, u0[0]))
        ang = twist * np.arange(len(P)) / len(P)
        W0 = np.cross(T, U)
        U = np.cos(ang)[:, None] * U + np.sin(ang)[:, None] * W0
    U = tf.normalize(U - np.einsum("ij,ij->i", U, T)[:, None] * T)
    return T, U, np.cross(T, U)


def tube(
    P: np.ndarray, radius: float, closed: bool = False, sides: int = DEFAULT_SIDES
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """An indexed triangle tube of `radius` around the polyline P, outward winding and
    normals; open tubes get flat end caps."""
    P = np.asarray(P, dtype=np.float64).reshape(-1, 3)
    keep = np.ones(len(P), dtype=bool)
    keep[1:] = np.linalg.norm(P[1:] - P[:-1], axis=1) > 0  # repeated points have no tangent
    P = P[keep]
    if closed and len(P) > 1 and np.allclose(P[0], P[-1]):
        P = P[:-1]
    if len(P) < 2:
        raise SubdivisionError("subdiv.curve_points", "the curve collapses to a point")
    N, S = len(P), sides
    if N * (S + 2) > MAX_TUBE_VERTICES:
        raise SubdivisionError(
            "subdiv.memory",
            f"the curve's tube would have {N * S:,} vertices; use fewer levels",
        )
    T, U, W = tube_frames(P, closed)
    phi = 2.0 * np.pi * np.arange(S) / S
    normals = np.cos(phi)[None, :, None] * U[:, None] + np.sin(phi)[None, :, None] * W[:, None]
    verts = (P[:, None] + radius * normals).reshape(-1, 3)
    normals = normals.reshape(-1, 3)
    rings = N if closed else N - 1
    i = np.arange(rings)[:, None]
    k = np.arange(S)[None, :]
    a = i * S + k
    b = ((i + 1) % N) * S + k
    c = ((i + 1) % N) * S + (k + 1) % S
    d = i * S + (k + 1) % S
    faces = np.concatenate(
        [np.stack([a, c, b], -1).reshape(-1, 3), np.stack([a, d, c], -1).reshape(-1, 3)]
    )
    if not closed:
        caps_v, caps_n, caps_f = [], [], []
        base = len(verts)
        for end, sign in ((0, -1.0), (N - 1, 1.0)):
            ring = verts[end * S : (end + 1) * S]
            centre = base
            caps_v.append(np.concatenate([P[end : end + 1], ring]))
            caps_n.append(np.repeat(sign * T[end : end + 1], S + 1, axis=0))
            r0 = centre + 1 + np.arange(S)
            r1 = centre + 1 + (np.arange(S) + 1) % S
            cen = np.full(S, centre)
            tri = np.stack([cen, r0, r1], 1) if sign > 0 else np.stack([cen, r1, r0], 1)
            caps_f.append(tri)
            base += S + 1
        verts = np.concatenate([verts, *caps_v])
        normals = np.concatenate([normals, *caps_n])
        faces = np.concatenate([faces, *caps_f])
    return verts, faces.astype(np.int32), normals


def curve_mesh(
    shape: ir.Subdivision, levels: int, sides: int = DEFAULT_SIDES
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The tube around a subdivision curve after `levels` steps."""
    npts = len(shape.points) * 2 ** max(levels, 0)
    if npts * sides > MAX_TUBE_VERTICES:
        raise SubdivisionError(
            "subdiv.memory",
            f"{levels} levels would give the curve about {npts:,} points; use fewer levels",
        )
    P = refine_curve(shape.points, shape.scheme, levels, shape.m, shape.closed)
    return tube(P, shape.radius, shape.closed, sides)
