"""All triangle geometry (triangle, smooth_triangle, mesh, mesh2, tessellated surfaces)
traced by Embree (embreex), with every hit refined in float64.

Embree works in float32, so the triangles are stored relative to the centre of their
bounding box (far-away meshes keep their precision), rays start just past the float32
noise of their origin (tolerances.EMBREE_START_REL) and a self-hit is cast again from
further out (EMBREE_REL, EMBREE_ROUNDS), and the reported distance is recomputed in float64
against the hit triangle's plane, with the normal (geometric, or interpolated for smooth
triangles) computed in float64 from the refined point.
"""

from __future__ import annotations

import threading

import numpy as np

from lang import ir
from runtime import tolerances as tol
from runtime import transform as tf
from runtime.shapes import barycentric

# Embree's "no hit" distance sentinel in embreex; its float32 tfar must stay finite.
_FAR = np.float32(1e37)


def leaf_triangles(obj: ir.Object):
    """World-space (T,3,3) vertices and (T,3,3) vertex normals (or None) of a leaf."""
    m = tf.as_matrix(obj.transform)
    m_inv = tf.inverse(m)
    shape = obj.shape
    move = not tf.is_identity(m)
    if isinstance(shape, ir.Triangle):
        v = np.array([shape.p1, shape.p2, shape.p3], dtype=np.float64)
        tri = tf.apply_points(m, v)[None]
        if shape.normals is None:
            return tri, None
        corner_n = tf.apply_normals(m_inv, np.asarray(shape.normals, dtype=np.float64))
        return tri, corner_n[None]
    if not isinstance(shape, ir.Mesh):
        raise TypeError(f"a {type(shape).__name__} is not triangle geometry")
    verts = np.asarray(shape.vertices, dtype=np.float64).reshape(-1, 3)
    if move:
        verts = tf.apply_points(m, verts)
    faces = np.asarray(shape.faces, dtype=np.int64).reshape(-1, 3)
    tri = verts[faces]
    normals = shape.normals
    vn: np.ndarray | None
    if normals is None and shape.smooth:
        vn = vertex_normals(verts, faces)[faces]
    elif normals is not None:
        n = np.asarray(normals, dtype=np.float64).reshape(-1, 3)
        vn = (tf.apply_normals(m_inv, n) if move else tf.normalize(n))[faces]
    else:
        vn = None
    return tri, vn


def normal_sign(obj: ir.Object) -> float:
    """-1 for a mesh (mesh, mesh2, height field) under a mirroring transform, else 1. The
    world-space edges' cross product turns over under a mirror; POV-Ray keeps a mesh's
    normal in its own space and carries it out through the inverse transpose, which does
    not (trace() reports it). A lone triangle is moved vertex by vertex: it turns over."""
    if not isinstance(obj.shape, ir.Mesh):
        return 1.0
    return -1.0 if np.linalg.det(tf.as_matrix(obj.transform)[:3, :3]) < 0 else 1.0


def vertex_normals(verts: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """Area-weighted vertex normals (for `smooth` meshes that give none)."""
    fn = np.cross(verts[faces[:, 1]] - verts[faces[:, 0]], verts[faces[:, 2]] - verts[faces[:, 0]])
    acc = np.zeros_like(verts)
    for k in range(3):
        np.add.at(acc, faces[:, k], fn)
    return tf.normalize(acc)


class TriangleSet:
    """Every triangle of the scene; `leaves` is [(object index, ir.Object)]. The objects in
    `solid` (parts of CSG, clipped ones) are traced by their own nodes
    (runtime.triangle_solids): their triangles are kept here for what a hit on them needs
    (textures, shadow-ray origins) but left out of the Embree scenes."""

    def __init__(self, leaves: list[tuple[int, ir.Object]], solid: frozenset[int] = frozenset()):
        self.solid = solid
        tris, vns, leaf_of, local, signs = [], [], [], [], []
        self.sizes: dict[int, float] = {}
        for index, obj in leaves:
            tri, vn = leaf_triangles(obj)
            tris.append(tri)
            signs.append(np.full(len(tri), normal_sign(obj)))
            if vn is None:
                vn = np.full_like(tri, np.nan)
            vns.append(vn)
            leaf_of.append(np.full(len(tri), index, dtype=np.int32))
            local.append(np.arange(len(tri), dtype=np.int32))
            if len(tri):
                flat = tri.reshape(-1, 3)
                self.sizes[index] = float(np.linalg.norm(flat.max(axis=0) - flat.min(axis=0)))
        self.tri = np.concatenate(tris) if tris else np.zeros((0, 3, 3))
        self.vn = np.concatenate(vns) if vns else np.zeros((0, 3, 3))
        self.smooth = ~np.isnan(self.vn[:, 0, 0])
        tri_size = [
            np.full(len(t), self.sizes.get(i, 0.0)) for t, (i, _) in zip(tris, leaves, strict=True)
        ]
        self.tri_size = np.concatenate(tri_size) if tri_size else np.zeros(0)
        self.leaf_of = np.concatenate(leaf_of) if leaf_of else np.zeros(0, np.int32)
        self.local = np.concatenate(local) if local else np.zeros(0, np.int32)
        # the first global triangle of each leaf (object index): global = first + local
        self.first: dict[int, int] = {}
        start = 0
        for (index, _), t in zip(leaves, tris, strict=True):
            self.first[index] = start
            start += len(t)
        self.v0 = self.tri[:, 0]
        self.e1 = self.tri[:, 1] - self.tri[:, 0]
        self.e2 = self.tri[:, 2] - self.tri[:, 0]
        across = np.cross(self.e1, self.e2)
        self.ng = tf.normalize(across)
        # degenerate (zero-area) triangles can never be hit: no tracer is given them
        self.hittable = np.linalg.norm(across, axis=1) > 0
        if signs:
            self.ng *= np.concatenate(signs)[:, None]
        flat = self.tri.reshape(-1, 3)
        lo = flat.min(axis=0) if len(flat) else np.zeros(3)
        hi = flat.max(axis=0) if len(flat) else np.zeros(3)
        self.offset = (lo + hi) / 2
        self.extent = float(np.linalg.norm(hi - lo))
        self.flags: dict[str, np.ndarray] = {}
        self.scenes: dict[tuple[int, ...], tuple] = {}
        self._lock = threading.Lock()

    # ------------------------------------------------------------------ embree
    def _scene(self, skip: str | None):
        """The Embree scene without the triangles whose object carries `skip`. Scenes are
        cached by the set of objects they leave out, so flags no triangle object carries
        share one scene (a big mesh is built once, not once per query kind)."""
        flag = self.flags.get(skip) if skip else None
        left_out: tuple[int, ...] = ()
        if flag is not None and len(flag):
            left_out = tuple(int(i) for i in np.unique(self.leaf_of[flag[self.leaf_of]]))
        if self.solid:
            left_out = tuple(sorted(set(left_out) | self.solid))
        with self._lock:
            if left_out not in self.scenes:
                keep = self.hittable.copy()
                if left_out:
                    keep &= ~np.isin(self.leaf_of, left_out)
                ids = np.nonzero(keep)[0].astype(np.int64)
                scene = None
                if len(ids):
                    from embreex import rtcore_scene
                    from embreex.mesh_construction import TriangleMesh

                    scene = rtcore_scene.EmbreeScene()
                    verts = np.ascontiguousarray((self.tri[ids] - self.offset).astype(np.float32))
                    TriangleMesh(scene, verts)
                    # embreex commits the scene on its first query; do that here, under the
                    # lock, so render threads never commit the same scene concurrently.
                    one = np.zeros((1, 3), np.float32)
                    scene.run(one, one + np.float32(1), dists=np.zeros(1, np.float32))
                self.scenes[left_out] = (scene, ids)
            return self.scenes[left_out]

    def _reach(self, o: np.ndarray) -> np.ndarray:
        return np.linalg.norm(o - self.offset, axis=1) + self.extent

    def _start(self, o: np.ndarray, tmin: np.ndarray) -> np.ndarray:
        """First start distance for rays from o: float32 noise of the origin only
        (tolerances.EMBREE_START_REL); a self-hit it lets through is refined, rejected and
        cast again from further out (`_first_hits`), so a close occluder is not skipped."""
        return np.maximum(tmin, tol.EMBREE_START_REL * self._reach(o))

    def _cast(self, scene, o, d, start, far, query):
        eo = np.ascontiguousarray(((o - self.offset) + start[:, None] * d).astype(np.float32))
        ed = np.ascontiguousarray(d.astype(np.float32))
        dist = np.clip(far - start, 0.0, float(_FAR)).astype(np.float32)
        if query == "OCCLUDED":
            return scene.run(eo, ed, dists=dist.copy(), query="OCCLUDED")
        return scene.run(eo, ed, dists=dist.copy(), output=1)

    # ----------------------------------------------------------------- queries
    def refine_t(self, tri: np.ndarray, o: np.ndarray, d: np.ndarray) -> np.ndarray:
        """float64 distance to the planes of triangles `tri` (indices) along o + t d."""
        n = self.ng[tri]
        with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
            return np.einsum("ij,ij->i", self.v0[tri] - o, n) / np.einsum("ij,ij->i", d, n)

    def closest(self, o, d, tmin, limit, skip, hits) -> None:
        """Update `hits` in place where a triangle is nearer than `limit`."""
        scene, ids = self._scene(skip)
        if scene is None:
            return
        rows, tri, t = self._first_hits(scene, ids, o, d, tmin, limit)
        if len(rows):
            self._record(hits, rows, tri, t, o[rows], d[rows])

    def _first_hits(self, scene, ids, o, d, tmin, limit):
        """Rows with a triangle hit in (tmin, limit), their triangle and float64 distance.

        A refined hit can land at or before the ray's floor (the ray started on that
        triangle, or grazes it): cast again from just past it (tolerances.EMBREE_ROUNDS)."""
        rows = np.nonzero(limit > tmin)[0]
        start = self._start(o[rows], tmin[rows])
        out_rows, out_tri, out_t = [], [], []
        for round_ in range(tol.EMBREE_ROUNDS):
            if len(rows) == 0:
                break
            orow, drow = o[rows], d[rows]
            res = self._cast(scene, orow, drow, start, limit[rows], "INTERSECT")
            got = res["primID"] >= 0
            if not got.any():
                break
            rows, orow, drow, start = rows[got], orow[got], drow[got], start[got]
            tri = ids[res["primID"][got]]
            t = self.refine_t(tri, orow, drow)
            floor = np.maximum(tmin[rows], tol.OBJECT_REL * self.tri_size[tri])
            ok = np.isfinite(t) & (t > floor) & (t < limit[rows])
            out_rows.append(rows[ok])
            out_tri.append(tri[ok])
            out_t.append(t[ok])
            retry = ~ok & ~(t >= limit[rows])
            t_e = start + res["tfar"][got].astype(np.float64)
            rows = rows[retry]
            # Past the rejected hit by a step that grows tenfold per round up to EMBREE_REL
            # (a grazing self-hit can repeat for ~1e-6 of the reach in float32).
            step = tol.EMBREE_REL * 10.0 ** (round_ + 2 - tol.EMBREE_ROUNDS)
            start = t_e[retry] + step * (np.abs(t_e[retry]) + self.extent)
        if not out_rows:
            return np.zeros(0, np.int64), np.zeros(0, np.int64), np.zeros(0)
        return np.concatenate(out_rows), np.concatenate(out_tri), np.concatenate(out_t)

    def terminator_points(self, obj, prim, point, normal) -> np.ndarray:
        """Shadow-ray origins for hits on smooth triangles (Hanika 2021, "Hacking the
        Shadow Terminator"): the hit point pushed onto the curved surface the vertex normals
        describe, so that a flat triangle near the light/shadow boundary does not shadow
        itself. `normal` is the shading normal turned toward the viewer; points on flat
        triangles stay where they are."""
        tri = np.array([self.first[int(o)] for o in obj], dtype=np.int64) + prim
        out = np.array(point, dtype=np.float64, copy=True)
        sm = self.smooth[tri]
        if not sm.any():
            return out
        tri, p = tri[sm], out[sm]
        u, v = barycentric(p, self.v0[tri], self.e1[tri], self.e2[tri])
        w = np.stack([1.0 - u - v, u, v], axis=1)
        vn = self.vn[tri]  # (M,3,3) vertex normals, turned to the viewer's side
        side = np.sign(np.einsum("mkj,mj->mk", vn, normal[sm]))
        vn = vn * np.where(side == 0, 1.0, side)[..., None]
        to_p = p[:, None, :] - self.tri[tri]  # from each vertex to the point
        below = np.minimum(0.0, np.einsum("mkj,mkj->mk", to_p, vn))
        lifted = self.tri[tri] + to_p - below[..., None] * vn
        out[sm] = np.einsum("mk,mkj->mj", w, lifted)
        return out

    def _record(self, hits, rows, tri, t, o, d) -> None:
        hits.t[rows] = t
        hits.obj[rows] = self.leaf_of[tri]
        hits.prim[rows] = self.local[tri]
        p = o + t[:, None] * d
        u, v = barycentric(p, self.v0[tri], self.e1[tri], self.e2[tri])
        if hits.bary is not None:
            hits.bary[rows] = np.column_stack([u, v])
        n = self.ng[tri].copy()
        sm = self.smooth[tri]
        if sm.any():
            us, vs, vn = u[sm], v[sm], self.vn[tri[sm]]
            n[sm] = tf.normalize(
                (1 - us - vs)[:, None] * vn[:, 0] + us[:, None] * vn[:, 1] + vs[:, None] * vn[:, 2]
            )
        hits.normal[rows] = n

    def occluded(self, o, d, tmin, tmax) -> np.ndarray:
        """Embree's any-hit query, then, for the rays it reports blocked, a float64-refined
        closest hit to reject self-hits at grazing angles (float32 cannot tell those)."""
        scene, ids = self._scene("no_shadow")
        if scene is None or len(o) == 0:
            return np.zeros(len(o), dtype=bool)
        start = self._start(o, tmin)
        out = np.zeros(len(o), dtype=bool)
        live = np.nonzero(tmax > start)[0]
        if len(live):
            res = self._cast(scene, o[live], d[live], start[live], tmax[live], "OCCLUDED")
            cand = live[res != -1]
            if len(cand):
                rows, _, _ = self._first_hits(scene, ids, o[cand], d[cand], tmin[cand], tmax[cand])
                out[cand[rows]] = True
        return out
