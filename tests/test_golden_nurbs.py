"""Golden image: exact rational NURBS sphere and torus (scene text) against POV-Ray's analytic
`sphere` and `torus` in the same scene layout. Metric: RMSE on [0,1] sRGB display values."""

from __future__ import annotations

import shutil

import numpy as np
import pytest

from runtime.nurbs import nurbs_sphere, nurbs_torus

LAYOUT = """#version 3.7;
global_settings {{ assumed_gamma 1.0 }}
camera {{ location <0, 2.5, -6> look_at <0, 0.2, 0> angle 45 }}
light_source {{ <-8, 12, -10> rgb 1 }}
background {{ rgb <0.5, 0.6, 0.8> }}
plane {{ y, -1 pigment {{ checker rgb 0.8, rgb 0.4 }} }}
{sphere}
{torus}
"""
SPHERE_TEX = (
    "pigment { rgb <0.8, 0.3, 0.2> } finish { specular 0.6 roughness 0.01 } translate x*-1.3"
)
TORUS_TEX = (
    "pigment { rgb <0.2, 0.6, 0.3> } finish { phong 0.5 } rotate x*-50 translate <1.4, 0, 0>"
)


def nurbs_text(shape, modifiers: str, tolerance: float) -> str:
    pts = ", ".join(
        f"<{x!r}, {y!r}, {z!r}, {w!r}>"
        for (x, y, z), w in zip(shape.points, shape.weights, strict=True)
    )
    knots_u = ", ".join(repr(k) for k in shape.u_knots)
    knots_v = ", ".join(repr(k) for k in shape.v_knots)
    return (
        f"nurbs {{ u_degree {shape.u_degree} v_degree {shape.v_degree}\n"
        f"  control_points {{ {shape.nu}, {shape.nv}, {pts} }}\n"
        f"  u_knots {{ {knots_u} }} v_knots {{ {knots_v} }}\n"
        f"  tolerance {tolerance}\n  {modifiers} }}"
    )


@pytest.mark.povray
def test_nurbs_sphere_and_torus_match_povray_analytic_shapes(tmp_path):
    if shutil.which("povray") is None:
        pytest.skip("POV-Ray is not installed")
    from conftest import povray_image

    from lang.evaluate import compile_source
    from runtime.color import to_display
    from runtime.render import render_scene

    pov = LAYOUT.format(
        sphere=f"sphere {{ 0, 1 {SPHERE_TEX} }}", torus=f"torus {{ 1, 0.3 {TORUS_TEX} }}"
    )
    ref = povray_image(pov, tmp_path, 256, 192)
    scene_text = LAYOUT.format(
        sphere=nurbs_text(nurbs_sphere((0.0, 0.0, 0.0), 1.0), SPHERE_TEX, 1e-3),
        torus=nurbs_text(nurbs_torus(1.0, 0.3), TORUS_TEX, 1e-3),
    )
    (tmp_path / "n.scene").write_text(scene_text)
    result = compile_source(scene_text, str(tmp_path / "n.scene"))
    assert result.scene is not None, [d.message for d in result.diagnostics]
    assert sum(type(o.shape).__name__ == "Nurbs" for o in result.scene.objects) == 2
    ours = to_display(render_scene(result.scene, 256, 192), result.scene.settings)
    rmse = float(np.sqrt(((ours - ref) ** 2).mean()))
    off = float((np.abs(ours - ref).max(axis=-1) > 0.1).mean())
    print(f"NURBS vs analytic: RMSE {rmse:.4f}, {off:.2%} pixels off by > 0.1")
    assert rmse < 0.02


BICUBIC = """#version 3.7;
global_settings { assumed_gamma 1.0 }
camera { location <1.5, 3, -4> look_at <1.5, 0, 1.5> }
light_source { <-5, 10, -8> rgb 1 }
background { rgb <0.4, 0.5, 0.7> }
bicubic_patch { type 1 flatness 0.001 u_steps 4 v_steps 4
  <0, 0, 0>, <1, 1, 0>, <2, -1, 0>, <3, 0, 0>,
  <0, 1, 1>, <1, 2, 1>, <2, 0, 1>, <3, 1, 1>,
  <0, -1, 2>, <1, 0, 2>, <2, 1, 2>, <3, 0, 2>,
  <0, 0, 3>, <1, 1, 3>, <2, 0, 3>, <3, -1, 3>
  pigment { checker rgb <0.9, 0.3, 0.2>, rgb 0.9 scale 0.5 } finish { phong 0.5 }
}
"""


@pytest.mark.povray
def test_bicubic_patch_matches_povray(tmp_path):
    """POV-Ray's bicubic_patch runs on the NURBS machinery (an exact Bézier patch)."""
    if shutil.which("povray") is None:
        pytest.skip("POV-Ray is not installed")
    from conftest import povray_image

    from lang.evaluate import compile_source
    from runtime.color import to_display
    from runtime.render import render_scene

    ref = povray_image(BICUBIC, tmp_path, 160, 120)
    result = compile_source(BICUBIC, str(tmp_path / "b.pov"))
    assert not [d for d in result.diagnostics if d.severity.value != "note"], result.diagnostics
    (obj,) = result.scene.objects
    assert type(obj.shape).__name__ == "Nurbs" and obj.shape.nu == 4
    ours = to_display(render_scene(result.scene, 160, 120), result.scene.settings)
    covered = (np.abs(ref - np.array([0.4, 0.5, 0.7]) ** (1 / 2.2)).max(axis=-1) > 0.05).mean()
    assert covered > 0.05  # the patch is really in the picture
    rmse = float(np.sqrt(((ours - ref) ** 2).mean()))
    assert rmse < 0.02, rmse


# A patch with a pole (its first row one point: POV-Ray's normal there is <1, 0, 0>, which
# it interpolates across the triangles about it), few steps (flat facets), a mirror finish
# that shows every normal, and the defaults (no steps: two triangles)
POLE_PATCH = """#version 3.7;
global_settings {{ assumed_gamma 1.0 }}
camera {{ location <0.5, 2.2, -3.2> look_at <0.4, 0.3, 0.6> }}
light_source {{ <-5, 10, -8> rgb 1 }}
plane {{ y, -0.5 pigment {{ checker rgb 0.1, rgb 0.9 scale 0.4 }} }}
sky_sphere {{ pigment {{ gradient y
  color_map {{ [0 rgb <0.9, 0.6, 0.3>] [1 rgb <0.2, 0.3, 0.8>] }} }} }}
bicubic_patch {{ type 1 {settings}
  <0, 1, 0>, <0, 1, 0>, <0, 1, 0>, <0, 1, 0>,
  <0.6, 0.9, -0.3>, <0.7, 0.9, 0.3>, <0.6, 0.9, 0.9>, <0.5, 0.9, 1.4>,
  <1.2, 0.3, -0.5>, <1.3, 0.4, 0.3>, <1.4, 0.3, 1>, <1.2, 0.3, 1.6>,
  <1.5, -0.2, -0.6>, <1.6, -0.2, 0.3>, <1.7, -0.2, 1.1>, <1.5, -0.2, 1.8>
  pigment {{ rgb 0.2 }} finish {{ reflection 0.8 specular 0.6 roughness 0.01 }}
  translate <-0.3, 0, -0.2> }}
"""


@pytest.mark.povray
@pytest.mark.parametrize(
    "settings", ["flatness 0.001 u_steps 3 v_steps 2", "u_steps 5 v_steps 5", ""]
)
def test_bicubic_patch_triangles_and_normals_are_povrays(tmp_path, settings):
    """POV-Ray cuts a bicubic_patch into 2^u_steps x 2^v_steps pairs of flat triangles (fewer
    where flat enough) with its vertex normals interpolated. Metric: RMSE over sRGB [0,1]
    < 0.01 and under 0.5% of pixels off by > 0.1 at 96x72 (measured 0.0012 / 0% for each;
    before, tessellated to the camera's tolerance with exact normals: 0.024 / 0.6%,
    0.026 / 0.7% and 0.079 / 4.9%)."""
    if shutil.which("povray") is None:
        pytest.skip("POV-Ray is not installed")
    from conftest import image_errors, povray_image, strala_image

    text = POLE_PATCH.format(settings=settings)
    ref = povray_image(text, tmp_path, 96, 72)
    ours, _ = strala_image(text, tmp_path, 96, 72)
    rmse, off = image_errors(ours, ref)
    assert rmse < 0.01 and off < 0.005, (rmse, off)


def test_bicubic_patch_needs_sixteen_points():
    from lang.evaluate import compile_source

    result = compile_source("bicubic_patch { type 1 <0,0,0>, <1,0,0> }\n", "b.pov")
    (err,) = [d for d in result.diagnostics if d.severity.value == "error"]
    assert "16 control points, found 2" in err.message
