"""checker cell edges exactly where POV-Ray 3.7 puts them (a floor at y = 0 and a wall)."""

from __future__ import annotations

import shutil

import numpy as np
import pytest

SCENE = """
camera { location <0.3, 2, -5> look_at <0.3, 0, 0> }
light_source { <10, 20, -10> rgb 1 }
plane { y, 0 pigment { checker rgb <0, 0.6, 0>, rgb 1 } }
plane { x, -2 pigment { checker rgb <0.6, 0, 0>, rgb 1 } }
"""


@pytest.mark.povray
def test_checker_on_integer_planes_matches_povray(tmp_path):
    if shutil.which("povray") is None:
        pytest.skip("POV-Ray is not installed")
    from conftest import povray_image

    from lang.evaluate import compile_source
    from runtime.color import to_display
    from runtime.render import render_scene

    ref = povray_image(SCENE, tmp_path, 160, 120)
    result = compile_source(SCENE, str(tmp_path / "f.pov"))
    ours = to_display(render_scene(result.scene, 160, 120), result.scene.settings)
    off = np.abs(ours - ref).max(axis=-1) > 0.1
    assert off.sum() == 0, f"{off.sum()} pixels differ from POV-Ray"
