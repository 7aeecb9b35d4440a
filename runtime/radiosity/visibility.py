"""Visibility between patches, traced by Embree against the patches themselves.

The radiosity mesh *is* a tessellation of the meshed surfaces, so occlusion between patch
pairs is traced against the patch polygons (two triangles each) in one Embree scene:
millions of segments per second, where the general tracer would intersect every analytic
shape in numpy. Shapes that got no patches (CSG, cylinders, tori …) still block light
through `extra` (a runtime.trace.Tracer over just those objects), queried only for the
segments Embree left open.

Segment ends lie on surfaces: Embree works in float32, so the tested segment is shortened
at both ends by `REL_GAP` of the scene's extent plus of the segment (float32 carries ~6e-8
relative to the coordinates; 1e-5 clears it by two orders of magnitude while staying far
below any patch size). Sphere patches are inscribed facets and the segment ends lie on the
true sphere, outside the facets, so a patch never shadows its own segment.
"""

from __future__ import annotations

import numpy as np

REL_GAP = 1e-5

# Embree rays per call: bounded memory, and long enough to amortise the call.
_BATCH = 1 << 21


class PatchVisibility:
    """`visible(origins, targets) -> (N,) float` (1 where the open segment is free)."""

    def __init__(self, verts: np.ndarray, extra=None):
        from embreex import rtcore_scene
        from embreex.mesh_construction import TriangleMesh

        verts = np.asarray(verts, dtype=np.float64)
        tris = np.concatenate([verts[:, [0, 1, 2]], verts[:, [0, 2, 3]]])
        area2 = np.linalg.norm(np.cross(tris[:, 1] - tris[:, 0], tris[:, 2] - tris[:, 0]), axis=1)
        tris = tris[area2 > 0]
        flat = tris.reshape(-1, 3)
        # Coordinates relative to the box centre keep float32 precision for far scenes.
        self.offset = (flat.min(axis=0) + flat.max(axis=0)) / 2 if len(flat) else np.zeros(3)
        self.extent = (
            float(np.linalg.norm(flat.max(axis=0) - flat.min(axis=0))) if len(flat) else 1.0
        )
        self.scene = None
        if len(tris):
            self.scene = rtcore_scene.EmbreeScene()
            TriangleMesh(self.scene, np.ascontiguousarray((tris - self.offset).astype(np.float32)))
            # embreex commits the scene on its first query: do it now, before threads
            # share the scene (two threads must not commit it at once).
            one = np.zeros((1, 3), np.float32)
            self.scene.run(one, one + np.float32(1), dists=np.zeros(1, np.float32))
        self.extra = extra

    def __call__(self, origins: np.ndarray, targets: np.ndarray) -> np.ndarray:
        o = np.asarray(origins, dtype=np.float64).reshape(-1, 3)
        t = np.asarray(targets, dtype=np.float64).reshape(-1, 3)
        blocked = np.zeros(len(o), dtype=bool)
        free = np.zeros(len(o), dtype=bool)
        # Embree's own part is a small share of the cost: the numpy work is kept to a few
        # float32 passes over contiguous batches (coordinates relative to the box centre,
        # as Embree sees them).
        for s in range(0, len(o), _BATCH):
            sl = slice(s, s + _BATCH)
            o32 = (o[sl] - self.offset).astype(np.float32)
            d = (t[sl] - self.offset).astype(np.float32)
            d -= o32
            dist = np.sqrt(np.einsum("nc,nc->n", d, d))
            gap = np.float32(REL_GAP) * (np.float32(self.extent) + dist)
            length = dist - 2 * gap
            ok = length > 0  # ends closer than the gap: the same point, call it visible
            free[sl] = ok
            if self.scene is None or not ok.any():
                continue
            d /= np.maximum(dist, np.float32(1e-30))[:, None]
            o32 += gap[:, None] * d
            res = self.scene.run(o32, d, dists=np.maximum(length, 0), query="OCCLUDED")
            blocked[sl] = (np.asarray(res) != -1) & ok
        if self.extra is not None:
            rows = np.nonzero(free & ~blocked)[0]
            if len(rows):
                seg = t[rows] - o[rows]  # float64 here, unlike the float32 `d` above
                seg_len = np.linalg.norm(seg, axis=1)
                seg_gap = REL_GAP * (self.extent + seg_len)
                blocked[rows] = self.extra.occluded(
                    o[rows], seg / seg_len[:, None], tmax=seg_len - seg_gap, tmin=seg_gap
                )
        return (~blocked).astype(np.float64)

    def hits(self, origins: np.ndarray, directions: np.ndarray) -> np.ndarray:
        """(N,) bool: does the ray from each origin (on a surface) along its unit direction
        hit a patch first? A ray that escapes, or meets an unmeshed object (light the
        patch system does not carry) before any patch, does not."""
        return self.hits_and_escapes(origins, directions)[0]

    def hits_and_escapes(
        self, origins: np.ndarray, directions: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray]:
        """(N,) bool twice: the ray hits a patch first (see `hits`); the ray meets nothing
        at all and sees the sky."""
        o = np.asarray(origins, dtype=np.float64).reshape(-1, 3)
        d = np.asarray(directions, dtype=np.float64).reshape(-1, 3)
        gap = REL_GAP * self.extent
        far = np.full(len(o), np.inf)
        if self.scene is not None and len(o):
            for s in range(0, len(o), _BATCH):
                sl = slice(s, s + _BATCH)
                start = (o[sl] - self.offset) + gap * d[sl]
                res = self.scene.run(
                    np.ascontiguousarray(start.astype(np.float32)),
                    np.ascontiguousarray(d[sl].astype(np.float32)),
                    dists=np.full(len(start), 1e30, dtype=np.float32),
                    output=1,
                )
                got = np.asarray(res["geomID"]) != -1
                far[sl] = np.where(got, np.asarray(res["tfar"], dtype=np.float64) + gap, np.inf)
        hit = np.isfinite(far)
        escaped = ~hit
        if self.extra is not None and len(o):
            blocked = self.extra.occluded(o, d, tmax=far, tmin=np.full(len(o), gap))
            hit &= ~blocked
            escaped &= ~blocked
        return hit, escaped
