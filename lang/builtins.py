"""Built-in operators, functions and constants of the scene language, with POV-Ray's semantics.

Everything here works on already-evaluated values and raises `EvalError` (a message and a
hint); the evaluator turns it into a Diagnostic at the expression's span. Pure Python math.
"""

from __future__ import annotations

import math
import os
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Any

from lang import transforms
from lang.values import ArrayValue, ColorValue, Vec, describe

# POV-Ray compares floats for (in)equality with this tolerance (its EPSILON).
EQUALITY_EPSILON = 1e-10
# POV-Ray's grey weights (colour.gray / .grey).
GREY_WEIGHTS = (0.297, 0.589, 0.114)


class EvalError(Exception):
    def __init__(self, message: str, hint: str | None = None):
        super().__init__(message)
        self.message = message
        self.hint = hint


# ------------------------------------------------------------------ conversion
def as_float(v: Any, what: str = "value") -> float:
    if isinstance(v, bool):
        return 1.0 if v else 0.0
    if isinstance(v, float | int):
        return float(v)
    raise EvalError(f"{what} must be a float, not {describe(v)}")


def as_vec(v: Any, n: int = 3, what: str = "value") -> Vec:
    """A float promotes to every component; a vector is padded/truncated to n."""
    if isinstance(v, bool | float | int):
        return Vec((float(v),) * n)
    if isinstance(v, Vec):
        return v.padded(n)
    if isinstance(v, ColorValue):
        return Vec(v.rgbft[:n]).padded(n)
    raise EvalError(f"{what} must be a vector, not {describe(v)}")


def as_color(v: Any, what: str = "value") -> ColorValue:
    """POV-Ray: a float sets all five components; a vector sets the ones it has."""
    if isinstance(v, ColorValue):
        return v
    if isinstance(v, bool | float | int):
        return ColorValue((float(v),) * 5)
    if isinstance(v, Vec):
        p = v.padded(5)
        return ColorValue((p[0], p[1], p[2], p[3], p[4]))
    raise EvalError(f"{what} must be a colour, not {describe(v)}")


def as_string(v: Any, what: str = "value") -> str:
    if isinstance(v, str):
        return v
    raise EvalError(f"{what} must be a string, not {describe(v)}")


def truth(v: Any) -> bool:
    if isinstance(v, Vec | ColorValue):
        comps = v if isinstance(v, Vec) else v.rgbft
        return any(c != 0.0 for c in comps)
    return as_float(v, "condition") != 0.0


# ------------------------------------------------------------------ operators
def _combine(a: Any, b: Any, fn: Callable[[float, float], float]) -> Any:
    # vectors of one length and a vector with a float, the common cases, first: the same
    # components as the promotions below give, without them
    ta, tb = type(a), type(b)
    if ta is Vec:
        if tb is Vec and len(a) == len(b):
            return Vec.of_floats(map(fn, a, b))
        if tb is float:
            return Vec.of_floats([fn(p, b) for p in a])
    elif ta is float and tb is Vec:
        return Vec.of_floats([fn(a, q) for q in b])
    if isinstance(a, str) or isinstance(b, str):
        raise EvalError(
            "arithmetic on a string", "join strings with concat(…), convert numbers with str(…)"
        )
    if isinstance(a, ColorValue) or isinstance(b, ColorValue):
        ca, cb = as_color(a), as_color(b)
        c = [fn(p, q) for p, q in zip(ca.rgbft, cb.rgbft, strict=True)]
        return ColorValue((c[0], c[1], c[2], c[3], c[4]))
    if isinstance(a, Vec) or isinstance(b, Vec):
        n = max(len(a) if isinstance(a, Vec) else 0, len(b) if isinstance(b, Vec) else 0)
        va, vb = as_vec(a, n), as_vec(b, n)
        return Vec(fn(p, q) for p, q in zip(va, vb, strict=True))
    return fn(as_float(a), as_float(b))


def _div(p: float, q: float) -> float:
    if q == 0.0:
        raise EvalError(ZERO_DIVISION, "the divisor is 0 here; guard it with #if or select()")
    return p / q


def divide_as_povray(a: Any, b: Any) -> Any:
    """`a / b` as POV-Ray's Parse_Mult_Factor computes it when a divisor is 0: that
    component becomes +HUGE_VAL (infinity, whatever the dividend's sign), with a warning."""
    return _combine(a, b, lambda p, q: math.inf if q == 0.0 else p / q)


ZERO_DIVISION = "division by zero"
ZERO_NORMALIZE = "vnormalize() of a zero-length vector"


# Each operator's formula on two floats, the one place it is written: vectors and colours
# apply it per component (_combine). Comparisons and logic give POV-Ray's 1.0 or 0.0.
_ARITHMETIC: dict[str, Callable[[float, float], float]] = {
    "+": lambda p, q: p + q,
    "-": lambda p, q: p - q,
    "*": lambda p, q: p * q,
    "/": _div,
}
# As POV-Ray's parser: two floats at most EQUALITY_EPSILON apart are equal, so `<=` and
# `>=` hold for them too (a loop `#while (T <= 1)` that adds 0.01 a hundred times, to
# 1.0000000000000007, still runs its last step); `<` and `>` are exact.
_COMPARISONS: dict[str, Callable[[float, float], float]] = {
    "<": lambda p, q: 1.0 if p < q else 0.0,
    "<=": lambda p, q: 1.0 if p <= q or abs(p - q) <= EQUALITY_EPSILON else 0.0,
    ">": lambda p, q: 1.0 if p > q else 0.0,
    ">=": lambda p, q: 1.0 if p >= q or abs(p - q) <= EQUALITY_EPSILON else 0.0,
    "=": lambda p, q: 1.0 if abs(p - q) <= EQUALITY_EPSILON else 0.0,
    "!=": lambda p, q: 1.0 if abs(p - q) > EQUALITY_EPSILON else 0.0,
}
_LOGIC: dict[str, Callable[[float, float], float]] = {
    "&": lambda p, q: 1.0 if p != 0.0 and q != 0.0 else 0.0,
    "|": lambda p, q: 1.0 if p != 0.0 or q != 0.0 else 0.0,
}
# Two plain floats (most of what loops compute) take the formula at once, without the
# promotions to vectors and colours (here and in lang.eval.expressions' compiled closures).
FLOAT_OPS = {**_ARITHMETIC, **_COMPARISONS, **_LOGIC}


def binary(op: str, a: Any, b: Any) -> Any:
    if type(a) is float and type(b) is float:
        f = FLOAT_OPS.get(op)
        if f is not None:
            return f(a, b)
    if op in _LOGIC:
        return _LOGIC[op](1.0 if truth(a) else 0.0, 1.0 if truth(b) else 0.0)
    if isinstance(a, str) and isinstance(b, str) and op in ("=", "!="):
        return 1.0 if (a == b) == (op == "=") else 0.0
    f = _ARITHMETIC.get(op) or _COMPARISONS.get(op)
    if f is None:
        raise EvalError(f"unknown operator `{op}`")
    return _combine(a, b, f)


def unary(op: str, a: Any) -> Any:
    if op == "-" and type(a) is float:
        return -a
    if op == "+":
        return _combine(0.0, a, lambda p, q: q)
    if op == "-":
        return _combine(0.0, a, lambda p, q: -q)
    if op == "!":
        return 0.0 if truth(a) else 1.0
    raise EvalError(f"unknown operator `{op}`")


_VEC_MEMBERS = {"x": 0, "u": 0, "y": 1, "v": 1, "z": 2, "t": 3}
_COLOR_MEMBERS = {"red": 0, "green": 1, "blue": 2, "filter": 3, "transmit": 4}
_MEMBER_HINT = (
    "a vector has .x .y .z (.t in 4-D, .u .v in 2-D); "
    "a colour .red .green .blue .filter .transmit .gray"
)


def member(v: Any, name: str) -> float:
    """`.x .y .z .t .u .v .red .green .blue .filter .transmit .gray`."""
    if name in ("gray", "grey"):
        c = as_color(v)
        return sum(w * c.rgbft[i] for i, w in enumerate(GREY_WEIGHTS))
    if isinstance(v, ColorValue):
        i = _COLOR_MEMBERS.get(name, _VEC_MEMBERS.get(name))
        if i is None:
            raise EvalError(f"a colour has no component `.{name}`", _MEMBER_HINT)
        return v.rgbft[i]
    if isinstance(v, Vec):
        i = _VEC_MEMBERS.get(name, _COLOR_MEMBERS.get(name))
        if i is None:
            raise EvalError(f"a vector has no component `.{name}`", _MEMBER_HINT)
        if i >= len(v):
            raise EvalError(f"a {len(v)}-component vector has no `.{name}`", _MEMBER_HINT)
        return v[i]
    if isinstance(v, float | int) and name in _VEC_MEMBERS:
        return float(v)
    raise EvalError(f"`.{name}` needs a vector or a colour, not {describe(v)}")


# ------------------------------------------------------------------ random
@dataclass
class BuiltinState:
    """What built-ins need from the world: random streams, the scene folder, the clock."""

    streams: list[int] = field(default_factory=list)
    folder: str = "."
    looked_outside: bool = False  # file_exists() asked (see Interpreter.outside)
    # whether a path may be read (lang.read_access): file_exists() answers only for those
    readable: Callable[[str], bool] = lambda path: True

    def seed(self, n: float) -> float:
        self.streams.append(int(n) & 0xFFFFFFFF)
        return float(len(self.streams) - 1)

    def rand(self, stream: float) -> float:
        """POV-Ray 3.7's stream generator (a 32-bit LCG), so scenes get POV-Ray's numbers."""
        i = int(stream)
        if not 0 <= i < len(self.streams):
            raise EvalError("rand() needs a stream made by seed()", "#declare R = seed(42);")
        self.streams[i] = (self.streams[i] * 1812433253 + 12345) & 0xFFFFFFFF
        return self.streams[i] / 0xFFFFFFFF


# ------------------------------------------------------------------ functions
def _f(args: Sequence[Any], i: int, name: str) -> float:
    return as_float(args[i], f"argument {i + 1} of {name}()")


def _v(args: Sequence[Any], i: int, name: str) -> Vec:
    return as_vec(args[i], 3, f"argument {i + 1} of {name}()")


def _s(args: Sequence[Any], i: int, name: str) -> str:
    return as_string(args[i], f"argument {i + 1} of {name}()")


MAX_STRING_LENGTH = 10_000_000


def _capped(text: str) -> str:
    """A string built by a scene, refused past MAX_STRING_LENGTH (a runaway loop doubling a
    string would otherwise fill the memory)."""
    if len(text) > MAX_STRING_LENGTH:
        raise EvalError(
            f"a string of {len(text):,} characters is too long",
            f"strings hold at most {MAX_STRING_LENGTH:,} characters",
        )
    return text


def _domain(ok: bool, msg: str) -> None:
    if not ok:
        raise EvalError(msg, "the argument is outside the function's domain")


def _unary_math(name: str, fn: Callable[[float], float], check=None, msg: str = ""):
    def run(args, state):
        a = _f(args, 0, name)
        if check is not None:
            _domain(check(a), msg.format(a=a))
        return float(fn(a))

    return run


def _format_float(v: float, length: int, precision: int) -> str:
    if precision < 0:
        precision = 6
    zero = "0" if length < 0 else ""
    if abs(length) > MAX_STRING_LENGTH or precision > MAX_STRING_LENGTH:
        raise EvalError(
            f"str() of width {length:,} and precision {precision:,} is too long",
            f"strings hold at most {MAX_STRING_LENGTH:,} characters",
        )
    return f"{v:{zero}{abs(length)}.{precision}f}"


def _str(args, state):
    return _format_float(_f(args, 0, "str"), int(_f(args, 1, "str")), int(_f(args, 2, "str")))


def _vstr(args, state):
    n = int(_f(args, 0, "vstr"))
    v = args[1]
    comps = as_color(v).rgbft if isinstance(v, ColorValue) else as_vec(v, n)
    sep = _s(args, 2, "vstr")
    length, prec = int(_f(args, 3, "vstr")), int(_f(args, 4, "vstr"))
    return sep.join(_format_float(c, length, prec) for c in list(comps)[:n])


def _substr(args, state):
    s = _s(args, 0, "substr")
    start, length = int(_f(args, 1, "substr")), int(_f(args, 2, "substr"))
    _domain(
        1 <= start and length >= 0 and start - 1 + length <= len(s),
        f"substr: {start}, {length} is outside the string of length {len(s)}",
    )
    return s[start - 1 : start - 1 + length]


def _val(args, state):
    s = _s(args, 0, "val").strip()
    try:
        return float(s)
    except ValueError:
        # POV-Ray reads the leading number, like C's atof.
        import re

        m = re.match(r"[+-]?(\d+\.?\d*|\.\d+)([eE][+-]?\d+)?", s)
        return float(m.group()) if m else 0.0


def _select(args, state):
    _domain(len(args) in (3, 4), "select() takes 3 or 4 arguments")
    a = _f(args, 0, "select")
    if len(args) == 3:
        return args[1] if a < 0 else args[2]
    return args[1] if a < 0 else (args[2] if a == 0 else args[3])


def _min(args, state):
    return min(_f(args, i, "min") for i in range(len(args)))


def _max(args, state):
    return max(_f(args, i, "max") for i in range(len(args)))


def _div_fn(args, state):
    a, b = _f(args, 0, "div"), _f(args, 1, "div")
    _domain(b != 0.0, "div(): division by zero")
    return float(math.trunc(a / b))


def _mod(args, state):
    a, b = _f(args, 0, "mod"), _f(args, 1, "mod")
    _domain(b != 0.0, "mod(): division by zero")
    return math.fmod(a, b)


def _pwr(a: Sequence[Any], s: BuiltinState) -> Any:
    raise EvalError(
        "`pwr(X, Y)` is a julia_fractal's function, not a value", "use pow(A, B) for a power"
    )


def _pow(args, state):
    a, b = _f(args, 0, "pow"), _f(args, 1, "pow")
    _domain(not (a == 0.0 and b < 0), "pow(): zero to a negative power")
    _domain(a >= 0 or b == int(b), f"pow(): {a:g} to the non-integer power {b:g}")
    return float(a**b)


def _atan2(args, state):
    return math.atan2(_f(args, 0, "atan2"), _f(args, 1, "atan2"))


def _vlength(args, state):
    v = args[0]
    comps = as_vec(v, len(v)) if isinstance(v, Vec) else _v(args, 0, "vlength")
    return math.sqrt(sum(c * c for c in comps))


def _vnormalize(args, state):
    v = _v(args, 0, "vnormalize")
    n = math.sqrt(sum(c * c for c in v))
    _domain(n > 0.0, ZERO_NORMALIZE)
    return Vec(c / n for c in v)


def _vdot(args, state):
    a, b = _v(args, 0, "vdot"), _v(args, 1, "vdot")
    return sum(p * q for p, q in zip(a, b, strict=True))


def _vcross(args, state):
    a, b = _v(args, 0, "vcross"), _v(args, 1, "vcross")
    return Vec(transforms.cross(a, b))


def _vrotate(args, state):
    p, r = _v(args, 0, "vrotate"), _v(args, 1, "vrotate")
    return Vec(transforms.apply_point(transforms.rotate(r), p))


def _vaxis_rotate(args, state):
    p, axis, deg = _v(args, 0, "vaxis_rotate"), _v(args, 1, "vaxis_rotate"), args[2]
    try:
        m = transforms.axis_rotate(axis, as_float(deg, "argument 3 of vaxis_rotate()"))
    except ZeroDivisionError:
        raise EvalError("vaxis_rotate(): the axis has zero length") from None
    return Vec(transforms.apply_point(m, p))


def _bitwise(op):
    def run(args, state):
        out = int(_f(args, 0, "bitwise"))
        for i in range(1, len(args)):
            out = op(out, int(_f(args, i, "bitwise")))
        return float(out)

    return run


def _dimension_size(args, state):
    a = args[0]
    if not isinstance(a, ArrayValue):
        raise EvalError(f"dimension_size() needs an array, not {describe(a)}")
    d = int(_f(args, 1, "dimension_size"))
    _domain(1 <= d <= len(a.dims), f"the array has {len(a.dims)} dimension(s), not {d}")
    return float(a.dims[d - 1])


def _dimensions(args, state):
    a = args[0]
    if not isinstance(a, ArrayValue):
        raise EvalError(f"dimensions() needs an array, not {describe(a)}")
    return float(len(a.dims))


def _file_exists(args, state):
    name = _s(args, 0, "file_exists")
    state.looked_outside = True
    path = os.path.join(state.folder, name)
    # a file outside the folders that may be read is not there (file_exists("/etc/shadow"))
    return 1.0 if state.readable(path) and os.path.exists(path) else 0.0


def vturbulence_args(args: Sequence[Any]) -> tuple[float, float, int, Vec]:
    """vturbulence(lambda, omega, octaves, point) read as POV-Ray's parser does (octaves
    kept within 1..10). The value is POV-Ray's DTurbulence, the renderer's noise: the
    evaluator asks for it (lang.queries)."""
    if len(args) != 4:
        raise EvalError(
            f"vturbulence() takes 4 argument(s), got {len(args)}",
            "call it as vturbulence(Lambda, Omega, Octaves, <Point>)",
        )
    lam, omega = _f(args, 0, "vturbulence"), _f(args, 1, "vturbulence")
    octaves = min(max(int(_f(args, 2, "vturbulence")), 1), 10)
    return lam, omega, octaves, _v(args, 3, "vturbulence")


def _strcmp(args, state):
    a, b = _s(args, 0, "strcmp"), _s(args, 1, "strcmp")
    return float((a > b) - (a < b))


def _chr(args, state):
    n = int(_f(args, 0, "chr"))
    _domain(0 <= n <= 0x10FFFF, f"chr({n}) is not a character")
    return chr(n)


def _asc(args, state):
    s = _s(args, 0, "asc")
    return float(ord(s[0])) if s else 0.0


def _datetime(args, state):
    import datetime

    secs = _f(args, 0, "datetime")
    fmt = _s(args, 1, "datetime") if len(args) > 1 else "%Y-%m-%d %H:%M:%SZ"
    epoch = datetime.datetime(2000, 1, 1, tzinfo=datetime.UTC)
    return (epoch + datetime.timedelta(days=secs)).strftime(fmt)


# name → (implementation, minimum arguments, maximum arguments or None for any)
Builtin = Callable[[Sequence[Any], BuiltinState], Any]
FUNCTIONS: dict[str, tuple[Builtin, int, int | None]] = {
    "abs": (_unary_math("abs", abs), 1, 1),
    "acos": (
        _unary_math("acos", math.acos, lambda a: -1 <= a <= 1, "acos({a:g}): outside [-1, 1]"),
        1,
        1,
    ),
    "asin": (
        _unary_math("asin", math.asin, lambda a: -1 <= a <= 1, "asin({a:g}): outside [-1, 1]"),
        1,
        1,
    ),
    "acosh": (_unary_math("acosh", math.acosh, lambda a: a >= 1, "acosh({a:g}): below 1"), 1, 1),
    "asinh": (_unary_math("asinh", math.asinh), 1, 1),
    "atanh": (
        _unary_math("atanh", math.atanh, lambda a: -1 < a < 1, "atanh({a:g}): outside (-1, 1)"),
        1,
        1,
    ),
    "atan": (_unary_math("atan", math.atan), 1, 1),
    "atan2": (_atan2, 2, 2),
    "ceil": (_unary_math("ceil", math.ceil), 1, 1),
    "floor": (_unary_math("floor", math.floor), 1, 1),
    "int": (_unary_math("int", math.trunc), 1, 1),
    "cos": (_unary_math("cos", math.cos), 1, 1),
    "sin": (_unary_math("sin", math.sin), 1, 1),
    "tan": (_unary_math("tan", math.tan), 1, 1),
    "cosh": (_unary_math("cosh", math.cosh), 1, 1),
    "sinh": (_unary_math("sinh", math.sinh), 1, 1),
    "tanh": (_unary_math("tanh", math.tanh), 1, 1),
    "degrees": (_unary_math("degrees", math.degrees), 1, 1),
    "radians": (_unary_math("radians", math.radians), 1, 1),
    "exp": (_unary_math("exp", math.exp, lambda a: a < 709, "exp({a:g}) overflows"), 1, 1),
    "ln": (_unary_math("ln", math.log, lambda a: a > 0, "ln({a:g}): not positive"), 1, 1),
    "log": (_unary_math("log", math.log10, lambda a: a > 0, "log({a:g}): not positive"), 1, 1),
    "sqrt": (
        _unary_math("sqrt", math.sqrt, lambda a: a >= 0, "sqrt({a:g}): square root of a negative"),
        1,
        1,
    ),
    "sqr": (_unary_math("sqr", lambda a: a * a), 1, 1),
    "pow": (_pow, 2, 2),
    "pwr": (_pwr, 2, 2),
    "div": (_div_fn, 2, 2),
    "mod": (_mod, 2, 2),
    "min": (_min, 1, None),
    "max": (_max, 1, None),
    "select": (_select, 3, 4),
    "bitwise_and": (_bitwise(lambda a, b: a & b), 2, None),
    "bitwise_or": (_bitwise(lambda a, b: a | b), 2, None),
    "bitwise_xor": (_bitwise(lambda a, b: a ^ b), 2, None),
    "seed": (lambda a, s: s.seed(_f(a, 0, "seed")), 1, 1),
    "rand": (lambda a, s: s.rand(_f(a, 0, "rand")), 1, 1),
    "vlength": (_vlength, 1, 1),
    "vnormalize": (_vnormalize, 1, 1),
    "vdot": (_vdot, 2, 2),
    "vcross": (_vcross, 2, 2),
    "vrotate": (_vrotate, 2, 2),
    "vaxis_rotate": (_vaxis_rotate, 3, 3),
    "str": (_str, 3, 3),
    "vstr": (_vstr, 5, 5),
    "concat": (lambda a, s: _capped("".join(_s(a, i, "concat") for i in range(len(a)))), 1, None),
    "strlen": (lambda a, s: float(len(_s(a, 0, "strlen"))), 1, 1),
    "substr": (_substr, 3, 3),
    "strupr": (lambda a, s: _s(a, 0, "strupr").upper(), 1, 1),
    "strlwr": (lambda a, s: _s(a, 0, "strlwr").lower(), 1, 1),
    "strcmp": (_strcmp, 2, 2),
    "chr": (_chr, 1, 1),
    "asc": (_asc, 1, 1),
    "val": (_val, 1, 1),
    "datetime": (_datetime, 1, 2),
    "file_exists": (_file_exists, 1, 1),
    "dimension_size": (_dimension_size, 2, 2),
    "dimensions": (_dimensions, 1, 1),
}


def call(name: str, args: Sequence[Any], state: BuiltinState) -> Any:
    entry = FUNCTIONS.get(name)
    if entry is None:
        raise EvalError(
            f"`{name}()` is not supported yet", "strala knows the name but does not evaluate it"
        )
    fn, lo, hi = entry
    if len(args) < lo or (hi is not None and len(args) > hi):
        want = f"{lo}" if hi == lo else (f"{lo} or more" if hi is None else f"{lo} to {hi}")
        letters = [chr(ord("A") + i) for i in range(hi if hi is not None else lo)]
        usage = ", ".join(letters) + (", …" if hi is None else "")
        if hi is not None and hi > lo:
            usage = ", ".join(letters[:lo]) + "".join(f"[, {c}]" for c in letters[lo:])
        raise EvalError(
            f"{name}() takes {want} argument(s), got {len(args)}", f"call it as {name}({usage})"
        )
    try:
        return fn(args, state)
    except OverflowError:
        raise EvalError(f"{name}(): the result overflows") from None
    except ValueError as e:
        raise EvalError(f"{name}(): {e}") from None


# ------------------------------------------------------------------ constants
UNIT = {
    "x": Vec((1.0, 0.0, 0.0)),
    "y": Vec((0.0, 1.0, 0.0)),
    "z": Vec((0.0, 0.0, 1.0)),
    "t": Vec((0.0, 0.0, 0.0, 1.0)),
    "u": Vec((1.0, 0.0)),
    "v": Vec((0.0, 1.0)),
}

# the built-in constants that are the same in every scene and frame
FIXED_CONSTANTS: dict[str, Any] = {
    **UNIT,
    "pi": math.pi,
    "tau": 2 * math.pi,
    "true": 1.0,
    "yes": 1.0,
    "on": 1.0,
    "false": 0.0,
    "no": 0.0,
    "off": 0.0,
}


def constant(
    name: str,
    *,
    clock: float = 0.0,
    version: float = 3.7,
    image_width: int = 0,
    image_height: int = 0,
    input_file: str = "",
) -> Any:
    if name in FIXED_CONSTANTS:
        return FIXED_CONSTANTS[name]
    simple = {
        "clock": clock,
        "clock_delta": 0.0,
        "clock_on": 0.0,
        "initial_clock": 0.0,
        "final_clock": 0.0,
        "initial_frame": 0.0,
        "final_frame": 0.0,
        "frame_number": 0.0,
        "version": version,
        "image_width": float(image_width),
        "image_height": float(image_height),
        "input_file_name": input_file,
    }
    if name == "now":
        import time

        return (time.time() - 946684800.0) / 86400.0  # days since 2000-01-01, as POV-Ray
    if name in simple:
        return simple[name]
    raise EvalError(f"unknown constant `{name}`")
