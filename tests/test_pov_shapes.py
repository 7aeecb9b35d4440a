"""The evaluator's reading of POV-Ray's free-form shapes (lang/eval/data_shapes.py): their data
becomes IR shapes, their mistakes diagnostics at the right place."""

from __future__ import annotations

import math
from pathlib import Path

import pytest
from hypothesis import given
from hypothesis import strategies as st

from lang import ir
from lang.eval.data_shapes import poly_size, poly_terms
from lang.evaluate import compile_source

FONTS = Path("/usr/share/povray-3.7/include")


def shape_of(src: str):
    res = compile_source(src)
    errors = [d for d in res.diagnostics if d.severity.name == "ERROR"]
    assert not errors, errors
    (obj,) = res.scene.objects
    return obj


def first_error(src: str):
    res = compile_source(src)
    errors = [d for d in res.diagnostics if d.severity.name == "ERROR"]
    assert errors
    return errors[0]


def test_quadric_coefficients_in_povray_order():
    obj = shape_of("quadric { <1, 2, 3>, <4, 5, 6>, <7, 8, 9>, -10 }")
    terms = {(i, j, k): c for i, j, k, c in obj.shape.terms}
    assert terms == {
        (2, 0, 0): 1, (0, 2, 0): 2, (0, 0, 2): 3, (1, 1, 0): 4, (1, 0, 1): 5,
        (0, 1, 1): 6, (1, 0, 0): 7, (0, 1, 0): 8, (0, 0, 1): 9, (0, 0, 0): -10,
    }  # fmt: skip


def test_quartic_torus_of_the_povray_manual_is_the_torus_polynomial():
    """The torus written as a quartic: the terms must be those of
    (x²+y²+z²+R²−r²)² − 4R²(x²+z²), which fixes POV-Ray's term order for order 4."""
    R, r = 1.0, 0.3
    a, b = 2 * (R * R + r * r), 2 * (R * R - r * r)
    coef = [1, 0, 0, 0, 2, 0, 0, 2, 0, -a] + [0] * 10 + [1, 0, 0, 2, 0, b, 0, 0, 0, 0]
    coef += [1, 0, -a, 0, (R * R - r * r) ** 2]
    obj = shape_of("quartic { <" + ", ".join(map(str, coef)) + "> sturm }")
    assert obj.shape.order == 4 and obj.shape.sturm

    def f(x, y, z):
        return sum(c * x**i * y**j * z**k for i, j, k, c in obj.shape.terms)

    for p in [(1.3, 0, 0), (0, 0.3, 1), (0.5, 0.1, -0.7), (2, 1, 3)]:
        x, y, z = p
        want = (x * x + y * y + z * z + R * R - r * r) ** 2 - 4 * R * R * (x * x + z * z)
        assert f(*p) == pytest.approx(want, abs=1e-12)


@given(st.integers(2, 7))
def test_poly_term_order_lists_every_monomial_once(order):
    terms = poly_terms(order, [1.0] * poly_size(order))
    exps = [(i, j, k) for i, j, k, _ in terms]
    assert len(set(exps)) == len(exps) == poly_size(order)
    assert all(i + j + k <= order for i, j, k in exps)
    assert exps[0] == (order, 0, 0) and exps[-1] == (0, 0, 0)


def test_poly_with_the_wrong_number_of_coefficients():
    d = first_error("poly { 3, <1, 2, 3> }")
    assert "20 coefficients" in d.message and (d.span.line, d.span.col) == (1, 11)


def test_superellipsoid_and_its_bad_exponents():
    assert shape_of("superellipsoid { <0.25, 1> }").shape == ir.Superellipsoid(0.25, 1.0)
    assert "positive" in first_error("superellipsoid { <0, 1> }").message


def test_blob_components_new_and_old_forms_with_their_transforms():
    obj = shape_of(
        "blob { threshold 0.5\n"
        "  sphere { <1, 0, 0>, 2, strength 3 translate y }\n"
        "  cylinder { 0, x, 0.5, -1 }\n"
        "  component 2, 1.5, <0, 0, 4>\n"
        "  #for (I, 0, 2) sphere { I*z, 1, 1 } #end\n"
        "  pigment { rgb 1 } scale 2 }"
    )
    b = obj.shape
    assert b.threshold == 0.5 and len(b.components) == 6
    s, c, old = b.components[:3]
    assert (s.kind, s.a, s.radius, s.strength) == ("sphere", (1, 0, 0), 2, 3)
    assert s.transform[1][3] == 1.0  # the component's own translate y
    assert (c.kind, c.a, c.b, c.strength) == ("cylinder", (0, 0, 0), (1, 0, 0), -1)
    assert (old.kind, old.a, old.radius, old.strength) == ("sphere", (0, 0, 4), 1.5, 2)
    assert obj.transform[0][0] == 2.0  # the blob's own scale stays on the object


def test_sphere_outside_a_blob_is_still_a_sphere():
    res = compile_source("blob { sphere { 0, 1, 1 } }\nsphere { 0, 1 }")
    assert isinstance(res.scene.objects[1].shape, ir.Sphere)


def test_lathe_sor_prism():
    la = shape_of("lathe { cubic_spline 5, <0,0>, <1,0>, <1,1>, <0.5,2>, <0,2> }").shape
    assert la.spline == "cubic_spline" and la.points[3] == (0.5, 2.0)
    so = shape_of("sor { 4, <0,0>, <1,0>, <1,1>, <0,2> open }").shape
    assert so.open and len(so.points) == 4
    pr = shape_of(
        "prism { conic_sweep bezier_spline 0.1, 1, 4, <0,0>, <1,0>, <1,1>, <0,0> open }"
    ).shape
    assert (pr.sweep, pr.spline, pr.height1, pr.height2, pr.open) == (
        "conic_sweep", "bezier_spline", 0.1, 1.0, True,
    )  # fmt: skip


def test_lathe_that_lists_fewer_points_than_it_declares():
    d = first_error("lathe { linear_spline 4, <0,0>, <1,0>, <1,1> }")
    assert "declares 4 points but lists 3" in d.message


def test_sor_heights_must_increase():
    assert "increase" in first_error("sor { 4, <0,0>, <1,2>, <1,1>, <0,3> }").message


@pytest.mark.skipif(not (FONTS / "timrom.ttf").is_file(), reason="POV-Ray's fonts absent")
def test_text_resolves_the_font_with_or_without_extension():
    t = shape_of('text { ttf "timrom" "Hi", 0.25, <0.1, 0, 0> }').shape
    assert t.font.endswith("timrom.ttf") and t.string == "Hi" and t.thickness == 0.25
    assert t.offset == (0.1, 0.0, 0.0)
    internal = shape_of('text { internal 2 "x" 1, 0 }').shape
    assert internal.font.endswith("cyrvetic.ttf")


def test_missing_font_is_reported_at_its_name():
    d = first_error('text { ttf "no_such_font.ttf" "Hi", 1, 0 }')
    assert d.code == "E0220" and (d.span.line, d.span.col) == (1, 12)


def test_sphere_sweep_and_height_field(tmp_path):
    sw = shape_of("sphere_sweep { b_spline 4, 0, 0.1, x, 0.2, y, 0.3, z, 0.4 tolerance 0.01 }")
    assert sw.shape.spline == "b_spline" and sw.shape.spheres[2] == (0, 1, 0, 0.3)
    assert sw.shape.tolerance == 0.01
    d = first_error('height_field { png "missing.png" }')
    assert d.code == "E0220"


def test_poly_needs_a_vector():
    d = first_error("cubic { 1 }")
    assert "vector" in d.message


def test_every_new_shape_takes_object_modifiers():
    obj = shape_of("superellipsoid { <1, 1> pigment { rgb x } scale 2 rotate 90*y no_shadow }")
    assert obj.no_shadow and obj.texture.pigment is not None
    assert math.isclose(abs(obj.transform[0][2]), 2.0, abs_tol=1e-12)
