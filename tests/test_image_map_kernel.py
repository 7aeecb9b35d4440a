"""image_map through the compiled kernel: the same pixels as the numpy path, its reference
(runtime.patterns.image_map), for every mapping type, interpolation, once, use_alpha,
filter and transmit (all, and per palette entry), gamma handling, in maps and the sky; a
missing image is black on both. Metric: the largest channel difference of the two
working-space images, < 1e-9 (the kernel does numpy's arithmetic in its order)."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import MAPPED_SHAPES, kernel_and_numpy, same_on_kernel_and_numpy, write_palette_png
from hypothesis import given, settings
from hypothesis import strategies as st

from runtime import api, whitted
from runtime.prepare import prepare

SCENE = """#version 3.7;
global_settings {{ assumed_gamma {gamma} }}
camera {{ location <0, 1.6, -4> look_at 0 }}
light_source {{ <-3, 5, -4>, rgb 1 }}
background {{ rgb <0.2, 0.3, 0.9> }}
plane {{ y, -1.2 pigment {{ checker rgb 1 rgb 0.3 }} }}
{shape} pigment {{ image_map {{ {file} {extra} }} {moves} }} }}
"""
SHAPES = MAPPED_SHAPES


def _write_rgba(path, w=24, h=12) -> None:
    """Distinct cells with a varying alpha, so a pixel off or a channel mixed shows."""
    import OpenImageIO as oiio

    rng = np.random.default_rng(3)
    img = rng.integers(0, 256, size=(h, w, 4), dtype=np.uint8)
    out = oiio.ImageOutput.create(str(path))
    out.open(str(path), oiio.ImageSpec(w, h, 4, oiio.UINT8))
    out.write_image(img)
    out.close()


def _palette(path) -> None:
    x, y = np.meshgrid(np.arange(16), np.arange(8))
    write_palette_png(path, (x // 2 + 8 * (y // 4)) % 16, bytes(range(0, 240, 5)))


@pytest.mark.parametrize("map_type", sorted(SHAPES))
@pytest.mark.parametrize(
    "extra",
    ["", "interpolate 2", "interpolate 4", "once", "use_alpha", "filter all 0.4 transmit all 0.2",
     "once interpolate 2 use_alpha"],
)  # fmt: skip
def test_every_mapping_renders_as_the_numpy_path(tmp_path, monkeypatch, map_type, extra):
    _write_rgba(tmp_path / "cells.png")
    monkeypatch.chdir(tmp_path)
    shape, moves = SHAPES[map_type]
    text = SCENE.format(
        gamma=1, shape=shape, file=f'png "cells.png" map_type {map_type}', extra=extra,
        moves=moves,
    )  # fmt: skip
    image = same_on_kernel_and_numpy(text, monkeypatch)
    assert image.std() > 0.05  # the picture is there, not a blank


@pytest.mark.parametrize("items", ["transmit 2, 1 filter 5, 0.6", "transmit all 0.3 transmit 6, 1",
                                   "interpolate 2 transmit 1, 0.8"])  # fmt: skip
def test_palette_entries_render_as_the_numpy_path(tmp_path, monkeypatch, items):
    _palette(tmp_path / "pal.png")
    monkeypatch.chdir(tmp_path)
    shape, moves = SHAPES[0]
    text = SCENE.format(gamma=1, shape=shape, file='png "pal.png"', extra=items, moves=moves)
    same_on_kernel_and_numpy(text, monkeypatch)


@pytest.mark.parametrize("version, gamma", [("3.7", 2.2), ("3.7", 1.0), ("3.6", 1.0)])
def test_gamma_as_the_numpy_path(tmp_path, monkeypatch, version, gamma):
    """The image decoded for the working gamma (and unchanged in a legacy scene)."""
    _write_rgba(tmp_path / "cells.png")
    monkeypatch.chdir(tmp_path)
    shape, moves = SHAPES[1]
    text = SCENE.format(
        gamma=gamma, shape=shape, file='png "cells.png" map_type 1 gamma 1.8', extra="",
        moves=moves,
    ).replace("#version 3.7", f"#version {version}")  # fmt: skip
    same_on_kernel_and_numpy(text, monkeypatch)


def test_in_a_pigment_map_with_turbulence_and_in_the_sky(tmp_path, monkeypatch):
    _write_rgba(tmp_path / "cells.png")
    monkeypatch.chdir(tmp_path)
    text = """#version 3.7;
global_settings { assumed_gamma 1 }
camera { location <0, 1, -4> look_at <0, 1, 0> }
light_source { <-3, 5, -4>, rgb 1 }
sky_sphere { pigment { image_map { png "cells.png" map_type 1 interpolate 2 } } }
sphere { <0, 1, 0>, 1.1
  pigment { gradient y turbulence 0.3 pigment_map {
    [0.3 image_map { png "cells.png" map_type 1 } rotate y*40]
    [0.7 rgb <1, 0.5, 0>] } } }
"""
    same_on_kernel_and_numpy(text, monkeypatch)


def test_an_image_gone_after_the_compile_is_black_on_both(tmp_path, monkeypatch):
    """As a compiled scene rendered where its image is not (an IR document moved)."""
    _write_rgba(tmp_path / "gone.png")
    monkeypatch.chdir(tmp_path)
    shape, moves = SHAPES[0]
    text = SCENE.format(gamma=1, shape=shape, file='png "gone.png"', extra="", moves=moves)
    scene = api.compile_string(text).scene
    (tmp_path / "gone.png").unlink()
    fast, slow = kernel_and_numpy(scene, 48, 36, monkeypatch)
    assert np.abs(fast - slow).max() < 1e-9
    assert (fast[18, 24] == 0).all()  # the box's middle: black


def test_warped_and_uv_mapped_images_stay_on_the_numpy_path(tmp_path, monkeypatch):
    _write_rgba(tmp_path / "cells.png")
    monkeypatch.chdir(tmp_path)
    for item, reason in (
        ('image_map { png "cells.png" } warp { repeat x }', "warped image_map"),
        ('uv_mapping image_map { png "cells.png" }', "uv_mapping"),
    ):
        text = f"camera {{ location -4*z look_at 0 }} sphere {{ 0, 1 pigment {{ {item} }} }}"
        scene = api.compile_string(text).scene
        assert reason in whitted.reasons(prepare(scene, 32, 24), scene.camera)


@settings(max_examples=15, deadline=None)
@given(
    map_type=st.sampled_from(sorted(SHAPES)),
    bilinear=st.booleans(),
    angles=st.tuples(*[st.floats(-180, 180)] * 3),
    scale=st.floats(0.2, 3.0),
    shift=st.tuples(*[st.floats(-2, 2)] * 3),
)
def test_any_placement_renders_as_the_numpy_path(
    tmp_path_factory, map_type, bilinear, angles, scale, shift
):
    """Wherever the image lands (rotated, scaled, moved: points outside the unit square,
    negative coordinates, the wrap), the kernel reads the pixel numpy reads."""
    folder = tmp_path_factory.mktemp("img")
    _write_rgba(folder / "cells.png", 7, 5)  # odd sizes: the bilinear wrap at both ends
    shape, _ = SHAPES[map_type]
    moves = "rotate <{}, {}, {}> scale {} translate <{}, {}, {}>".format(*angles, scale, *shift)
    text = SCENE.format(
        gamma=1, shape=shape, file=f'png "{folder / "cells.png"}" map_type {map_type}',
        extra="interpolate 2" if bilinear else "", moves=moves,
    )  # fmt: skip
    with pytest.MonkeyPatch.context() as mp:
        same_on_kernel_and_numpy(text, mp, 40, 30)
