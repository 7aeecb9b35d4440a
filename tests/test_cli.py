"""The `strala` command line: options (strala and POV-Ray style), exit codes, output names,
diagnostics instead of tracebacks, `check` staying free of numpy, and the progress bar."""

from __future__ import annotations

import argparse
import json
import os
import re
import subprocess
import sys
from pathlib import Path

import pytest
from conftest import EXAMPLES, ROOT, run_cli
from hypothesis import given
from hypothesis import strategies as st

from runtime import cli, povray_options

EX3 = EXAMPLES / "ex3.scene"


# ------------------------------------------------------------ POV-Ray options
def _translate(*argv: str) -> tuple[list[str], list[str]]:
    warnings: list[str] = []
    return cli.translate_povray_args(list(argv), warnings), warnings


def test_povray_switches_become_strala_options():
    out, warnings = _translate(
        "+Iscene.pov", "+W512", "+H384", "+A0.3", "+R4", "+Oout.png", "+L", "/inc", "+WT2"
    )
    assert out == [
        "scene.pov", "-W", "512", "-H", "384", "--aa", "0.3", "--aa-depth", "4",
        "-o", "out.png", "-L", "/inc", "--threads", "2",
    ]  # fmt: skip
    assert warnings == []


def test_the_seeds_own_command_line_works():
    # NOTES §5: "povray +IEx3.pov +X +D +W512 +H512"
    argv = ["+IEx3.pov", "+X", "+D", "+W512", "+H512"]
    assert cli.looks_like_render(argv)
    args = cli.build_parser().parse_args(["render", *_translate(*argv)[0]])
    assert (args.file, args.width, args.height, args.aa) == ("Ex3.pov", 512, 512, None)
    assert cli.output_path(args.file, args.output, ".png") == Path("Ex3.png")


def test_display_switches_become_options_and_unknown_ones_warned():
    out, warnings = _translate("-D", "+D", "-V", "+V", "-P", "+GA", "+Q9", "scene.pov")
    assert out == ["scene.pov", "--display", "--no-pause"]
    assert warnings == ["ignoring POV-Ray option +Q9"]
    # +D's letters after it are a DOS video mode and palette: the window opens all the same
    assert _translate("+D0", "s.pov")[0] == ["s.pov", "--display"]
    assert _translate("Display=on", "Pause_When_Done=true")[0] == ["--display", "--pause"]
    assert _translate("Display=off")[0] == ["--no-display"]


def test_aa_switch_forms():
    assert _translate("+A")[0] == ["--aa"]
    assert _translate("-A")[0] == ["--no-aa"]
    assert _translate("+FN16")[0] == ["--output-type", ".png", "--bits", "16"]
    assert _translate("+K0.25")[0] == ["--clock", "0.25"]


def test_values_of_strala_options_are_not_translated():
    out, _ = _translate("-o", "+odd.png", "-L", "+dir", "-W512", "-q")
    assert out == ["-o", "+odd.png", "-L", "+dir", "-W512", "-q"]


def test_ini_file_becomes_options(tmp_path):
    ini = tmp_path / "render.ini"
    ini.write_text(
        "; POV-Ray INI\nInput_File_Name=scene.pov\nWidth = 64\nHeight=48\nAntialias=On\n"
        "Antialias_Threshold=0.2\n+Oout.png\n[other]\nWidth=9999\n"
    )
    out, _ = _translate(str(ini))
    assert out == ["scene.pov", "-W", "64", "-H", "48", "--aa", "0.2", "-o", "out.png"]


def test_a_threshold_alone_does_not_turn_anti_aliasing_on():
    # POV-Ray: Antialias_Threshold without Antialias=on renders one ray per pixel
    out, warnings = _translate("Antialias_Threshold=0.1", "s.pov")
    assert out == ["s.pov"] and "not turned on" in warnings[0]
    assert _translate("Antialias_Threshold=0.1", "Antialias=on")[0] == ["--aa", "0.1"]
    assert _translate("+A0.1", "-A")[0] == ["--no-aa"]


def test_declare_on_the_command_line_and_in_ini_files(tmp_path):
    ini = tmp_path / "d.ini"
    ini.write_text("Declare=Size=2.5\ndeclare=Other=-1e-2 ; a comment\n")
    out, warnings = _translate("Declare=Rad=1.2", str(ini), "s.pov")
    assert out == ["s.pov", "--declare", "Rad=1.2", "--declare", "Size=2.5", "--declare",
                   "Other=-1e-2"]  # fmt: skip
    assert warnings == []
    args = cli.build_parser().parse_args(["render", *out])
    assert args.declare == [("Rad", 1.2), ("Size", 2.5), ("Other", -0.01)]


@pytest.mark.parametrize(
    ("text", "value"), [("R=1.2", 1.2), ("R=2*3", 2.0), ("R=abc", 0.0), ("R= .5e1x", 5.0)]
)
def test_declared_values_are_read_as_povray_reads_them(text, value):
    # POV-Ray 3.7 reads the value as C's atof: `Declare=R=2*3` declares 2, `R=abc` 0
    assert cli.parse_declare(text) == ("R", value)


@pytest.mark.povray
def test_declare_sets_the_name_as_in_povray(tmp_path):
    scene = tmp_path / "d.pov"
    scene.write_text('#debug concat("Rad=", str(Rad, 0, 4), "\\n")\nsphere { 0, 1 }\n')
    (tmp_path / "d.ini").write_text("Declare=Rad=3.25\n")
    pov = subprocess.run(
        ["povray", "+Id.pov", "-D", "-F", "+W8", "+H8", "Declare=Rad=1.2"],
        cwd=tmp_path, capture_output=True, text=True, timeout=60,
    ).stderr  # fmt: skip
    assert "Rad=1.2000" in pov
    for argv, want in (("Declare=Rad=1.2", "Rad=1.2000"), ("d.ini", "Rad=3.25")):
        r = run_cli("check", "d.pov", argv, cwd=tmp_path)
        assert want in r.stdout and r.returncode == 0, r.stdout + r.stderr


@given(st.lists(st.sampled_from(["+D", "-D", "+V", "-V", "+P", "-P", "+GA", "-GA", "+X"])))
def test_ignored_switches_never_reach_argparse(switches):
    out, warnings = _translate(*switches, "scene.pov")
    # the display and pause switches: the last of each wins, in the order last given
    last = {s[1]: s for s in switches if s[1] in "DP"}
    order = sorted(last.values(), key=lambda s: max(i for i, t in enumerate(switches) if t == s))
    flags = {"D": "display", "P": "pause"}
    want = [("--" if s[0] == "+" else "--no-") + flags[s[1]] for s in order]
    assert out == ["scene.pov", *want] and warnings == []
    cli.build_parser().parse_args(["render", *out])  # all of them strala's options


def test_bare_scene_or_plus_option_means_render():
    assert cli.looks_like_render(["scene.pov", "+W10"])
    assert cli.looks_like_render(["+Iscene.pov"])
    assert not cli.looks_like_render(["check", "scene.pov"])
    assert not cli.looks_like_render(["--help"])


@given(st.integers(0, 10_000), st.integers(0, 10_000), st.sampled_from(["..", ":", "-"]))
def test_frame_ranges_parse(a, b, sep):
    if a <= b:
        assert cli.parse_frames(f"{a}{sep}{b}") == (a, b)
    else:
        with pytest.raises(argparse.ArgumentTypeError):
            cli.parse_frames(f"{a}{sep}{b}")


def test_animation_follows_povray_clock_and_names():
    jobs = cli.frame_jobs(Path("out/ex3.png"), 0.0, (1, 10))
    assert [j[0].name for j in jobs[:2]] == ["ex301.png", "ex302.png"]
    assert jobs[-1][0] == Path("out/ex310.png")
    assert [j[1] for j in jobs] == pytest.approx([i / 9 for i in range(10)])
    assert cli.frame_jobs(Path("a.png"), 0.25, None) == [(Path("a.png"), 0.25, "rendering")]
    assert _translate("+KFI2", "+KFF5")[0] == ["--frames", "2..5"]


def test_partial_render_region_counts_like_povray():
    # POV-Ray 3.7, +W100 +H80 +SC0.25 +EC0.75 +SR10 +ER40: columns 25..74, rows 9..39 drawn
    out, _ = _translate("+SC0.25", "+EC0.75", "+SR10", "+ER40")
    assert out == [
        "--start-col",
        "0.25",
        "--end-col",
        "0.75",
        "--start-row",
        "10",
        "--end-row",
        "40",
    ]
    assert cli.resolve_region(100, 80, 0.25, 0.75, 10, 40) == (25, 9, 75, 40)
    assert cli.resolve_region(100, 80, None, None, None, None) is None
    assert cli.resolve_region(100, 80, None, None, 0.5, None) == (0, 40, 100, 80)
    with pytest.raises(cli.UsageError, match="no pixels"):
        cli.resolve_region(100, 80, 0.8, 0.2, None, None)
    with pytest.raises(cli.UsageError, match="finite"):
        cli.resolve_region(100, 80, float("nan"), None, None, None)


@given(
    st.integers(1, 400),
    st.integers(1, 400),
    st.tuples(*[st.none() | st.floats(0, 1) | st.integers(2, 500).map(float) | st.floats()] * 4),
)
def test_region_is_inside_the_image_or_refused(width, height, ends):
    try:
        left, top, right, bottom = cli.resolve_region(width, height, *ends) or (0, 0, width, height)
    except cli.UsageError:
        return
    assert 0 <= left < right <= width and 0 <= top < bottom <= height


# ----------------------------------------------------------------- outputs
@pytest.mark.parametrize(
    "scene, output, expected",
    [
        ("dir/ex3.scene", None, "dir/ex3.png"),
        ("ex3.pov", "out.exr", "out.exr"),
        ("ex3.pov", "renders/", "renders/ex3.png"),
        ("ex3.pov", "final", "final.png"),
    ],
)
def test_output_names_follow_povray(scene, output, expected):
    assert cli.output_path(scene, output, ".png") == Path(expected)


def test_output_into_an_existing_folder(tmp_path):
    assert cli.output_path("a/ex3.pov", str(tmp_path), ".png") == tmp_path / "ex3.png"


# --------------------------------------------------------------- exit codes
def test_missing_file_is_a_diagnostic_not_a_traceback(tmp_path, capsys):
    missing = str(tmp_path / "nope.pov")
    assert cli.main(["check", missing]) == 1
    out = capsys.readouterr().out
    assert f"{missing}:1:1: error: cannot read" in out
    assert "Traceback" not in out


def test_missing_file_in_render_exits_1(tmp_path, capsys):
    assert cli.main(["render", str(tmp_path / "nope.pov"), "-q"]) == 1
    assert "no such file" in capsys.readouterr().err


@pytest.mark.parametrize(
    "argv",
    [
        ["render"],
        ["render", "x.pov", "-W", "0"],
        ["render", "x.pov", "--aa", "lots"],
        ["render", "x.pov", "--aa-depth", "12"],
        ["render", "x.pov", "--frames", "9..2"],
        ["frobnicate", "x"],
        [],
    ],
)
def test_bad_command_lines_exit_2(argv, capsys):
    with pytest.raises(SystemExit) as exc:
        cli.main(argv)
    assert exc.value.code == 2
    assert "usage:" in capsys.readouterr().err


def test_unwritable_output_is_a_usage_error_before_rendering(tmp_path, capsys):
    scene = tmp_path / "s.pov"
    scene.write_text("sphere { 0, 1 }\n")
    assert cli.main(["render", str(scene), "-o", str(tmp_path / "x.bmpx")]) == 2
    assert "cannot write `.bmpx` images" in capsys.readouterr().err
    assert cli.main(["render", str(scene), "-o", str(tmp_path / "no" / "x.png")]) == 2
    assert "does not exist" in capsys.readouterr().err


def _read_only_folders(tmp_path):
    """Folders no new file can go into: /sys refuses even root; a chmod'd one others."""
    folders = [Path("/sys")] if Path("/sys").is_dir() else []
    if os.geteuid() != 0:
        locked = tmp_path / "locked"
        locked.mkdir()
        locked.chmod(0o555)
        folders.append(locked)
    return folders


def test_a_read_only_output_folder_is_refused_at_once(tmp_path, capsys):
    # the scene is broken: reaching it would exit 1, not 2
    scene = tmp_path / "s.pov"
    scene.write_text("sphere { 0, 1 \n")
    folders = _read_only_folders(tmp_path)
    assert folders
    for folder in folders:
        for extra in ([], ["--frames", "1..3"]):
            assert cli.main(["render", str(scene), "-o", str(folder / "x.png"), *extra]) == 2
            err = capsys.readouterr().err
            assert err.count("\n") == 1 and f"cannot write {folder / 'x.png'}" in err, err
            assert "tmp" not in err.replace(str(tmp_path), "")  # no hidden temporary file
    assert cli.main(["render", str(scene), "-o", str(tmp_path / "x.jpg"), "--bits", "16"]) == 2


_FUZZ_WORDS = [
    "render", "check", "compile", "fmt", "-o", "-W", "-H", "--aa", "--no-aa", "--aa-depth",
    "-L", "--threads", "--bits", "--clock", "--frames", "--format", "json", "sarif", "-q",
    "--io-restrictions", "restricted", "none",
    "+W", "+H64", "+A", "+A0.2", "-A", "+R2", "+O", "+Oo.png", "+I", "+L", "+WT2", "+FN16",
    "+KFI1", "+KFF3", "+SC0.5", "+ER2", "-D", "+Q9", "--", "-", "0", "-1", "1..2", "x.bmpx",
    "missing.pov", "missing.json", "missing.ini", "16", "8", "0.5", "nan",
]  # fmt: skip


@given(st.lists(st.sampled_from(_FUZZ_WORDS), max_size=8))
def test_no_command_line_gives_a_traceback(words):
    # every input file named here is missing, so nothing renders: the outcome is a usage
    # error (2), a diagnostic (1) or success (0), and never an exception
    try:
        code = cli.main(words)
    except SystemExit as exc:
        code = exc.code
    assert code in (0, 1, 2)


def test_version(capsys):
    with pytest.raises(SystemExit) as exc:
        cli.main(["--version"])
    assert exc.value.code == 0
    assert capsys.readouterr().out.startswith("strala ")


def test_internal_errors_are_one_line_unless_debug(monkeypatch, capsys, tmp_path):
    def boom(args):
        raise RuntimeError("kaboom")

    monkeypatch.setattr(cli, "cmd_check", boom)
    scene = str(tmp_path / "s.pov")
    assert cli.main(["check", scene]) == 3
    err = capsys.readouterr().err
    assert "internal error: RuntimeError: kaboom" in err
    assert "Traceback" not in err
    assert cli.main(["check", "--debug", scene]) == 3
    assert "Traceback" in capsys.readouterr().err
    assert cli.main(["--debug", "check", scene]) == 3
    assert "Traceback" in capsys.readouterr().err


def test_bad_ir_document_is_a_diagnostic(tmp_path, capsys):
    doc = tmp_path / "scene.json"
    doc.write_text('{"format": "strala-ir", "version": 999}')
    assert cli.main(["render", str(doc), "-q"]) == 1
    assert "IR version 999 is not supported" in capsys.readouterr().err


# ---------------------------------------------------------------------- fmt
def test_fmt_check_and_rewrite(tmp_path):
    scene = tmp_path / "s.pov"
    scene.write_text("sphere {<0,0,0>,1\npigment { Red }}\n")
    assert cli.main(["fmt", "--check", str(scene)]) == 1
    assert cli.main(["fmt", str(scene)]) == 0
    assert cli.main(["fmt", "--check", str(scene)]) == 0
    assert sorted(p.name for p in tmp_path.iterdir()) == ["s.pov"]


def test_lsp_subcommand_starts_the_language_server():
    args = cli.build_parser().parse_args(["lsp"])
    assert args.func is cli.cmd_lsp
    proc = run_cli("lsp")  # stdin is empty: the server sees end of input and stops
    assert proc.returncode == 0, proc.stderr


def test_example_is_formatted():
    assert cli.main(["fmt", "--check", str(EX3)]) == 0


# ------------------------------------------------------------ check (needs lang)
def test_check_into_a_closed_pipe_is_quiet(tmp_path):
    bad = tmp_path / "bad.pov"
    bad.write_text("sphere { 0, 1 }\n" + "}\n" * 60)
    # more output than a pipe buffers, so the writer meets the closed end
    cmd = [sys.executable, "-m", "runtime.cli", "check", *[str(bad)] * 40]
    proc = subprocess.Popen(
        cmd, cwd=ROOT, stdin=subprocess.DEVNULL, stdout=subprocess.PIPE, stderr=subprocess.PIPE
    )
    assert proc.stdout.readline().startswith(str(bad).encode())
    proc.stdout.close()
    err = proc.stderr.read().decode()
    assert proc.wait(timeout=120) == 141
    assert "Traceback" not in err and "internal error" not in err


def test_check_loads_no_numpy_embree_or_openimageio(tmp_path):
    """`check` of a scene with every kind of diagnostic stays in pure Python (it starts fast)."""
    bad = tmp_path / "bad.pov"
    bad.write_text(
        '#include "colors.inc"\nsphere { 0, Radiuss pigment { Red } }\n'
        'plane { y, 0 pigment { image_map { png "x.png" } } }\n'
        "nurbs { u_degree 1 v_degree 1 control_points { 2, 2, 0, 0, 0, 0 } }\n}\n"
    )
    code = (
        "import sys; from runtime import cli; "
        f"rc = cli.main(['check', {str(EX3)!r}, {str(bad)!r}]); "
        "heavy = sorted({m.split('.')[0] for m in sys.modules} & "
        "{'numpy', 'embree', 'embreex', 'OpenImageIO', 'PIL', 'scipy'}); "
        "print('RESULT', rc, heavy)"
    )
    proc = subprocess.run(
        [sys.executable, "-c", code], cwd=ROOT, capture_output=True, text=True, timeout=120
    )
    assert "RESULT 1 []" in proc.stdout, proc.stdout + proc.stderr
    assert "E0201" in proc.stdout and "E0281" in proc.stdout and "E0101" in proc.stdout


def test_check_json_and_sarif(tmp_path):
    bad = tmp_path / "bad.pov"
    bad.write_text("sphere { <0,0,0>, 1 }\n}\n")
    proc = run_cli("check", "--format", "json", str(bad), str(EX3))
    assert proc.returncode == 1
    doc = json.loads(proc.stdout)
    assert doc["errors"] >= 1
    first = doc["diagnostics"][0]
    assert first["severity"] == "error" and first["span"]["line"] == 2
    proc = run_cli("check", "--format", "sarif", str(bad))
    sarif = json.loads(proc.stdout)
    result = sarif["runs"][0]["results"][0]
    assert result["level"] == "error"
    assert result["locations"][0]["physicalLocation"]["region"]["startLine"] == 2
    # the rules the results name, each with its description, found by its index
    rules = sarif["runs"][0]["tool"]["driver"]["rules"]
    rule = rules[result["ruleIndex"]]
    assert rule["id"] == result["ruleId"] == "E0101"
    assert rule["shortDescription"]["text"] and rule["defaultConfiguration"]["level"] == "error"
    assert {"E0201", "W0400", "N0100"} <= {r["id"] for r in rules}


def test_sarif_names_the_macro_calls_as_related_locations(tmp_path):
    # the mistake is in an include's macro body; the calls that reached it, innermost first,
    # are places a code-scanning viewer can open (not only words in the message)
    (tmp_path / "shapes.inc").write_text(
        "#macro Ball(R)\n  sphere { 0, R pigment { rgb nope } }\n#end\n#macro Pair() Ball(1) #end\n"
    )
    scene = tmp_path / "main.pov"
    scene.write_text('#include "shapes.inc"\n\nPair()\n')
    proc = run_cli("check", "--format", "sarif", str(scene))
    (result,) = json.loads(proc.stdout)["runs"][0]["results"]
    assert result["ruleId"] == "E0201"
    place = result["locations"][0]["physicalLocation"]
    assert place["artifactLocation"]["uri"].endswith("shapes.inc")
    assert place["region"]["startLine"] == 2
    related = [
        (
            r["physicalLocation"]["artifactLocation"]["uri"].rsplit("/", 1)[-1],
            r["physicalLocation"]["region"]["startLine"],
            r["physicalLocation"]["region"]["startColumn"],
            r["message"]["text"],
        )
        for r in result["relatedLocations"]
    ]
    assert related == [
        ("shapes.inc", 4, 15, "in macro `Ball` called here"),
        ("main.pov", 3, 1, "in macro `Pair` called here"),
    ]
    assert len({r["id"] for r in result["relatedLocations"]}) == 2
    # a mistake outside any macro has none
    scene.write_text("sphere { 0, 1 pigment { rgb nope } }\n")
    (result,) = json.loads(run_cli("check", "--format", "sarif", str(scene)).stdout)["runs"][0][
        "results"
    ]
    assert "relatedLocations" not in result


def test_every_code_reported_has_a_title():
    from lang.diagnostics import DEFAULT_HINTS, TITLES

    assert set(DEFAULT_HINTS) <= set(TITLES)


def test_compile_writes_ir_that_loads(tmp_path):
    from lang import ir, serialize

    out = tmp_path / "ex3.json"
    assert cli.main(["compile", str(EX3), "-o", str(out), "-q"]) == 0
    scene = serialize.loads(out.read_text())
    assert isinstance(scene, ir.Scene)
    assert scene.camera.location == pytest.approx((1, 1, -7))
    assert len(scene.objects) == 4 and len(scene.lights) == 1


def test_render_end_to_end_writes_png(tmp_path):
    from runtime.image import read_image

    out = tmp_path / "ex3.png"
    proc = run_cli("render", str(EX3), "-W", "40", "-H", "30", "-o", str(out))
    assert proc.returncode == 0, proc.stderr
    img = read_image(out)
    assert img.shape == (30, 40, 3)
    assert img.std() > 0.05  # a picture, not a blank frame
    assert f"wrote {out}" in proc.stderr


def test_render_povray_style_default_size_and_name(tmp_path):
    from runtime.image import read_image

    scene = tmp_path / "ex3.pov"
    scene.write_text(EX3.read_text())
    proc = run_cli(f"+I{scene}", "-D", "+A0.3", "-q")
    assert proc.returncode == 0, proc.stderr
    assert read_image(tmp_path / "ex3.png").shape == (240, 320, 3)
    assert proc.stderr == ""  # --quiet, and no TTY: no bar, no summary


def test_scenes_see_the_image_size(tmp_path):
    scene = tmp_path / "size.pov"
    scene.write_text(
        "camera { right x*image_width/image_height }\n"
        '#if (image_width != 40 | image_height != 30) #error "size not passed" #end\n'
    )
    assert cli.main(["check", str(scene), "-W", "40", "-H", "30"]) == 0
    assert cli.main(["check", str(scene)]) == 1  # 320x240, POV-Ray's default, is not 40x30
    out = tmp_path / "size.json"
    assert cli.main(["compile", str(scene), "-W", "40", "-H", "30", "-o", str(out), "-q"]) == 0
    from lang import serialize

    right = serialize.loads(out.read_text()).camera.right
    assert right[0] == pytest.approx(40 / 30)


def test_formats_agree_png_is_srgb_of_exr_and_16_bit_refines_8(tmp_path):
    import numpy as np

    from runtime.color import srgb_encode
    from runtime.image import read_image

    images = {}
    for name, extra in (("a.png", []), ("a.exr", []), ("b.png", ["--bits", "16"])):
        argv = ["render", str(EX3), "-W", "48", "-H", "36", "-o", str(tmp_path / name), "-q"]
        assert cli.main(argv + extra) == 0
        images[name] = read_image(tmp_path / name).astype(np.float64)
    encoded = np.clip(srgb_encode(images["a.exr"]), 0, 1)
    assert np.abs(encoded - images["a.png"]).max() <= 0.5 / 255 + 1e-3
    assert np.abs(images["b.png"] - images["a.png"]).max() <= 0.5 / 255 + 1e-4


def test_animation_frames_see_the_clock(tmp_path):
    from runtime.image import read_image

    scene = tmp_path / "anim.pov"
    scene.write_text(
        "camera { location <0, 0, -5> look_at 0 }\n"
        "light_source { <0, 5, -5> rgb 1 }\n"
        "sphere { <-1.5 + 3*clock, 0, 0>, 0.5 pigment { rgb 1 } }\n"
    )
    assert cli.main(["render", str(scene), "+W24", "+H18", "+KFI1", "+KFF3", "-q"]) == 0
    frames = [read_image(tmp_path / f"anim{i}.png") for i in (1, 2, 3)]
    # the bright sphere moves from left to right: its centre of mass follows the clock
    xs = [float((f.sum(axis=(0, 2)) * range(24)).sum() / f.sum()) for f in frames]
    assert xs[0] < xs[1] < xs[2]


def test_image_to_standard_output(tmp_path):
    proc = subprocess.run(
        [sys.executable, "-m", "runtime.cli", "render", str(EX3), "+W16", "+H12", "+O-"],
        cwd=ROOT,
        stdin=subprocess.DEVNULL,
        capture_output=True,
        timeout=300,
    )
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout.startswith(b"\x89PNG\r\n\x1a\n")
    assert b"wrote standard output" in proc.stderr
    (tmp_path / "o.png").write_bytes(proc.stdout)
    from runtime.image import read_image

    assert read_image(tmp_path / "o.png").shape == (12, 16, 3)
    assert not (EXAMPLES / "-.png").exists()


def test_runtime_prints_never_mix_into_an_image_on_stdout(monkeypatch, capsysbinary):
    import numpy as np

    import runtime.render

    def chatty_render(scene, width, height, **kw):
        print("strala: warning: something the runtime says")  # as runtime modules do
        return np.zeros((height, width, 3), dtype=np.float32)

    monkeypatch.setattr(runtime.render, "render_scene", chatty_render)
    assert cli.main(["render", str(EX3), "-W", "8", "-H", "6", "-o", "-", "-q"]) == 0
    out, err = capsysbinary.readouterr()
    assert out.startswith(b"\x89PNG\r\n\x1a\n")
    assert b"something the runtime says" in err


RADIOSITY_SCENE = """#version 3.7;
global_settings { assumed_gamma 1 radiosity { count 20 } }
camera { location <0, 1, -5> look_at <0, 0.5, 0> }
light_source { <2, 5, -3> rgb 1 }
box { <-1, 0, -1>, <1, 1, 1> pigment { rgb <1, 0.2, 0.2> } }
plane { y, 0 pigment { rgb 1 } }
"""


def test_radiosity_cache_is_reused(tmp_path):
    from runtime.image import read_image

    scene = tmp_path / "rad.pov"
    scene.write_text(RADIOSITY_SCENE)
    cache = tmp_path / "cache"
    for name in ("a.png", "b.png"):
        argv = ["render", str(scene), "-W", "32", "-H", "24", "-o", str(tmp_path / name), "-q"]
        assert cli.main([*argv, "--radiosity-cache", str(cache)]) == 0
        if name == "a.png":
            first = {p: p.stat().st_mtime_ns for p in cache.iterdir()}
            assert first  # the solution was stored
    assert {p: p.stat().st_mtime_ns for p in cache.iterdir()} == first  # and reused, not redone
    assert (read_image(tmp_path / "a.png") == read_image(tmp_path / "b.png")).all()
    not_a_folder = tmp_path / "file"
    not_a_folder.write_text("")
    argv = ["render", str(scene), "-W", "8", "-H", "6", "-o", str(tmp_path / "c.png"), "-q"]
    assert cli.main([*argv, "--radiosity-cache", str(not_a_folder)]) == 2


def test_partial_render_leaves_the_rest_black(tmp_path):
    from runtime.image import read_image

    out = tmp_path / "part.png"
    argv = ["render", str(EX3), "+W40", "+H30", "+SC0.5", "+SR11", f"+O{out}", "-q"]
    assert cli.main(argv) == 0
    img = read_image(out)
    assert img.shape == (30, 40, 3)
    assert img[:10].max() == 0 and img[:, :20].max() == 0
    assert img[10:, 20:].max() > 0


def test_interrupted_render_stops_at_once_and_leaves_no_file(tmp_path):
    import os
    import signal
    import time

    out = tmp_path / "big.png"
    cmd = [sys.executable, "-m", "runtime.cli", "render", str(EX3), "-W", "3000", "-H", "3000"]
    # Threshold 0 supersamples every pixel (37 rays each): minutes of work, even compiled.
    proc = subprocess.Popen(
        [*cmd, "--aa", "0", "--aa-depth", "6", "-o", str(out)],
        cwd=ROOT,
        stdin=subprocess.DEVNULL,
        stderr=subprocess.PIPE,
        text=True,
        # a child of a non-interactive shell may inherit SIGINT ignored: restore ^C
        preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL),
    )
    time.sleep(3.0)  # past start-up, into the render
    sent = time.monotonic()
    os.kill(proc.pid, signal.SIGINT)
    err = proc.communicate(timeout=60)[1]
    assert proc.returncode == 130, err
    assert time.monotonic() - sent < 3.0  # not after the queued tiles have all been traced
    assert "interrupted" in err and "Traceback" not in err
    assert list(tmp_path.iterdir()) == []


def test_interrupting_a_preview_leaves_the_earlier_image_as_it_was(tmp_path):
    import signal
    import time

    out = tmp_path / "ex3.png"
    assert run_cli("render", str(EX3), "-W", "32", "-H", "24", "-o", str(out)).returncode == 0
    earlier = out.read_bytes()
    preview = cli.preview_path(out)
    proc = subprocess.Popen(
        [sys.executable, "-m", "runtime.cli", "render", str(EX3), "-W", "3000", "-H", "3000",
         "--aa", "0", "--aa-depth", "6", "--preview", "-o", str(out)],
        cwd=ROOT, stdin=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True,
        preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL),
    )  # fmt: skip
    deadline = time.monotonic() + 60
    while not preview.exists() and time.monotonic() < deadline and proc.poll() is None:
        time.sleep(0.05)
    assert preview.exists(), "no preview pass was written"
    time.sleep(0.5)
    os.kill(proc.pid, signal.SIGINT)
    err = proc.communicate(timeout=60)[1]
    assert proc.returncode == 130, err
    assert out.read_bytes() == earlier  # the finished image, untouched
    assert sorted(p.name for p in tmp_path.iterdir()) == ["ex3.png"]  # no preview left


def test_render_from_compiled_ir_matches_render_from_source(tmp_path):
    from runtime.image import read_image

    ir_doc = tmp_path / "ex3.json"
    assert cli.main(["compile", str(EX3), "-o", str(ir_doc), "-q"]) == 0
    a, b = tmp_path / "a.png", tmp_path / "b.png"
    assert cli.main(["render", str(EX3), "-W", "32", "-H", "24", "-o", str(a), "-q"]) == 0
    assert cli.main(["render", str(ir_doc), "-W", "32", "-H", "24", "-o", str(b), "-q"]) == 0
    assert (read_image(a) == read_image(b)).all()


def test_preview_writes_coarse_passes_then_the_same_final_image(tmp_path):
    import OpenImageIO as oiio

    scene = EXAMPLES / "ex3.scene"
    a, b = tmp_path / "a.png", tmp_path / "b.png"
    r = run_cli("render", str(scene), "-W", "128", "-H", "96", "--preview", "-o", str(a))
    assert r.returncode == 0, r.stderr
    passes = [line for line in r.stderr.splitlines() if line.startswith("preview")]
    assert all(str(cli.preview_path(a)) in p for p in passes) and passes
    assert not cli.preview_path(a).exists()  # gone once the final image is written
    # 1/8 would be 16x12, under the 16-pixel minimum: two passes
    assert [p.split()[1] for p in passes] == ["32x24", "64x48"]
    assert (
        run_cli("render", str(scene), "-W", "128", "-H", "96", "-o", str(b), "-q").returncode == 0
    )
    pa = oiio.ImageBuf(str(a)).get_pixels(oiio.FLOAT)
    pb = oiio.ImageBuf(str(b)).get_pixels(oiio.FLOAT)
    assert (pa == pb).all()  # the final pass replaces the previews entirely


def test_stats_say_how_the_image_was_traced(tmp_path, capsys):
    from runtime import cli

    out = tmp_path / "a.png"
    assert cli.main(["render", str(EXAMPLES / "ex3.scene"), "-W", "16", "-H", "12",
                     "--aa", "-o", str(out), "--stats", "-q"]) == 0  # fmt: skip
    line = capsys.readouterr().err.strip().splitlines()[-1]
    assert line.startswith("traced by the compiled kernel: ")
    rays = int(line.split(": ")[1].split(" rays")[0].replace(",", ""))
    assert rays >= 16 * 12  # a camera ray a pixel at least
    scene = tmp_path / "soft.scene"
    scene.write_text(
        "camera { location -5*z look_at 0 } isosurface { function { x*x + y*y + z*z - 1 }"
        " pigment { rgb 1 } }\n"
        "light_source { <2, 4, -3>, rgb 1 }\n"
    )
    assert cli.main(["render", str(scene), "-W", "8", "-H", "6", "-o", str(out),
                     "--stats", "-q"]) == 0  # fmt: skip
    assert "traced by numpy (shape isosurface)" in capsys.readouterr().err
    # spheres under an opaque floor are left out, and the stats say how many
    scene.write_text(
        "camera { location <0, 1, -5> look_at 0 } light_source { <2, 4, -3>, rgb 1 }\n"
        "plane { y, -1 pigment { rgb 1 } } sphere { 0, 1 pigment { rgb 1 } }\n"
        + "".join(f"sphere {{ <{k}, -9, 0>, 1 }}\n" for k in range(3))
    )
    assert cli.main(["render", str(scene), "-W", "8", "-H", "6", "-o", str(out),
                     "--stats", "-q"]) == 0  # fmt: skip
    assert ": 3 objects no ray can reach left out; " in capsys.readouterr().err


def test_the_library_path_from_the_environment_is_searched(tmp_path, monkeypatch):
    # README: STRALA_LIBRARY_PATH adds include folders, for the command line as for the API;
    # -L folders come first.
    first, second = tmp_path / "a", tmp_path / "b"
    for folder, colour in ((first, "<1, 0, 0>"), (second, "<0, 0, 1>")):
        folder.mkdir()
        (folder / "mine.inc").write_text(f"#declare Col = rgb {colour};\n")
    scene = tmp_path / "s.pov"
    scene.write_text('#include "mine.inc"\nsphere { 0, 1 pigment { Col } }\n')
    monkeypatch.setenv("STRALA_LIBRARY_PATH", str(second))
    done = run_cli("check", str(scene))
    assert done.returncode == 0, done.stdout + done.stderr
    out = tmp_path / "s.json"

    def colour(*extra: str) -> list[float]:
        done = run_cli("compile", str(scene), *extra, "-o", str(out))
        assert done.returncode == 0, done.stderr
        return json.loads(out.read_text())["scene"]["objects"][0]["texture"]["pigment"]["color"]

    assert colour()[:3] == [0.0, 0.0, 1.0]
    assert colour("-L", str(first))[:3] == [1.0, 0.0, 0.0]


def test_the_command_exits_without_teardown_but_not_under_a_profiler(tmp_path):
    # run() skips Python's teardown (atexit handlers, freeing every object) once the command
    # is done, with main()'s exit code and all output flushed; under a profiler it exits
    # normally so that the profile is written.
    scene = tmp_path / "bad.pov"
    scene.write_text("sphere { 0, }\n")
    script = (
        "import atexit, sys\n"
        "from runtime import cli\n"
        "atexit.register(lambda: print('teardown ran'))\n"
        "if sys.argv[1] == 'profiled':\n"
        "    sys.setprofile(lambda *a: None)\n"
        f"sys.argv = ['strala', 'check', {str(scene)!r}]\n"
        "cli.run()\n"
    )
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    for mode, teardown in (("plain", False), ("profiled", True)):
        done = subprocess.run([sys.executable, "-c", script, mode], capture_output=True,
                              text=True, env=env, cwd=tmp_path)  # fmt: skip
        assert done.returncode == 1, done.stderr  # check's code for an error
        assert "bad.pov:1:" in done.stdout + done.stderr  # the diagnostic got out
        assert ("teardown ran" in done.stdout) is teardown


def test_commands_lists_every_subcommand(capsys):
    """cli.COMMANDS names exactly the parser's subcommands (argparse lists them when it
    refuses an unknown one)."""
    with pytest.raises(SystemExit):
        cli.build_parser().parse_args(["no-such-command"])
    err = capsys.readouterr().err
    listed = err.split("choose from", 1)[1]
    names = re.findall(r"'([^']+)'", listed)
    assert sorted(names) == sorted(cli.COMMANDS)


def test_an_image_too_large_for_the_machine_is_refused_before_any_work(tmp_path):
    scene = tmp_path / "s.pov"
    scene.write_text("camera { location -5*z look_at 0 } sphere { 0, 1 pigment { rgb 1 } }\n")
    out = tmp_path / "big.png"
    for w, h in (("2000000", "2000000"), ("2147483648", "10")):
        done = run_cli("render", str(scene), "-W", w, "-H", h, "-o", str(out))
        assert done.returncode == 2, done.stderr
        assert f"an image of {w}×{h} needs about" in done.stderr and "GiB" in done.stderr
        assert "internal error" not in done.stderr
    assert not list(tmp_path.glob("*.png")) and not list(tmp_path.glob(".*"))


def test_anti_aliasing_methods_jitter_and_gamma_switches():
    assert _translate("+AM2", "+A0.2", "+R4", "-J", "+AG1.8")[0] == [
        "--aa-method", "2", "--aa", "0.2", "--aa-depth", "4", "--jitter", "0",
        "--aa-gamma", "1.8",
    ]  # fmt: skip
    assert _translate("Sampling_Method=2", "Jitter_Amount=0.5")[0] == [
        "--aa-method", "2", "--jitter", "0.5",
    ]  # fmt: skip
    assert _translate("Jitter=off", "Jitter_Amount=0.5")[0] == ["--jitter", "0"]
    out, warnings = _translate("Antialias_Confidence=0.9", "+AC0.9")
    assert out == [] and len(warnings) == 1 and "method 3" in warnings[0]  # one a key


def test_method_3_renders_as_method_2_with_a_warning(tmp_path):
    scene = tmp_path / "s.pov"
    scene.write_text("sphere { 0, 1 pigment { rgb 1 } }\n")
    r = run_cli("render", str(scene), "+A", "+AM3", "-W8", "-H8", "-o", str(tmp_path / "a.png"))
    assert r.returncode == 0, r.stderr
    assert "method 3 is POV-Ray 3.8's: rendering with method 2" in r.stderr


def test_animation_switches_and_settings():
    out, warnings = _translate("+KFI1", "+KFF4", "+KC", "+KI2", "+KF3", "+SF0.5", "+EF3")
    assert out == ["--frames", "1..4", "--initial-clock", "2", "--final-clock", "3",
                   "--subset-start", "0.5", "--subset-end", "3", "--cyclic"]  # fmt: skip
    assert warnings == []
    assert _translate("Cyclic_Animation=on", "Frame_Step=2")[0] == ["--frame-step", "2", "--cyclic"]


_TAKES_A_NAME = {"input_file_name", "output_file_name", "library_path", "declare"}


_VALUED = [s for s in povray_options.SWITCHES if s[1] not in _TAKES_A_NAME]


@pytest.mark.parametrize("switch", _VALUED)
@pytest.mark.parametrize("sign", ["+", "-"])
def test_every_povray_switch_is_done_or_warned_never_a_usage_error(switch, sign):
    name, value_key, _ = switch
    tok = sign + name + ("1" if value_key else "")
    out, warnings = _translate(tok, "s.pov")
    cli.build_parser().parse_args(["render", *out])  # raises SystemExit on a usage error
    assert len(warnings) <= 1 and all(w.count(tok) == 1 for w in warnings)


@pytest.mark.parametrize("key", sorted(povray_options.KNOWN - _TAKES_A_NAME))
def test_every_povray_ini_key_is_done_or_warned_never_a_usage_error(key):
    out, warnings = _translate(f"{key.title()}=1", f"{key}=1", "s.pov")
    cli.build_parser().parse_args(["render", *out])
    assert len(warnings) <= 1  # the same key twice: one warning


def test_an_unknown_option_is_told_with_the_commands_usage(tmp_path):
    r = run_cli("render", "x.scene", "--bogus")
    assert r.returncode == 2
    assert r.stderr.startswith("usage: strala render ")
    assert "strala render: error: unrecognized arguments: --bogus" in r.stderr
    r = run_cli("check", "x.scene", "+ZZ9", "Foo_Bar=3", "-UV", cwd=tmp_path)
    assert r.returncode == 1  # x.scene is missing; the options only warn
    assert "ignoring +ZZ9: not a POV-Ray 3.7 option" in r.stderr
    assert "ignoring Foo_Bar=3: not a POV-Ray 3.7 option" in r.stderr
    assert "ignoring POV-Ray option -UV" in r.stderr


def test_render_leaves_advice_to_check_and_quiet_leaves_only_errors(tmp_path):
    scene = tmp_path / "s.pov"
    scene.write_text(
        '#declare Unused = 1;\n#debug "hello\\n"\n#warning "careful"\n'
        "camera { location -3*z look_at 0 }\nsphere { 0, 1 pigment { rgb 1 } }\n"
    )
    out = str(tmp_path / "s.png")
    r = run_cli("render", str(scene), "-W", "8", "-H", "8", "-o", out)
    assert r.returncode == 0, r.stderr
    assert "never used" not in r.stderr and "careful" in r.stderr
    assert r.stderr.count("hello") == 1  # the #debug text, not again as a note
    quiet = run_cli("render", str(scene), "-W", "8", "-H", "8", "-o", out, "-q", "+Q9")
    assert quiet.returncode == 0 and quiet.stderr == ""
    assert "`Unused` is declared but never used" in run_cli("check", str(scene)).stdout
