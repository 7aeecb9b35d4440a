"""Hand-made inputs that broke the checker or the renderer (issue 22's list): each costs
bounded time and memory and ends in diagnostics, never an internal error."""

from __future__ import annotations

import resource
import subprocess
import sys
import time

import pytest

from lang.diagnostics import Severity
from lang.evaluate import compile_source
from lang.parser import parse
from runtime import api
from runtime.render import MAX_NESTING, render_scene


def _peak_mb_of(code: str) -> float:
    """The peak resident size of a fresh interpreter running `code`, in MB."""
    out = subprocess.run(
        [sys.executable, "-c", code + "\nimport resource\n"
         "print(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss)"],
        capture_output=True, text=True, check=True, timeout=300,
    )  # fmt: skip
    return int(out.stdout.split()[-1]) / 1024


def test_a_long_string_literal_costs_memory_in_proportion():
    # a 1 MB literal took 1 GB: the string pattern's repeated group kept state per character
    base = _peak_mb_of("from lang.parser import parse; parse('#declare S = \"a\";', 's.pov')")
    peak = _peak_mb_of(
        "from lang.parser import parse\nparse('#declare S = \"' + 'a' * 1_000_000 + '\";', 's.pov')"
    )
    assert peak - base < 100, (base, peak)
    assert resource.getrusage(resource.RUSAGE_SELF).ru_maxrss > 0


@pytest.mark.parametrize("flood", ["} ", ") ", "#end ", "#else ", "> "])
def test_syntax_recovery_is_linear(flood):
    # 8,000 unmatched `}` took 31 s: each one rescanned the braces from the chunk's start
    def took(n: int) -> float:
        start = time.perf_counter()
        parse(flood * n, "f.pov")
        return time.perf_counter() - start

    took(500)  # warm the parser
    small, large = took(2_000), took(16_000)
    assert large < 12 * max(small, 0.02), (small, large)  # 8 times the input


def test_directives_nested_thousands_deep_are_diagnostics():
    # 4,000 nested `#if` overflowed the cut-brace analysis (RecursionError, exit 3)
    r = compile_source("#if (1) " * 4000, "d.pov")
    assert not [d for d in r.diagnostics if d.code == "E0200"]
    assert [d.code for d in r.diagnostics if d.severity is Severity.ERROR] == ["E0107"]


def test_a_deeply_nested_union_is_read_and_its_checks_do_not_run_out_of_frames():
    # read within the interpreter's frames, then the coincidence check ran out (exit 3)
    src = "union { " * 1000 + "sphere { 0, 1 }" + " }" * 1000
    r = compile_source(src, "d.pov")
    assert not [d for d in r.diagnostics if d.code == "E0200"]
    assert r.scene is not None and len(r.scene.objects) == 1


def test_rendering_csg_nested_too_deep_is_a_located_error():
    head = "camera { location -5*z look_at 0 } light_source { <5, 5, -5> rgb 1 }\n"
    deep = "union { " * (MAX_NESTING + 1) + "sphere { 0, 1 }" + " }" * (MAX_NESTING + 1)
    scene = api.compile_string(head + deep).scene
    from lang.diagnostics import SceneError

    with pytest.raises(SceneError) as e:
        render_scene(scene, 8, 6)
    assert e.value.diagnostic.code == "E0231" and e.value.diagnostic.span.line == 2
    shallow = "union { " * 50 + "sphere { 0, 1 }" + " }" * 50
    assert render_scene(api.compile_string(head + shallow).scene, 8, 6).shape == (6, 8, 3)


@pytest.mark.parametrize("item", ["rotate <1e308 * 10, 0, 0>", "rotate <0, 0/0 + 1e308 * 10, 0>",
                                  "translate <1, 0, -1e308 * 10>", "scale 1e308 * 10"])  # fmt: skip
def test_a_transform_by_an_infinite_amount_is_an_error_at_it(item):
    # the fuzzer's: rotate of an overflowed angle was a math domain error (E0200)
    r = compile_source(f"sphere {{ 0, 1\n  {item}\n}}\n", "t.pov")
    errors = [d for d in r.diagnostics if d.severity is Severity.ERROR]
    assert [(d.code, d.span.line) for d in errors] == [("E0203", 2)], errors
    assert "infinite or undefined" in errors[0].message


@pytest.mark.parametrize("entry", ["texture { pigment { rgb 1 } }", "1"])
def test_a_mesh2_index_list_with_a_non_vector_is_an_error(entry):
    # the fuzzer's swap of mesh2.pov: AttributeError 'Texture' object has no attribute 'padded'
    src = (
        "mesh2 { vertex_vectors { 3, <0,0,0>, <1,0,0>, <0,1,0> }\n"
        "  normal_vectors { 1, <0,0,-1> }\n"
        "  face_indices { 1, <0, 1, 2> }\n"
        f"  normal_indices {{ 1, {entry} }}\n}}\n"
    )
    r = compile_source(src, "m.pov")
    errors = [d for d in r.diagnostics if d.severity is Severity.ERROR]
    assert [d.code for d in errors] == ["E0202"] and "index vectors" in errors[0].message


@pytest.mark.parametrize(
    "uvs, refused", [("0, x, y", True), ("0, <1, 0>, <0, 1>", False), ("<1, 0, 0>", True)]
)
def test_mesh2_uv_vectors_are_two_component_vectors_or_floats(uvs, refused):
    # a 3-vector among the uv_vectors was a TypeError ("internal error"); POV-Ray's
    # Parse_UV_Vect takes a float as <f, f> and refuses a longer vector
    count = 1 if uvs.startswith("<") else 3
    src = (
        "mesh2 { vertex_vectors { 3, <0,0,0>, <1,0,0>, <0,1,0> }\n"
        f"  uv_vectors {{ {count}, {uvs} }}\n"
        "  face_indices { 1, <0, 1, 2> }\n}\n"
    )
    errors = [d for d in compile_source(src, "m.pov").diagnostics if d.severity is Severity.ERROR]
    if refused:
        assert [d.code for d in errors] == ["E0202"] and "UV_Vector expected" in errors[0].message
    else:
        assert errors == []


@pytest.mark.parametrize("item", ["falloff 1e308 * 10", "radius 0/0 + 1e308 * 10",
                                  "point_at <0, -1e308 * 10, 0>"])  # fmt: skip
def test_a_spotlight_of_an_infinite_angle_is_an_error_at_it(item):
    # the fuzzer's lights/soft.pov: math domain error while rendering (exit 3)
    src = f"light_source {{ <0, 5, 0> rgb 1 spotlight\n  {item}\n}}\n"
    errors = [d for d in compile_source(src, "l.pov").diagnostics if d.severity is Severity.ERROR]
    assert [(d.code, d.span.line) for d in errors] == [("E0203", 2)], errors
