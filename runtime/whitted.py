"""The compiled Whitted path: scenes it covers are traced by `runtime._whitted` (C).

The numpy integrator (`runtime.integrate`) traces waves of rays: every step is a pass over
arrays of up to a million rays, which costs more than the arithmetic in a scene of a few
spheres and planes (the seed scene spent 1.7 s there at 1280x960, profiled). The C kernel
traces the same rays depth first, one at a time, with the same formulas and tolerances, and
is used only when a scene has nothing it does not know; anything else renders through
numpy, unchanged. tests/test_whitted_kernel.py holds the two to the same images. This
module is the kernel's only importer: `kernel_built`, `kernel_layout`, `trace_packed`
and (for the scene language's trace()) `probe` and `first_hit` are the way to it from
elsewhere.

What it covers (`reasons` lists what stops a scene): every camera projection POV-Ray 3.7
has (perspective, orthographic, fisheye, omnimax, panoramic, ultra_wide_angle, cylinder
1-4, spherical; camera.py's formulas) without focal blur or a mesh camera, and a camera
normal on the perspective and orthographic ones; spheres, planes, boxes, discs, cylinders,
cones, tori and polynomials (quadric, cubic, quartic, poly up to degree POLY_MAX_DEGREE),
prisms and text (sweeps: kernel/sweep.h), lathes and sors (kernel/lathe.h), blobs
(kernel/blob.h: spherical and cylindrical components, any strengths, every crossing kept;
like the numpy path, one texture for the whole blob, and sturm changes nothing: the roots
are exact anyway), polygons, superellipsoids (any exponents, searched in up to
SUPERELLIPSOID_MAX_CELLS cells: kernel/superellipsoid.h), transformed or not, inverse or
not, and their CSG (union, intersection, difference, merge, nested), any number of them
through the tracer's box tree, clipped by any of them (trace.ClipNode); triangles
(triangle, smooth_triangle, mesh, mesh2, height fields, bicubic patches: each in float64
through the triangles' own box tree, as triangles.TriangleSet refines Embree's float32
hits; not in CSG, nor the tessellations of nurbs and subdivision surfaces, whose shadow
rays start on the curved surface); no other shapes.
Textures of up to MAX_LAYERS layers, and patterned textures (checker, texture_map, average,
of those patterns, nested, showing up to MAX_LAYERS layers at a point), whose pigments are
solid, checker, hexagon, brick, gradient, onion, spherical, cylindrical, planar, boxed,
radial, leopard, spiral1, spiral2, ripples, waves, quilted, the fractals (mandel and julia
to exponent 4, magnet), image_map (every map_type, interpolation, once, use_alpha, filter
and transmit, palette entries: the numpy path's decoded pixels in a table of their own) or
one of POV-Ray's noise patterns (bozo, spotted, bumps, dents, granite, marble, wood,
wrinkles, agate, on its three noise generators, and crackle), with a colour map of any
length or a pigment map (checkers, maps and averages of such pigments, nested up to
PIGMENT_DEPTH), a wave and turbulence (no warps); normals (bumps, dents, wrinkles, ripples,
waves, quilted and the slope of those patterns, with turbulence and a slope map,
normal_maps and averages of them, nested, and bump_map images (kernel/bump_map.h); no
warps), one per layer; every finish item (crand, diffuse_back, fresnel reflection, irid
included) but a negative metallic. Interior textures (where the ray leaves the object).
Point lights and spotlights (fade included), area lights of either (adaptive, circular,
orient; jitter is not sampled, as in lights.shadow); interiors with ior, fade and faked
caustics, no media; a background colour and sky_sphere layers of those pigments (either
version's rules for their filter and transmit); fog (constant, ground, turbulent, several);
no media, rainbow or radiosity.

Pigment, texture-pattern and normal rows (what they hold, which the kernel renders) are
runtime.kernel_patterns'; the rest of the layout is here.

The scene goes to C as one float64 array: a header, then one row per object, texture,
light, pigment and node, the child lists, the unbounded and the loose roots (CSG whose box
may not hold their crossings: trace.Tracer.loose) and the box tree. The layout below is
mirrored in kernel/whitted.c; `layout()` checks it, and the kernel checks every index
between tables.
"""

from __future__ import annotations

import math
import os
import weakref
from collections.abc import Callable

import numpy as np

from lang import ir
from runtime import (
    color,
    containers,
    fog,
    interiors,
    lights,
    noise,
    patterns,
    shading,
    shapes,
)
from runtime import tolerances as tol
from runtime import transform as tf
from runtime.camera import view_planes
from runtime.kernel_patterns import (
    MAP_ENTRY,
    MAX_LAYERS,
    NRM,
    PIG,
    Images,
    inner_pigments,
    inv_rows,
    needs_noise,
    normal_reasons,
    normal_rows,
    pack_normal,
    pack_pigment,
    pack_texture_pattern,
    pattern_of,
    pigment_reasons,
    texture_reasons,
)
from runtime.lights import MAX_SHADOW_CROSSINGS
from runtime.prims import blob, spline2d
from runtime.prims.lathe import LathePrim, SorPrim
from runtime.prims.polynomial import PolyPrim
from runtime.prims.prism import PrismPrim, Sweep
from runtime.prims.superellipsoid import SuperellipsoidPrim
from runtime.prims.text import TextPrim
from runtime.trace import BoxTree, ClipNode, CsgNode, Leaf

try:  # the extension is optional: without a compiler the numpy path renders everything
    from runtime import _whitted
except ImportError:  # pragma: no cover - depends on the build
    _whitted = None  # type: ignore[assignment]  # typed by the import: module or None

# Packed layout: header, then one row per object, texture and light (float64).
HDR, OBJ, TEX, LIT, NODE, MAX_CROSS = 128, 64, 64, 32, 16, 1024
FOG = 20
BVH, BVH_STACK = 11, 128
H_NOBJ, H_NTEX, H_NLIGHT, H_MAXLEVEL, H_BAILOUT, H_AMB = 0, 1, 2, 3, 4, 5
H_BG, H_LEGACY, H_ANYTRANS, H_CAMKIND, H_WIDTH, H_HEIGHT = 8, 11, 12, 13, 14, 15
H_LOC, H_DIR, H_RIGHT, H_UP, H_TOL = 16, 19, 22, 25, 28
H_NPIG, H_NSKY, H_NNODE, H_NROOT, H_NCHILD, H_NUNB, H_NBVH, H_NITEM, H_MASK = range(39, 48)
H_NLOOSE = 48
# the camera rays' interior list (runtime.containers): its length, the ids, their iors
H_CAMIN = 56
# the projection (camera.py's) and what the others read: the angle in radians, the cylinder
# type, the spherical angles, the lengths of right and up, the unit right, up and
# direction, tan(135 degrees) for omnimax
CAMERAS = {
    "perspective": 0,
    "orthographic": 1,
    "fisheye": 2,
    "omnimax": 3,
    "panoramic": 4,
    "ultra_wide_angle": 5,
    "cylinder": 6,
    "spherical": 7,
}
H_CAMANGLE, H_CAMCYL, H_CAMH, H_CAMV, H_CAMLR, H_CAMLU = range(112, 118)
H_CAMRN, H_CAMUN, H_CAMDN, H_CAMTAN = 118, 121, 124, 127
# where POV-Ray's noise tables start in the packed array (0: not packed, no pigment needs them)
H_NOISE = 76
# the colour maps' table (MAP_ENTRY values an entry: key, rgbft): where it starts, its entries
H_MAPS, H_NMAPS = 77, 78
# the fogs' table (FOG values each), how many, and how far a ray that hits nothing sees fog
H_FOGS, H_NFOG, H_FOGMAX = 80, 81, 82
# the polynomials' terms table (i, j, k, c each), its length, and their tolerances
H_TERMS, H_NTERMS, H_POLY_REACH, H_POLY_LEAD, H_ROOT_ITER = 83, 84, 85, 86, 87
# the normals' table (NRM values each) and how many
H_NRMS, H_NNRM = 88, 89
# the camera's normal (camera.bend): its row in the normals' table, -1 without one
H_CAMNRM = 109
# the sweeps' table (kernel/sweep.h: groups, then segments, per sweep), its length, and the
# tolerances of their root finding (spline2d)
H_SWEEPS, H_NSWEEP, H_SWEEP_TOL = 96, 97, 98
# the triangles' table (TRI values each), their box tree (BVH rows) and its leaves' triangles
H_TRIS, H_NTRI, H_TBVH, H_NTBVH, H_TITEMS, H_NTITEM = range(90, 96)
# a triangle: first vertex, edges, unit geometric normal, vertex normals (NaN: flat), its
# object, texture row and the object's size (triangles.TriangleSet's, world space)
TRI = 24
TR_V0, TR_E1, TR_E2, TR_NG, TR_VN, TR_OBJ, TR_TEX, TR_SIZE = 0, 3, 6, 9, 12, 21, 22, 23
SWEEP_GROUP, SWEEP_SEGMENT = 6, 13
# a sor's segment in the sweeps' table (kernel/lathe.h SR_ values)
SOR_SEGMENT = 8
# the blobs' table (blob.PIECE values a piece: BlobPrim.table), its length, and POV-Ray's
# inside tolerance of a blob's density
H_BLOBS, H_NBLOB, H_BLOB_INSIDE = 103, 104, 105
POLY_TERM = 4
# a polynomial of a higher degree renders through numpy (kernel/poly.h POLY_MAX_DEGREE)
POLY_MAX_DEGREE = 8
F_DIST, F_COL, F_TYPE, F_UP, F_OFFSET, F_ALT, F_HASTURB, F_TURB = 0, 1, 6, 7, 10, 11, 12, 13
F_OCTAVES, F_OMEGA, F_LAMBDA, F_TDEPTH = 16, 17, 18, 19
N_KIND, N_OP, N_INV, N_LEAF, N_FIRST, N_COUNT, N_LO, N_HI = 0, 1, 2, 3, 4, 5, 8, 11
OPS = {"union": 0, "intersection": 1, "difference": 2, "merge": 3}
# clipped_by: the first child's crossings inside every other child (trace.ClipNode)
OP_CLIP = 4
O_KIND, O_IDENT, O_FLIP, O_SIZE, O_TEX, O_FLAGS, O_DOUBLE, O_IOR = range(8)
O_MINV, O_PRIM, O_FADEPOW, O_FADEDIST, O_FADECOL, O_INTERIOR = 8, 20, 44, 45, 46, 49
# POV-Ray's faked caustics (lights.CAUSTICS_SCALE times `caustics`: the exponent)
O_CAUSTICS = 50
# the interior_texture's row (-1: none), shown where the raw normal points along the ray
O_INSIDE_TEX = 51
PRIM_SLOTS = 24
T_PIG, T_TRANS, T_LIT, T_AMB, T_EMIS = 0, 23, 24, 25, 28
T_DIFF, T_BRIL, T_SPEC, T_ROUGH, T_PHONG, T_PHSIZE, T_METAL = range(31, 38)
# T_NEXT: the row of the layer below (-1: the last); a texture's first row holds T_TRANS, T_LIT
T_RMIN, T_RMAX, T_FALLOFF, T_REXP, T_RMETAL, T_CONSERVE, T_NEXT = 38, 41, 44, 45, 46, 47, 48
# crand, diffuse_back, fresnel reflection, irid (amount, thickness, turbulence); T_BACKLIT:
# some layer has diffuse_back (on the texture's first row: lights are tested from both sides)
T_CRAND, T_DBACK, T_FRESNEL, T_IRID, T_BACKLIT = 49, 50, 51, 52, 55
# T_NRM: the layer's normal row (-1: none); T_BUMPY (a texture's first row): some layer has
# one, so lights are tested from both sides (lights.light_colours)
T_NRM, T_BUMPY = 56, 57
# a patterned texture: T_PIG names its pattern row, whose entries name texture rows
T_PAT = 58
L_KIND, L_POS, L_COL, L_SHADOWLESS, L_FADEPOW, L_FADEDIST = 0, 1, 4, 7, 8, 9
L_AXIS, L_TIGHT, L_COSR, L_COSF = 10, 13, 14, 15
# an area light: its grid, adaptive level, orient and circular flags, axes
L_AREA, L_N1, L_N2, L_ADAPTIVE, L_ORIENT, L_CIRCULAR, L_A1, L_A2 = 16, 17, 18, 19, 20, 21, 22, 25
# the image maps' pixels (the values of a pixel after another's, rows from the top): where
# they start, how many values
H_IMAGES, H_NIMAGE = 110, 111
KINDS = {
    shapes.SpherePrim: 0,
    shapes.PlanePrim: 1,
    shapes.BoxPrim: 2,
    shapes.DiscPrim: 3,
    shapes.ConePrim: 4,
    shapes.TorusPrim: 5,
    PolyPrim: 6,
    PrismPrim: 7,
    TextPrim: 7,
    shapes.PolygonPrim: 8,
    SuperellipsoidPrim: 11,  # (9: K_MESH)
    LathePrim: 12,
    SorPrim: 13,
    blob.BlobPrim: 10,
}
# an object made of triangles (a mesh, mesh2, triangle, height field): met through the
# triangles' box tree, never as a primitive
K_MESH = 9
# a superellipsoid searched in more cells (tolerances.SUPERELLIPSOID_CELLS) renders through
# numpy (kernel/superellipsoid.h SE_MAX_CELLS)
SUPERELLIPSOID_MAX_CELLS = 32
FLAG_BITS = {"no_image": 1, "no_reflection": 2, "no_shadow": 4}

# The packed scene is ~400 bytes an object; past this many the numpy path (and its memory
# per object) is no worse.
MAX_OBJECTS: int = 1_000_000

# STRALA_KERNEL=numpy turns the compiled path off (to compare the two, or to bisect).
ENV = "STRALA_KERNEL"


def kernel_built() -> bool:
    """Whether the compiled kernel (runtime._whitted) was built and loads."""
    return _whitted is not None


def kernel_layout() -> dict[str, int]:
    """The packed layout the compiled kernel was built with (`layout()` must match it)."""
    return _whitted.layout()


def trace_packed(
    buf: np.ndarray,
    x0: int,
    y0: int,
    x1: int,
    y1: int,
    threshold: float,
    power: float,
    depth: int,
    out: np.ndarray,
    stage: int = 0,
    first: np.ndarray | None = None,
) -> tuple[int, int, int]:
    """Trace one tile of a packed scene (`pack`) into `out` with the compiled kernel:
    (rays, shadow rays, supersampled pixels). The kernel checks the packed tables first and
    raises ValueError on a damaged one. With anti-aliasing, stage 1 only traces the first
    rays of the tile and its border into `first` ((h + 1 + b, w + 1 + r, 3) as
    `runtime.antialias.edge_mask` lays them out), stage 2 only refines them into `out`."""
    return _whitted.render_tile(buf, x0, y0, x1, y1, threshold, power, depth, out, stage, first)


def available() -> bool:
    return kernel_built() and os.environ.get(ENV, "") != "numpy"


def layout() -> dict[str, int]:
    return {
        "header": HDR,
        "object": OBJ,
        "texture": TEX,
        "light": LIT,
        "pigment": PIG,
        "normal": NRM,
        "map_entry": MAP_ENTRY,
        "node": NODE,
        "max_crossings": MAX_CROSS,
        "bvh": BVH,
        "bvh_stack": BVH_STACK,
        "fog": FOG,
        "max_layers": MAX_LAYERS,
        "triangle": TRI,
        "blob_piece": blob.PIECE,
        "superellipsoid_cells": SUPERELLIPSOID_MAX_CELLS,
    }


def _camera_in_matter(prepared, camera: ir.Camera) -> bool:
    """Whether an orthographic camera starts inside an object whose interior bends or fades
    light: the kernel gives every camera ray the list of the objects holding the camera's
    location (runtime.containers), and an orthographic camera's rays start elsewhere (so
    do a cylinder camera's of types 3 and 4, along its axis)."""
    if camera.kind != "orthographic" and not (camera.kind == "cylinder" and camera.cylinder > 2):
        return False
    at = np.asarray(camera.location, dtype=np.float64)[None, :]
    for leaves, _ in containers.holding(prepared, at):
        for i in leaves:
            it = prepared.objects[i].interior
            if it.ior != 1.0 or it.fade_distance != 0.0:
                return True
    return False


def reasons(prepared, camera: ir.Camera, ctx=None) -> list[str]:
    """Why the compiled kernel cannot render this scene (empty: it can). With the render's
    context (integrate.make_context), textures it made one entry are looked at once."""
    scene: ir.Scene = prepared.scene
    out: list[str] = []
    if not kernel_built():
        out.append("the compiled kernel is not built")
    if camera.kind not in CAMERAS or camera.mesh is not None:
        out.append(f"{camera.kind} camera")
    if camera.aperture != 0.0 and camera.blur_samples > 0:
        out.append("focal blur")
    if camera.normal is not None:
        if camera.kind not in ("perspective", "orthographic"):
            out.append(f"camera normal on a {camera.kind} camera")
        out.extend(normal_reasons(camera.normal))
    if scene.settings.radiosity is not None:
        out.append("radiosity")
    if scene.media:
        out.append("media")
    fogs = fog.scene_fogs(scene)
    if fogs and any(lt.media_attenuation and lt.media_interaction for lt in scene.lights):
        out.append("a light's media_attenuation through fog")
    if scene.rainbows:
        out.append("rainbow")
    tracer = prepared.tracer
    if tracer.triangles is not None:
        out.extend(_triangle_reasons(prepared))
    if len(tracer.nodes) > MAX_OBJECTS:
        out.append(f"more than {MAX_OBJECTS} objects")
    if _tree_depth(tracer) >= BVH_STACK - 2:
        out.append("a box tree deeper than the kernel's stack")
    for node in tracer.nodes:
        out.extend(_uncovered(node))
    # each interior and texture once: a large scene's objects share them, or (textures)
    # ones equal to them, which make_context made one entry (ctx.leaf_id)
    interiors = {id(o.interior): o.interior for o in prepared.objects}
    if any(it.media for it in interiors.values()):
        out.append("interior media")
    if _camera_in_matter(prepared, camera):
        out.append("an orthographic camera inside an object with an ior or fading")
    seen: set[tuple[str, int]] = set()
    for obj in prepared.objects:
        if obj.interior_texture is not None and ("inside", id(obj.interior_texture)) not in seen:
            seen.add(("inside", id(obj.interior_texture)))
            out.extend(texture_reasons(obj.interior_texture))
        tex = obj.texture
        entry = None if ctx is None else ctx.leaf_id.get(id(tex))
        key = ("entry", entry) if entry is not None else ("object", id(tex))
        if key not in seen:
            seen.add(key)
            out.extend(texture_reasons(tex))
    for pig in scene.sky_sphere or ():
        out.extend(pigment_reasons(pig))
    if any(r is not None for r in getattr(prepared, "receivers", ())):
        out.append("light groups")
    for light in scene.lights:
        if light.kind not in ("point", "spotlight"):
            out.append(f"{light.kind} light")
        if light.projected_through is not None:
            out.append("projected_through")
        area = light.area
        if area is not None and area.size1 * area.size2 > ir.AREA_SAMPLES:
            out.append("an area light of more than 1,000,000 samples")
    return sorted(set(out))


def pack_fog(f: ir.Fog, row: np.ndarray) -> None:
    """One fog row (fog.fog_attenuation's inputs; `up` made unit as it does)."""
    row[F_DIST] = f.distance
    row[F_COL : F_COL + 5] = f.color
    row[F_TYPE], row[F_OFFSET], row[F_ALT] = f.fog_type, f.offset, f.alt
    up = np.asarray(f.up, dtype=np.float64)
    row[F_UP : F_UP + 3] = up / np.linalg.norm(up)
    if f.turbulence is not None:
        row[F_HASTURB] = 1.0
        row[F_TURB : F_TURB + 3] = f.turbulence
    row[F_OCTAVES], row[F_OMEGA], row[F_LAMBDA] = f.octaves, f.omega, f.lam
    row[F_TDEPTH] = f.turb_depth


def _noise_tables() -> np.ndarray:
    """POV-Ray's noise tables as the kernel reads them (kernel/noise.h): the hash
    permutation, the value table and its halves, generator 3's permutation and gradients,
    the cells' random values."""
    t = noise.tables()
    parts = (t.hash, t.rtable, t.half, t.solid_perm, t.solid_grads.ravel(), t.pattern_rands)
    return np.concatenate([np.asarray(a, dtype=np.float64) for a in parts])


def _tree_depth(tracer) -> int:
    return 1 if tracer.tree is None else _depth(tracer.tree)


def _depth(tree: BoxTree) -> int:
    depth, stack = 0, [(0, 1)]
    while stack:
        k, level = stack.pop()
        depth = max(depth, level)
        kids = tree.kids[k]
        if kids is not None:
            stack.extend((c, level + 1) for c in kids)
    return depth


def box_tree(tracer) -> tuple[np.ndarray, list[int]]:
    """(rows, items): the tracer's box tree over its bounded roots (one leaf holding them
    all when it has none), as BVH rows and the flat list of root indices of its leaves."""
    bounded = tracer.bounded
    if not bounded:
        return np.zeros((0, BVH)), []
    tree = tracer.tree
    if tree is None:
        lo = np.min([tracer.nodes[i].lo for i in bounded], axis=0)
        hi = np.max([tracer.nodes[i].hi for i in bounded], axis=0)
        row = np.concatenate([lo, hi, [-1, -1, 0, len(bounded), 0]])
        return row[None, :], list(bounded)
    return _tree_rows(tree, bounded)


def _tree_rows(tree: BoxTree, ids) -> tuple[np.ndarray, list[int]]:
    """A box tree as BVH rows, and its leaves' items (as `ids`, one run per leaf)."""
    m = len(tree.lo)
    rows = np.zeros((m, BVH))
    lo, hi = np.array(tree.lo).reshape(m, 3), np.array(tree.hi).reshape(m, 3)
    rows[:, 0:3], rows[:, 3:6] = lo, hi
    inner = np.array([k for k in range(m) if tree.kids[k] is not None], dtype=np.int64)
    leaves = [k for k in range(m) if tree.kids[k] is None]
    # each tree leaf's roots, one run after another in `items` (in whole columns)
    runs = [tree.items[k] for k in leaves]
    counts = np.array([len(r) for r in runs], dtype=np.int64)
    rows[leaves, 6:8] = -1
    rows[leaves, 8] = np.cumsum(counts) - counts
    rows[leaves, 9] = counts
    items = np.asarray(ids, dtype=np.int64)[np.concatenate(runs)].tolist()
    if len(inner):
        kids = np.array([tree.kids[k] for k in inner], dtype=np.int64).reshape(-1, 2)
        left, right = kids[:, 0], kids[:, 1]
        # the axis along which the children's centres lie furthest apart, ordered so that the
        # left one is lower (the kernel visits the near child first)
        gap = (lo[right] + hi[right]) - (lo[left] + hi[left])
        axis = np.argmax(np.abs(gap), axis=1)
        swap = gap[np.arange(len(inner)), axis] < 0
        rows[inner, 6] = np.where(swap, right, left)
        rows[inner, 7] = np.where(swap, left, right)
        rows[inner, 10] = axis
    return rows, items


# the triangles' box trees, built once per triangle set (reasons asks for their depth, pack
# for their rows)
_TRIANGLE_TREES: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()


def _triangles_kept(triangles) -> np.ndarray:
    """The triangles the kernel traces: the hittable ones (as in Embree's scenes) of objects
    not traced as solids of CSG."""
    keep = triangles.hittable
    if triangles.solid:
        keep = keep & ~np.isin(triangles.leaf_of, list(triangles.solid))
    return np.nonzero(keep)[0]


def _triangle_tree(triangles) -> tuple[BoxTree | None, np.ndarray, int]:
    """The box tree over the kept triangles (None: there are none), their indices and the
    tree's depth."""
    if triangles not in _TRIANGLE_TREES:
        ids = _triangles_kept(triangles)
        tree, depth = None, 0
        if len(ids):
            tri = triangles.tri[ids]
            tree = BoxTree(tri.min(axis=1), tri.max(axis=1))
            depth = _depth(tree)
        _TRIANGLE_TREES[triangles] = (tree, ids, depth)
    return _TRIANGLE_TREES[triangles]


def _triangle_reasons(prepared) -> list[str]:
    triangles = prepared.tracer.triangles
    curved = getattr(prepared, "curved", None)
    out = []
    if curved is not None and curved.any():
        # their shadow rays start on the curved surface (triangles.terminator_points)
        out.append("meshes tessellated from curved surfaces")
    if len(triangles.tri) > MAX_OBJECTS:
        out.append(f"more than {MAX_OBJECTS} triangles")
        return out
    if _triangle_tree(triangles)[2] >= BVH_STACK - 2:
        out.append("a triangles' box tree deeper than the kernel's stack")
    return out


def _pack_triangles(ctx) -> tuple[np.ndarray, np.ndarray, list[int]]:
    """(triangle rows, their box tree's rows, its leaves' triangles) of the scene."""
    t = ctx.tracer.triangles
    tree, ids, _ = (None, None, 0) if t is None else _triangle_tree(t)
    if tree is None or ids is None:
        return np.zeros((0, TRI)), np.zeros((0, BVH)), []
    rows = np.empty((len(ids), TRI))
    rows[:, TR_V0 : TR_V0 + 3] = t.v0[ids]
    rows[:, TR_E1 : TR_E1 + 3] = t.e1[ids]
    rows[:, TR_E2 : TR_E2 + 3] = t.e2[ids]
    rows[:, TR_NG : TR_NG + 3] = t.ng[ids]
    rows[:, TR_VN : TR_VN + 9] = t.vn[ids].reshape(-1, 9)  # NaN rows: flat triangles
    rows[:, TR_OBJ] = t.leaf_of[ids]
    rows[:, TR_TEX] = ctx.texture_of(t.leaf_of[ids].astype(np.int64), t.local[ids])
    rows[:, TR_SIZE] = t.tri_size[ids]
    bvh, items = _tree_rows(tree, np.arange(len(ids)))
    return rows, bvh, items


# A box counts as outside a half space only beyond this share of its distance from the
# plane's point, so that rounding along a ray near the border cannot reach it.
VIEW_MARGIN_REL = 1e-9


def view_masks(bvh: np.ndarray, camera: ir.Camera, width: int, height: int, lights) -> np.ndarray:
    """(len(bvh), 1 + len(lights)) 0/1: may a camera ray (column 0), or a shadow ray from a
    camera ray's hit toward light l (column 1 + l), meet box-tree node k's box?

    Camera rays stay inside the view's half spaces (see `camera.view_planes`), so a box wholly
    outside one of them is never met by one. A shadow ray runs from such a hit, inside every
    half space, to its light: when the light lies inside the half space the box is outside
    of, so does the whole segment. 1 everywhere when the view cannot be bounded."""
    masks = np.ones((len(bvh), 1 + len(lights)))
    planes = view_planes(camera, width, height)
    if not planes or not len(bvh):
        return masks
    lo, hi = bvh[:, 0:3], bvh[:, 3:6]
    pad = tol.BOX_PAD_REL * (np.abs(lo) + np.abs(hi)) + tol.BOX_PAD_ABS
    lo, hi = lo - pad, hi + pad
    pick = np.array([[i >> k & 1 for k in range(3)] for i in range(8)], dtype=bool)
    corners = np.where(pick[None, :, :], hi[:, None, :], lo[:, None, :])  # (m, 8, 3)
    for n, p0 in planes:
        rel = corners - p0
        side = rel @ n
        margin = VIEW_MARGIN_REL * np.sqrt((rel * rel).sum(axis=2)).max(axis=1) + tol.ABS_FLOOR
        outside = side.min(axis=1) > margin
        masks[outside, 0] = 0.0
        for i, light in enumerate(lights):
            if float(n @ (np.asarray(light.position, dtype=np.float64) - p0)) <= 0.0:
                masks[outside, 1 + i] = 0.0
    return masks


def walk_starts(bvh: np.ndarray, masks: np.ndarray) -> np.ndarray:
    """Per ray class (a column of `masks`), the box-tree node its walk can start at: below
    the root, past every node of which the class can meet one child only (a crowd of
    objects outside the view then costs camera rays nothing, not even a box test); -1 when
    it can meet none."""
    starts = np.zeros(masks.shape[1])
    for c in range(masks.shape[1]):
        k = 0 if len(bvh) else -1
        while k >= 0 and bvh[k, 6] >= 0:
            left, right = int(bvh[k, 6]), int(bvh[k, 7])
            ml, mr = masks[left, c] > 0, masks[right, c] > 0
            if ml == mr:
                k = k if ml else -1
                break
            k = left if ml else right
        if k >= 0 and masks[k, c] == 0:
            k = -1
        starts[c] = k
    return starts


def _uncovered(node) -> set[str]:
    """What in a node the kernel cannot trace (empty: all of it)."""
    if isinstance(node, Leaf):
        if type(node.prim) is PolyPrim and node.prim.degree > POLY_MAX_DEGREE:
            return {f"a polynomial of degree above {POLY_MAX_DEGREE}"}
        cells = tol.SUPERELLIPSOID_CELLS
        if type(node.prim) is SuperellipsoidPrim and not 1 <= cells <= SUPERELLIPSOID_MAX_CELLS:
            return {f"superellipsoid cells outside 1-{SUPERELLIPSOID_MAX_CELLS}"}
        if type(node.prim) in KINDS:
            return set()
        return {f"shape {type(node.prim).__name__.removesuffix('Prim').lower()}"}
    if isinstance(node, ClipNode):
        return set().union(*(_uncovered(c) for c in _kids(node)))
    if not isinstance(node, CsgNode):
        return {"triangle geometry in CSG"}
    out = set() if node.op in OPS else {f"CSG {node.op}"}
    for child in node.children:
        out |= _uncovered(child)
    return out


def _kids(node) -> list:
    """A node's children as the kernel walks them: a clip's object, then its clips."""
    if isinstance(node, ClipNode):
        return [node.inner, *node.clips]
    return list(node.children)


def _nodes(roots: list) -> tuple[list, list[int], dict[int, int]]:
    """Every node, roots first, each node's children after it (breadth first); the flat
    list of child indices; where each CSG node's children start in it (by id)."""
    if all(type(n) is Leaf for n in roots):  # a scene without CSG: nothing to walk
        return list(roots), [], {}
    order, index = list(roots), {id(n): i for i, n in enumerate(roots)}
    children: list[int] = []
    k = 0
    while k < len(order):
        node = order[k]
        for c in () if isinstance(node, Leaf) else _kids(node):
            index[id(c)] = len(order)
            order.append(c)
        k += 1
    firsts = {}
    for node in order:
        if not isinstance(node, Leaf):
            firsts[id(node)] = len(children)
            children.extend(index[id(c)] for c in _kids(node))
    return order, children, firsts


def _index(leaf) -> int:
    return leaf.index


class _MeshRow:
    """The object row of an object made of triangles: untransformed (its triangles are in
    world space), no primitive."""

    prim = None
    identity, inverse = True, False

    def __init__(self, index: int, size: float):
        self.index, self.size = index, float(size)


def _table(rows: list, width: int) -> np.ndarray:
    """(len(rows), width) float64, also for no rows (a scene with no objects)."""
    return np.array(rows, dtype=np.float64).reshape(len(rows), width)


def _segment_rows(c: spline2d.Curve) -> np.ndarray:
    """A curve's segments for the sweeps' table: each its x and y cubics, exact box and
    whether its end joins a start (kernel/sweep.h SS values)."""
    if len(c) == 0:
        return np.zeros(0)
    segs = np.concatenate(
        [c.coef[:, 0], c.coef[:, 1], c.lo, c.hi, c.joined[:, None].astype(np.float64)], axis=1
    )
    return segs.ravel()


def _sweep_rows(prim: Sweep) -> np.ndarray:
    """A sweep's part of the sweeps' table: per group its box, first segment and count, then
    its segments."""
    groups = [
        [*prim.glo[g], *prim.ghi[g], prim.offsets[g], len(curve)]
        for g, curve in enumerate(prim.groups)
    ]
    return np.concatenate([_table(groups, SWEEP_GROUP).ravel(), _segment_rows(prim.all)])


class _Curves:
    """The parts of the sweeps' table, and where the next starts (summing the parts' lengths
    for each of 17,000 polygons was most of a scene's packing)."""

    def __init__(self) -> None:
        self.parts: list[np.ndarray] = []
        self.size = 0

    def add(self, rows: np.ndarray) -> int:
        at = self.size
        self.parts.append(rows)
        self.size += len(rows)
        return at


def _prim_row(prim, terms: list[list[float]], sweeps: _Curves, blobs: _Curves) -> list[float]:
    """A primitive's parameters (PRIM_SLOTS of them): plane normal and distance, box
    corners, disc centre, normal, radius^2 and hole^2, cone/cylinder canonical frame (object
    to canonical rows), radii and openness; a polynomial's terms, a sweep's curves and a
    blob's pieces go to their tables (`terms`, `sweeps`, `blobs`). A sphere's (centre and
    radius) are written by pack, all spheres at once."""
    if isinstance(prim, shapes.PlanePrim):
        row = [*prim.n.tolist(), prim.dist]
    elif isinstance(prim, shapes.BoxPrim):
        row = [*prim.lo.tolist(), *prim.hi.tolist()]
    elif isinstance(prim, shapes.DiscPrim):
        row = [*prim.c.tolist(), *prim.n.tolist(), prim.r2, prim.h2]
    elif isinstance(prim, shapes.ConePrim):
        row = [*prim.frame_inv[:3].ravel().tolist(), prim.r0, prim.r1, float(prim.open)]
    elif isinstance(prim, shapes.TorusPrim):
        row = [prim.R, prim.r]
    elif isinstance(prim, PolyPrim):
        row = [len(terms), len(prim.c), prim.degree, prim.inside_eps, prim.size]
        terms.extend(map(list, zip(prim.i, prim.j, prim.k, prim.c, strict=True)))
    elif isinstance(prim, shapes.PolygonPrim):
        # its projected edges go to the sweeps' table, a flat table of curves
        at = sweeps.add(prim.e2.reshape(-1).astype(np.float64))
        row = [*prim.n.tolist(), prim.D, *prim.keep, at, len(prim.e2), float(prim.degenerate)]
    elif isinstance(prim, SuperellipsoidPrim):  # kernel/superellipsoid.h's slots
        row = [prim.e, prim.n, prim.p, prim.q, float(prim.convex), tol.SUPERELLIPSOID_BOX_PAD]
        row += [tol.SUPERELLIPSOID_CELLS, tol.SUPERELLIPSOID_INSET, tol.SUPERELLIPSOID_MIN_ITER]
        row += [tol.SUPERELLIPSOID_INSIDE, tol.ABS_FLOOR, tol.PARALLEL_EPS, tol.ROOT_MAX_ITER]
    elif isinstance(prim, LathePrim):  # kernel/lathe.h LA_ slots
        at = sweeps.add(_segment_rows(prim.curve))
        row = [at, len(prim.curve), *prim.lo, *prim.hi, prim.size]
        row += [prim.ylo, prim.yhi, prim.degenerate]
        row += [tol.ROOT_MAX_ITER, tol.LATHE_FLAT_DIR, tol.BOX_PAD_REL, tol.BOX_PAD_ABS]
    elif isinstance(prim, SorPrim):  # kernel/lathe.h SO_ slots
        segs = np.concatenate([prim.coef, prim.y, prim.rmin[:, None], prim.rmax[:, None]], axis=1)
        at = sweeps.add(segs.ravel())
        row = [at, len(prim.coef), *prim.lo, *prim.hi, prim.size, prim.ylo, prim.yhi]
        row += [prim.open, prim.base_r2, prim.cap_r2, prim.degenerate]
        row += [tol.SOR_CAP_MIN_R2, tol.BOX_PAD_REL, tol.BOX_PAD_ABS]
    elif isinstance(prim, blob.BlobPrim):
        at = blobs.add(prim.table().ravel())
        row = [at, len(prim.s), prim.threshold, *prim.centre.tolist()]
    elif isinstance(prim, Sweep):
        at = sweeps.add(_sweep_rows(prim))
        row = [at, len(prim.groups), len(prim.all), prim.h1, prim.h2, *prim.axes]
        row += [prim.conic, prim.open, prim.size, *prim.lo, *prim.hi, prim.degenerate]
    else:
        raise TypeError(f"no kernel row for {type(prim).__name__}")
    return row + [0.0] * (PRIM_SLOTS - len(row))


_IDENTITY_ROWS = inv_rows(np.eye(4))


def _pack_camera(camera: ir.Camera, h: np.ndarray) -> None:
    """The projection and what it reads, computed as camera.py computes them."""
    h[H_CAMKIND] = CAMERAS.get(camera.kind, 0)
    h[H_CAMANGLE] = np.radians(90.0 if camera.angle is None else camera.angle)
    h[H_CAMCYL] = camera.cylinder or 1
    turn = 360.0 if camera.angle is None else camera.angle
    h[H_CAMH] = np.radians(turn)
    h[H_CAMV] = np.radians(camera.v_angle if camera.v_angle is not None else turn / 2.0)
    h[H_CAMLR] = np.linalg.norm(np.asarray(camera.right, dtype=np.float64))
    h[H_CAMLU] = np.linalg.norm(np.asarray(camera.up, dtype=np.float64))
    h[H_CAMRN : H_CAMRN + 3] = tf.normalize(camera.right)
    h[H_CAMUN : H_CAMUN + 3] = tf.normalize(camera.up)
    h[H_CAMDN : H_CAMDN + 3] = tf.normalize(camera.direction)
    h[H_CAMTAN] = np.tan(np.radians(135.0))


def pack(ctx, camera: ir.Camera, width: int, height: int) -> np.ndarray:
    """The scene as the kernel reads it (see the layout above)."""
    prepared = ctx.prepared
    scene: ir.Scene = prepared.scene
    tracer = prepared.tracer
    objs = prepared.objects
    s = scene.settings
    nodes, children, firsts = _nodes(list(tracer.nodes))
    leaves: list = [n for n in nodes if isinstance(n, Leaf) and n.index >= 0]
    if tracer.triangles is not None:  # objects of triangles get a row, for what they share
        leaves += [_MeshRow(i, tracer.sizes[i]) for i in tracer.triangles.first]
    leaves.sort(key=_index)
    assert [n.index for n in leaves] == list(range(len(objs))), "one leaf per object"
    # clipping shapes (no object: never hit) get object rows after the objects', for their
    # inside tests
    n_real = len(leaves)
    leaves += [n for n in nodes if isinstance(n, Leaf) and n.index < 0]
    row_of = {id(leaf): k for k, leaf in enumerate(leaves)}
    n_obj, n_light = len(leaves), len(scene.lights)
    # a texture's first layer is its row (objects point there); the layers below it get
    # rows after all the textures', chained by T_NEXT
    # (a patterned texture's row names its pattern and textures: it has no layers)
    layer_rows = [[] if t in ctx.tree else list(ls) for t, ls in enumerate(ctx.textures)]
    below = [layer for layers in layer_rows for layer in layers[1:]]
    n_tex = len(ctx.textures) + len(below)
    sky = list(reversed(scene.sky_sphere or ()))  # evaluated innermost first, as integrate.sky
    tops = [
        pattern_of(ctx.tree[t]) if t in ctx.tree else layers[0].pigment
        for t, layers in enumerate(layer_rows)
    ] + [t.pigment for t in below]
    # the pigments inside pigments after the textures' (the sky's stay last, kernel's rule)
    inner = inner_pigments(tops + sky)
    n_pig = n_tex + len(inner) + len(sky)
    n_node = len(nodes)
    bvh, items = box_tree(tracer)
    unbounded = list(tracer.unbounded)
    loose = list(tracer.loose)
    size = HDR + n_obj * OBJ + n_tex * TEX + n_light * LIT + n_pig * PIG + n_node * NODE
    masks = view_masks(bvh, camera, width, height, scene.lights)
    starts = walk_starts(bvh, masks)
    tail = np.concatenate([children, unbounded, loose, bvh.ravel(), items, masks.ravel(), starts])
    tail = tail.astype(np.float64)
    pigs = tops + inner + sky
    fogs = list(fog.scene_fogs(scene))
    films = [layer.finish.irid for layers in layer_rows for layer in layers]
    # the layers' normals, in the order of the layer rows (`rows_of` below)
    layered = [layers[0] for layers in layer_rows if layers] + below
    bumped = [layer for layer in layered if layer.normal is not None]
    # the normals' rows: the layers', then the camera's
    normals = [(layer.normal, layer.no_bump_scale) for layer in bumped]
    if camera.normal is not None:
        normals.append((camera.normal, False))
    noisy = (
        bool(normals)
        or any(needs_noise(p) for p in pigs)
        or any(f.turbulence is not None for f in fogs)
        or any(irid is not None and irid[0] > 0 and irid[2] != 0 for irid in films)
    )
    tables = _noise_tables() if noisy else np.zeros(0)
    # pigment row k is pigs[k]'s: packed first, for the length of their colour maps' table
    pig_rows = np.zeros((n_pig, PIG))
    maps: list[list[float]] = []
    pig_row_of = {id(pig): k for k, pig in enumerate(pigs)}
    images = Images()
    for k, (pig, row) in enumerate(zip(pigs, pig_rows, strict=True)):
        if k in ctx.tree:  # a patterned texture's row: its pattern, its textures' rows
            pack_texture_pattern(ctx.tree[k], row, maps, ctx.leaf_id)
        else:
            pack_pigment(pig, row, maps, pig_row_of, images, ctx.gamma)
    packed_normals = normal_rows(normals)
    nrm_rows = np.zeros((len(packed_normals), NRM))
    for (nrm, keep, subs), row in zip(packed_normals, nrm_rows, strict=True):
        assert nrm is not None  # bumped holds the layers with one
        pack_normal(nrm, keep, row, maps, subs, images)
    maps_at = size + len(tail)
    fogs_at = maps_at + MAP_ENTRY * len(maps)
    terms_at = fogs_at + FOG * len(fogs)
    n_terms = sum(len(leaf.prim.c) for leaf in leaves if type(leaf.prim) is PolyPrim)
    nrms_at = terms_at + POLY_TERM * n_terms
    sweeps_at = nrms_at + NRM * len(packed_normals)
    n_sweep = sum(
        SWEEP_GROUP * len(leaf.prim.groups) + SWEEP_SEGMENT * len(leaf.prim.all)
        for leaf in leaves
        if isinstance(leaf.prim, Sweep)
    ) + sum(4 * len(leaf.prim.e2) for leaf in leaves if isinstance(leaf.prim, shapes.PolygonPrim))
    n_sweep += sum(
        SWEEP_SEGMENT * len(leaf.prim.curve) for leaf in leaves if type(leaf.prim) is LathePrim
    )
    n_sweep += sum(
        SOR_SEGMENT * len(leaf.prim.coef) for leaf in leaves if type(leaf.prim) is SorPrim
    )
    tri_rows, tri_bvh, tri_items = _pack_triangles(ctx)
    tris_at = sweeps_at + n_sweep
    tbvh_at = tris_at + TRI * len(tri_rows)
    titems_at = tbvh_at + BVH * len(tri_bvh)
    images_at = titems_at + len(tri_items)
    blobs_at = images_at + images.size
    n_blob = sum(
        blob.PIECE * len(leaf.prim.s) for leaf in leaves if type(leaf.prim) is blob.BlobPrim
    )
    buf = np.zeros(blobs_at + n_blob + len(tables))
    h = buf[:HDR]
    h[H_IMAGES], h[H_NIMAGE] = images_at, images.size
    if images.parts:
        buf[images_at : images_at + images.size] = np.concatenate([a.ravel() for a in images.parts])
    h[H_TRIS], h[H_NTRI], h[H_TBVH], h[H_NTBVH] = tris_at, len(tri_rows), tbvh_at, len(tri_bvh)
    h[H_TITEMS], h[H_NTITEM] = titems_at, len(tri_items)
    buf[tris_at:tbvh_at] = tri_rows.ravel()
    buf[tbvh_at:titems_at] = tri_bvh.ravel()
    buf[titems_at : titems_at + len(tri_items)] = tri_items
    buf[nrms_at : nrms_at + NRM * len(packed_normals)] = nrm_rows.ravel()
    h[H_NRMS], h[H_NNRM] = nrms_at, len(packed_normals)
    h[H_CAMNRM] = len(bumped) if camera.normal is not None else -1
    h[[H_NOBJ, H_NTEX, H_NLIGHT, H_NPIG, H_NSKY]] = n_obj, n_tex, n_light, n_pig, len(sky)
    h[[H_NNODE, H_NROOT, H_NCHILD]] = n_node, len(tracer.nodes), len(children)
    h[[H_NUNB, H_NBVH, H_NITEM, H_NLOOSE]] = len(unbounded), len(bvh), len(items), len(loose)
    h[H_MASK] = 1.0
    h[H_MAXLEVEL], h[H_BAILOUT] = s.max_trace_level, s.adc_bailout
    held = containers.camera_stacks(ctx, np.asarray(camera.location, dtype=np.float64)[None])[0]
    held = held[held >= 0]
    h[H_CAMIN] = len(held)
    h[H_CAMIN + 1 : H_CAMIN + 1 + len(held)] = held
    iors = H_CAMIN + 1 + interiors.DEPTH
    h[iors : iors + len(held)] = ctx.interior_ior[held]
    h[H_AMB : H_AMB + 3] = s.ambient_light
    h[H_BG : H_BG + 3] = ctx.background
    h[H_LEGACY] = ctx.legacy_opacity
    h[H_ANYTRANS] = bool(ctx.transmits.any())
    _pack_camera(camera, h)
    h[H_WIDTH], h[H_HEIGHT] = width, height
    for at, v in ((H_LOC, camera.location), (H_DIR, camera.direction)):
        h[at : at + 3] = v
    h[H_RIGHT : H_RIGHT + 3] = camera.right
    h[H_UP : H_UP + 3] = camera.up
    # Read here, not compiled in: one source for every tolerance (and tests that vary one).
    h[H_TOL : H_TOL + 11] = (
        tol.ORIGIN_REL,
        tol.OBJECT_REL,
        tol.ABS_FLOOR,
        tol.PARALLEL_EPS,
        shading.EPSILON,
        shading.SHADOW_TOLERANCE,
        patterns.CHECKER_OFFSET,
        MAX_SHADOW_CROSSINGS,
        tol.INSIDE_EPS,
        tol.BOX_PAD_REL,
        tol.BOX_PAD_ABS,
    )
    # Whole columns at once: a scene may have thousands of objects, and a numpy assignment
    # per field and object cost more than tracing the hidden ones.
    rows = buf[HDR : HDR + n_obj * OBJ].reshape(n_obj, OBJ)
    rows[:, O_KIND] = [KINDS.get(type(leaf.prim), K_MESH) for leaf in leaves]
    rows[:, O_IDENT] = [leaf.identity for leaf in leaves]
    rows[:, O_FLIP] = [leaf.inverse for leaf in leaves]
    rows[:, O_SIZE] = [leaf.size for leaf in leaves]
    rows[:n_real, O_SIZE] = tracer.sizes[:n_real]
    real = rows[:n_real]  # the clips' rows keep texture 0, no flags, the default interior
    real[:, O_TEX] = ctx.obj_tex
    for flag, bit in FLAG_BITS.items():
        if tracer.flags.get(flag) is not None:
            real[:, O_FLAGS] += bit * np.asarray(tracer.flags[flag], dtype=bool)
    real[:, O_DOUBLE] = ctx.double_illuminate
    rows[:, O_IOR] = 1.0
    real[:, O_IOR] = ctx.ior
    rows[:, O_INTERIOR] = -1.0
    real[:, O_INTERIOR] = ctx.interior_id  # runtime.interiors: told apart by identity
    # Untransformed leaves (most of a big scene) share one matrix row: only the others are
    # written one by one.
    rows[:, O_MINV : O_MINV + 12] = _IDENTITY_ROWS
    for k, leaf in enumerate(leaves):
        if not leaf.identity:
            rows[k, O_MINV : O_MINV + 12] = inv_rows(leaf.m_inv)
    # spheres, the bulk of a large scene, in one gather (centre, radius); the other shapes
    # row by row
    spheres = [k for k, leaf in enumerate(leaves) if type(leaf.prim) is shapes.SpherePrim]
    if spheres:
        rows[spheres, O_PRIM : O_PRIM + 3] = [leaves[k].prim.c for k in spheres]
        rows[spheres, O_PRIM + 3] = [leaves[k].prim.r for k in spheres]
    others = [
        k
        for k, leaf in enumerate(leaves)
        if type(leaf.prim) in KINDS and type(leaf.prim) is not shapes.SpherePrim
    ]
    terms: list[list[float]] = []
    sweeps, blobs = _Curves(), _Curves()
    if others:
        rows[others, O_PRIM : O_PRIM + PRIM_SLOTS] = _table(
            [_prim_row(leaves[k].prim, terms, sweeps, blobs) for k in others], PRIM_SLOTS
        )
    h[H_BLOBS], h[H_NBLOB], h[H_BLOB_INSIDE] = blobs_at, n_blob, tol.BLOB_INSIDE
    if blobs.parts:
        buf[blobs_at : blobs_at + n_blob] = np.concatenate(blobs.parts)
    h[H_TERMS], h[H_NTERMS] = terms_at, len(terms)
    h[H_SWEEPS], h[H_NSWEEP] = sweeps_at, n_sweep
    h[H_SWEEP_TOL : H_SWEEP_TOL + 5] = (
        tol.LEAD_REL,
        tol.NEWTON_STEPS,
        tol.NEWTON_MAX_STEP_REL,
        tol.SPLINE_PARAM_EPS,
        tol.SWEEP_SIDE_REL,
    )
    if sweeps.parts:
        buf[sweeps_at : sweeps_at + n_sweep] = np.concatenate(sweeps.parts)
    h[H_POLY_REACH], h[H_POLY_LEAD], h[H_ROOT_ITER] = (
        tol.POLY_REACH,
        tol.POLY_LEAD_REL,
        tol.ROOT_MAX_ITER,
    )
    buf[terms_at : terms_at + POLY_TERM * len(terms)] = np.ravel(terms)
    fades: dict[int, tuple] = {}  # by interior: objects share their default one
    for it in (o.interior for o in objs):
        if id(it) not in fades:
            fades[id(it)] = (it.fade_power, it.fade_distance, *it.fade_color)
    real[:, O_FADEPOW : O_FADECOL + 3] = _table([fades[id(o.interior)] for o in objs], 5)
    real[:, O_CAUSTICS] = [lights.CAUSTICS_SCALE * o.interior.caustics for o in objs]
    rows[:, O_INSIDE_TEX] = -1.0
    real[:, O_INSIDE_TEX] = ctx.obj_inside
    start = HDR + n_obj * OBJ
    trows = buf[start : start + n_tex * TEX].reshape(n_tex, TEX)
    start += n_tex * TEX
    lrows = buf[start : start + n_light * LIT].reshape(n_light, LIT)
    start += n_light * LIT
    buf[start : start + n_pig * PIG] = pig_rows.ravel()
    start += n_pig * PIG
    nrows = buf[start : start + n_node * NODE].reshape(n_node, NODE)
    buf[start + n_node * NODE : start + n_node * NODE + len(tail)] = tail
    if noisy:
        h[H_NOISE] = len(buf) - len(tables)
        buf[len(buf) - len(tables) :] = tables
    rows_of: list[tuple[int, ir.Texture]] = []  # (texture row, the layer it shades)
    extra = len(layer_rows)
    for t, layers in enumerate(layer_rows):
        trows[t, T_TRANS], trows[t, T_LIT] = ctx.transmits[t], ctx.lit[t]
        trows[t, T_BACKLIT] = ctx.back_lit[t]
        trows[t, T_BUMPY] = ctx.bumpy[t]
        if t in ctx.tree:
            trows[t, T_PAT], trows[t, T_PIG], trows[t, T_NEXT], trows[t, T_NRM] = 1, t, -1, -1
            continue
        chain = [t, *range(extra, extra + len(layers) - 1)]
        extra += len(layers) - 1
        for k, row in enumerate(chain):
            trows[row, T_NEXT] = chain[k + 1] if k + 1 < len(chain) else -1
        rows_of.extend(zip(chain, layers, strict=True))
    nrm_of = {id(layer): k for k, layer in enumerate(bumped)}
    for t, tex in rows_of:
        r = trows[t]
        r[T_NRM] = nrm_of.get(id(tex), -1)
        f = tex.finish
        r[T_PIG] = t  # texture row t's pigment is pigment row t; the sky's follow
        r[T_AMB : T_AMB + 3] = f.ambient
        r[T_EMIS : T_EMIS + 3] = f.emission
        r[T_DIFF : T_METAL + 1] = (
            f.diffuse, f.brilliance, f.specular, f.roughness, f.phong, f.phong_size, f.metallic
        )  # fmt: skip
        rf = f.reflection
        r[T_RMIN : T_RMIN + 3] = rf.min
        r[T_RMAX : T_RMAX + 3] = rf.max
        r[T_FALLOFF], r[T_REXP], r[T_RMETAL] = rf.falloff, rf.exponent, rf.metallic
        r[T_CONSERVE] = f.conserve_energy
        r[T_CRAND], r[T_DBACK], r[T_FRESNEL] = f.crand, f.diffuse_back, rf.fresnel
        if f.irid is not None and f.irid[0] > 0:
            r[T_IRID : T_IRID + 3] = f.irid[:3]
    nrows[:, N_LO : N_LO + 3] = _table([node.lo for node in nodes], 3)
    nrows[:, N_HI : N_HI + 3] = _table([node.hi for node in nodes], 3)
    is_leaf = [isinstance(node, Leaf) for node in nodes]
    nrows[:, N_LEAF] = [
        row_of[id(node)] if leaf else 0 for node, leaf in zip(nodes, is_leaf, strict=True)
    ]
    for k in (k for k, leaf in enumerate(is_leaf) if not leaf):  # N_KIND 0 for leaves
        node, r = nodes[k], nrows[k]
        if isinstance(node, ClipNode):
            r[N_KIND], r[N_OP], r[N_INV] = 1, OP_CLIP, 0
        else:
            r[N_KIND], r[N_OP], r[N_INV] = 1, OPS[node.op], node.inverse
        r[N_FIRST], r[N_COUNT] = firsts[id(node)], len(_kids(node))
    h[H_MAPS], h[H_NMAPS] = maps_at, len(maps)
    h[H_FOGS], h[H_NFOG], h[H_FOGMAX] = fogs_at, len(fogs), fog.MAX_FOG_DISTANCE
    frows = buf[fogs_at : fogs_at + FOG * len(fogs)].reshape(len(fogs), FOG)
    for one, r in zip(fogs, frows, strict=True):
        pack_fog(one, r)
    buf[maps_at : maps_at + MAP_ENTRY * len(maps)] = np.ravel(maps)
    for light, r in zip(scene.lights, lrows, strict=True):
        r[L_KIND] = 1 if light.kind == "spotlight" else 0
        r[L_POS : L_POS + 3] = light.position
        r[L_COL : L_COL + 3] = light.color
        r[L_SHADOWLESS] = light.shadowless
        r[L_FADEPOW], r[L_FADEDIST] = light.fade_power or 0.0, light.fade_distance or 0.0
        if light.kind == "spotlight":
            r[L_AXIS : L_AXIS + 3] = tf.normalize(np.subtract(light.point_at, light.position))
            r[L_TIGHT] = light.tightness
            r[L_COSR] = math.cos(math.radians(light.radius))
            r[L_COSF] = math.cos(math.radians(light.falloff))
        area = light.area
        if area is not None and area.size1 * area.size2 > 1:  # else a point (lights.shadow)
            r[L_AREA], r[L_N1], r[L_N2] = 1, max(1, area.size1), max(1, area.size2)
            # past the grid's depth a level changes nothing (a region of one cell is not split)
            level = min(max(area.adaptive, 0), 64)
            r[L_ADAPTIVE], r[L_ORIENT], r[L_CIRCULAR] = level, area.orient, area.circular
            r[L_A1 : L_A1 + 3], r[L_A2 : L_A2 + 3] = area.axis1, area.axis2
    return buf


def probe(prepared) -> np.ndarray | None:
    """A packed scene to ask `first_hit` of (the scene language's trace() on one object),
    or None where the kernel cannot trace its shapes (their textures are not asked of)."""
    from runtime import integrate

    camera = ir.Camera()
    if not available() or reasons(prepared, camera):
        return None
    return pack(integrate.make_context(prepared), camera, 1, 1)


def first_hit(buf: np.ndarray, origin, direction) -> tuple[float, tuple] | None:
    """(t, unit normal) of the nearest surface along the ray (direction a unit vector), as
    trace.Tracer.closest gives them, or None."""
    assert _whitted is not None  # probe() returned a buffer
    ox, oy, oz = (float(v) for v in origin)
    dx, dy, dz = (float(v) for v in direction)
    return _whitted.first_hit(buf, (ox, oy, oz), (dx, dy, dz))


class Kernel:
    """A packed scene and the call that traces pixels through it."""

    def __init__(self, ctx, camera: ir.Camera, width: int, height: int):
        self.ctx = ctx
        self.width, self.height = width, height
        self.buf = pack(ctx, camera, width, height)

    def render_tile(
        self,
        tile: tuple[int, int, int, int],
        threshold: float | None,
        depth: int,
        gamma: float = color.AA_GAMMA,
        first_seen: Callable[[np.ndarray], None] | None = None,
    ) -> tuple[np.ndarray, int]:
        """(h, w, 3) colours of one tile and its number of supersampled pixels, anti-aliased
        as `runtime.antialias` does (threshold None: one ray per pixel). first_seen, with
        anti-aliasing, is given the tile's first-ray colours before they are refined."""
        x0, y0, x1, y1 = tile
        out = np.empty((y1 - y0, x1 - x0, 3))
        power = color.aa_metric_power(self.ctx.settings, gamma)
        thr = -1.0 if threshold is None else float(threshold)
        depth = max(1, int(depth))
        if first_seen is None or threshold is None:
            rays, shadow_rays, n = trace_packed(self.buf, x0, y0, x1, y1, thr, power, depth, out)
        else:  # two calls, the same arithmetic: the first rays are shown in between
            ex1 = x1 + 1 if x1 < self.width else x1
            ey1 = y1 + 1 if y1 < self.height else y1
            first = np.empty((ey1 - y0 + 1, ex1 - x0 + 1, 3))
            rays, shadow_rays, _ = trace_packed(
                self.buf, x0, y0, x1, y1, thr, power, depth, out, 1, first
            )
            first_seen(first[1 : 1 + y1 - y0, 1 : 1 + x1 - x0])
            more, more_shadow, n = trace_packed(
                self.buf, x0, y0, x1, y1, thr, power, depth, out, 2, first
            )
            rays, shadow_rays = rays + more, shadow_rays + more_shadow
        self.ctx.count("rays", rays)
        self.ctx.count("shadow_rays", shadow_rays)
        return out, n


def why_not(prepared, camera: ir.Camera, ctx=None) -> list[str]:
    """Why the numpy path renders this scene (empty: the compiled kernel does)."""
    if kernel_built() and os.environ.get(ENV, "") == "numpy":
        return [f"{ENV}=numpy"]
    return reasons(prepared, camera, ctx)
