"""User functions compiled to numpy: an `ir.Function` becomes a callable on arrays.

`compile_function(fn)` returns f(*args) -> ndarray that evaluates the function's expression
tree (lang.eval.functions builds it) for whole arrays of arguments at once, in float64, the way
POV-Ray's function VM does per point:
- comparisons and logical operators give 1.0 or 0.0 (`=` within the scene language's
  epsilon), `cond ? a : b` and `select` pick per element;
- domain errors give NaN or inf rather than stopping (sqrt(-1), ln(0), x/0), as POV-Ray's
  VM does; an isosurface treats NaN as outside;
- calls of other user functions are compiled once per function and called with arrays;
- POV-Ray's internal functions (f_sphere, f_noise3d … of functions.inc) come from
  `runtime.fn_internal`; pattern and pigment functions evaluate `runtime.patterns`.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np

from lang import ir
from lang.builtins import EQUALITY_EPSILON

Array = np.ndarray
Compiled = Callable[..., Array]
_Node = Callable[[tuple[Any, ...]], Any]

# POV-Ray's grey of a colour (its GREY_SCALE weights), for `.gray` of a pigment function.
GRAY_WEIGHTS = (0.297, 0.589, 0.114)


def _int(a: Array) -> Array:
    return np.trunc(a)


def _pow(a: Any, b: Any) -> Any:
    return np.power(np.asarray(a, dtype=np.float64), b)


def _select(args: list[Any]) -> Any:
    a = args[0]
    if len(args) == 3:
        return np.where(a < 0, args[1], args[2])
    return np.where(a < 0, args[1], np.where(a == 0, args[2], args[3]))


def _reduce(op: Callable[[Any, Any], Any]) -> Callable[[list[Any]], Any]:
    def run(args: list[Any]) -> Any:
        out = args[0]
        for a in args[1:]:
            out = op(out, a)
        return out

    return run


UNARY: dict[str, Callable[[Any], Any]] = {
    "abs": np.abs,
    "acos": np.arccos,
    "acosh": np.arccosh,
    "asin": np.arcsin,
    "asinh": np.arcsinh,
    "atan": np.arctan,
    "atanh": np.arctanh,
    "ceil": np.ceil,
    "cos": np.cos,
    "cosh": np.cosh,
    "degrees": np.degrees,
    "exp": np.exp,
    "floor": np.floor,
    "int": _int,
    "ln": np.log,
    "log": np.log10,
    "radians": np.radians,
    "sin": np.sin,
    "sinh": np.sinh,
    "sqrt": np.sqrt,
    "sqr": np.square,
    "tan": np.tan,
    "tanh": np.tanh,
}
MULTI: dict[str, Callable[[list[Any]], Any]] = {
    "atan2": lambda a: np.arctan2(a[0], a[1]),
    "pow": lambda a: _pow(a[0], a[1]),
    "mod": lambda a: np.fmod(a[0], a[1]),
    "div": lambda a: np.trunc(np.true_divide(a[0], a[1])),
    "min": _reduce(np.minimum),
    "max": _reduce(np.maximum),
    "select": _select,
}
BINARY: dict[str, Callable[[Any, Any], Any]] = {
    "+": np.add,
    "-": np.subtract,
    "*": np.multiply,
    "/": np.true_divide,
    "<": lambda a, b: np.less(a, b).astype(np.float64),
    "<=": lambda a, b: np.less_equal(a, b).astype(np.float64),
    ">": lambda a, b: np.greater(a, b).astype(np.float64),
    ">=": lambda a, b: np.greater_equal(a, b).astype(np.float64),
    "=": lambda a, b: (np.abs(np.subtract(a, b)) < EQUALITY_EPSILON).astype(np.float64),
    "!=": lambda a, b: (np.abs(np.subtract(a, b)) >= EQUALITY_EPSILON).astype(np.float64),
    "&": lambda a, b: ((np.asarray(a) != 0) & (np.asarray(b) != 0)).astype(np.float64),
    "|": lambda a, b: ((np.asarray(a) != 0) | (np.asarray(b) != 0)).astype(np.float64),
}


class FunctionError(ValueError):
    """The tree holds something this compiler does not know (a newer IR)."""


class _Compiler:
    def __init__(self) -> None:
        self.cache: dict[int, tuple[ir.Function, _Node]] = {}

    def function(self, fn: ir.Function) -> _Node:
        hit = self.cache.get(id(fn))
        if hit is not None:
            return hit[1]
        node = self.node(fn.body)
        self.cache[id(fn)] = (fn, node)  # keeps fn alive so its id stays unique
        return node

    def node(self, e: Any) -> _Node:
        t = type(e)
        if t is ir.FnNum:
            v = float(e.value)
            return lambda a: v
        if t is ir.FnArg:
            i = e.index
            return lambda a: a[i]
        if t is ir.FnUnary:
            x = self.node(e.a)
            if e.op == "-":
                return lambda a: np.negative(x(a))
            if e.op == "!":
                return lambda a: (np.asarray(x(a)) == 0).astype(np.float64)
            return x
        if t is ir.FnBinary:
            op = BINARY.get(e.op)
            if op is None:
                raise FunctionError(f"unknown operator {e.op!r}")
            p, q = self.node(e.a), self.node(e.b)
            return lambda a: op(p(a), q(a))
        if t is ir.FnCond:
            c, th, ot = self.node(e.cond), self.node(e.then), self.node(e.other)
            return lambda a: np.where(np.asarray(c(a)) != 0, th(a), ot(a))
        if t is ir.FnBuiltin:
            kids = [self.node(k) for k in e.args]
            if e.name in UNARY:
                f1 = UNARY[e.name]
                k0 = kids[0]
                return lambda a: f1(k0(a))
            fm = MULTI.get(e.name)
            if fm is None:
                raise FunctionError(f"unknown built-in function {e.name}()")
            return lambda a: fm([k(a) for k in kids])
        if t is ir.FnCall:
            body = self.function(e.fn)
            kids = [self.node(k) for k in e.args]
            return lambda a: body(tuple(k(a) for k in kids))
        if t is ir.FnInternal:
            from runtime import fn_internal

            impl = fn_internal.IMPLEMENTATIONS.get(e.name)
            kids = [self.node(k) for k in e.args]
            if impl is None:
                fn_internal.warn_missing(e.name)
                return lambda a: np.zeros(np.broadcast(*a).shape) if a else 0.0
            if e.name in fn_internal.SCENE_NOISE:
                gen = e.noise_generator
                return lambda a: impl(*[k(a) for k in kids], generator=gen)
            return lambda a: impl(*[k(a) for k in kids])
        if t is ir.FnSpline:
            return _spline_node(e, self.node(e.arg))
        if t is ir.FnPattern or t is ir.FnPigment:
            return self.pattern(e)
        raise FunctionError(f"not a function expression: {t.__name__}")

    def pattern(self, e: ir.FnPattern | ir.FnPigment) -> _Node:
        from runtime import patterns

        kids = [self.node(k) for k in e.args]
        pig = e.pigment

        def points(a: tuple[Any, ...]) -> tuple[Array, tuple[int, ...]]:
            vals = np.broadcast_arrays(*[np.asarray(k(a), dtype=np.float64) for k in kids])
            shape = vals[0].shape
            return np.stack([v.ravel() for v in vals], axis=1), shape

        if isinstance(e, ir.FnPattern):

            def value(a: tuple[Any, ...]) -> Array:
                p, shape = points(a)
                return patterns.pattern_value(pig, p).reshape(shape)

            return value
        comp = e.component

        def colour(a: tuple[Any, ...]) -> Array:
            p, shape = points(a)
            c = patterns.evaluate(pig, p)
            if comp >= 5:
                v = (
                    c[:, 0] * GRAY_WEIGHTS[0]
                    + c[:, 1] * GRAY_WEIGHTS[1]
                    + c[:, 2] * GRAY_WEIGHTS[2]
                )
            else:
                v = c[:, comp]
            return v.reshape(shape)

        return colour


def _spline_node(e: ir.FnSpline, arg: _Node) -> _Node:
    """ir.FnSpline over arrays: the piece each t falls in, its cubic at the clamped s."""
    knots = np.asarray(e.knots, dtype=np.float64)
    coeffs = np.asarray(e.coeffs, dtype=np.float64)
    inner = knots[1:-1]

    def value(a: tuple[Any, ...]) -> Array:
        t = np.asarray(arg(a), dtype=np.float64)
        k = np.searchsorted(inner, t, side="right")
        lo, hi = knots[k], knots[k + 1]
        s = np.clip((t - lo) / (hi - lo), 0.0, 1.0)
        c = coeffs[k]
        return c[..., 0] + s * (c[..., 1] + s * (c[..., 2] + s * c[..., 3]))

    return value


def compile_function(fn: ir.Function) -> Compiled:
    """fn as f(*args) over arrays (broadcast together; the result has their shape)."""
    body = _Compiler().function(fn)
    n = len(fn.params)

    def f(*args: Any) -> Array:
        if len(args) != n:
            raise TypeError(f"this function takes {n} argument(s), got {len(args)}")
        arrays = tuple(np.asarray(v, dtype=np.float64) for v in args)
        shape = np.broadcast_shapes(*(v.shape for v in arrays)) if arrays else ()
        with np.errstate(all="ignore"):
            out = body(arrays)
        return np.broadcast_to(np.asarray(out, dtype=np.float64), shape).copy()

    return f


def compile_xyz(fn: ir.Function) -> Callable[[Array], Array]:
    """fn as g(points (N,3)) -> (N,), for isosurfaces and function patterns (a function
    with more than three parameters gets 0 for the rest, as POV-Ray does)."""
    f = compile_function(fn)
    extra = (0.0,) * max(0, len(fn.params) - 3)

    def g(p: Array) -> Array:
        xyz = (p[:, 0], p[:, 1], p[:, 2])[: len(fn.params)]
        return f(*xyz, *extra)

    return g
