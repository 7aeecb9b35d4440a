"""`#break` as POV-Ray reads it: it leaves the innermost #while, #for, #switch or macro,
and what that construct produced before the #break stays (POV-Ray has already read those
tokens); outside all of them it is POV-Ray's "Invalid context for #break", a located error
(it was an internal error). Each case's objects are counted against POV-Ray's own count."""

from __future__ import annotations

import re
import shutil

import pytest
from conftest import povray_debug

from lang.evaluate import compile_source

CASES = {
    "while, break inside #if": (
        "#declare I = 0; #while (I < 3) sphere { <I, 0, 0>, 0.5 } #declare I = I + 1;"
        " #if (I = 2) #break #end #end",
        2,
    ),
    "for": ("#for (I, 0, 5) sphere { <I, 0, 0>, 0.1 } #if (I = 1) #break #end #end", 2),
    "macro ends at #break": ("#macro M() sphere { 0, 1 } #break sphere { 1, 1 } #end M() M()", 2),
    "switch": (
        "#switch (1) #case (1) sphere { 0, 1 } #if (1) #break #end sphere { 1, 1 } #end",
        1,
    ),
    "inner loop only": (
        "#for (I, 0, 1) #for (J, 0, 9) sphere { <I, J, 0>, 0.1 } #if (J = 2) #break #end #end #end",
        6,
    ),
}


def _objects(src: str) -> int:
    r = compile_source(src, "t.pov")
    assert not [d for d in r.diagnostics if d.severity.name == "ERROR"], r.diagnostics
    assert r.scene is not None
    return len(r.scene.objects)


@pytest.mark.parametrize("name", sorted(CASES))
def test_break_keeps_what_came_before_it(name):
    src, want = CASES[name]
    assert _objects(src) == want


def test_objects_kept_inside_a_block_too():
    r = compile_source(
        "union { #declare I = 0; #while (I < 3) sphere { <I, 0, 0>, 0.5 } #declare I = I + 1;"
        " #if (I = 2) #break #end #end }",
        "t.pov",
    )
    assert r.scene is not None and len(r.scene.objects[0].shape.children) == 2


def test_break_outside_any_loop_is_a_located_error():
    r = compile_source("sphere { 0, 1 }\n#if (1) #break #end\nsphere { 1, 1 }\n", "t.pov")
    errors = [d for d in r.diagnostics if d.severity.name == "ERROR"]
    assert [(d.code, d.span.line) for d in errors] == [("E0234", 2)]


@pytest.mark.povray
@pytest.mark.parametrize("name", sorted(CASES))
def test_object_counts_match_povray(name, tmp_path):
    if shutil.which("povray") is None:
        pytest.skip("POV-Ray is not installed")
    src, want = CASES[name]
    scene = tmp_path / "b.pov"
    scene.write_text("#version 3.7;\ncamera { location -9*z look_at 0 }\n" + src + "\n")
    found = re.search(r"Finite Objects:\s+(\d+)", povray_debug(scene))
    assert found is not None
    assert int(found.group(1)) == want
