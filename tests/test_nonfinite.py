"""No NaN or infinity ever reaches an image: a scene whose values overflow (a light of
rgb 1e309, ambient 1e39, a background of ±1e308, a fog at a negative distance) renders finite
colours, counts the pixels it had to repair, and the command line says so."""

from __future__ import annotations

import numpy as np
import pytest

from runtime import api
from runtime.render import finite_pixels, render_scene

HEAD = "camera { location -5*z look_at 0 } light_source { <5, 5, -5> rgb 1 }\n"
BALL = "sphere { 0, 1 pigment { rgb 1 } }\n"


@pytest.mark.parametrize(
    "text",
    [
        BALL + "fog { distance -1 rgb 1 }",
        BALL + "light_source { <0, 5, -5> rgb 1e308 * 10 }",
        "sphere { 0, 1 pigment { rgb 1 } finish { ambient 1e39 } }",
        BALL + "background { rgb <1e308, -1e308, 1e308> }",
    ],
)
def test_overflowing_scenes_render_finite_colours(text):
    scene = api.compile_string(HEAD + text).scene
    stats: dict = {}
    image = render_scene(scene, 16, 12, stats=stats)
    assert np.isfinite(image).all()
    assert stats["nonfinite"] > 0


def test_an_ordinary_scene_needs_no_repair():
    stats: dict = {}
    render_scene(api.compile_string(HEAD + BALL).scene, 16, 12, stats=stats)
    assert stats["nonfinite"] == 0


def test_finite_pixels_repairs_only_what_is_not_finite():
    pix = np.array([[[0.5, np.nan, 1.0], [np.inf, 0.0, -np.inf], [1e39, 2.0, 3.0]]])
    fixed, bad = finite_pixels(pix)
    assert bad == 3
    assert fixed[0, 0].tolist() == [0.5, 0.0, 1.0]
    big = float(np.finfo(np.float32).max)
    assert fixed[0, 1].tolist() == [big, 0.0, -big] and fixed[0, 2, 0] == big


def test_the_command_line_warns_of_repaired_pixels(tmp_path, cli):
    scene = tmp_path / "f.pov"
    scene.write_text(HEAD + BALL + "fog { distance -1 rgb 1 }\n")
    r = cli("render", str(scene), "-o", str(tmp_path / "f.png"), "-W", "16", "-H", "12")
    assert r.returncode == 0, r.stderr
    assert "had no finite colour" in r.stderr
    assert (tmp_path / "f.png").exists()
