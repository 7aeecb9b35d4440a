"""POV-Ray 3.7's fractal patterns, vectorised over pattern-space points: mandel and julia
(z -> z^exponent + c) and the magnet fractals (types 1 and 2, each in a mandel and a julia
form), with their exterior and interior colourings. The pattern reads the point's x and y
as the complex plane. `params` keys: "iterations" (30), "exponent" (2; mandel and julia),
"complex" (julia's constant, and the magnet's julia form's), "exterior" and "interior" (a
type and its factor), "magnet" (1 or 2) and "magnet_form" ("mandel" or "julia")."""

from __future__ import annotations

import math

import numpy as np

from lang import ir


def _fractal_value(params: dict, c: tuple, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """POV-Ray's mandel and julia patterns: z -> z^exponent + c, up to `iterations` steps,
    a point escaping when |z|² > 4 after step `col` (from 0) coloured by its `exterior`
    type (default 1: col / iterations), one that never does by its `interior` type
    (default 0: the factor, 1), as fractal_exterior_color and fractal_interior_color. The
    powers are POV-Ray's real arithmetic in its order (exponents 2 to 4 written out, the
    higher ones by binomial sums): the kernel's too, and no numpy complex product (which
    fuses multiply-adds on some CPUs), so the image does not depend on the CPU."""
    it_max = iterations(params)
    power = exponent(params)
    (ext_type, efactor), (int_type, ifactor) = colourings(params)
    cr, ci = c
    n = len(a)
    out = np.zeros(n)
    rows = np.arange(n)
    a2, b2 = a * a, b * b
    mind2 = a2 + b2
    for col in range(it_max):
        a, b = _power(power, a, b, a2, b2)
        a, b = a + cr, b + ci
        a2, b2 = a * a, b * b
        d2 = a2 + b2
        mind2 = np.where(d2 < mind2, d2, mind2)
        escaped = d2 > 4.0
        if escaped.any():
            out[rows[escaped]] = _exterior(ext_type, efactor, col, it_max, a[escaped], b[escaped])
            keep = ~escaped
            live = (rows, a, b, a2, b2, mind2, cr, ci)
            rows, a, b, a2, b2, mind2, cr, ci = (
                v[keep] if isinstance(v, np.ndarray) else v for v in live
            )
            if not len(rows):
                return out
    out[rows] = _interior(int_type, ifactor, a, b, mind2)
    return out


# POV-Ray's defaults: the iterations, julia's constant (the magnet's julia form: 0)
ITERATIONS = 30
JULIA_CONSTANT = (0.353, 0.288)


def iterations(params: dict) -> int:
    return int(params.get("iterations", ITERATIONS))


def constant(params: dict, magnet: bool) -> tuple[float, float]:
    """The julia form's constant c."""
    k = params.get("complex", (0.0, 0.0) if magnet else JULIA_CONSTANT)
    return float(k[0]), float(k[1])


def colourings(params: dict) -> tuple[tuple[int, float], tuple[int, float]]:
    """The exterior and interior colourings (type, factor), POV-Ray's defaults 1 and 0."""
    return _colouring(params.get("exterior"), 1), _colouring(params.get("interior"), 0)


def exponent(params: dict) -> int:
    """A mandel or julia exponent: 2 to MAX_EXPONENT (the evaluator warns of others)."""
    n = int(params.get("exponent", 2) or 2)
    return n if 2 <= n <= ir.FRACTAL_MAX_EXPONENT else 2


def _power(n: int, a, b, a2, b2):
    """(a + bi)^n, as POV-Ray's Mandel2/3/4 and MandelX patterns compute it."""
    if n == 2:
        return a2 - b2, 2.0 * a * b
    if n == 3:
        return a2 * a - 3.0 * a * b2, 3.0 * a2 * b - b2 * b
    if n == 4:
        return a2 * a2 - 6.0 * a2 * b2 + b2 * b2, 4.0 * (a2 * a * b - a * b2 * b)
    with np.errstate(all="ignore"):
        re = np.power(a, float(n))
        im = np.zeros_like(a)
        for k in range(1, n + 1):
            # C(n, k) i^k: the real part takes the even k, the imaginary the odd
            term = _signed_binomial(n, k) * np.power(a, float(n - k)) * np.power(b, float(k))
            if k % 2:
                im = im + term
            else:
                re = re + term
    return re, im


def _signed_binomial(n: int, k: int) -> float:
    return float(math.comb(n, k) * (-1 if k & 2 else 1))


def _colouring(given, default_type: int) -> tuple[int, float]:
    """An exterior or interior colouring as (type, factor): a type alone has factor 1."""
    if given is None:
        return default_type, 1.0
    if isinstance(given, tuple):
        return int(given[0]), float(given[1]) if len(given) > 1 else 1.0
    return int(given), 1.0


def _exterior(kind: int, f: float, col: int, it_max: int, a, b) -> np.ndarray:
    if kind == 1:
        return np.full(len(a), col / it_max)
    if kind == 6:
        return np.sqrt(a * a + b * b) * f
    if kind == 7 and int(f) > 0:
        return np.full(len(a), (col % int(f)) / f)
    if kind == 8 and f != 0 and int(1 + f) != 0:
        return np.full(len(a), (col % int(1 + f)) / f)
    return _coloured(kind, f, a, b)


def _interior(kind: int, f: float, a, b, mind2: np.ndarray) -> np.ndarray:
    if kind == 1:
        return np.sqrt(mind2) * f
    if kind == 6:
        return a * a + b * b * f  # POV-Ray's precedence, kept
    return _coloured(kind, f, a, b)


def _coloured(kind: int, f: float, a, b) -> np.ndarray:
    """The colourings exterior and interior share: 0 the factor, 2-5 the last z's real or
    imaginary part (squared for 4 and 5) times it; another type gives 0."""
    if kind == 0:
        return np.full(len(a), f)
    if kind in (2, 3):
        return (a if kind == 2 else b) * f
    if kind in (4, 5):
        v = a if kind == 4 else b
        return v * v * f
    return np.zeros(len(a))


def mandel(p: np.ndarray, params: dict) -> np.ndarray:
    # the loop makes new arrays of a and b, so the point's columns are read, not written
    a, b = p[:, 0], p[:, 1]
    return _fractal_value(params, (a, b), a, b)


def julia(p: np.ndarray, params: dict) -> np.ndarray:
    return _fractal_value(params, constant(params, False), p[:, 0], p[:, 1])


# A magnet point escapes when |z|² passes this, or is caught when z comes this close
# (squared) to the fixed point 1.
MAGNET_ESCAPE: float = 10000.0
MAGNET_CATCH: float = 1.0 / 10000.0


def magnet(p: np.ndarray, params: dict) -> np.ndarray:
    """POV-Ray's magnet fractals: z -> q², with q = (z² + c - 1) / (2z + c - 2) (type 1)
    or (z³ + 3(c-1)z + (c-1)(c-2)) / (3z² + 3(c-2)z + (c-1)(c-2) + 1) (type 2); the mandel
    form starts from z = 0 with c the point, the julia form from the point with c the
    constant. A point that escapes (|z|² > 10000) or settles on 1 after step `col` takes
    the exterior colouring, one that does neither in `iterations` steps the interior one;
    the smallest |z|² starts at 10000 in the mandel form. The arithmetic is written out
    in real and imaginary parts in POV-Ray's order, so chaotic points round as its do."""
    it_max = iterations(params)
    (ext_type, efactor), (int_type, ifactor) = colourings(params)
    n = len(p)
    if params.get("magnet_form") == "julia":
        k = constant(params, True)
        cr, ci = np.full(n, k[0]), np.full(n, k[1])
        a, b = p[:, 0].copy(), p[:, 1].copy()
        mind2 = a * a + b * b
    else:
        cr, ci = p[:, 0].copy(), p[:, 1].copy()
        a, b = np.zeros(n), np.zeros(n)
        mind2 = np.full(n, MAGNET_ESCAPE)
    step = _magnet_step(int(params.get("magnet", 1)))
    a2, b2 = a * a, b * b
    rows = np.arange(n)
    out = np.zeros(n)
    with np.errstate(all="ignore"):  # a zero denominator gives inf/nan, as in POV-Ray
        for col in range(it_max):
            a, b = step(a, b, a2, b2, cr, ci)
            a2, b2 = a * a, b * b
            d2 = a2 + b2
            mind2 = np.where(d2 < mind2, d2, mind2)  # a nan never replaces the minimum
            done = (d2 > MAGNET_ESCAPE) | ((a - 1.0) * (a - 1.0) + b2 < MAGNET_CATCH)
            if done.any():
                out[rows[done]] = _exterior(ext_type, efactor, col, it_max, a[done], b[done])
                keep = ~done
                live = (rows, a, b, a2, b2, mind2, cr, ci)
                rows, a, b, a2, b2, mind2, cr, ci = (v[keep] for v in live)
                if not len(rows):
                    return out
        out[rows] = _interior(int_type, ifactor, a, b, mind2)
    return out


def _magnet_step(kind: int):
    """One magnet step of the given type: (a, b, a², b², cr, ci) -> the new (a, b)."""

    def squared(nr, ni, dr, di):
        # q = n / d, then q²
        den = dr * dr + di * di
        qa = (nr * dr + ni * di) / den
        qb = (ni * dr - nr * di) / den
        return qa * qa - qb * qb, 2 * qa * qb

    def type1(a, b, a2, b2, cr, ci):
        return squared(a2 - b2 + cr - 1, 2 * a * b + ci, 2 * a + cr - 2, 2 * b + ci)

    def type2(a, b, a2, b2, cr, ci):
        c1r, c2r = cr - 1, cr - 2
        c12r = c1r * c2r - ci * ci  # (c-1)(c-2)
        c12i = (c1r + c2r) * ci
        nr = a2 * a - 3 * a * b2 + 3 * (a * c1r - b * ci) + c12r
        ni = 3 * a2 * b - b2 * b + 3 * (a * ci + b * c1r) + c12i
        dr = 3 * (a2 - b2) + 3 * (a * c2r - b * ci) + c12r + 1
        di = 6 * a * b + 3 * (a * ci + b * c2r) + c12i
        return squared(nr, ni, dr, di)

    return type2 if kind == 2 else type1
