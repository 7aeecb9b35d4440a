"""Patch meshing: surfaces split into flat patches, refined adaptively.

Every surface is first cut into *elements* (roughly square cells no larger than the patch
size): parallelograms and triangles with an affine map p0 + u·eu + v·ev, or cells of a
sphere's (φ, θ) grid (mapped through the object's matrix, so ellipsoids work too). Each
element is the root of a quadtree: a patch splits into four children at its edge midpoints
(quads into quads, triangles into three corner triangles and the inverted middle one), in
the element's own (u, v), so a hit point finds its leaf patch by descending the tree
(`Patches.locate`), and subdivision never changes the geometry of the other patches.

A patch is flat: the polygon through its corners' surface points (an inscribed facet on a
sphere; a sphere's pole cells are triangles with a repeated vertex). Patches are one-sided
(normal by the right-hand rule over the vertices); a surface that must exchange light on
both sides is meshed twice (`flip`). Vertices are shared for Gouraud display within a
*group* (one planar face, one sphere side, one mesh side), never across a crease.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from runtime.radiosity.formfactor import polygon_centroid, polygon_normal_area

QUAD, TRI, SPHERE = 0, 1, 2

# Child corners in the parent's local (u, v), by the midpoint rule.
_QUAD_CHILDREN = np.array(
    [
        [[0, 0], [0.5, 0], [0.5, 0.5], [0, 0.5]],
        [[0.5, 0], [1, 0], [1, 0.5], [0.5, 0.5]],
        [[0, 0.5], [0.5, 0.5], [0.5, 1], [0, 1]],
        [[0.5, 0.5], [1, 0.5], [1, 1], [0.5, 1]],
    ]
)
_TRI_CHILDREN = np.array(
    [
        [[0, 0], [0.5, 0], [0, 0.5], [0, 0.5]],
        [[0.5, 0], [1, 0], [0.5, 0.5], [0.5, 0.5]],
        [[0, 0.5], [0.5, 0.5], [0, 1], [0, 1]],
        [[0.5, 0], [0.5, 0.5], [0, 0.5], [0, 0.5]],
    ]
)
_QUAD_ROOT = np.array([[0, 0], [1, 0], [1, 1], [0, 1]], dtype=np.float64)
_TRI_ROOT = np.array([[0, 0], [1, 0], [0, 1], [0, 1]], dtype=np.float64)


@dataclass
class Elements:
    """Root cells of all surfaces (structure of arrays, appended while meshing)."""

    kind: list[int] = field(default_factory=list)
    p0: list[np.ndarray] = field(default_factory=list)  # affine origin / sphere: unused
    eu: list[np.ndarray] = field(default_factory=list)
    ev: list[np.ndarray] = field(default_factory=list)
    sphere_box: list[tuple[float, float, float, float]] = field(default_factory=list)  # φ0 φ1 θ0 θ1
    matrix: list[int] = field(default_factory=list)  # sphere: index into `matrices`
    flip: list[bool] = field(default_factory=list)
    group: list[int] = field(default_factory=list)
    surface: list[int] = field(default_factory=list)  # caller's id (object index …)
    reflectance: list[np.ndarray] = field(default_factory=list)
    emission: list[np.ndarray] = field(default_factory=list)
    matrices: list[np.ndarray] = field(default_factory=list)  # unit sphere → world

    def __len__(self) -> int:
        return len(self.kind)

    def _add(self, kind, p0, eu, ev, box, mat, flip, group, surface, rho, emit) -> None:
        self.kind.append(kind)
        self.p0.append(np.broadcast_to(np.asarray(p0, dtype=np.float64), (3,)).copy())
        self.eu.append(np.broadcast_to(np.asarray(eu, dtype=np.float64), (3,)).copy())
        self.ev.append(np.broadcast_to(np.asarray(ev, dtype=np.float64), (3,)).copy())
        self.sphere_box.append(box)
        self.matrix.append(mat)
        self.flip.append(flip)
        self.group.append(group)
        self.surface.append(surface)
        self.reflectance.append(np.broadcast_to(np.asarray(rho, dtype=np.float64), (3,)).copy())
        self.emission.append(np.broadcast_to(np.asarray(emit, dtype=np.float64), (3,)).copy())

    def truncate(self, n: int, matrices: int) -> None:
        """Drop the elements from the n-th on and the matrices from `matrices` on (a
        surface given up half way)."""
        for name in ("kind", "p0", "eu", "ev", "sphere_box", "matrix", "flip", "group",
                     "surface", "reflectance", "emission"):  # fmt: skip
            del getattr(self, name)[n:]
        del self.matrices[matrices:]

    def arrays(self) -> dict[str, np.ndarray]:
        return {
            "kind": np.asarray(self.kind, dtype=np.int8),
            "p0": np.asarray(self.p0).reshape(-1, 3),
            "eu": np.asarray(self.eu).reshape(-1, 3),
            "ev": np.asarray(self.ev).reshape(-1, 3),
            "box": np.asarray(self.sphere_box, dtype=np.float64).reshape(-1, 4),
            "matrix": np.asarray(self.matrix, dtype=np.int64),
            "flip": np.asarray(self.flip, dtype=bool),
        }


# Cells one surface may be cut into: an object far larger than the rest of the scene (or
# of infinite size) would otherwise exhaust memory.
MAX_GRID = 1_000_000


class TooLarge(Exception):
    """A surface would need more patches than MAX_GRID (or its size is not finite)."""


class Mesher:
    """Builds elements for surfaces; `patches()` turns them into a Patches tree."""

    def __init__(self, patch_size: float):
        self.size = float(patch_size)
        self.el = Elements()
        self.groups = 0

    def new_group(self) -> int:
        self.groups += 1
        return self.groups - 1

    # ---------------------------------------------------------------- surfaces
    def parallelogram(
        self, p0, eu, ev, *, rho, emission=0.0, surface=-1, sides=(False,), cell=None
    ) -> tuple[int, int]:
        """The parallelogram p0 + u·eu + v·ev, cut into a grid of nu×nv cells ≤ the patch
        size, or `cell` if larger (returned; element j·nu + i of each side, sides in the
        order given).
        sides: for each side to mesh, whether it is the flipped one (normal −eu×ev)."""
        p0, eu, ev = (np.asarray(a, dtype=np.float64) for a in (p0, eu, ev))
        cell = self.size if cell is None else max(float(cell), self.size)
        with np.errstate(over="ignore", invalid="ignore"):
            ru, rv = np.linalg.norm(eu) / cell, np.linalg.norm(ev) / cell
        if not (np.isfinite(ru) and np.isfinite(rv)) or (ru + 1) * (rv + 1) > MAX_GRID:
            raise TooLarge(f"a surface of {ru:.3g} × {rv:.3g} patches")
        nu = max(1, int(np.ceil(ru - 1e-9)))
        nv = max(1, int(np.ceil(rv - 1e-9)))
        for flip in sides:
            g = self.new_group()
            for j in range(nv):
                for i in range(nu):
                    o = p0 + eu * (i / nu) + ev * (j / nv)
                    self.el._add(
                        QUAD,
                        o,
                        eu / nu,
                        ev / nv,
                        (0, 0, 0, 0),
                        -1,
                        flip,
                        g,
                        surface,
                        rho,
                        emission,
                    )
        return nu, nv

    def triangle(self, a, b, c, *, rho, emission=0.0, surface=-1, sides=(False,), group=None):
        """One triangle (normal (b−a)×(c−a)); refined to the patch size by the quadtree."""
        a, b, c = (np.asarray(x, dtype=np.float64) for x in (a, b, c))
        for flip in sides:
            g = self.new_group() if group is None else group
            self.el._add(TRI, a, b - a, c - a, (0, 0, 0, 0), -1, flip, g, surface, rho, emission)

    def polygon(self, points, *, rho, emission=0.0, surface=-1, sides=(False,)):
        """A simple planar polygon (no repeated closing point): a parallelogram stays one
        grid; anything else is ear-clipped into triangles sharing one group per side."""
        pts = np.asarray(points, dtype=np.float64)
        if len(pts) == 4 and np.allclose(pts[0] + pts[2], pts[1] + pts[3], atol=1e-12):
            self.parallelogram(
                pts[0],
                pts[1] - pts[0],
                pts[3] - pts[0],
                rho=rho,
                emission=emission,
                surface=surface,
                sides=sides,
            )
            return
        tris = ear_clip(pts)
        for flip in sides:
            g = self.new_group()
            for i, j, k in tris:
                self.triangle(
                    pts[i],
                    pts[j],
                    pts[k],
                    rho=rho,
                    emission=emission,
                    surface=surface,
                    sides=(flip,),
                    group=g,
                )

    def box(self, lo, hi, *, rho, emission=0.0, surface=-1, inside=False, outside=True):
        """Axis-aligned box (use `parallelogram` for transformed boxes): six faces, outward
        normals; `inside` meshes the inner side too (a room the camera stands in)."""
        lo, hi = np.asarray(lo, dtype=np.float64), np.asarray(hi, dtype=np.float64)
        for p0, eu, ev in box_faces(lo, hi):
            sides = tuple(s for s, want in ((False, outside), (True, inside)) if want)
            self.parallelogram(p0, eu, ev, rho=rho, emission=emission, surface=surface, sides=sides)

    def sphere(
        self, matrix, *, rho, emission=0.0, surface=-1, outside=True, inside=False, theta=(0, 1)
    ) -> tuple[int, int]:
        """The unit sphere mapped by `matrix` (4×4, object → world): a (φ, θ) grid of cells
        with edges about the patch size (pole cells are triangles). `theta` limits the polar
        range (fractions of π from the +y pole: (0, 0.5) is the upper hemisphere)."""
        m = np.asarray(matrix, dtype=np.float64).reshape(4, 4)
        self.el.matrices.append(m)
        mid = len(self.el.matrices) - 1
        radius = float(np.linalg.svd(m[:3, :3], compute_uv=False).max())
        t0, t1 = theta
        n_theta = max(1, int(np.ceil((t1 - t0) * np.pi * radius / self.size)))
        n_phi = max(4, int(np.ceil(2 * np.pi * radius / self.size)))
        mirrored = bool(np.linalg.det(m[:3, :3]) < 0)  # a mirror turns the winding inward
        for flip, want in ((False, outside), (True, inside)):
            if not want:
                continue
            g = self.new_group()
            for j in range(n_theta):
                for i in range(n_phi):
                    dt = (t1 - t0) / n_theta
                    box = (i / n_phi, (i + 1) / n_phi, t0 + j * dt, t0 + (j + 1) * dt)
                    self.el._add(
                        SPHERE, 0, 0, 0, box, mid, flip ^ mirrored, g, surface, rho, emission
                    )
        return n_phi, n_theta

    def mesh(self, vertices, faces, *, rho, emission=0.0, surface=-1, sides=(False,)):
        v = np.asarray(vertices, dtype=np.float64)
        for flip in sides:
            g = self.new_group()
            for f in np.asarray(faces, dtype=np.int64):
                self.triangle(
                    v[f[0]],
                    v[f[1]],
                    v[f[2]],
                    rho=rho,
                    emission=emission,
                    surface=surface,
                    sides=(flip,),
                    group=g,
                )

    def patches(self, max_patches: int | None = None, grade=None) -> Patches:
        p = Patches(self.el)
        p.refine_to(self.size, max_patches, grade)
        return p


def box_faces(lo: np.ndarray, hi: np.ndarray) -> list[tuple[np.ndarray, ...]]:
    """(p0, eu, ev) of a box's six faces with outward normals eu × ev."""
    d = hi - lo
    ex, ey, ez = np.diag(d)
    return [
        (lo, ey, ex),  # z = lo (normal −z)
        (lo + ez, ex, ey),  # z = hi
        (lo, ex, ez),  # y = lo (normal −y)
        (lo + ey, ez, ex),  # y = hi
        (lo, ez, ey),  # x = lo (normal −x)
        (lo + ex, ey, ez),  # x = hi
    ]


def ear_clip(pts: np.ndarray) -> list[tuple[int, int, int]]:
    """Triangulate a simple planar polygon (any winding); triangles keep its winding.
    O(n²) over the polygon's vertices, done once per polygon while meshing."""
    n_raw, _ = polygon_normal_area(pts[None])
    normal = n_raw[0]
    idx = list(range(len(pts)))
    out: list[tuple[int, int, int]] = []
    guard = 0
    while len(idx) > 3 and guard < 10 * len(pts) ** 2:
        guard += 1
        m = len(idx)
        for k in range(m):
            i, j, l = idx[k - 1], idx[k], idx[(k + 1) % m]
            a, b, c = pts[i], pts[j], pts[l]
            if np.dot(np.cross(b - a, c - b), normal) <= 0:
                continue  # reflex or degenerate corner
            if any(_in_triangle(pts[o], a, b, c, normal) for o in idx if o not in (i, j, l)):
                continue
            out.append((i, j, l))
            idx.pop(k)
            break
        else:
            break  # not simple: give up on the rest
    if len(idx) == 3:
        i, j, l = idx
        out.append((i, j, l))
    return out


def _in_triangle(p, a, b, c, n) -> bool:
    return (
        np.dot(np.cross(b - a, p - a), n) >= 0
        and np.dot(np.cross(c - b, p - b), n) >= 0
        and np.dot(np.cross(a - c, p - c), n) >= 0
    )


# ---------------------------------------------------------------------- patches


class Patches:
    """Leaf patches of the element quadtrees (structure of arrays).

    Per leaf patch: `element`, `node` (tree node), `uv` (4,2) corners in element
    coordinates, `verts` (4,3) world polygon (triangles repeat their last vertex), `normal`,
    `area`, `reflectance` and `emission` (RGB) from the element."""

    def __init__(self, elements: Elements):
        self.elements = elements
        a = elements.arrays()
        self.element_arrays = a
        self.reflectance_el = np.asarray(elements.reflectance).reshape(-1, 3)
        self.emission_el = np.asarray(elements.emission).reshape(-1, 3)
        self.group_el = np.asarray(elements.group, dtype=np.int64)
        self.surface_el = np.asarray(elements.surface, dtype=np.int64)
        n = len(elements)
        # Tree nodes: children (M,4) (−1 = leaf); roots are nodes 0..n−1.
        self.children = np.full((n, 4), -1, dtype=np.int64)
        self.node_uv = np.where(
            (a["kind"] == TRI)[:, None, None], _TRI_ROOT[None], _QUAD_ROOT[None]
        ).astype(np.float64)
        self.node_element = np.arange(n, dtype=np.int64)
        self.node_level = np.zeros(n, dtype=np.int64)
        self._leaves(np.arange(n, dtype=np.int64))

    # ------------------------------------------------------------ geometry
    def _leaves(self, nodes: np.ndarray) -> None:
        self.node = nodes
        self.element = self.node_element[nodes]
        self.uv = self.node_uv[nodes]
        self.verts = self.surface_points(self.element[:, None], self.uv)
        self.verts = np.where(
            self.element_arrays["flip"][self.element][:, None, None],
            self._flip_order(self.verts),
            self.verts,
        )
        self.normal, self.area = polygon_normal_area(self.verts)
        self.centroid = polygon_centroid(self.verts)
        self.reflectance = self.reflectance_el[self.element]
        self.emission = self.emission_el[self.element]
        self.group = self.group_el[self.element]
        self.surface = self.surface_el[self.element]
        self.level = self.node_level[nodes]
        self.is_tri = self.element_arrays["kind"][self.element] == TRI

    def _flip_order(self, verts: np.ndarray) -> np.ndarray:
        """Reverse the winding; triangles (last vertex repeated) stay padded at the end."""
        flipped = verts[:, ::-1]
        tri = (self.element_arrays["kind"][self.element] == TRI)[:, None, None]
        tri_order = verts[:, [0, 2, 1, 1]]
        return np.where(tri, tri_order, flipped)

    def __len__(self) -> int:
        return len(self.node)

    def surface_points(self, element: np.ndarray, uv: np.ndarray) -> np.ndarray:
        """World points of element-local (u, v); element broadcastable to uv[..., 0]."""
        a = self.element_arrays
        element = np.broadcast_to(element, uv.shape[:-1])
        u, v = uv[..., 0], uv[..., 1]
        kind = a["kind"][element]
        out = a["p0"][element] + u[..., None] * a["eu"][element] + v[..., None] * a["ev"][element]
        sph = kind == SPHERE
        if sph.any():
            box = a["box"][element[sph]]
            phi = 2 * np.pi * (box[:, 0] + u[sph] * (box[:, 1] - box[:, 0]))
            theta = np.pi * (box[:, 2] + v[sph] * (box[:, 3] - box[:, 2]))
            # θ from the +y pole, φ about y: corners in (u, v) order wind outward.
            local = np.stack(
                [np.sin(theta) * np.cos(phi), np.cos(theta), np.sin(theta) * np.sin(phi)],
                axis=-1,
            )
            mats = np.asarray(self.elements.matrices)[a["matrix"][element[sph]]]
            out[sph] = np.einsum("nij,nj->ni", mats[:, :3, :3], local) + mats[:, :3, 3]
        return out

    # ----------------------------------------------------------- refinement
    def subdivide(self, which: np.ndarray) -> int:
        """Split the leaf patches selected by `which` (bool mask or indices) into four;
        returns how many were split. Other patches keep their index order."""
        sel = np.zeros(len(self), dtype=bool)
        sel[which] = True
        nodes = self.node[sel]
        if len(nodes) == 0:
            return 0
        m0 = len(self.children)
        k = len(nodes)
        new = m0 + np.arange(4 * k).reshape(k, 4)
        self.children = np.concatenate([self.children, np.full((4 * k, 4), -1)])
        self.children[nodes] = new
        parent_uv = self.node_uv[nodes]  # (k,4,2)
        tri = (self.element_arrays["kind"][self.node_element[nodes]] == TRI)[:, None, None, None]
        rule = np.where(tri, _TRI_CHILDREN[None], _QUAD_CHILDREN[None])  # (k,4,4,2)
        # Child corners = parent's affine map of the rule's local corners (parents are
        # parallelograms or triangles in (u, v), so two edge vectors define the map).
        tri1 = self.element_arrays["kind"][self.node_element[nodes]] == TRI
        o = parent_uv[:, None, None, 0]
        du = parent_uv[:, 1] - parent_uv[:, 0]
        dv = np.where(tri1[:, None], parent_uv[:, 2], parent_uv[:, 3]) - parent_uv[:, 0]
        child_uv = o + rule[..., :1] * du[:, None, None] + rule[..., 1:] * dv[:, None, None]
        self.node_uv = np.concatenate([self.node_uv, child_uv.reshape(-1, 4, 2)])
        self.node_element = np.concatenate(
            [self.node_element, np.repeat(self.node_element[nodes], 4)]
        )
        self.node_level = np.concatenate(
            [self.node_level, np.repeat(self.node_level[nodes] + 1, 4)]
        )
        self._leaves(np.concatenate([self.node[~sel], new.reshape(-1)]))
        return k

    def sample_points(self, count: int, rng: np.random.Generator) -> np.ndarray:
        """(N,count,3) Latin-hypercube points on the *true* surface of each patch (on a
        sphere: on the sphere, not on the inscribed facet), for shadow and visibility rays.
        The inner side of a sphere is the exception: the true sphere lies outside the
        facets, so a segment from it into the sphere would cross its own facet; its points
        lie on the facet (the polyhedron is convex, so a segment between two facets stays
        inside it)."""
        n = len(self)
        s = (np.argsort(rng.random((n, count)), axis=1) + rng.random((n, count))) / count
        t = (np.argsort(rng.random((n, count)), axis=1) + rng.random((n, count))) / count
        c = self.uv[:, None]  # (N,1,4,2)
        tri = self.is_tri[:, None, None]
        r = np.sqrt(s)[..., None]
        tt = t[..., None]
        ss = s[..., None]
        on_tri = (1 - r) * c[:, :, 0] + r * (1 - tt) * c[:, :, 1] + r * tt * c[:, :, 2]
        on_quad = (
            (1 - ss) * (1 - tt) * c[:, :, 0]
            + ss * (1 - tt) * c[:, :, 1]
            + ss * tt * c[:, :, 2]
            + (1 - ss) * tt * c[:, :, 3]
        )
        uv = np.where(tri, on_tri, on_quad)
        out = self.surface_points(self.element[:, None], uv)
        inner = np.nonzero(self._sphere_inner())[0]
        if len(inner):
            v = self.verts[inner][:, None]  # (k,1,4,3), a planar quad (or a pole triangle)
            ss, tt = s[inner][..., None], t[inner][..., None]
            out[inner] = (
                (1 - ss) * (1 - tt) * v[:, :, 0]
                + ss * (1 - tt) * v[:, :, 1]
                + ss * tt * v[:, :, 2]
                + (1 - ss) * tt * v[:, :, 3]
            )
        return out

    def _sphere_inner(self) -> np.ndarray:
        """(N,) bool: sphere patches facing the sphere's centre."""
        a = self.element_arrays
        sph = a["kind"][self.element] == SPHERE
        out = np.zeros(len(self), dtype=bool)
        if sph.any():
            mats = np.asarray(self.elements.matrices)[a["matrix"][self.element[sph]]]
            outward = self.centroid[sph] - mats[:, :3, 3]
            out[sph] = np.einsum("nc,nc->n", self.normal[sph], outward) < 0
        return out

    def edge_length(self) -> np.ndarray:
        """Longest edge of each leaf patch."""
        e = np.roll(self.verts, -1, axis=1) - self.verts
        return np.linalg.norm(e, axis=2).max(axis=1)

    def refine_to(self, size: float, max_patches: int | None = None, grade=None) -> None:
        """Split until every patch edge ≤ its target size (or the budget would be exceeded).
        The target is `size`, or with `grade` = (lo, hi, scale) it grows with the distance d
        from the box [lo, hi]: size·max(1, d/scale) (coarse far away, e.g. on planes)."""
        while True:
            target = np.full(len(self), size)
            if grade is not None:
                lo, hi, scale = grade
                d = np.linalg.norm(self.centroid - np.clip(self.centroid, lo, hi), axis=1)
                target = size * np.maximum(1.0, d / scale)
            big = self.edge_length() > target * (1 + 1e-9)
            if not big.any():
                return
            if max_patches is not None and len(self) + 3 * int(big.sum()) > max_patches:
                return
            self.subdivide(big)

    # -------------------------------------------------------------- lookup
    def locate(self, element: np.ndarray, uv: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Leaf patch index and patch-local (u, v) of element-local points: the quadtree
        descended level by level for the whole batch at once."""
        node = np.asarray(element, dtype=np.int64).copy()
        loc = np.asarray(uv, dtype=np.float64).copy()
        tri = self.element_arrays["kind"][node] == TRI
        while True:
            ch = self.children[node]
            inner = ch[:, 0] >= 0
            if not inner.any():
                break
            u, v = loc[inner, 0], loc[inner, 1]
            t = tri[inner]
            # quads: 2×2 by halves; triangles: three corners, else the inverted middle.
            qu, qv = (u >= 0.5), (v >= 0.5)
            qc = qu + 2 * qv
            tc = np.where(qu, 1, np.where(qv, 2, np.where(u + v < 0.5, 0, 3)))
            c = np.where(t, tc, qc)
            mid = t & (c == 3)
            nu = np.where(mid, 2 * u + 2 * v - 1, 2 * u - np.where(t, c == 1, qu))
            nv = np.where(mid, 1 - 2 * u, 2 * v - np.where(t, c == 2, qv))
            loc[inner, 0], loc[inner, 1] = nu, nv
            node[inner] = ch[inner, c]
        leaf_of_node = np.full(len(self.children), -1, dtype=np.int64)
        leaf_of_node[self.node] = np.arange(len(self))
        return leaf_of_node[node], np.clip(loc, 0.0, 1.0)

    def element_uv(self, element: np.ndarray, points: np.ndarray) -> np.ndarray:
        """Element-local (u, v) of world points on (or near) the element's surface."""
        a = self.element_arrays
        element = np.asarray(element, dtype=np.int64)
        out = np.zeros((len(element), 2))
        aff = a["kind"][element] != SPHERE
        if aff.any():
            e = element[aff]
            eu, ev = a["eu"][e], a["ev"][e]
            d = points[aff] - a["p0"][e]
            # Least squares in the plane: [eu ev] (u v)ᵀ = d via the 2×2 Gram system.
            guu = np.einsum("nc,nc->n", eu, eu)
            gvv = np.einsum("nc,nc->n", ev, ev)
            guv = np.einsum("nc,nc->n", eu, ev)
            bu = np.einsum("nc,nc->n", eu, d)
            bv = np.einsum("nc,nc->n", ev, d)
            det = guu * gvv - guv * guv
            out[aff, 0] = (gvv * bu - guv * bv) / det
            out[aff, 1] = (guu * bv - guv * bu) / det
        sph = ~aff
        if sph.any():
            e = element[sph]
            mats = np.asarray(self.elements.matrices)[a["matrix"][e]]
            inv = np.linalg.inv(mats)
            local = np.einsum("nij,nj->ni", inv[:, :3, :3], points[sph]) + inv[:, :3, 3]
            local /= np.linalg.norm(local, axis=1, keepdims=True)
            theta = np.arccos(np.clip(local[:, 1], -1, 1)) / np.pi
            phi = (np.arctan2(local[:, 2], local[:, 0]) / (2 * np.pi)) % 1.0
            box = a["box"][e]
            out[sph, 0] = (phi - box[:, 0]) / (box[:, 1] - box[:, 0])
            out[sph, 1] = (theta - box[:, 2]) / (box[:, 3] - box[:, 2])
        return out
