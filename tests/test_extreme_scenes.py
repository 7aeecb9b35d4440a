"""Values far outside what a scene means give a located error or a warning and a finite
render, never an internal error: a focal blur of 1e30 samples, a radiosity scene with a box
1e300 long, an area light of 10^10 samples."""

from __future__ import annotations

import numpy as np

from runtime import api
from runtime.render import render_scene

HEAD = "light_source { <5, 5, -5> rgb 1 }\n"


def test_blur_samples_beyond_what_can_be_held_is_a_located_camera_error(tmp_path, cli):
    scene = tmp_path / "b.pov"
    scene.write_text(
        "camera { location -5*z look_at 0 aperture 0.4 blur_samples 1e30 }\n"
        + HEAD
        + "sphere { 0, 1 pigment { rgb 1 } }\n"
    )
    r = cli("render", str(scene), "-o", str(tmp_path / "b.png"), "-W", "16", "-H", "12")
    assert r.returncode == 1, r.stderr
    assert "b.pov:1:" in r.stderr and "blur_samples takes at most" in r.stderr
    assert "internal error" not in r.stderr
    assert not (tmp_path / "b.png").exists()


def test_a_surface_too_large_for_patches_is_left_to_the_ambient_estimate():
    text = (
        "camera { location -5*z look_at 0 }\n" + HEAD + "global_settings { radiosity {} }\n"
        "box { <-1, 0, -1>, <1, 1, 1e300> pigment { rgb 1 } }\n"
        "sphere { <0, -2, 0>, 0.5 pigment { rgb 1 } }\n"
    )
    scene = api.compile_string(text).scene
    image = render_scene(scene, 16, 12)
    assert np.isfinite(image).all()


def test_an_infinite_literal_is_a_located_error():
    from lang.evaluate import compile_source

    r = compile_source("sphere { 0, 1 rotate <1e400, 0, 0> }\n", "t.pov")
    errs = [d for d in r.diagnostics if d.severity == "error"]
    assert [(e.code, e.span.line, e.span.col) for e in errs] == [("E0006", 1, 23)]


def test_an_include_name_too_long_for_the_system_is_not_found(tmp_path):
    from lang.evaluate import compile_source

    r = compile_source(f'#include "{"a" * 300}.inc"\n', str(tmp_path / "t.pov"))
    assert [d.code for d in r.diagnostics if d.severity == "error"] == ["E0220"]


def test_an_undefined_max_trace_level_outside_global_settings_is_a_located_error():
    # found by the fuzzing job: the statement outside global_settings (POV-Ray's old
    # form) was read before any statement's error recovery, and 0/0 was an internal error
    from lang.evaluate import compile_source

    for text in ("max_trace_level 0/0\nsphere { 0, 1 }\n",
                 "global_settings { max_trace_level 0/0 }\nsphere { 0, 1 }\n"):  # fmt: skip
        r = compile_source(text, "t.pov")
        errs = [d for d in r.diagnostics if d.severity == "error"]
        assert [e.code for e in errs] == ["E0203"] and errs[0].span.line == 1


def test_an_area_light_of_more_samples_than_memory_holds_is_a_located_error():
    from lang.evaluate import compile_source

    for size in ("100000, 100000", "2147483648, 2"):
        text = f"sphere {{ 0, 1 }}\nlight_source {{ 0, 1 area_light x, z, {size} adaptive 1 }}\n"
        r = compile_source(text, "t.pov")
        errs = [d for d in r.diagnostics if d.severity == "error"]
        assert [(e.code, e.span.line) for e in errs] == [("E0238", 2)], errs
        assert "at most 1,000,000" in errs[0].message
    ok = compile_source("light_source { 0, 1 area_light x, z, 1000, 1000 }\n", "t.pov")
    assert not [d for d in ok.diagnostics if d.severity == "error"]
