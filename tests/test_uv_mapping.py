"""`uv_mapping`: pigments, normals and textures evaluated at the surface's <u, v, 0> as each
shape's POV-Ray UVCoord gives it (runtime.uvmap), and left alone by the object's later
transformations (lang.ir_ops). Golden scenes against POV-Ray, and the uv functions."""

from __future__ import annotations

import math

import numpy as np
import pytest
from conftest import image_errors, povray_image, strala_image
from hypothesis import given
from hypothesis import strategies as st

from lang import ir
from lang.evaluate import compile_source
from runtime import uvmap

HEAD = """#version 3.7;
camera { location <0, 1.5, -4> look_at 0 angle 45 }
light_source { <-5, 5, -10> rgb 1 }
#declare C = pigment { checker rgb <1,0.3,0.2> rgb <0.1,0.2,0.9> scale <0.125, 0.25, 1> }
"""
QUAD = "vertex_vectors { 4, <-1,-1,0>, <1,-1,0>, <1,1,0>, <-1,1,0> }"
SCENES = {
    "sphere": "sphere { 0, 1 uv_mapping pigment { C } rotate <20, 30, 0> }",
    "torus": "torus { 1, 0.4 uv_mapping pigment { C } rotate <-30, 20, 0> }",
    "box": "box { -1, 1 uv_mapping pigment { checker rgb <1,0.3,0.2> rgb <0.1,0.2,0.9>"
    " scale 0.05 } rotate <10, 30, 0> scale 0.8 }",
    "lathe": "lathe { cubic_spline 6, <0.2,-1>, <0.5,-1>, <1,-0.3>, <0.6,0.5>, <0.8,1>,"
    " <0.5,1.4> uv_mapping pigment { C } rotate x*-10 }",
    "lathe_linear": "lathe { linear_spline 4, <0.2,-1>, <1,-0.5>, <0.6,0.5>, <0.8,1>"
    " uv_mapping pigment { C } }",
    "sor": "sor { 6, <0.2,-1.2>, <0.5,-1>, <1,-0.3>, <0.6,0.5>, <0.8,1>, <0.5,1.4>"
    " uv_mapping pigment { C } rotate x*-25 }",
    "mesh2_uv_vectors": f"mesh2 {{ {QUAD} uv_vectors {{ 4, <0,0>, <2,0>, <2,1>, <0,1.5> }}"
    " face_indices { 2, <0,1,2>, <0,2,3> } uv_mapping pigment { C } rotate <20, 30, 0> }",
    "mesh2_uv_indices": f"mesh2 {{ {QUAD}"
    " uv_vectors { 5, <0,0>, <2,0>, <2,1>, <0,1.5>, <1,3> }"
    " face_indices { 2, <0,1,2>, <0,2,3> } uv_indices { 2, <0,1,4>, <0,2,3> }"
    " uv_mapping pigment { C } rotate <20, 30, 0> }",
    # one uv vector and no uv_indices: every corner has it
    "mesh2_one_uv": f"mesh2 {{ {QUAD} uv_vectors {{ 1, <0.3,0.2> }}"
    " face_indices { 2, <0,1,2>, <0,2,3> } uv_mapping pigment { gradient x } rotate y*30 }",
    # no uv_vectors: every corner is <0, 0>, so the pattern's value there fills the mesh
    "mesh_without_uvs": "mesh { triangle { <-1,-1,0>, <1,-1,0>, <1,1,0> }"
    " triangle { <-1,-1,0>, <1,1,0>, <-1,1,0> }"
    " uv_mapping pigment { C translate <0.06, 0.1, 0> } rotate <20, 30, 0> }",
    # shapes without a UVCoord of their own read the world x and y
    "plane_and_cylinder": "plane { y, -1 uv_mapping pigment { C } }"
    " cylinder { -y, y, 0.5 texture { uv_mapping pigment { C } } translate x }",
    # texture-level uv_mapping, and a uv-mapped normal
    "texture_and_normal": "sphere { 0, 1 texture { uv_mapping pigment { C }"
    " normal { uv_mapping bumps 0.6 scale 0.05 } } scale 1.2 }",
    # the object's later transformations leave a uv-mapped texture alone
    "object_uv_mapping": "sphere { 0, 1 uv_mapping texture { pigment { C } }"
    " scale <1.5, 1, 1> rotate y*40 translate x*0.3 }",
    "nested_in_pigment_map": "sphere { 0, 1 pigment { gradient x pigment_map {"
    " [0.5 uv_mapping checker rgb 1 rgb 0 scale 0.1] [0.5 rgb <0.2,0.6,0.2>] } scale 2 }"
    " rotate y*30 }",
    "patterned_texture": "sphere { 0, 1 texture { uv_mapping checker"
    " texture { pigment { rgb <1,0.3,0.2> } }"
    " texture { pigment { rgb <0.1,0.2,0.9> } finish { phong 1 } }"
    " scale <0.125, 0.25, 1> } rotate y*30 }",
    # a CSG's uv_mapping reaches its children, even one with its own texture (POV-Ray's
    # Post_Process passes the flag down with the interior_texture)
    "csg_children": "union { sphere { 0, 1 } sphere { x*1.2, 0.6 texture { pigment { C } } }"
    " uv_mapping texture { pigment { C } } translate -x*0.5 rotate y*20 }",
    "in_normal_map": "sphere { 0, 1 pigment { rgb 0.8 } normal { gradient x normal_map {"
    " [0.5 uv_mapping bumps 0.8 scale 0.05] [0.5 uv_mapping checker 0.5 scale 0.1] } }"
    " rotate y*30 }",
    # light through a uv-mapped filtering checker: the shadow rays read it at uv too
    "shadow_through": "plane { z, 1.5 pigment { rgb 1 } } sphere { 0, 1 uv_mapping pigment {"
    " checker rgbf <1,0.3,0.2,0.8> rgb <0.1,0.2,0.9> scale <0.125, 0.25, 1> } rotate y*30 }",
}
# The bicubic patch: POV-Ray's triangles, a few edge pixels apart.
# Its `uv_vectors` place the corners of its (v, u) square in uv.
BICUBIC = (
    "bicubic_patch { type 1 flatness 0.01 u_steps 4 v_steps 4"
    " <-1,0,-1>, <-0.3,0.5,-1>, <0.3,-0.5,-1>, <1,0,-1>,"
    " <-1,0.5,-0.3>, <-0.3,1,-0.3>, <0.3,0,-0.3>, <1,0.5,-0.3>,"
    " <-1,-0.5,0.3>, <-0.3,0,0.3>, <0.3,1,0.3>, <1,-0.5,0.3>,"
    " <-1,0,1>, <-0.3,0.5,1>, <0.3,-0.5,1>, <1,0,1>"
    " uv_mapping pigment { C } rotate y*20 }"
)


@pytest.mark.povray
@pytest.mark.parametrize("name", sorted(SCENES))
def test_uv_mapping_renders_like_povray(tmp_path, name):
    text = HEAD + SCENES[name] + "\n"
    ours, messages = strala_image(text, tmp_path, 96, 72)
    assert not [m for m in messages if "uv" in m], messages
    rmse, off = image_errors(ours, povray_image(text, tmp_path, 96, 72))
    assert rmse < 0.005 and off < 0.002, (rmse, off)


@pytest.mark.povray
@pytest.mark.parametrize("corners", ["", "uv_vectors <0,0>, <2,0.5>, <3,3>, <0,1>"])
def test_bicubic_patch_uv_mapping_renders_like_povray(tmp_path, corners):
    text = HEAD + BICUBIC.replace("v_steps 4", "v_steps 4 " + corners) + "\n"
    ours, messages = strala_image(text, tmp_path, 96, 72)
    assert not [m for m in messages if "uv" in m], messages
    rmse, off = image_errors(ours, povray_image(text, tmp_path, 96, 72))
    assert rmse < 0.02 and off < 0.005, (rmse, off)


# ------------------------------------------------------------------ the evaluator
def _objects(src: str) -> tuple[ir.Object, ...]:
    result = compile_source(HEAD + src, "uv.pov")
    assert result.scene is not None
    return result.scene.objects


def test_uv_mapped_textures_stay_put_when_the_object_moves():
    obj, moved, plain = _objects(
        "sphere { 0, 1 uv_mapping pigment { C } scale 2 }\n"
        "sphere { 0, 1 pigment { uv_mapping checker scale 0.1 } scale 2 }\n"
        "sphere { 0, 1 pigment { C } scale 2 }\n"
    )
    assert obj.texture.uv_mapping and obj.texture.pigment.transform[0][0] == 0.125
    # inside the block the scale moves it; the object's scale does not
    assert moved.texture.pigment.params["uv_mapping"]
    assert moved.texture.pigment.transform[0][0] == pytest.approx(0.1)
    assert not plain.texture.uv_mapping and plain.texture.pigment.transform[0][0] == 0.25


def test_uv_mapping_after_the_texture_is_an_error_as_in_povray():
    result = compile_source(HEAD + "sphere { 0, 1 pigment { C } uv_mapping }\n", "uv.pov")
    assert any("before texture" in d.message for d in result.diagnostics)


def test_uv_mapping_is_no_longer_reported_as_ignored():
    result = compile_source(HEAD + SCENES["object_uv_mapping"] + "\n", "uv.pov")
    assert not [d for d in result.diagnostics if d.code == "W0308"]


def test_uv_mapped_textures_go_to_the_numpy_path():
    from runtime import whitted
    from runtime.prepare import prepare

    for src, expect in ((SCENES["sphere"], True), ("sphere { 0, 1 pigment { C } }", False)):
        scene = compile_source(HEAD + src, "uv.pov").scene
        assert scene is not None
        found = whitted.reasons(prepare(scene, 16, 12), scene.camera)
        assert ("uv_mapping" in found) is expect, found


# ------------------------------------------------------------------ the uv functions
def test_sphere_uv_at_the_axes():
    d = np.array([[1.0, 0, 0], [0, 0, 1.0], [-1.0, 0, 0], [0, 0, -1.0], [0, 1.0, 0], [0, -2.0, 0]])
    uv = uvmap.sphere_uv(d)
    assert np.allclose(uv[:4, 0], [0.0, 0.25, 0.5, 0.75]) and np.allclose(uv[:4, 1], 0.5)
    assert np.allclose(uv[4:], [[0.0, 1.0], [0.0, 0.0]])  # the poles: u 0


def test_torus_uv_outer_equator_and_top():
    uv = uvmap.torus_uv(np.array([[1.4, 0, 0], [1.0, 0.4, 0], [0, 0, 1.4]]), 1.0)
    assert np.allclose(uv, [[0.5, 0.5], [0.5, 0.75], [0.25, 0.5]])


def test_box_uv_face_centres_fall_in_their_atlas_cells():
    centres = np.array(
        [[-1.0, 0, 0], [1.0, 0, 0], [0, -1.0, 0], [0, 1.0, 0], [0, 0, -1.0], [0, 0, 1.0]]
    )
    uv = uvmap.box_uv(centres, (-1, -1, -1), (1, 1, 1))
    cells = np.floor(uv * [4, 3]).astype(int).tolist()
    assert cells == [[0, 1], [2, 1], [1, 0], [1, 2], [3, 1], [1, 1]]


@given(st.floats(-1e3, 1e3), st.floats(-1e3, 1e3))
def test_angle_about_y_is_the_angle_from_x_toward_z(x, z):
    u = float(uvmap.angle_about_y(np.array([x]), np.array([z]))[0])
    assert 0.0 <= u <= 1.0
    if x * x + z * z > 1e-6:
        expect = (math.atan2(z, x) % (2 * math.pi)) / (2 * math.pi)
        # POV-Ray's acos loses digits near the x axis (about 1e-8 of a turn)
        assert min(abs(u - expect), 1 - abs(u - expect)) < 1e-7


@given(
    st.lists(st.floats(-5, 5), min_size=6, max_size=6),
    st.floats(0, 1),
    st.floats(0, 1),
)
def test_mesh_uv_mixes_the_corner_uvs_by_the_barycentrics(corner, a, b):
    if a + b > 1:
        a, b = 1 - a, 1 - b
    uvs = np.array(corner).reshape(3, 2)
    mesh = ir.Mesh(vertices=np.eye(3), faces=np.array([[0, 1, 2]]), uvs=uvs)
    got = uvmap.mesh_uv(mesh, np.array([0]), np.array([[a, b]]))[0]
    assert np.allclose(got, (1 - a - b) * uvs[0] + a * uvs[1] + b * uvs[2])
    bare = ir.Mesh(vertices=np.eye(3), faces=np.array([[0, 1, 2]]))
    assert np.allclose(uvmap.mesh_uv(bare, np.array([0]), np.array([[a, b]])), 0.0)


def test_lathe_uv_v_counts_segments():
    shape = ir.Lathe("linear_spline", ((0.5, 0.0), (1.0, 1.0), (0.5, 2.0), (1.0, 3.0)))
    # along +x: the profile's points and a segment's middle
    p = np.array([[0.5, 0.0, 0], [1.0, 1.0, 0], [0.75, 1.5, 0], [1.0, 3.0, 0]])
    assert np.allclose(uvmap.lathe_uv(p, shape)[:, 1], [0.0, 1 / 3, 0.5, 1.0])


def test_sor_uv_v_by_height_and_on_the_caps():
    shape = ir.Sor(((0.5, -1.0), (1.0, 0.0), (1.0, 1.0), (1.0, 2.0), (0.5, 3.0)))
    p = np.array([[1.0, 0.0, 0], [1.0, 0.5, 0], [1.0, 1.0, 0], [1.0, 2.0, 0]])
    v = uvmap.sor_uv(p, shape)[:, 1]
    assert np.allclose(v[[1, 2]], [0.25, 0.5])
    # base cap (y 0, radius 1): r/R - 1 runs from -1 at the centre to 0 at the rim
    base = uvmap.sor_uv(np.array([[0.0, 0.0, 0.0], [0.5, 0.0, 0.0]]), shape)[:, 1]
    assert np.allclose(base, [-1.0, -0.5])
    top = uvmap.sor_uv(np.array([[0.0, 2.0, 0.0], [0.5, 2.0, 0.0]]), shape)[:, 1]
    assert np.allclose(top, [2.0, 1.5])
