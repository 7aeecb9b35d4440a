"""Rainbows as POV-Ray's ComputeRainbow draws them over what a ray sees (a surface or the
sky), before media and fog.

A ray whose direction makes an angle a with the rainbow's antisolar direction (in front
of it: cos a >= 0) and lies within the arc (its angle from `up`, in the up-right plane, at
most arc_angle) looks up the colour_map at (a - angle) / width, if that is in [0, 1)
(jitter shifts the index by up to ±jitter). The colour C comes in by k = exp(-depth /
distance), at least C's transmit (raised toward 1 by the smooth falloff past
falloff_angle): the ray's colour becomes k * colour * ((1 - f) + f * C) + (1 - k) * C,
f = C's filter * (1 - k). Several rainbows on one ray average their results.
"""

from __future__ import annotations

import numpy as np

from lang import ir
from runtime import patterns

# POV-Ray's EPSILON: the colour_map index stops short of 1 by it
_EPSILON = 1.0e-10
# a missed ray's depth (POV-Ray's BOUND_HUGE): the rainbow's colour shows in full
_SKY_DEPTH = 2.0e10


def apply_rainbows(
    rainbows: tuple[ir.Rainbow, ...], dirs: np.ndarray, depth: np.ndarray, col: np.ndarray
) -> np.ndarray:
    """(N,3) the colours of rays with direction `dirs` that travelled `depth` (inf: they
    escaped) after the scene's rainbows."""
    d = dirs / np.linalg.norm(dirs, axis=1, keepdims=True)
    depth = np.where(np.isfinite(depth), depth, _SKY_DEPTH)
    total = np.zeros_like(col)
    count = np.zeros(len(col))
    for rb in rainbows:
        if rb.pigment is None or rb.distance == 0.0 or rb.width == 0.0:
            continue
        x = d @ np.asarray(rb.right)
        y = d @ np.asarray(rb.up)
        length = np.sqrt(x * x + y * y)
        y = np.where(length > 0.0, y / np.where(length > 0.0, length, 1.0), y)
        angle = np.abs(np.arccos(np.clip(y, -1.0, 1.0)))
        facing = d @ np.asarray(rb.direction)
        index = (np.arccos(np.clip(facing, -1.0, 1.0)) - rb.angle) / rb.width
        if rb.jitter > 0.0:
            index = index + (2.0 * _grain(d) - 1.0) * rb.jitter
        rows = np.nonzero(
            (angle <= rb.arc_angle) & (facing >= 0.0) & (index >= 0.0) & (index <= 1.0 - _EPSILON)
        )[0]
        if not len(rows):
            continue
        at = np.zeros((len(rows), 3))
        at[:, 0] = index[rows]
        c = patterns.evaluate(rb.pigment, at)
        fade = np.zeros(len(rows))
        falloff_width = rb.arc_angle - rb.falloff_angle
        if falloff_width > 0.0:
            past = angle[rows] > rb.falloff_angle
            t = (angle[rows] - rb.falloff_angle) / falloff_width
            fade = np.where(past, (3.0 - 2.0 * t) * t * t, 0.0)
        k = np.exp(-depth[rows] / rb.distance)
        k = np.maximum(k, fade * (1.0 - c[:, 4]) + c[:, 4])
        ki = 1.0 - k
        f = (c[:, 3] * ki)[:, None]
        rgb = c[:, :3]
        total[rows] += k[:, None] * col[rows] * ((1.0 - f) + f * rgb) + ki[:, None] * rgb
        count[rows] += 1.0
    hit = count > 0
    out = col.copy()
    out[hit] = total[hit] / count[hit, None]
    return out


def _grain(d: np.ndarray) -> np.ndarray:
    """(N,) pseudo-random numbers in [0, 1) per ray direction (POV-Ray draws them from its
    random generator; the same direction here always gets the same one)."""
    h = np.sin(d @ np.array([12.9898, 78.233, 37.719]) * 1000.0) * 43758.5453
    return h - np.floor(h)
