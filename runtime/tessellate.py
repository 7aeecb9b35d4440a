"""Adaptive tessellation of NURBS surfaces and curves (as tubes) into indexed triangle meshes.

Surfaces: the parameter domain is cut into one tensor grid for the whole surface. Each knot
span owns its own grid lines in u (and in v), so span boundaries are the knots themselves and
a single grid is watertight by construction: every edge between two cells has the same two
vertices on both sides. The lines are found by measuring: every cell's two triangles are
compared with the true surface at their edge midpoints and centroids (at the same parameters,
a bound on the distance to the surface), and a span whose cells miss the chord-error bound
gets its lines re-placed by equidistributing sqrt(error density) (chord error ~ h^2 g), which
also gives their number; passes repeat until every measured point is within `tolerance`.
Refinement is therefore adaptive per span and, inside a span, per row/column of the grid
(not per cell: that is the price of a crack-free tensor grid).

Closed surfaces are welded: a seam whose two boundary columns (or rows) coincide shares one
column of vertices, and a boundary that collapses to a point (the pole of a sphere) becomes one
vertex; triangles that collapse with it are dropped. So a sphere or a torus comes out as a
closed 2-manifold: every edge is shared by exactly two triangles. `TriMesh.corner_uvs` keeps
each triangle corner's own parameters (a seam vertex is u = 0 on one side, u = 1 on the other).

Normals and uvs come from the exact surface (`Surface.normals_from_derivatives`), never from
the triangles. Curves become tubes: rings around the curve on a rotation-minimising frame
(double reflection, Wang et al. 2008), mitre joints at kinks, closed curves closed up with
the frame's twist distributed along the length, open ends capped flat.
"""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass

import numpy as np

from lang import ir
from runtime import transform as tf
from runtime.nurbs import Curve, KnotVector, Surface, validate

# Refinement aims below the bound so that one more pass is rarely needed.
TARGET = 0.85
# At most this many refinement passes; each one re-measures the whole grid.
MAX_PASSES = 12
# A span never grows by more than this factor in one pass (the h^2 model is asymptotic).
MAX_GROWTH = 32.0
# Default ceiling on the triangle count of one surface: beyond it the tolerance is given up
# (with a warning) rather than the memory of the machine.
MAX_TRIANGLES = 4_000_000
# Coincidence test for seams and poles, relative to the net's size plus its distance from the
# origin: evaluations of identical control rows agree to a few ulps, distinct ones differ by
# far more than this.
WELD_REL = 1e-10


@dataclass(frozen=True)
class TriMesh:
    vertices: np.ndarray  # (N, 3) float64
    faces: np.ndarray  # (M, 3) int32
    normals: np.ndarray  # (N, 3) float64, unit
    uvs: np.ndarray  # (N, 2) float64 in [0, 1]
    max_error: float  # largest measured chord error (world units, object space)
    capped: bool = False  # True when MAX_TRIANGLES stopped refinement early
    # (M, 3, 2) each triangle corner's own uv. Welded seam and pole vertices keep one uv in
    # `uvs`, but a triangle on the seam needs u = 1, not 0, to interpolate its parameters: use
    # these to map a hit's barycentric coordinates back to (u, v) (e.g. for exact normals).
    corner_uvs: np.ndarray | None = None


def nurbs_mesh(shape: ir.Nurbs, tolerance: float, max_triangles: int = MAX_TRIANGLES):
    """(vertices (N,3) f64, faces (M,3) i32, normals (N,3) f64, uvs (N,2) f64) of a NURBS
    surface, or of the tube around a NURBS curve (`shape.nv == 0`), to chord error
    `tolerance` (object-space units). A shape that fails `nurbs.validate` (one that reached
    the renderer without the evaluator's checks, e.g. from an edited IR document) raises
    ValueError naming its problems, which the caller reports at the object's source."""
    problems = validate(shape)
    if problems:
        raise ValueError("; ".join(problems))
    m = tessellate(shape, tolerance, max_triangles)
    return m.vertices, m.faces, m.normals, m.uvs


def object_tolerance(tolerance: float, transform) -> float:
    """A world-space chord-error bound in the shape's own units. The net is tessellated before
    the object's transform is applied, and a transform can stretch an error by at most its
    largest singular value, so the bound is divided by that (a `scale 10` needs ten times
    finer triangles in object space)."""
    m = np.asarray(transform, dtype=np.float64)[:3, :3]
    stretch = float(np.linalg.svd(m, compute_uv=False)[0])
    return tolerance / stretch if stretch > 0 else tolerance


def tessellate(shape: ir.Nurbs, tolerance: float, max_triangles: int = MAX_TRIANGLES) -> TriMesh:
    if not tolerance > 0:
        raise ValueError(f"tolerance must be positive, got {tolerance}")
    if shape.nv == 0:
        return tube_mesh(Curve.from_ir(shape), shape.radius, tolerance, max_triangles)
    return surface_mesh(Surface.from_ir(shape), tolerance, max_triangles)


# ---------------------------------------------------------------------------- grids
class Axis:
    """The grid's parameters along one direction, kept per knot span so that span boundaries
    are the knots themselves (creases at repeated knots stay exact) and each span can be
    refined on its own."""

    def __init__(self, kv: KnotVector, count: int):
        self.kv = kv
        self.parts = []
        for s in kv.spans:
            a, b = kv.knots[s], kv.knots[s + 1]
            self.parts.append(a + (b - a) * (np.arange(count) / count))

    @property
    def params(self) -> np.ndarray:
        return np.concatenate(self.parts + [np.array([self.kv.hi])])

    @property
    def cell_span(self) -> np.ndarray:
        return np.repeat(np.arange(len(self.parts)), [len(p) for p in self.parts])

    @property
    def cells(self) -> int:
        return sum(len(p) for p in self.parts)

    def refine(self, need: np.ndarray, tol: float) -> bool:
        """Re-place the points of every span whose cells miss the bound (`need`: the error of
        each cell). Chord error grows like h^2 g with a local density g, so cells are
        equidistributed in the integral of sqrt(g / (TARGET tol)), which also gives their
        number (de Boor's equidistribution); a failing span gains at least one cell so the
        passes cannot cycle. Returns whether anything changed."""
        t = self.params
        h = np.diff(t)
        cs = self.cell_span
        changed = False
        for s, part in enumerate(self.parts):
            sel = cs == s
            e = need[sel]
            if e.max() <= tol:
                continue
            hs = h[sel]
            if not (hs > 0).all():
                # Knots an ulp apart: a span too narrow to split in floats (the surface
                # jumps there, as at a repeated knot); refining it would divide by zero.
                continue
            g = e / hs**2
            # A cell measured exact (a straight stretch) still gets a little density, so no
            # new cell grows more than ~1000x at once on an error model made for small cells.
            g = np.maximum(g, g.max() * 1e-6)
            mass = np.sqrt(g / (TARGET * tol)) * hs
            n_old = len(part)
            n = int(np.ceil(mass.sum()))
            n = min(max(n, n_old + 1), int(n_old * MAX_GROWTH) + 1)
            edges = np.concatenate([part, [t[np.flatnonzero(sel)[-1] + 1]]])
            cum = np.concatenate([[0.0], np.cumsum(mass)])
            new = np.interp(cum[-1] * np.arange(n) / n, cum, edges)
            new[0] = part[0]
            self.parts[s] = new
            changed = True
        return changed


def _err(exact: np.ndarray, approx: np.ndarray) -> np.ndarray:
    return np.linalg.norm(exact - approx, axis=-1)


def _measure(surf: Surface, us: np.ndarray, vs: np.ndarray, P: np.ndarray):
    """Chord errors of the grid's triangles, per cell: (e_u, e_v, e_mixed), each (nv-1, nu-1).

    Each cell (u_i..u_i+1, v_j..v_j+1) is cut along its (u_i, v_j)-(u_i+1, v_j+1) diagonal.
    The surface is compared with the triangles at edge midpoints (u edges, v edges, the
    diagonal) and at both triangle centroids, each a tensor grid of its own."""
    hu = np.diff(us)
    hv = np.diff(vs)
    uh, vh = us[:-1] + 0.5 * hu, vs[:-1] + 0.5 * hv

    def grid(a, b):
        return surf.grid_derivatives(a, b, 0)[0, 0]

    # Midpoints of u-edges (rows j, cells i) and v-edges; each cell takes its two edges.
    eu_edges = _err(grid(uh, vs), 0.5 * (P[:, :-1] + P[:, 1:]))  # (nv, nu-1)
    ev_edges = _err(grid(us, vh), 0.5 * (P[:-1] + P[1:]))  # (nv-1, nu)
    e_u = np.maximum(eu_edges[:-1], eu_edges[1:])
    e_v = np.maximum(ev_edges[:, :-1], ev_edges[:, 1:])
    p00, p10, p01, p11 = P[:-1, :-1], P[:-1, 1:], P[1:, :-1], P[1:, 1:]
    e_d = _err(grid(uh, vh), 0.5 * (p00 + p11))
    ca = grid(us[:-1] + hu * (2 / 3), vs[:-1] + hv * (1 / 3))
    cb = grid(us[:-1] + hu * (1 / 3), vs[:-1] + hv * (2 / 3))
    e_a = _err(ca, (p00 + p10 + p11) / 3)
    e_b = _err(cb, (p00 + p11 + p01) / 3)
    e_m = np.maximum(e_d, np.maximum(e_a, e_b))
    return e_u, e_v, e_m


def surface_mesh(surf: Surface, tol: float, max_triangles: int = MAX_TRIANGLES) -> TriMesh:
    U = Axis(surf.ukv, max(1, surf.u_degree))
    V = Axis(surf.vkv, max(1, surf.v_degree))
    capped = False
    for _ in range(MAX_PASSES):
        us, vs = U.params, V.params
        P = surf.grid_derivatives(us, vs, 0)[0, 0]
        e_u, e_v, e_m = _measure(surf, us, vs, P)
        worst = float(max(e_u.max(), e_v.max(), e_m.max()))
        if worst <= tol:
            break
        # Mixed (diagonal, centroid) error is charged in full to the direction(s) whose own
        # edge error is at least a third of the total; a pure twist (both edge errors ~0) to
        # both.
        share_u = np.where(e_u + e_v > 0, e_u / np.maximum(e_u + e_v, 1e-300), 0.5)
        need_u = np.maximum(e_u, np.where(share_u >= 1 / 3, e_m, 0.0))
        need_v = np.maximum(e_v, np.where(share_u <= 2 / 3, e_m, 0.0))
        old = (list(U.parts), list(V.parts))
        changed = U.refine(need_u.max(axis=0), tol)
        changed = V.refine(need_v.max(axis=1), tol) or changed
        if 2 * U.cells * V.cells > max_triangles:
            U.parts, V.parts = old
            capped = True
            break
        if not changed:
            break
    if capped or worst > tol:
        warnings.warn(
            f"nurbs tessellation reached {worst:.3g} instead of the tolerance {tol:.3g}"
            + (f" (capped at {max_triangles} triangles)" if capped else ""),
            RuntimeWarning,
            stacklevel=2,
        )
    return assemble(surf, us, vs, worst, capped)


def assemble(surf: Surface, us, vs, worst: float, capped: bool) -> TriMesh:
    """The triangle mesh of `surf` sampled on the grid us x vs (positions, normals, uvs),
    with its chord error `worst`; shared by NURBS and Bezier patches (runtime.bezier)."""
    D = surf.grid_derivatives(us, vs, 1)
    nv, nu = len(vs), len(us)
    P = D[0, 0].reshape(-1, 3)
    uu = np.broadcast_to(us[None, :], (nv, nu)).reshape(-1)
    vv = np.broadcast_to(vs[:, None], (nv, nu)).reshape(-1)
    N = surf.normals_from_derivatives(D.reshape(2, 2, -1, 3), uu, vv)
    (u0, u1), (v0, v1) = surf.domain
    uv = np.stack([(uu - u0) / (u1 - u0), (vv - v0) / (v1 - v0)], axis=1)

    idx = np.arange(nv * nu).reshape(nv, nu)
    a, b = idx[:-1, :-1].ravel(), idx[:-1, 1:].ravel()
    c, d = idx[1:, 1:].ravel(), idx[1:, :-1].ravel()
    faces = np.concatenate([np.stack([a, b, c], 1), np.stack([a, c, d], 1)])

    rep = np.arange(nv * nu)
    G = P.reshape(nv, nu, 3)
    eps = WELD_REL * (surf.scale + float(np.abs(G).max()))

    def close(x, y):
        return bool(np.all(np.linalg.norm(x - y, axis=-1) <= eps))

    # Seams first (the last column/row becomes the first), then poles (a boundary collapsed
    # to a point becomes its first vertex); composing the maps keeps shared corners shared.
    if close(G[:, 0], G[:, -1]):
        rep[idx[:, -1]] = rep[idx[:, 0]]
    if close(G[0], G[-1]):
        rep[idx[-1]] = rep[idx[0]]
    for line in (idx[0], idx[-1], idx[:, 0], idx[:, -1]):
        pts = P[line]
        if close(pts, pts[:1]):
            rep[line] = rep[line[0]]
    while not np.array_equal(rep[rep], rep):  # chains: a seam vertex on a pole, a corner
        rep = rep[rep]
    grid_faces = faces
    faces = rep[faces]
    keep = (
        (faces[:, 0] != faces[:, 1]) & (faces[:, 1] != faces[:, 2]) & (faces[:, 0] != faces[:, 2])
    )
    faces = faces[keep]
    used, inv = np.unique(faces, return_inverse=True)
    faces = inv.reshape(-1, 3).astype(np.int32)
    corner_uvs = uv[grid_faces[keep]]
    return TriMesh(P[used], faces, N[used], uv[used], worst, capped, corner_uvs)


def _tangents(curve: Curve, ts: np.ndarray, left: bool = False) -> tuple[np.ndarray, np.ndarray]:
    """Points and unit tangents (right-hand, or with `left` the left-hand limits at knots);
    where C' vanishes (coincident control points) the tangent is the direction of C'' (the
    limit of C'/|C'|), then the chord to the next sample."""
    D = curve.derivatives(ts, 2, left)
    C, t1, t2 = D[0], D[1], D[2]
    scale = float(np.linalg.norm(np.ptp(C, axis=0))) + 1e-300
    lo, hi = curve.domain
    l1 = np.linalg.norm(t1, axis=-1)
    T = t1.copy()
    weak = l1 <= 1e-9 * scale / (hi - lo)
    if weak.any():
        # Moving into the domain, C' ~ e C'': point the tangent along +C'' at the start side.
        sgn = np.where(ts >= 0.5 * (lo + hi), -1.0, 1.0)[:, None]
        T[weak] = (sgn * t2)[weak]
    still = np.linalg.norm(T, axis=-1) <= 1e-300
    if still.any():
        chord = np.diff(C, axis=0, append=C[-1:] + (C[-1:] - C[-2:-1]))
        T[still] = chord[still]
    T = tf.normalize(T)
    T[np.linalg.norm(T, axis=-1) == 0] = (0.0, 0.0, 1.0)
    return C, T


def _curve_samples(curve: Curve, radius: float, tol: float, max_rings: int):
    axis = Axis(curve.kv, max(1, curve.degree))
    budget = 0.5 * tol  # half for the centreline and the bending of the rings
    worst = math.inf
    for _ in range(MAX_PASSES):
        ts = axis.params
        C, T = _tangents(curve, ts)
        _, T_in = _tangents(curve, ts, left=True)
        mid = curve.points(ts[:-1] + 0.5 * np.diff(ts))
        e_c = _err(mid, 0.5 * (C[:-1] + C[1:]))
        # The turn inside each segment (leaving i, arriving at i+1): a kink at a knot is a
        # mitre joint, not something finer steps could smooth.
        cosang = np.clip(np.sum(T[:-1] * T_in[1:], axis=-1), -1.0, 1.0)
        half = 0.5 * np.arccos(cosang)
        # The outside of a bend of the tube is a circle of radius (rho + r): its sagitta is the
        # centreline's plus r(1 - cos(half the turn)).
        e = e_c + radius * (1.0 - np.cos(half))
        worst = float(e.max())
        if worst <= budget:
            break
        old = list(axis.parts)
        if not axis.refine(e, budget):
            break
        if axis.cells + 1 > max_rings:
            axis.parts = old
            break
    ts = axis.params
    C, T = _tangents(curve, ts)
    return ts, C, T, worst


def _turn(v: np.ndarray, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """v turned by the smallest rotation taking unit a to unit b (Rodrigues). For a U-turn
    the axis is v itself, which keeps a vector perpendicular to a unchanged."""
    axis = np.cross(a, b)
    s2 = float(axis @ axis)
    c = float(a @ b)
    if s2 < 1e-24:
        return v.copy()
    return v * c + np.cross(axis, v) + axis * float(axis @ v) * (1.0 - c) / s2


def _perp_unit(r: np.ndarray, t: np.ndarray) -> np.ndarray:
    r = r - float(r @ t) * t
    nr = float(np.linalg.norm(r))
    if nr < 1e-12:
        r = np.cross(t, np.eye(3)[int(np.argmin(np.abs(t)))])
        nr = float(np.linalg.norm(r))
    return r / nr


def _rmf(C: np.ndarray, T_in: np.ndarray, T_out: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Rotation-minimising reference vectors by double reflection (Wang et al. 2008): one
    perpendicular to the arriving tangent and one to the leaving tangent at every sample (they
    differ only at kinks, where the smallest rotation turns one into the other). Inherently
    sequential, one step per ring."""
    n = len(C)
    R_in = np.empty_like(C)
    R_out = np.empty_like(C)
    r = _perp_unit(np.cross(T_out[0], np.eye(3)[int(np.argmin(np.abs(T_out[0])))]), T_out[0])
    R_in[0] = _turn(r, T_out[0], T_in[0])
    R_out[0] = r
    for i in range(n - 1):
        v1 = C[i + 1] - C[i]
        c1 = float(v1 @ v1)
        t0 = T_out[i]
        if c1 > 0:
            rl = r - (2.0 / c1) * float(v1 @ r) * v1
            tl = t0 - (2.0 / c1) * float(v1 @ t0) * v1
        else:
            rl, tl = r, t0
        v2 = T_in[i + 1] - tl
        c2 = float(v2 @ v2)
        r = rl - (2.0 / c2) * float(v2 @ rl) * v2 if c2 > 0 else rl
        r = _perp_unit(r, T_in[i + 1])  # drift over many steps
        R_in[i + 1] = r
        r = _perp_unit(_turn(r, T_in[i + 1], T_out[i + 1]), T_out[i + 1])
        R_out[i + 1] = r
    return R_in, R_out


def _rotate_about(r: np.ndarray, t: np.ndarray, ang: np.ndarray) -> np.ndarray:
    b = np.cross(t, r)
    return np.cos(ang)[:, None] * r + np.sin(ang)[:, None] * b


def tube_mesh(
    curve: Curve, radius: float, tol: float, max_triangles: int = MAX_TRIANGLES
) -> TriMesh:
    """A tube of `radius` around the curve. Rings follow a rotation-minimising frame; at a
    kink (a knot where the tangent jumps: degree 1, or full multiplicity) the ring lies in
    the bisecting plane (a mitre joint), with one copy of its vertices per side so each side
    keeps its own normals. A closed curve closes the tube (the frame's twist spread along the
    length); an open one gets flat caps."""
    if not radius > 0:
        raise ValueError(f"a tube needs a positive radius, got {radius}")
    # Ring: a regular polygon's chord error r(1 - cos(pi/k)) within half the tolerance.
    x = min(1.0, 0.5 * tol / radius)
    k = max(3, math.ceil(math.pi / math.acos(1.0 - x))) if x < 1.0 else 3
    max_rings = max(2, max_triangles // (2 * k))
    ts, C, T, worst = _curve_samples(curve, radius, tol, max_rings)
    _, T_left = _tangents(curve, ts, left=True)
    lo, hi = curve.domain
    scale = float(np.linalg.norm(np.ptp(C, axis=0)))
    eps = WELD_REL * (scale + float(np.abs(C).max()))
    closed = bool(np.linalg.norm(C[-1] - C[0]) <= eps) and len(ts) > 2
    T_in, T_out = T_left.copy(), T.copy()
    T_in[0] = T_left[-1] if closed else T[0]
    T_out[-1] = T_out[0] if closed else T_left[-1]
    R_in, R_out = _rmf(C, T_in, T_out)
    n = len(ts)
    m = n - 1 if closed else n  # rings
    if closed:
        # The frame comes back turned by the curve's total torsion: spread the correction
        # along the arc length so the last ring meets the first.
        rN = R_out[-1]
        phi = math.atan2(float(np.cross(rN, R_out[0]) @ T_out[0]), float(rN @ R_out[0]))
        s = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(C, axis=0), axis=1))])
        ang = phi * s / max(s[-1], 1e-300)
        R_in = np.stack(
            [_rotate_about(R_in[i : i + 1], T_in[i], ang[i : i + 1])[0] for i in range(n)]
        )
        R_out = np.stack(
            [_rotate_about(R_out[i : i + 1], T_out[i], ang[i : i + 1])[0] for i in range(n)]
        )
    C, T_in, T_out, R_in, R_out = C[:m], T_in[:m], T_out[:m], R_in[:m], R_out[:m]
    theta = 2.0 * np.pi * np.arange(k) / k
    cos_t, sin_t = np.cos(theta)[None, :, None], np.sin(theta)[None, :, None]
    d_in = cos_t * R_in[:, None] + sin_t * np.cross(T_in, R_in)[:, None]
    d_out = cos_t * R_out[:, None] + sin_t * np.cross(T_out, R_out)[:, None]
    kink = np.sum(T_in * T_out, axis=1) < 1.0 - 1e-12
    mitre = T_in + T_out
    ml = np.linalg.norm(mitre, axis=1)
    kink &= ml > 1e-6  # a full U-turn has no mitre plane: plain rings there
    P = C[:, None] + radius * d_out
    if kink.any():
        M = mitre[kink] / ml[kink, None]
        ti = T_in[kink]
        lam = -radius * np.einsum("rkc,rc->rk", d_in[kink], M) / np.sum(ti * M, 1)[:, None]
        P[kink] = C[kink][:, None] + radius * d_in[kink] + lam[..., None] * ti[:, None]
    tn = (ts[:m] - lo) / (hi - lo)
    ring_uv = np.stack(np.broadcast_arrays(tn[:, None], (np.arange(k) / k)[None, :]), -1)
    kinks = np.flatnonzero(kink)
    verts = [P.reshape(-1, 3), P[kinks].reshape(-1, 3)]
    norms = [d_out.reshape(-1, 3), d_in[kinks].reshape(-1, 3)]
    uvs = [ring_uv.reshape(-1, 2), ring_uv[kinks].reshape(-1, 2)]
    out_block = np.arange(m)
    in_block = np.arange(m)
    in_block[kinks] = m + np.arange(len(kinks))
    i = np.arange(n - 1)[:, None]
    j = np.arange(k)[None, :]
    nxt = (i + 1) % m
    a = out_block[i] * k + j
    b = out_block[i] * k + (j + 1) % k
    c = in_block[nxt] * k + (j + 1) % k
    d = in_block[nxt] * k + j
    faces = [
        np.stack([a.ravel(), b.ravel(), c.ravel()], 1),
        np.stack([a.ravel(), c.ravel(), d.ravel()], 1),
    ]
    if not closed:
        base = (m + len(kinks)) * k
        jj = np.arange(k)
        for block, tangent, sign in ((out_block[0], T_out[0], -1.0), (in_block[-1], T_in[-1], 1.0)):
            ring = np.concatenate(verts)[block * k : (block + 1) * k]
            end = 0 if sign < 0 else m - 1
            verts += [C[end][None], ring]
            norms += [np.repeat((sign * tangent)[None], k + 1, axis=0)]
            uvs += [np.array([[tn[end], 0.5]]), ring_uv[end]]
            r0 = base + 1 + jj
            r1 = base + 1 + (jj + 1) % k
            cc = np.full(k, base)
            faces.append(np.stack([cc, r1, r0] if sign < 0 else [cc, r0, r1], 1))
            base += k + 1
    return TriMesh(
        np.concatenate(verts),
        np.concatenate(faces).astype(np.int32),
        np.concatenate(norms),
        np.concatenate(uvs),
        worst + radius * (1.0 - math.cos(math.pi / k)),
        False,
    )
