"""POV-Ray 3.7's version rules as its renders show them: a `#version` in any file makes the
version explicit, so a scene without one that includes a standard include (which keeps the
scene's version and sets it again at its end) is read with 3.7's gamma rules (assumed_gamma
1.0); without any #version, gamma handling is off; a #version before or after the include
wins. Each case: the floor's blue channel against POV-Ray's render of the same scene."""

from __future__ import annotations

import shutil
import subprocess
from pathlib import Path

import numpy as np
import OpenImageIO as oiio
import pytest

from runtime import api

SCENE = (
    "camera { location <0, 1, -4> look_at 0 }\n"
    "light_source { <2, 4, -3>, rgb 1 }\n"
    "plane { y, -1 pigment { rgb <0, 0, 0.8> } }\n"
)
# (what comes before the scene, the blue POV-Ray 3.7 gives the floor's pixel (20, 16))
CASES = {
    "no version, no include: gamma off": ("", 0.498),
    "colors.inc makes 3.7 explicit": ('#include "colors.inc"\n', 0.733),
    "shapes.inc too": ('#include "shapes.inc"\n', 0.733),
    "a #version after the include wins": ('#include "colors.inc"\n#version 3.6;\n', 0.498),
    "an include restores the scene's version": ('#version 3.6;\n#include "colors.inc"\n', 0.498),
    "a user include's #version counts": ('#include "mine.inc"\n', 0.733),
}


def _strala(tmp: Path, head: str) -> float:
    (tmp / "mine.inc").write_text("#version 3.7;\n")
    scene = tmp / "s.pov"
    scene.write_text(head + SCENE)
    image = api.render(str(scene), width=32, height=24)
    return float(image[20, 16, 2])


@pytest.mark.parametrize("name", sorted(CASES))
def test_version_rules(name, tmp_path):
    head, want = CASES[name]
    assert _strala(tmp_path, head) == pytest.approx(want, abs=0.004)


@pytest.mark.povray
@pytest.mark.parametrize("name", sorted(CASES))
def test_the_expected_values_are_povrays(name, tmp_path):
    if shutil.which("povray") is None:
        pytest.skip("POV-Ray is not installed")
    head, want = CASES[name]
    (tmp_path / "mine.inc").write_text("#version 3.7;\n")
    (tmp_path / "s.pov").write_text(head + SCENE)
    subprocess.run(
        [
            "povray",
            "+Is.pov",
            "+W32",
            "+H24",
            "-D",
            "-V",
            "+Os.png",
            "+L/usr/share/povray-3.7/include",
        ],
        cwd=tmp_path,
        capture_output=True,
        timeout=60,
        check=True,
    )
    image = oiio.ImageBuf(str(tmp_path / "s.png")).get_pixels()
    assert float(np.asarray(image)[20, 16, 2]) == pytest.approx(want, abs=0.004)
