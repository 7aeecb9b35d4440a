"""Leniency as POV-Ray's: what POV-Ray 3.7 warns about and repairs, strala warns about (at
the place, in POV-Ray's words, with POV-Ray's repair) and renders the same; what POV-Ray
refuses, strala refuses.

One golden case per rule: a minimal scene rendered by both. A `warn` case asserts that
POV-Ray prints its message and renders, that strala gives the located warning (code, line)
and that the two images agree within the case's tolerance; a `refuse` case asserts that
POV-Ray stops and strala reports the located error. The rules come from POV-Ray's parser
(parse.cpp, parstxtr.cpp, express.cpp, tokenize.cpp): each case names the function.
"""

from __future__ import annotations

import re
import subprocess
from dataclasses import dataclass

import pytest
from conftest import image_errors, strala_image

from lang.evaluate import compile_source

W, H = 64, 48

HEAD = """#version 3.7;
global_settings { assumed_gamma 1 }
camera { location <0, 1, -4> look_at 0 }
light_source { <2, 10, -3> rgb 1 }
plane { z, 3 pigment { checker rgb 1 rgb <0.2, 0.3, 0.8> scale 0.5 } }
"""
FIRST = HEAD.count("\n") + 1  # the line of a case's first body line
RED = "pigment { rgb <1, 0.2, 0.2> }"


@dataclass(frozen=True)
class Case:
    id: str
    body: str
    code: str  # strala's diagnostic code
    povray: str  # the start of POV-Ray's message
    line: int = 0  # the body line (0-based) strala locates it at
    refuse: bool = False
    head: bool = True  # False: the body is the whole scene
    rmse: float = 0.005
    off: float = 0.01  # share of pixels off by more than 0.1 in some channel

    @property
    def text(self) -> str:
        return (HEAD if self.head else "") + self.body + "\n"

    @property
    def where(self) -> int:
        return (FIRST if self.head else 1) + self.line


CASES = [
    # parstxtr.cpp, Parse_Finish: kept, the highlight's exponent is 0
    Case(
        "zero-roughness",
        f"sphere {{ 0, 1 {RED} finish {{ specular 0.8 roughness 0 }} }}",
        "W0313",
        "Zero roughness used.",
    ),
    # parse.cpp, Parse_Object_Mods: a colour among an object's modifiers is dropped
    Case(
        "quick-color",
        "sphere { 0, 1 color rgb <1, 0, 0> }",
        "W0312",
        "Quick color belongs in texture. Color ignored.",
    ),
    # parse.cpp, Parse_Frame: read as if in global_settings (no reflection at level 1)
    Case(
        "max-trace-level-at-top",
        "max_trace_level 1\n"
        "sphere { 0, 1 pigment { rgb <1, 0.2, 0.2> } finish { reflection 0.6 } }",
        "W0314",
        "'max_trace_level' should be in global_settings block.",
    ),
    # parse.cpp, Parse_Global_Settings: lowered to MAX_TRACE_LEVEL_LIMIT
    Case(
        "max-trace-level-limit",
        "global_settings { max_trace_level 300 }\n"
        "sphere { 0, 1 pigment { rgb <1, 0.2, 0.2> } finish { reflection 0.6 } }",
        "W0309",
        "Maximum max_trace_level is 256 but 300 was specified.",
    ),
    # cones.cpp, Compute_Cylinder_Data / Compute_Cone_Data: the parse stops
    Case(
        "degenerate-cylinder",
        f"cylinder {{ <0, 1, 0>, <0, 1, 0>, 1 {RED} }}",
        "E0290",
        "Degenerate cylinder, base point = apex point.",
        refuse=True,
    ),
    Case(
        "degenerate-cone",
        f"cone {{ 0, 1, 0, 0.5 {RED} }}",
        "E0290",
        "Degenerate cone/cylinder.",
        refuse=True,
    ),
    # parse.cpp, Parse_Triangle / Parse_Smooth_Triangle: rendered as nothing
    Case(
        "degenerate-triangle",
        f"triangle {{ 0, x, 2*x {RED} }}\nsphere {{ 0, 0.4 {RED} }}",
        "W0303",
        "Degenerate triangle. Please remove.",
    ),
    Case(
        "degenerate-smooth-triangle",
        "smooth_triangle { <-1, 0, 0>, 0, <1, 0, 0>, <0, 0, -1>, <0, 1, 0>, <0, 1, -1> "
        f"{RED} }}\nsphere {{ 0, 0.4 {RED} }}",
        "W0303",
        "Degenerate triangle. Please remove.",
    ),
    # parse.cpp, Parse_CSG
    Case(
        "csg-of-one",
        f"union {{ sphere {{ 0, 1 }} {RED} }}",
        "W0313",
        "Should have at least 2 objects in csg.",
    ),
    # parse.cpp, Parse_Frame: the last camera is used
    Case(
        "second-camera",
        f"camera {{ location <0, 2, -6> look_at 0 }}\nsphere {{ 0, 1 {RED} }}",
        "W0312",
        "More than one camera in scene. Ignoring previous camera(s).",
    ),
    # parse.cpp, Parse_Camera: the vectors are used as given
    Case(
        "camera-not-perpendicular",
        "#version 3.7;\nglobal_settings { assumed_gamma 1 }\n"
        "camera { location <0, 1, -4> direction <0, 0.5, 1> up <0, 1, 0.3> right <1.33, 0, 0> }\n"
        f"light_source {{ <2, 10, -3> rgb 1 }}\nsphere {{ 0, 1 {RED} }}",
        "W0306",
        "Camera vectors are not perpendicular.",
        line=2,
        head=False,
    ),
    Case(
        "camera-along-sky",
        "#version 3.7;\nglobal_settings { assumed_gamma 1 }\n"
        "camera { location <0, 4, 0> look_at 0 }\nlight_source { <2, 10, -3> rgb 1 }\n"
        "sphere { 0, 1 pigment { checker rgb <1, 0, 0> rgb 1 scale 0.3 } }",
        "W0306",
        "Camera location to look_at direction and sky direction should be different.",
        line=2,
        head=False,
    ),
    # parse.cpp, Parse: a scene without objects (a light source counts as one) renders
    # its background; located at the file's last line, as POV-Ray locates it
    Case(
        "no-objects",
        "#version 3.7;\nglobal_settings { assumed_gamma 1 }\nbackground { rgb <0.2, 0.4, 0.8> }\n"
        "camera { location <0, 1, -4> look_at 0 }",
        "W0304",
        "No objects in scene.",
        line=3,
        head=False,
    ),
    Case(
        "light-is-an-object",
        "#version 3.7;\nglobal_settings { assumed_gamma 1 }\nbackground { rgb <0.2, 0.4, 0.8> }\n"
        "camera { location <0, 1, -4> look_at 0 }\nlight_source { <2, 10, -3> rgb 1 }",
        "",
        "",
        head=False,
    ),
]


CASES += [
    # express.cpp, Parse_Colour: the components fill red, green, blue, filter, transmit
    Case(
        "rgb-with-four-components",
        "sphere { 0, 1 pigment { rgb <1, 0.2, 0.2, 0.6> } }",
        "W0313",
        "Suspicious expression after rgb.",
    ),
    Case(
        "rgbt-with-five-components",
        "sphere { 0, 1 pigment { rgbt <1, 0.2, 0.2, 0.6, 0.1> } }",
        "W0313",
        "Suspicious expression after rgbt.",
    ),
    # ... and fewer are padded with zeros, silently (Promote_Express)
    Case("rgb-with-two-components", "sphere { 0, 1 pigment { rgb <1, 0.4> } }", "", ""),
    # parse.cpp, Parse_Polygon: the last sub-polygon is closed on its first point
    Case(
        "polygon-not-closed",
        "polygon { 7, <-1, 0, 0>, <1, 0, 0>, <1, 1, 0>, <-1, 0, 0>, <-1, -1, 0>, <0, -1, 0>, "
        f"<0, -0.5, 0> {RED} }}",
        "W0309",
        "Polygon not closed. Closing it.",
    ),
    # ... which reads exactly the number of points it declares
    Case(
        "polygon-count",
        f"polygon {{ 5, <-1, 0, 0>, <1, 0, 0>, <1, 1, 0>, <-1, 1, 0> {RED} }}",
        "E0290",
        "",
        refuse=True,
    ),
    # parse.cpp, Parse_Prism: a linear outline is closed, a curved one makes it degenerate
    Case(
        "linear-prism-not-closed",
        "prism { 0, 1, 9, <-1, -1>, <1, -1>, <1, 1>, <-1, 1>, <-1, -1>, "
        f"<-0.5, -0.5>, <0.5, -0.5>, <0.5, 0.5>, <-0.5, 0.5> {RED} rotate -90*x }}",
        "W0309",
        "Linear prism not closed. Closing it.",
    ),
    Case(
        "bezier-prism-not-closed",
        "prism { bezier_spline 0, 1, 8, <-1, 0>, <-1, -1>, <0, -1>, <0.5, -1>, <0.5, -1>, "
        f"<1, 0>, <1, 1>, <0, 1> {RED} rotate -90*x }}\nsphere {{ 0, 0.3 {RED} }}",
        "W0303",
        "Prism not closed. Ignoring it.",
    ),
    # ... and then Compute_Prism (prism.cpp) runs out of points
    Case(
        "quadratic-prism-not-closed",
        f"prism {{ quadratic_spline 0, 1, 5, <-1, -1>, <1, -1>, <1, 1>, <-1, 1>, <-1, 0> {RED} }}",
        "E0290",
        "Too few points in prism.",
        refuse=True,
    ),
]

CASES += [
    # express.cpp, Parse_Mult_Factor: the quotient is +HUGE_VAL
    Case(
        "divide-by-zero",
        f"#declare K = -1/0;\n#if (K > 1e30) sphere {{ 0, 1 {RED} }} #end",
        "W0309",
        "Divide by zero.",
    ),
    # express.cpp, Parse_Vector_Factor: the zero vector (a possible error)
    Case(
        "normalize-zero-vector",
        f"sphere {{ vnormalize(<0, 0, 0>), 1 {RED} }}",
        "W0309",
        "Normalizing zero-length vector.",
    ),
]

ISO = (
    "isosurface {{ function {{ sqrt(x*x + y*y + z*z) - 1 }} {} "
    "contained_by {{ box {{ -2, 2 }} }} {} }}"
)
CASES += [
    # parse.cpp, Parse_Global_Settings: the first assumed_gamma stands
    Case(
        "assumed-gamma-twice",
        f"global_settings {{ assumed_gamma 2.2 }}\nsphere {{ 0, 1 {RED} }}",
        "W0312",
        "New instance of assumed_gamma ignored",
    ),
    # ... and Parse_Frame: max_intersections is read and has no effect
    Case(
        "max-intersections",
        f"global_settings {{ max_intersections 64 }}\nsphere {{ 0, 1 {RED} }}",
        "W0312",
        "'max_intersections' is no longer needed",
    ),
    Case(
        "max-intersections-at-top",
        f"max_intersections 64\nsphere {{ 0, 1 {RED} }}",
        "W0312",
        "'max_intersections' is no longer needed",
    ),
    # parse.cpp, Parse_Isosurface: the defaults replace values it cannot use
    Case(
        "isosurface-accuracy",
        ISO.format("accuracy 0", RED),
        "W0309",
        "Isosurface 'accuracy' is not positive. Using 0.001 (default).",
    ),
    Case(
        "isosurface-max-gradient",
        ISO.format("max_gradient -1", RED),
        "W0309",
        "Isosurface 'max_gradient' is not positive. Using 1.1 (default).",
    ),
    Case(
        "isosurface-max-trace",
        ISO.format("max_trace 20", RED),
        "W0309",
        "Isosurface 'max_trace' exceeds maximum of 10. Using maximum.",
    ),
    Case(
        "isosurface-max-trace-zero",
        ISO.format("max_trace 0", RED),
        "W0309",
        "Isosurface 'max_trace' is not positive. Using 1 (default).",
    ),
]

CASES += [
    # parse.cpp, Parse_Mesh: a zero normal becomes <1,0,0>; a flat triangle is dropped quietly
    Case(
        "mesh-zero-normal",
        "mesh { smooth_triangle { <-1, 0, 0>, 0, <1, 0, 0>, <0, 0, -1>, <0, 1, 0>, <0, 0, -1> } "
        f"triangle {{ 0, x, 2*x }} {RED} }}",
        "W0309",
        "Normal vector in mesh cannot be zero - changing it to <1,0,0>.",
    ),
    # parse.cpp, Parse_Frame: the last sky_sphere is used
    Case(
        "second-sky-sphere",
        "sky_sphere { pigment { rgb <0, 1, 0> } }\nsky_sphere { pigment { rgb <0, 0, 1> } }\n"
        f"sphere {{ 0, 1 {RED} }}",
        "W0312",
        "Only one sky-sphere allowed (last one will be used).",
        line=1,
    ),
]


def _flat(text: str) -> str:
    return re.sub(r"\s+", " ", text)


@pytest.mark.parametrize("case", CASES, ids=[c.id for c in CASES])
def test_strala_locates_it(case: Case) -> None:
    diags = compile_source(case.text, "w.pov").diagnostics
    if not case.code:  # read silently, as POV-Ray reads it
        assert not [d for d in diags if d.severity.value != "note"], [d.format() for d in diags]
        return
    got = [(d.code, d.span.line) for d in diags if d.code == case.code]
    assert (case.code, case.where) in got, [d.format() for d in diags]
    found = next(d for d in diags if (d.code, d.span.line) == (case.code, case.where))
    assert _flat(found.message).startswith(_flat(case.povray)), found.message
    errors = [d for d in diags if d.severity.value == "error"]
    assert bool(errors) == case.refuse, [d.format() for d in errors]


@pytest.mark.povray
@pytest.mark.parametrize("case", CASES, ids=[c.id for c in CASES])
def test_renders_like_povray(tmp_path, case: Case) -> None:
    import OpenImageIO as oiio

    (tmp_path / "oracle.pov").write_text(case.text)
    run = subprocess.run(
        ["povray", "+Ioracle.pov", "+Ooracle.png", f"+W{W}", f"+H{H}", "-D", "-V"],
        cwd=tmp_path,
        capture_output=True,
        text=True,
        timeout=600,
    )
    said = _flat(run.stdout + run.stderr)
    assert _flat(case.povray) in said, said[-2000:]
    if case.refuse:
        assert run.returncode != 0
        return
    assert run.returncode == 0, said[-2000:]
    ref = oiio.ImageBuf(str(tmp_path / "oracle.png")).get_pixels(oiio.FLOAT)[..., :3]
    ours, _ = strala_image(case.text, tmp_path, W, H)
    rmse, off = image_errors(ours, ref)
    assert rmse <= case.rmse and off <= case.off, (rmse, off)
