"""Expressions compiled into closures (lang.eval.expressions.compiled) evaluate exactly as
the tree walk does: the same values, and the same diagnostics at the same places, for
operators, negation and built-in calls over floats, vectors, colours, strings and names,
including the errors (division by zero, a string in arithmetic, a wrong argument count)."""

from __future__ import annotations

import math
from unittest import mock

from hypothesis import example, given
from hypothesis import strategies as st

from lang.eval import expressions, generated, interpreter
from lang.evaluate import compile_source

# floats most often (the loops' arithmetic), the other kinds and the error cases sometimes
_FLOATS = ["1", "0", "2.5", "-3", "A", "pi", "0.1"]
_OTHERS = ["V", "C", "S", "<1, 2, 3>", "rgb <0.1, 0.2, 0.3>"]
_OPS = ["+", "-", "*", "/", "<", "<=", ">", ">=", "=", "!=", "&", "|"]
_CALLS = ["sin", "cos", "sqrt", "abs", "max", "min", "vlength", "pow", "mod", "int", "strlen"]
_CALLS += ["acos", "asin"]  # they warn outside [-1, 1]


@st.composite
def _expr(draw, depth=3):
    if depth == 0 or draw(st.integers(0, 3)) == 0:
        return draw(st.sampled_from(_FLOATS if draw(st.integers(0, 3)) else _OTHERS))
    kind = draw(st.integers(0, 2))
    if kind == 0:
        a, b = draw(_expr(depth - 1)), draw(_expr(depth - 1))
        return f"({a} {draw(st.sampled_from(_OPS))} {b})"
    if kind == 1:
        return f"-({draw(_expr(depth - 1))})"
    args = ", ".join(draw(_expr(depth - 1)) for _ in range(draw(st.integers(1, 2))))
    return f"{draw(st.sampled_from(_CALLS))}({args})"


def _run(source: str):
    r = compile_source(source, "t.pov")
    return (
        {k: repr(v) for k, v in r.symbols.items()},
        [(d.code, d.message, d.span) for d in r.diagnostics],
    )


@given(exprs=st.lists(_expr(), min_size=1, max_size=3))
@example(exprs=["(A * 2.5) - sin(pi / 0.1)", "V * (A / 0)", "-(S + 1) | (1 & 0)"])
def test_compiled_expressions_evaluate_as_the_tree_walk(exprs):
    source = '#declare A = 0.5; #declare V = <1, -2, 0.5>; #declare C = rgb 1; #declare S = "s";\n'
    source += "".join(f"#declare R{i} = {e};\n" for i, e in enumerate(exprs))
    source += (
        "#declare K = 0; #while (K < 3) #declare K = K + 1; "
        + "".join(f"#declare L{i} = {e}; " for i, e in enumerate(exprs))
        + "#end\n"
    )
    compiled = _run(source)
    with mock.patch.object(interpreter, "_COMPILED_KINDS", frozenset()):
        walked = _run(source)
    assert compiled == walked


def test_a_loop_compiles_its_expressions_once():
    r = compile_source(
        "#declare S = 0; #declare I = 0; #while (I < 50) #declare S = S + sin(I); "
        "#declare I = I + 1; #end",
        "t.pov",
    )
    assert r.symbols["I"] == 50.0
    assert abs(r.symbols["S"] - sum(math.sin(i) for i in range(50))) < 1e-12


# ------------------------------------------------------------ generated functions
# lang.eval.generated: the pure subset as Python functions, giving up to the usual way on
# anything unusual. Made at once here (GENERATE_AFTER = 1), they must give what the tree
# walk gives, diagnostics and their places included, for the subset's every kind of node
# and for the cases where they give up (unknown names, a macro, arrays out of range,
# division by zero, acos outside [-1, 1], strings in arithmetic).
_LEAVES = ["1", "0", "2.5", "A", "pi", "V", "C", "S", "Arr[1]", "Arr[K]", "x", "M", "Nope"]
_LEAVES += ["<1, A, 3>", "V.x", "V.z", "C.red", "defined(A)", "defined(Nope)"]
_MORE_CALLS = [*_CALLS, "vdot", "select", "str"]


@st.composite
def _gen_expr(draw, depth=3):
    if depth == 0 or draw(st.integers(0, 3)) == 0:
        # floats most often, as loops compute them
        return draw(st.sampled_from(_LEAVES if draw(st.integers(0, 2)) == 0 else _FLOATS))
    kind = draw(st.integers(0, 4))
    sub = _gen_expr(depth - 1)
    if kind == 0:
        return f"({draw(sub)} {draw(st.sampled_from(_OPS))} {draw(sub)})"
    if kind == 1:
        return f"{draw(st.sampled_from(['-', '!', '+']))}({draw(sub)})"
    if kind == 2:
        return f"({draw(sub)} ? {draw(sub)} : {draw(sub)})"
    if kind == 3:
        return f"<{draw(sub)}, {draw(sub)}, 1>"
    args = ", ".join(draw(sub) for _ in range(draw(st.integers(1, 3))))
    return f"{draw(st.sampled_from(_MORE_CALLS))}({args})"


@given(exprs=st.lists(_gen_expr(), min_size=1, max_size=3))
@example(exprs=["(A / 0) + acos(2)", "Arr[K + 5] + M", "(0 & Nope) + (1 | Nope)"])
@example(exprs=["(A - 1) * (2.5 - A) - V.x", "(A <= 0.5) + (A != 1) - (A >= 2)"])
@example(exprs=["(A > 0 ? V.x : S) * 2", "select(-1, A, V) + C.red", "-(<1, A, 3>).y"])
def test_generated_functions_evaluate_as_the_tree_walk(exprs):
    source = (
        '#declare A = 0.5; #declare V = <1, -2, 0.5>; #declare C = rgb 1; #declare S = "s";\n'
        "#declare Arr = array[3] { 1, 2, 3 }; #declare K = 0;\n#macro M() 7 #end\n"
    )
    source += (
        "#while (K < 3) "
        + "".join(f"#declare L{i} = {e}; " for i, e in enumerate(exprs))
        + "#declare K = K + 1; #end\n"
    )
    with mock.patch.object(expressions, "GENERATE_AFTER", 1):
        generated = _run(source)
    with mock.patch.object(interpreter, "_COMPILED_KINDS", frozenset()):
        walked = _run(source)
    assert generated == walked


def test_a_hot_loop_runs_its_generated_function():
    """The loop's arithmetic is a generated function after GENERATE_AFTER passes, with the
    loop's values; a division by zero in a late pass still warns where it stands."""
    calls = []
    real = generated.function

    def spy(node, const):
        fn = real(node, const)
        calls.append(fn)
        return fn

    with mock.patch.object(generated, "function", spy):
        r = compile_source(
            "#declare S = 0; #declare I = 0;\n#while (I < 300)\n"
            "  #declare S = S + sin(I * 0.5) / (I - 299);\n  #declare I = I + 1;\n#end\n",
            "t.pov",
        )
    assert calls and all(fn is not None for fn in calls)
    want = sum(math.sin(i * 0.5) / (i - 299) for i in range(299)) + math.inf
    assert r.symbols["S"] == want
    warned = [d for d in r.diagnostics if d.code == "W0309"]
    assert [(d.span.line, d.message) for d in warned] == [(3, "Divide by zero.")]
