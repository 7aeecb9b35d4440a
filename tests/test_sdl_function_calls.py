"""Functions whose bodies need the renderer (a pattern, a pigment, an internal `f_*`
function), called from the scene language: the values POV-Ray prints for them, and a scene
placed by them renders as POV-Ray's; vturbulence() likewise (POV-Ray's vector noise, the
renderer's). Without the renderer (`strala check`) they give 0 with a warning that says so."""

from __future__ import annotations

import re

import pytest
from conftest import image_errors, povray_debug, povray_image, strala_image

from lang.eval.versioning import CODES as VERSION_CODES
from lang.evaluate import compile_source
from runtime.queries import RuntimeQueries

# POV-Ray's scene-wide warnings (no objects, version and gamma): not what these test
SCENE_WIDE = VERSION_CODES | {"W0304"}

# Each line prints one value; the names keep the two outputs apart.
VALUES = """#version 3.7;
global_settings {{ assumed_gamma 1 {settings} }}
#include "functions.inc"
#declare B = function {{ pattern {{ bozo scale 0.3 }} }}
#declare A = function {{ pattern {{ agate scale 0.8 }} }}
#declare W = function {{ pattern {{ wood turbulence 0.2 }} }}
#declare P = function {{
  pigment {{ gradient x color_map {{ [0 rgb <1, 0, 0>] [1 rgb <0, 0, 1>] }} }}
}}
#declare G = function {{ P(x, y, z).blue * 2 + B(x, y, z) }}
#declare C = P(0.25, 0, 0);
#debug concat("V B ", str(B(0.1, 0.2, 0.3), 0, 6), "\\n")
#debug concat("V A ", str(A(1.3, -0.2, 0.7), 0, 6), "\\n")
#debug concat("V W ", str(W(0.4, 0.5, 0.6), 0, 6), "\\n")
#debug concat("V N ", str(f_noise3d(0.1, 0.2, 0.3), 0, 6), "\\n")
#debug concat("V S ", str(f_snoise3d(1.1, 0.2, 0.3), 0, 6), "\\n")
#debug concat("V R ", str(f_r(1, 2, 2), 0, 6), "\\n")
#debug concat("V Sph ", str(f_sphere(1, 2, 2, 1), 0, 6), "\\n")
#debug concat("V C ", vstr(5, C, " ", 0, 6), "\\n")
#debug concat("V red ", str(P(0.75, 0, 0).red, 0, 6), "\\n")
#debug concat("V G ", str(G(0.5, 0.1, 0.2), 0, 6), "\\n")
"""


def _values(text: str) -> dict[str, list[float]]:
    out = {}
    for m in re.finditer(r"^V (\w+) ([-\d. ]+)$", text, re.M):
        out[m.group(1)] = [float(v) for v in m.group(2).split()]
    return out


def _strala_values(text: str, tmp_path) -> dict[str, list[float]]:
    result = compile_source(text, str(tmp_path / "scene.pov"), queries=RuntimeQueries)
    assert result.scene is not None
    # probe scenes print values and hold no objects (POV-Ray's W0304 says so)
    warned = [
        d for d in result.diagnostics if d.severity.name == "WARNING" and d.code not in SCENE_WIDE
    ]
    assert not warned, [d.message for d in result.diagnostics]
    notes = "\n".join(d.message for d in result.diagnostics)
    return _values(notes)


@pytest.mark.povray
@pytest.mark.parametrize("settings", ["", "noise_generator 1", "noise_generator 3"])
def test_values_are_povrays(tmp_path, settings):
    """The pattern's scene-wide settings (noise_generator) reach a call made while parsing."""
    text = VALUES.format(settings=settings)
    scene = tmp_path / "values.pov"
    scene.write_text(text)
    ref = _values(povray_debug(scene))
    ours = _strala_values(text, tmp_path)
    assert set(ref) == set(ours) and len(ref) == 10, (ref, ours)
    for name, want in ref.items():
        assert ours[name] == pytest.approx(want, abs=2e-6), name


PLACED = """#version 3.7;
global_settings { assumed_gamma 1 }
#include "functions.inc"
camera { location <0, 1, -6> look_at <0, 0.3, 0> }
light_source { <-3, 8, -6> rgb 1 }
#declare H = function { pattern { granite scale 2 } }
#declare P = function {
  pigment { bozo scale 0.7 color_map { [0 rgb <1, 0.2, 0>] [1 rgb <0, 0.4, 1>] } }
}
#declare I = 0;
#while (I < 7)
  #declare X = I - 3;
  sphere { <X, H(X, 0, 0.5) * 2, 0>, 0.2 + 0.3 * f_noise3d(X, 1, 2)
    pigment { color P(X * 0.4, 0, 1) } }
  #declare I = I + 1;
#end
plane { y, -0.5 pigment { rgb 0.8 } }
"""


@pytest.mark.povray
def test_scene_placed_by_pattern_functions_renders_as_povray(tmp_path):
    ours, messages = strala_image(PLACED, tmp_path, 96, 72)
    assert messages == [], messages
    rmse, off = image_errors(ours, povray_image(PLACED, tmp_path, 96, 72))
    assert rmse < 0.01 and off < 0.005, (rmse, off)


def test_without_the_renderer_the_value_is_zero_and_said(tmp_path):
    text = VALUES.format(settings="")
    result = compile_source(text, str(tmp_path / "scene.pov"))
    assert result.scene is not None
    warnings = [
        d.message
        for d in result.diagnostics
        if d.severity.name == "WARNING" and d.code not in SCENE_WIDE
    ]
    assert "a pattern function called from the scene language gives 0 here" in warnings
    assert "a pigment function called from the scene language gives 0 here" in warnings
    assert "f_noise3d() called from the scene language gives 0 here" in warnings
    assert _values("\n".join(d.message for d in result.diagnostics))["B"] == [0.0]


# vturbulence at points on both sides of the noise lattice's cells, the octaves kept to
# POV-Ray's 1..10 (0 and 14 below), other lambdas and omegas.
TURBULENCE = """#version 3.7;
#declare I = 0;
#while (I < 12)
  #declare P = <I * 0.731 - 4.1, 2.3 - I * 0.417, I * I * 0.093 - 1.7>;
  #declare T = vturbulence(1.5 + I * 0.2, 0.3 + I * 0.05, I * 1.2, P);
  #debug concat("V T", str(I, 0, 0), " ", vstr(3, T, " ", 0, 6), "\\n")
  #declare I = I + 1;
#end
"""


@pytest.mark.povray
def test_vturbulence_values_are_povrays(tmp_path):
    scene = tmp_path / "turbulence.pov"
    scene.write_text(TURBULENCE)
    ref = _values(povray_debug(scene))
    ours = _strala_values(TURBULENCE, tmp_path)
    assert len(ref) == 12 and set(ours) == set(ref), (ref, ours)
    for name, want in ref.items():
        assert ours[name] == pytest.approx(want, abs=2e-6), name


def test_vturbulence_without_the_renderer_is_zero_and_said(tmp_path):
    result = compile_source(TURBULENCE, str(tmp_path / "scene.pov"))
    (warning,) = [
        d for d in result.diagnostics if d.severity.name == "WARNING" and d.code not in SCENE_WIDE
    ]
    assert warning.message.startswith("vturbulence() called from the scene language")
    assert (warning.span.line, warning.span.col) == (5, 16)
    assert _values("\n".join(d.message for d in result.diagnostics))["T3"] == [0.0] * 3


ISO = """#version 3.7;
global_settings { assumed_gamma 1 noise_generator GEN }
#include "functions.inc"
camera { location <0, 0, -4> look_at 0 }
light_source { <-3, 5, -6> rgb 1 }
isosurface { function { f_sphere(x, y, z, 1) - f_noise3d(x * 3, y * 3, z * 3) * 0.6 }
  contained_by { box { -1.5, 1.5 } } max_gradient 6 pigment { rgb <1, 0.8, 0.5> } }
"""


@pytest.mark.povray
@pytest.mark.parametrize("generator", [1, 3])
def test_f_noise3d_reads_the_scenes_generator_at_render_time(tmp_path, generator):
    text = ISO.replace("GEN", str(generator))
    ours, messages = strala_image(text, tmp_path, 96, 72)
    assert messages == [], messages
    rmse, off = image_errors(ours, povray_image(text, tmp_path, 96, 72))
    assert rmse < 0.02 and off < 0.01, (rmse, off)
