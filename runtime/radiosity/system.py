"""Radiosity for a prepared scene: mesh → light → form factors → solve → refine → cache.

What the renderer gets (`RadiosityResult.gathered`): the indirect diffuse light G arriving
at a surface point, Gouraud-interpolated from the patches. The renderer multiplies it by
the point's own diffuse reflectance (pigment × diffuse), so textures keep their detail:

    colour = emission + ρ_pixel · (D_raytraced + brightness · G) + specular, reflection …

No light is counted twice: the patches' system is B = E + ρ ⊙ (D + F B), with D the direct
light of the scene's light_sources at the patches; G = F B is everything else — light
from emissive surfaces (`finish { emission }`) and every interreflection, including the
first bounce of the light sources — while D itself stays the renderer's ray-traced term.

Units are POV-Ray's: a light of colour c gives c·cos θ (no 1/r² unless it fades), an
emitter shows pigment × emission, and B is what the camera sees on a diffuse patch.

Meshed: sphere, box, polygon, triangle, mesh, plane (clipped to the scene's bounds), disc
(as a polygon). Other shapes and CSG still block light (visibility uses the tracer) but
get no patches; their `gathered` value is the area-weighted mean G (an ambient estimate).
The solution depends only on geometry, materials and lights, so it is cached by a content
hash and any viewpoint reuses it. The one exception is a camera inside a solid (a room
box, a sphere): that solid's inner side is meshed, so the key holds which solids contain
the eye (not where it is); every camera in the same room shares the solution.

Energy: rows of patches that see only surfaces (every closure ray hits something) are
scaled to sum to 1, and no row exceeds 1. The form-factor quadrature alone is off by
~1e-3, which a near-white furnace (ρ = 0.99) would amplify a hundredfold.
"""

from __future__ import annotations

import dataclasses
import hashlib
import os
import pickle
import secrets
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from lang import ir
from runtime import notices, uvmap
from runtime import transform as tf
from runtime.context import radiosity_ray
from runtime.radiosity import irradiance_cache
from runtime.radiosity import solve as solver
from runtime.radiosity.formfactor import form_factors, point_form_factors
from runtime.radiosity.gouraud import VertexField, luminance, refine_mask
from runtime.radiosity.patches import Mesher, Patches, TooLarge, box_faces
from runtime.radiosity.visibility import PatchVisibility

# POV-Ray's greyscale weights (its gray_threshold desaturates by them).
GREY = np.array([0.297, 0.589, 0.114])

CACHE_VERSION = 4  # 2: energy conservation, eye cell, budgeted refinement; 3: key inside;
# 4: sky light and legacy ambient

# A scene is "not closed" when more than this fraction of the light leaving its surfaces
# (area-weighted row sums of F, visibility included) escapes to infinity.
OPEN_FRACTION = 0.05

# Sides of a planar surface exchange light only if some other geometry or a light lies in
# front of them by more than this fraction of the scene's extent.
_SIDE_REL = 1e-6


@dataclass(frozen=True)
class Options:
    patch_size: float | None = None  # None: the scene's extent / 14
    max_patches: int = 3000
    error_bound: float = 1.8  # refine where corners differ by error_bound·2% of mean B
    tolerance: float = 1e-4
    method: str = "gauss_seidel"
    brightness: float = 1.0
    gray_threshold: float = 0.0  # POV-Ray's: desaturate the gathered light by this much
    order: int = 3  # Gauss points per direction on each source patch (near pairs)
    far_order: int = 1  # … for pairs more than far_ratio × their radii apart
    far_ratio: float = 4.0
    point_ratio: float | None = 8.0  # … beyond this, the point-to-point kernel
    vis_samples: int = 4  # segments per patch pair
    closure_rays: int = 32  # rays per patch testing that it sees only surfaces (0: off)
    symmetric: bool = True  # integrate each pair once, the other way by reciprocity
    dense_bytes: int = solver.DENSE_BYTES  # above: rows on demand, progressive refinement
    max_rounds: int = 2  # adaptive refinement rounds after the first solve
    flat: bool = False  # flat instead of Gouraud display
    vertex_gather: bool = False  # Gouraud from light gathered at the vertices (else averages)
    plane_scale: float = 8.0  # planes are clipped to the scene's box scaled by this
    seed: int = 0
    # Bounces of indirect light (POV-Ray's recursion_limit); None: every bounce.
    bounces: int | None = None
    final_gather: bool = True  # the display traces one bounce per point (gather.py)
    gather_rays: int = 35  # rays per point (POV-Ray's count) …
    gather_cap: int = 64  # … at most, to bound the time
    # Gather at every shaded point (exact, slow) instead of at the irradiance cache's
    # records with interpolation between them (POV-Ray's way, the default).
    gather_every_point: bool = False
    # the scene's radiosity block, which the irradiance cache reads its settings from
    cache_rules: ir.Radiosity = ir.Radiosity()

    @staticmethod
    def from_ir(r: ir.Radiosity, **extra) -> Options:
        # ir.Radiosity's default max_patches (20000) is a dense N² of 3.2 GB and about an
        # hour of form factors here; unless the scene asks for another number, use ours.
        default = ir.Radiosity.__dataclass_fields__["max_patches"].default
        budget = extra.pop("max_patches", Options.max_patches)
        if extra.get("final_gather", True):
            # The display gathers the first bounce itself; the patches carry the further
            # ones, smooth enough for the first mesh: no refinement rounds.
            extra.setdefault("max_rounds", 0)
        return Options(
            patch_size=r.patch_size,
            max_patches=budget if r.max_patches == default else r.max_patches,
            error_bound=r.error_bound,
            tolerance=r.tolerance,
            method=r.method,
            brightness=r.brightness,
            gray_threshold=r.gray_threshold,
            flat=r.display == "flat",
            bounces=r.recursion_limit,
            gather_rays=r.count,
            cache_rules=r,
            **extra,
        )


@dataclass
class _Record:
    """How to find an object's element from a hit point."""

    kind: str  # grid | tris | sphere
    first: int
    per_side: int
    sides: tuple[bool, ...]
    p0: np.ndarray | None = None  # grid: the whole face
    eu: np.ndarray | None = None
    ev: np.ndarray | None = None
    nu: int = 1
    nv: int = 1
    matrix: np.ndarray | None = None  # sphere: unit sphere → world
    n_phi: int = 1
    n_theta: int = 1


@dataclass
class RadiosityResult:
    patches: Patches
    B: np.ndarray  # (N,3) radiosity of every patch
    G: np.ndarray  # (N,3) gathered indirect light F B
    solution: solver.Solution
    options: Options
    records: dict[int, list[_Record]]
    ambient: np.ndarray  # (3,) area-weighted mean G (for unmeshed objects)
    stats: dict[str, float] = field(default_factory=dict)
    warnings: list[str] = field(default_factory=list)
    G_vertex: np.ndarray | None = None  # (V,3) gathered at the Gouraud vertices
    open_area: np.ndarray | None = None  # (N,) patch area outside other solids
    _field: VertexField | None = None
    # The irradiance cache of the render in progress (its camera's; never saved).
    cache: irradiance_cache.IrradianceCache | None = None

    @property
    def field(self) -> VertexField:
        if self._field is None:
            self._field = VertexField(
                self.patches,
                self.G,
                flat=self.options.flat,
                vertex_values=self.G_vertex,
                weights=self.open_area,
            )
        return self._field

    def gather(self, ctx, points: np.ndarray, normals: np.ndarray) -> np.ndarray | None:
        """(M,3) indirect light at points by a final gather over this solution (brightness
        and gray_threshold applied), or None where the display reads the patches instead:
        no final gather, or these points are themselves hit by gather rays."""
        from runtime.radiosity import gather

        if not self.options.final_gather or radiosity_ray():
            return None
        o = self.options
        rays = gather.rays_per_point(o.gather_rays, o.gather_cap, ctx.scene.lights)
        cache = self.cache
        if cache is None or cache.reading is None:
            ctx.count("radiosity_gathers", len(points))
            return self._display(gather.final_gather(ctx, points, normals, rays))
        how = cache.reading
        wsum, out = cache.lookup(points, normals, how)
        need = np.nonzero(~cache.served(wsum, how))[0]
        if len(need):
            p, n = points[need], normals[need]
            light, dirs, depth = gather.gather_rays(ctx, p, n, rays, depths=how.record)
            # Records in reach count with their weight, the new gather with one.
            part = wsum[need][:, None]
            out[need] = (out[need] * part + light) / (part + 1.0)
            if how.record:
                eye = ctx.scene.camera.location
                cache.pending.append(
                    irradiance_cache.samples_from_rays(p, n, light, dirs, depth, eye, cache.rules)
                )
        ctx.count("radiosity_gathers", len(need))
        ctx.count("radiosity_reused", len(points) - len(need))
        return self._display(out)

    def pretrace(self, shoot, width: int, height: int, region, progress=None) -> None:
        """Fill the irradiance cache before the image is traced (irradiance_cache.py):
        `shoot(xs, ys)` traces camera rays through pixel coordinates; progress(share) after
        each pass."""
        if not self.options.final_gather or self.options.gather_every_point:
            return
        self.cache = irradiance_cache.IrradianceCache(self.options.cache_rules)
        irradiance_cache.pretrace(self.cache, shoot, width, height, region, progress)

    def pretrace_rays(self, width: int, height: int, region) -> int:
        """How many camera rays `pretrace` shoots (0: none)."""
        if not self.options.final_gather or self.options.gather_every_point:
            return 0
        grids = irradiance_cache.pass_grids(self.options.cache_rules, width, height, region)
        return sum(xs.size for _, xs, _ in grids)

    def _display(self, g: np.ndarray) -> np.ndarray:
        """POV-Ray's last steps on gathered light: toward grey by gray_threshold (its
        greyscale weights), times brightness."""
        t = self.options.gray_threshold
        if t > 0:
            g = (1 - t) * g + t * (g @ GREY)[:, None]
        return g * self.options.brightness

    def gathered(
        self, obj: int, points: np.ndarray, ray_dir: np.ndarray, prim: np.ndarray | None = None
    ) -> np.ndarray:
        """(M,3) indirect light arriving at hit points of object `obj` (index into
        Prepared.objects), seen along `ray_dir`; brightness applied. Multiply by the
        surface's pigment × diffuse."""
        points = np.asarray(points, dtype=np.float64).reshape(-1, 3)
        ray_dir = np.asarray(ray_dir, dtype=np.float64).reshape(-1, 3)
        recs = self.records.get(int(obj))
        out = np.broadcast_to(self.ambient, (len(points), 3)).copy()
        if not recs or len(points) == 0:
            return out * self.options.brightness
        element, ok = _find_elements(recs, points, ray_dir, prim)
        if ok.any():
            out[ok] = self.field.lookup(element[ok], points[ok])
        # The side facing the viewer was not meshed: nothing can light it.
        out[~ok] = 0.0
        return self._display(out)


# ------------------------------------------------------------------ building


def scene_bounds(objects: list[ir.Object], extra: list[np.ndarray]) -> tuple[np.ndarray, ...]:
    """World bounding box of the finite objects and the extra points (lights); ±inf when
    there is nothing finite."""
    # lazily: only radiosity scenes need them here
    from runtime import prims
    from runtime.functions import compile_xyz

    lo, hi = np.full(3, np.inf), np.full(3, -np.inf)
    for obj in objects:
        prim = (
            prims.primitive_for(obj.shape, compile_xyz)
            if not isinstance(obj.shape, ir.Mesh)
            else None
        )
        if isinstance(obj.shape, ir.Mesh):
            v = tf.apply_points(tf.as_matrix(obj.transform), np.asarray(obj.shape.vertices))
            a, b = v.min(axis=0), v.max(axis=0)
        elif prim is not None:
            a, b = prim.bounds()
            a, b = tf.aabb_transform(
                tf.as_matrix(obj.transform), np.asarray(a, float), np.asarray(b, float)
            )
        else:
            continue
        if np.all(np.isfinite(a)) and np.all(np.isfinite(b)):
            lo, hi = np.minimum(lo, a), np.maximum(hi, b)
    for p in extra:
        lo, hi = np.minimum(lo, p), np.maximum(hi, p)
    return lo, hi  # ±inf when there was nothing finite


@dataclass(frozen=True)
class EyeCell:
    """The solids the camera is strictly inside: meshable objects (indices into
    Prepared.objects) and tracer nodes (indices into Prepared.tracer.nodes)."""

    objects: frozenset[int] = frozenset()
    nodes: frozenset[int] = frozenset()


def eye_cell(prepared) -> EyeCell:
    """Which solids hold the eye, by a margin (a camera on a surface is inside nothing)."""
    eye = np.asarray(prepared.scene.camera.location, dtype=np.float64)
    lo, hi = scene_bounds(prepared.objects, [eye])
    extent = float(np.linalg.norm(hi - lo)) if np.all(np.isfinite(lo)) else 0.0
    eps = _SIDE_REL * max(extent, float(np.linalg.norm(eye)), 1.0)
    probes = eye + eps * np.vstack([np.zeros(3), np.eye(3), -np.eye(3)])
    nodes = frozenset(
        k for k, node in enumerate(prepared.tracer.nodes) if bool(node.inside(probes).all())
    )
    leaf_nodes = {getattr(prepared.tracer.nodes[k], "index", -1) for k in nodes}
    objects = set()
    for i in _meshable(prepared):
        obj = prepared.objects[i]
        if isinstance(obj.shape, ir.Triangle | ir.Mesh):
            # Triangle geometry has no inside test here: its box must hold the eye.
            a, b = scene_bounds([obj], [])
            if np.all((probes > a) & (probes < b)):
                objects.add(i)
        elif i in leaf_nodes:
            objects.add(i)
    return EyeCell(frozenset(objects), nodes)


class SceneMesher:
    """Meshes a prepared scene's surfaces into radiosity elements, recording which object
    and primitive each element came from (`records`), with the problems it met."""

    def __init__(self, prepared, opts: Options):
        self.prepared = prepared
        self.opts = opts
        self.records: dict[int, list[_Record]] = {}
        self.warnings: list[str] = []
        scene: ir.Scene = prepared.scene
        self.lights = [np.asarray(light.position, dtype=np.float64) for light in scene.lights]
        self.indices = _meshable(prepared)
        objs = [prepared.objects[i] for i in self.indices]
        self.lo, self.hi = scene_bounds(objs, [])
        if not np.all(np.isfinite(self.lo)):
            # Nothing finite (only planes): the lights are what the scene is about.
            self.lo, self.hi = scene_bounds([], self.lights)
        if not np.all(np.isfinite(self.lo)):
            self.lo, self.hi = -np.ones(3), np.ones(3)
        self.extent = float(np.linalg.norm(self.hi - self.lo)) or 1.0
        size = opts.patch_size or self.extent / 14
        self.mesher = Mesher(size)
        # Witness points: where light can come from or go to (other objects, lights).
        self.witness: dict[int, np.ndarray] = {}
        boxes = []
        for i in self.indices:
            lo, hi = scene_bounds([prepared.objects[i]], [])
            if not np.all(np.isfinite(lo)):  # a plane: witnesses come from the others
                boxes.append((i, np.zeros((0, 3))))
                continue
            corners = np.array([[x, y, z] for x in (lo[0], hi[0]) for y in (lo[1], hi[1])
                                for z in (lo[2], hi[2])])  # fmt: skip
            boxes.append((i, corners))
        # The eye is a witness only for the solids it is inside: the viewer looks at their
        # inner side, which must be meshed even when nothing else is in there (a camera
        # inside a lone emitting sphere). Elsewhere it changes nothing, so the solution
        # stays viewer independent for every camera in the same cell (see eye_cell).
        self.eye_cell = eye_cell(prepared)
        eye = np.asarray(scene.camera.location, dtype=np.float64).reshape(1, 3)
        for i, _ in boxes:
            pts = [c for j, c in boxes if j != i] + [np.array(self.lights).reshape(-1, 3)]
            if i in self.eye_cell.objects:
                pts.append(eye)
            self.witness[i] = np.vstack(pts) if pts else np.zeros((0, 3))

    def warn(self, msg: str) -> None:
        if msg not in self.warnings:
            self.warnings.append(msg)

    def material(self, obj: ir.Object, where: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(ρ, emission) RGB of an object's texture averaged over sample points."""
        from runtime import patterns

        tex = obj.texture
        rgb = patterns.evaluate(tex.pigment, where)[:, :3].mean(axis=0)
        if tex.layers:
            self.warn("layered textures: radiosity uses the base layer's colour")
        if uvmap.uses_uv(tex):
            where_from = f"{obj.span}: " if obj.span is not None else ""
            self.warn(f"{where_from}uv_mapping: radiosity reads this texture's colour by position")
        fin = tex.finish
        rho = np.clip(rgb * fin.diffuse, 0.0, 0.999)
        return rho, emitted(rgb, fin, self.prepared.scene.settings)

    def sides_of_plane(self, i: int, point: np.ndarray, normal: np.ndarray) -> tuple[bool, ...]:
        h = (self.witness[i] - point) @ normal
        eps = _SIDE_REL * self.extent
        sides = tuple(
            flip for flip, ok in ((False, (h > eps).any()), (True, (h < -eps).any())) if ok
        )
        return sides

    def mesh_sides(self, i: int, v: np.ndarray, f: np.ndarray) -> tuple[bool, ...]:
        """Which sides of triangle geometry exchange light. POV-Ray meshes have no reliable
        winding: a closed mesh (every edge shared by two faces) gets its outer side, found
        from the sign of its volume, plus the inner one if a witness is inside its box;
        an open mesh or a lone triangle gets the sides that something lies in front of."""
        edges = np.sort(np.concatenate([f[:, [0, 1]], f[:, [1, 2]], f[:, [2, 0]]]), axis=1)
        _, counts = np.unique(edges, axis=0, return_counts=True)
        if len(f) >= 4 and np.all(counts == 2):
            a, b, c = v[f[:, 0]], v[f[:, 1]], v[f[:, 2]]
            volume = np.einsum("nc,nc->n", a, np.cross(b, c)).sum() / 6.0
            outer = bool(volume < 0)  # negative volume: the winding faces inward
            lo, hi = v.min(axis=0), v.max(axis=0)
            w = self.witness[i]
            inside = bool(np.all((w > lo) & (w < hi), axis=1).any())
            return (outer,) + ((not outer,) if inside else ())
        n = np.cross(v[f[:, 1]] - v[f[:, 0]], v[f[:, 2]] - v[f[:, 0]]).sum(axis=0)
        if np.linalg.norm(n) == 0:
            return (False, True)
        return self.sides_of_plane(i, v.mean(axis=0), n / np.linalg.norm(n)) or (False,)

    def run(self) -> None:
        for i in self.indices:
            obj = self.prepared.objects[i]
            el = self.mesher.el
            mark = (len(el), len(el.matrices))
            try:
                self.object(i, obj)
            except TooLarge as e:
                el.truncate(*mark)
                self.warn(
                    f"{type(obj.shape).__name__} gets no radiosity patches: {e} (ambient estimate)"
                )

    def object(self, i: int, obj: ir.Object) -> None:
        shape = obj.shape
        m = tf.as_matrix(obj.transform)
        el = self.mesher.el
        recs: list[_Record] = []
        if isinstance(shape, ir.Sphere):
            s = tf.compose(m, tf.translation(shape.center), np.diag([shape.radius] * 3 + [1.0]))
            centre = s[:3, 3]
            local = (self.witness[i] - centre) @ np.linalg.inv(s[:3, :3]).T
            r2 = np.einsum("nc,nc->n", local, local)
            outside, inside = bool((r2 > 1).any()), bool((r2 < 1).any())
            rho, emis = self.material(obj, centre[None])
            first = len(el)
            n_phi, n_theta = self.mesher.sphere(
                s, rho=rho, emission=emis, surface=i, outside=outside, inside=inside
            )
            sides = tuple(f for f, ok in ((False, outside), (True, inside)) if ok)
            recs.append(_Record("sphere", first, n_phi * n_theta, sides, matrix=s,
                                n_phi=n_phi, n_theta=n_theta))  # fmt: skip
        elif isinstance(shape, ir.Box):
            lo = np.minimum(shape.corner1, shape.corner2)
            hi = np.maximum(shape.corner1, shape.corner2)
            rho, emis = self.material(obj, tf.apply_points(m, ((lo + hi) / 2)[None]))
            for p0, eu, ev in box_faces(lo, hi):
                self._grid(i, recs, tf.apply_points(m, p0[None])[0], tf.apply_dirs(m, eu[None])[0],
                           tf.apply_dirs(m, ev[None])[0], rho, emis, solid=True)  # fmt: skip
        elif isinstance(shape, ir.Plane):
            self._plane(i, recs, shape, m, obj)
        elif isinstance(shape, ir.Polygon | ir.Disc):
            pts = _polygon_points(shape)
            pts = tf.apply_points(m, pts)
            rho, emis = self.material(obj, pts)
            if len(pts) == 4 and np.allclose(pts[0] + pts[2], pts[1] + pts[3], atol=1e-12):
                self._grid(i, recs, pts[0], pts[1] - pts[0], pts[3] - pts[0], rho, emis)
            else:
                from runtime.radiosity.formfactor import polygon_normal_area

                n, _ = polygon_normal_area(pts[None])
                sides = self.sides_of_plane(i, pts[0], n[0])
                first = len(el)
                self.mesher.polygon(pts, rho=rho, emission=emis, surface=i, sides=sides)
                recs.append(_Record("tris", first, (len(el) - first) // max(1, len(sides)), sides))
        elif isinstance(shape, ir.Triangle | ir.Mesh):
            if isinstance(shape, ir.Triangle):
                v = np.array([shape.p1, shape.p2, shape.p3], dtype=np.float64)
                f = np.array([[0, 1, 2]])
            else:
                v = np.asarray(shape.vertices, dtype=np.float64).reshape(-1, 3)
                f = np.asarray(shape.faces, dtype=np.int64).reshape(-1, 3)
            v = tf.apply_points(m, v)
            rho, emis = self.material(obj, v)
            first = len(el)
            sides = self.mesh_sides(i, v, f)
            self.mesher.mesh(v, f, rho=rho, emission=emis, surface=i, sides=sides)
            recs.append(_Record("tris", first, len(f), sides))
        else:
            self.warn(f"{type(shape).__name__} gets no radiosity patches (ambient estimate)")
        if recs:
            self.records[i] = recs

    def _grid(self, i, recs, p0, eu, ev, rho, emis, solid=False, cell=None) -> None:
        n = np.cross(eu, ev)
        n = n / np.linalg.norm(n)
        if solid:
            # A solid's face: the outer side, plus the inner one if something is inside.
            sides = (False,) + ((True,) if self._inside_solid(i) else ())
        else:
            sides = self.sides_of_plane(i, p0, n)
        if not sides:
            return
        first = len(self.mesher.el)
        nu, nv = self.mesher.parallelogram(
            p0, eu, ev, rho=rho, emission=emis, surface=i, sides=sides, cell=cell
        )
        recs.append(_Record("grid", first, nu * nv, sides, p0=p0, eu=eu, ev=ev, nu=nu, nv=nv))

    def _inside_solid(self, i: int) -> bool:
        obj = self.prepared.objects[i]
        m_inv = tf.inverse(tf.as_matrix(obj.transform))
        local = tf.apply_points(m_inv, self.witness[i])
        s = obj.shape
        lo, hi = np.minimum(s.corner1, s.corner2), np.maximum(s.corner1, s.corner2)
        return bool(np.all((local > lo) & (local < hi), axis=1).any())

    def _plane(self, i, recs, shape: ir.Plane, m, obj) -> None:
        n_obj = np.asarray(shape.normal, dtype=np.float64)
        p_obj = n_obj * shape.distance / float(n_obj @ n_obj)
        p = tf.apply_points(m, p_obj[None])[0]
        n = tf.apply_normals(tf.inverse(m), n_obj[None])[0]
        # Clip the infinite plane to the scene's box scaled by plane_scale about its centre
        # (a parallelogram covering the box's projection): far enough that the light an
        # infinite floor or wall sends back is nearly all there; patches grow with the
        # distance from the scene (see _compute), so this costs O(log plane_scale) patches.
        half = 0.5 * self.opts.plane_scale * np.maximum(self.hi - self.lo, 1e-3 * self.extent)
        mid = 0.5 * (self.lo + self.hi)
        lo, hi = mid - half, mid + half
        a = np.cross(n, [1.0, 0, 0] if abs(n[0]) < 0.9 else [0, 1.0, 0])
        a /= np.linalg.norm(a)
        b = np.cross(n, a)
        corners = np.array([[x, y, z] for x in (lo[0], hi[0]) for y in (lo[1], hi[1])
                            for z in (lo[2], hi[2])])  # fmt: skip
        ca, cb = (corners - p) @ a, (corners - p) @ b
        p0 = p + ca.min() * a + cb.min() * b
        eu, ev = (ca.max() - ca.min()) * a, (cb.max() - cb.min()) * b
        if np.cross(eu, ev) @ n < 0:
            eu, ev = ev, eu
        rho, emis = self.material(obj, (p0 + 0.5 * (eu + ev))[None])
        # Coarse cells; the graded refinement splits those near the scene.
        self._grid(i, recs, p0, eu, ev, rho, emis, cell=self.extent / 2)
        self.warn(
            f"infinite planes are clipped to {self.opts.plane_scale:g}× the scene's bounds "
            "for radiosity"
        )


def emitted(rgb: np.ndarray, fin: ir.Finish, settings: ir.Settings) -> np.ndarray:
    """The light a surface of pigment `rgb` sends out by itself: pigment × emission, and,
    before 3.7, pigment × ambient × ambient_light too: POV-Ray keeps `ambient` with
    radiosity in legacy scenes and its radiosity rays see it like emission (an ambient
    sky sphere lights the scene)."""
    from runtime.context import legacy_rules

    out = rgb * np.asarray(fin.emission, dtype=np.float64)
    if legacy_rules(settings):
        amb = np.asarray(fin.ambient, dtype=np.float64)
        out = out + rgb * amb * np.asarray(settings.ambient_light, dtype=np.float64)
    return out


def _polygon_points(shape) -> np.ndarray:
    if isinstance(shape, ir.Disc):
        c = np.asarray(shape.center, dtype=np.float64)
        n = np.asarray(shape.normal, dtype=np.float64)
        n = n / np.linalg.norm(n)
        a = np.cross(n, [1.0, 0, 0] if abs(n[0]) < 0.9 else [0, 1.0, 0])
        a /= np.linalg.norm(a)
        b = np.cross(n, a)
        k = 48
        t = 2 * np.pi * np.arange(k) / k
        return c + shape.radius * (np.cos(t)[:, None] * a + np.sin(t)[:, None] * b)
    pts = [np.asarray(p, dtype=np.float64) for p in shape.points]
    # First sub-polygon only (it closes where a point repeats the first one).
    for k in range(1, len(pts)):
        if np.array_equal(pts[k], pts[0]):
            return np.array(pts[:k])
    return np.array(pts)


def _meshable(prepared) -> list[int]:
    """Indices of top-level objects (not CSG parts, not clipped)."""
    return sorted(prepared.whole_objects)


def _gathered(F, B, patches: Patches, D, S) -> np.ndarray:
    """G = F B + S, the light each patch gathers from the others and the sky (S); without
    a dense F, from the patch's own equation B = E + ρ (D + G) (exact where ρ > 0; 0 on
    black patches)."""
    if F is not None:
        return np.maximum(F @ B + S, 0.0)
    rho = patches.reflectance
    g = np.where(rho > 0, (B - patches.emission - rho * D) / np.maximum(rho, 1e-12), 0.0)
    return np.maximum(g, 0.0)


def _hollow_solids(prepared, sm: SceneMesher) -> set[int]:
    """Tracer nodes whose inside holds a light source, part of an emitter or the eye: the
    scene happens inside them (a room box, the half-space of Ex3's back plane), so they
    bury nothing. Indices into prepared.tracer.nodes."""
    pts = list(sm.lights)
    for i in sm.indices:
        obj = prepared.objects[i]
        if max(obj.texture.finish.emission) > 0:
            lo, hi = scene_bounds([obj], [])
            if np.all(np.isfinite(lo)):
                box = np.array([lo, hi])
                corners = box[np.indices((2, 2, 2)).reshape(3, -1).T, [0, 1, 2]]
                pts += [(lo + hi) / 2, *corners]
    # A solid holding the eye is seen from inside: its inside is open space too.
    hollow = set(sm.eye_cell.nodes)
    if not pts:
        return hollow
    w = np.array(pts, dtype=np.float64).reshape(-1, 3)
    return hollow | {k for k, node in enumerate(prepared.tracer.nodes) if node.inside(w).any()}


def _residual_tolerance(F: np.ndarray | None, rho: np.ndarray, tolerance: float) -> float:
    """The solvers' residual target for a relative error of B within `tolerance`: the
    error is at most the residual over 1 − q, q = max ρ·rowsum (the contraction factor of
    ρF), so a furnace with ρ = 0.99 needs a residual 100 times smaller than ρ = 0."""
    sums = F.sum(axis=1) if F is not None else np.ones(len(rho))
    q = float((rho.max(axis=1) * sums).max()) if len(rho) else 0.0
    return tolerance * max(1.0 - q, 1e-4)


def hit_fraction(vis: PatchVisibility, pts: np.ndarray, normal: np.ndarray, rays: int,
                  rng) -> np.ndarray:  # fmt: skip
    """(N,) the fraction of `rays` cosine-distributed rays from each patch's open points
    that hit a surface: 1 where the patch sees a closed scene (no sky through any
    opening); 1 − it estimates the patch's light that escapes. NaN when rays = 0."""
    return closure(vis, pts, normal, rays, rng)[0]


def closure(vis: PatchVisibility, pts: np.ndarray, normal: np.ndarray, rays: int, rng,
            sky=None) -> tuple[np.ndarray, np.ndarray]:  # fmt: skip
    """`hit_fraction`, and (N,3) the sky's light arriving at each patch: the mean of
    `sky(directions)` (the background or sky_sphere colour, None: black) over the
    cosine-distributed rays that meet nothing — what POV-Ray's radiosity rays return
    where they escape (POV units: a sky of colour c all around gives c)."""
    n = len(normal)
    if rays <= 0 or n == 0:
        return np.full(n, np.nan), np.zeros((n, 3))
    # Stratified cosine-weighted directions about each patch normal.
    k = np.arange(rays)
    d = cosine_directions(normal, rays, rng)
    o = pts[:, k % pts.shape[1]]
    hit, escaped = vis.hits_and_escapes(o.reshape(-1, 3), d.reshape(-1, 3))
    light = np.zeros((n * rays, 3))
    if sky is not None and escaped.any():
        light[escaped] = sky(d.reshape(-1, 3)[escaped])
    return hit.reshape(n, rays).mean(axis=1), light.reshape(n, rays, 3).mean(axis=1)


def cosine_directions(normal: np.ndarray, rays: int, rng) -> np.ndarray:
    """(N,rays,3) unit directions about each of the (N,3) unit normals, cosine-distributed
    and stratified (rows and columns of a jittered grid, permuted: a Latin square)."""
    n = len(normal)
    k = np.arange(rays)
    u1 = (k[None] + rng.random((n, rays))) / rays
    u2 = rng.permutation(rays)[None] / rays + rng.random((n, rays)) / rays
    r, phi = np.sqrt(u1), 2 * np.pi * u2
    a = np.where(np.abs(normal[:, :1]) < 0.9, [[1.0, 0, 0]], [[0, 1.0, 0]])
    t = np.cross(normal, a)
    t /= np.linalg.norm(t, axis=1, keepdims=True)
    b = np.cross(normal, t)
    z = np.sqrt(np.maximum(0.0, 1 - u1))
    d = (r * np.cos(phi))[..., None] * t[:, None] + (r * np.sin(phi))[..., None] * b[:, None]
    return d + z[..., None] * normal[:, None]


def conserve(F: np.ndarray, closed: np.ndarray) -> None:
    """Scale form-factor rows in place so that energy is conserved: a patch that sees only
    surfaces (`closed`) sends all its light to them (row sum 1), no row sends more than
    all. The quadrature (far pairs use fewer points) and the visibility sampling leave row
    sums off by ~1e-3, which ρ/(1−ρ) amplifies: 10% at ρ = 0.99."""
    s = F.sum(axis=1)
    # A closed patch whose row holds less than half its light is buried, not leaky.
    target = np.where(closed & (s > 0.5), 1.0, np.minimum(s, 1.0))
    F *= np.where(s > 0, target / np.maximum(s, 1e-300), 1.0)[:, None]


def open_points(prepared, patches: Patches, count: int, rng, extent: float, hollow: set[int]):
    """(N,count,3) sample points on each patch that lie outside every other solid, and the
    buried fraction β (N,) of each patch (from 8·count candidates). A fully buried patch
    keeps buried points (its β = 1 removes it from the exchange anyway).

    Solids in `hollow` (see _hollow_solids) bury nothing."""
    cand_n = 8 * count
    cand = patches.sample_points(cand_n, rng)  # (N,C,3)
    n = len(patches)
    flat = cand.reshape(-1, 3)
    # Nudge off the surface along the normal: solids touching the patch (a box standing on
    # the floor) exclude their boundary, so a point exactly on it would count as open.
    probe = flat + np.repeat(patches.normal, cand_n, axis=0) * (1e-7 * extent)
    owner = np.repeat(patches.surface, cand_n)
    buried_flat = np.zeros(len(flat), dtype=bool)
    for k, node in enumerate(prepared.tracer.nodes):
        if k in hollow:
            continue
        inside = node.inside(probe)
        if inside.any():
            mine = np.isin(owner, node.leaves)
            buried_flat |= inside & ~mine
    buried = buried_flat.reshape(n, cand_n)
    beta = buried.mean(axis=1)
    # Open candidates first (stable), then take the first `count` of each row.
    order = np.argsort(buried, axis=1, kind="stable")
    picked = np.take_along_axis(cand, order[:, :count, None], axis=1)
    # Rows with fewer open candidates than `count`: cycle through the open ones.
    n_open = (~buried).sum(axis=1)
    short = (n_open > 0) & (n_open < count)
    for i in np.nonzero(short)[0]:
        picked[i] = cand[i, order[i, np.arange(count) % n_open[i]]]
    return picked, beta


def _patterned_materials(prepared, patches: Patches, rng, samples: int = 8) -> None:
    """Patches of objects with a patterned pigment (checker …) get their own ρ and
    emission: the pigment averaged over `samples` points of each patch (a solid pigment
    is already exact per element)."""
    from runtime import patterns

    for obj_index in np.unique(patches.surface):
        obj = prepared.objects[int(obj_index)]
        pig = obj.texture.pigment
        if pig.pattern == "solid":
            continue
        rows = np.nonzero(patches.surface == obj_index)[0]
        sub = patches.sample_points(samples, rng)[rows] if len(rows) else None
        if sub is None:
            continue
        rgb = patterns.evaluate(pig, sub.reshape(-1, 3))[:, :3].reshape(len(rows), samples, 3)
        rgb = rgb.mean(axis=1)
        fin = obj.texture.finish
        patches.reflectance[rows] = np.clip(rgb * fin.diffuse, 0.0, 0.999)
        patches.emission[rows] = emitted(rgb, fin, prepared.scene.settings)


def unmeshed_tracer(prepared, meshed: set[int]):
    """A tracer over the objects that got no patches (they still block light), or None."""
    from runtime.trace import Leaf, Tracer

    nodes = [n for n in prepared.tracer.nodes if not (isinstance(n, Leaf) and n.index in meshed)]
    if not nodes:
        return None
    return Tracer(nodes, None, {}, prepared.tracer.sizes)


def _find_elements(recs, points, ray_dir, prim):
    """Element of each point among an object's records, and whether one was found."""
    m = len(points)
    best = np.full(m, np.inf)
    element = np.zeros(m, dtype=np.int64)
    ok = np.zeros(m, dtype=bool)
    for rec in recs:
        if rec.kind == "grid":
            n = np.cross(rec.eu, rec.ev)
            n /= np.linalg.norm(n)
            dist = np.abs((points - rec.p0) @ n)
            g = np.array([[rec.eu @ rec.eu, rec.eu @ rec.ev], [rec.eu @ rec.ev, rec.ev @ rec.ev]])
            d = points - rec.p0
            uv = np.linalg.solve(g, np.stack([d @ rec.eu, d @ rec.ev]))
            i = np.clip((uv[0] * rec.nu).astype(np.int64), 0, rec.nu - 1)
            j = np.clip((uv[1] * rec.nv).astype(np.int64), 0, rec.nv - 1)
            cell = j * rec.nu + i
            facing_front = ray_dir @ n < 0
        elif rec.kind == "sphere":
            inv = np.linalg.inv(rec.matrix)
            local = points @ inv[:3, :3].T + inv[:3, 3]
            r = np.linalg.norm(local, axis=1)
            dist = np.abs(r - 1.0) * np.linalg.svd(rec.matrix[:3, :3], compute_uv=False).max()
            local = local / np.maximum(r, 1e-300)[:, None]
            theta = np.arccos(np.clip(local[:, 1], -1, 1)) / np.pi
            phi = (np.arctan2(local[:, 2], local[:, 0]) / (2 * np.pi)) % 1.0
            i = np.minimum((phi * rec.n_phi).astype(np.int64), rec.n_phi - 1)
            j = np.minimum((theta * rec.n_theta).astype(np.int64), rec.n_theta - 1)
            cell = j * rec.n_phi + i
            # Outward normal in world space: inverse-transpose of the local position.
            nw = local @ inv[:3, :3]
            facing_front = np.einsum("nc,nc->n", ray_dir, nw) < 0
        else:  # tris
            cell, dist, facing_front = _tri_lookup(rec, points, ray_dir, prim)
        for k, flip in enumerate(rec.sides):
            want = facing_front != flip
            take = want & (dist < best)
            element[take] = rec.first + k * rec.per_side + cell[take]
            best[take] = dist[take]
            ok[take] = True
    return element, ok


def _tri_lookup(rec, points, ray_dir, prim):
    """Triangle records: the face from `prim` (meshes: one element per face), else the
    record's triangle nearest to each point (polygons: a handful of triangles)."""
    p0, e1, e2 = rec.p0, rec.eu, rec.ev  # per-triangle arrays (_attach_triangle_geometry)
    n = np.cross(e1, e2)
    n /= np.linalg.norm(n, axis=1, keepdims=True)
    if prim is not None and rec.per_side == len(p0) and len(p0) > 1 and (prim >= 0).all():
        cell = np.clip(np.asarray(prim, dtype=np.int64), 0, len(p0) - 1)
    else:
        # Barycentric coordinates against every triangle (polygons have few).
        d = points[:, None, :] - p0[None]
        g11 = np.einsum("tc,tc->t", e1, e1)
        g22 = np.einsum("tc,tc->t", e2, e2)
        g12 = np.einsum("tc,tc->t", e1, e2)
        b1 = np.einsum("mtc,tc->mt", d, e1)
        b2 = np.einsum("mtc,tc->mt", d, e2)
        det = g11 * g22 - g12 * g12
        u = (g22 * b1 - g12 * b2) / det
        v = (g11 * b2 - g12 * b1) / det
        outside = np.maximum.reduce([-u, -v, u + v - 1, np.zeros_like(u)])
        plane = np.abs(np.einsum("mtc,tc->mt", d, n))
        cell = np.argmin(outside * 1e6 + plane, axis=1)
    dist = np.abs(np.einsum("mc,mc->m", points - p0[cell], n[cell]))
    facing_front = np.einsum("mc,mc->m", ray_dir, n[cell]) < 0
    return cell, dist, facing_front


# ------------------------------------------------------------------ lighting


def direct_light(
    prepared, patches: Patches, samples: int, rng, points: np.ndarray | None = None
) -> np.ndarray:
    """(N,3) light-source light arriving at each patch (POV units: colour·cos θ, shadowed),
    averaged over `samples` points on the patch's true surface (or the given (N,S,3)
    `points`, e.g. only its open part)."""
    from runtime import shading

    n = len(patches)
    out = np.zeros((n, 3))
    lights = prepared.scene.lights
    if not lights or n == 0:
        return out
    if points is not None:
        samples = points.shape[1]
    pts = (patches.sample_points(samples, rng) if points is None else points).reshape(-1, 3)
    nrm = np.repeat(patches.normal, samples, axis=0)
    for light in lights:
        ls = shading.sample_light(light, pts)
        cos = np.einsum("nc,nc->n", nrm, ls.direction)
        lit = (cos > 0) & (ls.colour.max(axis=1) > 0)
        if not light.shadowless and lit.any():
            rows = np.nonzero(lit)[0]
            depth = np.where(np.isfinite(ls.distance[rows]), ls.distance[rows], 1e30)
            blocked = prepared.tracer.occluded(
                pts[rows], ls.direction[rows], tmax=depth * (1 - 1e-9), tmin=1e-6 * (
                    1 + np.linalg.norm(pts[rows], axis=1))
            )  # fmt: skip
            lit[rows[blocked]] = False
        contrib = np.where(lit[:, None], np.maximum(cos, 0)[:, None] * ls.colour, 0.0)
        out += contrib.reshape(n, samples, 3).mean(axis=1)
    return out


# ------------------------------------------------------------------ pipeline


def content_key(scene: ir.Scene, opts: Options, cell: EyeCell | None = None) -> str:
    """A hash of everything the solution depends on: objects, lights, radiosity options,
    and which solids hold the eye (their inner sides are meshed only then). Not the
    camera itself (viewer independence), not source positions (spans)."""
    h = hashlib.sha256()
    h.update(f"strala-radiosity-{CACHE_VERSION}".encode())
    st = scene.settings
    # The sky lights the patches; before 3.7 so does every surface's ambient.
    _hash_value(h, (scene.objects, scene.lights, opts, scene.sky_sphere, scene.background,
                    st.version, st.ambient_light))  # fmt: skip
    if cell is not None and (cell.objects or cell.nodes):
        _hash_value(h, (sorted(cell.objects), sorted(cell.nodes)))
    return h.hexdigest()


def _hash_value(h, v) -> None:
    if dataclasses.is_dataclass(v) and not isinstance(v, type):
        h.update(type(v).__name__.encode())
        for f in dataclasses.fields(v):
            if f.name == "span":
                continue
            h.update(f.name.encode())
            _hash_value(h, getattr(v, f.name))
    elif isinstance(v, np.ndarray):
        h.update(str(v.dtype).encode() + str(v.shape).encode())
        h.update(np.ascontiguousarray(v).tobytes())
    elif isinstance(v, tuple | list):
        h.update(b"(")
        for x in v:
            _hash_value(h, x)
        h.update(b")")
    elif isinstance(v, dict):
        for k in sorted(v, key=str):
            h.update(str(k).encode())
            _hash_value(h, v[k])
    elif isinstance(v, float):
        h.update(float(v).hex().encode())
    else:
        h.update(repr(v).encode())


def solution_key(prepared, opts: Options | None = None) -> tuple[str, Options]:
    """The content key of a prepared scene's solution (its cache file's name; a cluster's
    workers share a solution by it) and the options it is computed and displayed with (the
    scene's own when `opts` is None: the grain warning is said then)."""
    scene: ir.Scene = prepared.scene
    if opts is None:
        r = scene.settings.radiosity or ir.Radiosity()
        meshed = set(_meshable(prepared))
        opts = Options.from_ir(r, final_gather=gather_pays(scene, prepared.objects, meshed))
        warn_grain(scene, prepared.objects, meshed, opts)
    # The display (flat or Gouraud) reads the solution; it is not part of it.
    # So is the number of gather rays.
    display = dataclasses.replace(opts, flat=False, gather_rays=0, gather_cap=0,
                                  gather_every_point=False,
                                  cache_rules=ir.Radiosity())  # fmt: skip
    return content_key(scene, display, eye_cell(prepared)), opts


def compute(
    prepared,
    opts: Options | None = None,
    *,
    cache_dir: Path | None = None,
    log=None,
    progress: Callable[[float], None] | None = None,
) -> RadiosityResult:
    """The radiosity solution of a prepared scene, reused from and saved to `cache_dir`
    when given: a folder keeps one file per solution; a file (a path with a suffix, such
    as `room.rad`) keeps the latest solution and is reused while the key matches.
    progress(share) as the work goes (`RoundsAhead`: the share of the rounds' estimated
    cost done)."""
    key, opts = solution_key(prepared, opts)
    path = None if cache_dir is None else cache_path(Path(cache_dir), key)
    if path is not None and path.is_file():
        try:
            with path.open("rb") as f:
                stored = pickle.load(f)
            if isinstance(stored, dict) and stored.get("key") == key:
                res = dataclasses.replace(stored["result"], options=opts, _field=None, cache=None)
                res.stats["cache_hit"] = 1.0
                _print_warnings(res)
                return res
        except (OSError, pickle.UnpicklingError, EOFError, AttributeError, TypeError):
            pass  # a stale or broken cache file: recompute and overwrite it
    res = _compute(prepared, opts, log, progress)
    _print_warnings(res)
    if path is not None:
        kept = dataclasses.replace(res, _field=None, cache=None)
        store(path, pickle.dumps({"key": key, "result": kept}))
    return res


def store(path: Path, data: bytes) -> None:
    """A cache file written whole: a reader never sees half of it (the temporary name is
    this process's: worker processes of one machine share a cache folder)."""
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(f"{path.name}.{os.getpid()}.{secrets.token_hex(4)}.tmp")
    try:
        tmp.write_bytes(data)
        tmp.replace(path)
    finally:
        tmp.unlink(missing_ok=True)


def cache_path(cache: Path, key: str) -> Path:
    """Where the solution with `key` lives: in a folder, a file named by the key; a path
    with a suffix that is not a folder is the one file itself."""
    return cache if cache.suffix and not cache.is_dir() else cache / f"{key}.pkl"


def _print_warnings(res: RadiosityResult) -> None:
    """On stderr, as prepare does with its own (one line each)."""
    for msg in res.warnings:
        notices.warn(msg)


def gather_pays(scene: ir.Scene, objects=None, meshed: set[int] | None = None) -> bool:
    """Whether the display should take the first bounce by a final gather: where light
    sources or the sky shine, where the emitting surfaces are large (a glowing dome
    around the scene), or where an emitter gets no patches (CSG, text: only the gather's
    rays see its light). Where the light comes from small emitting surfaces only (a Cornell
    box's ceiling patch), the patches carry it better: their form factors to the emitters
    are exact, while a gather's few dozen rays that must find a small emitter are noisy.
    `meshed`: the indices of `objects` that get patches (None: every meshable shape)."""
    if _lights_or_sky(scene):
        return True
    objects = scene.objects if objects is None else objects
    if unpatched_emitters(scene, objects, meshed):
        return True
    return emitter_share(objects, scene.settings) >= LARGE_EMITTERS


def _lights_or_sky(scene: ir.Scene) -> bool:
    """Light the gather's rays find easily: light sources, a sky sphere, a background."""
    return bool(scene.lights or scene.sky_sphere or any(scene.background[:3]))


def unpatched_emitters(scene: ir.Scene, objects, meshed: set[int] | None = None) -> list:
    """The emitting objects that get no patches (CSG, text …): only gather rays see them."""
    return [
        o
        for i, o in enumerate(objects)
        if _emits(o, scene.settings)
        and (not isinstance(o.shape, MESHED) or (meshed is not None and i not in meshed))
    ]


def warn_grain(scene: ir.Scene, objects, meshed: set[int], opts: Options) -> None:
    """Say where the image will be grainier than POV-Ray's: lit only by emitters without
    patches, whose light the final gather finds with its capped rays per point, where
    POV-Ray interpolates samples of `count` rays each (its irradiance cache)."""
    if _lights_or_sky(scene) or not opts.final_gather:
        return
    if opts.gather_rays <= opts.gather_cap:
        return
    found = unpatched_emitters(scene, objects, meshed)
    if not found:
        return
    first = next((o for o in found if o.span is not None), found[0])
    more = f" (and {len(found) - 1} more)" if len(found) > 1 else ""
    notices.warn(
        f"radiosity: the light of this emitting "
        f"{type(first.shape).__name__.lower()}{more} gets no patches and reaches other "
        f"surfaces only through the final gather's {opts.gather_cap} rays per point, "
        f"where POV-Ray interpolates samples of count {opts.gather_rays}: the image is "
        "grainier than POV-Ray's",
        first.span,
    )


# The emitters' bounding boxes' surface area, as a share of the scene's box's, from which
# gather rays find them easily.
LARGE_EMITTERS = 0.25

# The shapes the mesher gives patches (SceneMesher.object)
MESHED = (ir.Sphere, ir.Box, ir.Plane, ir.Polygon, ir.Disc, ir.Triangle, ir.Mesh)


def _emits(obj: ir.Object, settings: ir.Settings | None) -> bool:
    """Whether a surface sends out light of its own: emission, or before 3.7 ambient."""
    tex = obj.texture
    if tex is None:
        return False
    white = np.ones(3)
    if settings is None:
        return bool(np.any(white * np.asarray(tex.finish.emission, dtype=np.float64) > 0))
    return bool(np.any(emitted(white, tex.finish, settings) > 0))


def emitter_share(objects, settings: ir.Settings | None = None) -> float:
    """Surface area of the emitting objects' world boxes over that of the whole scene's
    box (1 or more: the emitters surround the scene)."""

    def area(lo: np.ndarray, hi: np.ndarray) -> float:
        if not np.all(np.isfinite(lo)) or not np.all(np.isfinite(hi)):
            return np.inf
        d = np.maximum(hi - lo, 0.0)
        return float(2 * (d[0] * d[1] + d[1] * d[2] + d[0] * d[2]))

    lit = [o for o in objects if _emits(o, settings)]
    if not lit:
        return 0.0
    whole = area(*scene_bounds(list(objects), []))
    part = area(*scene_bounds(lit, []))
    if not np.isfinite(part):
        return 1.0  # an emitting plane: it surrounds half the scene
    return part / whole if whole > 0 and np.isfinite(whole) else 1.0


def patch_levels(opts: Options) -> int | None:
    """How many bounces the patches' G carries (None: all). With a final gather the
    display traces the first bounce itself, so the patches carry one fewer."""
    if opts.bounces is None:
        return None
    return max(0, opts.bounces - (1 if opts.final_gather else 0))


def limited_gather(F: np.ndarray, patches: Patches, D: np.ndarray, S: np.ndarray,
                   levels: int) -> np.ndarray:  # fmt: skip
    """G after `levels` bounces, as POV-Ray's recursion_limit counts them: the deepest
    surfaces show only emission and direct light, G_L = 0, and each level up gathers
    G = S + F (E + ρ (D + G)) from the one below."""
    G = np.zeros_like(D)
    for _ in range(levels):
        G = np.maximum(S + F @ (patches.emission + patches.reflectance * (D + G)), 0.0)
    return G


class RoundsAhead:
    """The share of a solve's work done, for a progress bar: rounds of refinement cost by
    their form factors, which grow as patches^1.5 (pairs far apart take the cheap point
    kernel: measured 450 to 3000 patches, 0.24 s to 4.6 s); a round to come is taken to
    split every patch it may (a split adds three, within max_patches), and none comes once
    the budget has no room for a split (the loop below stops there). Cornell box: 449,
    1613, 2999 patches, predicted 449, 1796, 2999."""

    EXPONENT = 1.5

    def __init__(self, progress: Callable[[float], None] | None, max_rounds: int, cap: int):
        self.progress = progress
        self.rounds_left = max_rounds + 1
        self.cap = cap
        self.spent = 0.0  # the cost of the rounds done
        self.current = 0.0  # the cost of the round under way
        self.patches = 0  # in the round under way

    def begin(self, patches: int) -> None:
        self.rounds_left -= 1
        self.current = float(patches) ** self.EXPONENT
        self.patches = patches
        self.part(0.0)

    def part(self, share: float) -> None:
        """The round under way is `share` done."""
        if self.progress is None:
            return
        ahead, n = 0.0, self.patches
        for _ in range(self.rounds_left):
            splits = min(max(self.cap - n, 0) // 3, n)
            if splits == 0:
                break
            n += 3 * splits
            ahead += float(n) ** self.EXPONENT
        total = self.spent + self.current + ahead
        self.progress((self.spent + share * self.current) / total if total > 0 else 0.0)

    def end(self, last: bool) -> None:
        self.spent += self.current
        self.current = 0.0
        if last:
            self.rounds_left = 0
        self.part(0.0)


def _compute(prepared, opts: Options, log, progress=None) -> RadiosityResult:
    t_start = time.perf_counter()
    rounds = RoundsAhead(progress, opts.max_rounds, opts.max_patches)
    say = log or (lambda msg: None)
    if patch_levels(opts) == 0:
        # recursion_limit 1 with a final gather: the gathered surfaces show no indirect
        # light, so there is nothing for patches to carry.
        z = np.zeros((0, 3))
        m = Mesher(1.0)
        none = solver.Solution(z, "none", 0, 0.0, True, 0.0)
        keys = ("patches", "form_factor_seconds", "solve_seconds", "seconds", "iterations",
                "residual")  # fmt: skip
        return RadiosityResult(m.patches(), z, z, none, opts, {}, np.zeros(3),
                               dict.fromkeys(keys, 0.0))  # fmt: skip
    sm = SceneMesher(prepared, opts)
    sm.run()
    stats: dict[str, float] = {}
    if len(sm.mesher.el) == 0:
        return _empty_result(sm, opts)
    # Patch size grows with the distance from the finite objects' box (planes reach far).
    grade = (sm.lo, sm.hi, sm.extent / 6)
    patches = sm.mesher.patches(opts.max_patches, grade)
    _attach_triangle_geometry(sm)
    extra = unmeshed_tracer(prepared, set(sm.records))
    hollow = _hollow_solids(prepared, sm)
    rng = np.random.default_rng(opts.seed)
    skyfn = sky_function(prepared)
    min_size = sm.mesher.size / 16
    threshold_rel = 0.02 * opts.error_bound
    sol = None
    ff_s = solve_s = 0.0
    for round_ in range(opts.max_rounds + 1):
        t0 = time.perf_counter()
        n = len(patches)
        rounds.begin(n)
        pts, beta = open_points(prepared, patches, opts.vis_samples, rng, sm.extent, hollow)
        vis = PatchVisibility(patches.verts, extra)
        hit, S = closure(vis, pts, patches.normal, opts.closure_rays, rng, skyfn)
        closed = hit == 1.0
        if solver.fits_dense(n, opts.dense_bytes):
            F = form_factors(patches.verts, order=opts.order, far_order=opts.far_order,
                             far_ratio=opts.far_ratio, visible=vis, symmetric=opts.symmetric,
                             point_ratio=opts.point_ratio,
                             vis_samples=opts.vis_samples, seed=opts.seed + round_,
                             vis_points=(pts, pts), progress=rounds.part)  # fmt: skip
            # A patch partly buried in a solid (floor under a box) exchanges light through
            # its open part only: its visibility came from open points, and it is hit in
            # proportion to its open area (reciprocity with the effective area A(1-β)).
            F *= (1.0 - beta)[None, :]
            conserve(F, closed)
            rows = None
        else:  # memory-bounded: rows on demand for progressive refinement
            F = None

            def provider(idx, pts=pts, vis=vis, beta=beta, closed=closed):
                f = form_factors(patches.verts[idx], patches.verts, order=opts.order,
                                 far_order=opts.far_order, far_ratio=opts.far_ratio,
                                 point_ratio=opts.point_ratio, visible=vis,
                                 vis_points=(pts[idx], pts))  # fmt: skip
                f *= (1.0 - beta)[None, :]
                conserve(f, closed[idx])
                return f

            rows = solver.RowCache(provider, n, budget=max(opts.dense_bytes // 2, 8 * n))

        ff_s += time.perf_counter() - t0
        t0 = time.perf_counter()
        _patterned_materials(prepared, patches, rng)
        # Shadow rays from the same open points (vis_samples per patch and light).
        D = direct_light(prepared, patches, opts.vis_samples, rng, points=pts)
        E = patches.emission + patches.reflectance * (D + S)
        area = patches.area * np.maximum(1.0 - beta, 1e-6)
        sol = solver.solve(F, patches.reflectance, E, area, method=opts.method,
                           tol=_residual_tolerance(F, patches.reflectance, opts.tolerance),
                           rows=rows)  # fmt: skip
        solve_s += time.perf_counter() - t0
        say(f"radiosity round {round_}: {n} patches, {sol.method} {sol.iterations} iterations, "
            f"residual {sol.residual:.2e}")  # fmt: skip
        if round_ == opts.max_rounds:
            rounds.end(last=True)
            break
        # Refine where the displayed quantity, the gathered light G, changes fast (not B:
        # a checker pigment makes B jump at every check while G stays smooth).
        g = _gathered(F, sol.B, patches, D, S)
        field = VertexField(patches, g, weights=area, conform=False)
        mean = float((luminance(g) * area).sum() / area.sum())
        # A split adds three patches: within the budget, the worst patches go first.
        room = (opts.max_patches - n) // 3
        mask = refine_mask(field, threshold_rel * max(mean, 1e-12), min_size, budget=room)
        k = int(mask.sum())
        rounds.end(last=k == 0)
        if k == 0:
            break
        patches.subdivide(mask)
    assert sol is not None
    B = sol.B
    G = _gathered(F, B, patches, D, S)
    levels = patch_levels(opts)
    if levels is not None and F is not None:
        G = limited_gather(F, patches, D, S, levels)
    # The share of the light the surfaces reflect (power A·(B − E)) that hits nothing:
    # patches in the dark (a floor plane outside a room) or only emitting (an emitter's
    # back) are not openings that matter.
    escape = 1.0 - hit
    if np.isnan(escape).any():  # no closure rays: the form factors' row sums
        escape = 1.0 - F.sum(axis=1) if F is not None else np.zeros(len(patches))
    power = luminance(np.maximum(B - patches.emission, 0.0)) * area
    total = float(power.sum())
    open_fraction = float((power * np.clip(escape, 0, 1)).sum() / total) if total > 0 else 0.0
    G = np.maximum(G, 0.0)
    G_vertex = None
    if opts.vertex_gather and F is not None:
        # Gouraud's vertices get the light that actually arrives there (exact kernel to
        # every patch, with visibility) instead of an average of the patches around them,
        # which flattens corners and smears shadow edges.
        t0 = time.perf_counter()
        avg = VertexField(patches, G, weights=area)
        K = point_form_factors(avg.vertex_inner, avg.vertex_normal, patches.verts,
                               visible=vis, targets=pts)  # fmt: skip
        G_vertex = np.maximum(K @ B, 0.0)
        stats["vertex_gather_seconds"] = time.perf_counter() - t0
    if open_fraction > OPEN_FRACTION:
        sm.warn(
            f"the scene is not closed: {100 * open_fraction:.0f}% of the light leaving its "
            "surfaces escapes (the radiosity method assumes a closed scene)"
        )
    ambient = (G * area[:, None]).sum(axis=0) / area.sum()
    stats.update(
        patches=float(len(patches)),
        form_factor_seconds=ff_s,
        solve_seconds=solve_s,
        seconds=time.perf_counter() - t_start,
        open_fraction=open_fraction,
        iterations=float(sol.iterations),
        residual=sol.residual,
    )
    return RadiosityResult(
        patches, B, G, sol, opts, sm.records, ambient, stats, sm.warnings, G_vertex, area
    )


def sky_function(prepared):
    """What a ray that escapes the scene sees (sky_sphere over the background), as a
    function of unit directions; None when that is black everywhere."""
    scene: ir.Scene = prepared.scene
    if not scene.sky_sphere and not any(scene.background[:3]):
        return None
    from runtime import integrate

    ctx = integrate.make_context(prepared)
    return lambda dirs: integrate.sky(ctx, dirs)


def _empty_result(sm, opts) -> RadiosityResult:
    m = Mesher(1.0)
    m.parallelogram([0, 0, 0], [1, 0, 0], [0, 1, 0], rho=0.0)
    p = m.patches()
    z = np.zeros((1, 3))
    sol = solver.Solution(z, "none", 0, 0.0, True, 0.0)
    sm.warn("radiosity: no surface could be meshed")
    return RadiosityResult(p, z, z, sol, opts, {}, np.zeros(3), {}, sm.warnings)


def _attach_triangle_geometry(sm: SceneMesher) -> None:
    """Triangle records keep per-triangle (p0, e1, e2) arrays for hit lookup."""
    a = sm.mesher.el.arrays()
    for recs in sm.records.values():
        for rec in recs:
            if rec.kind == "tris":
                sl = slice(rec.first, rec.first + rec.per_side)
                rec.p0, rec.eu, rec.ev = a["p0"][sl], a["eu"][sl], a["ev"][sl]
