"""`normal { bump_map { … } }`: an image's grey values (or palette indices) as heights, as
POV-Ray renders them, and the pieces of runtime.bump_map on their own."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from conftest import image_errors, povray_image, strala_image, write_palette_png
from hypothesis import given
from hypothesis import strategies as st

from runtime import bump_map


def _heights(w: int = 40, h: int = 30) -> np.ndarray:
    """Smooth hills with a few hard steps: what interpolation and mapping act on."""
    y, x = np.mgrid[0:h, 0:w]
    v = 0.5 + 0.35 * np.sin(x / 3.0) * np.cos(y / 2.5)
    v[(x // 8 + y // 6) % 3 == 0] *= 0.4
    return np.clip(v, 0.0, 1.0)


def _write_grey_png(path: Path, values: np.ndarray) -> None:
    import OpenImageIO as oiio

    h, w = values.shape
    buf = oiio.ImageBuf(oiio.ImageSpec(w, h, 3, oiio.UINT8))
    rgb = np.repeat(values[:, :, None], 3, axis=2) * np.array([1.0, 0.9, 0.7])
    buf.set_pixels(oiio.ROI(0, w, 0, h), rgb.astype(np.float32))
    assert buf.write(str(path))


def _write_palette_png(path: Path, index: np.ndarray) -> None:
    """An 8-bit palette PNG whose colours do not follow the indices (so grey and index
    heights differ)."""
    palette = b"".join(bytes(((i * 97) % 256, (i * 31) % 256, 255 - i)) for i in range(256))
    write_palette_png(path, index, palette)


HEAD = """#version 3.7;
global_settings { assumed_gamma 1 }
camera { location <0, 0, -4> look_at 0 right x*4/3 }
light_source { <-3, 4, -5>, rgb 1 }
"""
PLANE = "plane {{ -z, 0 pigment {{ rgb 0.8 }} finish {{ specular 0.5 }} normal {{ {n} }} }}"
SCENES = {
    "planar": PLANE.format(
        n='bump_map { png "hf.png" bump_size 3 } scale <3, 2.2, 1> translate <-1.5, -1.1, 0>'
    ),
    "planar, repeated, bilinear": PLANE.format(
        n='bump_map { png "hf.png" bump_size 2 interpolate 2 } scale 1.3'
    ),
    "bicubic": PLANE.format(n='bump_map { png "hf.png" bump_size 2 interpolate 3 } scale 1.7'),
    "normalised distance": PLANE.format(
        n='bump_map { png "hf.png" bump_size 4 interpolate 4 } scale 1.1 rotate z*20'
    ),
    "once": PLANE.format(n='bump_map { png "hf.png" bump_size 3 once } scale 1.5'),
    "palette index": PLANE.format(
        n='bump_map { png "pal.png" use_index bump_size 0.05 interpolate 2 } scale 2'
    ),
    "palette colour": PLANE.format(n='bump_map { png "pal.png" bump_size 2 } scale 2'),
    "spherical": """sphere { 0, 1.5 pigment { rgb 0.9 } finish { specular 0.6 }
      normal { bump_map { png "hf.png" map_type 1 bump_size 4 interpolate 2 } }
      rotate <20, 30, 0> }""",
    "cylindrical": """cylinder { -1.5*y, 1.5*y, 1.2 pigment { rgb 0.9 }
      normal { bump_map { png "hf.png" map_type 2 bump_size 3 } scale <1, 3, 1> } rotate x*-20 }""",
    "torus": """torus { 1, 0.45 pigment { rgb 0.9 } finish { specular 0.6 }
      normal { bump_map { png "hf.png" map_type 5 bump_size 3 } } rotate x*-60 }""",
}


@pytest.mark.povray
@pytest.mark.parametrize("name", SCENES)
def test_bump_map_renders_like_povray(tmp_path, name):
    _write_grey_png(tmp_path / "hf.png", _heights())
    index = (np.arange(30)[:, None] * 7 + np.arange(40)[None, :] * 3) % 40
    _write_palette_png(tmp_path / "pal.png", index)
    text = HEAD + SCENES[name]
    ours, messages = strala_image(text, tmp_path, 96, 72)
    assert messages == []  # rendered: no "not supported yet"
    rmse, off = image_errors(ours, povray_image(text, tmp_path, 96, 72))
    assert rmse < 0.004 and off < 0.002, (rmse, off)


def test_palette_indices_are_read_from_the_file(tmp_path):
    index = np.arange(12 * 9).reshape(9, 12) % 256
    _write_palette_png(tmp_path / "p.png", index)
    assert np.array_equal(bump_map.palette_indices(str(tmp_path / "p.png")), index)
    _write_grey_png(tmp_path / "g.png", _heights(12, 9))
    assert bump_map.palette_indices(str(tmp_path / "g.png")) is None


def test_a_flat_image_leaves_the_normal_alone(tmp_path):
    _write_grey_png(tmp_path / "flat.png", np.full((8, 8), 0.6))
    params = {"path": str(tmp_path / "flat.png"), "interpolate": 2}
    rng = np.random.default_rng(1)
    n = rng.normal(size=(50, 3))
    n /= np.linalg.norm(n, axis=1, keepdims=True)
    out = bump_map.perturb(params, 3.0, rng.uniform(-2, 2, (50, 3)), n)
    out /= np.linalg.norm(out, axis=1, keepdims=True)
    assert np.allclose(out, n, atol=1e-9)


@given(st.floats(0.0, 1.0), st.floats(0.0, 1.0))
def test_interpolation_weights_sum_to_one(p, q):
    pp, qq = np.array([p]), np.array([q])
    assert np.isclose(sum(f[0] for f in bump_map.norm_dist_weights(pp, qq)), 1.0)
    assert np.isclose(sum(f[0] for f in bump_map.cubic_weights(pp)), 1.0)


@given(
    st.lists(st.floats(-1.0, 1.0), min_size=3, max_size=3).filter(
        lambda v: float(np.linalg.norm(v)) > 1e-3
    )
)
def test_an_upward_bump_is_the_normal_itself(v):
    n = np.array([v], dtype=np.float64)
    n /= np.linalg.norm(n)
    # the triangle's normal for equal heights is (0, 1, 0) in the frame: y is the normal
    out = bump_map.in_frame(n, np.array([[0.0, 1.0, 0.0]]))
    assert np.allclose(out, n)
