"""Triangle objects as solids (runtime.triangle_solids): meshes with inside_vector and
height fields inside CSG, clipped and clipping, their shadows, `inverse`, and inside() at
parse time, against POV-Ray; and the crossings and inside tests against analytic ones."""

from __future__ import annotations

import functools

import numpy as np
import pytest
from conftest import image_errors, povray_image, strala_image
from hypothesis import given, settings
from hypothesis import strategies as st

from lang import ir
from runtime.functions import compile_xyz
from runtime.heightfield import height_field_mesh, heights
from runtime.shapes import BoxPrim
from runtime.triangle_solids import HeightFieldInside, triangle_node

HEAD = """#version 3.7;
global_settings { assumed_gamma 1.0 }
camera { location <2.5, 3, -4> look_at <0, 0, 0> angle 40 }
light_source { <5, 8, -6> rgb 1 }
background { rgb <0.2, 0.3, 0.4> }
plane { y, -1.01 pigment { checker rgb 1 rgb 0.5 } }
// a cube of side 2 around the origin, each face two triangles
#declare Cube = mesh2 {
  vertex_vectors { 8, <-1,-1,-1>, <1,-1,-1>, <1,1,-1>, <-1,1,-1>,
                      <-1,-1,1>, <1,-1,1>, <1,1,1>, <-1,1,1> }
  face_indices { 12, <0,1,2>, <0,2,3>, <4,6,5>, <4,7,6>, <0,4,5>, <0,5,1>,
                     <3,2,6>, <3,6,7>, <0,3,7>, <0,7,4>, <1,5,6>, <1,6,2> }
  inside_vector <0.3, 0.7, 0.2>
}
"""
ORANGE = "pigment { rgb <1, 0.6, 0.2> }"
SCENES = {
    "difference": f"difference {{ object {{ Cube }} sphere {{ <0.8, 0.8, -0.8>, 1.1 }} {ORANGE} }}",
    "two meshes": "intersection { object { Cube } object { Cube rotate <30, 40, 10> scale 1.1 } "
    f"{ORANGE} }}",
    "inverse": f"intersection {{ sphere {{ <0.8, 0.8, -0.8>, 1.1 }} object {{ Cube inverse }} "
    f"{ORANGE} }}",
    # the light falls through the hole onto the floor
    "shadow": "difference { object { Cube translate 0.4*y } cylinder { -2*y, 2*y, 0.6 } "
    f"{ORANGE} }}",
    "clipped by a mesh": f"sphere {{ 0, 1.25 clipped_by {{ object {{ Cube }} }} {ORANGE} }}",
    "inside()": """#declare T = object { Cube rotate 30*y }
#for (i, -6, 6) #for (j, -6, 6) #local P = <i/4, 0, j/4>;
  #if (inside(T, P)) sphere { P, 0.1 pigment { rgb <1, 0.2, 0.2> } } #end
#end #end""",
}

FIELD = """#version 3.7;
global_settings { assumed_gamma 1.0 }
camera { location <0, 4, -5> look_at <0, 0.3, 0> angle 45 }
light_source { <5, 8, -6> rgb 1 }
background { rgb <0.2, 0.3, 0.4> }
#declare H = height_field { function 40, 40 { 0.5 + 0.4*sin(x*8)*cos(y*6) } WATER
  translate <-0.5, 0, -0.5> scale <3, 1, 3> }
// a height field clipped by a cylinder, and a cylinder clipped by the height field
object { H clipped_by { cylinder { -2*y, 2*y, 1 } } pigment { rgb <0.4, 0.9, 0.3> } }
cylinder { <-1.2, -1, 0.8>, <-1.2, 2, 0.8>, 0.3 clipped_by { object { H } }
  pigment { rgb <1, 0.3, 0.3> } }
difference { sphere { <0.9, 0.5, -0.9>, 0.5 } object { H } pigment { rgb <0.3, 0.4, 1> } }
"""


@pytest.mark.povray
@pytest.mark.parametrize("name", SCENES)
def test_mesh_with_inside_vector_in_csg_renders_like_povray(tmp_path, name):
    text = HEAD + SCENES[name]
    ours, messages = strala_image(text, tmp_path, 96, 72)
    assert messages == []  # inside_vector is used, not ignored
    rmse, off = image_errors(ours, povray_image(text, tmp_path, 96, 72))
    assert rmse < 0.01 and off < 0.005, (rmse, off)


@pytest.mark.povray
@pytest.mark.parametrize("water", ["", "water_level 0.45"])
def test_height_field_clips_and_is_clipped_like_povray(tmp_path, water):
    text = FIELD.replace("WATER", water)
    ours, messages = strala_image(text, tmp_path, 96, 72)
    assert messages == []
    rmse, off = image_errors(ours, povray_image(text, tmp_path, 96, 72))
    if not water:
        assert rmse < 0.005 and off < 0.002, (rmse, off)
    else:  # the mesh leaves out the cells under water that POV-Ray floors at the water
        assert rmse < 0.03 and off < 0.01, (rmse, off)


# ------------------------------------------------------------------ unit tests
_CUBE = ir.Mesh(
    vertices=tuple(
        (float(x), float(y), float(z)) for z in (-1, 1) for y in (-1, 1) for x in (-1, 1)
    ),
    # corners indexed x + 2y + 4z (0/1 for -1/+1), two triangles per face
    faces=(
        (0, 1, 3),
        (0, 3, 2),
        (4, 7, 5),
        (4, 6, 7),
        (0, 4, 5),
        (0, 5, 1),
        (2, 3, 7),
        (2, 7, 6),
        (0, 2, 6),
        (0, 6, 4),
        (1, 5, 7),
        (1, 7, 3),
    ),  # fmt: skip
    inside_vector=(0.3, 0.7, 0.2),
)


def _cube_node(inverse: bool = False):
    obj = ir.Object(shape=_CUBE, inverse=inverse)
    return triangle_node(obj, 0, compile_xyz)


coord = st.floats(-2.0, 2.0, allow_nan=False)


@settings(max_examples=30, deadline=None)
@given(st.lists(st.tuples(coord, coord, coord), min_size=1, max_size=20))
def test_parity_inside_of_a_closed_mesh_is_the_solids(points):
    p = np.array(points)
    # off the faces (a point on one is on either side)
    p = p[np.all(np.abs(np.abs(p) - 1) > 1e-6, axis=1)]
    box = BoxPrim((-1, -1, -1), (1, 1, 1))
    node = _cube_node()
    assert np.array_equal(node.inside(p), box.inside(p))
    assert np.array_equal(_cube_node(inverse=True).inside(p), ~box.inside(p))
    assert np.array_equal(node.inside(p, inverted=True), ~box.inside(p))


@settings(max_examples=30, deadline=None)
@given(
    st.tuples(coord, coord, coord).map(lambda v: np.array(v) * 3),
    st.tuples(coord, coord, coord).filter(lambda v: np.linalg.norm(v) > 0.1),
)
def test_crossings_of_a_mesh_are_every_crossing_of_its_surface(origin, direction):
    o, d = origin[None], np.array(direction, dtype=np.float64)[None]
    c = _cube_node().crossings(o, d)
    got = np.sort(c.t[np.isfinite(c.t)])
    t, _ = BoxPrim((-1, -1, -1), (1, 1, 1)).crossings(o, d)
    want = np.sort(t[np.isfinite(t) & (t > 1e-9)])
    if len(want) == 2 and abs(want[1] - want[0]) < 1e-6:
        return  # through an edge or a corner: one crossing or two
    assert np.allclose(got, want, atol=1e-9), (got, want)
    assert np.all(c.prim[np.isfinite(c.t)] >= 0)


def test_a_mesh_without_inside_vector_has_no_inside_nor_its_inverse():
    obj = ir.Object(shape=ir.Mesh(vertices=_CUBE.vertices, faces=_CUBE.faces), inverse=True)
    node = triangle_node(obj, 0, compile_xyz)
    p = np.array([[0.0, 0, 0], [5, 5, 5]])
    assert not node.inside(p).any()
    assert not node.inside(p, inverted=True).any()


@functools.cache
def _field(src: str) -> ir.HeightField:
    from lang.evaluate import compile_source

    shape = compile_source(src, "t.pov").scene.objects[0].shape
    assert isinstance(shape, ir.HeightField)
    return shape


@settings(max_examples=20, deadline=None)
@given(st.floats(0.001, 0.999), st.floats(0.001, 0.999), st.sampled_from([0.0, 0.3, 0.55]))
def test_height_field_inside_is_below_its_triangles(x, z, water):
    """Just below the surface the triangles make (found by a ray straight down) is inside,
    just above is not; below the water level is inside."""
    shape = _field(f"height_field {{ function 9, 7 {{ 0.5 + 0.4*sin(x*8)*cos(y*6) }} "
                   f"water_level {water} }}")  # fmt: skip
    rule = HeightFieldInside(shape, np.eye(4), compile_xyz)
    mesh = height_field_mesh(shape, compile_xyz)
    node = triangle_node(ir.Object(shape=mesh), 0, compile_xyz)
    c = node.crossings(np.array([[x, 5.0, z]]), np.array([[0.0, -1.0, 0.0]]))
    t = c.t[np.isfinite(c.t)]
    below_water = np.array([[x, max(water, 0.1) - 0.05, z]])
    assert rule.inside(node, below_water)[0]
    if len(t) == 0:  # wholly under water here: the water is the surface
        return
    y = 5.0 - t.min()
    grid = heights(shape, compile_xyz)[::-1]  # row 0 at z = 0
    cx, cz = int(x * (grid.shape[1] - 1)), int(z * (grid.shape[0] - 1))
    if grid[cz : cz + 2, cx : cx + 2].min() <= water:
        return  # a cell the water floors: POV-Ray's surface there is not the mesh's
    assert rule.inside(node, np.array([[x, y - 1e-7, z]]))[0]
    assert not rule.inside(node, np.array([[x, y + 1e-7, z]]))[0]
    assert not rule.inside(node, np.array([[x + 1.0, y - 1e-7, z]]))[0]  # off the square
