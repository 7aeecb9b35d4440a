"""`spline { … }`: reading the block into a SplineValue, and evaluating a spline at a
parameter as POV-Ray 3.7 does (linear, quadratic, cubic and natural splines)."""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

from lang import (
    ir,
    schema,
    syntax,
)
from lang.builtins import as_vec
from lang.eval.context import BuildContext
from lang.values import (
    SplineValue,
    Vec,
)


def evaluate_spline(sp: SplineValue, t: float) -> Any:
    """POV-Ray 3.7's splines (checked against it): linear; quadratic through the point
    before, at and after each segment start; cubic Hermite with each tangent the mean of the
    neighbouring secant slopes, defined between the second and the second-to-last point;
    natural cubic (zero curvature at the ends). Outside the range: the nearest end value."""
    ts = [e[0] for e in sp.entries]
    floats = all(isinstance(e[1], float) for e in sp.entries)
    dim = 1 if floats else max(len(e[1]) if isinstance(e[1], Vec) else 1 for e in sp.entries)
    ps = [(e[1],) if floats else tuple(as_vec(e[1], dim)) for e in sp.entries]
    n = len(ts)

    def out(v: Sequence[float]) -> Any:
        return v[0] if floats else Vec(v)

    lo, hi = (1, n - 2) if sp.spline_type == "cubic_spline" else (0, n - 1)
    if t <= ts[lo]:
        return out(ps[lo])
    if t >= ts[hi]:
        return out(ps[hi])
    i = max(k for k in range(lo, hi) if ts[k] <= t)
    h = ts[i + 1] - ts[i]
    s = (t - ts[i]) / h
    if sp.spline_type == "linear_spline" or (sp.spline_type == "quadratic_spline" and n < 3):
        return out([a + (b - a) * s for a, b in zip(ps[i], ps[i + 1], strict=True)])
    if sp.spline_type == "quadratic_spline" and n >= 3:
        j = max(i - 1, 0)
        t0, t1, t2 = ts[j], ts[j + 1], ts[j + 2]
        w0 = (t - t1) * (t - t2) / ((t0 - t1) * (t0 - t2))
        w1 = (t - t0) * (t - t2) / ((t1 - t0) * (t1 - t2))
        w2 = (t - t0) * (t - t1) / ((t2 - t0) * (t2 - t1))
        return out(
            [w0 * a + w1 * b + w2 * c for a, b, c in zip(ps[j], ps[j + 1], ps[j + 2], strict=True)]
        )
    if sp.spline_type == "cubic_spline":

        def tangent(k: int) -> list[float]:
            left = [(b - a) / (ts[k] - ts[k - 1]) for a, b in zip(ps[k - 1], ps[k], strict=True)]
            right = [(b - a) / (ts[k + 1] - ts[k]) for a, b in zip(ps[k], ps[k + 1], strict=True)]
            return [(a + b) / 2 for a, b in zip(left, right, strict=True)]

        m0, m1 = tangent(i), tangent(i + 1)
        h00, h10 = 2 * s**3 - 3 * s**2 + 1, s**3 - 2 * s**2 + s
        h01, h11 = -2 * s**3 + 3 * s**2, s**3 - s**2
        return out(
            [
                h00 * a + h10 * h * da + h01 * b + h11 * h * db
                for a, b, da, db in zip(ps[i], ps[i + 1], m0, m1, strict=True)
            ]
        )
    # natural cubic spline: solve for the second derivatives (tridiagonal, per component)
    hs = [ts[k + 1] - ts[k] for k in range(n - 1)]
    result = []
    for c in range(dim):
        y = [p[c] for p in ps]
        sub, diag, sup, rhs = [0.0] * n, [1.0] * n, [0.0] * n, [0.0] * n
        for k in range(1, n - 1):
            sub[k], diag[k], sup[k] = hs[k - 1], 2 * (hs[k - 1] + hs[k]), hs[k]
            rhs[k] = 6 * ((y[k + 1] - y[k]) / hs[k] - (y[k] - y[k - 1]) / hs[k - 1])
        for k in range(1, n):  # Thomas algorithm
            w = sub[k] / diag[k - 1]
            diag[k] -= w * sup[k - 1]
            rhs[k] -= w * rhs[k - 1]
        m = [0.0] * n
        m[-1] = rhs[-1] / diag[-1]
        for k in range(n - 2, -1, -1):
            m[k] = (rhs[k] - sup[k] * m[k + 1]) / diag[k]
        a, b = ts[i + 1] - t, t - ts[i]
        result.append(
            m[i] * a**3 / (6 * h)
            + m[i + 1] * b**3 / (6 * h)
            + (y[i] / h - m[i] * h / 6) * a
            + (y[i + 1] / h - m[i + 1] * h / 6) * b
        )
    return out(result)


def cubic_pieces(
    sp: SplineValue, component: int
) -> tuple[tuple[float, ...], tuple[tuple[float, float, float, float], ...]]:
    """The spline's `component` as ir.FnSpline's pieces (knots, per-segment cubic
    coefficients), for functions that call it with their parameters. Every kind is a cubic
    (or lower) polynomial between two points, so each piece is the cubic through four of its
    values, taken from evaluate_spline: one algorithm for the scene language and the
    renderer."""

    def at(t: float) -> float:
        v = evaluate_spline(sp, t)
        if isinstance(v, float | int):
            return float(v) if component == 0 else 0.0
        return float(v[component]) if component < len(v) else 0.0

    ts = [e[0] for e in sp.entries]
    lo, hi = (1, len(ts) - 2) if sp.spline_type == "cubic_spline" else (0, len(ts) - 1)
    if hi <= lo:  # one point in range: the spline is that value everywhere
        t0 = ts[min(max(lo, 0), len(ts) - 1)]
        return (t0, t0 + 1.0), ((at(t0), 0.0, 0.0, 0.0),)
    knots = tuple(ts[lo : hi + 1])
    coeffs = []
    for a, b in zip(knots, knots[1:], strict=False):
        # values at s = 0, 1/3, 2/3, 1; Newton's forward differences, then powers of s
        y0, y1, y2, y3 = (at(a + (b - a) * k / 3) for k in range(4))
        d1, d2, d3 = y1 - y0, y2 - 2 * y1 + y0, y3 - 3 * y2 + 3 * y1 - y0
        coeffs.append((y0, 3 * (d1 - d2 / 2 + d3 / 3), 4.5 * (d2 - d3), 4.5 * d3))
    return knots, tuple(coeffs)


def spline_piece_value(e: ir.FnSpline, t: float) -> float:
    """ir.FnSpline at t in plain floats (the runtime has the array form)."""
    knots = e.knots
    k = 0
    while k < len(e.coeffs) - 1 and t >= knots[k + 1]:
        k += 1
    s = min(max((t - knots[k]) / (knots[k + 1] - knots[k]), 0.0), 1.0)
    c0, c1, c2, c3 = e.coeffs[k]
    return c0 + s * (c1 + s * (c2 + s * c3))


def build_spline(it: BuildContext, node: syntax.Block) -> SplineValue:
    kind = "linear_spline"
    entries: dict[float, Any] = {}
    pending: float | None = None
    for el in it.expand(node.body, None):
        if el.kind == "comma":
            continue
        v = el.value
        if el.kind == "kw" and el.value in schema.SPLINE_TYPES:
            kind = el.value
        elif el.kind == "val" and isinstance(v, SplineValue):
            kind, entries = v.spline_type, dict(v.entries)
        elif el.kind == "val" and pending is None and isinstance(v, float):
            pending = v
        elif el.kind == "val" and pending is not None and isinstance(v, float | Vec):
            entries[pending] = v
            pending = None
        else:
            what = f"`{el.value}`" if el.kind == "kw" else "this"
            raise it.error(
                "E0212",
                f"{what} is not valid inside `spline`",
                el.span,
                "spline { cubic_spline 0, <…>, 1, <…> … }",
            )
    if pending is not None:
        raise it.error("E0211", "a spline parameter without its value", node.span)
    need = {"linear_spline": 2, "quadratic_spline": 3, "cubic_spline": 4, "natural_spline": 3}[kind]
    if len(entries) < need:
        raise it.error("E0211", f"a {kind} needs at least {need} points", node.span)
    return SplineValue(kind, tuple(sorted(entries.items())))
