"""Isosurfaces and function pigments rendered by strala and by POV-Ray 3.7 (the oracle).

Metric: both images as [0, 1] display values; RMSE over all pixels and channels, and the
fraction of pixels whose largest channel difference exceeds 0.1 (silhouette pixels hit or
missed at slightly different depths). The scenes name POV-Ray's built-in functions by
`internal(N)` so they need no include file on either side.
"""

from __future__ import annotations

import numpy as np
import pytest
from conftest import povray_image

from runtime import api

RMSE_LIMIT = 0.02
OUTLIER_LIMIT = 0.01

HEAD = """#version 3.7;
global_settings { assumed_gamma 1 }
camera { location <0, 3, -6> look_at <0, 0, 0> angle 50 }
light_source { <5, 8, -5>, 1 }
plane { y, -1 pigment { checker rgb 1 rgb 0.6 } }
#declare f_sphere = function { internal(61) }
#declare f_torus = function { internal(70) }
#declare f_rounded_box = function { internal(60) }
#declare f_helix1 = function { internal(25) }
"""

SHAPES = (
    HEAD
    + """
isosurface {
  function { f_rounded_box(x, y, z, 0.2, 0.8, 0.5, 0.6) }
  contained_by { box { -1, 1 } }
  pigment { rgb <1, 0.6, 0.3> } finish { phong 0.6 }
  translate <-2, 0, 0>
}
isosurface {
  function { f_torus(x, y, z, 0.7, 0.25) } max_gradient 1.2
  contained_by { box { -1, 1 } }
  pigment { rgb <0.3, 0.8, 0.3> }
}
isosurface {
  function { f_helix1(x, y, z, 2, 3, 0.12, 0.6, 1, 1, 0) } max_gradient 4
  contained_by { box { -1, 1 } }
  pigment { rgb <0.3, 0.5, 1> }
  translate <2, 0, 0>
}
isosurface {  // a ball cut by its container, walls closed
  function { x*x + y*y + z*z - 1 } max_gradient 4
  contained_by { box { <-1, -1, -0.6>, <1, 0.5, 1> } }
  pigment { rgb 0.9 } scale 0.6 translate <-1, 0, 2>
}
isosurface {  // the same ball, open
  function { f_sphere(x, y, z, 1) } open
  contained_by { box { <-1, -1, -0.6>, <1, 0.5, 1> } }
  pigment { rgb <0.9, 0.9, 0.3> } scale 0.6 translate <1, 0, 2>
}
"""
)

PIGMENT = """#version 3.7;
global_settings { assumed_gamma 1 }
camera { location <0, 0, -4> look_at 0 }
light_source { <3, 5, -6>, 1 }
#declare F = function(a, b) { a * a - b }
plane { z, 1.5
  pigment {
    function { F(x, y) * 0.7 + sin(4 * x) * 0.3 }
    color_map { [0 rgb <1, 0.2, 0>] [0.5 rgb <1, 1, 0.3>] [1 rgb <0, 0.3, 1>] }
    scale 1.3
  }
}
sphere { <0, 0, 0>, 1
  pigment { function { abs(y) * 3 } color_map { [0 rgb 0.1] [1 rgb <0.8, 1, 0.8>] } }
  finish { phong 0.5 }
}
"""


def compare(ours: np.ndarray, theirs: np.ndarray) -> tuple[float, float]:
    diff = np.abs(ours.astype(np.float64) - theirs.astype(np.float64))
    return float(np.sqrt((diff**2).mean())), float((diff.max(axis=2) > 0.1).mean())


@pytest.mark.povray
@pytest.mark.parametrize(("scene", "name"), [(SHAPES, "shapes"), (PIGMENT, "pigment")])
def test_matches_povray(tmp_path, scene, name):
    width, height = 240, 180
    theirs = povray_image(scene, tmp_path, width, height)
    compiled = api.compile_string(scene)
    ours = api.render(compiled, width=width, height=height)
    rmse, outliers = compare(ours, theirs)
    print(f"\n{name}: RMSE {rmse:.4f}, outliers {outliers * 100:.2f}%")
    assert rmse < RMSE_LIMIT
    assert outliers < OUTLIER_LIMIT


# trace() against isosurfaces, printed by #debug: POV-Ray finds a root on a grid fixed by the
# container's segment (its depth-first halving), so the points agree to the printed digits
# only if strala's search is POV-Ray's. Scaled, noisy and open surfaces, a shape entered
# through its container's wall, and rays that miss.
TRACES = """#version 3.7;
#declare f_noise3d = function { internal(76) }
#declare f_sphere = function { internal(61) }
#declare Ground = isosurface {
  function { y - f_noise3d(x / 3, 0, z / 2) * 0.5 }
  max_gradient 1.1
  contained_by { box { <-10, -3, -10>, <10, 1, 10> } }
}
#declare Ball = isosurface {
  function { f_sphere(x, y, z, 1) + f_noise3d(x * 2, y * 2, z * 2) * 0.4 }
  max_gradient 4
  contained_by { sphere { 0, 1.6 } }
  scale 0.3 translate <1, 2, 0>
}
#declare Cut = isosurface {  // the container cuts the solid: its walls show
  function { y + 0.5 }
  contained_by { box { -1, 1 } }
  translate <-3, 0, 0>
}
#declare Opened = isosurface { function { f_sphere(x, y, z, 0.7) } open accuracy 0.01 }
#declare S = seed(7);
#declare I = 0;
#while (I < 12)
  #declare O = <rand(S) * 8 - 4, 5, rand(S) * 8 - 4>;
  #declare N = <0, 0, 0>;
  #declare P = trace(Ground, O, -y, N);
  #debug concat("G", str(I, 0, 0), " ", vstr(3, P, ",", 0, 9), " ", vstr(3, N, ",", 0, 6), "\\n")
  #declare P = trace(Ball, <1, 2, -3>, <rand(S) - 0.5, rand(S) - 0.5, 3>, N);
  #debug concat("B", str(I, 0, 0), " ", vstr(3, P, ",", 0, 9), " ", vstr(3, N, ",", 0, 6), "\\n")
  #declare I = I + 1;
#end
#declare P = trace(Cut, <-3, -0.8, -5>, z, N);
#debug concat("C0 ", vstr(3, P, ",", 0, 9), " ", vstr(3, N, ",", 0, 6), "\\n")
#declare P = trace(Cut, <-3, 4, 0.2>, -y, N);
#debug concat("C1 ", vstr(3, P, ",", 0, 9), " ", vstr(3, N, ",", 0, 6), "\\n")
#declare P = trace(Opened, <0.2, 0.1, -4>, z, N);
#debug concat("O0 ", vstr(3, P, ",", 0, 9), " ", vstr(3, N, ",", 0, 6), "\\n")
"""


@pytest.mark.povray
def test_trace_finds_povrays_roots(tmp_path):
    import re

    from conftest import povray_debug

    from lang.evaluate import compile_source
    from runtime.queries import RuntimeQueries

    scene = tmp_path / "t.pov"
    scene.write_text(TRACES)
    line = re.compile(r"^[GBCO]\d+ [-\d.,e]+ [-\d.,e]+$")
    want = [s.strip() for s in povray_debug(scene).splitlines() if line.match(s.strip())]
    r = compile_source(TRACES, str(scene), queries=RuntimeQueries)
    got = [d.message.strip() for d in r.diagnostics if d.code == "N0100"]
    got = [s for g in got for s in g.splitlines() if line.match(s.strip())]
    assert len(want) == 27, want
    assert got == want
