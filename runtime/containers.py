"""The objects a camera ray starts inside: POV-Ray's InitRayContainerState.

POV-Ray gives every camera ray the interiors of the objects whose inside holds the camera
before it traces it, so a ray starting in a hollow sky sphere (or under water, or in glass)
carries that interior: the relative ior of refraction and of fresnel reflection at the
first surfaces it meets reads that list (runtime.interiors). Every object has an interior
in POV-Ray (Post_Process makes one), so every object with an inside test counts; flat or
open triangle geometry has none.
"""

from __future__ import annotations

import weakref

import numpy as np

from lang import ir
from runtime import interiors


def has_inside(shape) -> bool:
    """Whether the shape has an inside test here (not flat or open triangle geometry)."""
    if isinstance(shape, ir.Mesh):
        return shape.inside_vector is not None
    return not isinstance(shape, ir.Polygon | ir.Triangle)


def camera_stacks(ctx, origins: np.ndarray) -> np.ndarray:
    """(N, DEPTH) interior lists of camera rays from `origins`: the interiors of the scene's
    objects that hold each origin, in the order of the scene (innermost last as far as the
    scene lists outer objects first; POV-Ray's is its bounding tree's order)."""
    n = len(origins)
    out = interiors.empty(n)
    if n == 0:
        return out
    # a perspective camera's rays share one origin: test the distinct ones only
    if (origins == origins[0]).all():
        points, back = origins[:1], np.zeros(n, dtype=np.int64)
    else:
        points, back = np.unique(origins, axis=0, return_inverse=True)
        back = np.reshape(back, -1)
    lists = interiors.empty(len(points))
    count = np.zeros(len(points), dtype=np.int64)
    for leaves, inside in holding(ctx.prepared, points):
        iid = _interior_of(ctx, leaves)
        if iid is None:
            continue
        rows = np.nonzero(inside & (count < interiors.DEPTH))[0]
        lists[rows, count[rows]] = iid
        count[rows] += 1
    if not count.any():
        return out
    return lists[back]


def holding(prepared, points: np.ndarray) -> list[tuple[list[int], np.ndarray]]:
    """(its leaves' indices, (M,) bool inside) for each whole object (a CSG with all its
    parts) whose inside holds some of the points."""
    from runtime.functions import compile_xyz
    from runtime.inside import inside_points

    tracer = prepared.tracer
    lo, hi = points.min(axis=0), points.max(axis=0)
    found: list[tuple[list[int], np.ndarray]] = []
    # only the roots whose box holds some of the points (an inverted object's is infinite):
    # the camera's rays ask this for every tile, over scenes of thousands of roots
    boxes_lo, boxes_hi = _boxes(tracer)
    near = np.nonzero(np.all(boxes_lo <= hi, axis=1) & np.all(boxes_hi >= lo, axis=1))[0]
    for node in (tracer.nodes[k] for k in near):
        if not node.leaves:
            continue
        if len(node.leaves) == 1 and not has_inside(prepared.objects[node.leaves[0]].shape):
            continue
        inside = np.asarray(node.inside(np.ascontiguousarray(points)), dtype=bool)
        if inside.any():
            found.append((list(node.leaves), inside))
    tri = tracer.triangles
    if tri is not None and len(getattr(tri, "leaf_of", ())):
        solid: frozenset[int] = getattr(tri, "solid", frozenset())  # CSG parts, clipped
        for i in (int(i) for i in np.unique(tri.leaf_of)):
            target = prepared.objects[i]
            if i in solid or not has_inside(target.shape):
                continue
            inside = inside_points(target, points, compile_xyz)
            if inside.any():
                found.append(([i], inside))
    return found


_BOXES: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()


def _boxes(tracer) -> tuple[np.ndarray, np.ndarray]:
    """(R,3) lows and highs of the tracer's roots' boxes, gathered once per tracer."""
    got = _BOXES.get(tracer)
    if got is None:
        nodes = tracer.nodes
        got = _BOXES[tracer] = (
            np.array([n.lo for n in nodes], dtype=np.float64).reshape(-1, 3),
            np.array([n.hi for n in nodes], dtype=np.float64).reshape(-1, 3),
        )
    return got


def _interior_of(ctx, leaves: list[int]) -> int | None:
    """The interior of a whole object from its leaves': a CSG's children without one of
    their own share its. Where its children all differ, which one is the CSG's own is not
    known here: it is left out (it changes only the outer ior of what the ray enters)."""
    ids = {int(ctx.interior_id[i]) for i in leaves}
    return ids.pop() if len(ids) == 1 else None
