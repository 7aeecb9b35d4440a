"""The bundled include files (stdlib/*.inc): they parse and evaluate cleanly, and they give
every name POV-Ray 3.7's own include files give, with the same values.

Oracles (each skipped where POV-Ray or its include files are not installed):
- POV-Ray's include files, evaluated *by strala*: every colour, finish, texture, number …
  they declare must exist in strala's file of the same name with an equal value (1e-9).
  Both sides go through the same evaluator, so this checks the stdlib's data even where
  the evaluator itself might be wrong about POV-Ray.
- POV-Ray itself (`povray`) running strala's files in place of its own: the macros give
  the same numbers, and a gallery of every finish, texture, pigment, material and interior
  renders to the very same pixels. These hold independently of strala's evaluator.
- POV-Ray against strala, for the macros: colour-space conversions, vector maths and
  transform builders evaluated by POV-Ray (with its own includes) and by strala (with the
  stdlib) on the same inputs must agree.
"""

from __future__ import annotations

import dataclasses
import math
import random
import re
import shutil
import subprocess
from pathlib import Path
from typing import Any

import pytest
from conftest import ROOT
from hypothesis import given
from hypothesis import strategies as st

from lang import ir, values
from lang.diagnostics import Severity
from lang.parser import parse

STDLIB = ROOT / "stdlib"
POV_INCLUDE = Path("/usr/share/povray-3.7/include")
STDLIB_FILES = sorted(p.name for p in STDLIB.glob("*.inc"))
TOL = 1e-9

needs_pov_includes = pytest.mark.skipif(
    not (POV_INCLUDE / "colors.inc").exists(), reason="POV-Ray's include files are not installed"
)


# ----------------------------------------------------------------------------- helpers
def compile_file(path: Path, library_paths: tuple[str, ...] = (), **options):
    from lang.evaluate import compile_file as _compile

    return _compile(str(path), library_paths=library_paths, **options)


def errors(result) -> list:
    return [d for d in result.diagnostics if d.severity is Severity.ERROR]


def compile_text(tmp_path: Path, text: str, name: str = "probe.pov"):
    """Evaluate a scene written to tmp_path (so `#include` finds the bundled stdlib)."""
    path = tmp_path / name
    path.write_text(text)
    return compile_file(path)


def is_code(value: Any) -> bool:
    """Macros and functions are code, not data: the oracle compares data only."""
    return isinstance(value, values.MacroValue | values.FunctionValue)


def differences(a: Any, b: Any, where: str = "") -> list[str]:
    """Where two evaluated values differ (floats to TOL; spans and file names ignored)."""
    if isinstance(a, bool | int | float) and isinstance(b, bool | int | float):
        return [] if abs(float(a) - float(b)) <= TOL else [f"{where}: {a!r} != {b!r}"]
    if isinstance(a, values.ColorValue) and isinstance(b, values.ColorValue):
        return differences(a.rgbft, b.rgbft, where + ".rgbft")
    if type(a) is not type(b):
        return [f"{where}: {type(a).__name__} != {type(b).__name__} ({a!r} vs {b!r})"]
    if dataclasses.is_dataclass(a):
        out: list[str] = []
        for f in dataclasses.fields(a):
            if f.name in ("span", "file", "keyword_span"):
                continue
            out += differences(getattr(a, f.name), getattr(b, f.name), f"{where}.{f.name}")
        return out
    if isinstance(a, dict):
        if set(a) != set(b):
            return [f"{where}: keys {sorted(a)} != {sorted(b)}"]
        return [d for k in a for d in differences(a[k], b[k], f"{where}[{k!r}]")]
    if isinstance(a, tuple | list):
        if len(a) != len(b):
            return [f"{where}: length {len(a)} != {len(b)} ({a!r} vs {b!r})"]
        return [
            d
            for i, (x, y) in enumerate(zip(a, b, strict=True))
            for d in differences(x, y, f"{where}[{i}]")
        ]
    return [] if a == b else [f"{where}: {a!r} != {b!r}"]


# ------------------------------------------------------------------ parse and evaluate
def test_stdlib_has_the_promised_files():
    for name in (
        "colors.inc",
        "finish.inc",
        "metals.inc",
        "golds.inc",
        "textures.inc",
        "math.inc",
        "transforms.inc",
        "consts.inc",
        "glass.inc",
        "shapes.inc",
        "shapes_old.inc",
        "shapes2.inc",
        "skies.inc",
        "functions.inc",
        "stdcam.inc",
        "stdinc.inc",
        "strings.inc",
        "rand.inc",
        "arrays.inc",
        "debug.inc",
        "screen.inc",
        "rad_def.inc",
        "shapesq.inc",
        "logo.inc",
        "glass_old.inc",
        "stars.inc",
        "sunpos.inc",
        "ior.inc",
        "stage1.inc",
        "shapes3.inc",
        "woods.inc",
        "woodmaps.inc",
        "stones.inc",
        "stones1.inc",
        "stones2.inc",
        "stoneold.inc",
        "chars.inc",
        "makegrass.inc",
        "meshmaker.inc",
    ):
        assert (STDLIB / name).is_file(), name
    assert (STDLIB / "README.md").is_file()


@pytest.mark.parametrize("name", STDLIB_FILES)
def test_stdlib_file_parses_without_diagnostics(name):
    tree, diagnostics = parse((STDLIB / name).read_text(), name)
    assert diagnostics == []
    assert tree.body, "an include file with nothing in it"


@pytest.mark.parametrize("name", STDLIB_FILES)
def test_stdlib_file_has_its_own_include_guard(name):
    # Guards keep a second #include from resetting names the scene has changed since.
    text = (STDLIB / name).read_text()
    guard = re.search(r"#ifndef\s*\(\s*(Strala_\w+_Inc)\s*\)\s*#declare\s+\1\s*=", text)
    assert guard, f"{name} has no Strala_*_Inc guard at its top"
    assert text.rstrip().endswith(f"#end // {guard.group(1)}")


@pytest.mark.parametrize("name", STDLIB_FILES)
def test_stdlib_file_evaluates_without_errors(name):
    result = compile_file(STDLIB / name)
    assert errors(result) == []
    assert len(result.symbols) > 1


def test_scene_including_everything_evaluates(tmp_path):
    includes = "".join(f'#include "{n}"\n' for n in STDLIB_FILES)
    result = compile_text(tmp_path, includes + "sphere { 0, 1 texture { T_Gold_1A } }\n")
    assert errors(result) == []
    for name in (
        "Red",
        "BrightGold",
        "Shiny",
        "T_Chrome_4D",
        "Jade",
        "Col_Glass_Ruby",
        "Diamond_Ior",
        "sind",
        "Reorient_Trans",
    ):
        assert name in result.symbols, name


def test_include_guard_keeps_later_changes(tmp_path):
    result = compile_text(
        tmp_path,
        '#include "colors.inc"\n#declare Red = rgb <0.5, 0, 0>;\n#include "colors.inc"\n',
    )
    assert errors(result) == []
    assert result.symbols["Red"].rgbft == (0.5, 0.0, 0.0, 0.0, 0.0)


def test_metals_leave_their_own_finishes_over_the_gold_ones(tmp_path):
    # metals.inc includes golds.inc and then redefines F_MetalA..E; T_Gold_* keep gold.
    result = compile_text(tmp_path, '#include "metals.inc"\n')
    assert errors(result) == []
    sym = result.symbols
    assert sym["F_MetalA"].diffuse == pytest.approx(0.3)
    assert sym["T_Gold_1A"].finish.specular == pytest.approx(0.2)
    assert sym["T_Gold_1A"].finish.diffuse != pytest.approx(0.3)


# ------------------------------------------------ oracle 1: POV-Ray's include files as data
# POV-Ray's include-guard values (they hold `version`, what the file restores at its end):
# strala's files declare them too, but their value is the including scene's, not data.
def _guard_name(name: str) -> bool:
    return name.lower().endswith("_inc_temp")


# Names that only a parse artefact of POV-Ray's include files would declare (none left since
# `#declare deprecated once "…" T_Glass1 = …` of glass_old.inc parses).
_PARSE_ARTEFACTS: set[str] = set()
# POV-Ray's shapes2.inc builds HalfCone_Y from shapes.inc's Cone_Y without including it, and
# its shapesq.inc clips Helix with Cylinder_Z the same way, so evaluated alone they are
# incomplete (the POV-Ray shape galleries below cover them).
_NEEDS_ANOTHER_FILE = {"HalfCone_Y", "Helix", "Helix_1"}
# Scratch values POV-Ray's files keep with #local at their top level (compiled as the main
# file, they show among its names).
_FILE_LOCALS = {"iorData"}


def _oracle_pairs():
    # (strala file, POV-Ray file, what must be carried over, how many values POV-Ray's
    # file gives at least: fewer means strala failed to evaluate it, proving nothing)
    return [
        ("colors.inc", "colors.inc", "colours", 130),
        ("finish.inc", "finish.inc", "all", 8),
        ("golds.inc", "golds.inc", "all", 80),
        ("metals.inc", "metals.inc", "all", 200),
        ("textures.inc", "textures.inc", "all", 125),
        ("glass.inc", "glass.inc", "all", 180),
        ("consts.inc", "consts.inc", "all", 60),
        ("shapes_old.inc", "shapes_old.inc", "all", 24),
        ("shapes2.inc", "shapes2.inc", "all", 11),
        ("glass_old.inc", "glass_old.inc", "all", 18),
        ("ior.inc", "ior.inc", "all", 150),
        ("stars.inc", "stars.inc", "all", 6),
        ("shapesq.inc", "shapesq.inc", "all", 19),
        ("rad_def.inc", "rad_def.inc", "all", 11),
        ("logo.inc", "logo.inc", "all", 3),
        ("woodmaps.inc", "woodmaps.inc", "all", 38),
        ("woods.inc", "woods.inc", "all", 112),  # with woodmaps.inc's maps
        ("stones1.inc", "stones1.inc", "all", 87),
        ("stones2.inc", "stones2.inc", "all", 20),
        ("stones.inc", "stones.inc", "all", 107),
        ("stoneold.inc", "stoneold.inc", "all", 148),
        ("chars.inc", "chars.inc", "all", 50),
    ]


# POV-Ray's stone files take colours from colors.inc by name (a scene includes it first),
# and stones.inc and stoneold.inc include stones1.inc: they are read from a copy of the
# four files, so POV-Ray's stones1.inc is the one included, not strala's (which the
# stdlib-first search would find from POV-Ray's own folder).
_READ_AFTER_COLORS = ("stones.inc", "stones1.inc", "stones2.inc", "stoneold.inc")


@pytest.fixture(scope="module")
def evaluated(tmp_path_factory):
    """Each file of the oracle pairs evaluated once, strala's and POV-Ray's. The names of
    a file read after colors.inc are those colors.inc does not give."""
    cache: dict[Path, Any] = {}
    copies = tmp_path_factory.mktemp("povray_stones")

    def get(path: Path):
        if path in cache:
            return cache[path]
        if path.parent != POV_INCLUDE or path.name not in _READ_AFTER_COLORS:
            cache[path] = compile_file(path)
            return cache[path]
        for name in _READ_AFTER_COLORS:
            shutil.copy(POV_INCLUDE / name, copies / name)
        scene = copies / f"after_colors_{path.stem}.pov"
        scene.write_text(f'#include "colors.inc"\n#include "{path.name}"\n')
        result = compile_file(scene)
        colours = evaluated_colours(copies).symbols
        for name in colours:
            result.symbols.pop(name, None)
        cache[path] = result
        return result

    return get


def evaluated_colours(folder: Path):
    """colors.inc alone, as the scenes above read it."""
    scene = folder / "colors_only.pov"
    scene.write_text('#include "colors.inc"\n')
    return compile_file(scene)


@needs_pov_includes
@pytest.mark.parametrize(("ours", "theirs", "scope", "at_least"), _oracle_pairs())
def test_stdlib_matches_povray_include(evaluated, ours, theirs, scope, at_least):
    pov = evaluated(POV_INCLUDE / theirs).symbols
    mine = evaluated(STDLIB / ours).symbols
    names = [
        n
        for n, v in pov.items()
        if not _guard_name(n)
        and n not in _PARSE_ARTEFACTS | _NEEDS_ANOTHER_FILE | _FILE_LOCALS
        and not is_code(v)
        and (scope == "all" or isinstance(v, values.ColorValue))
    ]
    assert len(names) >= at_least, f"only {len(names)} values from POV-Ray's {theirs}"
    missing = [n for n in names if n not in mine]
    assert missing == [], f"{ours} lacks {missing}"
    wrong = [d for n in names for d in differences(pov[n], mine[n], n)]
    assert wrong == []


@needs_pov_includes
def test_every_povray_colour_is_in_colors_inc(evaluated):
    pov = evaluated(POV_INCLUDE / "colors.inc").symbols
    mine = evaluated(STDLIB / "colors.inc").symbols
    colours = {n for n, v in pov.items() if isinstance(v, values.ColorValue)}
    assert len(colours) >= 130  # POV-Ray 3.7's colors.inc declares 130 colours
    for name in (
        "Red",
        "White",
        "BrightGold",
        "Scarlet",
        "MediumSpringGreen",
        "Gray05",
        "Gray95",
        "Clear",
        "Mica",
    ):
        assert name in colours
    assert sorted(colours - set(mine)) == []
    assert mine["Clear"].rgbft == (1.0, 1.0, 1.0, 1.0, 0.0)
    assert mine["MediumSlateBlue"].rgbft == pytest.approx((0.498039, 0.0, 1.0, 0.0, 0.0))


@needs_pov_includes
@pytest.mark.parametrize("name", ["finish.inc", "metals.inc"])
def test_every_povray_finish_is_equal(evaluated, name):
    pov = evaluated(POV_INCLUDE / name).symbols
    mine = evaluated(STDLIB / name).symbols
    finishes = [n for n, v in pov.items() if isinstance(v, ir.Finish)]
    assert len(finishes) >= 5
    for n in finishes:
        assert isinstance(mine.get(n), ir.Finish), n
        assert differences(pov[n], mine[n], n) == []


# ------------------------------------------------------ oracle 2: POV-Ray runs the macros
# A probe is (kind, expression); the same text is evaluated by POV-Ray with its includes and
# by strala with the stdlib. Kinds: "f" float, "v" 3-vector, "c" 5-vector (colour-like),
# "t" a transform (compared by where it sends the origin and the three unit points).
_rng = random.Random(20261122)


def _r(lo: float = -3.0, hi: float = 3.0) -> float:
    return round(_rng.uniform(lo, hi), 4)


def _vec() -> str:
    return f"<{_r()}, {_r()}, {_r()}>"


def _colour() -> str:
    return f"rgbft <{_r(0, 1)}, {_r(0, 1)}, {_r(0, 1)}, {_r(0, 1)}, {_r(0, 1)}>"


def _probes() -> list[tuple[str, str]]:
    p: list[tuple[str, str]] = []
    # colors.inc: hues round the wheel (and beyond it), and colours with ties and greys
    for h in (-400, -30, 0, 45, 60, 119.5, 120, 200, 240, 300, 359.9, 360, 725):
        p.append(("v", f"CH2RGB({h})"))
    colours = [
        "rgbft <1, 0, 0, 0, 0>",
        "rgbft <0.2, 0.2, 0.2, 0.1, 0.3>",
        "rgbft <1, 1, 0, 0, 0>",
        "rgbft <0.3, 0.6, 0.6, 0, 0>",
        "rgbft <0.9, 0.1, 0.5, 0, 0>",
        "rgbft <0, 0, 0, 0, 0>",
        "rgbft <1, 1, 1, 0, 0>",
        *(_colour() for _ in range(6)),
    ]
    for c in colours:
        p += [("c", f"CRGB2HSV({c})"), ("c", f"CRGB2HSL({c})")]
    for _ in range(6):
        hsx = f"<{_r(-90, 450)}, {_r(0, 1)}, {_r(0, 1)}, {_r(0, 1)}, {_r(0, 1)}>"
        p += [("c", f"CHSV2RGB({hsx})"), ("c", f"CHSL2RGB({hsx})")]
    # math.inc
    p += [
        ("f", "sind(30)"),
        ("f", "cosd(-45)"),
        ("f", "tand(10)"),
        ("f", "asind(0.5)"),
        ("f", "acosd(-0.2)"),
        ("f", "atand(3)"),
        ("f", "atan2d(1, -2)"),
        ("f", "max3(1, 7, 3)"),
        ("f", "min3(4, -2, 9)"),
        ("f", "f_sqr(-3)"),
        ("f", "sgn(-0.1)"),
        ("f", "sgn(0)"),
        ("f", "even(4)"),
        ("f", "even(3)"),
        ("f", "odd(5)"),
        ("f", "odd(-2)"),
        ("f", "clip(7, 0, 5)"),
        ("f", "clip(-7, 0, 5)"),
        ("f", "clamp(7.5, 2, 5)"),
        ("f", "clamp(-1, 0, 3)"),
        ("f", "adj_range(0.25, 2, 6)"),
        ("f", "adj_range2(3, 2, 6, 10, 20)"),
    ]
    for method in (0, 1, 2.5):
        p.append(("f", f"Interpolate(0.3, 0, 2, 10, 20, {method})"))
    p += [("v", "Interpolate(0.5, 0, 1, <0, 0, 0>, <2, 4, 6>, 0)")]
    vecs = [
        "<1, 1, 1>",
        "<0, 0, 1>",
        "<2, 0, 0>",
        "<0, -3, 0>",
        "<1, 2, 2>",
        "<0, 0, 0>",
        *(_vec() for _ in range(5)),
    ]
    for v in vecs:
        p += [
            ("v", f"VPerp_To_Vector({v})"),
            ("v", f"VSqr({v})"),
            ("f", f"VMin({v})"),
            ("f", f"VMax({v})"),
            ("f", f"VZero({v})"),
        ]
    for _ in range(6):
        a, b, ax = _vec(), _vec(), _vec()
        p += [
            ("f", f"VAngle({a}, {b})"),
            ("f", f"VAngleD({a}, {b})"),
            ("f", f"VCos_Angle({a}, {b})"),
            ("f", f"VRotation({a}, {b}, {ax})"),
            ("f", f"VRotationD({a}, {b}, vcross({a}, {b}))"),
            ("f", f"VDist({a}, {b})"),
            ("v", f"VWith_Len({a}, 2.5)"),
            ("v", f"VPerp_To_Plane({a}, {b})"),
            ("v", f"VPerp_Adjust({a}, {b})"),
            ("v", f"VProject_Plane({a}, {b})"),
            ("v", f"VProject_Axis({a}, {b})"),
            ("f", f"VEq({a}, {a})"),
            ("f", f"VEq({a}, {b})"),
            ("v", f"VPow(<1.5, 2, 0.5>, {_r(0, 3)})"),
        ]
    c1, c2 = _colour(), _colour()
    p += [
        ("f", f"VDot5D({c1}, {c2})"),
        ("f", f"VLength5D({c1})"),
        ("f", f"VEq5D({c1}, {c1})"),
        ("f", f"VZero5D({c1})"),
        ("c", f"VNormalize5D({c1})"),
        ("c", f"VPow5D({c1}, 2)"),
    ]
    p += [
        ("f", "Mean(Probe_Array)"),
        ("f", "Std_Dev(Probe_Array, 2.5)"),
        ("v", "vGradient(Probe_Fn, <1, 2, 3>)"),
        ("f", "Gradient_Length(Probe_Fn, <1, -1, 2>)"),
        ("f", "Gradient_Directional(Probe_Fn, <1, 2, 3>, <1, 1, 0>)"),
        ("f", "Divergence(Probe_Fn, Probe_Fn, Probe_Fn, <0.5, 1, 2>)"),
        ("v", "vCurl(Probe_Fn, Probe_Fn2, Probe_Fn, <0.5, 1, 2>)"),
    ]
    # transforms.inc
    pairs = [
        ("x", "y"),
        ("<1, 2, 3>", "<1, 2, 3>"),
        ("<1, 2, 3>", "<-2, -4, -6>"),
        ("z", "-z"),
        *((_vec(), _vec()) for _ in range(5)),
    ]
    for a, b in pairs:
        p.append(("t", f"Reorient_Trans({a}, {b})"))
    for _ in range(4):
        p += [
            ("t", f"Axis_Rotate_Trans({_vec()}, {_r(-360, 360)})"),
            ("t", f"Rotate_Around_Trans({_vec()}, {_vec()})"),
            ("t", f"Point_At_Trans({_vec()})"),
            ("t", f"Axial_Scale_Trans({_vec()}, {_r(0.2, 4)})"),
            ("t", f"Shear_Trans({_vec()}, {_vec()}, {_vec()})"),
            ("t", f"Matrix_Trans({_vec()}, {_vec()}, {_vec()}, {_vec()})"),
        ]
    p += [
        ("t", "Point_At_Trans(y)"),
        ("t", "Point_At_Trans(<0, 0, 2>)"),
        ("t", "Center_Trans(Probe_Box, x + z)"),
        ("t", "Center_Trans(Probe_Box, <1, 1, 1>)"),
        ("t", "Align_Trans(Probe_Box, -y, <1, 2, 3>)"),
        ("t", "Align_Trans(Probe_Box, <1, 0, -1>, 4)"),
        ("t", "Align_Trans(Probe_Box, x + y + z, <-1, -2, -3>)"),
    ]
    return p


PROBES = _probes()
_PRELUDE = """\
#include "colors.inc"
#include "math.inc"
#include "transforms.inc"
#declare Probe_Array = array[5] {1, 2, 3.5, 10, -4}
#declare Probe_Fn = function (x, y, z) { x*x + y*z - 3*z }
#declare Probe_Fn2 = function (x, y, z) { sin(x)*y + z*z }
#declare Probe_Box = box { <-1, 0, 2>, <3, 4, 5> scale <2, 0.5, 1> translate <0.25, -1, 3> }
"""
_UNIT_POINTS = ("<0, 0, 0>", "x", "y", "z")


def _probe_declarations() -> str:
    lines = [_PRELUDE]
    for i, (kind, expr) in enumerate(PROBES):
        if kind == "t":
            lines.append(f"#declare Probe_{i} = transform {{ {expr} }}")
        else:
            lines.append(f"#declare Probe_{i} = {expr};")
    return "\n".join(lines) + "\n"


def _pov_scene() -> str:
    # Results go to a file: POV-Ray's debug stream wraps and shortens long lines.
    out = ["#version 3.7;", _probe_declarations(), '#fopen Probe_Out "probes.txt" write']
    for i, (kind, _expr) in enumerate(PROBES):
        if kind == "f":
            parts = [f"str(Probe_{i}, 0, 17)"]
        elif kind in ("v", "c"):
            n = 3 if kind == "v" else 5
            parts = [f'vstr({n}, Probe_{i}, ",", 0, 17)']
        else:
            parts = [f'vstr(3, vtransform({p}, Probe_{i}), ",", 0, 17)' for p in _UNIT_POINTS]
        out.append(f'#write (Probe_Out, "@@{i}=", ' + ', ";", '.join(parts) + ', "\\n")')
    out.append("#fclose Probe_Out")
    return "\n".join(out) + "\n"


# strala's transforms.inc has no vtransform (it needs transform-valued functions); when
# POV-Ray runs the probes with strala's files, the probe scene brings its own.
_VTRANSFORM_SHIM = """
#macro vtransform(Probe_V, Probe_T)
   #local Probe_F = function { transform { Probe_T } }
   (Probe_F(Probe_V.x, Probe_V.y, Probe_V.z))
#end
"""


def run_povray(
    folder: Path, scene: str, *, with_stdlib: bool, size=(8, 8), options: tuple[str, ...] = ()
) -> str:
    """Run POV-Ray on `scene` in `folder` (with further command-line `options`). With
    `with_stdlib`, strala's include files are copied beside the scene, where POV-Ray looks
    before its own include folder."""
    for old in folder.glob("*.inc"):
        old.unlink()
    if with_stdlib:
        for inc in STDLIB.glob("*.inc"):
            shutil.copy(inc, folder / inc.name)
    (folder / "scene.pov").write_text(scene)
    size_options = (f"+W{size[0]}", f"+H{size[1]}")
    run = subprocess.run(
        ["povray", "+Iscene.pov", "+Oscene.png", "-D", "-V", *size_options, *options],
        cwd=folder,
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert run.returncode == 0, run.stderr[-3000:]
    return run.stderr


def povray_both_ways(
    folder: Path, scene: str, size, options: tuple[str, ...] = ()
) -> tuple[Any, Any]:
    """POV-Ray's renders of `scene` with its own include files and with strala's, as int
    arrays of the 8-bit PNGs it writes (each in a subfolder of `folder`)."""
    from OpenImageIO import UINT8, ImageBuf

    images = []
    for with_stdlib in (False, True):
        sub = folder / ("stdlib" if with_stdlib else "pov")
        sub.mkdir(parents=True)
        run_povray(sub, scene, with_stdlib=with_stdlib, size=size, options=options)
        images.append(ImageBuf(str(sub / "scene.png")).get_pixels(UINT8).astype(int))
    return images[0], images[1]


def _read_probes(folder: Path) -> dict[int, list[float]]:
    written = (folder / "probes.txt").read_text()
    found = {}
    for m in re.finditer(r"@@(\d+)=([^\n]*)", written):
        found[int(m.group(1))] = [float(v) for v in re.split(r"[,;]", m.group(2))]
    assert len(found) == len(PROBES)
    return found


@pytest.fixture(scope="module")
def povray_results(tmp_path_factory) -> dict[int, list[float]]:
    """The probes as POV-Ray computes them with its own include files."""
    if not shutil.which("povray") or not POV_INCLUDE.exists():
        pytest.skip("POV-Ray is not installed")
    folder = tmp_path_factory.mktemp("pov_probes")
    run_povray(folder, _pov_scene(), with_stdlib=False)
    return _read_probes(folder)


@pytest.mark.povray
@needs_pov_includes
def test_povray_running_the_stdlib_macros_agrees_with_its_own(tmp_path, povray_results):
    # Independent of strala's evaluator: the stdlib macros are valid POV-Ray and, run by
    # POV-Ray, must give what POV-Ray's own macros give.
    scene = _pov_scene().replace("#fopen", _VTRANSFORM_SHIM + "#fopen", 1)
    run_povray(tmp_path, scene, with_stdlib=True)
    ours = _read_probes(tmp_path)
    for index, (_kind, expr) in enumerate(PROBES):
        assert ours[index] == pytest.approx(povray_results[index], rel=1e-9, abs=1e-9), expr


_DECLARE_BLOCK = re.compile(r'#declare\s+(?:deprecated\s+once\s+"[^"]*"\s+)?(\w+)\s*=\s*(\w+)')
_CELL = 24  # pixels per gallery sphere


def _declared_blocks() -> list[tuple[str, str]]:
    """(name, block type) of every texture, finish, pigment, material and interior that
    POV-Ray's finish, golds, metals, glass and textures include files declare."""
    found: dict[str, str] = {}
    for name in ("finish", "golds", "metals", "glass_old", "glass", "textures"):
        text = re.sub(r"//[^\n]*", "", (POV_INCLUDE / f"{name}.inc").read_text())
        for m in _DECLARE_BLOCK.finditer(text):
            if m.group(2) in ("texture", "finish", "pigment", "material", "interior"):
                found.setdefault(m.group(1), m.group(2))
    # EMBWood1's finish has `crand`, random noise that differs from one render to the next.
    found.pop("EMBWood1", None)
    return list(found.items())


def _gallery_scene(blocks: list[tuple[str, str]]) -> str:
    """Every block on its own sphere in a 16-wide grid (row 0 at the top), over a
    checkered wall to reflect and refract."""
    wrap = {
        "texture": "texture {{ {} }}",
        "finish": "pigment {{ rgb <0.7, 0.5, 0.3> }} finish {{ {} }}",
        "pigment": "pigment {{ {} }}",
        "material": "material {{ {} }}",
        "interior": "pigment {{ rgbf <1, 1, 1, 0.9> }} interior {{ {} }}",
    }
    rows = -(-len(blocks) // 16)
    centre = f"<7.5, {-(rows - 1) / 2}, 0>"
    lines = [
        "#version 3.7;",
        "global_settings { assumed_gamma 1.0 }",
        *(f'#include "{n}.inc"' for n in ("finish", "metals", "glass", "textures")),
        f"camera {{ orthographic location {centre} - 20*z look_at {centre} "
        f"right 16*x up {rows}*y }}",
        "light_source { <-20, 30, -40> rgb 1 }",
        "plane { z, 1 pigment { checker rgb 1, rgb <0.2, 0.3, 0.8> scale 0.5 } }",
    ]
    for i, (name, kind) in enumerate(blocks):
        body = wrap[kind].format(name)
        lines.append(f"sphere {{ <{i % 16}, {-(i // 16)}, 0>, 0.45 {body} }}")
    return "\n".join(lines) + "\n"


@pytest.mark.povray
@needs_pov_includes
def test_povray_renders_stdlib_textures_exactly_like_its_own(tmp_path):
    # Independent of strala's evaluator: every finish, texture, pigment, material and
    # interior, rendered by POV-Ray with strala's files, gives the very same pixels.
    blocks = _declared_blocks()
    assert len(blocks) > 250
    size = (16 * _CELL, -(-len(blocks) // 16) * _CELL)
    theirs, ours = povray_both_ways(tmp_path, _gallery_scene(blocks), size)
    changed = abs(theirs - ours).max(axis=2)
    # Name the spheres that differ (reflections spread a difference to the neighbours).
    cells = {(y // _CELL) * 16 + x // _CELL for y, x in zip(*changed.nonzero(), strict=True)}
    assert changed.max() == 0, [blocks[c][0] for c in sorted(cells) if c < len(blocks)][:20]


@pytest.fixture(scope="module")
def strala_results(tmp_path_factory):
    folder = tmp_path_factory.mktemp("strala_probes")
    return compile_text(folder, _probe_declarations(), "probes.scene")


def _as_numbers(kind: str, value: Any) -> list[float]:
    if kind == "t":
        m = value.matrix
        out: list[float] = []
        for p in ((0, 0, 0), (1, 0, 0), (0, 1, 0), (0, 0, 1)):
            out += [sum(m[r][c] * p[c] for c in range(3)) + m[r][3] for r in range(3)]
        return out
    if isinstance(value, values.ColorValue):
        return list(value.rgbft)
    if isinstance(value, tuple):
        return [float(v) for v in value]
    return [float(value)]


@pytest.mark.povray
@pytest.mark.parametrize("index", range(len(PROBES)), ids=[e for _, e in PROBES])
def test_macro_agrees_with_povray(index, povray_results, strala_results):
    kind, expr = PROBES[index]
    if "_extent" in _probe_macro_source(expr) and _unsupported(strala_results, "_extent()"):
        pytest.skip("the evaluator does not support min_extent()/max_extent() yet")
    name = f"Probe_{index}"
    assert name in strala_results.symbols, [str(d) for d in errors(strala_results)][:5]
    got = _as_numbers(kind, strala_results.symbols[name])
    want = povray_results[index]
    assert len(got) == len(want)
    # POV-Ray stores colours in single precision (`color C` rounds to float32), strala in
    # double: where a colour is involved, agree to float32's precision (amplified a little
    # by the divisions in the hue formulas); elsewhere to 1e-9.
    tol = 1e-5 if kind == "c" or "rgbft" in expr else 1e-9
    for g, w in zip(got, want, strict=True):
        assert g == pytest.approx(w, rel=tol, abs=tol), (expr, got, want)


def _probe_macro_source(expr: str) -> str:
    """The text of the stdlib macro a probe calls (to see what it depends on)."""
    name = expr.split("(", 1)[0]
    for inc in STDLIB.glob("*.inc"):
        m = re.search(rf"#macro\s+{name}\s*\((.*?)#end", inc.read_text(), re.S)
        if m:
            return m.group(0)
    return ""


def _unsupported(result, what: str) -> bool:
    return any("not supported" in d.message and what in d.message for d in result.diagnostics)


# ------------------------------------------------------- properties of the stdlib macros
@given(st.tuples(*[st.floats(0, 1, allow_nan=False)] * 5))
def test_hsv_and_hsl_round_trip(tmp_path_factory, rgbft):
    colour = "rgbft <" + ", ".join(repr(v) for v in rgbft) + ">"
    result = compile_text(
        tmp_path_factory.mktemp("hsv"),
        '#include "colors.inc"\n'
        f"#declare A = CHSV2RGB(CRGB2HSV({colour}));\n"
        f"#declare B = CHSL2RGB(CRGB2HSL({colour}));\n",
    )
    assert errors(result) == []
    for name in ("A", "B"):
        got = _as_numbers("c", result.symbols[name])
        assert got == pytest.approx(list(rgbft), abs=1e-9), name


_axis = st.tuples(*[st.floats(-5, 5, allow_nan=False)] * 3).filter(lambda v: math.hypot(*v) > 1e-3)


@given(_axis, _axis)
def test_reorient_trans_turns_one_direction_into_the_other(tmp_path_factory, a, b):
    va, vb = (f"<{v[0]!r}, {v[1]!r}, {v[2]!r}>" for v in (a, b))
    result = compile_text(
        tmp_path_factory.mktemp("reorient"),
        f'#include "transforms.inc"\n#declare T = transform {{ Reorient_Trans({va}, {vb}) }}\n',
    )
    assert errors(result) == []
    m = result.symbols["T"].matrix
    na, nb = math.hypot(*a), math.hypot(*b)
    image = [sum(m[r][c] * a[c] for c in range(3)) / na for r in range(3)]
    assert image == pytest.approx([v / nb for v in b], abs=1e-7)
    # A rotation: orthonormal columns, no translation.
    cols = [[m[r][c] for r in range(3)] for c in range(3)]
    for i in range(3):
        for j in range(3):
            dot = sum(cols[i][k] * cols[j][k] for k in range(3))
            assert dot == pytest.approx(1.0 if i == j else 0.0, abs=1e-9)
    assert [m[r][3] for r in range(3)] == pytest.approx([0, 0, 0], abs=1e-12)


@given(_axis, st.floats(-720, 720, allow_nan=False), _axis)
def test_axis_rotate_trans_agrees_with_vaxis_rotate(tmp_path_factory, axis, angle, point):
    va, vp = (f"<{v[0]!r}, {v[1]!r}, {v[2]!r}>" for v in (axis, point))
    result = compile_text(
        tmp_path_factory.mktemp("axisrot"),
        '#include "transforms.inc"\n'
        f"#declare T = transform {{ Axis_Rotate_Trans({va}, {angle!r}) }}\n"
        f"#declare P = vaxis_rotate({vp}, {va}, {angle!r});\n",
    )
    assert errors(result) == []
    m = result.symbols["T"].matrix
    image = [sum(m[r][c] * point[c] for c in range(3)) + m[r][3] for r in range(3)]
    assert image == pytest.approx(list(result.symbols["P"]), abs=1e-9)


# ------------------------------------------------ oracle 3: POV-Ray renders the shapes
# Every shape of shapes_old.inc and shapes2.inc and every object-making macro of
# shapes.inc (with arguments that reach each branch), infinite ones cut to a cube.
_SHAPES = [
    *(f"intersection {{ object {{ {n} }} box {{ -1.5, 1.5 }} }}" for n in (
        "Cylinder_X", "Cylinder_Y", "Cylinder_Z", "QCone_X", "QCone_Y", "QCone_Z",
        "Plane_YZ", "Plane_XZ", "Plane_XY", "Paraboloid_X", "Paraboloid_Y", "Paraboloid_Z",
        "Hyperboloid", "Hyperboloid_Y",
    )),
    *(f"object {{ {n} }}" for n in (
        "Ellipsoid scale <1, 0.5, 0.8>", "Sphere", "Cone_X", "Cone_Y", "Cone_Z", "UnitBox",
        "Cube", "Disk_X", "Disk_Y", "Disk_Z", "Tetrahedron", "Octahedron", "Dodecahedron",
        "Icosahedron", "HalfCone_Y", "Hexagon", "Rhomboid scale 0.6", "Pyramid", "Pyramid2",
        "Square_X", "Square_Y", "Square_Z",
    )),
    "Round_Box_Union(<-1, -1, -1>, <1, 0.5, 1>, 0.3)",
    "Round_Box_Merge(<1, 1, 0.2>, <-1, -1, -1>, 0.25)",
    "Round_Box(<-1, -1, -1>, <1, 1, -0.8>, 0.3, yes)",
    "Wire_Box_Union(<-1, -1, -1>, <1, 1, 1>, 0.1)",
    "Wire_Box_Merge(<-1, -1, 0>, <1, 1, 0>, 0.1)",
    "Wire_Box(<-1, 0, -1>, <1, 0, 1>, 0.15, no)",
    "Round_Cylinder_Union(<0, -1, 0>, <0, 1, 0.3>, 0.8, 0.2)",
    "Round_Cylinder_Merge(<0, -1, 0>, <0.5, 1, 0>, 0.1, 0.3)",
    "Round_Cone_Union(<0, -1, 0>, 1, <0, 1, 0>, 0.4, 0.15)",
    "Round_Cone_Merge(<0, 1, 0>, 1, <0.2, -1, 0>, 0.5, 0.1)",
    "Round_Cone2_Union(<0, -1, 0>, 0.8, <0, 1, 0>, 0.3)",
    "Round_Cone2_Merge(<0, -1, 0>, 0.3, <0.5, 1, 0>, 0.6)",
    "Round_Cone3_Union(<0, -1, 0>, 0.8, <0.3, 1, 0>, 0.3)",
    "Round_Cone3_Merge(<0, -1, 0>, 0.3, <0, 1, 0>, 0.7)",
    "Connect_Spheres(<0, -1, 0>, 0.8, <0, 1, 0>, 0.3)",
    "Spheroid(<0.2, 0, 0>, <1, 0.5, 0.7>)",
    *(f"intersection {{ Wedge({a}) sphere {{ 0, 1 }} }}" for a in (-10, 60, 180, 250, 400)),
    "Center_Object(sphere { <3, 2, 1>, 1 }, x + y + z)",
    "Align_Object(box { <1, 1, 1>, <2, 3, 2> }, -y, <0, -1, 0>)",
    "mesh { Quad(<-1, -1, 0>, <1, -1, 0>, <1, 1, 0>, <-1, 0.5, 0>) }",
    "mesh { Smooth_Quad(<-1, -1, 0>, <-1, 0, -1>, <1, -1, 0>, <1, 0, -1>, <1, 1, 0>, "
    "<0, 1, -1>, <-1, 1, 0>, <0, 0, -1>) }",
]  # fmt: skip


def _shape_gallery(shapes: list[str]) -> str:
    rows = -(-len(shapes) // 8)
    centre = f"<10.5, {-(rows - 1) * 1.5}, 0>"
    lines = [
        "#version 3.7;",
        "global_settings { assumed_gamma 1.0 }",
        '#include "shapes.inc"',
        '#include "shapes2.inc"',
        f"camera {{ orthographic location {centre} - 20*z look_at {centre} "
        f"right 24*x up {rows * 3}*y }}",
        "light_source { <-20, 30, -40> rgb 1 }",
        "background { rgb <0.1, 0.2, 0.3> }",
    ]
    for i, shape in enumerate(shapes):
        place = f"<{(i % 8) * 3}, {-(i // 8) * 3}, 0>"
        lines.append(
            f"object {{ {shape} rotate <20, 30, 10> translate {place} "
            "pigment { rgb <1, 0.6, 0.3> } finish { phong 0.5 } }"
        )
    return "\n".join(lines) + "\n"


@pytest.mark.povray
@needs_pov_includes
def test_povray_renders_stdlib_shapes_exactly_like_its_own(tmp_path):
    # Independent of strala's evaluator: POV-Ray builds every shape and macro result from
    # strala's shapes files and from its own, and the pictures are the same pixels.
    cell = 32
    size = (8 * cell, -(-len(_SHAPES) // 8) * cell)
    theirs, ours = povray_both_ways(tmp_path, _shape_gallery(_SHAPES), size)
    changed = abs(theirs - ours).max(axis=2)
    assert theirs.std() > 10  # the gallery shows something
    cells = {(y // cell) * 8 + x // cell for y, x in zip(*changed.nonzero(), strict=True)}
    assert changed.max() == 0, [_SHAPES[c] for c in sorted(cells) if c < len(_SHAPES)]


def test_strala_builds_every_shape_of_the_gallery(tmp_path):
    result = compile_text(tmp_path, _shape_gallery(_SHAPES))
    assert errors(result) == []
    assert result.scene is not None and len(result.scene.objects) == len(_SHAPES)


# ------------------------------------------------- oracle 4: POV-Ray renders the skies
_SKY_VIEW = "camera { location <0, 1, -5> look_at <0, 2, 0> angle 90 }\n"
_SKY_OBJECTS = """background { rgb <0.2, 0.3, 0.8> }
light_source { <10, 100, -50> rgb 1 }
object { O_Cloud2 }
object { O_Cloud1 scale 0.001 translate 12 * z }
sphere { <-2, 1, 0>, 1 pigment { P_Cloud1 scale 0.1 } }
sphere { <0, 1, 0>, 1 pigment { P_Cloud2 scale 0.1 } }
sphere { <2, 1, 0>, 1 pigment { P_Cloud3 scale 0.1 } }
sphere { <-1, 3, 0>, 1 pigment { P_Cloud4 } }
sphere { <1, 3, 0>, 1 texture { T_Cloud1 scale 0.1 } }
sphere { <3, 3, 0>, 1 texture { T_Cloud2 scale 0.2 } }
sphere { <-3, 3, 0>, 1 texture { T_Cloud3 scale 0.2 } }
"""
_SKY_SCENES = [f"sky_sphere {{ S_Cloud{i} }}\n" for i in range(1, 6)] + [_SKY_OBJECTS]


def _sky_scene(body: str) -> str:
    # POV-Ray's skies.inc needs colors.inc first; strala's includes it itself
    head = '#version 3.7;\nglobal_settings { assumed_gamma 1 }\n#include "colors.inc"\n'
    return head + '#include "skies.inc"\n' + _SKY_VIEW + body


@pytest.mark.povray
@needs_pov_includes
def test_povray_renders_stdlib_skies_exactly_like_its_own(tmp_path):
    for i, body in enumerate(_SKY_SCENES):
        theirs, ours = povray_both_ways(tmp_path / str(i), _sky_scene(body), (80, 60))
        assert theirs.std() > 5, body  # clouds, not a flat colour
        assert abs(theirs - ours).max() == 0, body


@pytest.mark.parametrize("body", _SKY_SCENES, ids=[*(f"S_Cloud{i}" for i in range(1, 6)), "rest"])
def test_strala_evaluates_every_sky(tmp_path, body):
    result = compile_text(tmp_path, _sky_scene(body))
    assert errors(result) == []
    assert result.scene is not None


# --------------------------------------------- oracle 5: POV-Ray evaluates functions.inc
_POINTS = [
    "0.3, -0.7, 1.1",
    "-1.2, 0.4, 0.25",
    "0.05, 2.0, -0.6",
    "1.5, 1.5, 1.5",
    "0.2, 0.1, 0.05",
]
_FORMULAS = [
    *(f"{f}({p})" for f in ("f_r", "f_th", "f_ph") for p in _POINTS),
    *(f"f_sphere({p}, 0.7)" for p in _POINTS),
    *(f"f_torus({p}, 1, 0.3)" for p in _POINTS),
    *(f"f_rounded_box({p}, 0.3, 1, 0.5, 0.8)" for p in _POINTS),
    *(f"f_rounded_box({p}, 0, 0.2, 2, 0.1)" for p in _POINTS),
    *(f"{f}({p})" for f in ("f_sine_wave", "f_scallop_wave") for p in _POINTS),
]
_PATTERN_FUNCTIONS = (
    "f_noise3d f_snoise3d f_agate f_boxed f_bozo f_brick f_bumps f_checker f_crackle "
    "f_cylindrical f_dents f_gradientX f_gradientY f_gradientZ f_granite f_leopard "
    "f_marble f_onion f_planar f_radial f_ripples f_spherical f_spiral1 f_spiral2 f_spotted "
    "f_waves f_wood f_wrinkles f_mandel"
).split()
_FUNCTION_PROBES = [
    *_FORMULAS,
    *(f"{f}({p})" for f in _PATTERN_FUNCTIONS for p in _POINTS),
    "eval_pigment(pigment { checker rgb 1, rgb <0.2, 0.4, 0.6> }, <0.5, 0.5, 0.5>).green",
]


def _function_probe_scene() -> str:
    lines = ["#version 3.7;", "global_settings { assumed_gamma 1 }", '#include "functions.inc"']
    lines.append('#fopen Probe_Out "probes.txt" write')
    for i, call in enumerate(_FUNCTION_PROBES):
        lines.append(f'#write (Probe_Out, "@@{i}=", str({call}, 0, 17), "\\n")')
    lines.append("#fclose Probe_Out")
    return "\n".join(lines) + "\n"


def _read_function_probes(folder: Path) -> list[float]:
    found = dict(re.findall(r"@@(\d+)=([^\n]*)", (folder / "probes.txt").read_text()))
    assert len(found) == len(_FUNCTION_PROBES)
    return [float(found[str(i)]) for i in range(len(_FUNCTION_PROBES))]


@pytest.fixture(scope="module")
def povray_functions(tmp_path_factory) -> list[float]:
    """The probes as POV-Ray computes them with its own functions.inc (built-ins)."""
    if not shutil.which("povray") or not POV_INCLUDE.exists():
        pytest.skip("POV-Ray is not installed")
    folder = tmp_path_factory.mktemp("pov_functions")
    run_povray(folder, _function_probe_scene(), with_stdlib=False, size=(1, 1))
    return _read_function_probes(folder)


@pytest.mark.povray
@needs_pov_includes
def test_povray_running_the_stdlib_functions_agrees_with_its_own(tmp_path, povray_functions):
    run_povray(tmp_path, _function_probe_scene(), with_stdlib=True, size=(1, 1))
    ours = _read_function_probes(tmp_path)
    assert len(set(povray_functions)) > len(_FUNCTION_PROBES) // 2  # the probes vary
    for call, got, want in zip(_FUNCTION_PROBES, ours, povray_functions, strict=True):
        assert got == pytest.approx(want, rel=1e-9, abs=1e-9), call


@needs_pov_includes
def test_the_stdlib_functions_inc_names_every_function_of_povrays():
    """Every function and macro POV-Ray 3.7's functions.inc declares, strala's declares
    too (so `#include "functions.inc"` gives a scene all the names POV-Ray's does)."""
    declared = re.compile(r"#\s*(?:declare|macro)\s+(\w+)")
    theirs = set(declared.findall((POV_INCLUDE / "functions.inc").read_text(errors="replace")))
    ours = set(declared.findall((STDLIB / "functions.inc").read_text()))
    theirs.discard("Functions_Inc_Temp")  # its version guard
    assert {n for n in theirs if n.startswith("f_")}, "POV-Ray's functions.inc declares f_…"
    assert sorted(theirs - ours) == []


# ------------------------------------------------ oracle 6: POV-Ray renders the test stage
_STAGE = """#version 3.7;
global_settings { assumed_gamma 1 }
#include "colors.inc"
#include "stdcam.inc"
sphere { <0, 0.5, 0>, 0.5 pigment { rgb <1, 0.8, 0.2> } }
"""


@pytest.mark.povray
@needs_pov_includes
def test_povray_renders_the_stdcam_stage_exactly_like_its_own(tmp_path):
    theirs, ours = povray_both_ways(tmp_path, _STAGE, (80, 60))
    assert theirs.std() > 10
    assert abs(theirs - ours).max() == 0


def test_stdinc_brings_the_everyday_names(tmp_path):
    result = compile_text(tmp_path, '#include "stdinc.inc"\n#include "stdcam.inc"\n')
    assert errors(result) == []
    for name in ("Red", "Round_Box", "Reorient_Trans", "f_sphere", "sind", "Cube"):
        assert name in result.symbols, name
    assert result.scene is not None and result.scene.lights
