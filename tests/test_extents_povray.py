"""min_extent/max_extent of lathe, sor, prism, superellipsoid, blob, polynomial shapes,
julia_fractal and text against POV-Ray 3.7's own figures (its #debug output). Every shape is
within 1e-5 of POV-Ray, text within 2e-4: POV-Ray grows a glyph's header box to its outline
points, which matters where the headers are wrong (timrom.ttf's and cyrvetic.ttf's xMax is
the glyph's width: the box was a left bearing short, 0.032 on "Hello")."""

from __future__ import annotations

import re
import shutil
import subprocess
import sys

import pytest
from conftest import ROOT, povray_debug

from lang.eval.versioning import CODES as VERSION_CODES
from lang.evaluate import compile_source

FONTS = "/usr/share/povray-3.7/include"
SHAPES = {
    "super": "superellipsoid { <0.3, 0.6> }",
    "blob": "blob { threshold 0.6 sphere { <0.75, 0, 0>, 1, 1 } sphere { <-0.5, 0.5, 0>, 0.8, 2 }"
    " cylinder { 0, <0, 2, 0>, 0.5, 1 } sphere { <0, -3, 0>, 1, -1 } }",
    "blobrot": "blob { threshold 0.6 sphere { <0.75, 0, 0>, 1, 1 scale <1, 2, 1> rotate z*30 } }",
    "lathe": "lathe { linear_spline 4, <0, 0>, <1, 0.5>, <0.5, 1.5>, <0, 2> }",
    "lathecub": "lathe { cubic_spline 6, <0, -1>, <0, 0>, <1, 0.5>, <0.5, 1.5>, <0, 2>, <1, 3> }",
    "latheq": "lathe { quadratic_spline 5, <0, -1>, <0, 0>, <1, 0.5>, <0.5, 1.5>, <0, 2> }",
    "lathebez": "lathe { bezier_spline 4, <0, 0>, <2, 0.5>, <0.5, 1.5>, <0, 2> }",
    "sor": "sor { 5, <0, 0>, <0.5, 0>, <1, 1>, <0.3, 2>, <0, 3> }",
    "prism": "prism { linear_sweep linear_spline 0, 1, 4, <0, 0>, <2, 0>, <1, 3>, <0, 0> }",
    "prismc": "prism { conic_sweep linear_spline -1, 0.5, 4, <0, 0>, <2, 0>, <1, 3>, <0, 0> }",
    "prismcub": "prism { cubic_spline 0, 1, 7, <1, 0>, <0, 0>, <1, 0>, <2, 1>, <1, 2>, <0, 0>,"
    " <1, 0> }",
    "prismq": "prism { quadratic_spline 0, 1, 5, <1, 0>, <0, 0>, <2, 1>, <1, 2>, <0, 0> }",
    "prismb": "prism { bezier_spline 0, 1, 4, <0, 0>, <3, 0>, <1, 2>, <0, 0> }",
    "ellipsoid": "quadric { <1, 2, 1>, <0, 0, 0>, <0, 0, 0>, -1 translate x }",
    "hyperboloid": "quadric { <1, -1, 1>, <0, 0, 0>, <0, 0, 0>, -1 }",
    "cubic": "cubic { <1, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, -1> }",
    "crystal": f'text {{ ttf "{FONTS}/crystal.ttf" "Wave gyp" 1, <0.1, 0.05, 0> }}',
    "timrom": f'text {{ ttf "{FONTS}/timrom.ttf" "Hello AV" 0.5, 0 scale 2 }}',
    "julia": "julia_fractal { <0.2, 0.1, -0.3, 0.1> }",
    "julia0": "julia_fractal { <0, 0, 0, 0> translate x }",
    "juliabig": "julia_fractal { <1, 1, 1, 1> cube }",
    "juliah": "julia_fractal { <0.2, 0.1, -0.3, 0.1> hypercomplex sin scale 0.5 rotate y*30 }",
}
# POV-Ray truncates long #debug strings: print min and max on lines of their own
MACRO = (
    '#macro P(N, O) #debug concat(N, " min ", vstr(3, min_extent(O), ",", 0, 6), "\\n")'
    ' #debug concat(N, " max ", vstr(3, max_extent(O), ",", 0, 6), "\\n") #end\n'
)
SCENE = MACRO + "".join(f'P("{k}", {v})\n' for k, v in SHAPES.items())
LINE = re.compile(r"^(\w+) (min|max) (\S+)$", re.M)


def _figures(text: str) -> dict[tuple[str, str], tuple[float, ...]]:
    return {(m[1], m[2]): tuple(float(v) for v in m[3].split(",")) for m in LINE.finditer(text)}


def _ours() -> dict[tuple[str, str], tuple[float, ...]]:
    result = compile_source(SCENE, "extents.pov")
    notes = "\n".join(d.message for d in result.diagnostics)
    return _figures(notes)


def test_extents_are_boxes_around_the_shapes() -> None:
    ours = _ours()
    assert len(ours) == 2 * len(SHAPES)
    for k in SHAPES:
        lo, hi = ours[(k, "min")], ours[(k, "max")]
        assert all(a < b for a, b in zip(lo, hi, strict=True)), k
    assert ours[("hyperboloid", "max")] == (1e10, 1e10, 1e10)
    assert ours[("ellipsoid", "max")] == pytest.approx((2, 0.5**0.5, 1))


def test_lang_reads_fonts_without_numpy() -> None:
    code = (
        "import sys; from lang import extents, font_metrics; "
        f"font_metrics.text_box('{FONTS}/timrom.ttf', 'Hi', 1, (0, 0, 0)); "
        "assert 'numpy' not in sys.modules"
    )
    subprocess.run([sys.executable, "-c", code], cwd=ROOT, check=True)


@pytest.mark.povray
def test_extents_match_povray(tmp_path) -> None:
    if shutil.which("povray") is None:
        pytest.skip("POV-Ray is not installed")
    scene = tmp_path / "extents.pov"
    scene.write_text(SCENE)
    theirs = _figures(povray_debug(scene))
    ours = _ours()
    assert set(theirs) == set(ours)
    for key, want in theirs.items():
        # POV-Ray pads a text's box a little (up to 1.4e-4 here); its glyph boxes reach the
        # outline points where a font's headers are too small (timrom.ttf)
        tol = 2e-4 if key[0] in ("crystal", "timrom") else 1e-4
        assert ours[key] == pytest.approx(want, abs=tol), key


CIRCLE_TEXT = (
    '#declare S = "Centered text, n";\n'
    "#declare I = 1;\n"
    "#while (I <= strlen(S))\n"
    f'  #declare O = text {{ ttf "{FONTS}/cyrvetic.ttf" substr(S, 1, I) 1, 0 }}\n'
    '  P(concat("c", str(I, 0, 0)), O)\n'
    "  #declare I = I + 1;\n"
    "#end\n"
    f'P("space", text {{ ttf "{FONTS}/cyrvetic.ttf" " " 1, 0 }})\n'
)


@pytest.mark.povray
def test_text_prefix_extents_match_povray(tmp_path) -> None:
    """Every prefix of a string in cyrvetic.ttf (whose glyph headers are too narrow), and a
    lone space: what shapes.inc's Circle_Text measures (incdemo/circletext.pov)."""
    text = MACRO + CIRCLE_TEXT
    scene = tmp_path / "prefixes.pov"
    scene.write_text(text)
    theirs = _figures(povray_debug(scene))
    result = compile_source(text, str(scene))
    quiet = {"N0100", "W0304", *VERSION_CODES}  # the scene has no #version, as POV-Ray says
    assert not [d.message for d in result.diagnostics if d.code not in quiet]
    ours = _figures("\n".join(d.message for d in result.diagnostics))
    assert set(theirs) == set(ours) and len(theirs) == 2 * 17
    for key, want in theirs.items():
        assert ours[key] == pytest.approx(want, abs=2e-4), key
