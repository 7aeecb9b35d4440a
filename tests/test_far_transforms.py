"""A transform that takes an object out of float64's reach (singular, not finite, or very far
or very small) skips the object with a warning at its line saying so, instead of NaNs or a
crash: egg.scene with a leg at `translate <1.05, 0, 1e300>` was exit 3 (a singular matrix in
the radiosity solve), and renders now as the scene without that leg."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from conftest import ROOT

from lang import ir
from lang.evaluate import compile_source
from runtime.inside import FAR_LIMIT, singular

EGG = ROOT / "examples" / "egg.scene"
LEG = "translate <(I < 2 ? -1.05 : 1.05), 0, (mod(I, 2) = 0 ? -0.65 : 0.65)>"


def _render_exr(folder: Path, name: str, text: str) -> tuple[np.ndarray, str]:
    import OpenImageIO as oiio

    (folder / name).write_text(text)
    env = dict(os.environ, PYTHONPATH=str(ROOT), STRALA_CACHE=str(folder / "cache"))
    r = subprocess.run(
        [sys.executable, "-m", "runtime.cli", "render", name, "-W", "32", "-H", "24",
         "-o", name + ".exr"],
        cwd=folder, env=env, capture_output=True, text=True, timeout=600,
    )  # fmt: skip
    assert r.returncode == 0, r.stderr
    return oiio.ImageBuf(str(folder / (name + ".exr"))).get_pixels(oiio.FLOAT), r.stderr


@pytest.mark.parametrize(
    "leg, why",
    [("translate <1.05, 0, 1e300>", "1e+300 units out"), ("scale 1e-320", "singular")],
)
def test_egg_with_a_leg_out_of_reach_renders_without_it_and_says_so(tmp_path, leg, why):
    text = EGG.read_text()
    assert LEG in text
    far, far_err = _render_exr(tmp_path, "far.scene", text.replace(LEG, leg))
    line = text[: text.index(LEG)].count("\n")  # the box's line (the one above the translate)
    warned = [w for w in far_err.splitlines() if "warning" in w and why in w]
    assert warned == [f"far.scene:{line}:3: warning: a box is skipped: " + warned[0].split(
        "a box is skipped: ")[1]], far_err  # fmt: skip
    assert "RuntimeWarning" not in far_err and "internal error" not in far_err
    # the same as the scene without the legs (radiosity included), to the last bit
    start = text.index("#for (I, 0, 3)")
    legless = text[:start] + text[text.index("#end", start) + len("#end") :]
    ref, _ = _render_exr(tmp_path, "legless.scene", legless)
    assert np.all(np.isfinite(far))
    assert np.array_equal(far, ref), float(np.abs(far - ref).max())


def _object(transform: str) -> ir.Object:
    r = compile_source(f"sphere {{ 0, 1 {transform} }}\n", "t.pov")
    assert r.scene is not None, r.diagnostics
    (obj,) = r.scene.objects
    return obj


@pytest.mark.parametrize(
    "transform, why",
    [
        ("translate <1.05, 0, 1e300>", "1e+300 units out"),
        ("scale 1e300 scale 1e300", "not finite"),
        ("scale 1e-320", "singular"),
        ("scale 1e-40", "shrinks it by 1e-40"),
        ("scale 1e31", "beyond 1e+30"),
        ("translate 1e20", None),  # far, still traced
        ("scale 1e-12", None),
        ("rotate 30 scale <1, 2, 3>", None),
    ],
)
def test_why_a_transform_cannot_be_traced(transform, why):
    found = singular(_object(transform))
    assert (found is None) if why is None else (found is not None and why in found), found


def test_the_limit_is_far_past_scenes_sizes():
    assert singular(_object(f"scale {FAR_LIMIT / 2}")) is None
    assert singular(_object(f"scale {FAR_LIMIT * 2}")) is not None


LAMP = "light_source { <-1.5, 2.6, -1.5> rgb 0.9 area_light x*0.4, z*0.4, 3, 3 }"


@pytest.mark.parametrize(
    "light, why",
    [
        ("light_source { <1.05, 0, 1e300> rgb 0.9 area_light x*0.4, z*0.4, 3, 3 }",
         "its position is 1e+300 units out"),
        ("light_source { <-1.5, 2.6, -1.5> rgb 0.9 spotlight point_at <0, 0, 1e300> }",
         "its point_at is 1e+300 units out"),
        ("light_source { <-1.5, 2.6, -1.5> rgb 0.9 translate 1e308 translate 1e308 }",
         "its position is not finite"),
    ],
)  # fmt: skip
def test_egg_with_its_light_out_of_reach_leaves_it_out_and_says_so(tmp_path, light, why):
    """The light's place overflows everything that measures a distance to it (POV-Ray's
    image has no light from it); before, the radiosity solve ran on the overflow and numpy's
    RuntimeWarning was the only word of it. Now a located warning, and the image of the egg
    without the light, to the last bit."""
    text = EGG.read_text()
    assert LAMP in text
    far, err = _render_exr(tmp_path, "far.scene", text.replace(LAMP, light))
    line = text[: text.index(LAMP)].count("\n") + 1
    warned = [w for w in err.splitlines() if "W0323" in w]
    assert len(warned) == 1 and warned[0].startswith(f"far.scene:{line}:1: warning: "), err
    assert why in warned[0]
    assert "RuntimeWarning" not in err and "internal error" not in err, err
    dark, _ = _render_exr(tmp_path, "dark.scene", text.replace(LAMP, ""))
    assert np.all(np.isfinite(far)) and np.array_equal(far, dark)


def test_a_light_within_reach_stays():
    r = compile_source("light_source { <1e29, 0, 0> rgb 1 }\nsphere { 0, 1 }\n", "t.pov")
    assert r.scene is not None and len(r.scene.lights) == 1
    assert not [d for d in r.diagnostics if d.code == "W0323"]
