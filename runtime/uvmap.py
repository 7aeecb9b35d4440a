"""Surface uv coordinates at ray hits, as POV-Ray's `uv_mapping` reads them.

A uv-mapped pigment, normal or texture is evaluated at <u, v, 0> instead of the hit's
position; (u, v) is what each shape's UVCoord gives in POV-Ray 3.7:

- sphere, lathe, sor: u the angle about the y axis from +x (toward +z), over 2 pi; the
  sphere's v is its latitude from the south pole (0) to the north pole (1), the lathe's the
  spline parameter (segment index + parameter in it) over the segment count, capped at 1,
  the sor's the height within its segment the same way (its base cap r/R - 1, its top cap
  2 - r/R);
- torus: u the angle about y (1 at +x going toward -z), v the angle about the tube;
- box: a cube unfolded into a 4 x 3 atlas, one cell per face;
- mesh, mesh2: the corners' uv_vectors mixed by the hit's barycentrics (none given: 0, 0);
- bicubic_patch: the patch parameters as (v, u);
- every other shape: the world x and y of the hit.

All but the last work in the shape's own space (the object's transformations undone).
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np

from lang import ir
from runtime import transform as tf
from runtime.prims import spline2d as sp
from runtime.prims.lathe import SorPrim

if TYPE_CHECKING:
    from runtime.context import Context

# POV-Ray's EPSILON: closer to the y axis than this (squared), the angle about it is 0.
AXIS_EPSILON: float = 1e-10


def hit_uv(
    ctx: Context,
    obj: np.ndarray,
    tex: np.ndarray,
    point: np.ndarray,
    prim: np.ndarray | None,
    bary: np.ndarray | None,
) -> np.ndarray | None:
    """(N,3) surface <u, v, 0> of the hits whose texture is uv-mapped somewhere (the others'
    rows stay 0), None when no hit's is: computed only where something reads it."""
    if ctx.needs_uv is None or not len(tex):
        return None
    need = np.nonzero(ctx.needs_uv[tex])[0]
    if not len(need):
        return None
    out = np.zeros((len(obj), 3))
    out[need] = surface_uv(
        ctx.prepared.objects,
        obj[need],
        point[need],
        None if prim is None else prim[need],
        None if bary is None else bary[need],
        ctx.prepared.world_uv,
    )
    return out


def surface_uv(
    objects: list[ir.Object],
    obj: np.ndarray,
    point: np.ndarray,
    prim: np.ndarray | None,
    bary: np.ndarray | None,
    world_uv: np.ndarray | None = None,
) -> np.ndarray:
    """(N,3) <u, v, 0> of N hits: `obj` their indices into `objects`, `point` world points,
    `prim` and `bary` the mesh face and barycentrics (u of its 2nd, v of its 3rd corner)
    of triangle hits. `world_uv` (per object, optional): meshes tessellated from a shape
    that has no uv of its own (a height_field), which read world x, y as POV-Ray's do."""
    out = np.zeros((len(obj), 3))
    for i in np.unique(obj):
        rows = np.nonzero(obj == i)[0]
        o = objects[int(i)]
        world = world_uv is not None and bool(world_uv[int(i)])
        f = None if prim is None else prim[rows]
        b = None if bary is None else bary[rows]
        out[rows, :2] = _object_uv(o, point[rows], f, b, world)
    return out


def _object_uv(o: ir.Object, p: np.ndarray, face, bary, world: bool) -> np.ndarray:
    shape = o.shape
    if world or not isinstance(shape, _OWN_UV):
        return p[:, :2].copy()
    if isinstance(shape, ir.Mesh):
        return mesh_uv(shape, face, bary)
    inv = tf.cached_inverse(o.transform)
    local = p if inv is None else p @ inv[:3, :3].T + inv[:3, 3]
    if isinstance(shape, ir.Sphere):
        return sphere_uv(local - np.asarray(shape.center, dtype=np.float64))
    if isinstance(shape, ir.Torus):
        return torus_uv(local, shape.major)
    if isinstance(shape, ir.Box):
        return box_uv(local, shape.corner1, shape.corner2)
    if isinstance(shape, ir.Lathe):
        return lathe_uv(local, shape)
    return sor_uv(local, shape)


_OWN_UV = (ir.Sphere, ir.Torus, ir.Box, ir.Mesh, ir.Lathe, ir.Sor)


def angle_about_y(x: np.ndarray, z: np.ndarray) -> np.ndarray:
    """POV-Ray's u of spheres, lathes and sors: the angle from +x toward +z over 2 pi,
    in [0, 1); 0 on the axis."""
    length = np.sqrt(x * x + z * z)
    with np.errstate(invalid="ignore", divide="ignore"):
        theta = np.arccos(np.clip(x / np.where(length > 0, length, 1.0), -1.0, 1.0))
    theta = np.where(z < 0.0, 2.0 * math.pi - theta, theta)
    return np.where(x * x + z * z > AXIS_EPSILON, theta / (2.0 * math.pi), 0.0)


def sphere_uv(d: np.ndarray) -> np.ndarray:
    """(N,2) uv of points d from the sphere's centre (its own space)."""
    length = np.linalg.norm(d, axis=1)
    safe = np.where(length > 0, length, 1.0)[:, None]
    n = d / safe
    v = 0.5 + np.arcsin(np.clip(n[:, 1], -1.0, 1.0)) / math.pi
    u = angle_about_y(n[:, 0], n[:, 2])
    return np.stack([u, v], axis=1)


def torus_uv(p: np.ndarray, major: float) -> np.ndarray:
    """(N,2) uv of points on a torus about the y axis (its own space)."""
    x, y, z = p[:, 0], p[:, 1], p[:, 2]
    u = 1.0 - (np.arctan2(z, x) + math.pi) / (2.0 * math.pi)
    ring = np.sqrt(x * x + z * z) - major
    v = (np.arctan2(y, ring) + math.pi) / (2.0 * math.pi)
    return np.stack([u, v], axis=1)


def box_uv(p: np.ndarray, corner1, corner2) -> np.ndarray:
    """(N,2) uv of points on a box's faces (its own space): POV-Ray's cube atlas, each face
    a cell of a 4 x 3 grid, none seen mirrored from outside."""
    lo = np.minimum(np.asarray(corner1, dtype=np.float64), corner2)
    hi = np.maximum(np.asarray(corner1, dtype=np.float64), corner2)
    size = np.where(hi - lo != 0, hi - lo, 1.0)
    q = (p - lo) / size
    # the face: the coordinate nearest a side (0 or 1)
    gap = np.concatenate([np.abs(q), np.abs(q - 1.0)], axis=1)  # x0 y0 z0 x1 y1 z1
    side = np.argmin(gap, axis=1)
    x, y, z = q[:, 0], q[:, 1], q[:, 2]
    third = 1.0 / 3.0
    u = np.select(
        [side == 0, side == 3, side == 1, side == 4, side == 2],
        [z / 4.0, 0.75 - z / 4.0, 0.25 + x / 4.0, 0.25 + x / 4.0, 1.0 - x / 4.0],
        0.25 + x / 4.0,
    )
    v = np.select(
        [side == 1, side == 4],
        [z / 3.0, 1.0 - z / 3.0],
        third + y / 3.0,
    )
    return np.stack([u, v], axis=1)


def mesh_uv(mesh: ir.Mesh, face, bary) -> np.ndarray:
    """(N,2) uv of mesh hits: the face corners' uvs mixed by the barycentrics."""
    n = 0 if face is None else len(face)
    if mesh.uvs is None or face is None or bary is None:
        return np.zeros((n, 2))
    uvs = np.asarray(mesh.uvs, dtype=np.float64).reshape(-1, 2)
    faces = np.asarray(mesh.faces, dtype=np.int64).reshape(-1, 3)
    f = np.clip(face.astype(np.int64), 0, max(len(faces) - 1, 0))
    corners = uvs[faces[f]]  # (N,3,2)
    b = np.nan_to_num(bary)
    w = np.stack([1.0 - b[:, 0] - b[:, 1], b[:, 0], b[:, 1]], axis=1)
    out = np.einsum("nk,nkj->nj", w, corners)
    return np.where((face >= 0)[:, None], out, 0.0)


def lathe_uv(p: np.ndarray, shape: ir.Lathe) -> np.ndarray:
    """(N,2) uv of points on a lathe (its own space): v is (segment + parameter) over the
    number of segments, at the profile point nearest the hit."""
    coef = sp.lathe_segments(shape.spline, shape.points)
    u = angle_about_y(p[:, 0], p[:, 2])
    count = len(coef)
    if count == 0:
        return np.stack([u, np.zeros(len(p))], axis=1)
    q = np.stack([np.hypot(p[:, 0], p[:, 2]), p[:, 1]], axis=1)
    cand = np.broadcast_to(np.arange(count), (len(p), count))
    seg, t = sp.locate(coef, np.ascontiguousarray(cand), q)
    v = np.minimum((t + seg) / count, 1.0)
    return np.stack([u, v], axis=1)


def sor_uv(p: np.ndarray, shape: ir.Sor) -> np.ndarray:
    """(N,2) uv of points on a sor (its own space): v is the height within its segment
    plus the segment's index, over the segment count; on the caps it runs with the radius
    (base r/R - 1, top 2 - r/R), meeting the curved surface's 0 and 1 at the rims."""
    prim = SorPrim(shape)
    u = angle_about_y(p[:, 0], p[:, 2])
    if prim.degenerate:
        return np.stack([u, np.zeros(len(p))], axis=1)
    y = p[:, 1]
    seg = prim.segment_of(y)
    h1, h2 = prim.y[seg, 0], prim.y[seg, 1]
    count = len(prim.coef)
    v = ((y - h1) / np.where(h2 != h1, h2 - h1, 1.0) + seg) / count
    r = np.hypot(p[:, 0], p[:, 2])
    scale = max(prim.size, 1.0)
    if not prim.open:
        base = np.abs(y - prim.ylo) <= 1e-9 * scale
        top = np.abs(y - prim.yhi) <= 1e-9 * scale
        if prim.base_r2 > 0:
            v = np.where(base, r / math.sqrt(prim.base_r2) - 1.0, v)
        if prim.cap_r2 > 0:
            v = np.where(top & ~base, 2.0 - r / math.sqrt(prim.cap_r2), v)
    return np.stack([u, v], axis=1)


def pigment_uses_uv(pig: ir.Pigment) -> bool:
    """Is this pigment, or one inside it, uv-mapped?"""
    return bool(
        pig.params.get("uv_mapping")
        or any(pigment_uses_uv(q) for q in pig.list)
        or any(pigment_uses_uv(q) for _, q in pig.pigment_map)
    )


def normal_uses_uv(nrm: ir.Normal | None) -> bool:
    if nrm is None:
        return False
    subs = [n for _, n in nrm.params.get("normal_map", ())]
    subs += [n for n in nrm.params.get("list", ()) if isinstance(n, ir.Normal)]
    return bool(nrm.params.get("uv_mapping")) or any(normal_uses_uv(n) for n in subs)


def uses_uv(tex: ir.Texture) -> bool:
    """Does shading this texture need the hits' uv (something in it is uv-mapped)?"""
    return (
        tex.uv_mapping
        or pigment_uses_uv(tex.pigment)
        or normal_uses_uv(tex.normal)
        or any(uses_uv(layer) for layer in tex.layers)
        or any(uses_uv(sub) for _, sub in tex.map)
    )
