"""POV-Ray 3.7's local illumination model, vectorised over batches of surface points.

Formulas (POV-Ray 3.7, `Trace::ComputeLightedTexture` and friends, documented behaviour):
- ambient:   pigment * ambient * ambient_light * opacity (+ pigment * emission * opacity)
- diffuse:   pigment * light * diffuse * |N·L|^brilliance * opacity, only where N·L > 0
             (or anywhere with double_illuminate; the back side uses diffuse_back)
- specular:  light * specular * (N·H)^(1/roughness), H = halfway between view and light
- phong:     light * phong * (R·L)^phong_size, R = the view ray mirrored about N
- metallic m tints highlights: light * (1 + m (1 - F) (pigment - 1)) with POV-Ray's
             empirical Fresnel curve F(angle) = 0.014567225/(x - 1.12)² - 0.011612903,
             x = angle/90°, clamped to [0,1]
- lights:    colour * spotlight/cylinder cone * fade 2/(1 + (d/fade_distance)^fade_power),
             times the shadow filter (opaque blockers black, transparent ones filter).
Highlights are not scaled by opacity (POV-Ray adds them outside the opacity factor).
N is the normal turned toward the viewer; L points from the surface to the light.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from lang import ir
from runtime import transform as tf
from runtime.noise import turbulence

if TYPE_CHECKING:  # the batched finishes of plain textures, which these functions take too
    from runtime.context import FinishRows

# POV-Ray's EPSILON: a light exactly in the tangent plane does not light the surface.
EPSILON: float = 1e-10

# POV-Ray's SHADOW_TOLERANCE: blockers closer than this to the light do not shadow (a
# light inside a looks_like object or on a surface must not shadow itself).
SHADOW_TOLERANCE: float = 1e-3

# The (POV-Ray) greyscale weights used to turn a filter colour into one transparency.
GREY = np.array([0.297, 0.589, 0.114])


def fresnel_metallic(cos_angle: np.ndarray) -> np.ndarray:
    """POV-Ray's empirical reflectivity curve F used by `metallic` (0 = head on)."""
    x = np.abs(np.arccos(np.clip(cos_angle, -1.0, 1.0))) / (math.pi / 2.0)
    f = 0.014567225 / (x - 1.12) ** 2 - 0.011612903
    return np.clip(f, 0.0, 1.0)


def metallic_tint(metallic: float, cos_angle: np.ndarray, pigment: np.ndarray) -> np.ndarray:
    """(N,3) factor 1 + m (1 - F) (pigment - 1)."""
    f = fresnel_metallic(cos_angle)
    return 1.0 + (metallic * (1.0 - f))[:, None] * (pigment - 1.0)


def cubic_spline(low: float, high: float, pos: np.ndarray) -> np.ndarray:
    """POV-Ray's smooth step from 0 at `low` to 1 at `high`."""
    if high == low:
        return np.where(pos >= high, 1.0, 0.0)
    t = np.clip((pos - low) / (high - low), 0.0, 1.0)
    return np.where(pos < low, 0.0, np.where(pos >= high, 1.0, (3.0 - 2.0 * t) * t * t))


# ------------------------------------------------------------------------ lights
@dataclass
class LightSample:
    """A light as seen from N surface points."""

    direction: np.ndarray  # (N,3) unit, surface → light
    distance: np.ndarray  # (N,) distance to the light along `direction` (inf: none)
    colour: np.ndarray  # (N,3) light colour after cone and distance attenuation


def light_ray(light: ir.Light, points: np.ndarray, centre=None) -> tuple[np.ndarray, np.ndarray]:
    """Unit direction to the light and its depth (POV-Ray's ComputeOneWhiteLightRay)."""
    c = np.asarray(light.position if centre is None else centre, dtype=np.float64)
    pts = np.asarray(points, dtype=np.float64)
    if light.kind == "cylinder":
        axis = tf.normalize(np.asarray(light.position) - np.asarray(light.point_at))
        d = np.broadcast_to(axis, pts.shape).copy()
        depth = (c - pts) @ axis
        return d, depth
    to_light = c - pts
    depth = np.linalg.norm(to_light, axis=-1)
    d = to_light / np.where(depth > 0, depth, 1.0)[..., None]
    if light.kind == "parallel":
        beam = tf.normalize(np.asarray(light.point_at) - np.asarray(light.position))
        a = d @ beam
        depth = depth * -a
        d = np.broadcast_to(-beam, pts.shape).copy()
    return d, depth


def attenuation(light: ir.Light, points: np.ndarray, direction: np.ndarray, depth: np.ndarray):
    """(N,) cone and distance attenuation (POV-Ray's Attenuate_Light)."""
    n = len(depth)
    att = np.ones(n)
    if light.kind == "spotlight":
        axis = tf.normalize(np.asarray(light.point_at) - np.asarray(light.position))
        cos_t = direction @ axis
        cos_t = np.where(depth > 0, -cos_t, cos_t)
        att = np.where(cos_t > 0, np.power(np.clip(cos_t, 0, None), light.tightness), 0.0)
        cos_r = math.cos(math.radians(light.radius))
        cos_f = math.cos(math.radians(light.falloff))
        if cos_r > 0:
            att = np.where(cos_t < cos_r, att * cubic_spline(cos_f, cos_r, cos_t), att)
    elif light.kind == "cylinder":
        axis = tf.normalize(np.asarray(light.point_at) - np.asarray(light.position))
        v1 = points - np.asarray(light.position, dtype=np.float64)
        k = v1 @ axis
        radial = np.linalg.norm(v1 - k[:, None] * axis, axis=1)
        falloff = light.falloff
        dist = 1.0 - radial / falloff if falloff > 0 else np.zeros(n)
        att = np.where(
            (k > 0) & (radial < falloff), np.power(np.clip(dist, 0, None), light.tightness), 0.0
        )
        if light.radius > 0 and falloff > 0:
            soft = cubic_spline(0.0, 1.0 - light.radius / falloff, dist)
            att = np.where(radial > light.radius, att * soft, att)
    power = light.fade_power or 0.0
    fd = light.fade_distance or 0.0
    # POV-Ray's Attenuate_Light: no fade unless both are set (a fade_distance of 0, or one
    # within EPSILON of it, leaves the light whole)
    if power > 0 and abs(fd) > EPSILON:
        with np.errstate(divide="ignore", over="ignore"):
            fade = 2.0 / (1.0 + np.power(np.abs(depth) / fd, power))
        att = np.where(att > 0, att * fade, att)
    return att


def sample_light(light: ir.Light, points: np.ndarray) -> LightSample:
    d, depth = light_ray(light, points)
    att = attenuation(light, points, d, depth)
    colour = att[:, None] * np.asarray(light.color, dtype=np.float64)
    return LightSample(d, depth, colour)


def area_offsets(area: ir.AreaLight) -> np.ndarray:
    """(K,2) grid coefficients (u, v) in [-0.5, 0.5] for an area light's sub-lights, with
    POV-Ray's circular remapping of the square grid onto a disc."""
    n1, n2 = max(1, area.size1), max(1, area.size2)
    u = np.arange(n1, dtype=np.float64)
    v = np.arange(n2, dtype=np.float64)
    grid_u, grid_v = np.meshgrid(u, v, indexing="ij")
    uu, vv = grid_u.ravel(), grid_v.ravel()
    if area.circular and n1 > 1 and n2 > 1:
        ju = uu / (n1 - 1) - 0.5 + 0.001
        jv = vv / (n2 - 1) - 0.5 + 0.001
        scale = np.maximum(np.abs(ju), np.abs(jv)) / np.hypot(ju, jv)
        return np.stack([ju * scale, jv * scale], axis=1)
    cu = uu / (n1 - 1) - 0.5 if n1 > 1 else np.zeros_like(uu)
    cv = vv / (n2 - 1) - 0.5 if n2 > 1 else np.zeros_like(vv)
    return np.stack([cu, cv], axis=1)


def area_weights(n1: int, n2: int) -> np.ndarray:
    """(n1*n2,) weights of an area light's sub-lights in the shadow average, flattened like
    `area_offsets`. POV-Ray averages the four corners of the grid, subdividing each region
    into quarters (sharing their middle row/column) while it is more than one cell wide;
    with every region subdivided that is a fixed weighting of the grid, computed here."""
    w = np.zeros((max(1, n1), max(1, n2)))

    def split(u1: int, v1: int, u2: int, v2: int, weight: float) -> None:
        if u2 - u1 > 1 or v2 - v1 > 1:
            um, vm = (u1 + u2) / 2.0, (v1 + v2) / 2.0
            lo_u, hi_u = int(math.floor(um)), int(math.ceil(um))
            lo_v, hi_v = int(math.floor(vm)), int(math.ceil(vm))
            for a, b, c, d in (
                (u1, v1, lo_u, lo_v),
                (hi_u, v1, u2, lo_v),
                (u1, hi_v, lo_u, v2),
                (hi_u, hi_v, u2, v2),
            ):
                split(a, b, c, d, weight / 4.0)
            return
        for u, v in ((u1, v1), (u2, v1), (u1, v2), (u2, v2)):
            w[u, v] += weight / 4.0

    split(0, 0, w.shape[0] - 1, w.shape[1] - 1, 1.0)
    return w.ravel()


def area_coarse_indices(n: int, levels: int) -> np.ndarray:
    """Grid indices (along one axis of n sub-lights) that POV-Ray samples when it splits
    the grid `levels` times from its two ends: 0 levels are the corners only."""
    picked = {0, n - 1}
    spans = [(0, n - 1)]
    for _ in range(max(0, levels)):
        nxt = []
        for a, b in spans:
            if b - a > 1:
                m = (a + b) / 2.0
                lo, hi = int(math.floor(m)), int(math.ceil(m))
                picked.update((lo, hi))
                nxt += [(a, lo), (hi, b)]
        spans = nxt
    return np.array(sorted(picked), dtype=np.int64)


def area_centres(light: ir.Light, points: np.ndarray) -> np.ndarray:
    """(N,K,3) sub-light positions of an area light as seen from each point."""
    area = light.area
    assert area is not None
    a1 = np.asarray(area.axis1, dtype=np.float64)
    a2 = np.asarray(area.axis2, dtype=np.float64)
    coef = area_offsets(area)
    centre = np.asarray(light.position, dtype=np.float64)
    n = len(points)
    if area.orient:
        d, _ = light_ray(light, points)
        length = np.linalg.norm(a1)
        near_vertical = np.abs(np.abs(d[:, 2]) - 1.0) < 0.01
        helper = np.where(near_vertical[:, None], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0])
        ax1 = np.cross(d, helper)
        ax1 /= np.linalg.norm(ax1, axis=1, keepdims=True)
        ax2 = np.cross(d, ax1)
        ax2 /= np.linalg.norm(ax2, axis=1, keepdims=True)
        ax1 *= length
        ax2 *= length
        return (
            centre
            + coef[None, :, 0, None] * ax1[:, None, :]
            + coef[None, :, 1, None] * ax2[:, None, :]
        )
    offs = coef[:, 0, None] * a1 + coef[:, 1, None] * a2
    return np.broadcast_to(centre + offs, (n, len(coef), 3))


# ----------------------------------------------------------------------- finish
@dataclass
class Surface:
    """What the finish model needs about N surface points."""

    normal: np.ndarray  # (N,3) layer normal, turned toward the viewer
    ray_dir: np.ndarray  # (N,3) unit direction of the incoming ray
    points: np.ndarray | None = None  # (N,3) world points, for the iridescence's turbulence


def ambient_term(
    finish: ir.Finish | FinishRows, pigment: np.ndarray, opacity: np.ndarray, ambient_light
) -> np.ndarray:
    amb = np.asarray(finish.ambient, dtype=np.float64) * np.asarray(ambient_light, dtype=np.float64)
    emis = np.asarray(finish.emission, dtype=np.float64)
    return pigment * (amb + emis) * opacity[:, None]


def light_terms(
    finish: ir.Finish | FinishRows,
    surf: Surface,
    pigment: np.ndarray,
    opacity: np.ndarray,
    light_dir: np.ndarray,
    light_col: np.ndarray,
    double_illuminate: bool | np.ndarray = False,
    grain: np.ndarray | None = None,
    highlights: bool = True,
) -> np.ndarray:
    """(N,3) diffuse + specular + phong (+ iridescence) from one light (light_col already
    shadowed). double_illuminate (per row or for all) lights both sides alike. grain:
    (N,) random numbers in [0, 1) for `crand` (POV-Ray subtracts crand * random from the
    diffuse intensity). `highlights` False: a shadowless light, which POV-Ray's
    ComputeOneLightRay gives no phong or specular highlight (a fill light)."""
    n = surf.normal
    cos_l = np.einsum("ij,ij->i", n, light_dir)
    front = cos_l >= EPSILON
    double = np.broadcast_to(np.asarray(double_illuminate, dtype=bool), front.shape)
    # POV-Ray skips the facing test for double_illuminate; otherwise the far side only gets
    # diffuse_back, and no highlights.
    back = ~front & ~double & (np.asarray(finish.diffuse_back) != 0.0)
    lit = front | double
    out = np.zeros_like(pigment)
    # Finish values are scalars, or (N,) arrays when textures are shaded together.
    if np.any(np.asarray(finish.diffuse) > 0) or np.any(np.asarray(finish.diffuse_back) > 0):
        diffuse = np.where(back, finish.diffuse_back, finish.diffuse)
        a = np.abs(cos_l)
        b = np.asarray(finish.brilliance)
        intensity = a if np.all(b == 1.0) else np.power(a, b)
        intensity = intensity * np.maximum(diffuse, 0.0) * opacity
        if grain is not None and np.any(np.asarray(finish.crand) > 0):
            intensity = intensity - grain * finish.crand
        intensity = np.where(lit | back, intensity, 0.0)
        out += intensity[:, None] * pigment * light_col
    if highlights and np.any(np.asarray(finish.phong) > 0):
        out += highlight_phong(finish, surf, light_dir, light_col, pigment, cos_l, lit)
    if highlights and np.any(np.asarray(finish.specular) > 0):
        out += highlight_specular(finish, surf, light_dir, light_col, pigment, cos_l, lit)
    if finish.irid is not None and finish.irid[0] > 0:
        out = out * iridescence(finish, surf, light_dir)
    return out


# POV-Ray 3.7's default `irid_wavelength`: 700, 520 and 480 nm divided by 1000 (checked
# against POV-Ray renders of an iridescent sphere).
IRID_WAVELENGTHS = np.array([0.70, 0.52, 0.48])


def iridescence(finish: ir.Finish, surf: Surface, light_dir: np.ndarray) -> np.ndarray:
    """(N,3) thin-film factor 1 + irid * cos(2 pi thickness (|N.L| + |N.V|) / wavelength).
    With `turbulence t` the film's thickness varies over the surface as POV-Ray's
    ComputeIridColour has it: times 1 + t (2 Turbulence(P) - 1), 5 octaves, omega 0.5,
    lambda 2, at the world point P."""
    assert finish.irid is not None
    amount, thickness, turb = finish.irid[0], finish.irid[1], finish.irid[2]
    cos_l = np.abs(np.einsum("ij,ij->i", surf.normal, light_dir))
    cos_e = np.abs(np.einsum("ij,ij->i", surf.normal, surf.ray_dir))
    film: float | np.ndarray = thickness
    if turb != 0 and surf.points is not None:
        film = thickness * (1.0 + turb * (2.0 * turbulence(surf.points, 5, 0.5, 2.0) - 1.0))
    phase = 2.0 * math.pi * film * (cos_l + cos_e)
    return 1.0 + amount * np.cos(phase[:, None] / IRID_WAVELENGTHS)


def _tinted(finish: ir.Finish, intensity, light_col, pigment, cos_l) -> np.ndarray:
    if np.any(np.asarray(finish.metallic) > 0):
        return intensity[:, None] * light_col * metallic_tint(finish.metallic, cos_l, pigment)
    return intensity[:, None] * light_col


def highlight_phong(finish, surf: Surface, light_dir, light_col, pigment, cos_l, mask):
    e = surf.ray_dir
    n = surf.normal
    refl = e - 2.0 * np.einsum("ij,ij->i", e, n)[:, None] * n
    c = np.einsum("ij,ij->i", refl, light_dir)
    # POV-Ray drops the tiny tail of very tight highlights.
    ok = mask & (c > 0) & ((np.asarray(finish.phong_size) < 60) | (c > 0.0008))
    intensity = np.where(ok, finish.phong * np.power(np.clip(c, 0, None), finish.phong_size), 0.0)
    return _tinted(finish, intensity, light_col, pigment, cos_l)


def highlight_specular(finish, surf: Surface, light_dir, light_col, pigment, cos_l, mask):
    half = 0.5 * (-surf.ray_dir + light_dir)
    length = np.linalg.norm(half, axis=1)
    c = np.einsum("ij,ij->i", half, surf.normal) / np.where(length > 0, length, 1.0)
    ok = mask & (length > 0) & (c > 0)
    rough = np.asarray(finish.roughness, dtype=np.float64)
    exponent = np.where(rough != 0, 1.0 / np.where(rough != 0, rough, 1.0), 0.0)
    intensity = np.where(ok, finish.specular * np.power(np.clip(c, 0, None), exponent), 0.0)
    return _tinted(finish, intensity, light_col, pigment, cos_l)


# ------------------------------------------------------------------- reflection
def reflectivity(
    finish: ir.Finish | FinishRows,
    cos_angle: np.ndarray,
    pigment: np.ndarray,
    relative_ior: np.ndarray | float = 1.0,
) -> tuple[np.ndarray, np.ndarray]:
    """(N,3) reflection colour and (N,) weight factor for the reflected ray
    (POV-Ray's ComputeReflectivity plus `reflection { metallic }`)."""
    r = finish.reflection
    n = len(cos_angle)
    # Colours are (3,) for one finish or (N,3) per row; falloff/metallic scalars or (N,).
    rmax = np.broadcast_to(np.asarray(r.max, dtype=np.float64), (n, 3))
    rmin = np.broadcast_to(np.asarray(r.min, dtype=np.float64), (n, 3))
    if r.fresnel:
        ior = np.broadcast_to(np.asarray(relative_ior, dtype=np.float64), (n,))
        sqx = ior**2 + cos_angle**2 - 1.0
        g = np.sqrt(np.clip(sqx, 0, None))
        with np.errstate(divide="ignore", invalid="ignore"):
            f = 0.5 * (g - cos_angle) ** 2 / (g + cos_angle) ** 2
            f = f * (
                1.0
                + (cos_angle * (g + cos_angle) - 1.0) ** 2
                / (cos_angle * (g - cos_angle) + 1.0) ** 2
            )
        f = np.clip(np.nan_to_num(f, nan=1.0), 0.0, 1.0)
        f = np.where(sqx > 0, f, 1.0)
        refl = f[:, None] * rmax + (1.0 - f[:, None]) * rmin
        weight = refl.max(axis=1)
    else:
        weight = np.maximum(rmax.max(axis=1), rmin.max(axis=1))
        frac = 1.0 - cos_angle
        falloff = np.asarray(r.falloff, dtype=np.float64)
        if np.any(np.abs(falloff - 1.0) > EPSILON):
            frac = np.power(np.clip(frac, 0, None), falloff)
        refl = frac[:, None] * rmax + (1.0 - frac[:, None]) * rmin
    if np.any(np.asarray(r.metallic) != 0.0):
        f = fresnel_metallic(cos_angle)
        refl = refl * (1.0 + (r.metallic * (1.0 - f))[:, None] * (pigment - 1.0))
    return refl, weight


def reflect(ray_dir: np.ndarray, normal: np.ndarray, raw_normal: np.ndarray) -> np.ndarray:
    """Mirror direction about the (perturbed) normal, with POV-Ray's fix for rays that a
    bumpy normal would send into the surface: mirror about the raw normal instead."""
    d = ray_dir - 2.0 * np.einsum("ij,ij->i", ray_dir, normal)[:, None] * normal
    into = np.einsum("ij,ij->i", d, raw_normal) < 0
    if into.any():
        behind = np.einsum("ij,ij->i", d, normal) < 0
        k = np.einsum("ij,ij->i", d, raw_normal)
        by_raw = ray_dir - 2.0 * np.einsum("ij,ij->i", ray_dir, raw_normal)[:, None] * raw_normal
        twice = d - 2.0 * k[:, None] * raw_normal
        d = np.where((into & behind)[:, None], by_raw, np.where(into[:, None], twice, d))
    return d / np.linalg.norm(d, axis=1, keepdims=True)


def refract(ray_dir: np.ndarray, normal: np.ndarray, ior: np.ndarray):
    """Heckbert's refraction: (directions, total_internal_reflection mask). `normal` faces
    the incoming ray; `ior` is n_from / n_to."""
    n_cos = -np.einsum("ij,ij->i", ray_dir, normal)
    t = 1.0 + ior**2 * (n_cos**2 - 1.0)
    tir = t < 0
    t2 = ior * n_cos - np.sqrt(np.clip(t, 0, None))
    d = ior[:, None] * ray_dir + t2[:, None] * normal
    d /= np.maximum(np.linalg.norm(d, axis=1, keepdims=True), 1e-300)
    return d, tir


def opacity(colour: np.ndarray, legacy: bool) -> np.ndarray:
    """How much of a layer's own colour shows (POV-Ray: 1 - filter - transmit; the older
    1 - (filter * max(rgb) + transmit) for scenes before 3.7)."""
    if legacy:
        return 1.0 - (colour[:, 3] * colour[:, :3].max(axis=1) + colour[:, 4])
    return 1.0 - colour[:, 3] - colour[:, 4]


def rgb_transmit(colour: np.ndarray) -> np.ndarray:
    """(N,3) light let through: filter * rgb + transmit."""
    return colour[:, 3, None] * colour[:, :3] + colour[:, 4, None]


def grain(points: np.ndarray) -> np.ndarray:
    """(N,) deterministic pseudo-random numbers in [0, 1) per surface point (for `crand`):
    the same point always gets the same value, whatever the tiling or thread."""
    h = np.sin(points @ np.array([12.9898, 78.233, 37.719])) * 43758.5453
    return h - np.floor(h)
