"""POV-Ray's `bicubic_patch` on the NURBS machinery.

A bicubic Bézier patch is a NURBS surface of degree 3 x 3 with knots {0,0,0,0,1,1,1,1} and unit
weights, so it is evaluated (points, exact normals) by `runtime.nurbs` and triangulated like any
NURBS grid. What stays POV-Ray's is how finely: POV-Ray splits the patch in halves (de Casteljau)
down to `u_steps` levels in u and `v_steps` in v, stopping early where a sub-patch's control
points lie within `flatness` of the plane through its corners; each leaf becomes two triangles
cut along its (u0,v0)-(u1,v1) diagonal, shaded with interpolated exact normals. POV-Ray's leaves
may sit at different depths (leaving cracks); strala uses the shallowest uniform depth at which
every sub-patch is flat enough (or the full depth), which keeps the mesh watertight.

Point order (POV-Ray's parser): the 16 points fill Control_Points[i][j] with i (u) outer and
j (v) inner, so point k sits at u index k // 4, v index k % 4. POV-Ray's uv_mapping reports
(v, u) as the texture's (u, v); the uvs returned here follow it. `type` 0 and 1 differ in
POV-Ray only in memory use, not in geometry, so both map to the same mesh.
"""

from __future__ import annotations

import numpy as np

from lang import ir
from runtime.nurbs import Surface
from runtime.tessellate import assemble

BEZIER_KNOTS = (0.0, 0.0, 0.0, 0.0, 1.0, 1.0, 1.0, 1.0)
# POV-Ray's EPSILON for coincident corners in its flatness test.
POV_EPSILON = 1e-10
# POV-Ray's BEZIER_EPSILON: corners this close to collinear give no plane (not flat).
BEZIER_EPSILON = 1e-10
# Steps beyond 10 (a 1025 x 1025 grid, 2M triangles) add nothing visible and cost memory.
MAX_STEPS = 10
# The flatness test holds 4^depth sub-patches in memory; past depth 7 (16k patches) the full
# depth is used without testing.
FLAT_TEST_DEPTH = 7


def _net(points16) -> np.ndarray:
    """POV order -> (v, u, 3) net (u fastest when flattened, as the IR wants)."""
    cp = np.asarray(points16, dtype=np.float64).reshape(4, 4, 3)  # [u][v]
    return np.ascontiguousarray(cp.transpose(1, 0, 2))


def patch_surface(points16) -> Surface:
    return Surface.from_arrays(3, 3, BEZIER_KNOTS, BEZIER_KNOTS, _net(points16))


def patch_to_nurbs(points16) -> ir.Nurbs:
    """The `ir.Nurbs` equal to a bicubic patch given in POV-Ray's point order."""
    net = _net(points16).reshape(-1, 3)
    return ir.Nurbs(
        u_degree=3,
        v_degree=3,
        nu=4,
        nv=4,
        points=tuple((float(x), float(y), float(z)) for x, y, z in net),
        weights=(1.0,) * 16,
        u_knots=BEZIER_KNOTS,
        v_knots=BEZIER_KNOTS,
    )


def _halve(cp: np.ndarray, axis: int) -> np.ndarray:
    """De Casteljau at 1/2 along `axis` (1 = u, 2 = v) of (N, 4, 4, 3) patches -> (2N, …)."""
    c = np.moveaxis(cp, axis, 1)  # (N, 4, 4, 3) with the split direction second
    p0, p1, p2, p3 = c[:, 0], c[:, 1], c[:, 2], c[:, 3]
    a, h, b = 0.5 * (p0 + p1), 0.5 * (p1 + p2), 0.5 * (p2 + p3)
    ah, hb = 0.5 * (a + h), 0.5 * (h + b)
    m = 0.5 * (ah + hb)
    left = np.stack([p0, a, ah, m], axis=1)
    right = np.stack([m, hb, b, p3], axis=1)
    out = np.concatenate([left, right])
    return np.moveaxis(out, 1, axis)


def _flatness(cp: np.ndarray) -> np.ndarray:
    """POV-Ray's determine_subpatch_flatness for (N, 4, 4, 3) patches indexed [u][v]: the
    largest distance of a control point from the plane through three corners, or -1 where
    the corners give no plane (never flat)."""
    v0 = cp[:, 0, 0]
    v1 = cp[:, 0, 3].copy()
    v2 = cp[:, 3, 0].copy()
    near = np.linalg.norm(v0 - v1, axis=-1) < POV_EPSILON
    bad = np.zeros(len(cp), dtype=bool)
    # Degenerate u = 0 edge: use the far corner instead, as POV-Ray does.
    v1[near] = cp[near, 3, 3]
    bad |= near & (np.linalg.norm(v0 - v1, axis=-1) < POV_EPSILON)
    bad |= np.linalg.norm(v1 - v2, axis=-1) < POV_EPSILON
    e1, e2 = v0 - v1, v2 - v1
    n = np.cross(e1, e2)
    ln2 = np.sum(n * n, axis=-1)
    bad |= ln2 <= BEZIER_EPSILON * np.sum(e1 * e1, -1) * np.sum(e2 * e2, -1)
    n = n / np.sqrt(np.where(ln2 > 0, ln2, 1.0))[:, None]
    d = -np.sum(n * v0, axis=-1)
    dist = np.abs(np.einsum("nijc,nc->nij", cp, n) + d[:, None, None]).max(axis=(1, 2))
    return np.where(bad, -1.0, dist)


def patch_levels(points16, u_steps: int, v_steps: int, flatness: float) -> tuple[int, int]:
    """Subdivision levels (in u, in v): the shallowest uniform depth at which every sub-patch
    is flatter than `flatness` (POV-Ray's test), capped by u_steps / v_steps."""
    u_steps = min(max(0, int(u_steps)), MAX_STEPS)
    v_steps = min(max(0, int(v_steps)), MAX_STEPS)
    if not flatness > 0:
        return u_steps, v_steps  # flatness 0: never flat, always the full depth
    cp = np.asarray(points16, dtype=np.float64).reshape(1, 4, 4, 3)
    for depth in range(min(max(u_steps, v_steps), FLAT_TEST_DEPTH) + 1):
        lu, lv = min(depth, u_steps), min(depth, v_steps)
        f = _flatness(cp)
        if np.all((f >= 0) & (f < flatness)):
            return lu, lv
        if depth < u_steps:
            cp = _halve(cp, 1)
        if depth < v_steps:
            cp = _halve(cp, 2)
    return u_steps, v_steps


def bicubic_patch_mesh(points16, u_steps: int = 0, v_steps: int = 0, flatness: float = 0.0):
    """(vertices, faces, normals, uvs) of POV-Ray's `bicubic_patch { type N flatness F
    u_steps U v_steps V <16 points> }` (POV-Ray's defaults: 0 steps, flatness 0)."""
    lu, lv = patch_levels(points16, u_steps, v_steps, flatness)
    surf = patch_surface(points16)
    us = np.linspace(0.0, 1.0, (1 << lu) + 1)
    vs = np.linspace(0.0, 1.0, (1 << lv) + 1)
    m = assemble(surf, us, vs, float("nan"), False)
    normals = patch_normals(points16, m.uvs[:, 0], m.uvs[:, 1])
    return m.vertices, m.faces, normals, np.ascontiguousarray(m.uvs[:, ::-1])


def patch_normals(points16, u: np.ndarray, v: np.ndarray) -> np.ndarray:
    """(N,3) POV-Ray's vertex normals of a patch at (u, v) (its bezier_value): the unit cross
    product of the u and v tangents, and <1, 0, 0> where they are (nearly) parallel or
    vanish, as at a pole of the teapot's lid and bottom. POV-Ray interpolates these across
    each triangle, so the pole's <1, 0, 0> shows; the sums run in POV-Ray's order so that a
    pole's tangents come out as small (or zero) as its own do."""
    cp = np.asarray(points16, dtype=np.float64).reshape(4, 4, 3)  # [u][v]
    u = np.asarray(u, dtype=np.float64)
    v = np.asarray(v, dtype=np.float64)
    one = np.ones_like(u)
    pu, qu, pv, qv = [one], [one], [one], [one]  # u^i, (1-u)^i, v^j, (1-v)^j
    du, dqu, dv, dqv = [0 * u], [0 * u], [0 * v], [0 * v]
    for i in range(1, 4):
        pu.append(pu[i - 1] * u)
        qu.append(qu[i - 1] * (1.0 - u))
        pv.append(pv[i - 1] * v)
        qv.append(qv[i - 1] * (1.0 - v))
        du.append(i * pu[i - 1])
        dqu.append(-i * qu[i - 1])
        dv.append(i * pv[i - 1])
        dqv.append(-i * qv[i - 1])
    binomial = (1.0, 3.0, 3.0, 1.0)
    tu = np.zeros((len(u), 3))
    tv = np.zeros((len(u), 3))
    for i in range(4):
        for j in range(4):
            c = binomial[i] * binomial[j]
            ut = pu[i] * qu[3 - i]
            vt = pv[j] * qv[3 - j]
            tu += (c * vt * (du[i] * qu[3 - i] + pu[i] * dqu[3 - i]))[:, None] * cp[i, j]
            tv += (c * ut * (dv[j] * qv[3 - j] + pv[j] * dqv[3 - j]))[:, None] * cp[i, j]
    n = np.cross(tu, tv)
    t = np.sum(n * n, axis=1)
    ok = t > BEZIER_EPSILON * np.sum(tu * tu, axis=1) * np.sum(tv * tv, axis=1)
    out = np.tile([1.0, 0.0, 0.0], (len(u), 1))
    out[ok] = n[ok] / np.sqrt(t[ok])[:, None]
    return out


def bicubic_mesh(shape):
    """`bicubic_patch_mesh` for an IR-like object with `points` (16, POV-Ray order),
    `u_steps`, `v_steps` and `flatness` attributes (the proposed `ir.BicubicPatch`)."""
    return bicubic_patch_mesh(
        shape.points,
        getattr(shape, "u_steps", 0),
        getattr(shape, "v_steps", 0),
        getattr(shape, "flatness", 0.0),
    )


def bicubic_uvs(uvs: np.ndarray, corners) -> np.ndarray:
    """(N,2) uv_mapping uvs of a bicubic patch from its (v, u) parameters (N,2), as
    `bicubic_patch_mesh` gives them: POV-Ray's Compute_Texture_UV mixes the patch's four
    `uv_vectors` corners bilinearly by them."""
    st = np.asarray(corners, dtype=np.float64).reshape(4, 2)
    a, b = uvs[:, 0:1], uvs[:, 1:2]
    low = st[0] + a * (st[1] - st[0])
    high = st[3] + a * (st[2] - st[3])
    return np.ascontiguousarray(low + b * (high - low))
