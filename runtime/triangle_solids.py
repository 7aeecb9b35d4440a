"""Triangle objects as solids: a mesh, mesh2 or height field (and any surface strala
tessellates) inside intersection / difference / merge, clipped, or clipping another object.

CSG needs every crossing of the ray with the object and an inside test at any point
(runtime.trace.CsgNode); Embree reports the nearest hit only, so a `TriangleNode` keeps an
Embree scene of its own object and casts again past each hit until the ray leaves it
(tolerances.EMBREE_NEXT_REL), every hit refined in float64 against its triangle's plane.
Meshes outside CSG stay in the scene's one Embree scene (runtime.triangles), untouched.

The inside tests are POV-Ray's:
- a mesh with `inside_vector`: a ray from the point along that world direction crosses
  the triangles an odd number of times (Mesh::Inside);
- a height field: below its surface over its x-z square, or below its lowest height
  (or water level, which also floors the heights), not above its highest (HField::Inside);
- any other triangle object has no inside: no point is inside it, nor inside its inverse.
"""

from __future__ import annotations

import threading
from typing import Protocol

import numpy as np

from lang import ir
from runtime import tolerances as tol
from runtime import transform as tf
from runtime.heightfield import heights
from runtime.prims import FunctionCompiler
from runtime.shapes import barycentric
from runtime.trace import Cands, Hits
from runtime.triangles import leaf_triangles, normal_sign

# Embree's "no hit" distance in embreex; its float32 tfar must stay finite.
_FAR = 1e37
# A height field's box reaches this far past its highest and lowest heights: POV-Ray's
# HFIELD_OFFSET (0.001 of its 65536 height steps), in the unit height of the field.
_HF_OFFSET = 0.001 / 65536.0


class InsideRule(Protocol):
    """Where a triangle object's inside is: `inside(node, points)` for world points (N,3)
    of the object whose TriangleNode is `node` (the parity rule casts its rays)."""

    # Does the object's box hold its inside (see trace.Leaf.boxes_inside)?
    boxes_inside: bool
    # False: no point is inside the object, nor inside its inverse
    has_inside: bool

    def inside(self, node: TriangleNode, p: np.ndarray) -> np.ndarray: ...


class NoInside:
    """Triangles without an inside (a mesh without inside_vector, a NURBS patch): POV-Ray's
    Mesh::Inside says false before it looks at `inverse`, so neither side holds a point."""

    boxes_inside = True
    has_inside = False

    def inside(self, node: TriangleNode, p: np.ndarray) -> np.ndarray:
        return np.zeros(len(p), dtype=bool)


class ParityInside:
    """Mesh::Inside: a ray from the point along the mesh's inside_vector (a world
    direction) crosses its triangles an odd number of times."""

    boxes_inside = True
    has_inside = True

    def __init__(self, direction: ir.Vec3):
        self.direction = np.asarray(direction, dtype=np.float64)

    def inside(self, node: TriangleNode, p: np.ndarray) -> np.ndarray:
        d = np.ascontiguousarray(np.broadcast_to(self.direction, p.shape))
        # past the float32 blur of the start only: a point on the mesh is on either side
        rows, _, _ = node.hits_along(p, d, tol.EMBREE_START_REL * node.reach(p, d))
        return (np.bincount(rows, minlength=len(p)) % 2) == 1


class HeightFieldInside:
    """POV-Ray's HField::Inside in the field's unit space (x, z in 0..1, heights 0..1, the
    image's top row at z = 1), taken there by the object's inverse transform."""

    boxes_inside = False  # everything below the field, down to -inf, is inside
    has_inside = True

    def __init__(self, shape: ir.HeightField, matrix: np.ndarray, compile_xyz: FunctionCompiler):
        h = heights(shape, compile_xyz)
        self.rows, self.cols = h.shape
        # the grid POV-Ray keeps: row z = 0 at the front (the image's bottom row)
        grid = h[::-1]
        self.water = max(float(grid.min()), float(shape.water_level)) - _HF_OFFSET
        self.top = float(grid.max()) + _HF_OFFSET
        self.grid = np.maximum(grid, self.water)  # heights below the water are the water
        self.m_inv = tf.inverse(matrix)
        self.matrix = matrix

    def box(self) -> tuple[np.ndarray, np.ndarray]:
        """World box: the unit square between the lowest (or water) and highest heights."""
        lo = np.array([0.0, self.water, 0.0])
        hi = np.array([1.0, self.top, 1.0])
        return tf.aabb_transform(self.matrix, lo, hi)

    def inside(self, node: TriangleNode, p: np.ndarray) -> np.ndarray:
        q = tf.apply_points(self.m_inv, p)
        x = q[:, 0] * (self.cols - 1)
        z = q[:, 2] * (self.rows - 1)
        y = q[:, 1]
        out = (x < 0) | (x >= self.cols - 1) | (z < 0) | (z >= self.rows - 1) | (y >= self.top)
        out |= ~np.isfinite(x + y + z)
        xs = np.where(out, 0.0, x)
        zs = np.where(out, 0.0, z)
        px = np.clip(np.floor(xs).astype(np.int64), 0, self.cols - 2)
        pz = np.clip(np.floor(zs).astype(np.int64), 0, self.rows - 2)
        fx, fz = xs - px, zs - pz
        g = self.grid
        low = fx + fz < 1.0
        # the cell's two triangles split along the diagonal from (px+1, pz) to (px, pz+1)
        y00, y10, y01, y11 = g[pz, px], g[pz, px + 1], g[pz + 1, px], g[pz + 1, px + 1]
        surface = np.where(
            low,
            y00 + fx * (y10 - y00) + fz * (y01 - y00),
            y11 + (1.0 - fx) * (y01 - y11) + (1.0 - fz) * (y10 - y11),
        )
        return ~out & ((y < self.water) | (y < surface))


class TriangleNode:
    """One triangle object as a node of the tracer (the interface of trace.Leaf): every
    crossing of a ray batch with it, its inside test, and the hit's normal, face and
    barycentrics (`record`, in place of Leaf.normals). `index` is the object's index among
    the scene's leaves (-1: an inside test only, never a hit)."""

    # the crossings lie on the triangles, inside its box
    tight = True

    def __init__(
        self,
        obj: ir.Object,
        index: int,
        rule: InsideRule,
        inverse: bool = False,
        box: tuple[np.ndarray, np.ndarray] | None = None,
    ):
        tri, vn = leaf_triangles(obj)
        self.index = index
        self.leaves = [index]
        self.rule = rule
        self.inverse = inverse
        self.v0 = tri[:, 0]
        self.e1 = tri[:, 1] - tri[:, 0]
        self.e2 = tri[:, 2] - tri[:, 0]
        cross = np.cross(self.e1, self.e2)
        self.ng = tf.normalize(cross) * normal_sign(obj)
        self.vn = vn
        self.tri = tri
        self.ids = np.nonzero(np.linalg.norm(cross, axis=1) > 0)[0]  # degenerate: never hit
        flat = tri.reshape(-1, 3)
        lo = flat.min(axis=0) if len(flat) else np.zeros(3)
        hi = flat.max(axis=0) if len(flat) else np.zeros(3)
        self.offset = (lo + hi) / 2
        self.extent = float(np.linalg.norm(hi - lo))
        self.size = self.extent
        if box is not None:
            lo, hi = box
        if inverse and rule.has_inside:
            lo, hi = np.full(3, -np.inf), np.full(3, np.inf)
        self.lo, self.hi = np.asarray(lo, dtype=np.float64), np.asarray(hi, dtype=np.float64)
        self.bounded = bool(np.all(np.isfinite(self.lo)) and np.all(np.isfinite(self.hi)))
        self.boxes_inside = rule.boxes_inside or not self.bounded
        self._scene = None
        self._lock = threading.Lock()

    # ------------------------------------------------------------------ embree
    def _embree(self):
        """The object's own Embree scene, built on first use (under a lock: render threads)."""
        with self._lock:
            if self._scene is None and len(self.ids):
                from embreex import rtcore_scene
                from embreex.mesh_construction import TriangleMesh

                scene = rtcore_scene.EmbreeScene()
                verts = np.ascontiguousarray((self.tri[self.ids] - self.offset).astype(np.float32))
                TriangleMesh(scene, verts)
                one = np.zeros((1, 3), np.float32)  # commit now, not in a render thread
                scene.run(one, one + np.float32(1), dists=np.zeros(1, np.float32))
                self._scene = scene
            return self._scene

    def hits_along(self, o: np.ndarray, d: np.ndarray, start: np.ndarray):
        """Every crossing past `start` along o + t d: (rows, t, local triangle), t in float64,
        in order along each ray."""
        scene = self._embree()
        empty = np.zeros(0, np.int64), np.zeros(0), np.zeros(0, np.int64)
        if scene is None or len(o) == 0:
            return empty
        reach = self.reach(o, d)
        rows = np.arange(len(o))
        start = np.asarray(start, dtype=np.float64).copy()
        last = np.full(len(o), -1, dtype=np.int64)
        out_rows, out_t, out_tri = [], [], []
        for _ in range(tol.MAX_MESH_CROSSINGS):
            if len(rows) == 0:
                break
            orow, drow = o[rows], d[rows]
            eo = np.ascontiguousarray(((orow - self.offset) + start[:, None] * drow), np.float32)
            ed = np.ascontiguousarray(drow, np.float32)
            res = scene.run(eo, ed, dists=np.full(len(rows), _FAR, np.float32), output=1)
            got = res["primID"] >= 0
            rows, start = rows[got], start[got]
            if len(rows) == 0:
                break
            tri = self.ids[res["primID"][got]]
            t_e = start + res["tfar"][got].astype(np.float64)
            t = self._plane_t(tri, o[rows], d[rows])
            t = np.where(np.isfinite(t), t, t_e)
            new = tri != last[rows]  # a line crosses a triangle's plane once
            out_rows.append(rows[new])
            out_t.append(t[new])
            out_tri.append(tri[new])
            last[rows] = tri
            start = np.maximum(t, t_e) + tol.EMBREE_NEXT_REL * reach[rows]
        if not out_rows:
            return empty
        return np.concatenate(out_rows), np.concatenate(out_t), np.concatenate(out_tri)

    def reach(self, o: np.ndarray, d: np.ndarray) -> np.ndarray:
        """(|origin - centre| + mesh size) in units of t: the scale of the float32 blur of
        a position along each ray near the mesh."""
        dl = np.linalg.norm(d, axis=1)
        return (np.linalg.norm(o - self.offset, axis=1) + self.extent) / np.where(dl > 0, dl, 1)

    def _plane_t(self, tri: np.ndarray, o: np.ndarray, d: np.ndarray) -> np.ndarray:
        n = self.ng[tri]
        with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
            return np.einsum("ij,ij->i", self.v0[tri] - o, n) / np.einsum("ij,ij->i", d, n)

    # ----------------------------------------------------------------- the node
    def crossings(self, o: np.ndarray, d: np.ndarray) -> Cands:
        """Every crossing ahead of the origins (t > 0, less the float32 blur of the start,
        which the tracer's floor rejects): what the callers of a node's crossings use."""
        n = len(o)
        rows, t, tri = self.hits_along(o, d, -tol.EMBREE_START_REL * self.reach(o, d))
        if len(rows):
            order = np.lexsort((t, rows))
            rows, t, tri = rows[order], t[order], tri[order]
            counts = np.bincount(rows, minlength=n)
            col = np.arange(len(rows)) - np.repeat(np.cumsum(counts) - counts, counts)
            k = int(counts.max())
        else:
            col, k = np.zeros(0, np.int64), 0
        tt = np.full((n, k), np.inf)
        prim = np.full((n, k), -1, dtype=np.int32)
        tt[rows, col] = t
        prim[rows, col] = tri
        return Cands(
            tt,
            np.full((n, k), self.index, dtype=np.int32),
            np.zeros((n, k), dtype=np.int8),
            np.full((n, k), self.inverse, dtype=bool),
            prim,
        )

    def inside(self, p: np.ndarray, inverted: bool = False) -> np.ndarray:
        """POV-Ray's inside test of the object (of its inverse when `inverted`, a subtracted
        CSG child): the rule's, turned over by `inverse`, except where there is no inside."""
        if not self.rule.has_inside:
            return np.zeros(len(p), dtype=bool)
        ins = self.rule.inside(self, p)
        return ~ins if self.inverse ^ inverted else ins

    def record(
        self, hits: Hits, rows: np.ndarray, prim: np.ndarray, o: np.ndarray, d: np.ndarray
    ) -> None:
        """Fill the normal (by the triangle's winding, interpolated on smooth meshes),
        face and barycentrics of hits on this object (their t and obj are set)."""
        assert hits.prim is not None
        hits.prim[rows] = prim
        p = o + hits.t[rows, None] * d
        u, v = barycentric(p, self.v0[prim], self.e1[prim], self.e2[prim])
        if hits.bary is not None:
            hits.bary[rows] = np.column_stack([u, v])
        n = self.ng[prim].copy()
        if self.vn is not None:
            vn = self.vn[prim]
            sm = ~np.isnan(vn[:, 0, 0])
            if sm.any():
                us, vs, vs_n = u[sm], v[sm], vn[sm]
                n[sm] = tf.normalize(
                    (1 - us - vs)[:, None] * vs_n[:, 0]
                    + us[:, None] * vs_n[:, 1]
                    + vs[:, None] * vs_n[:, 2]
                )
        hits.normal[rows] = n


def rule_for(
    obj: ir.Object, compile_xyz: FunctionCompiler, source: ir.Object | None = None
) -> InsideRule:
    """The inside rule of a triangle object; `source` is the object before tessellation
    (a height field keeps its own rule, not its triangles'; `compile_xyz` samples the
    function of a function image)."""
    shape = (source or obj).shape
    if isinstance(shape, ir.HeightField):
        return HeightFieldInside(shape, tf.as_matrix((source or obj).transform), compile_xyz)
    if isinstance(shape, ir.Mesh) and shape.inside_vector is not None:
        return ParityInside(shape.inside_vector)
    return NoInside()


def triangle_node(
    obj: ir.Object, index: int, compile_xyz: FunctionCompiler, source: ir.Object | None = None
) -> TriangleNode:
    """The node of a triangle object (obj's shape a Mesh), its inside rule from `source`
    (the object before tessellation, when it was tessellated)."""
    rule = rule_for(obj, compile_xyz, source)
    box = rule.box() if isinstance(rule, HeightFieldInside) else None
    return TriangleNode(obj, index, rule, inverse=obj.inverse, box=box)
