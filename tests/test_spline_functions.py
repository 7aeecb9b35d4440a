"""Splines called with a function's parameters (`function { S(x).y }`, POV-Ray's spline
function `function { spline { … } }`): each kind as POV-Ray renders it, and the pieces the
renderer evaluates equal the scene language's spline everywhere."""

from __future__ import annotations

import pytest
from conftest import image_errors, povray_image, strala_image
from hypothesis import given, settings
from hypothesis import strategies as st

from lang import ir
from lang.eval.splines import cubic_pieces, evaluate_spline, spline_piece_value
from lang.values import SplineValue, Vec
from runtime.functions import compile_function

SCENE = """#version 3.7;
global_settings {{ assumed_gamma 1 }}
camera {{ orthographic location <0.5, 0.5, -2> look_at <0.5, 0.5, 0> right x up y }}
#declare F = function {{ spline {{ {kind} {points} }} }}
box {{ <0, 0, 0>, <1, 1, 0.1>
  pigment {{ function {{ {expr} }} color_map {{ [0 rgb 0] [1 rgb <1, 0.8, 0.4>] }} }}
  finish {{ ambient 1 diffuse 0 }} }}
"""
KINDS = ["linear_spline", "quadratic_spline", "cubic_spline", "natural_spline"]
POINTS = """-0.2, <0, 0.1, 0.9>, 0, <0.1, 0.9, 0.2>, 0.3, <0.5, 0.2, 0.7>,
  0.55, <0.7, 0.8, 0.1>, 0.8, <0.9, 0.3, 0.5>, 1.2, <1, 0.6, 0.3>"""


@pytest.mark.povray
@pytest.mark.parametrize("kind", KINDS)
@pytest.mark.parametrize(
    "expr", ["F(x).y", "abs(F(x * 1.4 - 0.2).z - y)", "F(y).x * 0.5 + F(x).z * 0.5"]
)
def test_spline_of_the_parameters_renders_as_povray(tmp_path, kind, expr):
    text = SCENE.format(kind=kind, expr=expr, points=POINTS)
    ours, messages = strala_image(text, tmp_path, 96, 72)
    assert messages == [], messages
    rmse, off = image_errors(ours, povray_image(text, tmp_path, 96, 72))
    assert rmse < 0.005 and off < 0.002, (rmse, off)


# four points or more: what every kind is defined for
knot_gaps = st.lists(st.floats(0.05, 2.0), min_size=3, max_size=7)
values = st.floats(-5.0, 5.0, allow_nan=False)


@settings(max_examples=60, deadline=None)
@given(
    kind=st.sampled_from(KINDS),
    start=st.floats(-3.0, 3.0),
    gaps=knot_gaps,
    data=st.data(),
)
def test_pieces_are_the_spline(kind, start, gaps, data):
    ts = [start]
    for g in gaps:
        ts.append(ts[-1] + g)
    points = [Vec(data.draw(st.tuples(values, values))) for _ in ts]
    sp = SplineValue(kind, tuple(zip(ts, points, strict=True)))
    probes = data.draw(st.lists(st.floats(ts[0] - 1, ts[-1] + 1), min_size=1, max_size=8))
    for component in (0, 1):
        knots, coeffs = cubic_pieces(sp, component)
        piece = ir.FnSpline(knots, coeffs, ir.FnArg(0, "t"))
        fn = compile_function(ir.Function(("t",), piece, "float"))
        for t in probes:
            want = evaluate_spline(sp, t)[component]
            assert spline_piece_value(piece, t) == pytest.approx(want, rel=1e-9, abs=1e-9)
            assert float(fn(t)) == pytest.approx(want, rel=1e-9, abs=1e-9)
