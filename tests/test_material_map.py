"""`texture { material_map { … } }`: an image's palette index (or its red value times 255)
picks one whole texture at each point, as POV-Ray renders it, and runtime.material_map's
index rules on their own."""

from __future__ import annotations

import struct
import zlib
from pathlib import Path

import numpy as np
import pytest
from conftest import image_errors, povray_image, strala_image
from hypothesis import given
from hypothesis import strategies as st

from lang import ir
from lang.evaluate import compile_source
from runtime.material_map import material_index


def _png(path: Path, pixels: np.ndarray, colour_type: int, palette: bytes = b"") -> None:
    """An 8-bit PNG of (H, W) or (H, W, 3) bytes: colour type 0 grey, 2 RGB, 3 palette."""
    h, w = pixels.shape[:2]
    rows = pixels.astype(np.uint8).reshape(h, -1)
    raw = b"".join(b"\x00" + bytes(row) for row in rows)

    def chunk(tag: bytes, body: bytes) -> bytes:
        return struct.pack(">I", len(body)) + tag + body + struct.pack(">I", zlib.crc32(tag + body))

    path.write_bytes(
        b"\x89PNG\r\n\x1a\n"
        + chunk(b"IHDR", struct.pack(">IIBBBBB", w, h, 8, colour_type, 0, 0, 0))
        + (chunk(b"PLTE", palette) if palette else b"")
        + chunk(b"IDAT", zlib.compress(raw))
        + chunk(b"IEND", b"")
    )


def _indices(w: int = 12, h: int = 9, top: int = 7) -> np.ndarray:
    """Indices 0..top-1 in a pattern that is not aligned with the rows or columns."""
    y, x = np.mgrid[0:h, 0:w]
    return (x * 2 + y * 3 + (x * y) // 5) % top


def _write_images(folder: Path) -> None:
    index = _indices()
    # palette colours that do not follow the indices, so an index is not a colour's red
    palette = b"".join(bytes(((i * 97) % 256, (i * 31) % 256, 255 - i)) for i in range(256))
    _png(folder / "pal.png", index, 3, palette)
    _png(folder / "grey.png", index, 0)
    rgb = np.stack([index, (index * 53) % 256, np.full_like(index, 200)], axis=2)
    _png(folder / "rgb.png", rgb, 2)


HEAD = """#version 3.7;
global_settings { assumed_gamma 1 }
camera { location <0, 0, -4> look_at 0 right x*4/3 }
light_source { <-3, 4, -5>, rgb 1 }
"""
# four textures: indices 4 (the count) take the last, 5 and 6 wrap round to 1 and 2
TEXTURES = """
  texture { pigment { rgb <1, 0.2, 0.1> } finish { ambient 0.2 } }
  texture { pigment { checker rgb <0.2, 0.9, 0.2>, rgb 1 scale 0.1 } }
  texture { pigment { rgb <0.1, 0.3, 1> } normal { bumps 0.6 scale 0.05 } finish { phong 0.8 } }
  texture { pigment { gradient y color_map { [0 rgb 1] [1 rgb <1, 0.8, 0>] } scale 0.2 } }
"""
PLANE = "plane { -z, 0 texture { material_map { IMAGE" + TEXTURES + "} AFTER } }"


def _plane(image: str, after: str) -> str:
    return PLANE.replace("IMAGE", image).replace("AFTER", after)


SCENES = {
    "palette": _plane('png "pal.png"', "scale <3, 2.2, 1> translate -1.5*x"),
    "grey": _plane('png "grey.png"', "scale 1.7 rotate z*15"),
    "rgb red": _plane('png "rgb.png"', "scale 2"),
    "once": _plane('png "pal.png" once', "scale 2 translate <-1.2, -0.8, 0>"),
    "bilinear": _plane('png "pal.png" interpolate 2', "scale 2.5"),
    "normalised distance": _plane('png "pal.png" interpolate 4', "scale 2.5 translate y"),
    "bicubic, turned": _plane('png "pal.png" interpolate 3', "scale 3 rotate z*-25"),
    "spherical": 'sphere { 0, 1.5 texture { material_map { png "pal.png" map_type 1'
    + TEXTURES
    + "} rotate <20, 30, 0> } }",
}


@pytest.mark.povray
@pytest.mark.parametrize("name", SCENES)
def test_material_map_renders_like_povray(tmp_path, name):
    _write_images(tmp_path)
    text = HEAD + SCENES[name]
    ours, messages = strala_image(text, tmp_path, 96, 72)
    assert messages == []  # rendered: no "not supported yet"
    rmse, off = image_errors(ours, povray_image(text, tmp_path, 96, 72))
    # the bumps of the third texture shade a few pixels differently at tile edges
    assert rmse < 0.01 and off < 0.005, (rmse, off)


def _params(folder: Path, name: str, count: int, **extra) -> dict:
    return {"path": str(folder / name), "count": count, "map_type": 0, **extra}


def _pixel_centres(w: int = 12, h: int = 9) -> np.ndarray:
    """Pattern-space points at the centres of the image's pixels (row 0 at the top)."""
    y, x = np.mgrid[0:h, 0:w]
    return np.stack([(x.ravel() + 0.5) / w, 1.0 - (y.ravel() + 0.5) / h, np.zeros(w * h)], 1)


@given(st.integers(1, 9))
def test_indices_past_the_count_wrap_but_the_count_takes_the_last(tmp_path_factory, count):
    folder = tmp_path_factory.mktemp("mm")
    _write_images(folder)
    index = _indices().ravel()
    want = np.clip(np.where(index > count, index % count, index), 0, count - 1)
    for name in ("pal.png", "rgb.png"):
        got = material_index(_pixel_centres(), _params(folder, name, count))
        assert np.array_equal(got, want), name


# The textures POV-Ray 3.7 picks for the levels 0..15 of an 8-bit grey PNG (measured): it
# stores each level's grey in a byte, truncated, and some come out one lower.
POVRAY_GREY_LEVELS = [0, 1, 2, 2, 4, 4, 5, 7, 8, 9, 9, 11, 11, 13, 14, 15]


def test_grey_levels_read_as_povray_stores_them(tmp_path):
    _png(tmp_path / "levels.png", np.arange(16)[None, :], 0)
    got = material_index(_pixel_centres(16, 1), _params(tmp_path, "levels.png", 16))
    assert list(got) == POVRAY_GREY_LEVELS


@given(st.floats(0.0, 1.0), st.floats(0.0, 1.0), st.sampled_from([2, 3, 4]))
def test_an_interpolated_grey_image_gives_a_level_or_the_first(tmp_path_factory, u, v, interp):
    folder = tmp_path_factory.mktemp("mm")
    _png(folder / "flat.png", np.full((4, 4), 2), 0)
    params = _params(folder, "flat.png", 4, interpolate=interp)
    got = material_index(np.array([[u, v, 0.0]]), params)
    assert got[0] in (0, 2)


def test_off_the_image_once_is_the_first_texture(tmp_path):
    _write_images(tmp_path)
    p = np.array([[1.5, 0.5, 0.0], [-0.2, 0.5, 0.0], [0.5, 1.3, 0.0]])
    got = material_index(p, _params(tmp_path, "pal.png", 4, once=True))
    assert np.array_equal(got, [0, 0, 0])
    # repeated, the same points land on the image
    assert material_index(p, _params(tmp_path, "pal.png", 7)).any()


def test_the_texture_carries_the_image_and_its_textures(tmp_path):
    _write_images(tmp_path)  # an image not there stops the scene, as in POV-Ray
    result = compile_source(HEAD + SCENES["palette"], str(tmp_path / "m.pov"))
    assert result.scene is not None
    tex = result.scene.objects[0].texture
    assert isinstance(tex, ir.Texture) and tex.pattern is not None
    assert tex.pattern.pattern == "material_map" and tex.pattern.params["count"] == 4
    assert [k for k, _ in tex.map] == [0.0, 1.0, 2.0, 3.0]
