"""POV-Ray's parse warnings that strala gives too, located, with POV-Ray's repair: the
end-of-parse ones on language version and gamma (lang.eval.versioning) and the located
ones of the parser (#undef, #render, bounded_by, mesh2 lists, non-ASCII strings). Each is
checked against what POV-Ray itself prints for the same scene."""

from __future__ import annotations

import re

import numpy as np
import pytest
from conftest import image_errors, povray_debug, povray_image, strala_image

from lang.evaluate import compile_source

SPHERE = "sphere { 0, 1 pigment { rgb 1 } }\n"
V37 = "#version 3.7;\nglobal_settings { assumed_gamma 1 }\n"

# scene → the codes strala gives (in order) and the line each is at; the words of
# POV-Ray's own message for each code
VERSION_SCENES = {
    "bare": (SPHERE, [("W0316", 1), ("W0320", 1)]),
    "colors.inc first": ('#include "colors.inc"\n' + SPHERE, [("W0317", 1), ("W0319", 1)]),
    "3.7 without gamma": ("#version 3.7;\n" + SPHERE, [("W0317", 1)]),
    "3.6 without gamma": ("#version 3.6;\n" + SPHERE, [("W0316", 1)]),
    "3.7 with gamma": (V37 + SPHERE, []),
    "declare before version": (
        "#declare R = 1;\n" + V37 + "sphere { 0, R pigment { rgb 1 } }\n",
        [("W0319", 2)],
    ),
    "version 3.1": (
        "#version 3.1;\nglobal_settings { assumed_gamma 1 }\n" + SPHERE,
        [("W0318", 1)],
    ),
    "version in a comment-led file": ("// a scene\n\n" + V37 + SPHERE, []),
}
POVRAY_WORDS = {
    "W0316": "assumed_gamma not specified, so gamma_correction is turned off",
    "W0317": "assumed_gamma not specified in this POV-Ray 3.7 or later",
    "W0318": "language version set to 3.1 or",
    "W0319": "other declarations preceding the first #version",
    "W0320": "did not contain a #version directive",
}


def _said(text: str, filename: str = "scene.pov"):
    result = compile_source(text, filename)
    return [(d.code, d.span.line) for d in result.diagnostics if d.code in POVRAY_WORDS], result


@pytest.mark.parametrize("name", VERSION_SCENES)
def test_version_and_gamma_warnings(tmp_path, name):
    text, expected = VERSION_SCENES[name]
    said, result = _said(text, str(tmp_path / "scene.pov"))
    assert said == expected, result.diagnostics
    for d in result.diagnostics:
        if d.code in POVRAY_WORDS:
            assert d.hint and d.span.file == str(tmp_path / "scene.pov")


def test_version_warning_names_the_include_it_blames(tmp_path):
    said, result = _said('#include "colors.inc"\n' + SPHERE, str(tmp_path / "scene.pov"))
    late = next(d for d in result.diagnostics if d.code == "W0319")
    assert "colors.inc:" in late.message and late.span.line == 1


def test_include_files_and_failed_scenes_get_no_version_warnings(tmp_path):
    # an include file read on its own is no scene; a scene that stops at an error never
    # reaches POV-Ray's end of parsing
    assert _said("#declare A = sphere { 0, 1 }\n", str(tmp_path / "lib.inc"))[0] == []
    said, result = _said(SPHERE + "sphere { 0, undefined_name }\n")
    assert said == [] and result.diagnostics


@pytest.mark.parametrize(
    "name,expected",
    [
        ("bare", None),  # legacy: no gamma handling at all
        ("3.7 without gamma", 1.0),  # the working space is linear: assumed_gamma 1
        ("colors.inc first", 1.0),  # the include's #version marks the version set
    ],
)
def test_the_repairs_are_the_runtimes(name, expected):
    from runtime.color import working_gamma

    scene = compile_source(VERSION_SCENES[name][0]).scene
    assert scene is not None
    assert working_gamma(scene.settings) == expected


@pytest.mark.povray
@pytest.mark.parametrize("name", VERSION_SCENES)
def test_version_warnings_are_povrays(tmp_path, name):
    text, expected = VERSION_SCENES[name]
    (tmp_path / "scene.pov").write_text(text)
    printed = re.sub(r"\s+", " ", povray_debug(tmp_path / "scene.pov"))
    codes = {code for code, _ in expected}
    for code, words in POVRAY_WORDS.items():
        assert (words in printed) == (code in codes), (code, printed[-2000:])


HEAD = V37 + "camera { location -4*z look_at 0 }\nlight_source { <3, 5, -6>, 1 }\n"
MESH2 = (
    "mesh2 {{ vertex_vectors {{ 3, <-1,-1,0>, <1,-1,0>, <0,1,0> }} {}"
    " face_indices {{ 1, <0,1,2> }} pigment {{ rgb 1 }} }}\n"
)
LOCATED = {
    "undef unknown": (HEAD + "#undef Nothing\n" + SPHERE, "W0312", 5,
                      "Attempt to undef unknown identifier"),
    "render stream": (HEAD + '#render "text"\n' + SPHERE, "W0312", 5,
                      "#render and #statistics streams are no longer available"),
    "bounded sphere": (HEAD + "sphere { 0, 1 bounded_by { box { -2, 2 } } }\n", "W0312", 5,
                       "Unnecessary bounding object removed"),
    "duplicate vertex_vectors": (
        HEAD + MESH2.format("vertex_vectors { 3, <-1,-1,0>, <1,-1,0>, <0,1,0> }"), "W0312", 5,
        "Duplicate vertex_vectors block; ignoring previous block"),
    "duplicate normal_vectors": (
        HEAD + MESH2.format("normal_vectors { 3, -z, -z, -z } normal_vectors { 3, -z, -z, -z }"),
        "W0312", 5, "Duplicate normal_vectors block; ignoring previous block"),
    "zero mesh2 normal": (
        HEAD + MESH2.format("normal_vectors { 3, 0, -z, -z }"), "W0309", 5,
        "Normal vector in mesh2 cannot be zero - changing it to <1,0,0>"),
    "non-ASCII string": (HEAD + '#declare S = "h\u00e9llo"; #debug S\n' + SPHERE, "W0309", 5,
                         "Non-ASCII character has been replaced by space character"),
}  # fmt: skip


@pytest.mark.parametrize("name", LOCATED)
def test_located_warnings(tmp_path, name):
    text, code, line, message = LOCATED[name]
    result = compile_source(text, str(tmp_path / "scene.pov"))
    got = [d for d in result.diagnostics if d.severity == "warning"]
    assert [(d.code, d.span.line) for d in got] == [(code, line)], result.diagnostics
    assert message in got[0].message and got[0].hint


@pytest.mark.povray
@pytest.mark.parametrize("name", LOCATED)
def test_located_warnings_are_povrays(tmp_path, name):
    text, _, line, message = LOCATED[name]
    (tmp_path / "scene.pov").write_text(text)
    printed = re.sub(r"\s+", " ", povray_debug(tmp_path / "scene.pov"))
    assert f"line {line}: " in printed and message in printed, printed[-2000:]


def test_non_ascii_bytes_become_spaces():
    # POV-Ray: "é" is two bytes in the file, two spaces in the string
    text = V37 + '#declare S = "h\u00e9llo";\n#debug concat(S, "|", str(strlen(S), 0, 0))\n'
    result = compile_source(text)
    assert [d.message for d in result.diagnostics if d.code == "N0100"] == ["h  llo|6"]
    utf8 = text.replace("assumed_gamma 1", "assumed_gamma 1 charset utf8")
    result = compile_source(utf8)
    assert [d.message for d in result.diagnostics if d.code == "N0100"] == ["h\u00e9llo|5"]
    assert not [d for d in result.diagnostics if d.code == "W0309"]


@pytest.mark.povray
@pytest.mark.parametrize(
    "name,body",
    [
        # the accented letters are spaces: only "A" and "B" are drawn
        ("text", 'text { ttf "timrom.ttf" "A\u00e9\u00e8B" 0.5, 0 pigment { rgb 1 }'
                 " translate <-1.4, -0.3, 0> }\n"),
        # a zero normal is <1,0,0>: the smooth triangle's shading turns with it
        ("mesh2 normal", MESH2.format("normal_vectors { 3, 0, -z, -z }")),
    ],
)  # fmt: skip
def test_repairs_render_like_povray(tmp_path, name, body):
    text = HEAD + body
    ref = povray_image(text, tmp_path, 96, 72)
    ours, messages = strala_image(text, tmp_path, 96, 72)
    assert any("replaced by space" in m or "cannot be zero" in m for m in messages), messages
    rmse, off = image_errors(ours, ref)
    assert rmse < 0.003 and off < 0.005, (rmse, off)  # before the repairs: 0.095, 0.0076
    assert float(np.mean(ref)) > 0.01  # something is drawn
