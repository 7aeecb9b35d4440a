"""Fog as POV-Ray's ComputeFog draws it: what a ray sees through each fog over the distance it
travels (constant fog, ground fog with its density profile, turbulence thinning it), for
camera rays and, with a light's `media_attenuation`, for the light on its way to a
surface."""

from __future__ import annotations

import numpy as np

from lang import ir
from runtime import noise, shading


def scene_fogs(scene: ir.Scene) -> tuple[ir.Fog, ...]:
    """Every fog of the scene, in order (POV-Ray applies them all)."""
    return scene.fogs or ((scene.fog,) if scene.fog is not None else ())


def apply_fogs(
    fogs, depth: np.ndarray, col: np.ndarray, origins=None, dirs=None, shadow: bool = False
) -> np.ndarray:
    """POV-Ray's ComputeFog: each fog lets att = exp(-depth * density / distance) of what is
    behind it through (at least its transmit), tinted by its filter, and adds (1 - att) of
    its colour; several fogs multiply their attenuations and add their colours. Constant fog
    has density 1; ground fog integrates POV-Ray's density profile (1 below `offset`,
    1/(1 + h²) above it, h in units of `alt` along `up`). Turbulence thins a fog along each
    ray: the width is scaled by 1 - exp(-width/distance) * min(1, Turbulence(mid) * turb_depth),
    taken at the middle of the ray's path (scaled by the turbulence vector). A `shadow`
    ray (a light's way to a surface) is only attenuated: no fog colour is added."""
    width0 = np.where(np.isfinite(depth), depth, MAX_FOG_DISTANCE)
    sum_att = np.ones_like(col)
    sum_col = np.zeros_like(col)
    for fog in fogs:
        if abs(fog.distance) <= shading.EPSILON:
            continue
        att = fog_attenuation(fog, width0, origins, dirs)
        fc = np.asarray(fog.color, dtype=np.float64)
        att = np.maximum(att, fc[4])
        sum_att = sum_att * (att[:, None] * ((1.0 - fc[3]) + fc[3] * fc[:3]))
        if not shadow:
            sum_col = sum_col + (1.0 - att)[:, None] * fc[:3]
    return sum_col + sum_att * col


def fog_attenuation(fog: ir.Fog, width: np.ndarray, origins=None, dirs=None) -> np.ndarray:
    """The share of light one fog lets through over `width` along each ray (before its
    transmit floor): POV-Ray's ComputeConstantFogDepth and ComputeGroundFogDepth."""
    density: float | np.ndarray = 1.0
    have_rays = origins is not None and dirs is not None
    if fog.fog_type == 2 and have_rays and fog.alt != 0:
        up = np.asarray(fog.up, dtype=np.float64)
        up = up / np.linalg.norm(up)
        y1 = origins @ up
        y2 = (origins + dirs * width[:, None]) @ up
        a = (y1 - fog.offset) / fog.alt
        b = (y2 - fog.offset) / fog.alt
        density = ground_fog_density(a, b)
    # any other type is constant fog, as POV-Ray renders it (check warns where it is written)
    if fog.turbulence is not None and have_rays:
        mid = (origins + dirs * (width / 2.0)[:, None]) * np.asarray(fog.turbulence)
        turb = noise.turbulence(mid, fog.octaves, fog.omega, fog.lam)
        with np.errstate(over="ignore"):
            k = np.exp(-width / fog.distance)
        width = width * (1.0 - k * np.minimum(1.0, turb * fog.turb_depth))
    with np.errstate(over="ignore"):
        return np.exp(-width * density / fog.distance)


# Rays that hit nothing cross this much fog (POV-Ray's MAX_DISTANCE).
MAX_FOG_DISTANCE: float = 1.0e7


def ground_fog_density(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Mean ground-fog density between heights a and b (in units of fog_alt above
    fog_offset): 1 where below 0, 1/(1 + h²) above, whose integral is atan(h)."""
    with np.errstate(divide="ignore", invalid="ignore"):
        both_below = (a <= 0) & (b <= 0)
        a_below = (a <= 0) & (b > 0)
        b_below = (a > 0) & (b <= 0)
        delta = a - b
        d_a = np.where(a_below, (np.arctan(b) - a) / np.where(b - a != 0, b - a, 1), 0.0)
        d_b = np.where(b_below, (np.arctan(a) - b) / np.where(a - b != 0, a - b, 1), 0.0)
        close = np.abs(delta) <= shading.EPSILON
        d_up = np.where(
            close, 1.0 / (a * a + 1.0), (np.arctan(a) - np.arctan(b)) / np.where(close, 1, delta)
        )
    return np.where(both_below, 1.0, np.where(a_below, d_a, np.where(b_below, d_b, d_up)))
