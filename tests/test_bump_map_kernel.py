"""bump_map normals through the compiled kernel (kernel/bump_map.h): the same pixels as the
numpy path (runtime.bump_map) for every mapping type and interpolation, once, use_index
(palette indices), bump_size, no_bump_scale, as a normal_map's entry, and an image gone
after the compile (unbumped on both). Metric: the largest channel difference of the two
working-space images, < 1e-9."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import MAPPED_SHAPES, kernel_and_numpy, same_on_kernel_and_numpy, write_palette_png
from hypothesis import given, settings
from hypothesis import strategies as st

from runtime import api

SCENE = """#version 3.7;
global_settings {{ assumed_gamma 1 }}
camera {{ location <0, 1.5, -4> look_at 0 }}
light_source {{ <-3, 5, -4>, rgb 1 }}
{shape} texture {{ pigment {{ rgb <1, 0.8, 0.6> }} {keep}
  normal {{ bump_map {{ {file} {extra} }} bump_size {size} {moves} }}
  finish {{ phong 0.6 }} }} }}
"""
SHAPES = MAPPED_SHAPES


def _write_heights(path, w=24, h=16) -> None:
    """Grey noise with steps, so every neighbour sample matters."""
    import OpenImageIO as oiio

    rng = np.random.default_rng(5)
    img = rng.integers(0, 256, size=(h, w, 3), dtype=np.uint8)
    out = oiio.ImageOutput.create(str(path))
    out.open(str(path), oiio.ImageSpec(w, h, 3, oiio.UINT8))
    out.write_image(img)
    out.close()


def _scene(folder, map_type, extra="", size=2.0, keep="", file="heights.png"):
    shape, moves = SHAPES[map_type]
    return SCENE.format(
        shape=shape, keep=keep, file=f'png "{folder / file}" map_type {map_type}',
        extra=extra, size=size, moves=moves,
    )  # fmt: skip


@pytest.mark.parametrize("map_type", sorted(SHAPES))
@pytest.mark.parametrize(
    "extra", ["", "interpolate 2", "interpolate 3", "interpolate 4", "once", "once interpolate 2"]
)
def test_every_mapping_renders_as_the_numpy_path(tmp_path, monkeypatch, map_type, extra):
    _write_heights(tmp_path / "heights.png")
    bumped = same_on_kernel_and_numpy(_scene(tmp_path, map_type, extra), monkeypatch)
    flat = same_on_kernel_and_numpy(_scene(tmp_path, map_type, extra, size=0.0), monkeypatch)
    assert np.abs(bumped - flat).max() > 0.02  # the map bends the shading


@pytest.mark.parametrize("extra", ["use_index", "use_index interpolate 2", "interpolate 4"])
def test_palette_indices_render_as_the_numpy_path(tmp_path, monkeypatch, extra):
    x, y = np.meshgrid(np.arange(16), np.arange(8))
    write_palette_png(tmp_path / "pal.png", (x * 7 + y * 3) % 16, bytes(range(0, 240, 5)))
    same_on_kernel_and_numpy(_scene(tmp_path, 0, extra, size=0.3, file="pal.png"), monkeypatch)


def test_no_bump_scale_and_in_a_normal_map(tmp_path, monkeypatch):
    _write_heights(tmp_path / "heights.png")
    same_on_kernel_and_numpy(_scene(tmp_path, 1, keep="no_bump_scale"), monkeypatch)
    text = (
        _scene(tmp_path, 1)
        .replace(
            "normal { bump_map",
            "normal { gradient y normal_map { [0 bumps 1 scale 0.1] [1 bump_map",
        )
        .replace("bump_size 2.0 rotate y*20 }", "bump_size 2.0 rotate y*20] } }")
    )
    same_on_kernel_and_numpy(text, monkeypatch)


def test_an_image_gone_after_the_compile_leaves_it_unbumped(tmp_path, monkeypatch):
    _write_heights(tmp_path / "gone.png")
    scene = api.compile_string(_scene(tmp_path, 0, file="gone.png")).scene
    (tmp_path / "gone.png").unlink()
    fast, slow = kernel_and_numpy(scene, 48, 36, monkeypatch)
    assert np.abs(fast - slow).max() < 1e-9


@settings(max_examples=15, deadline=None)
@given(
    map_type=st.sampled_from(sorted(SHAPES)),
    interp=st.sampled_from([0, 2, 3, 4]),
    once=st.booleans(),
    angles=st.tuples(*[st.floats(-180, 180)] * 3),
    scale=st.floats(0.2, 3.0),
    size=st.floats(-4, 4),
)
def test_any_placement_renders_as_the_numpy_path(
    tmp_path_factory, map_type, interp, once, angles, scale, size
):
    folder = tmp_path_factory.mktemp("bump")
    _write_heights(folder / "heights.png", 7, 5)  # odd sizes: the wrap at both ends
    shape, _ = SHAPES[map_type]
    text = SCENE.format(
        shape=shape, keep="", file=f'png "{folder / "heights.png"}" map_type {map_type}',
        extra=f"interpolate {interp} {'once' if once else ''}", size=size,
        moves="rotate <{}, {}, {}> scale {}".format(*angles, scale),
    )  # fmt: skip
    with pytest.MonkeyPatch.context() as mp:
        same_on_kernel_and_numpy(text, mp, 40, 30)
