"""User functions: the expression tree the evaluator builds, its numpy compilation, the
internal functions of functions.inc, and the function pattern.

The reference for the compiled functions is the scene-language interpreter itself: the
same expression text is evaluated by `#declare` with the point's coordinates written in,
so the two paths share no code past the parser.
"""

from __future__ import annotations

import math
import re
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from lang import ir
from lang.eval.functions import INTERNALS
from lang.evaluate import compile_source
from runtime import fn_internal, patterns
from runtime.functions import compile_function, compile_xyz


def declared(src: str, name: str):
    r = compile_source(src, "t.pov")
    errs = [d for d in r.diagnostics if d.severity == "error"]
    assert not errs, errs
    return r.symbols[name]


def fn_of(src: str, name: str = "F") -> ir.Function:
    v = declared(src, name)
    assert v.compiled is not None
    return v.compiled


def scalar(expr: str) -> float:
    return float(declared(f"#declare V = {expr};", "V"))


# ------------------------------------------------------------------ random expressions
SAFE_UNARY = ["sin", "cos", "atan", "abs", "floor", "ceil", "int", "degrees", "radians",
              "sinh", "tanh", "asinh"]  # fmt: skip
SAFE_BINARY_FN = ["min", "max", "atan2"]
OPS = ["+", "-", "*", "<", "<=", ">", ">=", "=", "!=", "&", "|"]


def _expressions():
    leaf = st.one_of(
        st.sampled_from(["x", "y", "z"]),
        st.floats(-3, 3, allow_nan=False).map(lambda v: f"{v:.3f}"),
    )

    def extend(inner):
        return st.one_of(
            st.tuples(st.sampled_from(OPS), inner, inner).map(lambda t: f"({t[1]} {t[0]} {t[2]})"),
            st.tuples(st.sampled_from(SAFE_UNARY), inner).map(lambda t: f"{t[0]}({t[1]})"),
            st.tuples(st.sampled_from(SAFE_BINARY_FN), inner, inner).map(
                lambda t: f"{t[0]}({t[1]}, {t[2]})"
            ),
            inner.map(lambda a: f"(-{a})"),
            inner.map(lambda a: f"sqrt(abs({a}))"),
            st.tuples(inner, inner, inner).map(lambda t: f"select({t[0]}, {t[1]}, {t[2]})"),
            st.tuples(inner, inner, inner).map(lambda t: f"(({t[0]}) ? {t[1]} : {t[2]})"),
        )

    return st.recursive(leaf, extend, max_leaves=12)


EXPRESSIONS = _expressions()


def substitute(expr: str, p: tuple[float, float, float]) -> str:
    return re.sub(r"\b[xyz]\b", lambda m: f"({p['xyz'.index(m.group())]!r})", expr)


# Coordinates on a 1e-3 grid: the scene language compares with POV-Ray's parser tolerance
# (1e-10) while function bodies compare exactly, as POV-Ray's function VM does, so the two
# may part only on near-ties such as `x <= y` at x = 0, y = -5e-110; the grid keeps the
# points away from those.
COORD = st.floats(-2, 2).map(lambda v: round(v, 3))


@settings(max_examples=60, deadline=None)
@given(EXPRESSIONS, st.lists(st.tuples(*[COORD] * 3), min_size=1, max_size=4))
def test_compiled_equals_interpreter(expr, points):
    f = compile_function(fn_of(f"#declare F = function {{ {expr} }}"))
    xs = np.array(points, dtype=np.float64)
    got = f(xs[:, 0], xs[:, 1], xs[:, 2])
    for p, g in zip(points, got, strict=True):
        want = scalar(substitute(expr, p))
        assert g == pytest.approx(want, rel=1e-9, abs=1e-9), (expr, p)


@settings(max_examples=30, deadline=None)
@given(EXPRESSIONS, st.tuples(*[st.floats(-2, 2)] * 3))
def test_sdl_call_equals_compiled(expr, p):
    """Calling the function from the scene language evaluates the same tree."""
    src = f"#declare F = function {{ {expr} }}\n#declare V = F({p[0]!r}, {p[1]!r}, {p[2]!r});"
    want = float(declared(src, "V"))
    f = compile_function(fn_of(src))
    assert float(f(*p)) == pytest.approx(want, rel=1e-12, abs=1e-12)


# ------------------------------------------------------------------ every built-in
BUILTIN_CASES = [
    ("abs(x)", -1.5), ("acos(x)", 0.3), ("acosh(x)", 1.7), ("asin(x)", -0.4),
    ("asinh(x)", 2.0), ("atan(x)", 0.9), ("atanh(x)", 0.5), ("ceil(x)", 1.2),
    ("cos(x)", 0.7), ("cosh(x)", 0.6), ("degrees(x)", 1.0), ("exp(x)", 1.3),
    ("floor(x)", -1.2), ("int(x)", -1.7), ("ln(x)", 2.5), ("log(x)", 20.0),
    ("radians(x)", 90.0), ("sin(x)", 0.3), ("sinh(x)", 0.8), ("sqrt(x)", 2.0),
    ("tan(x)", 0.4), ("tanh(x)", 0.2), ("atan2(x, 2)", 1.0), ("pow(x, 3)", 1.5),
    ("pow(x, 0.5)", 2.0), ("mod(x, 0.7)", -2.3), ("min(x, 1, -2)", 0.5),
    ("max(x, 1, -2)", 3.5), ("select(x, 1, 2)", -1.0), ("select(x, 1, 2)", 0.0),
    ("select(x, 1, 2, 3)", 0.0), ("select(x, 1, 2, 3)", 4.0), ("x * pi", 2.0),
    ("(x > 1) + (x < 1) * 2", 3.0), ("!(x = 2)", 2.0), ("x / 4", 3.0),
]  # fmt: skip


@pytest.mark.parametrize(("expr", "value"), BUILTIN_CASES)
def test_every_builtin(expr, value):
    f = compile_function(fn_of(f"#declare F = function(x) {{ {expr} }}"))
    want = scalar(re.sub(r"\bx\b", f"({value!r})", expr))
    got = f(np.array([value, value]))
    assert got.shape == (2,)
    assert got[0] == pytest.approx(want, rel=1e-12, abs=1e-15)


def test_domain_errors_give_nan_not_exceptions():
    f = compile_function(fn_of("#declare F = function { sqrt(x) + ln(y) + 1 / z }"))
    out = f(np.array([-1.0, 4.0]), np.array([1.0, 0.0]), np.array([1.0, 1.0]))
    assert math.isnan(out[0])
    assert out[1] == -np.inf


# ------------------------------------------------------------------ declaration semantics
def test_constants_are_bound_when_the_function_is_declared():
    src = """#declare A = 2;
    #declare V = <1, 5, 7>;
    #declare F = function { A * x + V.y }
    #declare A = 100;"""
    f = compile_function(fn_of(src))
    assert f(3.0, 0.0, 0.0) == pytest.approx(11.0)


def test_u_and_v_name_the_first_two_default_parameters():
    # POV-Ray: a function of no declared parameters takes x, y, z, also called u and v
    # (a parametric's functions are written in u and v)
    f = compile_function(fn_of("#declare F = function { u * 10 + v - z }"))
    assert f(3.0, 2.0, 1.0) == pytest.approx(31.0)


def test_functions_call_functions_with_their_own_parameters():
    src = """#declare G = function(a, b) { a * 10 + b }
    #declare F = function { G(y, x) - G(1, 2) }"""
    fn = fn_of(src)
    assert isinstance(fn.body, ir.FnBinary)
    assert isinstance(fn.body.a, ir.FnCall)
    assert fn.body.b == ir.FnNum(12.0)  # a call on constants is folded
    f = compile_function(fn)
    assert f(1.0, 2.0, 0.0) == pytest.approx(21.0 - 12.0)


@pytest.mark.parametrize(
    ("src", "message"),
    [
        ("#declare F = function { x + Nope }", "Nope"),
        ("#declare G = function(a) { a }\n#declare F = function { G(x, y) }", "takes 1"),
        ("#declare F = function(a, b) { a + x }", "`x` is a vector"),
        ("#declare F = function { sin(x, y) }", "sin() takes 1"),
        ("#declare F = function { <x, y, z> }", "not a vector"),
        ("#declare F = function { internal(400) }", "no internal function"),
    ],
)
def test_bad_functions_are_diagnosed_at_their_span(src, message):
    r = compile_source(src, "t.pov")
    errs = [d for d in r.diagnostics if d.severity == "error"]
    assert errs and message in errs[0].message, r.diagnostics
    assert errs[0].span is not None and errs[0].span.line >= 1 and errs[0].span.col > 1


def test_the_ir_of_a_function_serialises():
    from lang import serialize

    fn = fn_of("#declare G = function(a) { a * 2 }\n#declare F = function { G(x) + f(y) }"
               .replace("f(y)", "select(y, 1, 2)"))  # fmt: skip
    assert serialize.from_data(serialize.to_data(fn)) == fn


# ------------------------------------------------------------------ internal functions
def test_every_internal_function_is_implemented_with_its_arity():
    rng = np.random.default_rng(7)
    p = rng.uniform(-1.5, 1.5, (50, 3))
    for name, n in INTERNALS:
        if name == "f_pattern":
            continue
        impl = fn_internal.IMPLEMENTATIONS[name]
        params = [1.0, 0.5, 0.3, 0.4, 0.2, 1.0, 0.0, 1.0, 0.5, 0.5][:n]
        with np.errstate(all="ignore"):
            out = np.asarray(impl(p[:, 0], p[:, 1], p[:, 2], *params), dtype=np.float64)
        out = np.broadcast_to(out, (50,))
        assert np.isfinite(out).mean() > 0.5, name


def test_internal_shapes_are_distances():
    inc = '#include "functions.inc"\n'
    f = compile_xyz(fn_of(inc + "#declare F = function { f_sphere(x, y, z, 2) }"))
    assert f(np.array([[3.0, 0.0, 0.0], [0.0, 0.0, 0.0]])) == pytest.approx([1.0, -2.0])
    t = compile_xyz(fn_of(inc + "#declare F = function { f_torus(x, y, z, 2, 0.5) }"))
    assert t(np.array([[2.0, 0.0, 0.0], [0.0, 0.0, 2.0], [3.0, 0.0, 0.0]])) == pytest.approx(
        [-0.5, -0.5, 0.5]
    )
    b = compile_xyz(fn_of(inc + "#declare F = function { f_rounded_box(x, y, z, 0.1, 1, 2, 3) }"))
    assert b(np.array([[2.0, 0.0, 0.0], [0.0, 2.5, 0.0]])) == pytest.approx([1.0, 0.5], abs=1e-5)
    n = compile_xyz(fn_of(inc + "#declare F = function { f_snoise3d(x, y, z) }"))
    v = n(np.random.default_rng(1).uniform(-5, 5, (2000, 3)))
    assert -1.0 <= v.min() < -0.2 and 0.2 < v.max() <= 1.0


def test_povrays_own_functions_inc_gives_the_same_functions():
    """`internal(N)` follows POV-Ray's numbering, so its functions.inc works too."""
    src = (
        '#include "functions.inc"\n'
        "#declare F = function { f_helix1(x, y, z, 2, 3, 0.1, 0.5, 1, 1, 0) }"
    )
    ours = compile_xyz(fn_of(src))
    # POV-Ray's file by its full name: named by -L, POV-Ray's folder comes after the stdlib
    theirs_inc = Path("/usr/share/povray-3.7/include/functions.inc")
    if not theirs_inc.is_file():
        pytest.skip("POV-Ray's include files are not installed")
    r = compile_source(src.replace("functions.inc", str(theirs_inc)), "t.pov")
    assert str(theirs_inc) in r.files
    theirs = compile_xyz(r.symbols["F"].compiled)
    pts = np.random.default_rng(3).uniform(-1, 1, (100, 3))
    np.testing.assert_allclose(theirs(pts), ours(pts))


# ------------------------------------------------------------------ patterns and pigments
def test_pattern_and_pigment_functions_evaluate_the_pattern():
    src = """#declare P = function { pattern { gradient x } }
    #declare Q = function {
      pigment { gradient x color_map { [0 rgb <0, 0, 1>] [1 rgb <1, 0, 0>] } }
    }
    #declare F = function { P(x, 0, 0) + 10 * Q(x, y, z).red + 100 * Q(x, y, z).blue }"""
    f = compile_function(fn_of(src))
    assert f(0.25, 0.0, 0.0) == pytest.approx(0.25 + 2.5 + 75.0)


def test_function_pattern_wraps_like_povray():
    fn = fn_of("#declare F = function { x }")
    pig = ir.Pigment(pattern="function", params={"function": fn})
    v = patterns.pattern_value(pig, np.array([[0.25, 0, 0], [1.5, 0, 0], [-0.25, 0, 0]]))
    assert v == pytest.approx([0.25, 0.5, 0.75])
