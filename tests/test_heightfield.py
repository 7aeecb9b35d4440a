"""height_field: palette-index heights, the mesh layout, and POV-Ray's render as the oracle."""

from __future__ import annotations

import shutil
import struct
from pathlib import Path

import numpy as np
import pytest
from conftest import image_errors, povray_image, strala_image

from lang import ir
from runtime import heightfield as hf
from runtime.functions import compile_xyz

PLASMA = Path("/usr/share/povray-3.7/include/plasma3.png")
needs_plasma = pytest.mark.skipif(not PLASMA.is_file(), reason="POV-Ray's include files absent")


def palette_of(data: bytes) -> np.ndarray:
    pos = 8
    while pos < len(data):
        length, kind = struct.unpack(">I4s", data[pos : pos + 8])
        if kind == b"PLTE":
            return np.frombuffer(data[pos + 8 : pos + 8 + length], np.uint8).reshape(-1, 3)
        pos += 12 + length
    raise AssertionError("no palette")


@needs_plasma
def test_palette_indices_map_through_the_palette_to_what_openimageio_reads():
    """The oracle for the PNG decoder (zlib, all five row filters): each decoded index, looked
    up in the file's palette, is the colour OpenImageIO decodes for that pixel."""
    import OpenImageIO as oiio

    data = PLASMA.read_bytes()
    index = hf.png_palette_indices(data)
    rgb = oiio.ImageBuf(str(PLASMA)).get_pixels(oiio.UINT8)[..., :3]
    assert index.shape == rgb.shape[:2]
    assert np.array_equal(palette_of(data)[index], rgb)
    assert index.min() < 64 and index.max() > 192  # a real terrain, not a constant


def test_mesh_layout_and_water_level(tmp_path):
    import OpenImageIO as oiio

    h = np.array([[0.0, 0.5, 1.0], [0.25, 0.25, 0.25]], dtype=np.float32)
    spec = oiio.ImageSpec(3, 2, 1, oiio.FLOAT)
    out = oiio.ImageOutput.create(str(tmp_path / "h.exr"))
    out.open(str(tmp_path / "h.exr"), spec)
    out.write_image(h.reshape(2, 3, 1))
    out.close()
    mesh = hf.height_field_mesh(ir.HeightField(str(tmp_path / "h.exr")))
    v = mesh.vertices
    assert len(v) == 6 and len(mesh.faces) == 2 * (3 - 1) * (2 - 1)
    # top image row at the back (z = 1), columns along x
    # heights as POV-Ray's: the grey value times 65535, whole, over 65536
    assert np.allclose(v[:3], [[0, 0, 1], [0.5, 32767 / 65536, 1], [1, 65535 / 65536, 1]])
    q = 16383 / 65536
    assert np.allclose(v[3:], [[0, q, 0], [0.5, q, 0], [1, q, 0]])
    wet = hf.height_field_mesh(ir.HeightField(str(tmp_path / "h.exr"), water_level=0.3))
    # triangles wholly under the water go (POV-Ray cuts straddling ones at the level)
    assert len(wet.faces) == 3
    smooth = hf.height_field_mesh(ir.HeightField(str(tmp_path / "h.exr"), smooth=True))
    assert np.allclose(np.linalg.norm(smooth.normals, axis=1), 1)
    assert (smooth.normals[:, 1] > 0).all()


SCENE = """#version 3.7;
global_settings {{ assumed_gamma 1.0 }}
camera {{ location <0.5, 1.6, -0.9> look_at <0.5, 0.1, 0.5> angle 50 }}
light_source {{ <-3, 6, -4> rgb 1 }}
background {{ rgb 0.2 }}
height_field {{ png "plasma3.png" {smooth} pigment {{ rgb <0.9, 0.7, 0.4> }}
  finish {{ specular 0.3 }} scale <1, 0.4, 1> }}
"""


@pytest.mark.povray
@needs_plasma
@pytest.mark.parametrize("smooth", ["", "smooth"])
def test_height_field_renders_like_povray(tmp_path, smooth):
    """Metric: RMSE over sRGB [0,1] < 0.03 and under 2% of pixels off by > 0.1 (measured
    0.0155 / 0.72% flat, 0.0123 / 0.26% smooth at 240x180)."""
    shutil.copy(PLASMA, tmp_path / "plasma3.png")
    text = SCENE.format(smooth=smooth)
    pov = povray_image(text, tmp_path, 160, 120)
    ours, _ = strala_image(text, tmp_path, 160, 120)
    rmse, off = image_errors(ours, pov)
    assert rmse < 0.03 and off < 0.02, (rmse, off)


# ------------------------------------------------------------------ function images
def _field(src: str) -> ir.HeightField:
    from lang.evaluate import compile_source

    r = compile_source(src, "t.pov")
    errs = [d.format() for d in r.diagnostics if d.severity == "error"]
    assert not errs, errs
    return r.scene.objects[0].shape


def test_function_image_sizes_and_samples():
    """`function W, H { … }`: POV-Ray samples the function at x = j/(W-1), y = i/(H-1),
    z = 0 for pixel (j, i); the sizes may be names and round to the nearest whole number."""
    shape = _field("#declare N = 4.6; height_field { function N, 3 { x * 0.5 + y * 0.25 } }")
    assert shape.source == "" and shape.size == (5, 3)
    h = hf.function_heights(shape.function, shape.size, compile_xyz)
    assert h.shape == (3, 5)
    assert np.allclose(h[0], np.arange(5) / 4 * 0.5, atol=1e-4)
    assert np.allclose(h[:, 0], np.arange(3) / 2 * 0.25, atol=1e-4)


def test_function_image_of_a_pigment_is_its_grey_value_clipped_to_0_1():
    shape = _field(
        "height_field { function 5, 2 { pigment { gradient x color_map {"
        " [0 rgb 0] [1 rgb <1, 0.5, 0>] } } } }"
    )
    h = hf.function_heights(shape.function, shape.size, compile_xyz)
    grey = 0.297 + 0.5 * 0.589  # POV-Ray's grey of rgb <1, 0.5, 0>
    assert np.allclose(h[:, :4], np.arange(4) / 4 * grey, atol=2e-3)
    clipped = _field("height_field { function 2, 2 { x * 3 - 1 } }")
    assert np.allclose(
        hf.function_heights(clipped.function, clipped.size, compile_xyz), [[0, 1], [0, 1]]
    )


FN_SCENE = """#version 3.7;
global_settings { assumed_gamma 1 }
camera { location <0.5, 2.2, -0.8> look_at <0.5, 0.2, 0.5> angle 50 }
light_source { <2, 5, -3> color rgb 1 }
background { rgb 0.2 }
height_field {
  function 40, 30 { pigment { bozo color_map { [0 rgb 0] [1 rgb 1] } scale 0.3 } }
  smooth pigment { color rgb <1, 0.8, 0.6> }
}
height_field {
  function 40, 30 { min(1, y * y * 2 + 0.1 * x) }
  scale <1, 0.5, 1> translate <1.1, 0, 0>
  pigment { color rgb <0.6, 0.8, 1> }
}
"""


@pytest.mark.povray
def test_function_height_field_renders_like_povray(tmp_path):
    """Metric: RMSE over sRGB [0,1] < 0.03 and under 2% of pixels off by > 0.1."""
    pov = povray_image(FN_SCENE, tmp_path, 160, 120)
    ours, _ = strala_image(FN_SCENE, tmp_path, 160, 120)
    rmse, off = image_errors(ours, pov)
    assert rmse < 0.03 and off < 0.02, (rmse, off)


# Steep relief (a checker's steps, bozo's cliffs) smoothed: POV-Ray's normals are made in
# its grid space, where a step is a near-vertical face, and so stay near vertical on the
# ground beside it; normals averaged in the field's own 0..1 space bevelled every edge.
STEEP = """#version 3.7;
global_settings {{ assumed_gamma 1 }}
camera {{ location <0, 7, -9> look_at 0 angle 50 }}
light_source {{ <5, 10, -5> rgb 1 }}
background {{ rgb <0.2, 0.3, 0.5> }}
height_field {{ function 48, 48 {{ pigment {{ {pattern} }} }} smooth
  translate <-0.5, 0, -0.5> scale <12, 1.5, 12>
  pigment {{ rgb <0.9, 0.8, 0.6> }} finish {{ specular 0.6 roughness 0.02 }} }}
"""


@pytest.mark.povray
@pytest.mark.parametrize("pattern", ["checker color rgb 1 color rgb 0 scale 1/8", "bozo scale 0.2"])
def test_smoothed_steep_relief_is_shaded_as_povray(tmp_path, pattern):
    """RMSE and share of pixels off by more than 0.1, 160×120, no anti-aliasing: 0.006/0%
    (checker) and 0.003/0% (bozo); with normals averaged in the field's own space they
    were 0.127/30% and 0.087/19%."""
    text = STEEP.format(pattern=pattern)
    ref = povray_image(text, tmp_path, 160, 120)
    ours, _ = strala_image(text, tmp_path, 160, 120)
    rmse, off = image_errors(ours, ref)
    assert rmse < 0.015 and off < 0.005, (rmse, off)


def test_smooth_normals_point_up_on_flat_ground_and_sideways_only_on_a_step():
    h = np.zeros((5, 5))
    h[:, 3:] = 1.0  # a cliff between columns 2 and 3
    n = hf.povray_normals(h).reshape(5, 5, 3)
    assert np.allclose(n[:, 0], [0, 1, 0]) and np.allclose(n[:, 4], [0, 1, 0])
    # beside the cliff: still nearly up (the grid's 65536 per height makes the step steep)
    assert np.all(n[:, 2, 1] > 0.99) and np.all(n[:, 3, 1] > 0.99)
    assert np.allclose(np.linalg.norm(n, axis=-1), 1.0)
