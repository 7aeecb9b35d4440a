"""POV-Ray 3.7's fractal patterns, vectorised over pattern-space points: mandel and julia
(z -> z^exponent + c) with their exterior and interior colourings. The pattern reads the
point's x and y as the complex plane. `params` keys: "iterations" (30), "exponent" (2),
"complex" (julia's constant), "exterior" and "interior" (a type and its factor)."""

from __future__ import annotations

import numpy as np


def _fractal_value(params: dict, c: np.ndarray, z: np.ndarray) -> np.ndarray:
    """POV-Ray's mandel and julia patterns: z -> z^exponent + c, up to `iterations` steps,
    a point escaping when |z|² > 4 after step `col` (from 0) coloured by its `exterior`
    type (default 1: col / iterations), one that never does by its `interior` type
    (default 0: the factor, 1), as fractal_exterior_color and fractal_interior_color."""
    it_max = int(params.get("iterations", 30))
    power = int(params.get("exponent", 2) or 2)
    ext_type, efactor = _fractal_colouring(params.get("exterior"), 1)
    int_type, ifactor = _fractal_colouring(params.get("interior"), 0)
    n = len(c)
    out = np.zeros(n)
    alive = np.ones(n, dtype=bool)
    mind2 = np.abs(z) ** 2
    for col in range(it_max):
        z = np.where(alive, z**power + c, z)
        d2 = z.real * z.real + z.imag * z.imag
        mind2 = np.where(alive, np.minimum(mind2, d2), mind2)
        escaped = alive & (d2 > 4.0)
        if escaped.any():
            out[escaped] = _exterior(ext_type, efactor, col, it_max, z[escaped])
            alive &= ~escaped
        if not alive.any():
            return out
    out[alive] = _interior(int_type, ifactor, z[alive], mind2[alive])
    return out


def _fractal_colouring(given, default_type: int) -> tuple[int, float]:
    if given is None:
        return default_type, 1.0
    if isinstance(given, tuple):
        return int(given[0]), float(given[1]) if len(given) > 1 else 1.0
    return int(given), 1.0


def _exterior(kind: int, f: float, col: int, it_max: int, z: np.ndarray) -> np.ndarray:
    if kind == 1:
        return np.full(len(z), col / it_max)
    if kind == 6:
        return np.sqrt(z.real * z.real + z.imag * z.imag) * f
    if kind == 7 and int(f) > 0:
        return np.full(len(z), (col % int(f)) / f)
    if kind == 8 and f != 0:
        return np.full(len(z), (col % int(1 + f)) / f)
    return _coloured(kind, f, z)


def _interior(kind: int, f: float, z: np.ndarray, mind2: np.ndarray) -> np.ndarray:
    if kind == 1:
        return np.sqrt(mind2) * f
    if kind == 6:
        return z.real * z.real + z.imag * z.imag * f  # POV-Ray's precedence, kept
    return _coloured(kind, f, z)


def _coloured(kind: int, f: float, z: np.ndarray) -> np.ndarray:
    """The colourings exterior and interior share: 0 the factor, 2-5 the last z's real or
    imaginary part (squared for 4 and 5) times it; another type gives 0."""
    a, b = z.real, z.imag
    if kind == 0:
        return np.full(len(z), f)
    if kind in (2, 3):
        return (a if kind == 2 else b) * f
    if kind in (4, 5):
        v = a if kind == 4 else b
        return v * v * f
    return np.zeros(len(z))


def mandel(p: np.ndarray, params: dict) -> np.ndarray:
    c = p[:, 0] + 1j * p[:, 1]
    return _fractal_value(params, c, c.copy())


def julia(p: np.ndarray, params: dict) -> np.ndarray:
    k = params.get("complex", (0.353, 0.288))
    c = np.full(len(p), complex(float(k[0]), float(k[1])))
    return _fractal_value(params, c, p[:, 0] + 1j * p[:, 1])
