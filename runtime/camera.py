"""Primary rays: POV-Ray's camera model on final camera vectors (see `ir.Camera`)."""

from __future__ import annotations

from statistics import NormalDist

import numpy as np

from lang import ir
from runtime import notices, ray_random
from runtime import transform as tf
from runtime.patterns import perturb_normal


def screen_coords(width: int, height: int, xs: np.ndarray, ys: np.ndarray):
    """Continuous pixel coordinates (row 0 at the top) to normalised screen coordinates in
    [-0.5, 0.5], sx to the right and sy up."""
    sx = np.asarray(xs, dtype=np.float64) / width - 0.5
    sy = 0.5 - np.asarray(ys, dtype=np.float64) / height
    return sx, sy


def primary_rays(
    camera: ir.Camera, width: int, height: int, xs: np.ndarray, ys: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Origins (N,3) and unit directions (N,3) for pixel coordinates xs, ys (N,).

    Pixel (col, row) has its centre at (col + 0.5, row + 0.5). Rays a projection does not
    trace (outside a fisheye's circle) are included; `camera_rays` says which they are."""
    origins, directions, _ = camera_rays(camera, width, height, xs, ys)
    return origins, directions


def camera_rays(
    camera: ir.Camera,
    width: int,
    height: int,
    xs: np.ndarray,
    ys: np.ndarray,
    unit: bool = True,
) -> tuple[np.ndarray, np.ndarray, np.ndarray | None]:
    """Origins, directions (unit, unless `unit` is off: then as the projection builds
    them, which focal blur's focal distance is measured in) and which rays are traced
    ((N,) bool, or None for all) for every projection POV-Ray 3.7 has, by its formulas
    (the angle in degrees; 90 when the scene gives none, as POV-Ray's default). A
    camera `normal` bends the unit directions; focal blur's (`unit` off) bends its own
    after the lens, as POV-Ray does."""
    origins, directions, traced, screen = _project(camera, width, height, xs, ys)
    if unit:
        if camera.normal is not None:
            directions = bend(camera.normal, directions, *screen)
        directions = directions / np.linalg.norm(directions, axis=1, keepdims=True)
    return np.array(origins, dtype=np.float64), np.array(directions, dtype=np.float64), traced


def _project(camera: ir.Camera, width: int, height: int, xs: np.ndarray, ys: np.ndarray):
    """Origins, directions as the projection builds them, traced mask, and each ray's
    (x0, y0) in the projection's own screen coordinates (where a camera normal is read)."""
    sx, sy = screen_coords(width, height, xs, ys)
    sx = sx.reshape(-1, 1)
    sy = sy.reshape(-1, 1)
    loc = np.asarray(camera.location, dtype=np.float64)
    dirv = np.asarray(camera.direction, dtype=np.float64)
    right = np.asarray(camera.right, dtype=np.float64)
    up = np.asarray(camera.up, dtype=np.float64)
    kind = camera.kind
    traced = None
    origins = np.broadcast_to(loc, (len(sx), 3))
    screen = (sx, sy)
    if kind == "orthographic":
        origins = loc + sx * right + sy * up
        directions = np.broadcast_to(dirv, origins.shape)
    elif kind == "perspective" or kind not in _PROJECTIONS:
        if kind != "perspective":
            _warn_kind(kind)
        directions = dirv + sx * right + sy * up
    else:
        directions, origins, traced, screen = _PROJECTIONS[kind](
            camera, sx, sy, loc, dirv, right, up
        )
    return origins, directions, traced, screen


def bend(normal: ir.Normal, directions: np.ndarray, x0: np.ndarray, y0: np.ndarray):
    """Camera rays turned by the camera's `normal { … }`: POV-Ray's CreateCameraRay
    perturbs the unit direction as if it were a surface normal, by the pattern at the
    point <x0, y0, 0> of the projection's own screen coordinates (x0, y0 (N,1) each:
    -0.5..0.5 for perspective and orthographic, angles for the others)."""
    unit = directions / np.linalg.norm(directions, axis=1, keepdims=True)
    n = len(unit)
    pts = np.zeros((n, 3))
    pts[:, 0] = np.broadcast_to(x0, (n, 1))[:, 0]
    pts[:, 1] = np.broadcast_to(y0, (n, 1))[:, 0]
    return perturb_normal(normal, pts, unit)


def has_focal_blur(camera: ir.Camera) -> bool:
    return camera.aperture != 0.0 and camera.blur_samples > 0


class FocalBlur:
    """POV-Ray's thin lens for `blur_samples` rays per pixel point: each from a sub-pixel
    position jittered over the pixel and from a point of the lens, aimed so that a point's
    rays meet on the focal plane (the eye moves across a disc of radius aperture/4
    perpendicular to the view, the direction by the opposite amount at the focal
    distance). `rays(rows, k)` gives the rays of samples k (an array of sample numbers)
    of the points `rows`."""

    def __init__(self, camera: ir.Camera, width: int, height: int, xs, ys):
        self.camera, self.width, self.height = camera, width, height
        self.n = n = max(1, int(camera.blur_samples))
        xs = np.asarray(xs, dtype=np.float64)
        ys = np.asarray(ys, dtype=np.float64)
        # Kronecker sequences: every prefix covers its square evenly, so a point that stops
        # after a few rounds is not biased toward part of the lens. The lens takes R2
        # (frequencies 1/g, 1/g^2, g the plastic number), the sub-pixel position two more
        # of Roberts' R_d frequencies; a random shift per point decorrelates neighbours
        # (Cranley-Patterson rotation).
        k = np.arange(n, dtype=np.float64)[None, :]
        # the shift is the point's own (a hash of its position): tiles and threads agree
        shift = ray_random.uniforms(ray_random.keys(xs, ys), 4)[:, :, None]
        freq = (1 / 1.324717957244746, 1 / 1.324717957244746**2, 1 / 1.1673039782614187**3,
                1 / 1.1673039782614187**4)  # fmt: skip
        u, v, jx, jy = ((shift[:, i] + k * freq[i]) % 1.0 for i in range(4))
        rad, ang = 0.5 * np.sqrt(u), 2.0 * np.pi * v  # area-preserving map to the disc
        self.lx, self.ly = rad * np.cos(ang), rad * np.sin(ang)
        self.px = xs[:, None] + jx - 0.5
        self.py = ys[:, None] + jy - 0.5
        d = np.asarray(camera.direction, dtype=np.float64)
        self.xperp = tf.normalize(np.cross(np.asarray(camera.up, dtype=np.float64), d))
        self.yperp = tf.normalize(np.cross(d, self.xperp))
        loc = np.asarray(camera.location, dtype=np.float64)
        focus = loc if camera.focal_point is None else np.asarray(camera.focal_point, float)
        self.reach = np.linalg.norm(focus - loc) / np.linalg.norm(d)  # in direction lengths
        self.radius = camera.aperture * 0.5

    def rays(self, rows: np.ndarray, k: np.ndarray):
        """Origins, unit directions and traced mask of samples k (M,) of points rows (M,)."""
        origins, dirs, traced, screen = _project(
            self.camera, self.width, self.height, self.px[rows, k], self.py[rows, k]
        )
        origins = np.array(origins, dtype=np.float64)
        lx, ly = self.radius * self.lx[rows, k], self.radius * self.ly[rows, k]
        deflect = lx[:, None] * self.xperp - ly[:, None] * self.yperp
        target = origins + self.reach * dirs
        origins = origins + deflect
        dirs = target - origins
        if self.camera.normal is not None:
            dirs = bend(self.camera.normal, dirs, *screen)
        dirs /= np.linalg.norm(dirs, axis=1, keepdims=True)
        return origins, dirs, traced


def blur_rounds(n: int):
    """How many lens samples a point takes before each confidence test, as POV-Ray does:
    the rings of its hexagonal lens grids first (7, then 6 and 6, then 4, 4, 4, 4, 2 for
    the 19- and 37-sample grids; only as far as `blur_samples` reaches a grid), then 4 at
    a time, until `n` are taken."""
    rings = [7, 6, 6, 4, 4, 4, 4, 2] if n >= 37 else [7, 6, 6] if n >= 19 else [7] if n >= 7 else []
    taken = 0
    for step in rings:
        taken += step
        yield step
    while taken < n:
        taken += 4
        yield 4


def blur_thresholds(n: int, variance: float, confidence: float) -> np.ndarray:
    """POV-Ray's confidence test: after i+1 samples a point is done when the variance of
    its mean is below T[i] = variance * X(i+1) / X(n-1), X(df) the chi-square value that
    a variable of df degrees of freedom exceeds with probability `confidence`
    (Wilson-Hilferty's cube-root normal approximation)."""
    if n <= 1:
        return np.zeros(max(n, 1))
    z = NormalDist().inv_cdf(1.0 - confidence)  # exceeded with probability `confidence`
    df = np.arange(1, n + 1, dtype=np.float64)
    chi = df * np.maximum(1.0 - 2.0 / (9.0 * df) + z * np.sqrt(2.0 / (9.0 * df)), 0.0) ** 3
    last = chi[n - 2]  # X(n - 1)
    return variance * chi / last if last > 0 else np.zeros(n)


def _angle(camera: ir.Camera) -> float:
    """The viewing angle in radians (POV-Ray's default 90 degrees)."""
    return np.radians(90.0 if camera.angle is None else camera.angle)


def _fisheye(camera, sx, sy, loc, d, r, u):
    # Screen coordinates -1..1 scaled by the lengths of right and up; the angle spans the
    # unit circle's diameter; nothing is traced outside it.
    x0, y0 = 2.0 * sx * np.linalg.norm(r), 2.0 * sy * np.linalg.norm(u)
    rad = np.hypot(x0, y0)
    phi = _polar_angle(x0, y0, rad)
    theta = rad * _angle(camera) / 2.0
    r, u, d = tf.normalize(r), tf.normalize(u), tf.normalize(d)
    dirs = (np.cos(phi) * np.sin(theta)) * r + (np.sin(phi) * np.sin(theta)) * u
    dirs = dirs + np.cos(theta) * d
    return dirs, np.broadcast_to(loc, dirs.shape), (rad <= 1.0).ravel(), (phi, theta)


def _polar_angle(x0: np.ndarray, y0: np.ndarray, rad: np.ndarray) -> np.ndarray:
    """The screen point's angle around the centre, as POV-Ray takes it (from asin)."""
    phi = np.arcsin(np.clip(y0 / np.where(rad == 0, 1.0, rad), -1.0, 1.0))
    return np.where(rad == 0, 0.0, np.where(x0 < 0, np.pi - phi, phi))


def _omnimax(camera, sx, sy, loc, d, r, u):
    aspect = np.linalg.norm(r) / np.linalg.norm(u)
    x0, y0 = 2.0 * sx, 2.0 * sy
    if aspect > 1.0:
        if aspect > 1.283458:
            x0 = x0 * aspect / 1.283458
            y0 = (y0 - 1.0) / 1.283458 + 1.0
        else:
            y0 = (y0 - 1.0) / aspect + 1.0
    else:
        y0 = y0 / aspect
    rad = np.hypot(x0, y0)
    phi = _polar_angle(x0, y0, rad)
    theta = 1.411269 * rad - 0.09439 * rad**3 + 0.25674 * rad**5  # the Omnimax lens
    sp, st, ct = np.sin(phi), np.sin(theta), np.cos(theta)
    r, u, d = tf.normalize(r), tf.normalize(u), tf.normalize(d)
    dirs = (np.cos(phi) * st) * r + (sp * st) * u + ct * d
    # nothing below 45 degrees under the projection axis
    traced = (rad <= 1.0) & ~(sp * st < np.tan(np.radians(135.0)) * ct)
    return dirs, np.broadcast_to(loc, dirs.shape), traced.ravel(), (phi, theta)


def _panoramic(camera, sx, sy, loc, d, r, u):
    # Graphics Gems III: 180 degrees across, the height on a cylinder (tan of the latitude).
    lon = (0.5 - sx) * np.pi
    lat = np.pi * sy
    with np.errstate(over="ignore"):
        ty = np.where(np.abs(np.pi / 2 - np.abs(lat)) < 1e-10, np.sign(lat) * 1e30, np.tan(lat))
    dirs = np.cos(lon) * r + ty * u + np.sin(lon) * d
    return dirs, np.broadcast_to(loc, dirs.shape), None, (lon, lat)


def _ultra_wide(camera, sx, sy, loc, d, r, u):
    aspect = np.linalg.norm(u) / np.linalg.norm(r)
    a = _angle(camera)
    x0, y0 = sx * a, sy * a * aspect
    dirs = (
        np.sin(x0) * tf.normalize(r)
        + np.sin(y0) * tf.normalize(u)
        + (np.cos(x0) * np.cos(y0)) * tf.normalize(d)
    )
    return dirs, np.broadcast_to(loc, dirs.shape), None, (x0, y0)


def _cylinder(camera, sx, sy, loc, d, r, u):
    """Types 1 and 3 wrap the angle around the up axis, 2 and 4 around right; 3 and 4
    shift the origin along the axis (parallel rays along it) instead of fanning out."""
    kind = camera.cylinder or 1
    lr, lu = np.linalg.norm(r), np.linalg.norm(u)
    r, u, d = tf.normalize(r), tf.normalize(u), tf.normalize(d)
    # 2 and 4 are 1 and 3 with right and up (and the screen's x and y) trading places
    side, s_side, axis, s_axis, length = (
        (r, sx, u, sy, lu) if kind in (1, 3) else (u, sy, r, sx, lr)
    )
    theta = s_side * _angle(camera)
    dirs = np.sin(theta) * side + np.cos(theta) * d
    offset = (s_axis * length) * axis
    origins = np.broadcast_to(loc, (len(sx), 3))
    if kind in (1, 2):
        dirs = dirs + offset
    else:
        origins = loc + offset
    screen = (theta, sy * length) if kind in (1, 3) else (sx * length, theta)
    return dirs, origins, None, screen


def _spherical(camera, sx, sy, loc, d, r, u):
    # Latitude: turn the direction about right by -y; longitude: about up by x.
    h = 360.0 if camera.angle is None else camera.angle
    v = camera.v_angle if camera.v_angle is not None else h / 2.0
    lat = sy * np.radians(v)
    lon = sx * np.radians(h)
    v1 = _rotate(np.broadcast_to(d, (len(sy), 3)), tf.normalize(r), -lat)
    return _rotate(v1, tf.normalize(u), lon), np.broadcast_to(loc, v1.shape), None, (lon, lat)


def _rotate(v: np.ndarray, axis: np.ndarray, angle: np.ndarray) -> np.ndarray:
    """Rodrigues: v turned by `angle` (N,1) about the unit `axis`, counter-clockwise seen
    from its tip in a right-handed frame (POV-Ray's Compute_Axis_Rotation_Transform)."""
    c, s = np.cos(angle), np.sin(angle)
    return v * c + np.cross(axis, v) * s + axis * (v @ axis)[:, None] * (1.0 - c)


_PROJECTIONS = {
    "fisheye": _fisheye,
    "omnimax": _omnimax,
    "panoramic": _panoramic,
    "ultra_wide_angle": _ultra_wide,
    "cylinder": _cylinder,
    "spherical": _spherical,
}
SUPPORTED_KINDS = frozenset({"perspective", "orthographic", *_PROJECTIONS})


def _warn_kind(kind: str) -> None:
    # The evaluator already reports unsupported camera kinds; this only says what we did.
    notices.say_once(f"strala: camera type {kind!r} not supported, rendering as perspective")


# How far beyond the image the view's half spaces reach, in pixels: anti-aliasing compares
# with (and so traces) a row and a column just outside the tile, also at the image's edge.
VIEW_GROW_PIXELS = 2.0


def view_planes(camera: ir.Camera, width: int, height: int) -> list[tuple[np.ndarray, np.ndarray]]:
    """Half spaces (unit n, p0), n . (x - p0) <= 0, holding every point of every camera ray
    a render traces (the image grown by VIEW_GROW_PIXELS on each side), or [] when a
    degenerate camera leaves none to trust. Used to skip work for what lies outside (see
    prepare and whitted.view_masks)."""
    loc = np.asarray(camera.location, dtype=np.float64)
    fwd = np.asarray(camera.direction, dtype=np.float64)
    right = np.asarray(camera.right, dtype=np.float64)
    up = np.asarray(camera.up, dtype=np.float64)
    if camera.normal is not None or camera.mesh is not None:
        return []  # a camera normal bends rays out of the view's pyramid; a mesh has none
    if camera.kind not in ("perspective", "orthographic"):
        return []  # the other projections' rays leave the pyramid (a fisheye's go sideways)
    gx = 0.5 + VIEW_GROW_PIXELS / max(width, 1)
    gy = 0.5 + VIEW_GROW_PIXELS / max(height, 1)
    out = []
    if camera.kind == "orthographic":
        # origins loc + sx right + sy up (|sx| <= gx, |sy| <= gy), all going along fwd
        for n, reach, centre in (
            (np.cross(fwd, up), gx * right, right),
            (np.cross(fwd, right), gy * up, up),
        ):
            if not n @ centre:
                return []
            n = n if n @ centre > 0 else -n
            out += [(n, loc + reach), (-n, loc - reach)]
        back = np.cross(right, up)
        if not back @ fwd:
            return []
        out.append((-back if back @ fwd > 0 else back, loc))
    else:
        # rays from loc along fwd + sx right + sy up: the pyramid over the grown image
        corners = [
            fwd + a * gx * right + b * gy * up for a, b in ((1, 1), (-1, 1), (-1, -1), (1, -1))
        ]
        for k in range(4):
            n = np.cross(corners[k], corners[(k + 1) % 4])
            if not n @ fwd:
                return []
            out.append((-n if n @ fwd > 0 else n, loc))
        if all(c @ fwd > 0 for c in corners):  # every ray goes forward: nothing behind the eye
            out.append((-fwd, loc))
    return [(n / np.linalg.norm(n), p0) for n, p0 in out]
