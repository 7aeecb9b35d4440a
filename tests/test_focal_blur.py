"""Focal blur (`aperture`, `blur_samples [min,] max`, `focal_point`, `confidence`,
`variance`): POV-Ray's thin lens, its confidence test, and images against POV-Ray."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import image_errors, povray_image, strala_image

from lang import ir
from lang.eval.versioning import CODES as VERSION_CODES
from lang.evaluate import compile_source
from runtime import render
from runtime.camera import FocalBlur, blur_thresholds


def _camera(**kw) -> ir.Camera:
    base = dict(location=(1.0, 2.0, -5.0), direction=(0.0, 0.0, 2.0), right=(1.33, 0.0, 0.0),
                up=(0.0, 1.0, 0.0), aperture=0.8, blur_samples=40,
                focal_point=(0.5, 1.0, 3.0))  # fmt: skip
    return ir.Camera(**{**base, **kw})


def test_a_points_rays_meet_on_the_focal_plane_from_a_disc_of_radius_aperture_over_4():
    cam = _camera()
    lens = FocalBlur(cam, 64, 48, np.array([10.5, 40.5]), np.array([5.5, 30.5]))
    for row in (0, 1):
        k = np.arange(lens.n)
        o, d, traced = lens.rays(np.full(lens.n, row), k)
        assert traced is None and np.allclose(np.linalg.norm(d, axis=1), 1.0)
        eye = np.asarray(cam.location)
        offset = o - eye
        assert np.allclose(offset @ np.asarray(cam.direction), 0.0)  # across the view
        assert np.linalg.norm(offset, axis=1).max() <= cam.aperture / 4 + 1e-12
        assert np.linalg.norm(offset, axis=1).max() > 0.8 * cam.aperture / 4  # the whole disc
        # where each ray crosses the focal plane (distance |focal_point - eye| along the
        # view): for one sub-pixel position that point would be the same for every lens
        # point; the sub-pixel jitter spreads them over one pixel's footprint only
        fwd = np.asarray(cam.direction) / np.linalg.norm(cam.direction)
        depth = np.linalg.norm(np.asarray(cam.focal_point) - eye)
        t = (depth - offset @ fwd) / (d @ fwd)
        hit = o + t[:, None] * d
        pixel = depth * np.linalg.norm(cam.right) / np.linalg.norm(cam.direction) / 64
        assert np.ptp(hit, axis=0).max() <= 1.01 * pixel


def test_every_prefix_of_the_lens_samples_is_spread_over_the_disc():
    lens = FocalBlur(_camera(blur_samples=64), 8, 8, np.full(50, 3.5), np.full(50, 4.5))
    # Bounds that independent uniform samples miss (they measure 0.29/0.20/0.17 off centre
    # and 0.069/0.050/0.041 off in |p|^2 over 200 points at 8/16/32 samples).
    for count, off_centre, off_r2 in ((8, 0.12, 0.035), (16, 0.06, 0.03), (32, 0.03, 0.02)):
        centre = np.hypot(lens.lx[:, :count].mean(1), lens.ly[:, :count].mean(1))
        assert centre.max() < off_centre  # a uniform disc of radius 0.5 has its mean at 0
        r2 = (lens.lx[:, :count] ** 2 + lens.ly[:, :count] ** 2).mean(1)
        assert np.abs(r2 - 0.125).max() < off_r2  # E|p|^2 on that disc is R^2 / 2


def test_confidence_thresholds_follow_the_chi_square_quantiles():
    thr = blur_thresholds(101, variance=1.0, confidence=0.9)
    # chi-square values exceeded with probability 0.9: df 100 -> 82.358, df 50 -> 37.689
    assert thr[-2] == pytest.approx(1.0, rel=1e-12)  # T[n-2] is the variance itself
    assert thr[49] / thr[99] == pytest.approx(37.689 / 82.358, rel=0.005)
    assert np.all(np.diff(thr) > 0)
    assert blur_thresholds(1, 1.0, 0.9).tolist() == [0.0]


def test_a_flat_image_stops_at_the_first_round_and_a_busy_one_takes_more(monkeypatch):
    traced: list[int] = []
    real = render.trace_primary

    def counting(ctx, origins, dirs, mask=None):
        traced.append(len(origins) if mask is None else int(mask.sum()))
        return real(ctx, origins, dirs, mask)

    monkeypatch.setattr(render, "trace_primary", counting)
    flat = "background { rgb 0.5 }"
    busy = "plane { z, 4 pigment { checker rgb 1, rgb 0 scale 0.05 } finish { ambient 1 } }"
    for body, few in ((flat, True), (busy, False)):
        traced.clear()
        text = ("camera { location 0 look_at z aperture 2 focal_point <0,0,1> "
                f"blur_samples 4, 64 }} {body}")  # fmt: skip
        scene = compile_source(text, "fb.pov").scene
        render.render_scene(scene, 8, 6, threads=1)
        if few:  # POV-Ray's rounds: 7 (its hexagonal grid), then 6 more before the 4 min
            assert sum(traced) == 8 * 6 * 7
        else:
            assert sum(traced) > 8 * 6 * 30


def test_camera_block_reads_the_focal_blur_items():
    cam = compile_source(
        "camera { location 0 look_at z aperture 0.5 blur_samples 5, 50 focal_point <0,0,4>"
        " confidence 0.95 variance 1/200 }",
        "fb.pov",
    ).scene.camera
    assert (cam.aperture, cam.blur_samples_min, cam.blur_samples) == (0.5, 5, 50)
    assert (cam.blur_confidence, cam.blur_variance) == (0.95, 1 / 200)
    assert compile_source("camera { blur_samples 9 }", "fb.pov").scene.camera.blur_samples == 9
    bad = compile_source("camera { confidence 2 }", "fb.pov")
    # POV-Ray's "Illegal confidence value. Default is used.": a warning, the default kept
    assert [d.code for d in bad.diagnostics if d.severity == "error"] == []
    assert "Illegal confidence value" in " ".join(d.message for d in bad.diagnostics)
    quiet = compile_source("camera { aperture 1 blur_samples 9 }", "fb.pov")
    # rendered now: no "accepted but ignored" warning (only POV-Ray's "No objects in scene")
    assert [d.code for d in quiet.diagnostics if d.code not in VERSION_CODES] == ["W0304"]


@pytest.mark.povray
def test_focal_blur_renders_like_povray(tmp_path):
    text = """#version 3.7;
global_settings { assumed_gamma 1 }
camera { location <0, 1.5, -6> look_at <0, 1, 0> right x*4/3 angle 40
         aperture 1.2 blur_samples 8, 60 focal_point <0, 1, 0> }
light_source { <4, 8, -6>, 1 }
plane { y, 0 pigment { checker rgb 0.9, rgb 0.15 } }
sphere { <0, 1, 0>, 1 pigment { rgb <1, 0.3, 0.1> } finish { phong 0.5 } }
sphere { <-2.2, 0.7, 4>, 0.7 pigment { rgb <0.2, 0.4, 1> } }
box { <1.4, 0, -2.5>, <2.2, 0.8, -1.7> pigment { rgb <0.2, 0.9, 0.3> } }
"""
    ref = povray_image(text, tmp_path, 96, 72)
    ours, messages = strala_image(text, tmp_path, 96, 72)
    assert messages == []
    # Both are noisy estimates that stop at a confidence test: POV-Ray's own noise is RMSE
    # 0.015 against strala's 400-sample render; strala's adaptive render measured 0.025.
    rmse, off = image_errors(ours, ref)
    assert rmse < 0.035 and off < 0.02, (rmse, off)
    # and the blur is real: the in-focus render differs from both
    sharp, _ = strala_image(text.replace("aperture 1.2", "aperture 0"), tmp_path, 96, 72)
    assert image_errors(sharp, ref)[0] > 2 * rmse
