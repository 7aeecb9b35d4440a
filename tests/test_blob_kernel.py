"""Blobs through the compiled kernel (kernel/blob.h) against the numpy path (runtime/prims/
blob.py), its reference. Metrics: the largest absolute channel difference over the
working-space image (< 1e-9: both take the same sums in the same order, so they agree to
the bit in practice), and for single rays the nearest hit's distance (relative 1e-12) and
unit normal (1e-9)."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import kernel_and_numpy
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from lang import ir
from runtime import api, integrate, tolerances, whitted
from runtime.prepare import prepare
from runtime.prims.blob import BlobPrim

HEAD = """
#version 3.7;
global_settings { assumed_gamma 1 max_trace_level 5 }
camera { location <0.5, 2.5, -7> look_at <0, 0.3, 0> angle 45 }
light_source { <-5, 8, -6>, rgb 1 }
light_source { <4, 3, -5>, rgb 0.5 }
plane { y, -1.5 pigment { checker rgb 0.9, rgb 0.3 } }
"""

# spheres and cylinders, a negative strength carving, component and object transforms
PLAIN = """
blob { threshold 0.5
  sphere { <-1.2, 0, 0>, 1.1, 1 }
  sphere { <-0.4, 0.4, 0>, 0.9, 1.5 scale <1, 1.4, 1> rotate z * 20 }
  cylinder { <0.2, -0.8, 0>, <1.8, 0.9, 0.3>, 0.6, 1.2 }
  cylinder { <-1.5, 1, -1>, <1.5, 1, 1>, 0.5, 2 translate y * 0.3 }
  sphere { <0.9, 0.2, -0.3>, 0.6, -2 }
  cylinder { <-0.6, -0.5, -1>, <-0.6, -0.5, 1>, 0.35, -1 }
  pigment { rgb <0.9, 0.4, 0.2> } finish { phong 0.7 reflection 0.15 }
  rotate y * 25 scale 1.1 translate x * 0.2
}
"""

# inside CSG (intersection, difference, merge, clipped), inverse, glass
CSG = """
intersection {
  blob { threshold 0.4 sphere { 0, 1.4, 1 } cylinder { -1.5 * x, 1.5 * x, 0.7, 1 }
    sphere { <0.6, 0.6, -0.5>, 0.6, -1.5 } }
  box { <-1.2, -0.6, -2>, <1.2, 2, 2> }
  pigment { rgb <0.3, 0.7, 0.9> } translate <-1.6, 0.3, 0>
}
difference {
  sphere { 0, 1 }
  blob { threshold 0.6 sphere { <0.4, 0.3, -0.6>, 0.8, 1 } cylinder { -y, y, 0.5, 1 } }
  pigment { rgb <0.9, 0.8, 0.2> } translate <1.6, 0, 0>
}
merge {
  blob { threshold 0.3 cylinder { <-0.6, 0, 0>, <0.6, 0, 0>, 0.4, 1 } inverse }
  sphere { <0, 0, 0>, 0.3 }
  pigment { rgbf <0.9, 1, 0.9, 0.8> } interior { ior 1.4 }
  clipped_by { sphere { 0, 3 } } translate <0, 1.7, -1>
}
blob { threshold 0.5 sphere { 0, 0.8, 1 } sphere { <0.4, 0, 0>, 0.8, 1 }
  pigment { rgb <0.2, 0.8, 0.3> } clipped_by { plane { z, 0 } } translate <0, -0.9, -2> }
"""

# component textures (the numpy path and the kernel both show the blob's), sturm and
# hierarchy (nothing to change: the roots are exact), the old `component` form, a zero
# strength and a component scaled flat (both dropped)
OPTIONS = """
blob { threshold 0.55
  sphere { <-0.5, 0, 0>, 1, 1 pigment { rgb <1, 0, 0> } }
  sphere { <0.5, 0, 0>, 1, 1 texture { pigment { rgb <0, 0, 1> } } }
  component 1, 0.8, <0, 0.8, 0>
  sphere { <0, -0.8, 0>, 0.8, 0 }
  sphere { <0, -0.8, 0>, 0.8, 3 scale <1, 0, 1> }
  sturm hierarchy on
  pigment { rgb 0.8 }
}
"""


def _scene(body: str):
    return api.compile_string(HEAD + body).scene


def _assert_same(scene, width: int, height: int, monkeypatch, aa=None) -> None:
    fast, slow = kernel_and_numpy(scene, width, height, monkeypatch, aa=aa)
    assert np.isfinite(fast).all()
    assert np.abs(fast - slow).max() < 1e-9


@pytest.mark.parametrize("body", [PLAIN, CSG, OPTIONS], ids=["plain", "csg", "options"])
def test_blob_scenes_match_numpy(body, monkeypatch):
    _assert_same(_scene(body), 64, 48, monkeypatch)


def test_a_blob_with_antialiasing_and_shadows_matches_numpy(monkeypatch):
    _assert_same(_scene(PLAIN.replace("threshold 0.5", "threshold 0.3")), 48, 36, monkeypatch, 0.3)


def test_a_blob_is_on_the_kernel_and_drawn():
    scene = _scene(PLAIN)
    assert whitted.reasons(prepare(scene, 16, 12), scene.camera) == []
    # not a blank image: the blob covers the middle
    from runtime.render import render_scene

    img = render_scene(scene, 16, 12)
    centre = img[6, 8]
    assert abs(centre[0] - centre[2]) > 0.1  # the blob's orange, not the grey floor


def test_a_threshold_at_or_below_zero_is_everywhere_inside(monkeypatch):
    # every point away from the components is inside: the blob is unbounded (its box is
    # the whole space), and only the carved holes show
    body = """blob { threshold -0.1 sphere { 0, 1, -1 } sphere { <1, 0.5, 0>, 0.8, -2 }
      pigment { rgb <0.4, 0.6, 0.9> } }
      light_source { <0, 0, 0>, rgb 1 }"""
    text = HEAD.replace("plane { y, -1.5", "plane { y, -9") + body
    _assert_same(api.compile_string(text).scene, 48, 36, monkeypatch)


def _probe(shape: ir.Blob, transform=None):
    obj = ir.Object(shape) if transform is None else ir.Object(shape, transform=transform)
    scene = ir.Scene(camera=ir.Camera(), objects=(obj,))
    prepared = prepare(scene, 8, 8)
    buf = whitted.probe(prepared)
    assert buf is not None
    return prepared.tracer.nodes[0], buf


def _nearest(leaf, o: np.ndarray, d: np.ndarray):
    """The numpy tracer's nearest hit beyond the object's floor: (t, unit normal) or None."""
    c = leaf.crossings(o[None], d[None])
    floor = max(tolerances.ORIGIN_REL * float(np.linalg.norm(o)) + tolerances.ABS_FLOOR,
                tolerances.OBJECT_REL * leaf.size)  # fmt: skip
    t = c.t[0][np.isfinite(c.t[0]) & (c.t[0] > floor)]
    if not len(t):
        return None
    k = int(np.argmin(np.where(np.isfinite(c.t[0]) & (c.t[0] > floor), c.t[0], np.inf)))
    n = leaf.normals(o[None], d[None], c.t[0][k : k + 1], c.face[0][k : k + 1])[0]
    return float(t.min()), n * (-1.0 if c.flip[0][k] else 1.0)


@st.composite
def _blobs(draw):
    comps = []
    for _ in range(draw(st.integers(1, 6))):
        kind = draw(st.sampled_from(["sphere", "cylinder"]))
        a = tuple(draw(st.floats(-1.5, 1.5)) for _ in range(3))
        b = tuple(draw(st.floats(-1.5, 1.5)) for _ in range(3)) if kind == "cylinder" else a
        r = draw(st.floats(0.2, 1.5))
        s = draw(st.sampled_from([1.0, 2.0, -1.0, 0.5, -3.0, 1.7]))
        sx, sy = draw(st.floats(0.5, 2.0)), draw(st.floats(0.5, 2.0))
        m = np.diag([sx, sy, 1.0, 1.0]).tolist()
        comps.append(ir.BlobComponent(kind, a, b, r, s, tuple(map(tuple, m))))
    return ir.Blob(draw(st.sampled_from([0.1, 0.3, 0.6, 1.0])), tuple(comps))


@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(shape=_blobs(), seed=st.integers(0, 2**31 - 1))
def test_random_blobs_hit_where_numpy_does(shape, seed):
    leaf, buf = _probe(shape)
    rng = np.random.default_rng(seed)
    prim = leaf.prim
    lo, hi = (prim.lo, prim.hi) if np.isfinite(prim.lo).all() else (-np.ones(3), np.ones(3))
    for _ in range(60):
        o = rng.uniform(lo - 1.5, hi + 1.5)
        if rng.random() < 0.3:  # aimed at a point of the blob's box: rays that meet it
            d = rng.uniform(lo, hi) - o
        else:
            d = rng.normal(size=3)
        d /= np.linalg.norm(d)
        want = _nearest(leaf, o, d)
        got = whitted.first_hit(buf, o, d)
        assert (want is None) == (got is None), (o.tolist(), d.tolist(), want, got)
        if want is not None:
            assert got is not None
            assert abs(got[0] - want[0]) <= 1e-12 * (1 + abs(want[0]))
            assert np.abs(np.asarray(got[1]) - want[1]).max() < 1e-9


def test_a_ray_through_more_crossings_than_a_leaf_holds(monkeypatch):
    # 40 spheres in a row (above the 32 pieces the kernel keeps on its stack), cut by a box:
    # along the row the ray meets 80 crossings, and the one seen is the 71st (beyond the
    # 64 an ordinary leaf has room for: a blob keeps every one of its own)
    row = " ".join(f"sphere {{ <{k}, 0, 0>, 0.4, 1 }}" for k in range(40))
    text = f"""
    camera {{ location <-3, 0, 0> look_at <0, 0, 0> angle 10 }}
    light_source {{ <-5, 5, -5>, rgb 1 }}
    intersection {{ blob {{ threshold 0.5 {row} }} box {{ <34.7, -1, -1>, <50, 1, 1> }}
      pigment {{ rgb 1 }} }}"""
    scene = api.compile_string(text).scene
    prepared = prepare(scene, 8, 8)
    node = prepared.tracer.nodes[0]
    o, d = np.array([-3.0, 0.0, 0.0]), np.array([1.0, 0.0, 0.0])
    blob_leaf = node.children[0]
    c = blob_leaf.crossings(o[None], d[None])
    assert np.isfinite(c.t).sum() == 80
    hits = node.crossings(o[None], d[None]).t[0]
    want = float(np.min(hits[np.isfinite(hits)]))
    assert int(np.searchsorted(np.sort(c.t[0]), want)) == 70  # the 71st crossing
    buf = whitted.pack(integrate.make_context(prepared), scene.camera, 8, 8)
    got = whitted.first_hit(buf, o, d)
    assert got is not None and abs(got[0] - want) <= 1e-12 * want
    _assert_same(scene, 16, 16, monkeypatch)


def test_a_blob_of_many_pieces_matches_numpy(monkeypatch):
    # 120 components: the kernel's working arrays are allocated, not on its stack
    rng = np.random.default_rng(7)
    parts = " ".join(
        f"sphere {{ <{x:.3f}, {y:.3f}, {z:.3f}>, {r:.3f}, {s} }}"
        for x, y, z, r, s in zip(
            *rng.uniform(-1.6, 1.6, (3, 120)), rng.uniform(0.2, 0.6, 120),
            rng.choice([1, 1, 1, -1], 120), strict=True,
        )
    )  # fmt: skip
    scene = _scene(f"blob {{ threshold 0.4 {parts} pigment {{ rgb <0.8, 0.5, 0.3> }} }}")
    assert len(prepare(scene, 8, 8).tracer.nodes[1].prim.s) == 120
    _assert_same(scene, 48, 36, monkeypatch)


def test_a_ray_along_a_cylinder_axis_meets_its_field():
    # a ray exactly along a cylinder component's axis, inside its radius: the field there
    # is the middle piece's (constant across the ray), bounded by the caps
    shape = ir.Blob(0.5, (ir.BlobComponent("cylinder", (0, -1, 0), (0, 1, 0), 1.0, 1.0),))
    prim = BlobPrim(shape)
    o, d = np.array([[0.3, -5.0, 0.0]]), np.array([[0.0, 1.0, 0.0]])
    t, _ = prim.crossings(o, d)
    t = t[0][np.isfinite(t[0])]
    # density 0.5 where (1 - rho^2)^2 = 0.5 with rho the distance to the nearest axis point
    rho2 = 1 - np.sqrt(0.5)
    depth = np.sqrt(rho2 - 0.3**2)  # how far past the end the cap's field reaches 0.5
    np.testing.assert_allclose(t, [4 - depth, 6 + depth], rtol=1e-12)
    leaf, buf = _probe(shape)
    got = whitted.first_hit(buf, o[0], d[0])
    assert got is not None and abs(got[0] - t[0]) < 1e-12


def test_a_damaged_blob_table_is_refused():
    scene = _scene(PLAIN)
    prepared = prepare(scene, 8, 6)
    good = whitted.pack(integrate.make_context(prepared), scene.camera, 8, 6)
    out = np.empty((6, 8, 3))

    def tile(buf):
        return whitted.trace_packed(buf, 0, 0, 8, 6, -1.0, 0.4, 3, out)

    tile(good)
    rows = good[whitted.HDR : whitted.HDR + int(good[whitted.H_NOBJ]) * whitted.OBJ]
    blob_row = [k for k, r in enumerate(rows.reshape(-1, whitted.OBJ)) if r[0] == 10]
    assert len(blob_row) == 1
    at = whitted.HDR + blob_row[0] * whitted.OBJ + whitted.O_PRIM
    for where, value in ((at, -1.0), (at, 1e9), (at + 1, 1e7), (at + 1, np.nan),
                         (whitted.H_NBLOB, 1e15), (whitted.H_BLOBS, 3.0)):  # fmt: skip
        bad = good.copy()
        bad[where] = value
        with pytest.raises(ValueError, match="scene"):
            tile(bad)
