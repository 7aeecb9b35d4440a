"""Expressions compiled into closures (lang.eval.expressions.compiled) evaluate exactly as
the tree walk does: the same values, and the same diagnostics at the same places, for
operators, negation and built-in calls over floats, vectors, colours, strings and names,
including the errors (division by zero, a string in arithmetic, a wrong argument count)."""

from __future__ import annotations

import math
from unittest import mock

from hypothesis import example, given
from hypothesis import strategies as st

from lang.eval import interpreter
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
