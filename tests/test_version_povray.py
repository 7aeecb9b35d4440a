"""POV-Ray 3.7's language-version rules, each checked against POV-Ray's own render.

POV-Ray (tokenize.cpp, the VERSION_TOKEN case of Parse_Directive) marks the language version
as set on any `#version`, in the scene or in any file it includes; after parsing
(parse.cpp, Parse_Frame's end) a scene whose version was never set counts as 3.62 and one
that ends below 3.7 gets no gamma handling unless it gives `assumed_gamma`. POV-Ray's
standard include files declare `<Name>_Inc_Temp = version`, read themselves as 3.5 and end
with `#version <Name>_Inc_Temp;`: so `#include "colors.inc"` alone makes a scene 3.7, and a
3.6 scene that includes it stays 3.6.

The gamma case of the issue, measured when written (32×24, the floor's centre pixel, blue
channel): POV-Ray 0.7647; strala 0.5453 before (it counted only the main file's #version and
its colors.inc had none), 0.7644 after.
"""

from __future__ import annotations

import pytest
from conftest import povray_image, strala_image

W, H = 32, 24
# One display value (1/255) plus shading noise between two ray tracers.
TOLERANCE = 0.01

BODY = """camera { location <0, 1, -4> look_at 0 }
light_source { <2, 10, -3> rgb 1 }
plane { y, -1 pigment { rgb <0, 0, 0.8> } }
sphere { <0, 0.2, 0>, 0.8 pigment { rgb <0.8, 0.3, 0.1> } }
"""


def _compare(tmp_path, text: str, files: dict[str, str] | None = None) -> None:
    for name, body in (files or {}).items():
        (tmp_path / name).write_text(body)
    ref = povray_image(text, tmp_path, W, H)
    ours, _ = strala_image(text, tmp_path, W, H)
    worst = float(abs(ours - ref).max())
    assert worst <= TOLERANCE, worst


@pytest.mark.povray
@pytest.mark.parametrize(
    "head",
    [
        # no #version anywhere: 3.62, no gamma handling
        "",
        # the case: the standard include sets (and restores) the version → 3.7
        '#include "colors.inc"\n',
        # the include restores the scene's own 3.6: legacy
        '#version 3.6;\n#include "colors.inc"\n',
        # a 3.7 scene stays 3.7
        '#version 3.7;\n#include "colors.inc"\n',
        # stdinc.inc includes the others, each restoring what it found
        '#include "stdinc.inc"\n',
        # a later #version wins: the version the scene ends with counts
        "#version 3.7;\n#version 3.6;\n",
        "#version 3.6;\n#version 3.7;\n",
        # assumed_gamma given: it applies whatever the version
        '#include "colors.inc"\nglobal_settings { assumed_gamma 2.2 }\n',
        "#version 3.6;\nglobal_settings { assumed_gamma 1.0 }\n",
    ],
    ids=[
        "none",
        "colors-inc",
        "3.6-colors-inc",
        "3.7-colors-inc",
        "stdinc",
        "3.7-then-3.6",
        "3.6-then-3.7",
        "colors-inc-gamma-2.2",
        "3.6-gamma-1",
    ],
)
def test_version_rule_matches_povray(tmp_path, head) -> None:
    _compare(tmp_path, head + BODY)


@pytest.mark.povray
@pytest.mark.parametrize(
    "include",
    [
        # a user's include that sets a version and does not restore it
        "#version 3.7;\n",
        "#version 3.6;\n",
        # one written like POV-Ray's own: set while read, restored at its end
        "#declare My_Inc_Temp = version;\n#version 3.5;\n#declare C = 1;\n#version My_Inc_Temp;\n",
    ],
    ids=["sets-3.7", "sets-3.6", "restores"],
)
def test_users_include_sets_the_version_like_povray(tmp_path, include) -> None:
    _compare(tmp_path, '#include "mine.inc"\n' + BODY, {"mine.inc": include})


def test_version_set_by_an_include_reaches_the_scene() -> None:
    from lang.evaluate import compile_source

    scene = compile_source('#include "colors.inc"\nsphere { 0, 1 }', "v.pov").scene
    assert scene.settings.version == pytest.approx(3.7)
    scene = compile_source('#version 3.6;\n#include "colors.inc"\n', "v.pov").scene
    assert scene.settings.version == pytest.approx(3.6)
    assert compile_source("sphere { 0, 1 }", "v.pov").scene.settings.version is None
