"""POV-Ray 3.7's mesh_camera: camera rays that start on the faces of meshes.

A pixel picks a face (distributions 0, 1 and 2 by its index, 3 by its uv); the ray starts at
the face's centroid (3: at the point with the pixel's uv) moved `location.z` along the face's
normal, and goes along that normal (reversed when `direction.z` is below zero), both then
moved by the mesh's transformation. The face normal is POV-Ray's, (p3 - p1) × (p2 - p1).

Pixel coordinates are strala's (pixel centres at col + 0.5, row + 0.5); POV-Ray's
CreateCameraRay sees the same pixel as x = col + 0.5 but y = row - 0.5, clamped into the
image, and takes whole numbers of both: the first two rows of the image read the same row
of faces, and the last row of faces is never read. That is kept, as POV-Ray renders it.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from lang import ir
from runtime import transform as tf

# POV-Ray's EPSILON: a direction z below minus this reverses the rays
_REVERSE_BELOW = -1e-10
# Distribution 3 looks faces up in a grid over uv [0, 1)²: about this many faces per cell
_FACES_PER_CELL = 2.0
_MAX_GRID = 512


@dataclass
class _Faces:
    """One mesh's faces in its own space, as POV-Ray keeps them."""

    corners: np.ndarray  # (F,3,3) the vertices of each face
    normal: np.ndarray  # (F,3) unit face normals (zero for a degenerate face)
    matrix: np.ndarray  # (4,4) mesh space to world
    inverse: np.ndarray  # (4,4)
    uvs: np.ndarray | None  # (F,3,2) the corners' uv (none given: all <0,0>)
    vertex_normals: np.ndarray | None  # (F,3,3) unit normals at the corners

    @property
    def count(self) -> int:
        return len(self.corners)


def _faces(cm: ir.CameraMesh) -> _Faces:
    m = cm.mesh
    verts = np.asarray(m.vertices, dtype=np.float64).reshape(-1, 3)
    faces = np.asarray(m.faces, dtype=np.int64).reshape(-1, 3)
    corners = verts[faces]
    p1, p2, p3 = corners[:, 0], corners[:, 1], corners[:, 2]
    normal = tf.normalize(np.cross(p3 - p1, p2 - p1))
    uvs = None
    if m.uvs is not None:
        uvs = np.asarray(m.uvs, dtype=np.float64).reshape(-1, 2)[faces]
    vn = None
    if m.normals is not None:
        vn = tf.normalize(np.asarray(m.normals, dtype=np.float64).reshape(-1, 3))[faces]
    matrix = tf.as_matrix(cm.transform)
    return _Faces(corners, normal, matrix, tf.inverse(matrix), uvs, vn)


class MeshCameraRays:
    """A mesh camera's rays for any pixel coordinates (built once per render)."""

    def __init__(self, camera: ir.Camera):
        assert camera.mesh is not None
        self.spec = camera.mesh
        self.meshes = [_faces(cm) for cm in camera.mesh.meshes]
        self.offset = float(camera.location[2])  # along the normal, before reversing
        self.reverse = float(camera.direction[2]) < _REVERSE_BELOW
        counts = np.array([f.count for f in self.meshes], dtype=np.int64)
        self.ends = np.cumsum(counts)  # POV-Ray's Mesh_Index: faces up to each mesh's end
        self._grid: _UVGrid | None = None

    @property
    def rays_per_pixel(self) -> int:
        return self.spec.rays_per_pixel

    def rays(
        self, width: int, height: int, xs: np.ndarray, ys: np.ndarray, ray_number: int
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Origins (N,3), unit directions (N,3) and which are traced ((N,) bool) of ray
        `ray_number` of the pixels at xs, ys."""
        x = np.clip(np.asarray(xs, dtype=np.float64), 0.0, width - 1.0)
        y = np.clip(np.asarray(ys, dtype=np.float64) - 1.0, 0.0, height - 1.0)
        n = len(x)
        origins = np.zeros((n, 3))
        dirs = np.zeros((n, 3))
        dirs[:, 2] = 1.0
        traced = np.zeros(n, dtype=bool)
        method = self.spec.distribution
        if method == 3:
            self._by_uv(width, height, x, y, origins, dirs, traced)
            return origins, dirs, traced
        ix, iy = x.astype(np.int64), y.astype(np.int64)
        if method == 0:
            self._place(ray_number, iy * width + ix, np.arange(n), origins, dirs, traced)
        elif method == 1:
            # POV-Ray adds ray_number × (all faces): only the first ray can land on one
            index = iy * width + ix + ray_number * int(self.ends[-1])
            first = 0
            for k, end in enumerate(self.ends):
                rows = np.nonzero((index >= first) & (index < end))[0]
                self._place(k, index[rows] - first, rows, origins, dirs, traced)
                first = int(end)
        else:
            # meshes side by side; the face index counts x across the whole image
            share = width / len(self.meshes)
            which = (x / share).astype(np.int64)
            index = iy * (width // len(self.meshes)) + ix
            for k in range(len(self.meshes)):
                rows = np.nonzero(which == k)[0]
                self._place(k, index[rows], rows, origins, dirs, traced)
        return origins, dirs, traced

    def _place(self, k, index, rows, origins, dirs, traced) -> None:
        """Rays from the centroids of faces `index` of mesh k into `rows` (those past the
        mesh's last face are not traced)."""
        f = self.meshes[k]
        ok = index < f.count
        rows, index = rows[ok], index[ok]
        start = f.corners[index].mean(axis=1)
        normal = f.normal[index]
        self._finish(f, rows, start, normal, origins, dirs, traced)

    def _finish(self, f: _Faces, rows, start, normal, origins, dirs, traced) -> None:
        start = start + self.offset * normal
        if self.reverse:
            normal = -normal
        origins[rows] = tf.apply_points(f.matrix, start)
        d = tf.apply_normals(f.inverse, normal)
        good = np.linalg.norm(d, axis=1) > 0  # a degenerate face shoots nothing
        dirs[rows[good]] = d[good]
        traced[rows[good]] = True

    def _by_uv(self, width, height, x, y, origins, dirs, traced) -> None:
        """Distribution 3: the first face (in the mesh's order) whose uv triangle holds the
        pixel's (u, v), at the point of those barycentric coordinates."""
        f = self.meshes[0]
        if f.uvs is None:
            return  # no uv at all: every face's uv triangle is the point <0,0>
        u = (x - 0.5) / width
        v = 1.0 - (y + 0.5) / height
        if self._grid is None:
            self._grid = _UVGrid(f.uvs)
        face, bary = self._grid.first(u, v)
        rows = np.nonzero(face >= 0)[0]
        face, bary = face[rows], bary[rows]
        start = np.einsum("nk,nkj->nj", bary, f.corners[face])
        if self.spec.smooth and f.vertex_normals is not None:
            normal = np.einsum("nk,nkj->nj", bary, f.vertex_normals[face])
        else:
            normal = f.normal[face]
        self._finish(f, rows, start, normal, origins, dirs, traced)


class _UVGrid:
    """Faces binned by their uv bounds over [0, 1)², for finding the first face that holds
    a uv point."""

    def __init__(self, uvs: np.ndarray):
        self.uvs = uvs
        f = len(uvs)
        g = int(min(_MAX_GRID, max(1, np.sqrt(f / _FACES_PER_CELL))))
        self.g = g
        lo = np.clip(np.floor(uvs.min(axis=1) * g), 0, g - 1).astype(np.int64)
        hi = np.clip(np.floor(uvs.max(axis=1) * g), 0, g - 1).astype(np.int64)
        span_u = hi[:, 0] - lo[:, 0] + 1
        span_v = hi[:, 1] - lo[:, 1] + 1
        per = span_u * span_v
        face = np.repeat(np.arange(f), per)
        k = np.arange(len(face)) - np.repeat(np.cumsum(per) - per, per)
        cu = lo[face, 0] + k % span_u[face]
        cv = lo[face, 1] + k // span_u[face]
        cell = cv * g + cu
        order = np.lexsort((face, cell))  # by cell, then by face: the first face first
        self.face = face[order]
        self.start = np.searchsorted(cell[order], np.arange(g * g + 1))

    def first(self, u: np.ndarray, v: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """For each point the first face holding it (-1: none) and its barycentric
        coordinates (N,3), by POV-Ray's formulas (a point on a shared edge goes to the
        face that comes first; a face with a zero-area uv triangle holds nothing)."""
        n, g = len(u), self.g
        cu = np.clip(np.floor(u * g), 0, g - 1).astype(np.int64)
        cv = np.clip(np.floor(v * g), 0, g - 1).astype(np.int64)
        cell = cv * g + cu
        lo, hi = self.start[cell], self.start[cell + 1]
        counts = hi - lo
        q = np.repeat(np.arange(n), counts)
        pos = np.arange(len(q)) - np.repeat(np.cumsum(counts) - counts, counts) + lo[q]
        face = self.face[pos]
        t = self.uvs[face]
        pu, pv = u[q], v[q]
        p1u, p2u, p3u = t[:, 0, 0], t[:, 1, 0], t[:, 2, 0]
        p1v, p2v, p3v = t[:, 0, 1], t[:, 1, 1], t[:, 2, 1]
        scale = (p2u - p1u) * (p3v - p1v) - (p3u - p1u) * (p2v - p1v)
        with np.errstate(divide="ignore", invalid="ignore"):
            b1 = ((p2u - pu) * (p3v - pv) - (p3u - pu) * (p2v - pv)) / scale
            b2 = ((p3u - pu) * (p1v - pv) - (p1u - pu) * (p3v - pv)) / scale
            b3 = ((p1u - pu) * (p2v - pv) - (p2u - pu) * (p1v - pv)) / scale
        inside = (scale != 0) & (b1 >= 0) & (b2 >= 0) & (b3 >= 0)
        none = len(self.uvs)
        best = np.full(n, none, dtype=np.int64)
        np.minimum.at(best, q[inside], face[inside])
        found = best < none
        bary = np.zeros((n, 3))
        # the barycentric coordinates of each point's chosen face
        pick = inside & (face == best[q])
        bary[q[pick]] = np.stack([b1[pick], b2[pick], b3[pick]], axis=1)
        return np.where(found, best, -1), bary
