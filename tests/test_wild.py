"""The runner of POV-Ray users' scenes (tests/conformance/wild.py) without a corpus: how it
groups failures, counts, decides a match, finds scenes and frames, and runs a tiny corpus
written here (the POV-Ray half only where POV-Ray is installed)."""

from __future__ import annotations

import json
import math
import shutil

import pytest
from conformance import wild
from conformance.wild import WildResult

GOOD = """camera { location <0, 0, -4> look_at 0 }
light_source { <5, 5, -5> color rgb 1 }
sphere { 0, 1 pigment { color rgb <1, 0.5, 0.2> } }
background { color rgb <0.1, 0.2, 0.3> }
"""
BROKEN_FOR_BOTH = "sphere { 0, 1 pigment { color rgb 1 } \n"  # no closing brace


# ------------------------------------------------------------------ messages
@pytest.mark.parametrize(
    "a, b",
    [
        ("unknown identifier `T_Wood20`", "unknown identifier `Stone_Floor`"),
        ("unknown identifier `ball`", "unknown identifier `my_thing2`"),
        ("include file `woods.inc` not found", "include file `stones.inc` not found"),
        ('cannot open "pics/sky.png"', 'cannot open "Earth.JPG"'),
        ("cannot read image maps/sky.png", "cannot read image /home/u/earth.tga"),
        ("array index 12 out of range 0..9", "array index -1.5 out of range 0..3"),
        (
            "`tiles` is not supported yet in texture (in chess.inc)",
            "`tiles` is not supported yet in texture (in pieces.inc)",
        ),
        ("expected 3 components, got 2.5e-3", "expected 4 components, got .5"),
        ("unexpected `Foo`", "unexpected `bar_2`"),
    ],
)
def test_normalize_groups_the_same_failure(a, b):
    assert wild.normalize(a) == wild.normalize(b)


@pytest.mark.parametrize(
    "a, b",
    [
        ("`tiles` is not supported yet in texture", "`photons` is not supported yet in texture"),
        ("unknown identifier `T_Wood20`", "include file `woods.inc` not found"),
        ("`#switch` without `#end`", "`#while` without `#end`"),
        ("unexpected `=`", "unexpected `}`"),
    ],
)
def test_normalize_keeps_what_names_the_feature(a, b):
    assert wild.normalize(a) != wild.normalize(b)


def test_normalize_spells_out_what_it_replaced():
    assert wild.normalize("unknown identifier `T_Wood20`") == "unknown identifier `ID`"
    assert wild.normalize("include file `woods.inc` not found") == "include file `…` not found"
    assert wild.normalize("bad value 2.5 in sky.pov") == "bad value N in FILE"
    assert wild.normalize("`tiles`  is\tnot supported") == "`tiles` is not supported"


def _scene(name: str, **kw) -> WildResult:
    return WildResult(name, **({"povray": "ok"} | kw))


def test_failure_classes_put_internal_errors_first_then_the_largest():
    results = [
        _scene("a.pov", strala="error", exit_code=1, diagnostic="unknown identifier `A`"),
        _scene("b.pov", strala="error", exit_code=1, diagnostic="unknown identifier `B`"),
        _scene("c.pov", strala="error", exit_code=1, diagnostic="include file `x.inc` not found"),
        _scene("d.pov", strala="internal", exit_code=3, diagnostic="internal error: KeyError: 3"),
        _scene("e.pov", strala="timeout", diagnostic="render took over 9 s"),
        _scene("f.pov", strala="ok", exit_code=0, rmse=0.5, off=0.5),  # renders: no class
        WildResult("g.pov", povray="error", strala="n/a"),  # POV-Ray fails: not counted
        _scene("h.pov", strala="crash", exit_code=-11, diagnostic="exit -11"),
    ]
    classes = wild.failure_classes(results)
    assert classes[0] == (f"{wild.INTERNAL}: KeyError: N", ["d.pov"])
    assert classes[1] == ("unknown identifier `ID`", ["a.pov", "b.pov"])
    assert sorted(n for _, names in classes for n in names) == [f"{c}.pov" for c in "abcdeh"]
    assert [len(n) for _, n in classes[1:]] == sorted(
        (len(n) for _, n in classes[1:]), reverse=True
    )
    # f.pov renders unlike POV-Ray: a difference, grouped by its first warning
    assert wild.differences(results) == [("no warning", ["f.pov"])]
    # an error that only says "internal" in its text (exit 1) is not an internal error
    exit1 = _scene("i.pov", strala="error", exit_code=1, diagnostic="internal error while x")
    assert not wild.failure_class(exit1).startswith(wild.INTERNAL)


# ------------------------------------------------------------------ counting
@pytest.mark.parametrize(
    "rmse, off, match",
    [(0.0, 0.0, True), (0.049, 0.029, True), (0.05, 0.0, False), (0.01, 0.03, False),
     (0.2, 0.0, False), (0.0, 0.5, False)],
)  # fmt: skip
def test_match_rule(rmse, off, match):
    assert wild.is_match(rmse, off) is match
    assert _scene("s.pov", strala="ok", rmse=rmse, off=off).match is match
    assert not _scene("s.pov", strala="error").match  # nothing to compare


def test_summary_counts_only_what_povray_renders():
    results = [
        _scene("a.pov", strala="ok", strala_seconds=4.0, povray_seconds=1.0, rmse=0.0, off=0.0),
        _scene("b.pov", strala="ok", strala_seconds=1.0, povray_seconds=1.0, rmse=0.3, off=0.5),
        _scene("c.pov", strala="ok", strala_seconds=3.0, povray_seconds=2.0, rmse=0.01, off=0.0),
        _scene("d.pov", strala="error", strala_seconds=9.0, povray_seconds=5.0),
        _scene("e.pov", strala="internal", exit_code=3, povray_seconds=1.0),
        WildResult("f.pov", povray="error", povray_seconds=0.5),
        WildResult("g.pov", povray="timeout", povray_seconds=120.0),
    ]
    s = wild.summarize(results)
    assert (s.scenes, s.povray, s.rendered, s.matched, s.internal) == (7, 5, 3, 2, 1)
    assert s.render_share == pytest.approx(0.6) and s.match_share == pytest.approx(0.4)
    # times over the scenes both rendered: 8 s / 4 s; per scene 4, 1, 1.5
    assert s.total_ratio == pytest.approx(2.0)
    assert s.median_ratio == pytest.approx(1.5)
    assert "POV-Ray renders 5" in s.line


def test_summary_of_nothing_is_not_a_division_by_zero():
    s = wild.summarize([WildResult("a.pov", povray="error")])
    assert (s.scenes, s.povray, s.rendered) == (1, 0, 0)
    assert math.isnan(s.render_share) and math.isnan(s.total_ratio)
    assert math.isnan(s.median_ratio)


# ------------------------------------------------------------------ corpus
def test_scenes_selection_and_frames(tmp_path):
    (tmp_path / "a").mkdir()
    (tmp_path / "a" / "one.pov").write_text(GOOD)
    (tmp_path / "a" / "TWO.POV").write_text(GOOD)
    (tmp_path / "a" / "lib.inc").write_text("#declare X = 1;")
    (tmp_path / "b" / "shot").mkdir(parents=True)
    (tmp_path / "b" / "shot" / "anim.pov").write_text(GOOD)
    # an .ini in the folder above names the scene (POV-Ray runs it from there)
    (tmp_path / "b" / "anim.ini").write_text(
        "Input_File_Name=shot/anim.pov\nInitial_Frame=0\nFinal_Frame=60\n"
        "Initial_Clock=0\nFinal_Clock=30\n"
    )
    found = wild.scenes(tmp_path)
    rel = [p.relative_to(tmp_path).as_posix() for p in found]
    assert rel == ["a/TWO.POV", "a/one.pov", "b/shot/anim.pov"]
    assert len(wild.select(found, tmp_path, ["a/*"], None)) == 2
    assert len(wild.select(found, tmp_path, [], 1)) == 1
    assert wild.select(found, tmp_path, ["*anim*"], None) == [found[2]]
    anim = wild.frame_for(found[2], tmp_path)
    assert (anim.number, anim.first, anim.last, anim.final_clock) == (0, 0, 60, 30.0)
    assert wild.ini_for(found[2], tmp_path) == tmp_path / "b" / "anim.ini"
    assert wild.frame_for(found[1], tmp_path).number is None  # a still, at clock 0
    assert wild.slug("a/TWO.POV") == "a__TWO" and wild.slug("b/x.pov") == "b__x"


def test_strala_half_of_the_runner(tmp_path):
    """strala's render of a good scene, a broken one and one past its time limit (no
    POV-Ray needed)."""
    from conformance import corpus

    (tmp_path / "good.pov").write_text(GOOD)
    (tmp_path / "bad.pov").write_text(GOOD + "object { Nowhere_Declared }\n")
    frame = corpus.Frame()
    status, code, seconds, _, first = wild.strala_render(
        tmp_path / "good.pov", frame, tmp_path / "good.png", 60, []
    )
    assert (status, code) == ("ok", 0) and (tmp_path / "good.png").exists() and seconds > 0
    status, code, _, diags, first = wild.strala_render(
        tmp_path / "bad.pov", frame, tmp_path / "bad.png", 60, []
    )
    assert (status, code) == ("error", 1) and "Nowhere_Declared" in first
    assert wild.normalize(first) == "unknown identifier `ID`"
    status, code, _, _, first = wild.strala_render(
        tmp_path / "good.pov", frame, tmp_path / "slow.png", 0.01, []
    )  # not even Python starts in 10 ms: the process is killed
    assert (status, code) == ("timeout", None) and not (tmp_path / "slow.png").exists()


@pytest.mark.povray
def test_runner_on_a_tiny_corpus(tmp_path):
    """Three scenes: one both render alike, one strala cannot evaluate, one POV-Ray cannot
    render either (left out of the counts); the report and results.json say so."""
    assert shutil.which("povray")
    root = tmp_path / "corpus"
    (root / "users").mkdir(parents=True)
    (root / "users" / "good.pov").write_text(GOOD)
    (root / "users" / "strala_fails.pov").write_text(
        GOOD
        # a colour map file of POV-Ray's include folder, which strala's stdlib lacks
        + '#include "ash.map"\n'
        + "box { -1, 1 pigment { wood color_map { M_Ash } } translate 5*x }\n"
    )
    (root / "users" / "broken.pov").write_text(BROKEN_FOR_BOTH)
    (root / "users" / "broken.inc").write_text("not a scene")
    out = tmp_path / "report"
    rc = wild.main([str(root), "-o", str(out), "--jobs", "2", "--timeout", "60",
                    "--no-povray-include"])  # fmt: skip
    assert rc == 0
    doc = json.loads((out / "results.json").read_text())
    by = {d["scene"]: d for d in doc["scenes"]}
    assert set(by) == {"users/good.pov", "users/strala_fails.pov", "users/broken.pov"}
    assert by["users/good.pov"]["match"] and by["users/good.pov"]["exit_code"] == 0
    assert by["users/broken.pov"]["povray"] != "ok"
    fails = by["users/strala_fails.pov"]
    assert fails["povray"] == "ok" and fails["strala"] == "error" and fails["exit_code"] == 1
    s = doc["summary"]
    assert (s["scenes"], s["povray"], s["rendered"], s["matched"]) == (3, 2, 1, 1)
    assert doc["options"]["povray_include"] is False
    assert [c["count"] for c in doc["failure_classes"]] == [1]
    assert [c["scenes"] for c in doc["povray_failures"]] == [["users/broken.pov"]]
    assert doc["differences"] == []
    page = (out / "index.html").read_text()
    assert "users/strala_fails.pov" in page and "good.povray.png" in page
    assert (out / "images" / "users__good.diff.png").exists()
    # the report again from results.json alone, and with POV-Ray's includes strala renders it
    assert wild.main([str(root), "-o", str(out), "--report-only"]) == 0
    assert wild.load_results(out / "results.json")[0].scene == "users/broken.pov"
    wild.main([str(root), "-o", str(out), "--match", "*fails*"])
    doc = json.loads((out / "results.json").read_text())
    assert doc["scenes"][0]["strala"] == "ok" and doc["options"]["povray_include"] is True


def test_povray_error_is_the_parse_error_not_the_fatal_line():
    err = """==== [Parsing...] ====
File 'Dumbell.pov' line 4: Possible Parse Error: Cannot find file 'SHAPES.INC.',
 even after trying to append file type extension.
File 'Dumbell.pov' line 4: Parse Error: Cannot open include file
 SHAPES.INC..
Fatal error in parser: Cannot parse input.
Render failed
"""
    assert wild.povray_error(err) == (
        "File 'Dumbell.pov' line 4: Parse Error: Cannot open include file SHAPES.INC.."
    )
    assert wild.povray_error("Fatal error in parser: Cannot open file.\nRender failed\n") == (
        "Fatal error in parser: Cannot open file."
    )
    assert wild.povray_error("") == ""


def test_the_suite_runner_counts_the_scenes_the_kernel_traced(tmp_path):
    """run.py reads `render --stats` for how each image was traced: a scene of spheres is
    the compiled kernel's, one in media the numpy path's with its reason; the summary counts
    the kernel's share and reasons.md tallies the reasons."""
    from conformance import corpus, report, run

    from runtime.whitted import kernel_built

    (tmp_path / "kern.pov").write_text(GOOD)
    (tmp_path / "fog.pov").write_text(GOOD + "media { scattering { 1, 0.05 } }\n")
    frame = corpus.Frame()
    results = []
    for name in ("kern", "fog"):
        res = run.SceneResult(f"{name}.pov", 0.0, None, povray_seconds=1.0)
        res.lib = run.strala_render(tmp_path / f"{name}.pov", frame, [], tmp_path / f"{name}.png",
                                    None, 60)  # fmt: skip
        results.append(res)
    kern, fog = (r.lib for r in results)
    assert fog.traced_by == "numpy" and "media" in fog.numpy_because
    if kernel_built():
        assert (kern.traced_by, kern.numpy_because) == ("kernel", [])
        assert "compiled kernel 1/2 (50%) of the rendered" in report.summary_line(
            report.counts(results)
        )
    assert "| 1 | media | fog.pov |" in report.reasons(results)
    assert run.traced_by("no stats here") == ("", [])
