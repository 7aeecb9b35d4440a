"""Subdivision surfaces: Catmull–Clark, Loop and bilinear refinement, with the features
OpenSubdiv users rely on: boundaries (`sharp`: edges and corners, `smooth`: edges only),
infinitely sharp and semi-sharp creases with fractional sharpness (DeRose, Kass & Truong
1998), corner vertices, limit positions and limit normals from tangent masks.

Everything is array code. The control mesh's topology (half-edges, edges, twins) comes
from one numpy sort of integer edge keys; each refined level derives its tables from its
parent's by index arithmetic, without sorting. Every rule is a scatter (`bincount`) over
corners or edges. No Python loop runs per vertex or per face; the only Python loops run
per level, per coordinate, and, when walking vertex rings, per ring position (at most the
largest valence).

Creases follow DeRose, Kass & Truong's uniform rule (OpenSubdiv's default, not its
Chaikin variant): both halves of an edge of sharpness s get s − 1, an edge with
0 < s < 1 blends the smooth and sharp edge rules, and a vertex whose rule changes during
a step blends the two rules by the mean sharpness of the edges that stop being sharp.
Limits: smooth vertices use the closed-form limit and tangent masks; darts (one sharp
edge) and the sectors of crease and boundary vertices use masks read off the
eigenvectors of their ring's subdivision matrix (one small eigenproblem per valence or
sector size), so limit points and normals are exact there too. A vertex on infinitely
sharp edges is split into one output vertex per sector, each with its one-sided normal;
a corner's sector takes the plane of its two sharp edges; one-face Catmull–Clark crease
sectors take the angle-weighted face normal.

Vertex numbering is stable: a refined mesh keeps the parent's vertices first (then face
points, then edge points), so a control vertex keeps its index at every level. Limit
evaluation uses this: a vertex's limit point and normal are the same at every level.

`subdivision_mesh` (and `tessellate`, `validate`, `levels_for_tolerance`) take any
subdivision shape: a curve (no faces) is tubed by runtime.curves.
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass
from itertools import chain

import numpy as np

from lang import ir
from runtime import transform as tf
from runtime.curves import SubdivisionError, curve_mesh

SURFACE_SCHEMES = ("catmull_clark", "loop", "bilinear")
CURVE_SCHEMES = ("midpoint", "chaikin", "four_point", "bezier")
BOUNDARY_MODES = ("sharp", "smooth")

# Vertex rules (OpenSubdiv's names): smooth (also darts), crease (two sharp edges),
# corner (an explicit corner, three or more sharp edges, or an isolated vertex).
SMOOTH, CREASE, CORNER = 0, 1, 2

# Index type of the per-corner and per-edge tables: int32 halves the memory traffic (and,
# on machines where fresh pages are dear, the page faults) of int64; `check_memory` keeps
# every count below 2**31. Keys that multiply two indices are computed in int64.
IDX = np.int32

# Part of the free memory one level may claim before it is refused (the estimate is rough
# and numpy needs temporaries while the next level is being built).
MEMORY_FRACTION = 0.6
# Bytes per output vertex and per output face corner while a level is built, pushed to the
# limit and shaded (peak measured with tracemalloc: about 250 bytes per output corner for
# Catmull–Clark, 200 for Loop, everything included).
_BYTES_PER_VERTEX = 3 * 8 * 10
_BYTES_PER_CORNER = 8 * 24


# ------------------------------------------------------------------ the mesh
@dataclass
class ControlMesh:
    """A polygon mesh at one level. Faces are flat: `fv` holds every face's vertex indices
    one after another, `fsize` each face's size. Creases are vertex pairs with sharpness
    (inf: infinitely sharp); boundary edges are found from the topology, never listed."""

    points: np.ndarray  # (V,3) float64
    fv: np.ndarray  # (C,) int64
    fsize: np.ndarray  # (F,) int64
    crease_pairs: np.ndarray  # (K,2) int64
    crease_sharpness: np.ndarray  # (K,) float64
    corner: np.ndarray  # (V,) bool: explicit corner vertices
    _topo: Topology | None = None
    # per-edge sharpness aligned with `_topo.edges`, set by refinement (which knows each
    # child edge's parent); without it the crease pairs are looked up by edge key
    _edge_sharp: np.ndarray | None = None
    # the last rings built, with the sharp-edge mask they were built for (normals and the
    # shading split usually ask for the same rings)
    _rings: tuple[np.ndarray, Rings] | None = None

    @property
    def nv(self) -> int:
        return len(self.points)

    @property
    def nf(self) -> int:
        return len(self.fsize)

    @property
    def fstart(self) -> np.ndarray:
        return np.concatenate(([0], np.cumsum(self.fsize)[:-1])).astype(np.int64)

    def all_size(self, k: int) -> bool:
        return bool(np.all(self.fsize == k))

    @property
    def topology(self) -> Topology:
        if self._topo is None:
            self._topo = build_topology(self)
            self._edge_sharp = None  # aligned with a refined topology only
            self._rings = None
        return self._topo

    @classmethod
    def from_lists(
        cls,
        points,
        faces,
        creases=(),
        corners=(),
    ) -> ControlMesh:
        pts = np.asarray(points, dtype=np.float64).reshape(-1, 3)
        fsize = np.fromiter(map(len, faces), dtype=np.int64, count=len(faces))
        fv = np.fromiter(chain.from_iterable(faces), dtype=np.int64, count=int(fsize.sum()))
        cr = np.asarray([c[:2] for c in creases], dtype=np.int64).reshape(-1, 2)
        cs = np.asarray([c[2] for c in creases], dtype=np.float64).reshape(-1)
        corner = np.zeros(len(pts), dtype=bool)
        if len(corners):
            corner[np.asarray(corners, dtype=np.int64)] = True
        return cls(pts, fv, fsize, cr, cs, corner)

    @classmethod
    def from_shape(cls, shape: ir.Subdivision) -> ControlMesh:
        return cls.from_lists(shape.points, shape.faces, shape.creases, shape.corners)

    def triangles(self, corner_index: np.ndarray | None = None) -> np.ndarray:
        """(T,3) int64: quads split along their first diagonal, n-gons fanned from their
        first corner. `corner_index` maps each corner to an output vertex (default fv)."""
        idx = self.fv if corner_index is None else corner_index
        start = self.fstart
        ntri = self.fsize - 2
        face = np.repeat(np.arange(self.nf), ntri)
        k = np.arange(len(face)) - np.repeat(np.cumsum(ntri) - ntri, ntri)
        s = start[face]
        return np.stack([idx[s], idx[s + k + 1], idx[s + k + 2]], axis=1)


# ---------------------------------------------------------------- topology
@dataclass
class Topology:
    """Half-edge tables of one level. Corner c (face `face[c]`, vertex fv[c]) is also the
    half-edge fv[c] -> fv[nxt[c]]; `twin[c]` is the opposite half-edge or -1 on a
    boundary. `edge[c]` numbers undirected edges; `edges[e]` = (low, high) vertex."""

    face: np.ndarray
    nxt: np.ndarray
    prv: np.ndarray
    edge: np.ndarray
    edges: np.ndarray
    edge_nf: np.ndarray
    ekeys: np.ndarray | None  # sorted keys low*V + high (None: built by refinement)
    twin: np.ndarray
    dup_directed: int  # half-edges that repeat an existing direction (orientation errors)


def build_topology(mesh: ControlMesh) -> Topology:
    nv, fv, fsize = mesh.nv, mesh.fv, mesh.fsize
    c = np.arange(len(fv), dtype=np.int64)
    start = mesh.fstart
    face = np.repeat(np.arange(mesh.nf, dtype=np.int64), fsize)
    first = start[face]
    last = first + fsize[face] - 1
    nxt = np.where(c == last, first, c + 1)
    prv = np.where(c == first, last, c - 1)
    a, b = fv, fv[nxt]
    lo, hi = np.minimum(a, b), np.maximum(a, b)
    # one sort of the undirected edge keys gives edge ids, face counts and twins: the two
    # half-edges of a manifold edge sit next to each other in the sorted order
    ukey = lo.astype(np.int64) * nv + hi
    order = np.argsort(ukey)
    sk = ukey[order]
    run_start = np.ones(len(sk), dtype=bool)
    run_start[1:] = sk[1:] != sk[:-1]
    starts = np.nonzero(run_start)[0]
    edge = np.empty(len(sk), dtype=np.int64)
    edge[order] = np.cumsum(run_start) - 1
    ekeys = sk[starts]
    edge_nf = np.diff(np.append(starts, len(sk)))
    edges = np.stack([ekeys // nv, ekeys % nv], axis=1)
    pair = starts[edge_nf == 2]
    c0, c1 = order[pair], order[pair + 1]
    twin = np.full(len(sk), -1, dtype=np.int64)
    twin[c0], twin[c1] = c1, c0
    dup = int(np.count_nonzero(fv[c0] == fv[c1]))  # both run the same way
    t_face, t_nxt, t_prv, t_edge, t_edges, t_twin = (
        x.astype(IDX) for x in (face, nxt, prv, edge, edges, twin)
    )
    return Topology(t_face, t_nxt, t_prv, t_edge, t_edges, edge_nf, ekeys, t_twin, dup)


def _scatter(index: np.ndarray, values: np.ndarray, n: int) -> np.ndarray:
    """Sum (N,3) or (N,) values into n bins (bincount per column: faster than add.at)."""
    if values.ndim == 1:
        return np.bincount(index, weights=values, minlength=n)
    out = np.empty((n, values.shape[1]))
    for k in range(values.shape[1]):
        out[:, k] = np.bincount(index, weights=values[:, k], minlength=n)
    return out


def _edge_count(edges: np.ndarray, weights: np.ndarray, n: int) -> np.ndarray:
    """Per-vertex sum of a per-edge quantity over the vertex's incident edges."""
    w = weights.astype(np.float64)
    return np.bincount(edges[:, 0], w, n) + np.bincount(edges[:, 1], w, n)


def _neighbour_sum(points: np.ndarray, edges: np.ndarray, mask, n: int) -> np.ndarray:
    """Per vertex, the sum of the other ends of its incident edges (those in `mask`)."""
    e = edges if mask is None else edges[mask]
    return _scatter(e[:, 0], points[e[:, 1]], n) + _scatter(e[:, 1], points[e[:, 0]], n)


def edge_sharpness(mesh: ControlMesh, topo: Topology | None = None) -> np.ndarray:
    """Per-edge sharpness: crease values where given, inf on boundary edges, else 0."""
    topo = topo or mesh.topology
    if mesh._edge_sharp is not None:
        s = mesh._edge_sharp.copy()
        s[topo.edge_nf == 1] = np.inf
        return s
    s = np.zeros(len(topo.edges))
    if len(mesh.crease_pairs):
        ekeys, order = topo.ekeys, None
        if ekeys is None:  # a refined topology's edges are not in key order
            all_keys = topo.edges[:, 0].astype(np.int64) * mesh.nv + topo.edges[:, 1]
            order = np.argsort(all_keys)
            ekeys = all_keys[order]
        p = mesh.crease_pairs
        keys = np.minimum(p[:, 0], p[:, 1]) * mesh.nv + np.maximum(p[:, 0], p[:, 1])
        pos = np.minimum(np.searchsorted(ekeys, keys), len(ekeys) - 1)
        ok = ekeys[pos] == keys
        pos = pos if order is None else order[pos]
        np.maximum.at(s, pos[ok], mesh.crease_sharpness[ok])
    s[topo.edge_nf == 1] = np.inf
    return s


@dataclass
class VertexRules:
    parent: np.ndarray  # rule from edges sharp at this level (sharpness > 0)
    child: np.ndarray  # rule from edges still sharp after this step (sharpness > 1)
    weight: np.ndarray  # fractional weight of the parent rule where the two differ
    crease_sum_parent: np.ndarray  # (V,3) sum of the sharp neighbours (parent)
    crease_sum_child: np.ndarray


def _rule(corner: np.ndarray, nsharp: np.ndarray) -> np.ndarray:
    return np.where(corner | (nsharp > 2), CORNER, np.where(nsharp == 2, CREASE, SMOOTH))


def vertex_rules(mesh: ControlMesh, s: np.ndarray, boundary: str) -> VertexRules:
    topo = mesh.topology
    V, P, edges = mesh.nv, mesh.points, topo.edges
    nfaces = np.bincount(mesh.fv, minlength=V)
    corner = mesh.corner | (nfaces == 0)
    if boundary == "sharp":
        # edge-and-corner: a boundary vertex of a single face is a corner (a quad's corner)
        on_boundary = _edge_count(edges, topo.edge_nf == 1, V) > 0
        corner = corner | (on_boundary & (nfaces == 1))
    par, chi = s > 0, s > 1
    if not par.any() and not corner.any():  # the common smooth closed mesh
        smooth = np.full(V, SMOOTH)
        zero = np.zeros((V, 3))
        return VertexRules(smooth, smooth, np.ones(V), zero, zero)
    rp = _rule(corner, _edge_count(edges, par, V))
    rc = _rule(corner, _edge_count(edges, chi, V))
    # OpenSubdiv's fractional weight: the mean sharpness of the edges that stop being sharp
    trans = par & ~chi
    tcount = _edge_count(edges, trans, V)
    tsum = _edge_count(edges, np.where(trans, s, 0.0), V)
    w = np.clip(tsum / np.maximum(tcount, 1), 0.0, 1.0)
    w = np.where(tcount > 0, w, 1.0)
    return VertexRules(
        rp, rc, w, _neighbour_sum(P, edges, par, V), _neighbour_sum(P, edges, chi, V)
    )


def _apply_vertex_rules(P: np.ndarray, smooth: np.ndarray, r: VertexRules) -> np.ndarray:
    if not r.parent.any() and not r.child.any():  # SMOOTH == 0 everywhere
        return smooth
    crease_p = (r.crease_sum_parent + 6.0 * P) / 8.0
    crease_c = (r.crease_sum_child + 6.0 * P) / 8.0
    pos_p = np.where(
        (r.parent == SMOOTH)[:, None], smooth, np.where((r.parent == CREASE)[:, None], crease_p, P)
    )
    pos_c = np.where(
        (r.child == SMOOTH)[:, None], smooth, np.where((r.child == CREASE)[:, None], crease_c, P)
    )
    w = r.weight[:, None]
    return np.where((r.parent == r.child)[:, None], pos_p, w * pos_p + (1.0 - w) * pos_c)


def _blend_edge_points(P, edges, s, smooth) -> np.ndarray:
    mid = 0.5 * (P[edges[:, 0]] + P[edges[:, 1]])
    sc = np.clip(s, 0.0, 1.0)[:, None]
    return sc * mid + (1.0 - sc) * smooth


def _child_creases(mesh: ControlMesh, s: np.ndarray, edge_point_base: int):
    """Each parent edge with sharpness > 1 becomes two child edges of sharpness s - 1
    (DeRose's rule; inf stays inf). Boundary edges are found again from the topology."""
    topo = mesh.topology
    ids = np.nonzero((s > 1) & (topo.edge_nf == 2))[0]
    ep = edge_point_base + ids
    pairs = np.concatenate(
        [np.stack([topo.edges[ids, 0], ep], 1), np.stack([topo.edges[ids, 1], ep], 1)]
    )
    child_s = np.concatenate([s[ids] - 1.0, s[ids] - 1.0])
    return pairs.astype(np.int64), child_s


def _half_edge_side(topo: Topology, e: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Child edge id of the half of parent edge e that touches vertex v."""
    return 2 * e + (v != topo.edges[e, 0])


def _interleave(*parts: np.ndarray) -> np.ndarray:
    """[a0, b0, c0, a1, b1, c1, …]: strided stores, no (N,k) temporary."""
    k = len(parts)
    out = np.empty(k * len(parts[0]), dtype=np.result_type(*parts))
    for i, p in enumerate(parts):
        out[i::k] = p
    return out


def _cyclic(n: int, k: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """face, next and previous corner of n corners in faces of k corners each."""
    i = np.arange(n, dtype=IDX)
    nxt, prv = i + 1, i - 1
    nxt[k - 1 :: k] -= k
    prv[0::k] += k
    return i // k, nxt, prv


def _child_edges(topo: Topology, edge_point: np.ndarray, inner: tuple[np.ndarray, np.ndarray]):
    """Child edge table: parent edge e → 2e (low end, EP) and 2e+1 (high end, EP), then
    the inner edges given as two vertex arrays; face counts follow the parent's."""
    E, K = len(topo.edges), len(inner[0])
    edges = np.empty((2 * E + K, 2), dtype=IDX)
    edges[0 : 2 * E : 2, 0] = topo.edges[:, 0]
    edges[1 : 2 * E : 2, 0] = topo.edges[:, 1]
    edges[0 : 2 * E, 1] = np.repeat(edge_point, 2)
    edges[2 * E :, 0] = np.minimum(*inner)
    edges[2 * E :, 1] = np.maximum(*inner)
    nf = np.full(2 * E + K, 2, dtype=topo.edge_nf.dtype)
    nf[: 2 * E] = np.repeat(topo.edge_nf, 2)
    return edges, nf


def _child_sharpness(s: np.ndarray, inner: int) -> np.ndarray:
    """DeRose's rule: both halves of an edge of sharpness s get s − 1 (inf stays inf)."""
    return np.concatenate([np.repeat(np.where(s > 1, s - 1.0, 0.0), 2), np.zeros(inner)])


def _quad_child_topology(mesh: ControlMesh, nfp: int) -> Topology:
    """Topology of the quads made by `_quads_from_corners`, derived from the parent's
    without any sorting. Child corner 4c+k of parent corner c: k=0 the old vertex, 1 the
    out-edge's point, 2 the face point, 3 the in-edge's point. The first half of parent
    half-edge h is child half-edge 4h, its second half 4·nxt(h)+3."""
    topo, V, fv = mesh.topology, mesh.nv, mesh.fv
    C, E = len(fv), len(topo.edges)
    c = np.arange(C, dtype=IDX)
    tw, nx, pv = topo.twin, topo.nxt, topo.prv
    twp = tw[pv]
    twin = _interleave(
        np.where(tw >= 0, 4 * nx[np.maximum(tw, 0)] + 3, -1),
        4 * nx + 2,
        4 * pv + 1,
        np.where(twp >= 0, 4 * np.maximum(twp, 0), -1),
    )
    edge = _interleave(
        _half_edge_side(topo, topo.edge, fv),
        2 * E + c,
        2 * E + pv,
        _half_edge_side(topo, topo.edge[pv], fv),
    )
    edges, edge_nf = _child_edges(
        topo, V + nfp + np.arange(E, dtype=IDX), (V + topo.face, V + nfp + topo.edge)
    )
    face, nxt, prv = _cyclic(4 * C, 4)
    return Topology(face, nxt, prv, edge, edges, edge_nf, None, twin, 0)


def _loop_child_topology(mesh: ControlMesh) -> Topology:
    """Topology of Loop's children, derived from the parent's without sorting. Parent
    corner c = 3f+k gives the corner triangle 4f+k with child corners 12f+3k+(0,1,2)
    (old vertex, out-edge point, in-edge point); the centre triangle 4f+3 has corners
    12f+9+i on the edge points of corners 3f+i."""
    topo, V, fv = mesh.topology, mesh.nv, mesh.fv
    C, E = len(fv), len(topo.edges)
    c = np.arange(C, dtype=IDX)
    f, k = c // 3, c % 3
    tw, nx, pv = topo.twin, topo.nxt, topo.prv
    twp = tw[pv]

    def tri(corner):  # first child corner of the corner triangle of a parent corner
        return 12 * (corner // 3) + 3 * (corner % 3)

    t0 = np.where(tw >= 0, tri(nx[np.maximum(tw, 0)]) + 2, -1)
    t1 = 12 * f + 9 + (k + 2) % 3
    t2 = np.where(twp >= 0, tri(np.maximum(twp, 0)), -1)
    twin = np.empty(12 * (C // 3), dtype=IDX)
    e0 = _half_edge_side(topo, topo.edge, fv)
    e2 = _half_edge_side(topo, topo.edge[pv], fv)
    edge = np.empty_like(twin)
    tc = tri(c)
    twin[tc], twin[tc + 1], twin[tc + 2] = t0, t1, t2
    edge[tc], edge[tc + 1], edge[tc + 2] = e0, 2 * E + c, e2
    # centre corner 12f+9+i runs from the point of edge 3f+i to that of 3f+i+1
    cn = 3 * f + (k + 1) % 3
    centre = 12 * f + 9 + k
    twin[centre] = tri(cn) + 1
    edge[centre] = 2 * E + cn
    edges, edge_nf = _child_edges(
        topo, V + np.arange(E, dtype=IDX), (V + topo.edge, V + topo.edge[pv])
    )
    face, nxt, prv = _cyclic(12 * (C // 3), 3)
    return Topology(face, nxt, prv, edge, edges, edge_nf, None, twin, 0)


def _quads_from_corners(mesh: ControlMesh, nfp: int) -> np.ndarray:
    """Catmull–Clark / bilinear children: one quad per parent corner
    (vertex, edge point of its out-edge, face point, edge point of its in-edge)."""
    topo, V = mesh.topology, mesh.nv
    eb = V + nfp
    return _interleave(mesh.fv, eb + topo.edge, V + topo.face, eb + topo.edge[topo.prv])


def _quad_child(mesh: ControlMesh, s: np.ndarray, vp, fp, ep) -> ControlMesh:
    """The all-quad child mesh of one face-split step (Catmull–Clark, bilinear) from its new
    vertex, face and edge points; creases, corners and sharpness carry over."""
    V, F, E = mesh.nv, mesh.nf, len(mesh.topology.edges)
    pairs, cs = _child_creases(mesh, s, V + F)
    return ControlMesh(
        np.concatenate([vp, fp, ep]),
        _quads_from_corners(mesh, F),
        np.full(len(mesh.fv), 4, dtype=np.int64),
        pairs,
        cs,
        np.concatenate([mesh.corner, np.zeros(F + E, dtype=bool)]),
        _quad_child_topology(mesh, F),
        _child_sharpness(s, len(mesh.fv)),
    )


def catmull_clark_once(mesh: ControlMesh, boundary: str = "sharp") -> ControlMesh:
    """One Catmull–Clark step on any polygons (the result is all quads)."""
    topo, P, V, F = mesh.topology, mesh.points, mesh.nv, mesh.nf
    E = len(topo.edges)
    s = edge_sharpness(mesh, topo)
    fp = _scatter(topo.face, P[mesh.fv], F) / mesh.fsize[:, None]
    a, b = topo.edges[:, 0], topo.edges[:, 1]
    fsum = _scatter(topo.edge, fp[topo.face], E)
    smooth_e = (P[a] + P[b] + fsum) / (2.0 + topo.edge_nf)[:, None]
    ep = _blend_edge_points(P, topo.edges, s, smooth_e)
    n = np.maximum(np.bincount(mesh.fv, minlength=V), 1).astype(np.float64)[:, None]
    fsum_v = _scatter(mesh.fv, fp[topo.face], V)
    esum_v = _neighbour_sum(P, topo.edges, None, V)
    smooth_v = (n - 2.0) / n * P + (esum_v + fsum_v) / (n * n)
    vp = _apply_vertex_rules(P, smooth_v, vertex_rules(mesh, s, boundary))
    return _quad_child(mesh, s, vp, fp, ep)


def bilinear_once(mesh: ControlMesh, boundary: str = "sharp") -> ControlMesh:
    """One bilinear step: face centroids and edge midpoints, vertices stay."""
    topo, P, F = mesh.topology, mesh.points, mesh.nf
    fp = _scatter(topo.face, P[mesh.fv], F) / mesh.fsize[:, None]
    ep = 0.5 * (P[topo.edges[:, 0]] + P[topo.edges[:, 1]])
    s = edge_sharpness(mesh, topo)
    return _quad_child(mesh, s, P, fp, ep)


def loop_beta(n: np.ndarray | int) -> np.ndarray:
    """Loop's β(n) = (5/8 − (3/8 + ¼cos(2π/n))²)/n; 1/16 for the seed's valence 6."""
    n = np.maximum(np.asarray(n, dtype=np.float64), 1.0)
    return (0.625 - (0.375 + 0.25 * np.cos(2.0 * np.pi / n)) ** 2) / n


def loop_once(mesh: ControlMesh, boundary: str = "sharp") -> ControlMesh:
    """One Loop step (triangles only; `validate` rejects other faces)."""
    topo, P, V, F = mesh.topology, mesh.points, mesh.nv, mesh.nf
    E = len(topo.edges)
    s = edge_sharpness(mesh, topo)
    a, b = topo.edges[:, 0], topo.edges[:, 1]
    # the vertex opposite half-edge c in its triangle is the corner before c
    osum = _scatter(topo.edge, P[mesh.fv[topo.prv]], E)
    smooth_e = 0.375 * (P[a] + P[b]) + 0.125 * osum
    ep = _blend_edge_points(P, topo.edges, s, smooth_e)
    n = _edge_count(topo.edges, np.ones(E), V)
    beta = loop_beta(n)[:, None]
    smooth_v = (1.0 - n[:, None] * beta) * P + beta * _neighbour_sum(P, topo.edges, None, V)
    vp = _apply_vertex_rules(P, smooth_v, vertex_rules(mesh, s, boundary))
    e_out, e_in = V + topo.edge, V + topo.edge[topo.prv]
    corner_tris = np.stack([mesh.fv, e_out, e_in], axis=1).reshape(F, 3, 3)
    centre = e_out.reshape(F, 3)[:, None, :]
    faces = np.concatenate([corner_tris, centre], axis=1).reshape(-1)
    pairs, cs = _child_creases(mesh, s, V)
    return ControlMesh(
        np.concatenate([vp, ep]),
        faces,
        np.full(4 * F, 3, dtype=np.int64),
        pairs,
        cs,
        np.concatenate([mesh.corner, np.zeros(E, dtype=bool)]),
        _loop_child_topology(mesh),
        _child_sharpness(s, len(mesh.fv)),
    )


_STEPS = {"catmull_clark": catmull_clark_once, "loop": loop_once, "bilinear": bilinear_once}


def subdivide_once(mesh: ControlMesh, scheme: str, boundary: str = "sharp") -> ControlMesh:
    try:
        step = _STEPS[scheme]
    except KeyError:
        raise SubdivisionError("subdiv.unknown_scheme", _unknown_scheme(scheme)) from None
    return step(mesh, boundary)


# ------------------------------------------------------------------ memory
def _available_memory() -> int:
    try:
        with open("/proc/meminfo") as f:
            for line in f:
                if line.startswith("MemAvailable:"):
                    return int(line.split()[1]) * 1024
    except OSError:
        pass
    try:
        return os.sysconf("SC_AVPHYS_PAGES") * os.sysconf("SC_PAGE_SIZE")
    except (ValueError, OSError):
        return 8 << 30


def next_level_size(mesh: ControlMesh, scheme: str, steps: int = 1) -> tuple[int, int, int]:
    """(vertices, faces, corners) of the level `steps` below `mesh`, without building it
    (counted exactly: a step's counts follow from the last one's)."""
    V, F, C, E = mesh.nv, mesh.nf, len(mesh.fv), len(mesh.topology.edges)
    for _ in range(steps):  # one iteration per level, on four integers
        if scheme == "loop":
            V, F, C, E = V + E, 4 * F, 12 * F, 2 * E + 3 * F
        else:  # one quad per corner; one inner edge per corner
            V, F, C, E = V + F + E, C, 4 * C, 2 * E + C
    return V, F, C


def check_memory(
    mesh: ControlMesh, scheme: str, level: int, max_bytes: int | None, steps: int = 1
) -> None:
    """Refuse a level that would not fit, before building it: `level` is the level that
    lies `steps` below `mesh`."""
    v, f, c = next_level_size(mesh, scheme, steps)
    need = v * _BYTES_PER_VERTEX + c * _BYTES_PER_CORNER
    budget = max_bytes if max_bytes is not None else int(MEMORY_FRACTION * _available_memory())
    if need > budget or max(v, c) >= 2**31 - 1:
        raise SubdivisionError(
            "subdiv.memory",
            f"subdivision level {level} would have {f:,} faces and {v:,} vertices and need "
            f"about {need / 2**30:.2f} GiB, more than the {budget / 2**30:.2f} GiB allowed; "
            "use fewer levels",
        )


# ------------------------------------------------------------ limit surface
def _remaining_semi_sharp(mesh: ControlMesh) -> float:
    s = edge_sharpness(mesh)
    finite = s[np.isfinite(s)]
    return float(finite.max()) if finite.size else 0.0


def limit_ready(mesh: ControlMesh, scheme: str, boundary: str, max_bytes=None) -> ControlMesh:
    """A mesh on which the limit masks are exact: Catmull–Clark needs all quads, and no
    semi-sharp edge may remain (their rules change with the level). Refines as needed;
    the vertices of `mesh` keep their indices in the result."""
    steps = math.ceil(_remaining_semi_sharp(mesh))
    if scheme == "catmull_clark" and not mesh.all_size(4):
        steps = max(steps, 1)
    if scheme == "bilinear":
        steps = 0
    for k in range(steps):
        check_memory(mesh, scheme, k + 1, max_bytes)
        mesh = subdivide_once(mesh, scheme, boundary)
    return mesh


def limit_positions(mesh: ControlMesh, scheme: str, boundary: str = "sharp") -> np.ndarray:
    """Limit positions of the vertices of a `limit_ready` mesh: smooth vertices by the
    scheme's limit mask, crease vertices by the cubic B-spline's (1,4,1)/6, corners stay."""
    P = mesh.points
    if scheme == "bilinear":
        return P.copy()
    topo, V = mesh.topology, mesh.nv
    s = edge_sharpness(mesh, topo)
    r = vertex_rules(mesh, s, boundary)
    esum = _neighbour_sum(P, topo.edges, None, V)
    if scheme == "catmull_clark":
        n = np.maximum(np.bincount(mesh.fv, minlength=V), 1).astype(np.float64)[:, None]
        diag = mesh.fv[topo.nxt[topo.nxt]]
        Pt = np.ascontiguousarray(P.T)
        dsum = np.stack([np.bincount(mesh.fv, Pt[k][diag], V) for k in range(3)], axis=1)
        smooth = (n * n * P + 4.0 * esum + dsum) / (n * (n + 5.0))
    else:
        n = _edge_count(topo.edges, np.ones(len(topo.edges)), V)
        beta = loop_beta(n)
        chi = (1.0 / (3.0 / (8.0 * beta) + n))[:, None]
        smooth = (1.0 - n[:, None] * chi) * P + chi * esum
    crease = (r.crease_sum_parent + 4.0 * P) / 6.0
    out = np.where(
        (r.parent == SMOOTH)[:, None], smooth, np.where((r.parent == CREASE)[:, None], crease, P)
    )
    darts = find_darts(mesh, s, r)
    if darts is not None:
        out[darts.vertices] = darts.apply(P, 0)
    return out


def dart_matrix(scheme: str, n: int) -> np.ndarray:
    """The subdivision matrix of a dart's 1-ring (valence n, the sharp edge to e_0).
    Catmull–Clark: [centre, e_0..e_n-1, f_0..f_n-1] (f_j the far corner of the quad
    between e_j and e_j+1); Loop: [centre, e_0..e_n-1]. The rules are the ones the
    refinement applies: smooth vertex rule at the centre, smooth edge rule except on the
    sharp edge (its midpoint), face points."""
    if scheme == "catmull_clark":
        m = 2 * n + 1
        F = np.zeros((n, m))
        for j in range(n):  # loops over one small matrix's rows, not over mesh elements
            F[j, [0, 1 + j, 1 + n + j, 1 + (j + 1) % n]] += 0.25
        S = np.zeros((m, m))
        S[0, 0] = (n - 2) / n
        S[0, 1 : 1 + n] += 1.0 / n**2
        S[0] += F.sum(axis=0) / n**2
        for j in range(n):
            S[1 + j] = 0.25 * (F[j - 1] + F[j])
            S[1 + j, 0] += 0.25
            S[1 + j, 1 + j] += 0.25
        S[1] = 0.0
        S[1, [0, 1]] = 0.5
        S[1 + n :] = F
        return S
    m = n + 1
    beta = float(loop_beta(n))
    S = np.zeros((m, m))
    S[0, 0] = 1.0 - n * beta
    S[0, 1:] = beta
    for j in range(n):
        S[1 + j, [0, 1 + j]] += 0.375
        S[1 + j, 1 + (j - 1) % n] += 0.125
        S[1 + j, 1 + (j + 1) % n] += 0.125
    S[1] = 0.0
    S[1, [0, 1]] = 0.5
    return S


def dart_masks(scheme: str, n: int) -> np.ndarray:
    """(3, m) masks over a dart's 1-ring: the limit point (left eigenvector of eigenvalue
    1, summing to 1) and two tangents (the left eigenvectors of the subdominant pair;
    real and imaginary parts when they are complex). The smooth closed forms assume a
    rotationally symmetric ring, which a dart's sharp edge breaks."""
    St = dart_matrix(scheme, n).T
    w, vec = np.linalg.eig(St)
    order = np.argsort(-np.abs(w), kind="stable")
    limit = np.real(vec[:, order[0]])
    limit /= limit.sum()
    # The tangents span the real invariant plane of the subdominant pair l1, l2: two real
    # eigenvalues, a complex pair, or a double one (Catmull–Clark valence 4: 1/2 twice).
    # eig's vectors for a double eigenvalue of this non-symmetric matrix can come back
    # nearly parallel (which ones depends on the BLAS kernel, so it varied from run to
    # run: a zero normal now and then). The plane is the null space of the real matrix
    # (St - l1)(St - l2) = St^2 - (l1 + l2) St + l1 l2 in every case; an SVD finds it.
    l1, l2 = w[order[1]], w[order[2]]
    pencil = St @ St - np.real(l1 + l2) * St + np.real(l1 * l2) * np.eye(len(St))
    basis = np.linalg.svd(pencil)[2][-2:]
    return np.stack([limit, basis[0], basis[1]])


@dataclass
class Darts:
    """Per-corner ring weights for the dart vertices of a mesh."""

    vertices: np.ndarray  # (D,) dart vertex ids
    row: np.ndarray  # (K,) the dart (0..D-1) of each of the darts' corners
    centre: np.ndarray  # (3, D) centre weights: limit, tangent 1, tangent 2
    edge_w: np.ndarray  # (3, K) weights of each corner's edge neighbour e_j
    face_w: np.ndarray  # (3, K) weights of its face neighbour f_j (Catmull–Clark)
    en: np.ndarray  # (K,) edge neighbour vertex ids
    dn: np.ndarray | None  # (K,) face neighbour vertex ids (Catmull–Clark)

    def apply(self, P: np.ndarray, mask: int) -> np.ndarray:
        """(D,3): mask `mask` (0 the limit point, 1 and 2 the tangents) applied to P."""
        terms = self.edge_w[mask][:, None] * P[self.en]
        if self.dn is not None:
            terms = terms + self.face_w[mask][:, None] * P[self.dn]
        centre = self.centre[mask][:, None] * P[self.vertices]
        return centre + _scatter(self.row, terms, len(self.vertices))


def find_darts(mesh: ControlMesh, s: np.ndarray, r: VertexRules) -> Darts | None:
    """Smooth-rule vertices with exactly one sharp edge (darts) in a closed fan of quads
    (Catmull–Clark) or triangles (Loop), with their eigen-analysed masks."""
    sharp = s > 0
    if not sharp.any():
        return None
    topo, V, fv = mesh.topology, mesh.nv, mesh.fv
    count = _edge_count(topo.edges, sharp, V)
    cand = (r.parent == SMOOTH) & (count == 1)
    if not cand.any():
        return None
    rings = build_rings(mesh, sharp)
    open_corners = np.bincount(fv, weights=(~rings.closed).astype(np.float64), minlength=V)
    fans = np.bincount(fv[rings.j == 0], minlength=V)
    cand &= (open_corners == 0) & (fans == 1)
    if not cand.any():
        return None
    scheme = "catmull_clark" if mesh.all_size(4) else "loop" if mesh.all_size(3) else None
    if scheme is None:
        return None
    verts = np.nonzero(cand)[0]
    slot = np.full(V, -1, dtype=np.int64)
    slot[verts] = np.arange(len(verts))
    corners = np.nonzero(cand[fv])[0]
    j, n = rings.j[corners], rings.size[corners]
    centre = np.zeros((3, len(verts)))
    edge_w = np.zeros((3, len(corners)))
    face_w = np.zeros((3, len(corners)))
    valence_of = np.bincount(fv[corners], minlength=V)[verts]
    for valence in np.unique(n):  # one small eigenproblem per distinct valence
        masks = dart_masks(scheme, int(valence))
        sel = n == valence
        edge_w[:, sel] = masks[:, 1 + j[sel]]
        if scheme == "catmull_clark":
            face_w[:, sel] = masks[:, 1 + valence + j[sel]]
        centre[:, valence_of == valence] = masks[:, :1]
    nx = topo.nxt[corners]
    dn = fv[topo.nxt[nx]] if scheme == "catmull_clark" else None
    return Darts(verts, slot[fv[corners]], centre, edge_w, face_w, fv[nx], dn)


@dataclass
class Rings:
    """Corners ordered around their vertex: `j` is the ring position (counter-clockwise
    seen from the side the winding faces), `fan` the first corner of the corner's fan
    (a vertex has one fan unless it is non-manifold), `sector` counts the sharp edges
    crossed since the fan's start, `size` the corners in the corner's fan, `closed` whether
    the fan goes all the way round."""

    j: np.ndarray
    fan: np.ndarray
    sector: np.ndarray
    size: np.ndarray
    closed: np.ndarray
    rep: np.ndarray  # the first corner of the corner's sector: one per output vertex


def build_rings(mesh: ControlMesh, sharp: np.ndarray) -> Rings:
    """Walk all vertex rings at once, one ring position per iteration. A boundary fan
    starts at its corner whose out-edge is on the boundary; a closed fan starts after a
    sharp edge when it has one (so sectors never wrap)."""
    if mesh._rings is not None and np.array_equal(mesh._rings[0], sharp):
        return mesh._rings[1]
    rings = _walk_rings(mesh, sharp)
    mesh._rings = (sharp.copy(), rings)
    return rings


def _walk_rings(mesh: ControlMesh, sharp: np.ndarray) -> Rings:
    topo, fv = mesh.topology, mesh.fv
    C = len(fv)
    rot = np.where(topo.twin[topo.prv] >= 0, topo.twin[topo.prv], -1)
    j = np.full(C, -1, dtype=IDX)
    fan = np.full(C, -1, dtype=IDX)
    sector = np.zeros(C, dtype=IDX)
    rep = np.full(C, -1, dtype=IDX)
    step_sharp = sharp[topo.edge[topo.prv]]

    def walk(starts: np.ndarray) -> None:
        cur, fid, sec, first, k = starts, starts, np.zeros(len(starts), IDX), starts, 0
        while cur.size:
            j[cur], fan[cur], sector[cur], rep[cur] = k, fid, sec, first
            nx = rot[cur]
            ok = nx >= 0
            ok[ok] = j[nx[ok]] < 0
            crossed = step_sharp[cur]
            sec = sec + crossed
            first = np.where(crossed, nx, first)
            cur, fid, sec, first, k = nx[ok], fid[ok], sec[ok], first[ok], k + 1

    walk(np.nonzero(topo.twin < 0)[0])
    while True:
        rest = np.nonzero(j < 0)[0]
        if rest.size == 0:
            break
        # one start per vertex (any corner will do; a corner after a sharp edge wins)
        pick = np.full(mesh.nv, -1, dtype=IDX)
        pick[fv[rest]] = rest
        after_sharp = rest[sharp[topo.edge[rest]]]
        pick[fv[after_sharp]] = after_sharp
        walk(pick[pick >= 0])
    size = np.bincount(fan, minlength=C)[fan]
    return Rings(j, fan, sector, size, topo.twin[fan] >= 0, rep)


def smooth_limit_normals(mesh: ControlMesh, scheme: str, boundary: str = "sharp"):
    """Limit normals of the smooth vertices of a `limit_ready` mesh from the tangent masks
    (Halstead et al. for Catmull–Clark, cos/sin masks for Loop). Returns (normals (V,3),
    mask (V,) of the vertices they are exact for: smooth, manifold, interior)."""
    topo, P, V, fv = mesh.topology, mesh.points, mesh.nv, mesh.fv
    s = edge_sharpness(mesh, topo)
    r = vertex_rules(mesh, s, boundary)
    rings = build_rings(mesh, s > 0)
    fans = np.bincount(fv[rings.j == 0], minlength=V)
    open_corners = np.bincount(fv, weights=(~rings.closed).astype(np.float64), minlength=V)
    ok = (r.parent == SMOOTH) & (fans == 1) & (open_corners == 0)
    if scheme == "bilinear":
        return np.zeros((V, 3)), np.zeros(V, dtype=bool)
    en = fv[topo.nxt]  # the edge neighbour e_j of each corner
    Pt = np.ascontiguousarray(P.T)  # gathers per coordinate keep the temporaries 1-D
    t1, t2 = np.empty((V, 3)), np.empty((V, 3))
    if scheme == "catmull_clark":
        dn = fv[topo.nxt[topo.nxt]]  # the face-diagonal neighbour f_j
        w1e, w1d, w2e, w2d = _tangent_weights(rings.j, rings.size)
        for k in range(3):
            ek, dk = Pt[k][en], Pt[k][dn]
            t1[:, k] = np.bincount(fv, w1e * ek + w1d * dk, V)
            t2[:, k] = np.bincount(fv, w2e * ek + w2d * dk, V)
    else:
        th = 2.0 * np.pi * rings.j / rings.size
        c, sn = np.cos(th), np.sin(th)
        for k in range(3):
            ek = Pt[k][en]
            t1[:, k] = np.bincount(fv, c * ek, V)
            t2[:, k] = np.bincount(fv, sn * ek, V)
    normals = tf.normalize(np.cross(t1, t2))
    darts = find_darts(mesh, s, r)
    if darts is not None:
        dn = tf.normalize(np.cross(darts.apply(P, 1), darts.apply(P, 2)))
        # eigenvectors have no sign: turn each dart normal to its faces' side
        cn = np.cross(P[fv[topo.nxt]] - P[fv], P[fv[topo.prv]] - P[fv])
        side = _scatter(fv, cn, V)[darts.vertices]
        flip = np.einsum("ij,ij->i", dn, side) < 0
        dn[flip] *= -1.0
        normals[darts.vertices] = dn
    return normals, ok


def _cc_tangent_table(n: np.ndarray, j: np.ndarray):
    """Catmull–Clark's tangent masks (Halstead et al.): edge neighbour e_j weighs
    A·cos(θj), face neighbour f_j weighs cos(θj) + cos(θj+1) (and sin for the second
    tangent), θj = 2πj/n, A(n) = 1 + cos(2π/n) + cos(π/n)·sqrt(2(9 + cos(2π/n)))."""
    step = 2.0 * np.pi / n
    A = 1.0 + np.cos(step) + np.cos(step / 2) * np.sqrt(2.0 * (9.0 + np.cos(step)))
    th = j * step
    return (
        A * np.cos(th),
        np.cos(th) + np.cos(th + step),
        A * np.sin(th),
        np.sin(th) + np.sin(th + step),
    )


def _tangent_weights(j: np.ndarray, n: np.ndarray):
    """Per-corner tangent weights; valences are small integers, so they come from a
    (valence × ring position) table unless some valence is huge."""
    top = int(n.max()) if n.size else 1
    if top > 512:
        return _cc_tangent_table(n.astype(np.float64), j.astype(np.float64))
    nn, jj = np.meshgrid(np.arange(1, top + 1.0), np.arange(top + 1.0), indexing="ij")
    flat = (n - 1) * (top + 1) + j
    return tuple(np.take(t.ravel(), flat) for t in _cc_tangent_table(nn, jj))


def _crease_tangents(mesh: ControlMesh, inf_sharp: np.ndarray) -> np.ndarray:
    """(V,3) limit tangent e_b − e_a along an infinitely sharp crease (zero elsewhere)."""
    V, edges = mesh.nv, mesh.topology.edges[inf_sharp]
    ends = np.concatenate([edges[:, 0], edges[:, 1]])
    other = np.concatenate([edges[:, 1], edges[:, 0]])
    order = np.argsort(ends, kind="stable")
    ends, other = ends[order], other[order]
    count = np.bincount(ends, minlength=V)
    t = np.zeros((V, 3))
    two = count[ends] == 2
    firsts = np.ones(len(ends), dtype=bool)
    firsts[1:] = ends[1:] != ends[:-1]
    i = np.nonzero(two & firsts)[0]
    t[ends[i]] = mesh.points[other[i + 1]] - mesh.points[other[i]]
    return t


def shade(
    mesh: ControlMesh,
    positions: np.ndarray,
    smooth_normals: np.ndarray,
    smooth_mask: np.ndarray,
    scheme: str,
    boundary: str = "sharp",
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Output vertices, per-corner output index and normals. A vertex is split into one
    output vertex per sector between infinitely sharp edges (a crease has two normals).
    Smooth vertices take the tangent-mask normal; each sector of a crease (or boundary)
    vertex takes its one-sided limit normal from the crease tangent and the sector's
    eigen-analysed cross tangent; a corner's sector between two sharp edges takes the
    plane of those edges. The rest (cone points: corners with fewer than two sharp edges
    in a sector; vertices with a semi-sharp edge of their own, until it decays) take
    angle-weighted face normals, made perpendicular to a crease's limit tangent."""
    topo, V, fv = mesh.topology, mesh.nv, mesh.fv
    s = edge_sharpness(mesh, topo)
    inf_sharp = np.isinf(s)
    if scheme == "bilinear":
        inf_sharp = np.ones_like(inf_sharp)
    rings = build_rings(mesh, inf_sharp)
    # one output vertex per sector, numbered without sorting: sectors are identified by
    # their first corner; a vertex's first sector (lowest corner) keeps its index
    C = len(fv)
    is_rep = rings.rep == np.arange(C)
    reps = np.nonzero(is_rep)[0]
    group = (np.cumsum(is_rep) - 1)[rings.rep]
    gvert = fv[reps]
    G = len(reps)
    lowest = np.full(V, C, dtype=np.int64)
    np.minimum.at(lowest, gvert, reps)
    primary = lowest[gvert] == reps
    new_index = np.where(primary, gvert, V + np.cumsum(~primary) - 1)
    use_smooth = smooth_mask[gvert]
    gn = np.zeros((G, 3))
    gn[use_smooth] = smooth_normals[gvert[use_smooth]]
    # the other sectors: angle-weighted corner normals of the output positions
    need = np.nonzero(~smooth_mask[fv])[0]
    if need.size:
        p, cv = positions, fv[need]
        u = p[fv[topo.nxt[need]]] - p[cv]
        w = p[fv[topo.prv[need]]] - p[cv]
        cn = np.cross(u, w)
        angle = np.arctan2(np.linalg.norm(cn, axis=1), np.einsum("ij,ij->i", u, w))
        sector_n = _scatter(group[need], tf.normalize(cn) * angle[:, None], G)
        tangent = tf.normalize(_crease_tangents(mesh, inf_sharp))[gvert]
        sector_n -= np.einsum("ij,ij->i", sector_n, tangent)[:, None] * tangent
        for exact in (
            _crease_sector_normals(mesh, scheme, boundary, s, rings, group, reps),
            _corner_sector_normals(mesh, scheme, boundary, s, rings, group, reps),
        ):
            if exact is not None:
                g, en = exact
                # the masks fix the plane, the faces the side
                en[np.einsum("ij,ij->i", en, sector_n[g]) < 0] *= -1.0
                sector_n[g] = en
        gn[~use_smooth] = sector_n[~use_smooth]
    gn = tf.normalize(gn)
    verts = np.concatenate([positions, positions[gvert[~primary]]])
    normals = np.zeros((V, 3))
    normals[:, 2] = 1.0  # unreferenced vertices: any unit vector
    normals[gvert[primary]] = gn[primary]
    normals = np.concatenate([normals, gn[~primary]])
    return verts, new_index[group], normals


def _crease_sector_matrix(scheme: str, k: int) -> tuple[np.ndarray, list[int]]:
    """Subdivision matrix of one sector of a crease vertex: k faces between its two sharp
    edges. Catmull–Clark nodes [c, e_0..e_k, f_0..f_k-1], Loop [c, e_0..e_k]; e_0 and
    e_k lie on the crease. Returns the matrix and the crease nodes [c, e_0, e_k], whose
    rows (crease rule, midpoints) do not depend on the sector."""
    m = 2 * k + 2 if scheme == "catmull_clark" else k + 2
    S = np.zeros((m, m))
    e = [1 + i for i in range(k + 1)]
    S[0, [e[0], e[k]]] = 0.125
    S[0, 0] = 0.75
    for i in (0, k):
        S[e[i], [0, e[i]]] = 0.5
    if scheme == "catmull_clark":
        F = np.zeros((k, m))
        for i in range(k):  # rows of one small matrix, not mesh elements
            F[i, [0, e[i], k + 2 + i, e[i + 1]]] = 0.25
        for i in range(1, k):
            S[e[i]] = 0.25 * (F[i - 1] + F[i])
            S[e[i], [0, e[i]]] += 0.25
        S[k + 2 :] = F
    else:
        for i in range(1, k):
            S[e[i], [0, e[i]]] = 0.375
            S[e[i], [e[i - 1], e[i + 1]]] += 0.125
    return S, [0, e[0], e[k]]


def _crease_sector_mask(scheme: str, k: int) -> np.ndarray | None:
    """The cross tangent mask of a crease sector: the left eigenvector of the sector's
    leading eigenvalue μ. The matrix is block-triangular (crease nodes first), so the
    eigenvector's sector part comes from the sector block and its crease part solves
    l_c (μ − S_cc) = l_s S_sc (least squares: where μ meets the crease's own 1/2, the
    free part only adds the crease tangent, which the normal ignores)."""
    S, upper = _crease_sector_matrix(scheme, k)
    inner = [i for i in range(len(S)) if i not in upper]
    if not inner:
        return None
    S_ss = S[np.ix_(inner, inner)]
    w, vec = np.linalg.eig(S_ss.T)
    top = int(np.argmax(np.abs(w)))
    mu, l_s = float(np.real(w[top])), np.real(vec[:, top])
    if mu <= 0.25 + 1e-9:
        # a one-face Catmull–Clark sector: μ = 1/4 ties with the crease's own curvature
        # eigenvalue, so the one-sided tangent plane is not fixed by the ring alone
        return None
    A = (mu * np.eye(3) - S[np.ix_(upper, upper)]).T
    l_u = np.linalg.lstsq(A, (l_s @ S[np.ix_(inner, upper)]), rcond=None)[0]
    mask = np.zeros(len(S))
    mask[upper], mask[inner] = l_u, l_s
    return mask


def _settled(mesh: ControlMesh, s: np.ndarray) -> np.ndarray:
    """(V,) vertices with no semi-sharp edge of their own. A vertex's 1-ring is mapped to
    its next 1-ring by rules that read only the sharpness of the vertex's own edges (its
    vertex rule, its edges' points; face points read none), so the sector masks hold at
    such a vertex whatever semi-sharp edges remain elsewhere in the mesh."""
    semi = (s > 0) & np.isfinite(s)
    if not semi.any():
        return np.ones(mesh.nv, dtype=bool)
    return _edge_count(mesh.topology.edges, semi, mesh.nv) == 0


def _crease_sector_normals(mesh, scheme, boundary, s, rings, group, reps):
    """(groups, normals) for the sectors of crease vertices of a mesh whose rules the
    masks describe (all quads or all triangles; vertices without semi-sharp edges of
    their own), else None."""
    size = {"catmull_clark": 4, "loop": 3}.get(scheme)
    if size is None or not mesh.all_size(size):
        return None
    topo, P, fv = mesh.topology, mesh.points, mesh.fv
    r = vertex_rules(mesh, s, boundary)
    cc = np.nonzero((r.parent == CREASE)[fv] & _settled(mesh, s)[fv])[0]  # their corners
    if cc.size == 0:
        return None
    G = len(reps)
    grp = group[cc]
    k = np.bincount(group, minlength=G)[grp]
    i = rings.j[cc] - rings.j[reps[grp]]  # position inside the sector
    e_out, e_in = fv[topo.nxt[cc]], fv[topo.prv[cc]]
    first, last = i == 0, i == k - 1
    along = _scatter(grp, np.where(last[:, None], P[e_in], 0.0), G) - _scatter(
        grp, np.where(first[:, None], P[e_out], 0.0), G
    )
    w_c, w_e, w_k, w_f = (np.zeros(len(cc)) for _ in range(4))
    ok = np.zeros(len(cc), dtype=bool)
    for kk in np.unique(k):  # one small eigenproblem per sector size
        mask = _crease_sector_mask(scheme, int(kk))
        if mask is None:
            continue
        sel = k == kk
        ok[sel] = True
        w_c[sel] = np.where(first[sel], mask[0], 0.0)  # the centre once per sector
        w_e[sel] = mask[1 + i[sel]]
        w_k[sel] = np.where(last[sel], mask[1 + kk], 0.0)
        if scheme == "catmull_clark":
            w_f[sel] = mask[kk + 2 + i[sel]]
    terms = (
        w_c[:, None] * P[fv[cc]]
        + w_e[:, None] * P[e_out]
        + w_k[:, None] * P[e_in]
        + w_f[:, None] * P[fv[topo.nxt[topo.nxt[cc]]]]
    )
    across = _scatter(grp, terms, G)
    groups = np.unique(grp[ok])
    return groups, tf.normalize(np.cross(along[groups], across[groups]))


# Corner sectors whose two sharp edges meet at less than this angle (or more than π minus
# it) have no well-defined tangent plane from their edges; they keep the face normals.
CORNER_MIN_ANGLE = math.radians(2.0)


def _corner_sector_normals(mesh, scheme, boundary, s, rings, group, reps):
    """(groups, normals) for the sectors of corner vertices between two infinitely sharp
    (or boundary) edges. A corner stays put and its edge points are midpoints, so each
    sharp edge's limit curve leaves the corner along the edge's own direction at every
    level: the sector's tangent plane holds both edges, whatever the faces between them."""
    if scheme == "bilinear":
        return None
    topo, P, fv = mesh.topology, mesh.points, mesh.fv
    r = vertex_rules(mesh, s, boundary)
    cc = np.nonzero((r.parent == CORNER)[fv] & _settled(mesh, s)[fv])[0]
    if cc.size == 0:
        return None
    G = len(reps)
    grp = group[cc]
    k = np.bincount(group, minlength=G)[grp]
    i = rings.j[cc] - rings.j[reps[grp]]
    # a sector is bounded when its first out-edge and its last in-edge are sharp or open
    edge_sharp = np.isinf(s) | (topo.edge_nf == 1)
    first, last = i == 0, i == k - 1
    a = _scatter(grp, np.where(first[:, None], P[fv[topo.nxt[cc]]] - P[fv[cc]], 0.0), G)
    b = _scatter(grp, np.where(last[:, None], P[fv[topo.prv[cc]]] - P[fv[cc]], 0.0), G)
    bounded = np.zeros(G, dtype=bool)
    bounded[grp[first]] = edge_sharp[topo.edge[cc[first]]]
    closed_end = np.zeros(G, dtype=bool)
    closed_end[grp[last]] = edge_sharp[topo.edge[topo.prv[cc[last]]]]
    groups = np.unique(grp)
    groups = groups[bounded[groups] & closed_end[groups]]
    n = np.cross(a[groups], b[groups])
    sin = np.linalg.norm(n, axis=1) / np.maximum(
        np.linalg.norm(a[groups], axis=1) * np.linalg.norm(b[groups], axis=1), 1e-300
    )
    keep = sin > math.sin(CORNER_MIN_ANGLE)
    return groups[keep], tf.normalize(n[keep])


# ----------------------------------------------------------- entry points
def refine(shape: ir.Subdivision, levels: int, max_bytes: int | None = None) -> ControlMesh:
    """The control mesh of `shape` after `levels` steps (validated first)."""
    errors = validate(shape)
    if errors:
        raise SubdivisionError(*errors[0])
    mesh = ControlMesh.from_shape(shape)
    if levels > 1:  # the deepest level first, so nothing is built for a level that won't fit
        check_memory(mesh, shape.scheme, levels, max_bytes, steps=levels)
    for level in range(1, levels + 1):
        check_memory(mesh, shape.scheme, level, max_bytes)
        mesh = subdivide_once(mesh, shape.scheme, shape.boundary)
    return mesh


def subdivision_mesh(
    shape: ir.Subdivision, levels: int, max_bytes: int | None = None
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Tessellate a subdivision surface (or curve tube) for the tracer: (vertices (N,3)
    float64, faces (M,3) int32, normals (N,3) float64). With `limit on` the vertices are
    pushed to their limit positions; the normals are limit normals either way."""
    if not shape.faces:
        errors = validate(shape)
        if errors:
            raise SubdivisionError(*errors[0])
        return curve_mesh(shape, levels)
    mesh = refine(shape, levels, max_bytes)
    scheme, boundary = shape.scheme, shape.boundary
    V = mesh.nv
    ready = limit_ready(mesh, scheme, boundary, max_bytes)
    positions = limit_positions(ready, scheme, boundary)[:V] if shape.limit else mesh.points
    sn, smask = smooth_limit_normals(ready, scheme, boundary)
    verts, corner_index, normals = shade(mesh, positions, sn[:V], smask[:V], scheme, boundary)
    faces = mesh.triangles(corner_index)
    if len(verts) >= 2**31 - 1:
        raise SubdivisionError("subdiv.memory", "too many vertices for 32-bit indices")
    return verts, faces.astype(np.int32), normals


DEFAULT_TOLERANCE = 1e-3  # world units, when a shape gives neither levels nor tolerance


def levels_for_tolerance(shape: ir.Subdivision, tolerance: float, max_levels: int = 6) -> int:
    """Levels so that the vertices lie within about `tolerance` of the limit: the distance
    shrinks about fourfold per level for every scheme here. Surfaces measure the control
    points' distance to their limit points; curves their second differences."""
    P = np.asarray(shape.points, dtype=np.float64).reshape(-1, 3)
    if not len(P):
        return 0
    if shape.faces:
        mesh = ControlMesh.from_shape(shape)
        ready = limit_ready(mesh, shape.scheme, shape.boundary)
        lim = limit_positions(ready, shape.scheme, shape.boundary)[: mesh.nv]
        err = float(np.max(np.linalg.norm(lim - P, axis=1)))
    else:
        err = (
            float(np.max(np.linalg.norm(P[:-2] - 2 * P[1:-1] + P[2:], axis=1))) / 2
            if len(P) > 2
            else 0.0
        )
    if err <= tolerance:
        return 0
    if tolerance <= 0:
        return max_levels
    return int(min(max_levels, math.ceil(math.log(err / tolerance, 4))))


def tessellate(shape: ir.Subdivision, max_bytes: int | None = None):
    """`subdivision_mesh` at the shape's own `levels`, or at the levels its `tolerance`
    (else DEFAULT_TOLERANCE) asks for. What `runtime.prepare` calls."""
    levels = shape.levels
    if levels is None:
        levels = levels_for_tolerance(shape, shape.tolerance or DEFAULT_TOLERANCE)
    return subdivision_mesh(shape, levels, max_bytes)


# -------------------------------------------------------------- validation
def _unknown_scheme(scheme: str) -> str:
    return (
        f"unknown subdivision scheme `{scheme}`; surfaces: {', '.join(SURFACE_SCHEMES)}; "
        f"curves: {', '.join(CURVE_SCHEMES)}"
    )


def _few(ids, limit: int = 5) -> str:
    ids = [int(i) for i in ids]
    more = f" and {len(ids) - limit} more" if len(ids) > limit else ""
    return ", ".join(map(str, ids[:limit])) + more


def validate(shape: ir.Subdivision) -> list[tuple[str, str]]:
    """Every problem that stops `shape` from being built, as (code, message) pairs."""
    out: list[tuple[str, str]] = []
    scheme = shape.scheme
    if scheme not in SURFACE_SCHEMES + CURVE_SCHEMES:
        return [("subdiv.unknown_scheme", _unknown_scheme(scheme))]
    if shape.boundary not in BOUNDARY_MODES:
        out.append(("subdiv.boundary", f"boundary must be sharp or smooth, not `{shape.boundary}`"))
    if shape.levels is not None and shape.levels < 0:
        out.append(("subdiv.levels", f"levels must be 0 or more, not {shape.levels}"))
    npts = len(shape.points)
    if scheme in CURVE_SCHEMES:
        if shape.faces:
            out.append(("subdiv.curve_faces", f"`{scheme}` is a curve scheme: it takes no faces"))
        need = 3 if shape.closed else 2
        if npts < need:
            out.append(
                (
                    "subdiv.curve_points",
                    f"a `{scheme}` curve needs at least {need} points, it has {npts}",
                )
            )
        if scheme == "midpoint" and not shape.m > 0:
            out.append(("subdiv.m", f"m must be positive, not {shape.m}"))
        if not shape.radius > 0:
            out.append(("subdiv.radius", "a subdivision curve needs a radius > 0 for its tube"))
        return out
    if not shape.faces:
        return out + [("subdiv.no_faces", f"a `{scheme}` surface needs face_indices")]
    mesh = ControlMesh.from_lists(shape.points, shape.faces)
    fv, fsize = mesh.fv, mesh.fsize
    face_of = np.repeat(np.arange(len(fsize)), fsize)
    bad = (fv < 0) | (fv >= npts)
    if bad.any():
        out.append(
            (
                "subdiv.index_range",
                f"face(s) {_few(np.unique(face_of[bad]))} use vertex indices outside 0..{npts - 1}",
            )
        )
        return out
    small = np.nonzero(fsize < 3)[0]
    if small.size:
        out.append(("subdiv.face_size", f"face(s) {_few(small)} have fewer than 3 vertices"))
        return out
    if scheme == "loop":
        nontri = np.nonzero(fsize != 3)[0]
        if nontri.size:
            out.append(
                (
                    "subdiv.loop_non_triangle",
                    f"loop subdivision takes triangles only; "
                    f"face(s) {_few(nontri)} have {int(fsize[nontri[0]])}+ vertices",
                )
            )
    key = np.sort(face_of * max(npts, 1) + fv)
    rep = np.unique(key[1:][key[1:] == key[:-1]] // max(npts, 1))
    if rep.size:
        out.append(("subdiv.degenerate_face", f"face(s) {_few(rep)} repeat a vertex"))
        return out
    topo = mesh.topology
    over = np.nonzero(topo.edge_nf > 2)[0]
    if over.size:
        pairs = ", ".join(f"<{a},{b}>" for a, b in topo.edges[over[:5]])
        out.append(
            ("subdiv.non_manifold", f"non-manifold edge(s) {pairs}: shared by more than two faces")
        )
    if topo.dup_directed:
        out.append(
            (
                "subdiv.orientation",
                f"inconsistent face orientation: {topo.dup_directed} "
                "edge(s) run the same way in both of their faces (faces must all wind the "
                "same way)",
            )
        )
    if shape.creases:
        cr = np.asarray([c[:2] for c in shape.creases], dtype=np.int64)
        sh = np.asarray([c[2] for c in shape.creases], dtype=np.float64)
        if ((cr < 0) | (cr >= npts)).any():
            out.append(("subdiv.crease_range", "crease edge index outside the vertex list"))
        else:
            keys = np.minimum(cr[:, 0], cr[:, 1]) * npts + np.maximum(cr[:, 0], cr[:, 1])
            ekeys = topo.ekeys
            assert ekeys is not None  # a control mesh's topology is built from its edge keys
            pos = np.minimum(np.searchsorted(ekeys, keys), len(ekeys) - 1)
            missing = np.nonzero(ekeys[pos] != keys)[0]
            if missing.size:
                pairs = ", ".join(f"<{a},{b}>" for a, b in cr[missing[:5]])
                out.append(("subdiv.crease_edge", f"crease(s) {pairs} are not edges of the mesh"))
        if (np.isnan(sh) | (sh < 0)).any():
            out.append(("subdiv.crease_sharpness", "crease sharpness must be 0 or more"))
    if shape.corners:
        c = np.asarray(shape.corners, dtype=np.int64)
        if ((c < 0) | (c >= npts)).any():
            out.append(("subdiv.corner_range", "corner vertex index outside the vertex list"))
    return out
