"""POV-Ray's render-time built-in functions (`internal(N)`; the f_… names of functions.inc),
vectorised: each takes x, y, z arrays and its parameters P0, P1, … (arrays or floats) and
returns an array. The surfaces follow POV-Ray 3.7's definitions: most algebraic surfaces
are `clamp(P0 * r, -10, 10)` of a polynomial r whose sign makes the inside negative
(P0 is the "field strength"); the `_2d` variants are plane curves turned into surfaces by
POV-Ray's "sor" switch (P_sor > 0: revolve the curve around y at offset P_off, tilted by
P_angle degrees), otherwise extruded along z.

Noise: f_noise3d and the fractal noises use strala's POV-Ray-like noise
(runtime.noise.noise, values in 0..1) with the generator POV-Ray's would use: the
scene's for f_noise3d, the noise_generator parameter for the others.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any

import numpy as np

from runtime import notices
from runtime.noise import noise

Arr = Any  # an ndarray or a float (parameters are usually plain numbers)


def warn_missing(name: str) -> None:
    notices.warn_once(f"the internal function {name} is not available: it gives 0")


def _clamp(v: Arr, lim: Arr = 10.0) -> Arr:
    return np.minimum(lim, np.maximum(v, -lim))


def _scalar(p: Arr) -> float:
    """A parameter that selects a variant (cross-section type, octaves): its first value."""
    return float(np.ravel(np.asarray(p, dtype=np.float64))[0])


def _rot2d(x: Arr, y: Arr, z: Arr, sor: Arr, off: Arr, angle: Arr) -> tuple[Arr, Arr]:
    """The plane coordinates of a `_2d` curve: (x, y), or with the sor switch on, the
    distance from the y axis less the offset, turned by `angle` degrees with y."""
    if _scalar(sor) <= 0:
        return x, y
    r = np.sqrt(x * x + z * z) - off
    th = math.radians(_scalar(angle))
    if th == 0:
        return r, y
    return r * math.cos(th) - y * math.sin(th), r * math.sin(th) + y * math.cos(th)


def _noise(p0: Arr, p1: Arr, p2: Arr, generator: int = 2) -> np.ndarray:
    shape = np.broadcast(p0, p1, p2).shape
    pts = np.stack([np.broadcast_to(v, shape).ravel() for v in (p0, p1, p2)], axis=1)
    return noise(pts.astype(np.float64), generator).reshape(shape)


def _generator(param: Arr) -> int:
    """A noise_generator parameter as POV-Ray reads it (`(int)P & 3`; 0 is the original
    noise, as 1)."""
    return int(_scalar(param)) & 3 or 1


def _section(a: Arr, b: Arr, kind: float) -> Arr:
    """The cross-section distance used by the helix and spiral functions: 1 a circle,
    0 a square, otherwise the superellipse of exponent 2/kind."""
    if kind == 1:
        return np.sqrt(a * a + b * b)
    if kind == 0:
        return np.maximum(np.abs(a), np.abs(b))
    e = 2.0 / kind
    return (np.abs(a) ** e + np.abs(b) ** e) ** (kind * 0.5)


# ---------------------------------------------------------------- plain shapes
def f_sphere(x, y, z, r):
    return np.sqrt(x * x + y * y + z * z) - r


def f_r(x, y, z):
    return np.sqrt(x * x + y * y + z * z)


def f_th(x, y, z):
    return np.arctan2(x, z)


def f_ph(x, y, z):
    return np.arctan2(np.sqrt(x * x + z * z), y)


def f_ellipsoid(x, y, z, a, b, c):
    return np.sqrt((x * a) ** 2 + (y * b) ** 2 + (z * c) ** 2)


def f_torus(x, y, z, major, minor):
    q = np.sqrt(x * x + z * z) - major
    return np.sqrt(q * q + y * y) - minor


def f_rounded_box(x, y, z, radius, sx, sy, sz):
    # Distance outside the inner box (half sizes less the radius), less the radius.
    dx = np.maximum(np.abs(x) - (sx - radius), 0.0)
    dy = np.maximum(np.abs(y) - (sy - radius), 0.0)
    dz = np.maximum(np.abs(z) - (sz - radius), 0.0)
    return np.sqrt(dx * dx + dy * dy + dz * dz) - radius - 1e-6


def f_superellipsoid(x, y, z, e, n):
    xy = (np.abs(x) ** (2.0 / e) + np.abs(y) ** (2.0 / e)) ** (e / n)
    return 1.0 - (xy + np.abs(z) ** (2.0 / n)) ** (n * 0.5)


def f_paraboloid(x, y, z, s):
    return _clamp(s * -(x * x - y + z * z))


def f_pillow(x, y, z, s):
    x2, y2, z2 = x * x, y * y, z * z
    return _clamp(s * (x2 * x2 + y2 * y2 + z2 * z2 - (x2 + y2 + z2)))


def f_heart(x, y, z, s):
    x2, y2, z2 = x * x, y * y, z * z
    a = 2 * x2 + y2 + z2 - 1
    return _clamp(s * -(a * a * a - 0.1 * x2 * z2 * z - y2 * z2 * z))


def f_torus2(x, y, z, s, major, minor):
    x2, y2, z2 = x * x, y * y, z * z
    a, b = major * major, minor * minor
    r = (x2 + y2 + z2) ** 2 - 2 * (a + b) * (x2 + z2) + 2 * (a - b) * y2 + (a - b) ** 2
    return _clamp(s * -r)


def f_torus_gumdrop(x, y, z, s):
    x2, y2, z2 = x * x, y * y, z * z
    r = 4 * (x2 * x2 + (y2 + z2) ** 2) + 17 * x2 * (y2 + z2) - 20 * (x2 + y2 + z2) + 17
    return _clamp(s * -r)


def f_comma(x, y, z, size):
    x = np.where((x == 0) & (z == 0), 0.0001, x)
    th = np.arctan2(z, x)
    r = np.sqrt((x + size * 0.25) ** 2 + z * z)
    tube = np.cos(th * 0.5) * size * 0.5 - np.sqrt((r - size * 0.75) ** 2 + y * y)
    tube = np.minimum(z, tube)
    ball = size * 0.5 - np.sqrt((x - size * 0.5) ** 2 + z * z + y * y)
    return -np.maximum(tube, ball)


# ------------------------------------------------------------ Gaussian fields
def _g(q, k):
    return np.exp(-q * k)


def _three(x, y, z, a):
    x2, y2, z2 = x * x, y * y, z * z
    return (x2 * a + y2 * a + z2, x2 * a + y2 + z2 * a, x2 + y2 * a + z2 * a)


def f_flange_cover(x, y, z, a, k, s, t):
    q = _three(x, y, z, a)
    return t - (_g(q[0], k) + _g(q[1], k) + _g(q[2], k)) * s


def f_cross_ellipsoids(x, y, z, a, k, s, t):
    q = _three(x, y, z, a)
    return t - np.maximum(np.maximum(_g(q[0], k), _g(q[1], k)), _g(q[2], k)) * s


def f_isect_ellipsoids(x, y, z, a, k, s, t):
    q = _three(x, y, z, a)
    return t - np.minimum(np.minimum(_g(q[0], k), _g(q[1], k)), _g(q[2], k)) * s


def f_spikes(x, y, z, a, k, size, roundness, fat):
    q = _three(x, y, z, a)
    r = _g(x * x + y * y + z * z, roundness) * fat - _g(q[0], k) - _g(q[1], k) - _g(q[2], k)
    return -r * size


def f_blob(x, y, z, dist, s1, r1, s2, r2):
    yz = y * y + z * z
    a = np.minimum(((x + dist * 0.5) ** 2 + yz) * r1 * r1, 1.0)
    b = np.minimum(((x - dist * 0.5) ** 2 + yz) * r2 * r2, 1.0)
    return -(s1 * (1 - a) ** 2 + s2 * (1 - b) ** 2)


def f_blob2(x, y, z, dist, k, s, t):
    yz = y * y + z * z
    return t - (np.exp(-(x * x + yz) * k) + np.exp(-((x - dist) ** 2 + yz) * k)) * s


def f_spikes_2d(x, y, z, h, fx, fz, rate):
    return -(h * np.cos(fx * x) * np.cos(fz * z) * np.exp(-rate * (x * x + z * z)) - y)


# -------------------------------------------------------------- algebraic
def _alg(poly: Callable[..., Arr]) -> Callable[..., Arr]:
    """x, y, z, strength, … -> clamp(strength * poly(x, y, z, …), ±10)."""

    def f(x, y, z, s, *p):
        return _clamp(s * poly(x, y, z, *p))

    f.__name__ = poly.__name__
    return f


def _alg2d(poly: Callable[..., Arr], n: int, lim_param: bool = False) -> Callable[..., Arr]:
    """A `_2d` curve: parameters (strength, p1 … p_n, sor, offset, angle)."""

    def f(x, y, z, s, *p):
        u, v = _rot2d(x, y, z, *p[n : n + 3])
        r = poly(u, v, *p[:n])
        if lim_param:  # the algbr_cyl functions clamp at their own limit P1
            return _clamp(s * r, p[0])
        return _clamp(s * r)

    return f


def _bicorn(x, y, z, a):
    xz = x * x + z * z
    b = xz + 2 * a * y - a * a
    return y * y * (a * a - xz) - b * b


def _bifolia(x, y, z, a):
    r = x * x + y * y + z * z
    return -(r * r - a * (x * x + z * z) * y)


def _boy(x, y, z, a):
    x2, y2, z2 = x * x, y * y, z * z
    w, ph, s2 = 1 - z, x2 + y2, math.sqrt(2.0)
    return a * (
        64 * w**3 * z2 * z
        - 48 * w * w * z2 * (3 * x2 + 3 * y2 + 2 * z2)
        + 12 * w * z * (27 * ph * ph - 24 * z2 * ph + 36 * s2 * y * z * (y2 - 3 * x2) + 4 * z2 * z2)
        + (9 * x2 + 9 * y2 - 2 * z2)
        * (-81 * ph * ph - 72 * z2 * ph + 108 * s2 * x * z * (x2 - 3 * y2) + 4 * z2 * z2)
    )


def _cushion(x, y, z):
    x2, y2, z2 = x * x, y * y, z * z
    return (
        z2 * x2 - z2 * z2 - 2 * z * x2 + 2 * z2 * z + x2 - z2 - (x2 - z) ** 2
        - y2 * y2 - 2 * x2 * y2 - y2 * z2 + 2 * y2 * z + y2
    )  # fmt: skip


def _dupin(x, y, z, a, b, c, d, e):
    x2, y2, z2 = x * x, y * y, z * z
    r2, ph, th = e * e, b * b, d * d
    p1 = ph - th - (c + a) ** 2
    p2 = ph - th - (c - a) ** 2
    p3, p4 = c * c, a * a
    q = x2 + y2 + z2
    return -(
        p1 * p2 * (x2 * x2 + y2 * y2 + z2 * z2)
        + 2 * p1 * p2 * (x2 * y2 + x2 * z2 + y2 * z2)
        + 2 * r2 * ((-th - p3 + ph + p4) * (2 * x * c + 2 * y * d - r2) - 4 * d * ph * y) * q
        + 4 * r2 * r2 * (c * x + d * y) * (-r2 + d * y + c * x)
        + 4 * r2 * r2 * p4 * y2
        + r2**4
    )


def _enneper(x, y, z):
    z = np.where(np.abs(z) < 0.2, 0.2, z)
    x2, y2, z2 = x * x, y * y, z * z
    # POV-Ray's integer divisions (2/3, 1/4, 8/9, 2/9 are 0 in its C source) kept as rendered.
    r = (y2 - x2) / (2 * z) + 2 * z2 / 9
    r2 = (y2 - x2) / (4 * z)
    return -(r * r * r - 6 * r2 * r2)


def _folium(x, y, z, a, b):
    return (y * y + z * z) * (1 + (b - 4 * a) * x) + x * x * (1 + b)


def _hunt(x, y, z):
    x2, y2, z2 = x * x, y * y, z * z
    q = x2 + y2 + z2 - 13
    return -(4 * q**3 + 27 * (3 * x2 + y2 - 4 * z2 - 12) ** 2)


def _hyperbolic_torus(x, y, z, a, b):
    x2, y2, z2 = x * x, y * y, z * z
    ph, th = a * a, b * b
    return -(
        x2 * x2 + 2 * x2 * y2 - 2 * x2 * z2 - 2 * (ph + th) * x2 + y2 * y2
        - 2 * y2 * z2 + 2 * (ph - th) * y2 + z2 * z2 + 2 * (ph + th) * z2 + (ph - th) ** 2
    )  # fmt: skip


def _klein(x, y, z):
    q = x * x + y * y + z * z
    a = q - 2 * y - 1
    return -((q + 2 * y - 1) * (a * a - 8 * z * z) + 16 * x * z * a)


def _kummer2(x, y, z, a, b, c):
    x2, y2, z2 = x * x, y * y, z * z
    return -(
        x2 * x2 + y2 * y2 + z2 * z2 + a * (x2 + y2 + z2) + b * (x2 * y2 + x2 * z2 + y2 * z2)
        + c * x * y * z - 1
    )  # fmt: skip


def _parabolic_torus(x, y, z, a, b):
    x2, y2, z2 = x * x, y * y, z * z
    ph, th = a * a, b * b
    return -(
        x2 * x2 + 2 * x2 * y2 - 2 * x2 * z - (ph + th) * x2 + y2 * y2 - 2 * y2 * z
        + (ph - th) * y2 + z2 + (ph + th) * z + (ph - th) ** 2
    )  # fmt: skip


def _odd(x, y, z):
    return _cushion(x, y, z)


_ALGEBRAIC: dict[str, Callable[..., Arr]] = {
    "f_bicorn": _bicorn,
    "f_bifolia": _bifolia,
    "f_boy_surface": _boy,
    "f_crossed_trough": lambda x, y, z: x * x * z * z - y,
    "f_cubic_saddle": lambda x, y, z: -(x**3 - y**3 - z),
    "f_cushion": _cushion,
    "f_devils_curve": lambda x, y, z: (
        -(x**4 + 2 * x * x * z * z - 0.36 * x * x - y**4 + 0.25 * y * y + z**4)
    ),
    "f_dupin_cyclid": _dupin,
    "f_enneper": _enneper,
    "f_folium_surface": _folium,
    "f_glob": lambda x, y, z: 0.5 * x**5 + 0.5 * x**4 - (y * y + z * z),
    "f_hunt_surface": _hunt,
    "f_hyperbolic_torus": _hyperbolic_torus,
    "f_kampyle_of_eudoxus": lambda x, y, z, a, b: (
        -((y * y + z * z) - b * b * x**4 + b * b * a * a * x * x)
    ),
    "f_klein_bottle": _klein,
    "f_kummer_surface_v1": lambda x, y, z: (
        -(
            x**4
            + y**4
            + z**4
            - x * x
            - y * y
            - z * z
            - x * x * y * y
            - x * x * z * z
            - y * y * z * z
            + 1
        )
    ),  # fmt: skip
    "f_kummer_surface_v2": _kummer2,
    "f_lemniscate_of_gerono": lambda x, y, z: -(x**4 - x * x + y * y + z * z),
    "f_mitre": lambda x, y, z: -(4 * x * x * (x * x + y * y + z * z) - y * y * (1 - y * y - z * z)),
    "f_nodal_cubic": lambda x, y, z: -(y**3 + z**3 - 6 * y * z),
    "f_odd": _odd,
    "f_ovals_of_cassini": lambda x, y, z, a, b, c: (
        -((x * x + y * y + z * z + a * a) ** 2 - c * a * a * (x * x + z * z) - b * b)
    ),
    "f_parabolic_torus": _parabolic_torus,
    "f_quartic_paraboloid": lambda x, y, z: -(x**4 + z**4 - y),
    "f_quartic_saddle": lambda x, y, z: -(x**4 - z**4 - y),
    "f_quartic_cylinder": lambda x, y, z, a, b: (
        -((x * x + z * z) * y * y + b * b * (x * x + z * z) - b * b * a * a)
    ),
    "f_steiners_roman": lambda x, y, z: (
        -(x * x * y * y + x * x * z * z + y * y * z * z + x * y * z)
    ),
    "f_strophoid": lambda x, y, z, a, b, c: (
        -((b - x) * (y * y + z * z) - c * c * a * x * x - c * c * x**3)
    ),
    "f_umbrella": lambda x, y, z: -(x * x - y * z * z),
    "f_witch_of_agnesi": lambda x, y, z, a: -(a * (y - 1) + (x * x + z * z) * y),
}

_CURVES_2D: dict[str, tuple[Callable[..., Arr], int]] = {
    "f_devils_curve_2d": (
        lambda u, v, a, b: -(u * u * (u * u - a * a) - v * v * (v * v - b * b)),
        2,
    ),
    "f_folium_surface_2d": (
        lambda u, v, a, b: -(v * v * (1 + (b - 4 * a) * u) + u * u * (1 + b)),
        2,
    ),
    "f_kampyle_of_eudoxus_2d": (
        lambda u, v, a, b: -(v * v - b * b * u**4 + b * b * a * b * u * u),
        2,
    ),
    "f_lemniscate_of_gerono_2d": (
        lambda u, v, a, b: -(v * v - b * b * a * a * u * u + b * b * u**4),
        2,
    ),
    "f_piriform_2d": (lambda u, v, a, b, c: -(v * v - a * c * c * u**3 - b * c * c * u**4), 3),
    "f_strophoid_2d": (
        lambda u, v, a, b, c: -((b - u) * v * v - c * c * a * u * u - c * c * u**3),
        3,
    ),
    "f_witch_of_agnesi_2d": (lambda u, v, a, b: -(a * a * v + u * u * v - b), 2),
}


def f_piriform(x, y, z, s):
    return -_clamp(s * -((x**4 - x**3) + y * y + z * z))


def _algbr_cyl(poly: Callable[..., Arr], flip: bool = False) -> Callable[..., Arr]:
    """Parameters (strength, limit, sor, offset, angle): clamp(strength * r, ±limit)."""

    def f(x, y, z, s, lim, sor, off, angle):
        u, v = _rot2d(x, y, z, sor, off, angle)
        if flip:
            u = np.abs(u)
        r = _clamp(s * poly(u, v), lim)
        return -r if flip else r

    return f


# ------------------------------------------------------------- helices, meshes
def f_helix1(x, y, z, n, period, minor, major, shape, section, angle):
    r = np.sqrt(x * x + z * z)
    x = np.where((x == 0) & (z == 0), 1e-6, x)
    th = np.fmod(np.arctan2(z, x) * n + y * period * n, 2 * math.pi)
    th = np.where(th < 0, th + 2 * math.pi, th)
    w = (th - math.pi) / shape / (period * n)
    u = r - major
    kind = _scalar(section)
    if kind != 1 and _scalar(angle) != 0:
        c, s = math.cos(math.radians(_scalar(angle))), math.sin(math.radians(_scalar(angle)))
        u, w = u * c - w * s, u * s + w * c
    return -minor + np.minimum(major + r, _section(u, w, kind))


def f_helix2(x, y, z, n, period, minor, major, shape, section, angle):
    th = y * period
    c, s = np.cos(th), np.sin(th)
    dx, dz = x - major * c, z - major * s
    u, w = dx * c + dz * s, -dx * s + dz * c
    return _section(u, w, _scalar(section)) - minor


def f_helical_torus(x, y, z, major, nwind, twist, fatten, p4, minor, p6, p7, p8, p9):
    r2 = np.sqrt(x * x + z * z)
    x = np.where((x == 0) & (z == 0), 1e-6, x)
    ph = np.arctan2(x, z)
    temp = np.arctan2(r2 - major, y)
    r = np.sqrt((r2 - major) ** 2 + y * y)
    th = np.fmod(ph * nwind + temp * twist, 2 * math.pi)
    th = np.where(th < 0, th + 2 * math.pi, th)
    temp = np.arctan2((th - math.pi) * p8, r - minor)
    temp = np.cos(temp * p7 + ph * p9) * fatten + p4
    outer = p4 + minor - major - r2
    th = th - math.pi
    temp = temp - np.minimum(np.sqrt((r - minor) ** 2 + th * th * p6), r + minor)
    return -np.maximum(outer, temp)


def f_spiral(x, y, z, gap, thick, outer, _p3, _p4, section):
    r = np.sqrt(x * x + z * z)
    x = np.where((x == 0) & (z == 0), 1e-6, x)
    r = r + gap * np.arctan2(z, x) / (2 * math.pi)
    w = np.fmod(r, gap) - gap * 0.5
    q = _section(w, y, _scalar(section))
    rr = np.sqrt(x * x + y * y + z * z)
    return -np.minimum(outer - rr, thick - np.minimum(q, rr))


def f_mesh1(x, y, z, dx, dz, k, amp, ky):
    def strand(a, period, wave):
        r = np.fmod(a, period * 2)
        r = np.where(r < 0, r + period * 2, r)
        r = np.abs(r - period) * k
        w = wave * ky
        return -np.sqrt(w * w + r * r)

    th, ph = math.pi / dx, math.pi / dz
    t = strand(x, dx, y - np.cos(z * ph) * amp)
    t = np.maximum(strand(x - dx, dx, y + np.cos(z * ph) * amp), t)
    t = np.maximum(strand(z, dz, y + np.cos(x * th) * amp), t)
    return -np.maximum(strand(z - dz, dz, y - np.cos(x * th) * amp), t)


def _hex(a, b, first: bool):
    s3 = math.sqrt(3.0)
    x1 = np.abs(np.fmod(np.abs(a), s3) - s3 / 2)
    y1 = np.abs(np.fmod(np.abs(b), 3.0) - 1.5)
    x2, y2 = s3 / 2 - x1, 1.5 - y1
    swap = x1 * x1 + y1 * y1 > x2 * x2 + y2 * y2
    x1, y1 = np.where(swap, x2, x1), np.where(swap, y2, y1)
    th = np.arctan2(y1, x1)
    if first:
        return np.where(
            th < math.pi / 6, x1, math.cos(math.pi / 3) * x1 + math.sin(math.pi / 3) * y1
        )
    return np.where(
        th < math.pi / 6, y1, np.abs(-math.sin(math.pi / 3) * x1 + math.cos(math.pi / 3) * y1)
    )


def f_hex_x(x, y, z, _p0):
    return _hex(x, y, True)


def f_hex_y(x, y, z, _p0):
    return _hex(x, y, False)


def f_poly4(x, y, z, a, b, c, d, e):
    t = np.maximum(a + b * y + c * y * y + d * y**3 + e * y**4, -5.0)
    return -t + np.sqrt(x * x + z * z)


def f_polytubes(x, y, z, n, a, b, c, d, e):
    r2 = a + b * y + c * y * y + d * y**3 + e * y**4
    k = int(_scalar(n))
    best: Arr = -10000.0
    for i in range(k):
        ang = 2 * math.pi / _scalar(n) * i
        best = np.maximum(
            best, -np.sqrt((x - r2 * math.sin(ang)) ** 2 + (z - r2 * math.cos(ang)) ** 2)
        )
    return -best


def f_quantum(x, y, z, _p0):
    x = np.where((x == 0) & (z == 0), 1e-6, x)
    r = np.sqrt(x * x + z * z)
    th = np.cos(np.arctan2(r, y))
    r = np.sqrt(r * r + y * y) * 2.0
    t = r * r * np.exp(-r / 3.0) * (3 * th * th - 1)
    return (t * t - 12.0) * -0.1


# ------------------------------------------------------------------- noise
def f_noise3d(x, y, z, *, generator: int = 2):
    """The scene's noise generator (global_settings), which the compiler passes."""
    return _noise(x, y, z, generator)


def f_noise_generator(x, y, z, gen):
    return _noise(x, y, z, _generator(gen))


# f_noise3d reads the scene's generator (the others take theirs as a parameter)
SCENE_NOISE = frozenset({"f_noise3d"})


def f_ridged_mf(x, y, z, h, lacunarity, octaves, offset, gain, gen):
    g = _generator(gen)
    lac, n = _scalar(lacunarity), _scalar(octaves)
    weights = [lac ** (-_scalar(h) * i) for i in range(int(n) + 1)]
    signal = (offset - np.abs(_noise(x, y, z, g) * 2 - 1)) ** 2
    result = signal
    scale = 1.0
    i = 1
    while i < n:
        scale *= lac
        weight = np.clip(signal * gain, 0.0, 1.0)
        signal = (offset - np.abs(_noise(x * scale, y * scale, z * scale, g) * 2 - 1)) ** 2 * weight
        result = result + signal * weights[i]
        i += 1
    return result


def f_ridge(x, y, z, lam, octaves, omega, off, ridge, gen):
    g = _generator(gen)
    lam_, om_, oct_ = _scalar(lam), _scalar(omega), _scalar(octaves)
    rscale = 1.0 / max(ridge, 1.0 - ridge)
    scale = 1.0 / max(off, 1.0 - off)
    n = int(oct_)
    value = np.abs(_noise(x, y, z, g) - ridge) * rscale - off
    tot, lv, o = 1.0, lam_, om_
    for _ in range(2, n + 1):
        value = value + o * (np.abs(_noise(x * lv, y * lv, z * lv, g) - ridge) * rscale - off)
        tot += o
        lv *= lam_
        o *= om_
    resid = oct_ - n
    if resid:
        value = (
            value + o * (np.abs(_noise(x * lv, y * lv, z * lv, g) - ridge) * rscale - off) * resid
        )
        tot += o * resid
    return value * scale / tot


def f_hetero_mf(x, y, z, h, lacunarity, octaves, offset, t, gen):
    g = _generator(gen)
    lac, oct_ = _scalar(lacunarity), _scalar(octaves)
    signal = (_noise(x, y, z, g) * 2 - 1) + offset
    step = lac ** -_scalar(h)
    ea, scale = step, lac
    i = 1
    while i < oct_:
        inc = ((_noise(x * scale, y * scale, z * scale, g) * 2 - 1) + offset) * ea
        for _ in range(int(_scalar(t))):
            inc = inc * signal
        signal = signal + inc
        scale *= lac
        ea *= step
        i += 1
    rem = oct_ - int(oct_)
    if rem:
        inc = ((_noise(x * scale, y * scale, z * scale, g) * 2 - 1) + offset) * ea
        signal = signal + rem * inc * signal
    return signal


IMPLEMENTATIONS: dict[str, Callable[..., Arr]] = {
    name: fn for name, fn in globals().items() if name.startswith("f_") and callable(fn)
}
IMPLEMENTATIONS.update({name: _alg(poly) for name, poly in _ALGEBRAIC.items()})
IMPLEMENTATIONS.update({name: _alg2d(poly, n) for name, (poly, n) in _CURVES_2D.items()})
IMPLEMENTATIONS.update(
    {
        "f_algbr_cyl1": _algbr_cyl(lambda u, v: -(u * u * u - u * u + v * v), flip=True),
        "f_algbr_cyl2": _algbr_cyl(
            lambda u, v: -(2 * u**4 - 3 * u * u * v + v * v - 2 * v**3 + v**4)
        ),
        "f_algbr_cyl3": _algbr_cyl(
            lambda u, v: -(u**4 + u * u * v * v - 2 * u * u * v - u * v * v + v * v)
        ),
        "f_algbr_cyl4": _algbr_cyl(
            lambda u, v: -(u**4 + v**4 + 2 * u * u * v * v + 3 * u * u * v - v**3)
        ),
    }
)
