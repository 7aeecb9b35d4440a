"""Display of a radiosity solution: patch values → vertex values → any point.

Gouraud shading (NOTES.md §6 step 4): a vertex takes the area-weighted mean of the patches
around it *within its group* (one planar face, one side of a sphere or mesh), so creases
such as a floor meeting a wall stay sharp; a point inside a patch interpolates its corners
(bilinear on quads, barycentric on triangles). `flat=True` returns the patch value.
A subdivided patch's edge midpoints are T-vertices for an undivided neighbour; they take
the value interpolated along the neighbour's edge (`conform`), so the field is continuous
(on planar groups; on a sphere a T-vertex sits off the neighbour's chord and keeps its
average).

The same vertex field drives adaptive refinement: `refine_mask` marks patches whose
corners disagree with their own value by more than a threshold — where radiosity changes
fast across the patch.
"""

from __future__ import annotations

import numpy as np

from runtime.radiosity.patches import Patches

# Vertices closer than this fraction of the scene's extent are one vertex: far below any
# patch size, far above the rounding of points computed from different elements' maps.
_WELD_REL = 1e-9


# How far a gathering point moves from a vertex toward its patches' centre: enough to leave
# a shared corner (and the polygons meeting there), small against the patch.
_NUDGE = 1e-3


def luminance(rgb: np.ndarray) -> np.ndarray:
    return rgb @ np.array([0.2126, 0.7152, 0.0722])


class VertexField:
    """Interpolated patch values (N,3) over a Patches mesh."""

    def __init__(
        self,
        patches: Patches,
        values: np.ndarray,
        *,
        flat: bool = False,
        vertex_values: np.ndarray | None = None,
        weights: np.ndarray | None = None,
        conform: bool = True,
    ):
        """`weights` (N,) replace the patch areas in the vertex averages (the system passes
        the open area, so a patch mostly buried under a box hardly counts). `conform`
        gives T-vertices (a split patch's corner on an unsplit neighbour's edge) the value
        interpolated along that edge, so the displayed field has no seams."""
        self.patches = patches
        self.values = np.asarray(values, dtype=np.float64).reshape(len(patches), 3)
        self.flat = flat
        corners = patches.surface_points(patches.element[:, None], patches.uv)  # (N,4,3)
        n = len(patches)
        scale = float(np.abs(corners).max()) if n else 1.0
        q = np.round(corners / (scale * _WELD_REL + 1e-300)).astype(np.int64)
        keys = np.concatenate([np.repeat(patches.group[:, None, None], 4, axis=1), q], axis=2)
        _, vid = np.unique(keys.reshape(-1, 4), axis=0, return_inverse=True)
        self.vertex = vid.reshape(n, 4)  # (N,4) vertex ids of the uv corners
        # Triangles repeat their last corner: count it once.
        w = patches.area if weights is None else np.asarray(weights, dtype=np.float64)
        weight = np.repeat(w[:, None], 4, axis=1)
        weight[patches.is_tri, 3] = 0.0
        nv = int(vid.max()) + 1 if n else 0
        acc = np.zeros((nv, 3))
        wsum = np.zeros(nv)
        np.add.at(
            acc, self.vertex.reshape(-1), (weight[..., None] * self.values[:, None]).reshape(-1, 3)
        )
        np.add.at(wsum, self.vertex.reshape(-1), weight.reshape(-1))
        self.vertex_values = acc / np.maximum(wsum, 1e-300)[:, None]
        if vertex_values is not None:
            # Values computed at the vertices themselves (gathered), replacing the averages.
            self.vertex_values = np.asarray(vertex_values, dtype=np.float64).reshape(nv, 3)
        pos = np.zeros((nv, 3))
        pos[self.vertex.reshape(-1)] = corners.reshape(-1, 3)
        if conform and n:
            self.t_vertices = _t_vertices(self.vertex, pos, patches)
            v, a, b, t = self.t_vertices
            # Nested splits put T-vertices on edges whose ends are T-vertices themselves:
            # repeat until the deepest level has settled (each pass fixes one level).
            for _ in range(int(patches.level.max()) + 1 if len(v) else 0):
                self.vertex_values[v] = (1 - t)[:, None] * self.vertex_values[a] + t[
                    :, None
                ] * self.vertex_values[b]
        self.corner_values = self.vertex_values[self.vertex]  # (N,4,3)
        # Where each vertex is, which way it faces (area-weighted patch normals), and a
        # point nudged into its patches (for gathering: a point exactly on a corner shared
        # with a neighbouring surface would sit on that surface's polygon).
        nrm = np.zeros((nv, 3))
        cen = np.zeros((nv, 3))
        np.add.at(
            nrm,
            self.vertex.reshape(-1),
            (weight[..., None] * patches.normal[:, None]).reshape(-1, 3),
        )
        np.add.at(
            cen,
            self.vertex.reshape(-1),
            (weight[..., None] * patches.centroid[:, None]).reshape(-1, 3),
        )
        self.vertex_pos = pos
        self.vertex_normal = nrm / np.maximum(np.linalg.norm(nrm, axis=1, keepdims=True), 1e-300)
        cen /= np.maximum(wsum, 1e-300)[:, None]
        self.vertex_inner = pos + _NUDGE * (cen - pos)

    def at(self, patch: np.ndarray, local: np.ndarray) -> np.ndarray:
        """Values at patch-local (u, v) of the given leaf patches: (M,3)."""
        patch = np.asarray(patch, dtype=np.int64)
        if self.flat:
            return self.values[patch]
        u, v = local[:, 0], local[:, 1]
        tri = self.patches.is_tri[patch]
        w = np.where(
            tri[:, None],
            np.stack([1 - u - v, u, v, np.zeros_like(u)], axis=1),
            np.stack([(1 - u) * (1 - v), u * (1 - v), u * v, (1 - u) * v], axis=1),
        )
        return np.einsum("mk,mkc->mc", w, self.corner_values[patch])

    def lookup(self, element: np.ndarray, points: np.ndarray) -> np.ndarray:
        """Values at world points lying on the given elements (the renderer knows the hit
        object and, with `Patches.element_uv`, its element): (M,3)."""
        uv = self.patches.element_uv(element, np.asarray(points, dtype=np.float64))
        patch, local = self.patches.locate(element, np.clip(uv, 0.0, 1.0))
        return self.at(patch, local)


def _t_vertices(vertex: np.ndarray, pos: np.ndarray, patches: Patches):
    """(v, a, b, t): vertex v lies strictly inside the edge a→b of a patch of its group, at
    parameter t. Vectorised per group over (edges × vertices), in chunks."""
    k = np.array([0, 1, 2, 3])
    ea = vertex[:, k]
    eb = vertex[:, (k + 1) % 4]
    # Triangles: edges 0→1, 1→2, 2→0 (corner 3 repeats corner 2).
    eb = np.where(patches.is_tri[:, None] & (k == 2)[None], vertex[:, [0]], eb)
    keep = ea != eb
    keep[patches.is_tri, 3] = False
    grp = np.repeat(patches.group[:, None], 4, axis=1)
    ea, eb, grp = ea[keep], eb[keep], grp[keep]
    # Unique undirected edges.
    e = np.unique(np.stack([np.minimum(ea, eb), np.maximum(ea, eb), grp], axis=1), axis=0)
    vgroup = np.full(len(pos), -1)
    vgroup[vertex.reshape(-1)] = np.repeat(patches.group, 4)
    out_v, out_a, out_b, out_t = [], [], [], []
    for g in np.unique(e[:, 2]):
        eg = e[e[:, 2] == g]
        verts = np.nonzero(vgroup == g)[0]
        if len(verts) < 3:
            continue
        p = pos[verts]
        chunk = max(1, 2_000_000 // len(verts))
        for s in range(0, len(eg), chunk):
            a, b = eg[s : s + chunk, 0], eg[s : s + chunk, 1]
            pa, d = pos[a], pos[b] - pos[a]
            dd = np.einsum("ec,ec->e", d, d)
            rel = p[None, :, :] - pa[:, None, :]  # (E,V,3)
            t = np.einsum("evc,ec->ev", rel, d) / np.maximum(dd, 1e-300)[:, None]
            off = rel - t[..., None] * d[:, None, :]
            dist2 = np.einsum("evc,evc->ev", off, off)
            on = (t > 1e-9) & (t < 1 - 1e-9) & (dist2 < 1e-12 * dd[:, None])
            ei, vi = np.nonzero(on)
            out_v.append(verts[vi])
            out_a.append(a[ei])
            out_b.append(b[ei])
            out_t.append(t[ei, vi])
    if not out_v:
        z = np.zeros(0, dtype=np.int64)
        return z, z, z, np.zeros(0)
    return (
        np.concatenate(out_v),
        np.concatenate(out_a),
        np.concatenate(out_b),
        np.concatenate(out_t),
    )


def corner_spread(field: VertexField) -> np.ndarray:
    """(N,) the largest luminance difference between a patch's value and its corners'."""
    own = luminance(field.values)[:, None]
    corners = luminance(field.corner_values)
    return np.abs(corners - own).max(axis=1)


def refine_mask(
    field: VertexField, threshold: float, min_size: float, budget: int | None = None
) -> np.ndarray:
    """Patches to split: some corner differs from the patch value by more than `threshold`
    (luminance, absolute) and the patch is still larger than `min_size`. With `budget`
    (how many patches may be split) only the worst that many: worst by spread² × area,
    a patch's share of the squared error of an image of the surfaces."""
    p = field.patches
    spread = corner_spread(field)
    mask = (spread > threshold) & (p.edge_length() > min_size)
    if budget is not None and mask.sum() > budget:
        score = np.where(mask, spread**2 * p.area, -np.inf)
        keep = np.argsort(score)[::-1][: max(budget, 0)]
        mask = np.zeros_like(mask)
        mask[keep] = True
    return mask
