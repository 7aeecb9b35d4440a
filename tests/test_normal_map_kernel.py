"""normal_map through the compiled kernel: the normals of the entries around the pattern's
value blended by weight, an average of its entries, nested maps, no_bump_scale passed on,
turbulence and transforms: the same pixels as the numpy path (patterns._normal_map).
Metric: the largest channel difference of the two working-space images, < 1e-9."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import kernel_and_numpy, same_on_kernel_and_numpy
from hypothesis import given, settings
from hypothesis import strategies as st

from runtime import api

SCENE = """#version 3.7;
global_settings {{ assumed_gamma 1 }}
camera {{ location <0, 1.5, -4> look_at <0, 0.4, 0> }}
light_source {{ <-4, 6, -5>, rgb 1 }}
plane {{ y, -1 pigment {{ rgb 0.7 }} normal {{ {plane} }} }}
sphere {{ <0, 0.4, 0>, 1.2 texture {{ pigment {{ rgb <1, 0.6, 0.3> }} {keep}
  normal {{ {normal} }} finish {{ phong 0.8 }} }} }}
"""
MAPS = {
    "gradient": "gradient x normal_map { [0.3 bumps 0.8 scale 0.1] [0.7 ripples 1 frequency 9] }",
    "checker": "checker normal_map { [0 dents 2 scale 0.2] [1 wrinkles 0.6 scale 0.3] } scale 0.4",
    "average": "average normal_map { [1 bumps 0.5 scale 0.1] [3 gradient y 1 scale 0.2] }",
    "bumps parent": "bumps normal_map { [0.2 quilted 1 scale 0.2] [0.8 waves 1 frequency 5] }"
    " scale 0.3",
    "marble, turbulent": "marble turbulence 0.5 normal_map { [0 granite 0.4] [1 leopard 1"
    " scale 0.05] } scale 0.5",
    "ripples parent": "ripples frequency 3 normal_map { [0 bumps 1 scale 0.1] [1 dents 1] }",
    "nested": "gradient y normal_map { [0.2 onion normal_map { [0 bumps 1 scale 0.05]"
    " [1 ripples 2] } scale 0.3] [0.8 crackle 0.7 scale 0.2] } rotate z*30",
    "one entry": "spherical normal_map { [0.5 wrinkles 1 scale 0.2] }",
}


@pytest.mark.parametrize("keep", ["", "no_bump_scale"])
@pytest.mark.parametrize("case", sorted(MAPS))
def test_normal_maps_render_as_the_numpy_path(monkeypatch, case, keep):
    text = SCENE.format(plane="bumps 0.2 scale 0.3", keep=keep, normal=MAPS[case])
    bent = same_on_kernel_and_numpy(text, monkeypatch)
    smooth = SCENE.format(plane="bumps 0.2 scale 0.3", keep=keep, normal="bumps 0")
    plain = api.compile_string(smooth).scene
    ref, _ = kernel_and_numpy(plain, 64, 48, monkeypatch)
    assert np.abs(bent - ref).max() > 0.02  # the map bends the sphere's shading


@settings(max_examples=15, deadline=None)
@given(
    keys=st.lists(st.floats(0, 1), min_size=1, max_size=4).map(sorted),
    kinds=st.lists(st.sampled_from(["bumps 1", "dents 2", "ripples 1", "granite 0.5",
                                    "wrinkles 0.8", "gradient x 1"]), min_size=4, max_size=4),
    parent=st.sampled_from(["gradient x", "bozo", "wood", "average", "hexagon"]),
    scale=st.floats(0.05, 2.0),
)  # fmt: skip
def test_any_normal_map_renders_as_the_numpy_path(keys, kinds, parent, scale):
    entries = " ".join(f"[{k} {kind} scale 0.2]" for k, kind in zip(keys, kinds, strict=False))
    normal = f"{parent} normal_map {{ {entries} }} scale {scale}"
    with pytest.MonkeyPatch.context() as mp:
        same_on_kernel_and_numpy(SCENE.format(plane="", keep="", normal=normal), mp, 40, 30)
