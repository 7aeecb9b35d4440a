"""lathe and sor through the compiled kernel (kernel/lathe.h): the same pixels as the numpy
path, its reference (runtime.prims.lathe), for every spline kind, open and capped,
transformed and inverse, in CSG and as a clip, seen from above, below and exactly side-on
(the rays of constant height take their own branch). Metric: the largest channel
difference of the two working-space images, < 1e-9 (the kernel repeats numpy's arithmetic
in its order)."""

from __future__ import annotations

import pytest
from conftest import same_on_kernel_and_numpy
from hypothesis import given, settings
from hypothesis import strategies as st

HEAD = """#version 3.7;
global_settings { assumed_gamma 1 }
camera { %s }
light_source { <-4, 6, -5>, rgb 1 }
light_source { <5, 2, -3>, rgb 0.4 }
plane { y, -1.5 pigment { checker rgb 1 rgb 0.3 } }
"""
PERSPECTIVE = "location <0, 2.5, -5> look_at <0, 0.3, 0>"
# horizontal rays: every camera ray keeps its height (the flat branch)
SIDE_ON = "orthographic location <0, 0.4, -6> look_at <0, 0.4, 0> right x*4 up y*3"
PROFILES = {
    "linear_spline": "7, <0, -1>, <1, -1>, <1.2, 0>, <0.5, 0.4>, <0.8, 1.2>, <0.3, 1.3>, <0, 1.3>",
    "quadratic_spline": "6, <0, -1>, <0, -1>, <1.1, -0.5>, <0.4, 0.5>, <0.9, 1.2>, <0, 1.3>",
    "cubic_spline": "7, <0, -1.2>, <0, -1>, <1.0, -0.6>, <0.5, 0.3>, <1.0, 1.0>, <0, 1.2>,"
    " <0, 1.4>",
    "bezier_spline": "8, <0, -1>, <1.5, -1>, <1.2, 0>, <0.6, 0.3>, <0.6, 0.3>, <0, 0.6>,"
    " <1.4, 1.2>, <0, 1.3>",
}


def _lathe(kind: str, extra: str = "") -> str:
    return f"lathe {{ {kind} {PROFILES[kind]} {extra} pigment {{ rgb <1, 0.6, 0.2> }} }}"


@pytest.mark.parametrize("camera", [PERSPECTIVE, SIDE_ON])
@pytest.mark.parametrize("kind", sorted(PROFILES))
def test_every_spline_renders_as_the_numpy_path(monkeypatch, kind, camera):
    image = same_on_kernel_and_numpy(HEAD % camera + _lathe(kind, "rotate z*15"), monkeypatch)
    assert image.std() > 0.05  # the lathe is in the picture


@pytest.mark.parametrize(
    "item",
    [
        "difference { %s sphere { <0.4, 0.6, -0.5>, 0.7 } }",
        "intersection { %s box { <-2, -2, -2>, <2, 0.5, 2> } }",
        "union { %s sphere { <1.2, 0, 0>, 0.5 } }",
        "object { %s inverse clipped_by { sphere { 0, 2 } } }",
        "sphere { 0, 2 clipped_by { %s } pigment { rgb 0.8 } }",
        "object { %s scale <1, 0.6, 1.3> rotate x*-30 translate <0.3, 0, 0> }",
    ],
)
def test_in_csg_clipped_and_transformed_as_the_numpy_path(monkeypatch, item):
    text = HEAD % PERSPECTIVE + item % _lathe("cubic_spline")
    same_on_kernel_and_numpy(text, monkeypatch)


def test_glass_lathe_as_the_numpy_path(monkeypatch):
    """Refraction through it: the inside test and the crossings from within."""
    glass = "pigment { rgbf <1, 1, 1, 0.9> } finish { reflection 0.1 } interior { ior 1.5 }"
    text = HEAD % PERSPECTIVE + f"lathe {{ bezier_spline {PROFILES['bezier_spline']} {glass} }}"
    same_on_kernel_and_numpy(text, monkeypatch)


@settings(max_examples=20, deadline=None)
@given(
    kind=st.sampled_from(sorted(PROFILES)),
    points=st.lists(st.tuples(st.floats(0.0, 1.5), st.floats(-1.2, 1.4)), min_size=8, max_size=12),
    tilt=st.floats(-60, 60),
)
def test_any_profile_renders_as_the_numpy_path(kind, points, tilt):
    """Random profiles (self-crossing, doubled points, flat runs included), tilted."""
    n = len(points) - len(points) % 4 if kind == "bezier_spline" else len(points)
    body = ", ".join(f"<{x}, {y}>" for x, y in points[:n])
    text = HEAD % PERSPECTIVE + (
        f"lathe {{ {kind} {n}, {body} rotate x*{tilt} pigment {{ rgb <1, 0.6, 0.2> }} }}"
    )
    with pytest.MonkeyPatch.context() as mp:
        same_on_kernel_and_numpy(text, mp, 40, 30)


SOR = "sor { 7, <0, -1.2>, <0.6, -1>, <1.0, -0.5>, <0.4, 0.2>, <0.8, 0.9>, <0.5, 1.3>, <0.2, 1.5>"


@pytest.mark.parametrize("camera", [PERSPECTIVE, SIDE_ON, "location <0, -3, -4> look_at 0"])
@pytest.mark.parametrize("extra", ["", "open", "sturm", "inverse", "open rotate x*-35 scale 1.2"])
def test_sor_renders_as_the_numpy_path(monkeypatch, camera, extra):
    text = HEAD % camera + f"{SOR} {extra} pigment {{ rgb <0.3, 0.7, 1> }} }}"
    same_on_kernel_and_numpy(text, monkeypatch)


def test_sor_in_csg_and_glass_as_the_numpy_path(monkeypatch):
    glass = "pigment { rgbf <1, 1, 1, 0.9> } interior { ior 1.4 }"
    text = HEAD % PERSPECTIVE + (
        f"difference {{ {SOR} }} sphere {{ <0.5, 0.5, -0.5>, 0.6 }} pigment {{ rgb 1 }} }}"
        f"{SOR} {glass} translate x*1.5 }}"
    )
    same_on_kernel_and_numpy(text, monkeypatch)


@settings(max_examples=15, deadline=None)
@given(
    radii=st.lists(st.floats(0.05, 1.5), min_size=5, max_size=9),
    tilt=st.floats(-60, 60),
    is_open=st.booleans(),
)
def test_any_sor_renders_as_the_numpy_path(radii, tilt, is_open):
    """Random profiles (heights increasing, as POV-Ray requires), tilted, open or capped."""
    points = ", ".join(f"<{r}, {-1.2 + 0.35 * i}>" for i, r in enumerate(radii))
    text = HEAD % PERSPECTIVE + (
        f"sor {{ {len(radii)}, {points} {'open' if is_open else ''} rotate x*{tilt}"
        " pigment { rgb <0.3, 0.7, 1> } }"
    )
    with pytest.MonkeyPatch.context() as mp:
        same_on_kernel_and_numpy(text, mp, 40, 30)
