"""lang.transforms: POV-Ray's matrix conventions, checked against numbers and against POV-Ray."""

from __future__ import annotations

import math

import pytest
from conftest import povray_debug
from hypothesis import given
from hypothesis import strategies as st

from lang import transforms as T
from lang.ir import IDENTITY

finite = st.floats(-100, 100, allow_nan=False, allow_infinity=False)
angles = st.floats(-360, 360, allow_nan=False, allow_infinity=False)
vec3 = st.tuples(finite, finite, finite)
nonzero = st.floats(0.1, 10) | st.floats(-10, -0.1)


def close(a, b, tol=1e-9):
    return all(abs(p - q) <= tol * (1 + abs(q)) for p, q in zip(a, b, strict=True))


def mclose(a, b, tol=1e-9):
    return all(close(r, s, tol) for r, s in zip(a, b, strict=True))


@st.composite
def affine(draw):
    m = T.rotate(draw(st.tuples(angles, angles, angles)))
    m = T.then(m, T.scale(draw(st.tuples(nonzero, nonzero, nonzero))))
    return T.then(m, T.translate(draw(vec3)))


def test_rotate_matches_pov_vrotate():
    # POV-Ray 3.7: vrotate(<1,2,3>, <10,20,30>) = <1.067425, 2.289059, 2.760581>
    p = T.apply_point(T.rotate((10, 20, 30)), (1, 2, 3))
    assert close(p, (1.067425, 2.289059, 2.760581), 1e-6)


def test_rotate_is_left_handed_x_then_y_then_z():
    assert close(T.apply_point(T.rotate((0, 90, 0)), (1, 0, 0)), (0, 0, -1), 1e-12)
    assert close(T.apply_point(T.rotate((90, 0, 0)), (0, 1, 0)), (0, 0, 1), 1e-12)
    assert close(T.apply_point(T.rotate((0, 0, 90)), (1, 0, 0)), (0, 1, 0), 1e-12)
    # x first, then y: (0,1,0) → x90 → (0,0,1) → y90 → (1,0,0)
    assert close(T.apply_point(T.rotate((90, 90, 0)), (0, 1, 0)), (1, 0, 0), 1e-12)


def test_pov_matrix_is_transposed_row_form():
    m = T.from_pov_matrix([1, 0, 0, 0, 1, 0, 0, 0, 1, 5, 6, 7])
    assert T.apply_point(m, (1, 1, 1)) == (6.0, 7.0, 8.0)
    shear = T.from_pov_matrix([1, 0, 0, 2, 1, 0, 0, 0, 1, 0, 0, 0])  # x' = x + 2y
    assert T.apply_point(shear, (0, 1, 0)) == (2.0, 1.0, 0.0)
    with pytest.raises(ValueError):
        T.from_pov_matrix([1, 2, 3])


def test_singular_inverse_raises():
    with pytest.raises(ZeroDivisionError):
        T.inverse(T.scale((1, 0, 1)))
    with pytest.raises(ZeroDivisionError):
        T.axis_rotate((0, 0, 0), 10)


@given(affine(), affine(), vec3)
def test_compose_applies_right_first(a, b, p):
    assert close(T.apply_point(T.compose(a, b), p), T.apply_point(a, T.apply_point(b, p)), 1e-7)
    assert mclose(T.then(b, a), T.compose(a, b), 1e-12)


@given(affine())
def test_inverse_is_inverse(m):
    assert mclose(T.compose(m, T.inverse(m)), IDENTITY, 1e-6)
    assert mclose(T.compose(T.inverse(m), m), IDENTITY, 1e-6)


@given(affine(), affine())
def test_inverse_of_product(a, b):
    lhs = T.inverse(T.compose(a, b))
    rhs = T.compose(T.inverse(b), T.inverse(a))
    assert mclose(lhs, rhs, 1e-5)


@given(st.tuples(angles, angles, angles), vec3)
def test_rotation_preserves_length(r, p):
    q = T.apply_point(T.rotate(r), p)
    assert math.isclose(
        math.dist(q, (0, 0, 0)), math.dist(p, (0, 0, 0)), rel_tol=1e-9, abs_tol=1e-9
    )


@given(vec3.filter(lambda a: math.dist(a, (0, 0, 0)) > 1e-3), angles, vec3)
def test_axis_rotation_fixes_axis_and_length(axis, deg, p):
    m = T.axis_rotate(axis, deg)
    assert close(T.apply_point(m, axis), axis, 1e-7)
    assert math.isclose(
        math.dist(T.apply_point(m, p), (0, 0, 0)),
        math.dist(p, (0, 0, 0)),
        rel_tol=1e-7,
        abs_tol=1e-7,
    )


def test_axis_rotate_agrees_with_rotate_about_axes():
    for axis, r in (((1, 0, 0), (30, 0, 0)), ((0, 1, 0), (0, 30, 0)), ((0, 0, 1), (0, 0, 30))):
        assert mclose(T.axis_rotate(axis, 30), T.rotate(r), 1e-12)


@given(affine(), vec3)
def test_normals_stay_perpendicular(m, d):
    # a tangent t on the plane with normal n stays perpendicular to the transformed normal
    n = (0.0, 0.0, 1.0)
    t = (d[0], d[1], 0.0)
    tn = T.apply_direction(m, t)
    nn = T.apply_normal(m, n)
    dot = sum(a * b for a, b in zip(tn, nn, strict=True))
    assert abs(dot) <= 1e-6 * (1 + math.dist(tn, (0, 0, 0)) * math.dist(nn, (0, 0, 0)))


CASES = [
    ("vrotate(<1,2,3>, <10,20,30>)", lambda: T.apply_point(T.rotate((10, 20, 30)), (1, 2, 3))),
    (
        "vrotate(<0.3,-2,5>, <-45,120,7>)",
        lambda: T.apply_point(T.rotate((-45, 120, 7)), (0.3, -2, 5)),
    ),
    ("vrotate(x, <0,90,0>)", lambda: T.apply_point(T.rotate((0, 90, 0)), (1, 0, 0))),
    (
        "vaxis_rotate(<1,2,3>, <1,1,0>, 30)",
        lambda: T.apply_point(T.axis_rotate((1, 1, 0), 30), (1, 2, 3)),
    ),
    (
        "vaxis_rotate(<-1,0.5,2>, <0.2,-1,3>, -75)",
        lambda: T.apply_point(T.axis_rotate((0.2, -1, 3), -75), (-1, 0.5, 2)),
    ),
]


@pytest.mark.povray
def test_against_povray(tmp_path):
    lines = [f'#debug concat(vstr(3, {expr}, ",", 0, 9), "\\n")' for expr, _ in CASES]
    src = tmp_path / "t.pov"
    src.write_text("\n".join(lines) + "\n")
    out = povray_debug(src)
    got = [ln for ln in out.splitlines() if ln.count(",") == 2 and ln[0] in "-0123456789"]
    assert len(got) == len(CASES), out[-2000:]
    for (expr, fn), line in zip(CASES, got, strict=True):
        pov = tuple(float(v) for v in line.split(","))
        assert close(fn(), pov, 1e-7), (expr, fn(), pov)
