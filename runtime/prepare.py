"""Turn an `ir.Scene` into what the tracer needs, and skip what the scene does not need.

Unions flatten into their leaves (each child already carries its full world transform and
resolved texture); intersection / difference / merge become CSG nodes over leaves; all
triangle geometry goes into one Embree-backed TriangleSet, built only when there is some
(a triangle object in CSG or clipped is a node of its own, runtime.triangle_solids).

Also owned here: `Tessellator` (NURBS, subdivision and height fields to meshes at a
tolerance from the camera; runtime.export uses it too), `Culler` (what the view cannot
show or shadow) and the texture predicates `texture_reflects` / `texture_transparent`.
An object's inside test (clipped_by) is runtime.inside's.
"""

from __future__ import annotations

import dataclasses
import functools
import math
from dataclasses import dataclass, field

import numpy as np

from lang import ir
from lang.ir_ops import every_object
from runtime import light_groups, prims, shapes
from runtime import tolerances as tol
from runtime import transform as tf
from runtime.camera import view_planes
from runtime.functions import compile_xyz
from runtime.inside import inside_node, object_matrix, singular, warn_once
from runtime.occlusion import Occluders, lets_light_through
from runtime.patterns import may_transmit
from runtime.trace import ClipNode, CsgNode, Leaf, Tracer
from runtime.triangle_solids import triangle_node

FLAG_NAMES = ("no_image", "no_reflection", "no_shadow")
_NO_FLAGS = dict.fromkeys(FLAG_NAMES, False)
# Deepest level `adaptive` subdivision picks on its own (each level has 4x the faces).
MAX_ADAPTIVE_LEVELS = 6


@dataclass
class Prepared:
    scene: ir.Scene
    objects: list[ir.Object]  # renderable leaves; a hit's `obj` indexes this list
    tracer: Tracer
    warnings: list[str] = field(default_factory=list)  # one line each, already printed
    culled: list[str] = field(default_factory=list)  # shapes not tessellated: never seen
    # (n_objects,) bool: a mesh tessellated from a curved surface (nurbs, subdivision), whose
    # shadow rays start from the curved surface its normals describe (see integrate)
    curved: np.ndarray | None = None
    # (n_objects,) bool: a mesh tessellated from a shape without uvs of its own (height
    # field, subdivision), whose uv_mapping reads world x, y (runtime.uvmap)
    world_uv: np.ndarray | None = None
    # per scene light: the inside node of its projected_through object, or None
    projected: list = field(default_factory=list)
    # per light, (n_objects,) bool of the objects it lights (None: all); the scene's own
    # lights come first (`scene_lights` of them), light groups' after (runtime.light_groups)
    receivers: list = field(default_factory=list)
    scene_lights: int | None = None  # None: every light is the scene's

    # Asked for, not computed for every render: a walk over thousands of objects.
    @functools.cached_property
    def has_reflection(self) -> bool:
        """Some finish reflects (reflection max or min > 0)."""
        return any(texture_reflects(t) for o in self.objects for t in _textures(o))

    @functools.cached_property
    def whole_objects(self) -> frozenset[int]:
        """Indices of the objects that are whole objects, not parts of a CSG nor clipped:
        analytic leaves that are tracer nodes themselves, and triangle leaves."""
        from runtime.trace import Leaf

        found = {n.index for n in self.tracer.nodes if isinstance(n, Leaf) and n.index >= 0}
        tri = self.tracer.triangles
        if tri is not None and len(getattr(tri, "leaf_of", ())):
            solid: frozenset[int] = getattr(tri, "solid", frozenset())  # CSG parts, clipped
            found |= {int(i) for i in np.unique(tri.leaf_of) if int(i) not in solid}
        return frozenset(found)

    @functools.cached_property
    def has_refraction(self) -> bool:
        """Some pigment colour lets light through (filter or transmit not 0)."""
        return any(texture_transparent(t) for o in self.objects for t in _textures(o))


# Shapes prepare turns into meshes before tracing (absent from older IR versions).
_TESSELLATED = tuple(
    t
    for t in (
        getattr(ir, "Nurbs", None),
        getattr(ir, "Subdivision", None),
        getattr(ir, "HeightField", None),
    )
    if t
)


# Shapes whose untransformed leaves node() makes first, without its other checks.
_PLAIN = (ir.Sphere, ir.Box)


class Tessellator:
    """Turns NURBS, subdivision and height-field shapes into meshes, at a chord tolerance
    picked from the camera (half a pixel at the control net's nearest point) when the shape
    sets none: what prepare does for the tracer, and runtime.export for a mesh file."""

    def __init__(self, camera: ir.Camera, width: int, warnings: list[str] | None = None):
        self.camera = camera
        self.width = max(int(width), 1)
        self.warnings: list[str] = [] if warnings is None else warnings
        self.curved_ids: set[int] = set()  # id() of the meshes tessellated from curved shapes
        self.world_uv_ids: set[int] = set()  # id() of those whose shape has no uvs

    def warn_once(self, msg: str, span=None) -> None:
        """One line per distinct problem, on stderr, blaming the object's source when known."""
        warn_once(self.warnings, msg, span)

    def tessellate(self, obj: ir.Object) -> ir.Mesh | None:
        """NURBS and subdivision shapes become indexed triangle meshes (their own modules do
        the work; this only picks the tolerance and reports failures as warnings)."""
        shape = obj.shape
        name = type(shape).__name__
        try:
            if isinstance(shape, ir.HeightField):
                from runtime.heightfield import height_field_mesh

                hf = height_field_mesh(shape, compile_xyz)
                self.world_uv_ids.add(id(hf))
                return hf
            if isinstance(shape, ir.Nurbs) and shape.patch is not None:
                # POV-Ray's own triangles: flat, with its interpolated normals, and shadow
                # rays from the triangles (not the curved surface) as POV-Ray's
                from runtime.bezier import bicubic_patch_mesh, bicubic_uvs

                net = shape.points  # u fastest; POV-Ray lists the points along v first
                pov_order = [net[4 * (k % 4) + k // 4] for k in range(16)]
                verts, faces, normals, uvs = bicubic_patch_mesh(pov_order, *shape.patch)
                if shape.bicubic_uv is not None:
                    uvs = bicubic_uvs(uvs, shape.bicubic_uv)
                return ir.Mesh(vertices=verts, faces=faces, normals=normals, uvs=uvs, smooth=True)
            if isinstance(shape, ir.Nurbs):
                from runtime.tessellate import nurbs_mesh

                tolerance = shape.tolerance or self.auto_tolerance(obj)
                verts, faces, normals, uvs = nurbs_mesh(shape, tolerance)
                if shape.bicubic_uv is not None:  # its (v, u), as bicubic_patch_mesh's
                    from runtime.bezier import bicubic_uvs

                    uvs = bicubic_uvs(np.asarray(uvs)[:, ::-1], shape.bicubic_uv)
            else:
                if not isinstance(shape, ir.Subdivision):
                    raise TypeError(f"{name} is not a tessellated shape")
                from runtime.subdivide import levels_for_tolerance, subdivision_mesh

                levels = shape.levels
                if shape.adaptive:  # half a pixel from the camera; `levels` caps it
                    tolerance = self.auto_tolerance(obj)
                    if shape.tolerance:
                        tolerance = min(tolerance, shape.tolerance)
                    cap = MAX_ADAPTIVE_LEVELS if levels is None else levels
                    levels = levels_for_tolerance(shape, tolerance, cap)
                elif levels is None:  # `tolerance`, else half a pixel from the camera
                    tolerance = shape.tolerance or self.auto_tolerance(obj)
                    levels = levels_for_tolerance(shape, tolerance)
                verts, faces, normals = subdivision_mesh(shape, levels)
                uvs = None
        except Exception as exc:  # noqa: BLE001 - a broken surface must not stop the render
            self.warn_once(f"{name.lower()} could not be tessellated ({exc}); skipped", obj.span)
            return None
        mesh = ir.Mesh(vertices=verts, faces=faces, normals=normals, uvs=uvs, smooth=True)
        self.curved_ids.add(id(mesh))
        if uvs is None:
            self.world_uv_ids.add(id(mesh))
        return mesh

    def auto_tolerance(self, obj: ir.Object) -> float:
        """Chord-error bound from the camera: half a pixel at the control net's nearest
        distance from the eye (in world units)."""
        cam = self.camera
        shape = obj.shape
        if not isinstance(shape, ir.Nurbs | ir.Subdivision):
            raise TypeError(f"a {type(shape).__name__} has no control net")
        pts = tf.apply_points(tf.as_matrix(obj.transform), np.asarray(shape.points, float))
        dist = float(np.min(np.linalg.norm(pts - np.asarray(cam.location), axis=1)))
        right = float(np.linalg.norm(cam.right))
        if cam.kind == "orthographic":
            return max(tol.AUTO_TESSELLATION_PIXELS * right / self.width, tol.ABS_FLOOR)
        pixel = right / float(np.linalg.norm(cam.direction)) / self.width
        extent = float(np.linalg.norm(pts.max(axis=0) - pts.min(axis=0)))
        return max(
            tol.AUTO_TESSELLATION_PIXELS * pixel * dist,
            tol.TESSELLATION_REL * max(extent, tol.ABS_FLOOR),
        )


class _Builder:
    """Walks a scene's objects into the tracer's nodes and leaves (see `prepare`)."""

    def __init__(self, camera: ir.Camera, width: int) -> None:
        self.objects: list[ir.Object] = []
        self.flags: dict[str, list[bool]] = {k: [] for k in FLAG_NAMES}
        self.sizes: list[float] = []
        self.nodes: list = []
        self.triangle_leaves: list[tuple[int, ir.Object]] = []
        self.solid: set[int] = set()  # triangle leaves traced by their nodes (CSG, clipped)
        self.warnings: list[str] = []
        self.culled: list[str] = []
        self.curved: list[bool] = []
        self.world_uv: list[bool] = []
        self.tessellator = Tessellator(camera, width, self.warnings)
        self.curved_ids = self.tessellator.curved_ids  # id() of the meshes from curved shapes
        self.cull: Culler | None = None
        self.occluders: Occluders | None = None  # planes walling objects off (culling on)
        # plain spheres waiting for their leaves: (node slot, object index, centre, radius)
        self.spheres: list[tuple[int, int, tuple, float]] = []

    def warn_once(self, msg: str, span=None) -> None:
        """One line per distinct problem, on stderr, blaming the object's source when known."""
        warn_once(self.warnings, msg, span)

    def add_leaf_object(self, obj: ir.Object, flags: dict[str, bool]) -> int:
        """obj's index among the leaves; `flags` are its own and inherited ones, merged."""
        index = len(self.objects)
        self.objects.append(obj)
        self.curved.append(id(obj.shape) in self.curved_ids)
        self.world_uv.append(id(obj.shape) in self.tessellator.world_uv_ids)
        for k in FLAG_NAMES:
            self.flags[k].append(flags[k])
        self.sizes.append(0.0)
        return index

    def plain_sphere(self, obj: ir.Object) -> bool:
        """Take obj if it is a sphere where it was written, with no flags, inverse or
        clipping (most objects of a large scene): its leaf is made later with the others
        (`place_spheres`). False: obj is not one, `top` has to see it."""
        shape = obj.shape
        if (
            type(shape) is not ir.Sphere
            or not shape.radius
            or obj.no_image
            or obj.no_reflection
            or obj.no_shadow
            or obj.inverse
            or obj.clipped_by
            or not (obj.transform is ir.IDENTITY or obj.transform == ir.IDENTITY)
        ):
            return False
        if (self.occluders and self.occluders.hides_sphere(shape.center, shape.radius)) or (
            self.cull is not None and self.cull.hides_sphere(shape.center, shape.radius)
        ):
            self.culled.append("sphere")
            return True
        index = self.add_leaf_object(obj, _NO_FLAGS)
        self.spheres.append((len(self.nodes), index, shape.center, shape.radius))
        self.nodes.append(None)  # its slot: the scene's order stays the nodes' order
        return True

    def place_spheres(self) -> None:
        """The leaves of the spheres `plain_sphere` took, in their node slots."""
        if not self.spheres:
            return
        slots, indices, centres, radii = zip(*self.spheres, strict=True)
        for slot, leaf in zip(slots, Leaf.spheres(centres, radii, indices), strict=True):
            self.nodes[slot] = leaf
            self.sizes[leaf.index] = leaf.size
        self.spheres = []

    def hidden(self, obj: ir.Object, no_shadow: bool) -> bool:
        """Is obj walled off by a plane (runtime.occlusion), or outside the view where
        nothing can show or shadow it (Culler)? Asked of the shapes whose bounds come
        cheaply: untransformed boxes, and surfaces held by their control points (whose
        tessellation culling saves most)."""
        if not (self.occluders or (self.cull is not None and self.cull.enabled)):
            return False
        pts = _bounding_points(obj)
        if pts is None:
            return False
        if self.occluders and self.occluders.hides_points(pts):
            return True
        return self.cull is not None and self.cull.invisible_points(pts, no_shadow)

    def top(self, obj: ir.Object, inherited: dict[str, bool]) -> None:
        """A top-level object or a child of a flattened union."""
        shape = obj.shape
        flags = {k: inherited[k] or bool(getattr(obj, k)) for k in FLAG_NAMES}
        if (
            isinstance(shape, ir.CSG)
            and shape.op == "union"
            and not (obj.inverse or obj.clipped_by)
        ):
            for child in shape.children:
                self.top(child, flags)
            return
        if self.hidden(obj, flags["no_shadow"]):
            self.culled.append(type(shape).__name__.lower())
            return
        if _TESSELLATED and isinstance(shape, _TESSELLATED) and not obj.clipped_by:
            mesh = self.tessellator.tessellate(obj)
            if mesh is None:
                return
            obj = dataclasses.replace(obj, shape=mesh)
            shape = mesh
        if isinstance(shape, ir.Triangle) and shapes.flat_triangle(shape):
            return
        if isinstance(shape, ir.Mesh | ir.Triangle) and not obj.clipped_by:
            # the common case: into the scene's Embree scene, past the CSG machinery
            # (`inverse` turns only the inside over, which prepare never asks of it)
            why = singular(obj)
            if why:
                self.warn_once(f"a {type(shape).__name__.lower()} is skipped: {why}", obj.span)
                return
            index = self.add_leaf_object(obj, flags)
            self.triangle_leaves.append((index, obj))
            return
        node = self.node(obj, flags, merged=True)
        if node is not None:
            self.nodes.append(node)

    def node(
        self,
        obj: ir.Object,
        inherited: dict[str, bool],
        merged: bool = False,
        inverted: bool = False,
        child: bool = False,
    ):
        """An analytic node (Leaf or CsgNode) for obj, or None when nothing renders.
        `merged`: `inherited` already holds obj's own flags too. `inverted`: obj is inside
        an inverted CSG (a difference's subtracted child, an `inverse` one), where POV-Ray's
        Invert turns every union into an intersection of inverted children (CSG::Morph):
        its children's surfaces inside one another are gone, as a merge's. `child`: obj is
        a CSG's child, whose every crossing counts (a lone julia_fractal reports its first)."""
        shape = obj.shape
        flags = (
            inherited if merged else {k: inherited[k] or bool(getattr(obj, k)) for k in FLAG_NAMES}
        )
        if (
            type(shape) in _PLAIN
            and not (obj.inverse or obj.clipped_by)
            and obj.transform == ir.IDENTITY
            and not shapes.degenerate(shape)
        ):
            # a sphere or box where it was written, most of a large scene: its leaf at once,
            # past the checks below that cannot apply to it
            index = self.add_leaf_object(obj, flags)
            leaf = Leaf(shapes.primitive_for(shape), None, index)
            self.sizes[index] = leaf.size
            return leaf
        if type(shape) is ir.Sphere and not (obj.inverse or obj.clipped_by) and shape.radius:
            placed = similar_sphere(shape, obj.transform)
            if placed is not None:
                # moved, turned and scaled alike: still a sphere, as POV-Ray keeps one
                # (Sphere::Scale), and traced without a matrix
                index = self.add_leaf_object(obj, flags)
                leaf = Leaf(shapes.SpherePrim(*placed), None, index)
                self.sizes[index] = leaf.size
                return leaf
        if isinstance(shape, ir.Unsupported):
            return None
        if isinstance(shape, ir.SphereSweep):
            sweep = self.sphere_sweep(obj, flags)
            return None if sweep is None else self.clipped(obj, sweep)
        if isinstance(shape, ir.CSG):
            under = inverted or obj.inverse
            kids = (
                self.node(
                    ch, flags, inverted=under or (shape.op == "difference" and i > 0), child=True
                )
                for i, ch in enumerate(shape.children)
            )
            children = [c for c in kids if c]
            if not children:
                return None
            op = "merge" if under and shape.op == "union" else shape.op
            return self.clipped(obj, CsgNode(op, children, inverse=obj.inverse))
        source = obj
        if _TESSELLATED and isinstance(shape, _TESSELLATED):
            mesh = self.tessellator.tessellate(obj)
            if mesh is None:
                return None
            obj = dataclasses.replace(obj, shape=mesh)
            shape = mesh
        if isinstance(shape, ir.Mesh):
            # Inside CSG or clipped: a node of its own with every crossing and the inside
            # test of its kind (runtime.triangle_solids); its triangles stay in the
            # TriangleSet for what a hit needs, out of its Embree scene.
            why = singular(obj)
            if why:
                self.warn_once(f"a mesh is skipped: {why}", obj.span)
                return None
            index = self.add_leaf_object(obj, flags)
            self.triangle_leaves.append((index, obj))
            self.solid.add(index)
            mesh_node = triangle_node(obj, index, compile_xyz, source)
            self.sizes[index] = mesh_node.size
            return self.clipped(obj, mesh_node)
        if isinstance(shape, ir.Triangle) and shapes.flat_triangle(shape):
            return None
        why = shapes.degenerate(shape)
        if why:
            self.warn_once(
                f"a degenerate {type(shape).__name__.lower()} is skipped: {why}", obj.span
            )
            return None
        why = singular(obj)
        if why:
            self.warn_once(f"a {type(shape).__name__.lower()} is skipped: {why}", obj.span)
            return None
        matrix = object_matrix(obj)
        if matrix is not None and isinstance(shape, ir.Polygon):
            # a polygon stays one, its points moved (a snowflake's 17,000 polygons)
            points = np.asarray(shape.points, dtype=np.float64) @ matrix[:3, :3].T + matrix[:3, 3]
            shape, matrix = ir.Polygon(tuple(map(tuple, points.tolist()))), None
        try:
            prim = prims.primitive_for(shape, compile_xyz)
        except ValueError as exc:  # unreadable data behind a shape (a broken font file)
            self.warn_once(f"{type(shape).__name__.lower()} skipped: {exc}", obj.span)
            return None
        if prim is None:
            self.warn_once(f"shape {type(shape).__name__} is not supported by the tracer", obj.span)
            return None
        if (child or obj.clipped_by) and hasattr(prim, "first_only"):
            # POV-Ray's marching shapes report every crossing to a CSG, and look past the
            # ones clipped away
            prim.first_only = False
        index = self.add_leaf_object(obj, flags)
        leaf = Leaf(prim, matrix, index, inverse=obj.inverse)
        self.sizes[index] = leaf.size
        return self.clipped(obj, leaf)

    def sphere_sweep(self, obj: ir.Object, flags: dict[str, bool]):
        """One object whose surface is the merge of spheres and tangent cones."""
        from runtime.sphere_sweep import pieces

        shape = obj.shape
        if not isinstance(shape, ir.SphereSweep):
            return None
        parts = pieces(shape)
        if not parts:
            self.warn_once("a sphere_sweep with no positive radius is skipped", obj.span)
            return None
        m = tf.as_matrix(obj.transform)
        # one object entry per piece: a hit's normal comes from the leaf its index names
        leaves = [Leaf(p, m, self.add_leaf_object(obj, flags)) for p in parts]
        for leaf in leaves:
            self.sizes[leaf.index] = leaf.size
        return CsgNode("merge", leaves, inverse=obj.inverse)

    def clipped(self, obj: ir.Object, node):
        """Wrap node in its `clipped_by` objects (which are never reported as hits)."""
        if not obj.clipped_by:
            return node
        clips = [c for c in (self.clip_node(c) for c in obj.clipped_by) if c is not None]
        return ClipNode(node, clips) if clips else node

    def clip_node(self, obj: ir.Object):
        return inside_node(obj, self.warn_once, compile_xyz)


# How far from a similarity (a turn and one scale for all axes) a sphere's transform may be
# and still make a sphere of it: relative, in the squared lengths of its axes.
SIMILAR_REL = 1e-12


def similar_sphere(shape: ir.Sphere, m: ir.Matrix) -> tuple[tuple, float] | None:
    """(centre, radius) of a sphere under m when m moves, turns and scales it alike on
    every axis (and leaves it within the traced world), else None. In plain floats: a
    fractal of 100,000 spheres spent seconds on numpy per sphere."""
    (a, b, c, tx), (d, e, f, ty), (g, h, i, tz) = m[0], m[1], m[2]
    if m[3] != (0.0, 0.0, 0.0, 1.0):
        return None
    s2 = a * a + d * d + g * g
    near = SIMILAR_REL * s2
    if not (
        0.0 < s2 < math.inf
        and abs(b * b + e * e + h * h - s2) <= near
        and abs(c * c + f * f + i * i - s2) <= near
        and abs(a * b + d * e + g * h) <= near
        and abs(a * c + d * f + g * i) <= near
        and abs(b * c + e * f + h * i) <= near
    ):
        return None
    x, y, z = shape.center
    centre = (a * x + b * y + c * z + tx, d * x + e * y + f * z + ty, g * x + h * y + i * z + tz)
    radius = abs(shape.radius) * math.sqrt(s2)
    reach = max(abs(v) for v in centre) + radius
    if not (reach < ir.FAR_LIMIT and radius > 1.0 / ir.FAR_LIMIT):
        return None  # left to the checks below (out of reach, shrunk away)
    return centre, radius


def prepare(scene: ir.Scene, width: int, height: int, cull: bool = True) -> Prepared:
    """width/height are the image size (they set the automatic tessellation tolerance);
    `cull` off keeps surfaces the camera cannot see (trace() asks before there is one).

    A light's `looks_like` object arrives at the light's position (the evaluator moves it
    there, as POV-Ray's parser does) and is traced here with `no_shadow`."""
    scene, own_lights = light_groups.with_group_lights(scene)
    b = _Builder(scene.camera, width)
    b.cull = Culler(scene, width, height) if cull else None
    b.occluders = Occluders(scene, width, height) if cull else None
    for obj in scene.objects:
        if not b.plain_sphere(obj):
            b.top(obj, _NO_FLAGS)
    b.place_spheres()
    for light in scene.lights:
        if light.looks_like is not None:
            # POV-Ray lets the light shine through its looks_like object: it casts no shadows.
            b.top(dataclasses.replace(light.looks_like, no_shadow=True), _NO_FLAGS)
    triangles = None
    if b.triangle_leaves:
        # Imported lazily so scenes without triangles never load Embree.
        from runtime.triangles import TriangleSet

        triangles = TriangleSet(b.triangle_leaves, frozenset(b.solid))
        for index, size in triangles.sizes.items():
            b.sizes[index] = size
    flags = {k: np.array(v, dtype=bool) for k, v in b.flags.items()}
    tracer = Tracer(b.nodes, triangles, flags, np.array(b.sizes, dtype=np.float64))
    if triangles is not None:
        triangles.flags = flags
    projected = [
        None if light.projected_through is None else b.clip_node(light.projected_through)
        for light in scene.lights
    ]
    return Prepared(
        scene=scene,
        objects=b.objects,
        tracer=tracer,
        warnings=b.warnings,
        culled=b.culled,
        curved=np.array(b.curved, dtype=bool),
        world_uv=np.array(b.world_uv, dtype=bool),
        projected=projected,
        receivers=light_groups.receivers(scene.lights, own_lights, b.objects),
        scene_lights=own_lights,
    )


class Culler:
    """Decides that a surface needs no tessellation because it cannot show in the image.

    Only where that is provable: nothing in the scene reflects or refracts, there is no
    radiosity or focal blur, the surface's bounding points (a sphere's centre and radius, a
    box's corners, the control points of NURBS with positive weights and of approximating
    subdivision) lie wholly outside one face of the view pyramid (grown by the pixels
    anti-aliasing traces beyond the image), and, unless the surface casts no shadows, every
    shadow-casting light lies inside that face: then every segment from a visible point to
    a light stays inside too, so the surface can neither be seen nor shadow anything seen."""

    def __init__(self, scene: ir.Scene, width: int = 1, height: int = 1):
        self.scene = scene
        self.width, self.height = width, height
        self.lights = [lt for lt in scene.lights if not lt.shadowless]

    @functools.cached_property
    def enabled(self) -> bool:
        # Decided on the first surface asked about: a scene without one never walks its
        # objects' textures for it (each texture once: a large scene's objects share them).
        scene, cam = self.scene, self.scene.camera
        if (
            cam.kind not in ("perspective", "orthographic")
            or (cam.aperture != 0.0 and cam.blur_samples > 0)
            or scene.settings.radiosity is not None
        ):
            return False
        seen: set[int] = set()
        for o in every_object(scene.objects + tuple(lt.looks_like for lt in scene.lights)):
            for t in _textures(o):
                if id(t) not in seen:
                    seen.add(id(t))
                    if texture_reflects(t) or texture_transparent(t) or lets_light_through(t):
                        return False
        return True

    @functools.cached_property
    def faces(self) -> list[tuple[np.ndarray, np.ndarray, bool]]:
        """The view's faces (n, p0; n . (x - p0) > 0 outside) and whether every
        shadow-casting light lies inside each."""
        if not self.enabled:
            return []
        planes = view_planes(self.scene.camera, self.width, self.height)
        return [(n, p0, all(self._inside(lt, n, p0) for lt in self.lights)) for n, p0 in planes]

    def invisible_points(self, pts: np.ndarray, no_shadow: bool) -> bool:
        """Can nothing show the convex hull of these world points, nor its shadow?"""
        for n, p0, lit in self.faces:
            if np.min((pts - p0) @ n) <= 0:
                continue  # part of the surface is inside this face
            if no_shadow or lit:
                return True
        return False

    def hides_sphere(self, centre, radius: float) -> bool:
        """invisible_points for a sphere that casts shadows, in plain floats (a scene's
        thousands of spheres)."""
        x, y, z = centre
        r = abs(radius)
        for a, b, c, px, py, pz in self.lit_faces:
            reach = tol.OCCLUDED_MARGIN_REL * (abs(x) + abs(y) + abs(z) + r)
            if a * (x - px) + b * (y - py) + c * (z - pz) - r > reach:
                return True
        return False

    @functools.cached_property
    def lit_faces(self) -> list[tuple[float, ...]]:
        """The faces with every light inside, as plain floats (n, p0) for hides_sphere."""
        return [(*n.tolist(), *p0.tolist()) for n, p0, lit in self.faces if lit]

    @staticmethod
    def hull(obj: ir.Object) -> np.ndarray | None:
        """World points whose convex hull holds the surface, or None when there are none."""
        shape = obj.shape
        if isinstance(shape, ir.HeightField):  # inside the unit cube
            cube = np.array([[i, j, k] for i in (0, 1) for j in (0, 1) for k in (0, 1)], float)
            return tf.apply_points(tf.as_matrix(obj.transform), cube)
        if isinstance(shape, ir.Nurbs):
            if min(shape.weights, default=1.0) <= 0:
                return None
        elif not isinstance(shape, ir.Subdivision):
            return None  # not a surface held by control points
        elif shape.scheme == "four_point" or (shape.scheme == "midpoint" and shape.m < 2):
            return None  # interpolating / negative-weight rules may leave the hull
        pts = tf.apply_points(tf.as_matrix(obj.transform), np.asarray(shape.points, float))
        r = float(getattr(shape, "radius", 0.0) or 0.0)
        if r > 0:
            # A tube of radius r around a curve: pad the hull by r along every axis.
            pts = np.concatenate([pts + dv for dv in r * np.vstack([np.eye(3), -np.eye(3)])])
        return pts

    @staticmethod
    def _inside(light: ir.Light, n: np.ndarray, p0: np.ndarray) -> bool:
        if light.kind in ("parallel", "cylinder"):
            # Light from infinitely far along (position - point_at).
            w = np.asarray(light.position, float) - np.asarray(light.point_at, float)
            return bool(n @ w <= 0)
        pos = np.asarray(light.position, float)
        corners = [pos]
        if light.area is not None:
            a1 = np.asarray(light.area.axis1, float) / 2
            a2 = np.asarray(light.area.axis2, float) / 2
            corners = [pos + s1 * a1 + s2 * a2 for s1 in (-1, 1) for s2 in (-1, 1)]
        return all(n @ (c - p0) <= 0 for c in corners)


def _bounding_points(obj: ir.Object) -> np.ndarray | None:
    """World points whose convex hull holds obj, for the shapes that have them cheaply
    (untransformed boxes, surfaces held by their control points), else None."""
    shape = obj.shape
    if type(shape) is ir.Box and obj.transform == ir.IDENTITY and not obj.inverse:
        pts = np.array([shape.corner1, shape.corner2], dtype=np.float64)
        lo, hi = pts.min(axis=0), pts.max(axis=0)
        return np.array([[(lo, hi)[i >> k & 1][k] for k in range(3)] for i in range(8)])
    if _TESSELLATED and isinstance(shape, _TESSELLATED):
        return Culler.hull(obj)
    return None


def _textures(obj: ir.Object) -> list[ir.Texture]:
    """The object's texture, its interior_texture and, for meshes, its per-face textures."""
    extra = obj.shape.textures if isinstance(obj.shape, ir.Mesh) else ()
    inside = () if obj.interior_texture is None else (obj.interior_texture,)
    return [obj.texture, *inside, *extra]


def texture_reflects(tex: ir.Texture) -> bool:
    """Does some layer or map entry of the texture reflect (reflection max or min > 0)?"""
    if max(tex.finish.reflection.max) > 0 or max(tex.finish.reflection.min) > 0:
        return True
    return any(texture_reflects(t) for t in tex.layers) or any(
        texture_reflects(t) for _, t in tex.map
    )


def texture_transparent(tex: ir.Texture) -> bool:
    """Does some pigment colour of the texture let light through (patterns.may_transmit)?"""
    return (
        may_transmit(tex.pigment)
        or any(texture_transparent(t) for t in tex.layers)
        or any(texture_transparent(t) for _, t in tex.map)
    )
