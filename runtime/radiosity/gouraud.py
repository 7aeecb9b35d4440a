"""Display of a radiosity solution: patch values → vertex values → any point.

Gouraud shading (NOTES.md §6 step 4): a vertex takes the area-weighted mean of the patches
around it *within its group* (one planar face, one side of a sphere or mesh), so creases
such as a floor meeting a wall stay sharp; a point inside a patch interpolates its corners
(bilinear on quads, barycentric on triangles). `flat=True` returns the patch value.
A subdivided patch's edge midpoints are T-vertices for an undivided neighbour, whose own
interpolation ignores them: the small seam this leaves is bounded by the refinement
threshold that stopped the neighbour from splitting.

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
    ):
        """`weights` (N,) replace the patch areas in the vertex averages (the system passes
        the open area, so a patch mostly buried under a box hardly counts)."""
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
        self.corner_values = self.vertex_values[self.vertex]  # (N,4,3)
        # Where each vertex is, which way it faces (area-weighted patch normals), and a
        # point nudged into its patches (for gathering: a point exactly on a corner shared
        # with a neighbouring surface would sit on that surface's polygon).
        pos = np.zeros((nv, 3))
        pos[self.vertex.reshape(-1)] = corners.reshape(-1, 3)
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


def refine_mask(field: VertexField, threshold: float, min_size: float) -> np.ndarray:
    """Patches to split: some corner differs from the patch value by more than `threshold`
    (luminance, absolute) and the patch is still larger than `min_size`."""
    p = field.patches
    own = luminance(field.values)[:, None]
    corners = luminance(field.corner_values)
    spread = np.abs(corners - own).max(axis=1)
    return (spread > threshold) & (p.edge_length() > min_size)
