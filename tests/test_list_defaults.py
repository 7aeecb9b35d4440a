"""A list pattern given fewer entries than it takes keeps POV-Ray's defaults for the rest:
colour entries replace the pattern's default colours one by one (checker's blue and green),
pigment entries leave black pigments. Each case against POV-Ray's render."""

from __future__ import annotations

import shutil
import subprocess

import numpy as np
import OpenImageIO as oiio
import pytest

from lang.evaluate import compile_source
from runtime import api

CASES = {
    "checker, one colour": ("checker color rgb <0, 1, 0>", [(0, 1, 0), (0, 1, 0)]),
    "checker, one pigment": ("checker pigment { color rgb <0, 1, 0> }", [(0, 1, 0), (0, 0, 0)]),
    "hexagon, one pigment": (
        "hexagon pigment { color rgb <0, 1, 0> }",
        [(0, 1, 0), (0, 0, 0), (0, 0, 0)],
    ),
    "brick, one pigment": ("brick pigment { color rgb <0, 1, 0> }", [(0, 1, 0), (0, 0, 0)]),
    "brick, one colour": ("brick color rgb <0, 1, 0>", [(0, 1, 0), (0.6, 0.15, 0.15)]),
}


def _scene(pigment: str) -> str:
    return (
        "#version 3.7;\nglobal_settings { assumed_gamma 1 }\n"
        "camera { orthographic location <0, 0, -5> look_at 0 right 4*x up 3*y }\n"
        f"plane {{ z, 0 pigment {{ {pigment} }} finish {{ ambient 1 diffuse 0 }} }}\n"
    )


@pytest.mark.parametrize("name", sorted(CASES))
def test_missing_entries_take_povrays_defaults(name):
    pigment, want = CASES[name]
    r = compile_source(_scene(pigment), "d.pov")
    assert r.scene is not None
    entries = r.scene.objects[0].texture.pigment.list
    assert [tuple(p.color[:3]) for p in entries] == [tuple(map(float, c)) for c in want]


@pytest.mark.povray
@pytest.mark.parametrize("name", sorted(CASES))
def test_list_defaults_render_as_povray(name, tmp_path):
    if shutil.which("povray") is None:
        pytest.skip("POV-Ray is not installed")
    scene = tmp_path / "d.pov"
    scene.write_text(_scene(CASES[name][0]))
    subprocess.run(
        ["povray", f"+I{scene}", "+W16", "+H12", "-D", "-V", "+Opov.png"],
        cwd=tmp_path,
        capture_output=True,
        timeout=60,
        check=True,
    )
    theirs = np.asarray(oiio.ImageBuf(str(tmp_path / "pov.png")).get_pixels(), dtype=np.float64)
    ours = api.render(str(scene), width=16, height=12)
    assert float((np.abs(theirs - ours).max(axis=2) > 0.1).mean()) == 0.0  # no pixel off
