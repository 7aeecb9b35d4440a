"""Objects walled off by an opaque infinite plane, which no ray of the render can reach.

Take a top-level plane that every ray stops at: not clipped, not `no_image` or
`no_reflection`, and letting no light through (no layer of its texture filters or
transmits). Suppose every camera ray starts strictly on one side of it, and every light that
casts shadows lies strictly on that side too (an area light with all its cells, a parallel
or cylinder light shining from that side). Then, by induction over a ray tree:

- a ray starting on that side meets the plane before it could cross it, and stops there;
- so every hit is on that side or on the plane, and the reflected rays and shadow rays
  leaving it start there (nothing refracts through the plane: it is opaque);
- a shadow ray runs from such a point to a light on the same side: the segment never
  leaves the half space.

No ray ever reaches an object lying wholly on the far side. Such an object is left out of
the render (prepare builds, packs and traces none of it): a scene's objects under its floor
cost nothing. Radiosity (its own rays from every patch), focal blur (origins spread over the
aperture) and the other projections are not reasoned about: no plane walls anything off
there.

What this gives up: a ray leaving a surface closer to the plane than its self-hit offset
(tolerances.ORIGIN_REL) could slip under the plane and, left in, meet a walled-off object;
left out, it meets what lies beyond. That is a speck of the hidden object showing through
a crack the size of rounding, which a POV-Ray render of the scene does not promise either.
"""

from __future__ import annotations

import math

import numpy as np

from lang import ir
from runtime import patterns
from runtime import tolerances as tol
from runtime import transform as tf
from runtime.camera import VIEW_GROW_PIXELS

# The projections whose camera rays all start at `location` (perspective) or on the image
# rectangle around it (orthographic).
_CAMERAS = ("perspective", "orthographic")
# Pixels beyond the image's edge whose rays are traced (anti-aliasing compares with them):
# camera.VIEW_GROW_PIXELS, with a margin.
_GROW_PIXELS = 2 * VIEW_GROW_PIXELS


class Occluders:
    """The scene's walling planes, each as (unit normal, offset): n . p - offset > 0 on the
    camera's side. `hides_sphere` / `hides_points` ask whether one walls an object off."""

    def __init__(self, scene: ir.Scene, width: int = 1, height: int = 1) -> None:
        self.planes: list[tuple[tuple[float, float, float], float]] = []
        cam = scene.camera
        if (
            cam.kind not in _CAMERAS
            or (cam.aperture != 0.0 and cam.blur_samples > 0)
            or scene.settings.radiosity is not None
        ):
            return
        origins = _camera_origins(cam, width, height)
        for obj in scene.objects:
            plane = _plane_of(obj)
            if plane is None:
                continue
            n, off = plane
            side = [float(np.dot(n, o)) - off for o in origins]
            if min(side) > _margin(origins, off) and _lights_inside(scene.lights, n, off):
                self.planes.append(((float(n[0]), float(n[1]), float(n[2])), off))
            elif max(side) < -_margin(origins, off) and _lights_inside(scene.lights, -n, -off):
                self.planes.append(((float(-n[0]), float(-n[1]), float(-n[2])), -off))

    def __bool__(self) -> bool:
        return bool(self.planes)

    def hides_sphere(self, centre, radius: float) -> bool:
        """Does a plane wall off the sphere (its centre and radius, in world space)?"""
        x, y, z = centre
        r = abs(radius)
        for (a, b, c), off in self.planes:
            s = a * x + b * y + c * z - off
            if s + r < -(tol.OCCLUDED_MARGIN_REL * (abs(x) + abs(y) + abs(z) + r + abs(off))):
                return True
        return False

    def hides_points(self, points: np.ndarray) -> bool:
        """Does a plane wall off the convex hull of these world points?"""
        if not len(points) or not np.all(np.isfinite(points)):
            return False
        scale = float(np.abs(points).sum(axis=1).max())
        for n, off in self.planes:
            margin = tol.OCCLUDED_MARGIN_REL * (scale + abs(off))
            if float((points @ np.asarray(n)).max()) - off < -margin:
                return True
        return False


def _camera_origins(cam: ir.Camera, width: int, height: int) -> list[np.ndarray]:
    """Points whose convex hull holds every camera ray's origin: the location, or for an
    orthographic camera the corners of the image rectangle, grown by the pixels beyond its
    edge that anti-aliasing traces (camera.VIEW_GROW_PIXELS)."""
    loc = np.asarray(cam.location, dtype=np.float64)
    if cam.kind != "orthographic":
        return [loc]
    right, up = np.asarray(cam.right, dtype=np.float64), np.asarray(cam.up, dtype=np.float64)
    gx = 0.5 + _GROW_PIXELS / max(int(width), 1)
    gy = 0.5 + _GROW_PIXELS / max(int(height), 1)
    return [loc + sx * gx * right + sy * gy * up for sx in (-1.0, 1.0) for sy in (-1.0, 1.0)]


def _margin(points: list[np.ndarray], off: float) -> float:
    return tol.OCCLUDED_MARGIN_REL * (max(float(np.abs(p).sum()) for p in points) + abs(off))


def _plane_of(obj: ir.Object) -> tuple[np.ndarray, float] | None:
    """(unit world normal, offset) of a plane every ray stops at, or None."""
    shape = obj.shape
    if (
        not isinstance(shape, ir.Plane)
        or obj.clipped_by
        or obj.no_image
        or obj.no_reflection
        or lets_light_through(obj.texture)
        or (obj.interior_texture is not None and lets_light_through(obj.interior_texture))
    ):
        return None
    n = np.asarray(shape.normal, dtype=np.float64)
    length = float(np.linalg.norm(n))
    if not length > 0 or not math.isfinite(length) or not math.isfinite(shape.distance):
        return None
    n = n / length
    point = n * float(shape.distance)  # PlanePrim: the plane lies `distance` along the unit normal
    if obj.transform != ir.IDENTITY:
        m = tf.as_matrix(obj.transform)
        if not np.all(np.isfinite(m)) or abs(np.linalg.det(m[:3, :3])) == 0:
            return None
        point = tf.apply_points(m, point[None, :])[0]
        n = tf.apply_normals(tf.inverse(m), n[None, :])[0]
        n = n / np.linalg.norm(n)
    return n, float(np.dot(n, point))


def lets_light_through(tex: ir.Texture) -> bool:
    """May some layer of the texture filter or transmit light (patterns.may_transmit)?"""
    if tex.pattern is None and patterns.may_transmit(tex.pigment):
        return True
    return any(lets_light_through(t) for t in tex.layers) or any(
        lets_light_through(t) for _, t in tex.map
    )


def _lights_inside(lights, n: np.ndarray, off: float) -> bool:
    """Every light that casts shadows lies strictly on the side n . p > off: its shadow rays
    (from points on that side) stay there."""
    for light in lights:
        if light.shadowless:
            continue  # it sends no rays
        pos = np.asarray(light.position, dtype=np.float64)
        reach = 0.0
        if light.area is not None:  # every cell, oriented or not, lies within this distance
            reach = (
                float(np.linalg.norm(light.area.axis1)) + float(np.linalg.norm(light.area.axis2))
            ) / 2
        if not float(np.dot(n, pos)) - off > reach + _margin([pos], off):
            return False
        if light.kind in ("parallel", "cylinder"):
            # shadow rays run toward the light's direction without end: it must point away
            # from the plane
            if not float(np.dot(n, pos - np.asarray(light.point_at, dtype=np.float64))) > 0:
                return False
    return True
