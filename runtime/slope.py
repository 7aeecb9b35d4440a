"""The slope pattern (POV-Ray 3.7's slope_pattern): how steep the surface is against a
direction, read from the surface normal at the shaded point, optionally mixed with the
point's altitude along a second vector.

The normal is the one shading uses, turned toward the incoming ray (and, for a pigment,
perturbed by its layer's normal), in world space: the pattern's transforms move the
altitude's points, never the direction. Without a surface (media densities, the sky, a
pattern in a function) the value is 0, as POV-Ray's is without an intersection.

`params` keys (lang.eval.textures sets them): "slope_direction" (unit vector, or the
point with "slope_point_at"), "altitude" (unit vector), "slope_range" and
"altitude_range" ((low, width); width 0: none), "slope_mix" (the slope's and the
altitude's shares, summing to 1)."""

from __future__ import annotations

import math

import numpy as np

# POV-Ray's EPSILON: a value of exactly 1 stays at the map's top instead of wrapping to 0.
TOP_EPSILON: float = 1.0e-10


def slope(
    p: np.ndarray, points: np.ndarray, normals: np.ndarray | None, params: dict
) -> np.ndarray:
    """(N,) the slope pattern at pattern-space points `p` (world points `points`, unit
    world `normals`): asin(normal . direction) mapped from [-90°, 90°] to [0, 1] (0 facing
    away, 1 facing the direction; with point_at, the direction toward the point), rescaled
    by the slope range, mixed with the altitude (p . altitude, rescaled by its range), and
    wrapped into [0, 1)."""
    n = len(p)
    if normals is None:
        return np.zeros(n)
    d = np.asarray(params.get("slope_direction", (0.0, 1.0, 0.0)), dtype=np.float64)
    if params.get("slope_point_at"):
        toward = d - points
        length = np.linalg.norm(toward, axis=1, keepdims=True)
        toward = toward / np.where(length > 0, length, 1.0)
        cos = np.einsum("ij,ij->i", normals, toward)
    else:
        cos = normals @ d
    value = (np.arcsin(np.clip(cos, -1.0, 1.0)) / math.pi * 2.0 + 1.0) * 0.5
    value = _rescale(value, params.get("slope_range", (0.0, 0.0)))
    share, altitude_share = params.get("slope_mix", (1.0, 0.0))
    if not altitude_share:
        return np.where(value == 1.0, 1.0 - TOP_EPSILON, _wrap(value))
    height = p @ np.asarray(params.get("altitude", (0.0, 0.0, 0.0)), dtype=np.float64)
    height = _rescale(height, params.get("altitude_range", (0.0, 0.0)))
    value = share * value + altitude_share * height
    at_top = (value >= 1.0) & (value - 1.0 < TOP_EPSILON)
    return np.where(at_top, value - TOP_EPSILON, _wrap(value))


def _rescale(value: np.ndarray, low_width) -> np.ndarray:
    low, width = low_width
    return value if width == 0.0 else (value - low) / width


def _wrap(value: np.ndarray) -> np.ndarray:
    # C's fmod keeps the sign: a negative value wraps to 1 + fmod(v, 1)
    f = np.fmod(value, 1.0)
    # 1 + fmod of a tiny negative value rounds to 1: kept below the map's top, as at 1 itself
    return np.where(value < 0.0, np.minimum(1.0 + f, 1.0 - TOP_EPSILON), f)
