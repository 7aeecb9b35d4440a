"""What POV-Ray warns about and repairs, strala warns about (located, in POV-Ray's words)
and repairs the same way, so the scene renders as POV-Ray renders it."""

from __future__ import annotations

import shutil
import subprocess

import numpy as np
import OpenImageIO as oiio
import pytest

from lang.evaluate import compile_source
from runtime import api

ZERO_SCALES = (
    "#version 3.7;\nglobal_settings { assumed_gamma 1 }\n"
    "camera { location -5*z look_at 0 } light_source { <2, 4, -3>, 1 }\n"
    "sphere { 0, 1 scale <0, .5, 0> pigment { rgb 1 } }\n"
    "box { -0.5, 0.5 scale <2, 0, 1> rotate 30 translate x*2 pigment { rgb <1, 0, 0> } }\n"
    "sphere { <-2, 0, 0>, 0.3 pigment { rgb 1 } scale 0 translate -x }\n"
)


def test_a_zero_scale_factor_becomes_1_with_povrays_warning():
    r = compile_source(ZERO_SCALES, "s.pov")
    assert not [d for d in r.diagnostics if d.severity.name == "ERROR"]
    warned = [(d.span.line, d.message) for d in r.diagnostics if d.code == "W0309"]
    assert warned == [
        (4, "Illegal Value: Scale X by 0.0. Changed to 1.0."),
        (4, "Illegal Value: Scale Z by 0.0. Changed to 1.0."),
        (5, "Illegal Value: Scale Y by 0.0. Changed to 1.0."),
        (6, "Illegal Value: Scale X by 0.0. Changed to 1.0."),
        (6, "Illegal Value: Scale Y by 0.0. Changed to 1.0."),
        (6, "Illegal Value: Scale Z by 0.0. Changed to 1.0."),
    ]
    assert r.scene is not None and len(r.scene.objects) == 3


@pytest.mark.povray
def test_zero_scales_render_as_povray(tmp_path):
    if shutil.which("povray") is None:
        pytest.skip("POV-Ray is not installed")
    scene = tmp_path / "s.pov"
    scene.write_text(ZERO_SCALES)
    subprocess.run(
        ["povray", f"+I{scene}", "+W64", "+H48", "-D", "-V", "+Opov.png"],
        cwd=tmp_path,
        capture_output=True,
        timeout=60,
        check=True,
    )
    theirs = np.asarray(oiio.ImageBuf(str(tmp_path / "pov.png")).get_pixels(), dtype=np.float64)
    ours = api.render(str(scene), width=64, height=48)
    assert float(np.abs(theirs - ours).max()) < 1 / 255 + 1e-6  # the same 8-bit image
