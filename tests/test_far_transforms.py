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

from lang import ir, transforms
from lang.evaluate import compile_source
from lang.transforms import out_of_reach
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


def _check(folder: Path, name: str, text: str) -> subprocess.CompletedProcess:
    (folder / name).write_text(text)
    env = dict(os.environ, PYTHONPATH=str(ROOT), STRALA_CACHE=str(folder / "cache"))
    return subprocess.run(
        [sys.executable, "-m", "runtime.cli", "check", name],
        cwd=folder, env=env, capture_output=True, text=True, timeout=600,
    )  # fmt: skip


def _w0324(out: str) -> list[str]:
    return [w for w in out.splitlines() if "W0324" in w]


@pytest.mark.parametrize(
    "leg, why",
    [("translate <1.05, 0, 1e300>", "1e+300 units out"), ("scale 1e-320", "singular")],
)
def test_egg_with_its_legs_out_of_reach_renders_without_them_and_says_so(tmp_path, leg, why):
    text = EGG.read_text()
    assert LEG in text
    far, far_err = _render_exr(tmp_path, "far.scene", text.replace(LEG, leg))
    line = text[: text.index(LEG)].count("\n")  # the box's line (the one above the translate)
    warned = _w0324(far_err)  # said once for the four legs: one line in the source
    assert warned == [f"far.scene:{line}:3: warning: this box is left out: " + warned[0].split(
        "this box is left out: ")[1]], far_err  # fmt: skip
    assert why in warned[0]
    assert "RuntimeWarning" not in far_err and "internal error" not in far_err
    # the same as the scene without the legs (radiosity included), to the last bit
    start = text.index("#for (I, 0, 3)")
    legless = text[:start] + text[text.index("#end", start) + len("#end") :]
    ref, _ = _render_exr(tmp_path, "legless.scene", legless)
    assert np.all(np.isfinite(far))
    assert np.array_equal(far, ref), float(np.abs(far - ref).max())


def test_egg_with_one_leg_out_of_reach_is_said_by_check_and_render(tmp_path):
    """Issue 22's case: one leg of egg.scene at `translate <1.05, 0, 1e300>` (the render was
    exit 3, a singular matrix in the radiosity solve). `check` says it at the leg's line, as
    `render` does (before, only the renderer did, in a line of its own), and the image at
    32×24 is the three-legged egg's, to the last bit."""
    text = EGG.read_text()
    one = text.replace(LEG, f"#if (I = 3) translate <1.05, 0, 1e300> #else {LEG} #end")
    line = text[: text.index(LEG)].count("\n")
    said = f"one.scene:{line}:3: warning: this box is left out: its transform takes it 1e+300"
    checked = _check(tmp_path, "one.scene", one)
    assert checked.returncode == 0, checked.stderr
    assert [w[: len(said)] for w in _w0324(checked.stdout + checked.stderr)] == [said]
    assert "Traceback" not in checked.stderr and "internal error" not in checked.stdout
    image, err = _render_exr(tmp_path, "one.scene", one)
    assert [w[: len(said)] for w in _w0324(err)] == [said], err
    assert "RuntimeWarning" not in err and "internal error" not in err
    three, _ = _render_exr(
        tmp_path, "three.scene", text.replace("#for (I, 0, 3)", "#for (I, 0, 2)")
    )
    assert np.all(np.isfinite(image)) and np.array_equal(image, three)


@pytest.mark.parametrize(
    "scene, left, said",
    [
        ("union { sphere { 0, 1 } sphere { 0, 1 translate 1e300 } }", 1, ["1:25 sphere"]),
        ("union { sphere { 0, 1 } sphere { 0, 1 } translate 1e300 }", 0, ["1:1 union"]),
        ("union { sphere { 0, 1 scale 1e-320 } box { -1, 1 translate <0, 0, 1e31> } }", 0,
         ["1:1 union"]),
        ("difference { box { -1, 1 } union { sphere { 0, 1 } sphere { 0, 1 } scale 1e-40 } }",
         1, ["1:28 union"]),
        ("sphere { 0, 1 matrix <0,0,0, 0,0,0, 0,0,0, 0,0,0> }", 0, ["1:1 sphere"]),
        ("sphere { 0, 1 translate 1e20 scale 1e-12 }", 1, []),
    ],
)  # fmt: skip
def test_a_csg_keeps_its_children_in_reach(scene, left, said):
    """A CSG's children out of reach are each left out and said at their line; a CSG left
    with none goes too (what the renderer did with them), said once, at the CSG."""
    r = compile_source(scene + "\n", "t.pov")
    assert r.scene is not None
    w = [d for d in r.diagnostics if d.code == "W0324"]
    assert [f"{d.span.line}:{d.span.col} {d.message.split()[1]}" for d in w] == said
    if left == 0:
        assert r.scene.objects == ()
    else:
        (obj,) = r.scene.objects
        assert len(obj.shape.children if isinstance(obj.shape, ir.CSG) else (obj,)) == left


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
    r = compile_source(f"sphere {{ 0, 1 {transform} }}\n", "t.pov")
    assert r.scene is not None, r.diagnostics
    said = [d.message for d in r.diagnostics if d.code == "W0324"]
    if why is None:
        assert not said and len(r.scene.objects) == 1
        assert out_of_reach(r.scene.objects[0].transform) is None
    else:
        assert len(said) == 1 and why in said[0] and r.scene.objects == (), said


def test_the_limit_is_far_past_scenes_sizes():
    assert out_of_reach(transforms.scale((FAR_LIMIT / 2,) * 3)) is None
    assert out_of_reach(transforms.scale((FAR_LIMIT * 2,) * 3)) is not None


def test_the_renderer_still_skips_an_object_out_of_reach_it_is_given():
    """An IR object that did not come through the evaluator's W0324 (built by hand, as a
    stored scene or another producer could): the renderer's own test, at its line."""
    far = ir.Object(
        shape=ir.Sphere((0.0, 0.0, 0.0), 1.0), transform=transforms.translate((0, 0, 1e300))
    )
    assert singular(far) is not None and "1e+300 units out" in singular(far)
    assert singular(ir.Object(shape=ir.Sphere((0.0, 0.0, 0.0), 1.0))) is None


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
