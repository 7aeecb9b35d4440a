"""Thin and degenerate triangles (zero area, slivers, repeated vertices, zero normals): no
NaN, no crash, through the tracer and through a whole render."""

from __future__ import annotations

import numpy as np
from hypothesis import given
from hypothesis import strategies as st

from lang import ir
from runtime import api
from runtime.prepare import prepare

SCENE = """#version 3.7;
global_settings { assumed_gamma 1 }
camera { location <0, 0, -4> look_at <0, 0, 0> angle 50 }
light_source { <3, 5, -4>, rgb 1 }
#declare M = finish { ambient 0.1 diffuse 0.8 phong 0.5 reflection 0.2 }
// a good face, a repeated vertex, all three the same, a 1e-17 sliver, collinear points,
// a 1e-300 height; zero and proper vertex normals mixed
mesh2 {
  vertex_vectors { 9, <-1,-1,0>, <1,-1,0>, <0,1,0>, <0.5,0.5,0>, <1,1,0>, <-1,1,1e-300>,
                   <0,0,0>, <1e-17,1e-17,0>, <2,2,0> }
  normal_vectors { 9, <0,0,0>, <0,0,-1>, <0,0,-1>, <0,0,-1>, <0,0,-1>, <0,0,-1>, <0,0,-1>,
                   <0,0,-1>, <0,0,-1> }
  face_indices { 6, <0,1,2>, <0,0,1>, <3,3,3>, <6,7,8>, <0,4,8>, <5,6,7> }
  pigment { rgb 1 } finish { M }
}
triangle { <-1,-1,1>, <-1,-1,1>, <1,1,1> pigment { rgb 1 } }
triangle { <-2,0,0.5>, <2,0,0.5>, <0,1e-12,0.5> pigment { rgb <1,0,0> } finish { M } }
smooth_triangle { <-2,-1,0.2>, <0,0,0>, <2,-1,0.2>, <0,0,-1>, <0,-0.5,0.2>, <0,0,0>
  pigment { rgb 1 } finish { M } }
mesh { triangle { <-1,-1,0.3>, <1,-1,0.3>, <1,-1,0.3> }
       smooth_triangle { <-1,0.5,0.3>, <0,0,-1>, <-1,0.5,0.3>, <0,0,-1>, <1,0.5,0.3>, <0,0,-1> }
       pigment { rgb 1 } }
"""


def test_degenerate_triangles_render_finite():
    compiled = api.compile_string(SCENE, width=64, height=48)
    img = api.render(compiled, width=64, height=48, linear=True, threads=1)
    assert np.isfinite(img).all()
    assert img.max() > 0.3  # the good face and the smooth triangle are seen and lit


def _trace(verts: np.ndarray, faces: np.ndarray, o: np.ndarray, d: np.ndarray, smooth: bool):
    mesh = ir.Mesh(vertices=verts, faces=faces.astype(np.int32), smooth=smooth)
    prep = prepare(ir.Scene(camera=ir.Camera(), objects=(ir.Object(mesh),)), 8, 8)
    return prep.tracer, prep.tracer.closest(o, d)


@given(
    log_scale=st.floats(-6, 7),
    log_thin=st.floats(-300, -1),
    kind=st.sampled_from(["sliver", "needle", "repeat", "collinear"]),
    smooth=st.booleans(),
    seed=st.integers(0, 2**16),
)
def test_thin_triangles_give_finite_hits(log_scale, log_thin, kind, smooth, seed):
    """A fan of degenerate and nearly degenerate triangles around a good one, smooth
    (vertex normals from the faces, zero-area faces contributing none) or flat: every hit
    has a finite point, a unit normal and t > 0; shadow queries from the hits finish."""
    rng = np.random.default_rng(seed)
    s, e = 10.0**log_scale, 10.0**log_thin
    good = [[-1, -1, 0], [1, -1, 0], [0, 1, 0]]
    if kind == "sliver":  # height e
        bad = [[-1, 0, 0], [1, 0, 0], [0, e, 0]]
    elif kind == "needle":  # width e, length 2
        bad = [[-1, 0, 0], [1, e, 0], [1, -e, 0]]
    elif kind == "repeat":  # a repeated vertex, nudged by e
        bad = [[0, 0, 0], [0, 0, e], [1, 1, 0]]
    else:  # collinear, off the line by e out of the plane
        bad = [[-1, -1, 0], [0, 0, e], [1, 1, 0]]
    verts = np.array(good + bad, dtype=np.float64) * s
    faces = np.array([[0, 1, 2], [3, 4, 5], [0, 4, 5], [3, 3, 5]])
    n = 200
    o = np.column_stack([rng.uniform(-1.2, 1.2, n), rng.uniform(-1.2, 1.2, n), np.full(n, -3.0)])
    d = np.column_stack([rng.normal(0, 0.05, n), rng.normal(0, 0.05, n), np.ones(n)])
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    tracer, h = _trace(verts, faces, o * s, d, smooth)
    hit = h.obj >= 0
    assert hit.sum() > 10  # the good triangle is there
    assert not np.isnan(h.t).any()
    assert np.isfinite(h.point[hit]).all() and (h.t[hit] > 0).all()
    assert np.allclose(np.linalg.norm(h.normal[hit], axis=1), 1.0)
    up = np.tile([0.3, 0.2, -1.0], (int(hit.sum()), 1))
    blocked = tracer.occluded(h.point[hit], up / np.linalg.norm(up[0]), np.full(hit.sum(), 10 * s))
    assert not blocked.any()  # nothing in front of the fan
