"""POV-Ray 3.7's camera rules: block items → the final ir.Camera vectors.

POV-Ray (3.5+ syntax) reads every item of the block first and then, in this order: sets the
direction's length from `angle` (|direction| = |right| / 2 / tan(angle/2)), re-aims the camera
for `look_at` (direction toward the point with its length kept, right = sky × direction with
its length and handedness kept, up = direction × right with its length kept), scales an
orthographic camera's right and up to the perspective view's area at the look_at distance
(unless right/up were given without an angle), and finally applies the block's
transformations to every vector. `camera { Declared … }` starts from a
declared camera's final state.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field, replace
from typing import Any

from lang import transforms
from lang.ir import IDENTITY, Camera, Matrix, Vec3

# POV-Ray's EPSILON for a degenerate look_at (location == look_at, or sky ∥ direction).
CAMERA_EPSILON = 1e-10


# Focal blur's rays per pixel, at most (POV-Ray sets no bound; its adaptive sampling stops
# far below this in any scene that renders).
MAX_BLUR_SAMPLES = 65536


class CameraError(Exception):
    pass


def _sub(a: Vec3, b: Vec3) -> Vec3:
    return (a[0] - b[0], a[1] - b[1], a[2] - b[2])


def _dot(a: Vec3, b: Vec3) -> float:
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


def _len(a: Vec3) -> float:
    return math.sqrt(_dot(a, a))


def _scaled(a: Vec3, s: float) -> Vec3:
    return (a[0] * s, a[1] * s, a[2] * s)


def _unit(a: Vec3) -> Vec3:
    n = _len(a)
    return _scaled(a, 1.0 / n) if n > 0 else a


def legal_blur_value(name: str, value: float) -> bool:
    """POV-Ray's Parse_Camera ranges: confidence strictly inside 0..1, variance within it
    (outside them it warns and keeps the default)."""
    v = float(value)
    return 0.0 < v < 1.0 if name == "confidence" else 0.0 <= v <= 1.0


@dataclass
class CameraBuilder:
    """Collects a camera block's items; `build` applies POV-Ray's rules."""

    camera: Camera = field(default_factory=Camera)
    look_at_point: Vec3 = (0.0, 0.0, 1.0)
    had_look_at: bool = False
    had_angle: bool = False
    had_right: bool = False
    had_up: bool = False
    transform: Matrix = IDENTITY
    warnings: list[str] = field(default_factory=list)

    def set(self, name: str, value: Any) -> None:
        c = self.camera
        if name in ("location", "direction", "right", "up", "sky", "focal_point"):
            self.camera = replace(c, **{name: value})
            self.had_right |= name == "right"
            self.had_up |= name == "up"
        elif name == "look_at":
            self.look_at_point = value
            self.had_look_at = True
        elif name == "angle":
            # a float, or (horizontal, vertical) for the spherical camera
            both = value if isinstance(value, tuple) else (value,)
            a = float(both[0])
            if a < 0 or (len(both) > 1 and float(both[1]) < 0):
                raise CameraError("negative viewing angle")
            if c.kind == "perspective" and a >= 180.0:
                raise CameraError("a perspective camera's angle must be below 180 degrees")
            v = float(both[1]) if len(both) > 1 else None
            self.camera = replace(c, angle=a, v_angle=v)
            self.had_angle = True
        elif name == "cylinder":
            kind = int(value)
            if kind not in (1, 2, 3, 4):
                raise CameraError(f"cylinder camera type {kind}: it is 1, 2, 3 or 4")
            self.camera = replace(c, kind="cylinder", cylinder=kind)
        elif name in (
            "perspective",
            "orthographic",
            "fisheye",
            "ultra_wide_angle",
            "omnimax",
            "panoramic",
            "spherical",
            "mesh_camera",
        ):
            self.camera = replace(c, kind=name)
        elif name == "aperture":
            self.camera = replace(c, aperture=float(value))
        elif name == "blur_samples":  # max, or (min, max)
            both = value if isinstance(value, tuple) else (0, value)
            if not all(abs(float(v)) <= MAX_BLUR_SAMPLES for v in both):
                raise CameraError(
                    f"blur_samples takes at most {MAX_BLUR_SAMPLES:,} rays per pixel"
                )  # each pixel's rays are traced at once: more cannot be held
            lo, hi = int(both[0]), int(both[1])
            if lo < 0 or hi < 0:
                raise CameraError("blur_samples must not be negative")
            self.camera = replace(c, blur_samples=hi, blur_samples_min=lo)
        elif name == "confidence":
            self.camera = replace(c, blur_confidence=float(value))
        elif name == "variance":
            self.camera = replace(c, blur_variance=float(value))
        else:
            raise CameraError(f"unknown camera item `{name}`")

    def add_transform(self, m: Matrix) -> None:
        self.transform = transforms.then(self.transform, m)

    def build(self) -> Camera:
        c = self.camera
        direction, right, up = c.direction, c.right, c.up
        if (
            self.had_angle
            and c.angle  # POV-Ray scales the direction by a positive angle; 0 leaves it
            and c.kind in ("perspective", "orthographic")
        ):
            length = 0.5 * _len(right) / math.tan(math.radians(c.angle) / 2.0)
            direction = _scaled(_unit(direction), length)
        if self.had_look_at:
            d_len, u_len, r_len = _len(direction), _len(up), _len(right)
            handedness = _dot(transforms.cross(up, direction), right)
            new_dir = _sub(self.look_at_point, c.location)
            if _dot(new_dir, new_dir) < CAMERA_EPSILON:
                raise CameraError("camera location and look_at point must be different")
            new_dir = _unit(new_dir)
            new_right = transforms.cross(c.sky, new_dir)
            if all(abs(v) < CAMERA_EPSILON for v in new_right):
                self.warnings.append(
                    "Camera location to look_at direction and sky direction should be "
                    "different. Using default/supplied right vector instead."
                )
                new_right = right
            new_right = _unit(new_right)
            up = _scaled(transforms.cross(new_dir, new_right), u_len)
            direction = _scaled(new_dir, d_len)
            right = _scaled(new_right, r_len if handedness > 0.0 else -r_len)
        if c.kind == "orthographic" and (self.had_angle or not (self.had_up or self.had_right)):
            # POV-Ray: the same image area as the perspective camera would show at the
            # look_at distance (only when right/up were not given, or with an angle)
            k1 = _len(_sub(self.look_at_point, c.location))
            k2 = _len(direction)
            if k1 > CAMERA_EPSILON and k2 > CAMERA_EPSILON:
                right = _scaled(right, k1 / k2)
                up = _scaled(up, k1 / k2)
        c = replace(c, direction=direction, right=right, up=up)
        if not transforms.is_identity(self.transform):
            c = transform_camera(c, self.transform)
        # POV-Ray's Parse_Camera ends by checking the vectors it will render with
        pairs = ((c.right, c.up), (c.right, c.direction), (c.up, c.direction))
        if any(abs(_dot(a, b)) > CAMERA_EPSILON for a, b in pairs):
            self.warnings.append(
                "Camera vectors are not perpendicular. Making look_at the last statement may help."
            )
        return c


def transform_camera(c: Camera, m: Matrix) -> Camera:
    fp = c.focal_point
    return replace(
        c,
        location=transforms.apply_point(m, c.location),
        direction=transforms.apply_direction(m, c.direction),
        right=transforms.apply_direction(m, c.right),
        up=transforms.apply_direction(m, c.up),
        sky=transforms.apply_direction(m, c.sky),
        focal_point=transforms.apply_point(m, fp) if fp is not None else None,
    )


def vec3(v: Sequence[float]) -> Vec3:
    return (float(v[0]), float(v[1]), float(v[2]))
