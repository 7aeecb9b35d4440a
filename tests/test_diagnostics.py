"""Golden diagnostics: a corpus of broken scenes, each with its first error's code and
position, plus the messages users read. Every case is a mistake people make."""

from __future__ import annotations

import random
import time
from pathlib import Path

import pytest
from conftest import run_cli
from hypothesis import given, settings
from hypothesis import strategies as st

from lang.diagnostics import Severity
from lang.eval.versioning import CODES as VERSION_CODES
from lang.evaluate import compile_source

# (name, source, code, line, col) of the first error
CORPUS = [
    ("stray_brace", "sphere { 0, 1 }\n}\n", "E0101", 2, 1),
    ("unclosed_block", "sphere { 0, 1\n", "E0106", 1, 8),
    ("missing_end", "#if (1)\nsphere { 0, 1 }\n", "E0107", 1, 1),  # at the #if left open
    ("unterminated_string", '#debug "abc\n', "E0004", 1, 8),
    ("unterminated_comment", "/* never\nsphere{0,1}\n", "E0003", 1, 1),
    ("bad_char", "sphere { 0, 1 } @\n", "E0005", 1, 17),
    ("reserved_name", "#declare sphere = 1;\n", "E0102", 1, 10),
    ("unknown_ident", "sphere { 0, Radiu }\n", "E0201", 1, 13),
    ("did_you_mean", "#declare Radius = 1;\nsphere { 0, Radiuss }\n", "E0201", 2, 13),
    ("item_not_in_block", "sphere { 0, 1 angle 5 }\n", "E0210", 1, 15),
    # a zero divisor is POV-Ray's warning (W0309); a string in arithmetic is an error
    ("string_arithmetic", '#declare A = 1 + "s";\n', "E0203", 1, 14),
    ("sqrt_negative", "#declare A = sqrt(-1);\n", "E0203", 1, 14),
    ("wrong_type_add", '#declare A = 1 + "s";\n', "E0203", 1, 14),
    ("include_missing", '#include "nope.inc"\n', "E0220", 1, 1),
    ("macro_arity", "#macro M(A, B) sphere{A,B} #end\nM(1)\n", "E0232", 2, 1),
    ("unknown_macro", "Foo(1)\n", "E0201", 1, 1),
    ("error_directive", '#error "stop here"\n', "E0240", 1, 1),
    ("bad_vector_index", "#declare V = <1,2,3>;\n#declare A = V.w;\n", "E0203", 2, 14),
    ("array_out_of_range", "#declare A = array[2] {1,2};\n#declare B = A[5];\n", "E0250", 2, 14),
    ("runaway_while", "#declare I = 0;\n#while (1) #declare I = I + 1; #end\n", "E0230", 2, 1),
    ("include_cycle", '#include "cycle.inc"\n', "E0221", 1, 1),
    ("sphere_missing_radius", "sphere { <0,0,0> }\n", "E0211", 1, 1),
    ("box_one_corner", "box { <0,0,0> }\n", "E0211", 1, 1),
    ("camera_bad_item", "camera { location <0,0,-5> radius 3 }\n", "E0210", 1, 28),
    ("light_no_colour", "light_source { <0,0,0> }\n", "E0211", 1, 1),
    ("finish_bad_value", 'sphere { 0, 1 finish { ambient "x" } }\n', "E0211", 1, 32),
    ("pigment_unknown_pattern_ident", "sphere { 0, 1 pigment { Nonesuch } }\n", "E0201", 1, 25),
    # POV-Ray pads `rgb <1,0>` with zeros; a string is no colour
    ("color_bad", '#declare C = rgb "red";\n', "E0202", 1, 14),
    (
        "nurbs_bad_count",
        "nurbs { u_degree 1 v_degree 1 control_points { 2, 2, <0,0,0>, <1,0,0>, <0,1,0> } }\n",
        "E0281",
        1,
        31,
    ),
    (
        "nurbs_bad_weight",
        "nurbs { u_degree 1 v_degree 1 control_points { 2, 2, <0,0,0>, <1,0,0>, <0,1,0>, <1,1,0> } weights { 1, 0, 1, 1 } }\n",
        "E0282",
        1,
        91,
    ),
    (
        "nurbs_decreasing_knots",
        "nurbs { degree 1 control_points { 3, <0,0,0>, <1,0,0>, <2,0,0> } knots { 0, 0, 2, 1, 3 } radius 0.1 }\n",
        "E0280",
        1,
        66,
    ),
    (
        "subdiv_index_range",
        "subdivision { scheme catmull_clark vertex_vectors { 3, <0,0,0>, <1,0,0>, <0,1,0> } face_indices { 1, <0,1,7> } }\n",
        "E0286",
        1,
        102,
    ),
    (
        "subdiv_loop_quad",
        "subdivision { scheme loop vertex_vectors { 4, <0,0,0>, <1,0,0>, <1,1,0>, <0,1,0> } face_indices { 1, <0,1,2,3> } }\n",
        "E0286",
        1,
        102,
    ),
    (
        "subdiv_unknown_scheme",
        "subdivision { scheme sqrt3 vertex_vectors { 3, <0,0,0>, <1,0,0>, <0,1,0> } face_indices { 1, <0,1,2> } }\n",
        "E0285",
        1,
        15,
    ),
    (
        "subdiv_non_manifold",
        "subdivision { vertex_vectors { 5, 0, x, y, -y, z } face_indices { 3, <0,1,2>, <1,0,3>, <0,1,4> } }\n",
        "E0287",
        1,
        70,
    ),
    (
        "subdiv_orientation",
        "subdivision { vertex_vectors { 4, 0, x, y, z } face_indices { 2, <0,1,2>, <0,1,3> } }\n",
        "E0289",
        1,
        75,
    ),
    ("declare_no_value", "#declare A = ;\n", "E0002", 1, 14),
    ("unclosed_vector", "sphere { <0,0,0, 1 }\n", "E0002", 1, 20),
    ("missing_paren", "#if (1\nsphere {0,1}\n#end\n", "E0002", 2, 1),
    ("switch_no_case", "#switch (1)\nsphere{0,1}\n#end\n", "E0104", 2, 1),
    ("for_bad_step", "#for (I, 0, 10, 0) sphere { I*x, .1 } #end\n", "E0230", 1, 1),
    ("two_errors", "sphere { 0, Foo }\nbox { 0, Bar }\n", "E0201", 1, 13),
    ("function_too_many_args", "#declare A = sqrt(1, 2);\n", "E0203", 1, 14),
    ("function_no_args", "#declare A = 1 + sin();\n", "E0203", 1, 18),
    ("function_wrong_arg_type", '#declare A = sin("x");\n', "E0203", 1, 14),
    ("macro_too_many_args", "#macro M(A) sphere { A, 1 } #end\nM(1, 2)\n", "E0232", 2, 1),
    ("array_two_indices", "#declare A = array[2] {1, 2};\n#declare B = A[0][1];\n", "E0250", 2, 14),
    (
        "nurbs_knot_count",
        "nurbs { degree 1 control_points { 3, <0,0,0>, <1,0,0>, <2,0,0> } knots { 0, 0, 1, 2 } radius 0.1 }\n",
        "E0280",
        1,
        66,
    ),
    ("infinite_array_size", "#declare A = array[1e400];\n", "E0006", 1, 20),
    (
        "infinite_face_index",
        "subdivision { vertex_vectors { 3, 0, x, y } face_indices { 1, <0, 1, 1e400> } }\n",
        "E0006",
        1,
        70,
    ),
    (
        "nurbs_degenerate_net",
        "nurbs { u_degree 1 v_degree 1 control_points { 2, 2, <1,1,1>, <1,1,1>, <1,1,1>, <1,1,1> } }\n",
        "E0281",
        1,
        31,
    ),
    # POV-Ray reads exactly the declared number of points
    ("count_mismatch", "polygon { 4, <0,0>, <1,0>, <0,1> }\n", "E0290", 1, 1),
    # an image that cannot be had stops the scene, as in POV-Ray (tests/test_refusals_povray.py)
    ("image_missing", 'plane { y, 0 pigment { image_map { png "none.png" } } }\n', "E0220", 1, 36),
    (
        "image_unreadable",
        'plane { y, 0 pigment { image_map { png "bad.png" } } }\n',
        "E0222",
        1,
        36,
    ),
    ("declare_semicolon", "#declare R = 1\nsphere { 0, R }\n", "E0108", 1, 15),
]

# (name, source, code, line, col) of a warning the scene must get
WARNINGS = [
    ("unused_declare", "#declare Unused = 3;\nsphere { 0, 1 }\n", "W0400", 1, 10),
    (
        "local_shadows_global",
        "#declare R = 1;\n#macro M() #local R = 2; sphere { 0, R } #end\nM()\nsphere { 0, R }\n",
        "W0401",
        2,
        19,
    ),
    ("unsupported_block", "sphere { 0, 1 photons { target } }\n", "W0300", 1, 15),
    ("ignored_irid_waves", "global_settings { irid_wavelength <0.7, 0.5, 0.4> }\n", "W0308", 1, 19),
    ("waves_at_least_one", "global_settings { number_of_waves -2 }\n", "W0309", 1, 19),
    ("ignored_albedo", "sphere { 0, 1 finish { diffuse albedo 0.7 } }\n", "W0308", 1, 32),
    (
        "ignored_cutaway",
        "union { sphere { 0, 1 } sphere { x, 1 } cutaway_textures }\n",
        "W0308",
        1,
        41,
    ),
    ("open_polygon", "polygon { 3, <0,0>, <1,0>, <0,1> }\n", "W0309", 1, 1),
]


def diagnostics_of(name: str, src: str, tmp_path):
    folder = tmp_path
    if name == "include_cycle":
        (folder / "cycle.inc").write_text('#include "cycle.inc"\n')
    if name == "image_unreadable":
        (folder / "bad.png").write_text("this is not a PNG file\n")
    path = folder / f"{name}.pov"
    return compile_source(src, str(path)).diagnostics


def errors_of(name: str, src: str, tmp_path):
    return [d for d in diagnostics_of(name, src, tmp_path) if d.severity is Severity.ERROR]


@pytest.mark.parametrize("name, src, code, line, col", CORPUS, ids=[c[0] for c in CORPUS])
def test_first_error_code_and_position(name, src, code, line, col, tmp_path):
    errs = errors_of(name, src, tmp_path)
    assert errs, f"{name}: no error reported"
    first = errs[0]
    assert (first.code, first.span.line, first.span.col) == (code, line, col), first
    assert first.span.file.endswith((f"{name}.pov", "cycle.inc"))
    text = first.format(src.splitlines())
    assert f":{line}:{col}: error:" in text and "^" in text  # gcc style with a caret


def test_corpus_is_large_enough():
    assert len(CORPUS) >= 40
    assert len({c[0] for c in CORPUS + WARNINGS}) == len(CORPUS) + len(WARNINGS)


@pytest.mark.parametrize("name, src, code, line, col", WARNINGS, ids=[c[0] for c in WARNINGS])
def test_warning_code_and_position(name, src, code, line, col, tmp_path):
    diags = diagnostics_of(name, src, tmp_path)
    warns = [d for d in diags if d.severity is Severity.WARNING and d.code == code]
    assert warns, f"{name}: no {code} in {diags}"
    assert (warns[0].span.line, warns[0].span.col) == (line, col), warns[0]
    assert warns[0].hint, warns[0]
    assert not [d for d in diags if d.severity is Severity.ERROR], diags


@pytest.mark.parametrize("name, src", [c[:2] for c in CORPUS], ids=[c[0] for c in CORPUS])
def test_every_error_has_a_hint(name, src, tmp_path):
    for d in errors_of(name, src, tmp_path):
        assert d.hint and len(d.hint) > 10, d
        assert "= hint: " in d.format(src.splitlines())


def test_hints_say_how_to_call_and_what_the_range_is():
    src = (
        "#declare A = pow(2);\n#declare B = array[3] {1, 2, 3};\n#declare C = B[3];\n"
        "#declare D = <1, 2>.z;\n#declare E = 1 / 0;\n"
    )
    diags = compile_source(src, "h.pov").diagnostics
    hints = {d.span.line: d.hint for d in diags if d.code not in ("W0400", "W0304")}
    assert hints[1] == "call it as pow(A, B)"
    assert "3 element(s)" in hints[3]
    assert ".u .v" in hints[4]
    assert "infinite" in hints[5]  # a warning: POV-Ray divides by zero too


def test_ignored_keywords_warn_once_per_feature_and_not_for_rendered_ones():
    src = (
        "camera { location -z look_at 0 aperture 0.4 blur_samples 20 variance 0.1 }\n"
        "sphere { 0, 1 uv_mapping pigment { bozo uv_mapping } }\n"
        "union { sphere { 0, 1 } cutaway_textures } union { box { 0, 1 } cutaway_textures }\n"
        "sphere { 0, 1 sturm }\nglobal_settings { max_intersections 64 }\n"
    )
    warns = [d for d in compile_source(src, "i.pov").diagnostics if d.code == "W0308"]
    assert [(d.span.line, d.message) for d in warns] == [
        (3, "`cutaway_textures` is accepted but ignored"),
    ]  # focal blur (line 1) and uv_mapping (line 2) render; sturm and max_intersections
    # change no pixel


@pytest.mark.parametrize(
    "src, words",
    [
        ("sphere { 0, 1 }\n}\n", ["unmatched `}`", "`sphere` block opened at 1:1"]),
        ("#declare Radius = 1;\nsphere { 0, Radiuss }\n", ["Radius"]),
        ("sphere { 0, 1 angle 5 }\n", ["not valid inside `sphere`"]),
        ('#include "nope.inc"\n', ["nope.inc"]),
    ],
)
def test_messages_and_hints_use_the_users_words(src, words):
    result = compile_source(src, "m.pov")
    d = [x for x in result.diagnostics if x.severity is Severity.ERROR][0]
    text = d.message + " " + (d.hint or "")
    for w in words:
        assert w in text, text


def test_several_errors_in_one_file_are_all_reported():
    src = 'sphere { 0, Foo }\nbox { 0, Bar }\n}\n#declare A = 1 + "s";\n'
    errs = [d for d in compile_source(src, "m.pov").diagnostics if d.severity is Severity.ERROR]
    lines = {d.span.line for d in errs}
    assert {1, 2, 3, 4} <= lines


_EXAMPLES = {
    p.name: p.read_text()
    for p in sorted((Path(__file__).resolve().parent.parent / "examples").glob("*.scene"))
}
# Pieces a mutation inserts: halves of constructs, text that changes how the rest reads, and
# values at the edges of what floats hold.
_BREAKERS = [
    '"unterminated',
    "/* never closed",
    "// a comment\n",
    "{",
    "}",
    "(",
    ")",
    "<",
    ">",
    "[",
    "#if (1)",
    "#else",
    "#end",
    "#macro M(",
    "#declare",
    "#local X =",
    "#while (1)",
    "#for (I, 0, 1e9)",
    '#include "',
    "#switch (1)",
    "#case (",
    "#version 1e9;",
    "function {",
    "spline {",
    "1e308 * 1e308",
    "-1e400",
    "1e-400",
    "9" * 400,
    "\x00",
    "\t\r",
]


@settings(max_examples=80, deadline=None)
@given(
    st.sampled_from(sorted(_EXAMPLES)),
    st.lists(
        st.tuples(
            st.sampled_from(["delete", "duplicate", "swap", "bytes", "insert", "nest", "cut"]),
            st.integers(0, 2**31),
        ),
        min_size=1,
        max_size=4,
    ),
)
def test_mutated_examples_never_raise_and_terminate(name, mutations):
    """Mutations of the example scenes (tokens deleted, duplicated or swapped, random bytes,
    unterminated strings and comments, deep nesting, huge numbers, the file cut short): the
    checker reports, it never raises, never hits an internal error and never hangs."""
    tokens = _EXAMPLES[name].split(" ")
    for kind, seed in mutations:
        rng = random.Random(seed)
        i = rng.randrange(len(tokens)) if tokens else 0
        if kind == "delete" and tokens:
            del tokens[i]
        elif kind == "duplicate" and tokens:
            tokens.insert(i, tokens[i])
        elif kind == "swap" and tokens:
            j = rng.randrange(len(tokens))
            tokens[i], tokens[j] = tokens[j], tokens[i]
        elif kind == "bytes":
            n = rng.randrange(1, 12)
            tokens.insert(i, "".join(chr(rng.randrange(0, 0x250)) for _ in range(n)))
        elif kind == "insert":
            tokens.insert(i, rng.choice(_BREAKERS))
        elif kind == "nest":
            opener = rng.choice(
                ["(", "<", "union {", "#if (1)", "{", "pigment {", "-", "#macro M("]
            )
            tokens.insert(i, opener * rng.randrange(1, 300))
        else:
            tokens = tokens[:i]
    src = " ".join(tokens)
    start = time.perf_counter()
    result = compile_source(src, f"mutant_{name}")
    lines = src.splitlines()
    text = "\n".join(d.format(lines) for d in result.diagnostics)  # what `check` prints
    assert time.perf_counter() - start < 60
    internal = [d for d in result.diagnostics if d.code in ("E0000", "E0200")]
    assert not internal, (internal, text[:2000])


def test_deep_nesting_and_huge_numbers_terminate():
    deep = "union { " * 300 + "sphere { 0, 1 }" + " }" * 300
    assert compile_source(deep, "deep.pov").scene is not None
    huge = "sphere { <1e308, 1e308, 1e308>, 1e308 }\n#declare A = 1e400 * 1e400;\n"
    compile_source(huge, "huge.pov")  # finishes with diagnostics or a scene, never raises


def test_unused_declare_and_shadowing_local_are_warned():
    src = (
        "#declare Unused = 3;\n#declare R = 1;\n"
        "#macro M(A) #local R = 2; sphere { A, R } #end\nM(0)\nsphere { 0, R }\n"
    )
    diags = compile_source(src, "w.pov").diagnostics
    got = {
        (d.code, d.span.line, d.span.col)
        for d in diags
        if d.severity is Severity.WARNING and d.code not in VERSION_CODES
    }
    assert got == {("W0400", 1, 10), ("W0401", 3, 20)}


RUNTIME_SCENE = """camera { location <0.5, 0.5, -3> look_at <0.5, 0.5, 0> }
light_source { <0, 5, -5>, 1 }
nurbs { u_degree 1 v_degree 1
  control_points { 2, 2, <0,0,0>, <1,0,0>, <0,1,0>, <1,1,0> }
  pigment { rgb 1 }
}
subdivision { vertex_vectors { 4, <0,0,0>, <1,0,0>, <0,1,0>, <1,1,0> }
  face_indices { 2, <0,1,2>, <1,3,2> } }
plane { z, 1
  pigment { image_map { png "img.png" } }
}
"""


def test_runtime_failures_name_the_object_that_caused_them(tmp_path):
    """What only the renderer finds (here: in an IR document edited after `compile`, so the
    evaluator's checks never saw it) is reported at the source of the object."""
    import json

    (tmp_path / "img.png").write_bytes(b"\x89PNG\r\n\x1a\n" + b"\0" * 40)  # a header, no image
    scene = tmp_path / "rt.pov"
    scene.write_text(RUNTIME_SCENE)
    doc = tmp_path / "rt.json"
    assert run_cli("compile", str(scene), "-o", str(doc)).returncode == 0
    data = json.loads(doc.read_text())
    nurbs, subdivision, _plane = data["scene"]["objects"]
    nurbs["shape"]["points"] = [[0.0, 0.0, 0.0]] * 4  # a degenerate net
    subdivision["shape"]["faces"] = [[0, 1, 2], [1, 0, 3], [0, 1, 3]]  # edge <0,1> thrice
    doc.write_text(json.dumps(data))
    proc = run_cli("render", str(doc), "-W", "16", "-H", "12", "-o", str(tmp_path / "rt.png"))
    assert proc.returncode == 0, proc.stderr
    out = proc.stdout + proc.stderr
    assert f"{scene}:3:1: warning: nurbs could not be tessellated (all control points" in out
    assert f"{scene}:7:1: warning: subdivision could not be tessellated (non-manifold" in out
    assert f"{scene}:10:3: warning: image `" in out and "could not be read" in out
    assert "Traceback" not in out


def test_a_value_that_failed_is_reported_once_not_again_as_missing():
    src = (
        "#declare Radius = 1;\nsphere { 0, Radiuss pigment { rgb 1 } }\n"
        'light_source { <0, 1, 0>, Colr }\nbox { 0, 1 + "s" }\nbox { 0, 1, 2 }\n'
    )
    errs = [d for d in compile_source(src, "c.pov").diagnostics if d.severity is Severity.ERROR]
    assert [(d.code, d.span.line) for d in errs] == [
        ("E0201", 2),
        ("E0201", 3),
        ("E0203", 4),
        ("E0212", 5),  # an extra value with nothing failed before it is still an error
    ]


def test_a_mistake_in_a_loop_or_a_macro_is_reported_once():
    for src in (
        "#for (I, 0, 100) sphere { I*x, Foo } #end\n",
        "#declare I = 0;\n#while (I < 5000) sphere { I*x, Foo } #declare I = I + 1; #end\n",
        "#macro M() sphere { 0, Foo } #end\nM() M() M()\n",
    ):
        errs = [d for d in compile_source(src, "l.pov").diagnostics if d.severity is Severity.ERROR]
        assert [d.message for d in errs] == ["unknown identifier `Foo`"], src


@pytest.mark.parametrize(
    "src, code",
    [
        ("#declare A = array[1e9];\n", "E0250"),
        ("#declare A = array[100000][100000];\n", "E0250"),
        ('#declare S = "ab";\n#while (strlen(S)) #declare S = concat(S, S); #end\n', "E0203"),
    ],
)
def test_runaway_sizes_are_errors_not_memory_exhaustion(src, code):
    errs = [d for d in compile_source(src, "m.pov").diagnostics if d.severity is Severity.ERROR]
    assert [d.code for d in errs] == [code]
    assert "too" in errs[0].message


@pytest.mark.parametrize(
    "src, endless",
    [
        ("#while (1) sphere { 0, 1 } #end\n", True),
        ("#declare I = 0;\n#while (I < 3) #declare J = I + 1; sphere { J*x, 1 } #end\n", True),
        ("#declare I = 0;\n#while (I < 3) #declare I = I + 1; #end\n", False),
        ("#declare I = 0;\n#while (1) #declare I = I + 1; #if (I > 3) #break #end #end\n", False),
        ('#declare S = seed(1);\n#while (rand(S) < 0.99) #end\n', False),
        # tracevines.pov's form: the condition is reset each pass and set again while a
        # counter lasts (same value after most passes, yet the loop ends)
        ("#declare W = 5;\n#declare C = 1;\n#while (C) #declare C = 0; #declare W = W - 1;"
         " #if (W > 0) #declare C = 1; #end #end\n", False),
        # a macro may change what the condition reads
        ("#declare C = 3;\n#macro Down() #declare C = C - 1; #end\n#while (C) Down() #end\n",
         False),
    ],
)  # fmt: skip
def test_a_while_whose_condition_cannot_change_is_reported_at_once(src, endless):
    """A `#while` that nothing can end (its condition reads no function, the body has no
    #break and cannot change the names the condition reads) is E0230 after one pass, not
    after a million (the fuzzer's `#while (1)` swallowing a file took minutes and 17 GB).
    A body that assigns them, calls a macro or includes a file is left to run."""
    start = time.perf_counter()
    codes = [
        d.code for d in compile_source(src, "loop.pov").diagnostics if d.severity is Severity.ERROR
    ]
    assert codes == (["E0230"] if endless else [])
    assert time.perf_counter() - start < 5


def test_a_for_loop_beyond_the_iteration_limit_is_reported_before_it_runs():
    start = time.perf_counter()
    src = "#for (I, 0, 1e9) sphere { I*x, 1 } #end\n"
    errs = [d for d in compile_source(src, "f.pov").diagnostics if d.severity is Severity.ERROR]
    assert [d.code for d in errs] == ["E0230"] and "1e+09 times" in errs[0].message
    assert time.perf_counter() - start < 5
    ok = "#for (I, 0, 999999, 1) #end\n#for (I, 10, 0, -5) #end\n"
    assert not [d for d in compile_source(ok, "g.pov").diagnostics if d.severity is Severity.ERROR]


def test_diagnostics_come_by_position(tmp_path):
    # a warning (found at the end of the scene) and errors of two passes, in source order
    src = "#declare Z = 1;\nsphere { 0, 1 pigment { rgb bar } }\nsphere { 0, 1 angle 3 }\n}\n"
    diags = diagnostics_of("order", src, tmp_path)
    places = [(d.span.line, d.span.col) for d in diags]
    assert places == sorted(places) and len(diags) >= 4, [d.format() for d in diags]


def test_a_misspelt_block_is_one_error(tmp_path):
    # POV-Ray: "No matching } in 'sphere', undeclared identifier 'pigmnet' found instead"
    diags = diagnostics_of("typo", "sphere { 0, 1 pigmnet { rgb 1 } }\n", tmp_path)
    assert [(d.code, d.span.line, d.span.col) for d in diags] == [("E0201", 1, 15)]
    assert "pigment" in (diags[0].hint or "")


def test_an_error_in_a_macro_body_names_the_call(tmp_path):
    src = "#macro M(A)\n  sphere { 0, A pigment { rgb foo } }\n#end\nM(1)\nM(2)\n"
    (d,) = errors_of("macro_call", src, tmp_path)  # once, for the first call
    assert (d.code, d.span.line, d.span.col) == ("E0201", 2, 31)
    assert [(name, at.line, at.col) for name, at in d.called_from] == [("M", 4, 1)]
    assert "in macro `M` called at" in d.format() and ":4:1" in d.format()
    # through two macros: the innermost call first
    src = "#macro In() rgb foo #end\n#macro Out() sphere { 0, 1 pigment { In() } } #end\nOut()\n"
    (d,) = errors_of("macro_nested", src, tmp_path)
    assert [(name, at.line) for name, at in d.called_from] == [("In", 2), ("Out", 3)]
