"""Boxes of CSG intersections of planes and quadrics (runtime/csg_bounds.py): every point the
intersection holds, and every crossing of a ray with it, lies in its box (sampled, with
random shapes, turns and planes), and the shapes.inc way of writing a bounded quadric gets a
box at all (it had none: every ray tested it)."""

from __future__ import annotations

import math

import numpy as np
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from runtime import api
from runtime.prepare import prepare

QUADRICS = {
    "ellipsoid": "quadric { <1, 1, 1>, <0, 0, 0>, <0, 0, 0>, -1 }",
    "cylinder": "quadric { <1, 0, 1>, <0, 0, 0>, <0, 0, 0>, -1 }",
    "hyperboloid": "quadric { <1, -1, 1>, <0, 0, 0>, <0, 0, 0>, -1 }",
    "cone": "quadric { <1, -1, 1>, <0, 0, 0>, <0, 0, 0>, 0 }",
    "paraboloid": "quadric { <1, 0, 1>, <0, 0, 0>, <0, -1, 0>, 0 }",
    "saddle": "quadric { <1, -1, 0>, <0, 0, 0>, <0, 0, 1>, 0 }",
}


def _root(text: str):
    scene = api.compile_string(
        "camera { location <0, 0, -30> look_at 0 } light_source { <5, 9, -9>, rgb 1 }" + text
    ).scene
    tracer = prepare(scene, 16, 12).tracer
    assert len(tracer.nodes) == 1
    return tracer.nodes[0]


def test_a_hyperboloid_between_planes_has_a_box():
    node = _root(
        "intersection { quadric { <1, -1, 1>, <0, 0, 0>, <0, 0, 0>, -1 }"
        " plane { y, 5.5 } plane { -y, -2.5 } scale <0.5, 1, 0.5> translate <3, 0, 1> }"
    )
    assert node.bounded
    reach = 0.5 * math.sqrt(1 + 5.5**2)  # the widest ring, at the top plane
    assert np.allclose(node.lo, [3 - reach, 2.5, 1 - reach], atol=1e-5)
    assert np.allclose(node.hi, [3 + reach, 5.5, 1 + reach], atol=1e-5)


def test_a_turned_ellipsoid_and_a_paraboloid_under_a_plane_have_their_boxes():
    turned = _root(
        "intersection { quadric { <1, 1, 1>, <0, 0, 0>, <0, 0, 0>, -1 } plane { y, 10 }"
        " scale <3, 1, 1> rotate z * 90 }"
    )
    assert np.allclose(turned.lo, [-1, -3, -1], atol=1e-5)
    assert np.allclose(turned.hi, [1, 3, 1], atol=1e-5)
    # x^2 + z^2 <= y, y <= 4: a bowl of radius 2
    bowl = _root("intersection { quadric { <1, 0, 1>, <0, 0, 0>, <0, -1, 0>, 0 } plane { y, 4 } }")
    assert np.allclose(bowl.lo, [-2, 0, -2], atol=1e-5)
    assert np.allclose(bowl.hi, [2, 4, 2], atol=1e-5)


def test_tilted_planes_bound_a_prism_and_leave_a_wedge_unbounded():
    prism = _root(
        "intersection { plane { <1, 1, 0>, 1 } plane { <-1, 1, 0>, 1 } plane { -y, 1 }"
        " plane { z, 2 } plane { -z, 2 } }"
    )
    assert prism.bounded
    # (POV-Ray's plane distance is along the unit normal: x + y <= sqrt 2)
    r2 = math.sqrt(2)
    assert np.allclose(prism.lo, [-1 - r2, -1, -2], atol=1e-5)
    assert np.allclose(prism.hi, [1 + r2, r2, 2], atol=1e-5)
    wedge = _root("intersection { plane { <1, 1, 0>, 1 } plane { <-1, 1, 0>, 1 } }")
    assert not wedge.bounded  # open downwards: a box would cut it
    assert wedge.hi[1] >= r2 - 1e-6 and wedge.lo[1] == -np.inf


# quarter turns most often (shapes.inc's quadrics are turned so), any turn too
_angle = st.one_of(st.sampled_from([0.0, 90.0, 180.0, -90.0]), st.floats(-180, 180))
_turn = st.tuples(_angle, _angle, _angle)
_move = st.tuples(*[st.floats(-5, 5)] * 3)
_size = st.tuples(*[st.floats(0.3, 3)] * 3)
_plane = st.tuples(
    st.sampled_from(["x", "y", "z", "-x", "-y", "-z", "<1, 1, 0>", "<0, -1, 2>", "<1, 2, 3>"]),
    st.floats(-3, 3),
)


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(
    kind=st.sampled_from(sorted(QUADRICS)),
    size=_size,
    turn=_turn,
    move=_move,
    planes=st.lists(_plane, min_size=1, max_size=5),
    seed=st.integers(0, 2**32 - 1),
)
def test_every_point_and_crossing_of_an_intersection_lies_in_its_box(
    kind, size, turn, move, planes, seed
):
    cuts = " ".join(f"plane {{ {n}, {d} }}" for n, d in planes)
    node = _root(
        f"intersection {{ object {{ {QUADRICS[kind]} scale <{size[0]}, {size[1]}, {size[2]}>"
        f" rotate <{turn[0]}, {turn[1]}, {turn[2]}> }} {cuts} translate <{move[0]}, {move[1]},"
        f" {move[2]}> }}"
    )
    rng = np.random.default_rng(seed)
    pts = rng.uniform(-40, 40, size=(20000, 3))
    # points inside the intersection lie in the box
    inside = pts[node.inside(pts)]
    lo, hi = node.lo, node.hi
    assert np.all(inside >= lo) and np.all(inside <= hi), (lo, hi)
    # so do the crossings of rays through the region
    o = rng.uniform(-40, 40, size=(2000, 3))
    d = rng.normal(size=(2000, 3))
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    t = node.crossings(o, d).t
    rows, cols = np.nonzero(np.isfinite(t))
    hits = o[rows] + t[rows, cols, None] * d[rows]
    assert np.all(hits >= lo) and np.all(hits <= hi), (lo, hi)
