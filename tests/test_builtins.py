"""Built-in operators and functions: POV-Ray's semantics, errors as EvalError, and agreement
with POV-Ray itself (the oracle) on a batch of expressions."""

from __future__ import annotations

import math

import pytest
from conftest import povray_debug
from hypothesis import given
from hypothesis import strategies as st

from lang import builtins as B
from lang.evaluate import compile_source
from lang.values import ArrayValue, ColorValue, Vec

S = B.BuiltinState()
finite = st.floats(-1e3, 1e3, allow_nan=False, allow_infinity=False)
vec3 = st.tuples(finite, finite, finite).map(Vec)


def call(name, *args):
    return B.call(name, list(args), S)


def test_float_promotes_to_vector_and_colour():
    assert B.binary("*", 2.0, Vec((1, 2, 3))) == Vec((2, 4, 6))
    assert B.binary("+", Vec((1, 2, 3)), Vec((2, 2))) == Vec((3, 4, 3))
    assert B.binary("*", Vec((1, 2, 3)), Vec((2, 2))) == Vec((2, 4, 0))  # as POV-Ray
    c = B.binary("*", ColorValue.of(1, 1, 1), 0.5)
    assert c.rgbft == (0.5, 0.5, 0.5, 0.0, 0.0)
    assert B.binary("+", ColorValue.of(1, 0, 0), Vec((0, 1, 0))).rgbft == (1, 1, 0, 0, 0)
    assert B.as_color(0.5).rgbft == (0.5,) * 5  # `color 0.5` sets all five, as POV-Ray


def test_comparisons_and_logic():
    assert B.binary("<", 1.0, 2.0) == 1.0
    assert B.binary("=", 0.1 + 0.2, 0.3) == 1.0  # POV-Ray's epsilon equality
    assert B.binary("!=", 1.0, 1.0) == 0.0
    assert B.binary("&", 1.0, 0.0) == 0.0
    assert B.binary("|", 0.0, 3.0) == 1.0
    assert B.unary("!", 0.0) == 1.0
    assert B.unary("-", Vec((1, -2))) == Vec((-1, 2))


def test_members():
    v = Vec((1, 2, 3, 4))
    assert [B.member(v, n) for n in "xyzt"] == [1, 2, 3, 4]
    c = ColorValue.of(0.2, 0.4, 0.6, 0.1, 0.3)
    assert B.member(c, "filter") == 0.1 and B.member(c, "transmit") == 0.3
    assert math.isclose(B.member(c, "gray"), 0.297 * 0.2 + 0.589 * 0.4 + 0.114 * 0.6)
    with pytest.raises(B.EvalError):
        B.member(Vec((1, 2)), "z")
    with pytest.raises(B.EvalError):
        B.member("s", "x")


@pytest.mark.parametrize(
    "expr",
    [
        lambda: B.binary("/", 1.0, 0.0),
        lambda: call("sqrt", -1.0),
        lambda: call("acos", 2.0),
        lambda: call("ln", 0.0),
        lambda: call("mod", 1.0, 0.0),
        lambda: call("vnormalize", Vec((0, 0, 0))),
        lambda: call("substr", "abc", 3, 5),
        lambda: call("sin", "x"),
        lambda: call("sin", 1.0, 2.0),
        lambda: B.binary("+", "a", "b"),
        lambda: call("rand", 99.0),
        lambda: call("pow", -2.0, 0.5),
    ],
)
def test_errors_are_eval_errors(expr):
    with pytest.raises(B.EvalError) as e:
        expr()
    assert e.value.message


def test_pov_formatting_and_strings():
    assert call("str", 3.14159, 0.0, -1.0) == "3.141590"
    assert call("str", 2.0, 5.0, 2.0) == " 2.00"
    assert call("str", -2.5, -6.0, 1.0) == "-002.5"
    assert call("vstr", 3.0, Vec((1, 2, 3)), ",", 0.0, 1.0) == "1.0,2.0,3.0"
    assert call("concat", "a", "b", "c") == "abc"
    assert call("substr", "strala", 2.0, 3.0) == "tra"
    assert call("strlen", "héllo") == 5.0
    assert call("chr", 65.0) == "A" and call("asc", "A") == 65.0
    assert call("strupr", "aB") == "AB" and call("val", "2.5e1xyz") == 25.0


def test_integer_functions_follow_c():
    assert call("mod", -7.0, 3.0) == -1.0
    assert call("div", -7.0, 3.0) == -2.0
    assert call("int", -2.5) == -2.0
    assert call("floor", -2.5) == -3.0
    assert call("select", -1.0, 1.0, 2.0) == 1.0
    assert call("select", 0.0, 1.0, 2.0, 3.0) == 2.0
    assert call("max", 1.0, 5.0, 3.0) == 5.0 and call("min", 7.0) == 7.0
    assert call("bitwise_and", 12.0, 10.0) == 8.0


def test_rand_is_povray_stream():
    st_ = B.BuiltinState()
    s = st_.seed(42)
    # POV-Ray 3.7 prints 0.72358291 and 0.32997926 for seed(42)
    assert abs(st_.rand(s) - 0.72358291) < 1e-8
    assert abs(st_.rand(s) - 0.32997926) < 1e-8


def test_arrays():
    a = ArrayValue((2, 3), [None] * 6)
    assert call("dimension_size", a, 2.0) == 3.0
    assert call("dimensions", a) == 2.0
    with pytest.raises(B.EvalError):
        call("dimension_size", a, 3.0)


@given(vec3.filter(lambda v: math.dist(v, (0, 0, 0)) > 1e-6))
def test_vnormalize_has_unit_length(v):
    assert math.isclose(call("vlength", call("vnormalize", v)), 1.0, rel_tol=1e-9)


@given(vec3, vec3)
def test_vcross_is_perpendicular(a, b):
    c = call("vcross", a, b)
    scale = (1 + call("vlength", a)) * (1 + call("vlength", b)) * (1 + call("vlength", c))
    assert abs(call("vdot", c, a)) <= 1e-9 * scale
    assert abs(call("vdot", c, b)) <= 1e-9 * scale


@given(finite, finite)
def test_div_mod_identity(a, b):
    """POV-Ray's div truncates a/b and its mod is C's fmod (exact, sign of a). The identity
    div·b + mod = a then holds up to the rounding of a/b: when a/b rounds up to a whole
    number (1/0.01 → 100), div is one more than the true quotient and mod is close to |b|."""
    if abs(b) < 1e-3:
        return
    d, m = call("div", a, b), call("mod", a, b)
    assert d == math.trunc(a / b) and m == math.fmod(a, b)
    assert abs(m) < abs(b) and (m == 0 or math.copysign(1, m) == math.copysign(1, a))
    slack = abs(b) if abs(abs(m) - abs(b)) < 1e-9 * abs(b) + 1e-12 else 0.0
    assert abs(d * b + m - a) <= 1e-9 * abs(a) + 1e-6 + slack


@given(st.lists(finite, min_size=1, max_size=8))
def test_min_max_any_arity(xs):
    assert call("max", *xs) == max(xs) and call("min", *xs) == min(xs)


def test_vturbulence_arguments_are_read_as_povray_reads_them():
    # the value is the renderer's noise (tests/test_sdl_function_calls.py); octaves 1..10
    p = Vec((0.3, 0.2, 0.1))
    assert B.vturbulence_args([2.0, 0.5, 6.7, p]) == (2.0, 0.5, 6, p)
    assert B.vturbulence_args([2.0, 0.5, 0.0, p])[2] == 1
    assert B.vturbulence_args([2.0, 0.5, 40.0, p])[2] == 10
    with pytest.raises(B.EvalError):
        B.vturbulence_args([2.0, 0.5, p])


# ------------------------------------------------------------------ oracle
FLOAT_EXPRS = [
    "mod(-7,3)",
    "div(-7,3)",
    "int(-2.5)",
    "floor(-2.5)",
    "ceil(2.1)",
    "pow(2,10)",
    "atan2(1,-1)",
    "degrees(1)",
    "radians(90)",
    "log(1000)",
    "ln(10)",
    "exp(1.5)",
    "select(-1,1,2)",
    "select(0,1,2,3)",
    "max(1,5,3)",
    "min(4,2,8)",
    "vlength(<1,2,2>)",
    "vdot(<1,2,3>,<4,5,6>)",
    "vcross(<1,2,3>,<4,5,6>).y",
    'strlen("hello")',
    'asc("A")',
    "bitwise_xor(12,10)",
    "abs(-3)",
    "acos(0.5)",
    "tanh(0.5)",
    "sinh(1)",
    'val("3.5e2")',
    'strcmp("a","b")',
    "<1,2,3>.y",
    "(<1,2,3>*<2,2>).z",
    "C.gray",
    "C.green",
    "(C*2).blue",
    "(1+2*3-4/8)",
    "(2<3)",
    "(2=2.0)",
    "((1&0)|1)",
    "(3>2?10:20)",
    "vrotate(<1,2,3>,<10,20,30>).x",
    "vnormalize(<3,4,0>).x",
    "true+on+yes",
    "pi",
    "dimension_size(A,2)",
    "A[1][2]",
    "D.x",
    "E.transmit",
    "F.filter",
    "rand(R)",
    "rand(R)",
    "sin(pi/6)",
    "cosh(0.3)",
    "asin(0.2)",
    "atan(3)",
    "tan(1)",
    "sqrt(2)",
    "vaxis_rotate(<1,0,0>,y,90).z",
    "x.x+y.y+z.z",
    "t.t",
    "u.u+v.v",
]
STRING_EXPRS = [
    "str(3.14159,0,-1)",
    "str(2,5,2)",
    "str(-2.5,-6,1)",
    'concat("a","bc")',
    'substr("strala",2,3)',
    "chr(66)",
    'strupr("aBc")',
    'strlwr("AbC")',
    'vstr(3,<1,2,3>,",",0,2)',
    "str(1234.5678,0,2)",
]
PRELUDE = """
#declare C = rgb <0.2,0.4,0.6>;
#declare A = array[2][3] { {1,2,3}, {4,5,6} };
#declare D = color red 0.3 green 0.5;
#declare E = rgbt <0.1,0.2,0.3,0.4>;
#declare F = rgbf 0.5;
#declare R = seed(7);
"""


def _scene() -> str:
    lines = [PRELUDE]
    lines += [f'#debug concat("F ", str({e}, 0, 9), "\\n")' for e in FLOAT_EXPRS]
    lines += [f'#debug concat("S ", {e}, "|\\n")' for e in STRING_EXPRS]
    return "\n".join(lines) + "\n"


def test_strala_evaluates_the_oracle_batch():
    r = compile_source(_scene())
    assert not [d for d in r.diagnostics if d.severity == "error"], r.diagnostics
    notes = [d.message for d in r.diagnostics if d.code == "N0100"]
    assert len(notes) == len(FLOAT_EXPRS) + len(STRING_EXPRS)


@pytest.mark.povray
def test_against_povray(tmp_path):
    src = tmp_path / "b.pov"
    src.write_text(_scene())
    pov = povray_debug(src)
    pov_lines = [ln for ln in pov.splitlines() if ln.startswith(("F ", "S "))]
    ours = [d.message for d in compile_source(_scene()).diagnostics if d.code == "N0100"]
    assert len(pov_lines) == len(ours) == len(FLOAT_EXPRS) + len(STRING_EXPRS), pov[-1500:]
    exprs = FLOAT_EXPRS + STRING_EXPRS
    for expr, p, o in zip(exprs, pov_lines, ours, strict=True):
        if p.startswith("F "):
            assert math.isclose(float(p[2:]), float(o[2:]), rel_tol=1e-7, abs_tol=1e-8), (
                expr,
                p,
                o,
            )
        else:
            assert p == o, (expr, p, o)


_OPS = ["+", "-", "*", "/", "<", "<=", ">", ">=", "=", "!=", "&", "|"]
_finite = st.floats(-1e6, 1e6, allow_nan=False)


@given(op=st.sampled_from(_OPS), a=st.one_of(_finite, st.sampled_from([0.0, -0.0, 1.0])),
       b=st.one_of(_finite, st.sampled_from([0.0, -0.0, 1e-11])))  # fmt: skip
def test_two_floats_take_the_same_formula_as_components(op, a, b):
    """binary() computes two plain floats at once; the result is what the same operator
    gives per component of one-component vectors (the general path), errors included."""

    def run(x, y):
        try:
            return B.binary(op, x, y)
        except B.EvalError as e:
            return e.message

    fast = run(a, b)
    general = run(Vec((a,)), Vec((b,)))
    if op in ("&", "|"):
        assert fast == general  # logic reads a vector's truth, giving a float
    else:
        assert fast == (general if isinstance(general, str) else general[0])
        assert type(fast) is type(general if isinstance(general, str) else general[0])


@given(a=_finite)
def test_negating_a_float_is_its_negation(a):
    assert B.unary("-", a) == -a and B.unary("-", Vec((a,)))[0] == -a
