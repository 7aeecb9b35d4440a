"""A camera `normal { … }` (camera.bend) through the compiled kernel: the same pixels as the
numpy path for perspective and orthographic cameras, with several patterns, scaled and
turbulent; the projections whose screen coordinates are angles stay on numpy and say so.
Metric: the largest channel difference of the two working-space images, < 1e-9."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import kernel_and_numpy

from runtime import api, whitted
from runtime.prepare import prepare

SCENE = """#version 3.7;
global_settings {{ assumed_gamma 1 }}
camera {{ {kind} location <0, 1.5, -5> look_at <0, 0.5, 0> normal {{ {normal} }} }}
light_source {{ <-4, 6, -5>, rgb 1 }}
plane {{ y, 0 pigment {{ checker rgb 1 rgb 0.2 }} }}
sphere {{ <0, 1, 0>, 1 pigment {{ rgb <1, 0.5, 0.2> }} finish {{ reflection 0.3 }} }}
"""


@pytest.mark.parametrize("kind", ["perspective", "orthographic"])
@pytest.mark.parametrize(
    "normal",
    ["bumps 0.4 scale 0.05", "ripples 0.6 frequency 4", "wrinkles 0.5 scale 0.1",
     "granite 0.3 turbulence 0.4", "dents 0.8 scale 0.02"],
)  # fmt: skip
def test_a_camera_normal_renders_as_the_numpy_path(monkeypatch, kind, normal):
    scene = api.compile_string(SCENE.format(kind=kind, normal=normal)).scene
    fast, slow = kernel_and_numpy(scene, 64, 48, monkeypatch)
    assert np.abs(fast - slow).max() < 1e-9
    plain = api.compile_string(SCENE.format(kind=kind, normal="bumps 0")).scene
    still, _ = kernel_and_numpy(plain, 64, 48, monkeypatch)
    assert np.abs(fast - still).max() > 0.05  # the normal bends the view


def test_a_camera_normal_with_anti_aliasing_as_the_numpy_path(monkeypatch):
    scene = api.compile_string(SCENE.format(kind="perspective", normal="bumps 0.5")).scene
    fast, slow = kernel_and_numpy(scene, 48, 36, monkeypatch, aa=0.1)
    assert np.abs(fast - slow).max() < 1e-9


@pytest.mark.parametrize("kind", ["fisheye", "panoramic", "spherical"])
def test_on_other_projections_it_stays_on_numpy(kind):
    scene = api.compile_string(SCENE.format(kind=kind, normal="bumps 0.5")).scene
    found = whitted.reasons(prepare(scene, 32, 24), scene.camera)
    assert f"camera normal on a {kind} camera" in found
