"""POV-Ray 3.7's mesh_camera: rays from mesh faces, pixel for pixel as POV-Ray renders
them (each distribution, several meshes, transformed meshes, smooth on and off), and its
parser's rules."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import image_errors, povray_image, strala_image
from hypothesis import given, settings
from hypothesis import strategies as st

from lang import ir
from lang.evaluate import compile_source
from runtime.mesh_camera import MeshCameraRays

W, H = 64, 48

# What the cameras look at: a checker plane (ambient only), a lit sphere, a background;
# the patterns' edges are moved off the rays' rational start points (whose rounding
# differs from POV-Ray's in the last bits).
WORLD = """#version 3.7;
global_settings { assumed_gamma 1 }
background { rgb <0.2, 0.3, 0.5> }
plane { z, 3
  pigment { checker rgb <1, 0.8, 0.2>, rgb <0.1, 0.5, 0.2> scale 0.25 translate <0.013, 0.007, 0> }
  finish { ambient 1 diffuse 0 } }
sphere { <0.4, 0.2, 1.5>, 0.5
  pigment { gradient y color_map { [0 rgb x] [1 rgb z] } scale 0.4 translate 0.011*y }
  finish { ambient 0.2 diffuse 0.8 } }
light_source { <-3, 4, -5>, 1 }
"""

# A fan of tiny triangles, one per pixel of a Cols x Rows image (rows J0 .. J1-1, in
# POV-Ray's face order), each facing where a pinhole camera's ray would go; Flip swaps the
# winding, so POV-Ray's face normal points the other way.
FAN = """
#macro Fan(Cols, Rows, J0, J1, Flip)
mesh {
 #for (j, J0, J1 - 1) #for (i, 0, Cols - 1)
   #local C = <((i + 0.5) / Cols - 0.5) * 4 / 3, 0.5 - (j + 0.5) / Rows, 0>;
   #local N = vnormalize(<C.x * 0.8, C.y * 0.8, 1>);
   #local A = vnormalize(vcross(N, y)) * 0.001;
   #local B = vcross(N, A);
   #if (Flip) triangle { C + B, C + A, C - A - B }
   #else triangle { C + A, C + B, C - A - B } #end
 #end #end
}
#end
"""

# A uv-mapped grid over the image with smooth normals fanning out (towards -z), as
# `mesh` triangles with uv_vectors or as a mesh2 whose uvs have their own indices.
GRID = """
#declare NX = 8; #declare NY = 6;
#macro P(a, b) <(a / NX - 0.5) * 4 / 3, b / NY - 0.5, 0> #end
#macro Nm(a, b) vnormalize(<(a / NX - 0.5) * 1.1, (b / NY - 0.5) * 0.8, -1>) #end
#macro UV(a, b) <a / NX, b / NY> #end
"""
GRID_MESH = """#declare Grid = mesh {
 #for (b, 0, NY - 1) #for (a, 0, NX - 1)
  smooth_triangle { P(a, b), Nm(a, b), P(a + 1, b), Nm(a + 1, b), P(a + 1, b + 1), Nm(a + 1, b + 1)
    uv_vectors UV(a, b), UV(a + 1, b), UV(a + 1, b + 1) }
  smooth_triangle { P(a, b), Nm(a, b), P(a + 1, b + 1), Nm(a + 1, b + 1), P(a, b + 1), Nm(a, b + 1)
    uv_vectors UV(a, b), UV(a + 1, b + 1), UV(a, b + 1) }
 #end #end
}
"""
GRID_MESH2 = """#declare K = (NX + 1) * (NY + 1);
#declare Grid2 = mesh2 {
  vertex_vectors { K #for (k, 0, K - 1) P(mod(k, NX + 1), div(k, NX + 1)) #end }
  normal_vectors { K #for (k, 0, K - 1) Nm(mod(k, NX + 1), div(k, NX + 1)) #end }
  // the uvs listed backwards, so their indices differ from the vertices'
  uv_vectors { K #for (k, K - 1, 0, -1) UV(mod(k, NX + 1), div(k, NX + 1)) #end }
  face_indices { NX * NY * 2
   #for (b, 0, NY - 1) #for (a, 0, NX - 1)
    #local k = b * (NX + 1) + a;
    <k, k + 1, k + NX + 2>, <k, k + NX + 2, k + NX + 1>
   #end #end }
  uv_indices { NX * NY * 2
   #for (b, 0, NY - 1) #for (a, 0, NX - 1)
    #local k = K - 1 - (b * (NX + 1) + a);
    <k, k - 1, k - NX - 2>, <k, k - NX - 2, k - NX - 1>
   #end #end }
}
"""

CAMERAS = {
    # one mesh, moved and turned; the start moved back along the normal, the rays reversed
    "d0 transformed, reversed": "#declare M = Fan(W, H, 0, H, 0);\n"
    "camera { mesh_camera { 1 0 mesh { M rotate 10*y translate <0.1, 0, -1> } }"
    " location <0, 0, -0.5> direction -z }",
    "d0 flipped winding": "#declare M = Fan(W, H, 0, H, 1);\n"
    "camera { mesh_camera { 1 0 mesh { M translate -z } } }",
    # two rays a pixel, one from each mesh, averaged
    "d0 two meshes": "#declare M = Fan(W, H, 0, H, 1);\n"
    "camera { mesh_camera { 2 0 mesh { M } mesh { M translate <0.05, 0.03, 0> } } }",
    # faces counted across the meshes; fewer faces than pixels (the rest are not traced),
    # and POV-Ray's second ray never finds a face
    "d1 summed": "#declare Top = Fan(W, H, 0, 20, 1); #declare Low = Fan(W, H, 20, H - 6, 1);\n"
    "camera { mesh_camera { 2 1 mesh { Top } mesh { Low rotate -5*x } } }",
    # two cameras side by side (the face index counts x across the whole image)
    "d2 side by side": "#declare Half = Fan(W / 2, H, 0, H, 1);\n"
    "camera { mesh_camera { 1 2 mesh { Half translate -0.3*x } mesh { Half translate 0.3*x } } }",
    "d3 smooth": "camera { mesh_camera { 1 3 mesh { Grid rotate 180*y } smooth }"
    " location <0, 0, -0.2> }",
    "d3 flat": "camera { mesh_camera { 1 3 mesh { Grid rotate 180*y translate -0.5*z } } }",
    "d3 mesh2 smooth": "camera { mesh_camera { 1 3 mesh2 { Grid2 } smooth } direction -z }",
}


def _scene(camera: str) -> str:
    if "Grid" in camera:  # only what the camera uses (no "declared but never used")
        shapes = GRID + (GRID_MESH2 if "Grid2" in camera else GRID_MESH)
        return f"{WORLD}{shapes}{camera}\n"
    return f"{WORLD}#declare W = {W}; #declare H = {H};\n{FAN}{camera}\n"


@pytest.mark.povray
@pytest.mark.parametrize("name", list(CAMERAS))
def test_mesh_camera_renders_like_povray(tmp_path, name):
    text = _scene(CAMERAS[name])
    ours, messages = strala_image(text, tmp_path, W, H)
    assert messages == []  # rendered: no "not supported yet"
    ref = povray_image(text, tmp_path, W, H)
    rmse, off = image_errors(ours, ref)
    assert rmse < 0.01 and off < 0.005, (rmse, off)


def _camera(text: str) -> ir.Camera:
    r = compile_source(text)
    errs = [d.message for d in r.diagnostics if d.severity.name == "ERROR"]
    assert not errs, errs
    assert r.scene is not None
    return r.scene.camera


def _errors(text: str) -> list[str]:
    r = compile_source(text)
    return [d.message for d in r.diagnostics if d.severity.name == "ERROR"]


ONE = "mesh { triangle { 0, x, y } }"


@pytest.mark.parametrize(
    "body, message",
    [
        (f"0 0 {ONE}", "Rays per pixel may not be 0"),
        (f"1 4 {ONE}", "Unrecognized distribution method"),
        (f"2 2 {ONE} {ONE}", "Rays per pixel must be 1 for distribution method #2 or #3"),
        (f"1 0 {ONE} smooth", "Smooth can only be used with distribution method #3"),
        (f"2 0 {ONE}", "Rays per pixel must be <= number of meshes for distribution method #0"),
        ("1 0", "mesh or mesh2 expected"),
        ("1 0 sphere { 0, 1 }", "a mesh_camera takes mesh or mesh2 objects"),
    ],
)
def test_mesh_camera_rules(body, message):
    assert message in _errors(f"camera {{ mesh_camera {{ {body} }} }}")


def test_mesh_camera_ir():
    cam = _camera(
        "camera { mesh_camera { 1 3 0.5 mesh { triangle { 0, x, y uv_vectors <0,0>, <1,0>, <0,1> }"
        " triangle { 0, x, 2*x } translate z } smooth } location <0, 0, -1> }"
    )
    assert cam.kind == "mesh_camera" and cam.mesh is not None
    assert (cam.mesh.rays_per_pixel, cam.mesh.distribution, cam.mesh.smooth) == (1, 3, True)
    assert cam.mesh.max_distance == 0.5
    (cm,) = cam.mesh.meshes
    assert len(cm.mesh.faces) == 1  # the degenerate triangle left out, as POV-Ray does
    assert cm.mesh.uvs == ((0.0, 0.0), (1.0, 0.0), (0.0, 1.0))
    assert cm.transform[2][3] == 1.0  # the mesh's own transformation, not baked in


def test_longest_ray_is_not_rendered_yet():
    r = compile_source(f"camera {{ mesh_camera {{ 1 0 2.5 {ONE} }} }}")
    assert any("longest ray" in d.message for d in r.diagnostics)


def test_extra_meshes_are_ignored_for_distribution_3():
    r = compile_source(f"camera {{ mesh_camera {{ 1 3 {ONE} {ONE} }} }}")
    assert any("Additional meshes" in d.message for d in r.diagnostics)
    assert r.scene is not None and r.scene.camera.mesh is not None
    assert len(r.scene.camera.mesh.meshes) == 1


def _grid_camera(distribution: int, rays: int = 1, meshes: int = 1) -> MeshCameraRays:
    tri = " ".join(
        f"triangle {{ <{i}, {-j}, 0>, <{i + 1}, {-j + 1}, 0>, <{i + 1}, {-j}, 0> }}"
        for j in range(3)
        for i in range(4)
    )
    body = " ".join(f"mesh {{ {tri} translate {k}*z }}" for k in range(meshes))
    return MeshCameraRays(_camera(f"camera {{ mesh_camera {{ {rays} {distribution} {body} }} }}"))


@settings(max_examples=40, deadline=None)
@given(col=st.integers(0, 3), row=st.integers(0, 2))
def test_pixels_pick_faces_as_povray(col, row):
    """Distribution 0: pixel (col, row) of a 4x3 image starts at the centroid of face
    (row - 1) * 4 + col (rows 0 and 1 both read face row 0), going along +z here."""
    rays = _grid_camera(0)
    o, d, traced = rays.rays(4, 3, np.array([col + 0.5]), np.array([row + 0.5]), 0)
    assert traced[0]
    face = max(row - 1, 0) * 4 + col
    i, j = face % 4, face // 4
    assert np.allclose(o[0], [i + 2 / 3, -j + 1 / 3, 0.0])
    assert np.allclose(d[0], [0.0, 0.0, 1.0])


def test_distribution_1_traces_only_the_first_ray():
    rays = _grid_camera(1, rays=2, meshes=2)
    xs, ys = np.array([0.5, 3.5]), np.array([0.5, 2.5])
    assert rays.rays(4, 3, xs, ys, 0)[2].all()
    assert not rays.rays(4, 3, xs, ys, 1)[2].any()


@settings(max_examples=40, deadline=None)
@given(
    u=st.floats(0.0, 0.999),
    v=st.floats(0.001, 1.0),
)
def test_uv_lookup_finds_the_point(u, v):
    """Distribution 3 on a uv grid that matches the positions: the ray starts at the
    point whose uv is the pixel's."""
    n = 5
    tris = []
    for b in range(n):
        for a in range(n):
            p = [(a, b), (a + 1, b), (a + 1, b + 1), (a, b + 1)]
            for t in ((0, 1, 2), (0, 2, 3)):
                pts = ", ".join(f"<{p[k][0] / n}, {p[k][1] / n}, 0>" for k in t)
                uvs = ", ".join(f"<{p[k][0] / n}, {p[k][1] / n}>" for k in t)
                tris.append(f"triangle {{ {pts} uv_vectors {uvs} }}")
    rays = MeshCameraRays(
        _camera(f"camera {{ mesh_camera {{ 1 3 mesh {{ {' '.join(tris)} }} }} }}")
    )
    width = height = 1000
    # the pixel coordinates whose uv (POV-Ray's formulas, strala's pixel centres) is (u, v)
    xs = np.array([u * width + 0.5])
    ys = np.array([(1.0 - v) * height + 0.5])
    o, _d, traced = rays.rays(width, height, xs, ys, 0)
    assert traced[0]
    x = np.clip(xs[0], 0, width - 1)
    y = np.clip(ys[0] - 1, 0, height - 1)
    assert np.allclose(o[0], [(x - 0.5) / width, 1 - (y + 0.5) / height, 0.0])


def test_mesh2_uv_indices_give_each_corner_its_uv():
    r = compile_source(
        "mesh2 { vertex_vectors { 4, 0, x, y, x+y } uv_vectors { 2, <0.25, 0.5>, <1, 0> }"
        " face_indices { 2, <0, 1, 2>, <1, 3, 2> } uv_indices { 2, <0, 1, 1>, <1, 0, 0> } }"
    )
    assert r.scene is not None
    m = r.scene.objects[0].shape
    assert len(m.vertices) == 6 and m.faces == ((0, 1, 2), (3, 4, 5))
    assert m.vertices[3:] == ((1.0, 0.0, 0.0), (1.0, 1.0, 0.0), (0.0, 1.0, 0.0))
    assert m.uvs == ((0.25, 0.5), (1.0, 0.0), (1.0, 0.0), (1.0, 0.0), (0.25, 0.5), (0.25, 0.5))
