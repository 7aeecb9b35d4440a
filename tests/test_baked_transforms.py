"""Shapes whose transform prepare bakes into them, traced without a matrix with the same
crossings as through it: a sphere moved, turned and scaled alike on every axis stays a
sphere (similar_sphere, as POV-Ray's Sphere::Scale keeps one; other transforms keep the
matrix), a polygon's points move. And equal solid colours moved apart shade as one
texture."""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from lang import ir, transforms
from runtime import api, integrate
from runtime.prepare import prepare, similar_sphere
from runtime.shapes import SpherePrim
from runtime.trace import Leaf

_vec = st.tuples(*[st.floats(-10, 10)] * 3)


def _matrix(scale, turn, move) -> ir.Matrix:
    m = transforms.scale((scale, scale, scale))
    m = transforms.compose(transforms.rotate(turn), m)
    return transforms.compose(transforms.translate(move), m)


@settings(max_examples=80, deadline=None)
@given(
    centre=_vec,
    radius=st.floats(0.1, 5),
    scale=st.floats(0.05, 20),
    turn=st.tuples(*[st.floats(-180, 180)] * 3),
    move=_vec,
    seed=st.integers(0, 2**32 - 1),
)
def test_a_similar_sphere_has_the_crossings_of_its_matrix(centre, radius, scale, turn, move, seed):
    m = _matrix(scale, turn, move)
    placed = similar_sphere(ir.Sphere(centre, radius), m)
    assert placed is not None
    plain = Leaf(SpherePrim(*placed), None, 0)
    moved = Leaf(SpherePrim(centre, radius), np.asarray(m, dtype=np.float64), 0)
    rng = np.random.default_rng(seed)
    o = np.asarray(placed[0]) + rng.uniform(-50, 50, size=(500, 3))
    aim = np.asarray(placed[0]) + rng.uniform(-1, 1, size=(500, 3)) * placed[1]
    d = aim - o
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    a, b = plain.crossings(o, d).t, moved.crossings(o, d).t
    a, b = np.sort(a, axis=1), np.sort(b, axis=1)
    both = np.isfinite(a) & np.isfinite(b)
    assert (np.isfinite(a) == np.isfinite(b)).mean() > 0.99  # grazing rays may differ
    assert np.allclose(a[both], b[both], rtol=1e-9, atol=1e-9 * placed[1])


def test_other_transforms_keep_their_matrix():
    sphere = ir.Sphere((0.0, 0.0, 0.0), 1.0)
    assert similar_sphere(sphere, transforms.scale((1.0, 2.0, 1.0))) is None
    shear = ((1.0, 0.3, 0.0, 0.0), (0.0, 1.0, 0.0, 0.0), (0.0, 0.0, 1.0, 0.0), (0, 0, 0, 1.0))
    assert similar_sphere(sphere, shear) is None
    mirror = transforms.scale((-2.0, 2.0, 2.0))
    assert similar_sphere(sphere, mirror) == ((0.0, 0.0, 0.0), 2.0)


def test_a_fractal_of_moved_spheres_traces_plain_spheres_with_one_texture():
    text = (
        "camera { location <0, 0, -9> look_at 0 } light_source { <5, 5, -5>, rgb 1 }"
        "#declare T = texture { pigment { rgb <0.9, 0.8, 0.2> } finish { phong 0.5 } }"
        "#declare S = sphere { 0, 1 texture { T } }"
        "#declare I = 0; #while (I < 3)"
        "#declare S = union { object { S } object { S scale 0.5 translate x }"
        " object { S scale 0.5 rotate y * 45 translate -y } } #declare I = I + 1; #end\n"
        "object { S rotate z * 30 }"
    )
    prepared = prepare(api.compile_string(text).scene, 16, 12)
    leaves = prepared.tracer.nodes
    assert len(leaves) == 27 and all(leaf.identity for leaf in leaves)
    assert len(integrate.make_context(prepared).textures) == 1


@settings(max_examples=40, deadline=None)
@given(
    scale=st.tuples(*[st.floats(0.2, 5)] * 3),
    turn=st.tuples(*[st.floats(-180, 180)] * 3),
    move=_vec,
    seed=st.integers(0, 2**32 - 1),
)
def test_a_moved_polygon_has_the_crossings_of_its_matrix(scale, turn, move, seed):
    from runtime.shapes import PolygonPrim

    # a square with a square hole, then a triangle: two sub-polygons
    points = [(0, 0, 0), (2, 0, 0), (2, 2, 0), (0, 2, 0), (0, 0, 0), (0.5, 0.5, 0),
              (1.5, 0.5, 0), (1, 1.5, 0), (0.5, 0.5, 0)]  # fmt: skip
    text = f"polygon {{ {len(points)}, " + ", ".join(f"<{x}, {y}, {z}>" for x, y, z in points)
    text += f" scale <{scale[0]}, {scale[1]}, {scale[2]}> rotate <{turn[0]}, {turn[1]}, {turn[2]}>"
    text += f" translate <{move[0]}, {move[1]}, {move[2]}> }}"
    scene = api.compile_string("camera { location -9*z look_at 0 }" + text).scene
    leaf = prepare(scene, 16, 12).tracer.nodes[0]
    assert leaf.identity
    m = np.asarray(scene.objects[0].transform, dtype=np.float64)
    moved = Leaf(PolygonPrim(points), m, 0)
    rng = np.random.default_rng(seed)
    centre = m[:3, :3] @ np.array([1.0, 1.0, 0.0]) + m[:3, 3]
    o = centre + rng.uniform(-20, 20, size=(400, 3))
    d = centre + rng.uniform(-3, 3, size=(400, 3)) * np.array(scale) - o
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    a, b = leaf.crossings(o, d).t[:, 0], moved.crossings(o, d).t[:, 0]
    assert (np.isfinite(a) == np.isfinite(b)).mean() > 0.99  # rays along an edge may differ
    both = np.isfinite(a) & np.isfinite(b)
    assert np.allclose(a[both], b[both], rtol=1e-9, atol=1e-9)
