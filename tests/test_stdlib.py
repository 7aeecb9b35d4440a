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
    ]


@pytest.fixture(scope="module")
def evaluated():
    """Each file of the oracle pairs evaluated once, strala's and POV-Ray's."""
    cache: dict[Path, Any] = {}

    def get(path: Path):
        if path not in cache:
            cache[path] = compile_file(path)
        return cache[path]

    return get


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


def run_povray(folder: Path, scene: str, *, with_stdlib: bool, size=(8, 8)) -> str:
    """Run POV-Ray on `scene` in `folder`. With `with_stdlib`, strala's include files are
    copied beside the scene, where POV-Ray looks before its own include folder."""
    for old in folder.glob("*.inc"):
        old.unlink()
    if with_stdlib:
        for inc in STDLIB.glob("*.inc"):
            shutil.copy(inc, folder / inc.name)
    (folder / "scene.pov").write_text(scene)
    run = subprocess.run(
        ["povray", "+Iscene.pov", "+Oscene.png", "-D", "-V", f"+W{size[0]}", f"+H{size[1]}"],
        cwd=folder,
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert run.returncode == 0, run.stderr[-3000:]
    return run.stderr


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
    from OpenImageIO import UINT8, ImageBuf

    blocks = _declared_blocks()
    assert len(blocks) > 250
    size = (16 * _CELL, -(-len(blocks) // 16) * _CELL)
    images = []
    for with_stdlib in (False, True):
        folder = tmp_path / ("stdlib" if with_stdlib else "pov")
        folder.mkdir()
        run_povray(folder, _gallery_scene(blocks), with_stdlib=with_stdlib, size=size)
        images.append(ImageBuf(str(folder / "scene.png")).get_pixels(UINT8).astype(int))
    changed = abs(images[0] - images[1]).max(axis=2)
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
    from OpenImageIO import UINT8, ImageBuf

    cell = 32
    size = (8 * cell, -(-len(_SHAPES) // 8) * cell)
    images = []
    for with_stdlib in (False, True):
        folder = tmp_path / ("stdlib" if with_stdlib else "pov")
        folder.mkdir()
        run_povray(folder, _shape_gallery(_SHAPES), with_stdlib=with_stdlib, size=size)
        images.append(ImageBuf(str(folder / "scene.png")).get_pixels(UINT8).astype(int))
    changed = abs(images[0] - images[1]).max(axis=2)
    assert images[0].std() > 10  # the gallery shows something
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
    from OpenImageIO import UINT8, ImageBuf

    for i, body in enumerate(_SKY_SCENES):
        images = []
        for with_stdlib in (False, True):
            folder = tmp_path / f"{i}-{with_stdlib}"
            folder.mkdir()
            run_povray(folder, _sky_scene(body), with_stdlib=with_stdlib, size=(80, 60))
            images.append(ImageBuf(str(folder / "scene.png")).get_pixels(UINT8).astype(int))
        assert images[0].std() > 5, body  # clouds, not a flat colour
        assert abs(images[0] - images[1]).max() == 0, body


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
]
_PATTERN_FUNCTIONS = (
    "f_noise3d f_snoise3d f_agate f_boxed f_bozo f_brick f_bumps f_checker f_crackle "
    "f_cylindrical f_dents f_gradientX f_gradientY f_gradientZ f_granite f_leopard "
    "f_marble f_onion f_planar f_radial f_ripples f_spherical f_spiral1 f_spiral2 f_spotted "
    "f_waves f_wood f_wrinkles"
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
    from OpenImageIO import UINT8, ImageBuf

    images = []
    for with_stdlib in (False, True):
        folder = tmp_path / str(with_stdlib)
        folder.mkdir()
        run_povray(folder, _STAGE, with_stdlib=with_stdlib, size=(80, 60))
        images.append(ImageBuf(str(folder / "scene.png")).get_pixels(UINT8).astype(int))
    assert images[0].std() > 10
    assert abs(images[0] - images[1]).max() == 0


def test_stdinc_brings_the_everyday_names(tmp_path):
    result = compile_text(tmp_path, '#include "stdinc.inc"\n#include "stdcam.inc"\n')
    assert errors(result) == []
    for name in ("Red", "Round_Box", "Reorient_Trans", "f_sphere", "sind", "Cube"):
        assert name in result.symbols, name
    assert result.scene is not None and result.scene.lights


# ------------------------------------------ oracle 7: every name POV-Ray's files declare
# A public name is one a `#declare` or `#macro` gives outside comments and strings and that
# does not start with `_`. POV-Ray's file is read when the test runs.
_DECLARED_NAME = re.compile(
    r'#\s*(?:declare|macro)\s+(?:deprecated\s+(?:once\s+)?""\s*)?([A-Za-z]\w*)'
)
# Files strala does not provide yet (scenes needing them can point -L at POV-Ray's folder).
_FILES_NOT_PROVIDED = {
    "woods.inc": "not written yet (layered wood textures, data only)",
    "woodmaps.inc": "not written yet (wood colour maps, data only)",
    "stones.inc": "not written yet (includes stones1.inc and stones2.inc)",
    "stones1.inc": "not written yet (about 150 crackle and granite textures)",
    "stones2.inc": "not written yet (about 20 layered stone textures)",
    "stoneold.inc": "not written yet (the pre-3.0 stone textures)",
    "chars.inc": "not written yet (letters built from boxes and cylinders)",
    "makegrass.inc": "not written yet (grass meshes)",
    "meshmaker.inc": "not written yet (parametric mesh2 builders)",
    "shapes3.inc": "not written yet (segments, tubes, pyramids, eggs)",
}
# Names a POV-Ray file declares that strala's file leaves out on purpose.
_NAMES_LEFT_OUT = {
    # scratch names of POV-Ray's HF_* macros (counters and the point grid, which POV-Ray's
    # #declare updates in the macro's own scope) and the internal macro that writes the
    # mesh; strala's macros keep theirs local under Strala_* names
    "shapes.inc": {"J", "K", "PArr", "HFCreate_"},
    # the two helper macros that POV-Ray's ior.inc defines and #undefs again
    "ior.inc": {"Ior", "Disp"},
    # ARRAYS_WriteDF3's temporary macros, which POV-Ray's version #undefs before it returns
    "arrays.inc": {"ARRAYS_Temp", "ARRAYS_Temp_WriteDF3"},
    # being added to functions.inc in another change
    "functions.inc": {"f_mandel", "f_scallop_wave", "f_sine_wave"},
}


def _public_names(text: str) -> set[str]:
    text = re.sub(r"/\*.*?\*/", "", text, flags=re.S)
    text = re.sub(r"//[^\n]*", "", text)
    text = re.sub(r'"(?:[^"\\\n]|\\.)*"', '""', text)
    return {n for n in _DECLARED_NAME.findall(text) if not n.startswith("_")}


def _povray_include_files() -> list[str]:
    return sorted(p.name for p in POV_INCLUDE.glob("*.inc")) or ["(none installed)"]


@pytest.mark.povray
@needs_pov_includes
@pytest.mark.parametrize("name", _povray_include_files())
def test_stdlib_declares_every_name_povray_declares(name):
    if name in _FILES_NOT_PROVIDED:
        pytest.skip(_FILES_NOT_PROVIDED[name])
    theirs = _public_names((POV_INCLUDE / name).read_text(errors="replace"))
    assert (STDLIB / name).is_file(), f"strala's stdlib has no {name}"
    if name not in ("stdcam.inc", "stage1.inc"):  # a stage only: no names (stage1 has one)
        assert theirs, f"no names found in POV-Ray's {name}"
    mine = _public_names((STDLIB / name).read_text())
    missing = sorted(theirs - mine - _NAMES_LEFT_OUT.get(name, set()))
    assert missing == [], f"{name} lacks {missing}"


def test_names_left_out_are_still_left_out():
    # An exception that the stdlib file now declares after all is stale.
    for name, left_out in _NAMES_LEFT_OUT.items():
        if name == "functions.inc":
            continue  # another change adds these; the list only tolerates their absence
        assert not left_out & _public_names((STDLIB / name).read_text()), name
    for name in _FILES_NOT_PROVIDED:
        assert not (STDLIB / name).exists(), f"{name} is provided now: drop it from the list"


# -------------------------------------- oracle 8: the newer files' values against POV-Ray
# Each probe is (key, kind, expression): kinds "f" a float, "v" a 3-vector, "s" a string;
# the probes of one file run in order in one scene (the random streams depend on it).
_VALUE_PRELUDES = {
    "rand.inc": """
#declare S = seed(123);
#declare Spl = spline { linear_spline 0, <0, 0.2, 0>, 0.5, <0, 1, 0>, 1, <0, 0.1, 0> }
#declare Ball = sphere { <1, 2, 3>, 1.5 }
""",
    "arrays.inc": """
#declare S = seed(7);
#declare A = array[30]
#for (I, 0, 29) #declare A[I] = mod(I*17 + 5, 23) - 0.5*mod(I, 3); #end
Sort_Array(A)
#declare B = array[6] {5, 4, 3, 2, 1, 0}
Reverse_Array(B)
#declare C = array[4] {1, 2, 3, 4}
Resize_Array(C, 6)
#declare D = array[7] {9, 8, 7, 6, 5, 4, 3}
Sort_Partial_Array(D, 1, 4)
#declare V = array[14]
#for (I, 0, 13) #declare V[I] = <mod(I*5, 7), I, 0>; #end
// sort vectors by x only, so equal keys show the order the method leaves them in
#macro Sort_Compare(Array, IdxA, IdxB) (Array[IdxA].x < Array[IdxB].x) #end
Sort_Array(V)
""",
    "math.inc": """
#declare F = function (x, y, z) { x*x + y*z - 3*z }
#declare G = function (x, y, z) { sin(x)*y + z*z }
#declare Grad = fn_Gradient(F);
#declare GradDir = fn_Gradient_Directional(G, <1, 1, 0>);
#declare Div = fn_Divergence(F, G, F);
""",
    "transforms.inc": """
#declare T = transform { rotate <10, 20, 30> scale <1, 2, -3> translate <1, 2, 3> }
#declare T2 = transform { Axis_Rotate_Trans(<1, 1, 0>, 33) translate -x }
""",
    "screen.inc": """
Set_Camera(<3, 2, -5>, <0, 1, 0>, 50)
#declare Ball = Screen_Object(sphere { <0.2, 0, 0>, 0.1 }, <0.2, 0.8>, 0.01, 1, 0.5)
#declare Ball2 = Screen_Object(box { -0.1, 0.2 }, <1, 0>, <0.02, 0.01>, <1, 0.5, 0>, 2)
#declare Patch = Screen_Plane(texture { pigment { rgb 1 } }, 0.25, <0.1, 0.2>, <0.5, 0.9>)
Set_Camera_Sky(<0.2, 1, 0>)
Set_Camera_Zoom(1.5)
#declare Patch2 = Screen_Plane(texture { pigment { rgb 1 } }, 1, <0, 0>, <1, 1>)
""",
    "sunpos.inc": "",
    "strings.inc": "",
}


def _rand_probes() -> list[tuple[str, str, str]]:
    calls = [
        ("f", "Prob(0.4, S)"), ("f", "SRand(S)"), ("f", "RRand(2, 5, S)"), ("v", "VRand(S)"),
        ("v", "VRand_In_Box(<1, 2, 3>, <4, 6, 8>, S)"), ("v", "VRand_On_Sphere(S)"),
        ("v", "VRand_In_Sphere(S)"), ("v", "VRand_In_Obj(Ball, S)"),
        ("f", "Rand_Gauss(1, 2, S)"), ("f", "Rand_Gauss(1, 2, S)"), ("f", "Rand_Gauss(1, 2, S)"),
        ("f", "Rand_Normal(1, 2, S)"), ("f", "Rand_Cauchy(1, 2, S)"), ("f", "Rand_Student(3, S)"),
        ("f", "Rand_Spline(Spl, S)"), ("f", "cVal"), ("f", "Rand_Gamma(2.5, 1.5, S)"),
        ("f", "Rand_Gamma(1, 2, S)"), ("f", "Rand_Gamma(0.6, 2, S)"), ("f", "Rand_Beta(2, 3, S)"),
        ("f", "Rand_Beta(0.7, 0.8, S)"), ("f", "Rand_Chi_Square(4, S)"),
        ("f", "Rand_F_Dist(3, 5, S)"), ("f", "Rand_Triangle(0, 10, 3, S)"),
        ("f", "Rand_Triangle(0, 10, 3, S)"), ("f", "Rand_Erlang(2, 3, S)"),
        ("f", "Rand_Exp(1.5, S)"), ("f", "Rand_Lognormal(0, 0.5, S)"), ("f", "Rand_Pareto(2, S)"),
        ("f", "Rand_Weibull(1, 2, S)"), ("f", "Rand_Bernoulli(0.5, S)"),
        ("f", "Rand_Binomial(10, 0.3, S)"), ("f", "Rand_Geo(0.3, S)"),
        ("f", "Rand_Poisson(4, S)"), ("f", "rand(RdmA)"), ("f", "rand(RdmB)"),
        ("f", "rand(RdmC)"), ("f", "rand(RdmD)"), ("f", "rand(S)"),
    ]  # fmt: skip
    # a thousand draws of some, summed (the sums are deterministic too)
    sums = [
        ("f", "Strala_Sum(Rand_Normal(0, 1, S))"),
        ("f", "Strala_Sum(Rand_Gamma(0.7, 1, S))"),
        ("f", "Strala_Sum(Rand_Poisson(2.5, S))"),
    ]
    return [(f"rand{i}", k, e) for i, (k, e) in enumerate(calls + sums)]


_SUM_MACRO = """
#macro Strala_Sum(Draw)
   #local Total = 0;
   #for (I, 1, 1000) #local Total = Total + Draw; #end
   Total
#end
"""


def _value_probes() -> dict[str, list[tuple[str, str, str]]]:
    p: dict[str, list[tuple[str, str, str]]] = {"rand.inc": _rand_probes()}
    p["arrays.inc"] = [
        *((f"A{i}", "f", f"A[{i}]") for i in range(30)),
        *((f"B{i}", "f", f"B[{i}]") for i in range(6)),
        *((f"D{i}", "f", f"D[{i}]") for i in range(7)),
        *((f"V{i}", "v", f"V[{i}]") for i in range(14)),
        ("C", "f", "dimension_size(C, 1)"),
        ("C3", "f", "C[3]"),
        *((f"item{i}", "f", "Rand_Array_Item(B, S)") for i in range(5)),
    ]
    p["math.inc"] = [
        ("grad", "f", "Grad(1, 2, 3)"),
        ("grad2", "f", "Grad(-0.5, 0.25, 2)"),
        ("graddir", "f", "GradDir(1, 2, 3)"),
        ("div", "f", "Div(0.5, 1, 2)"),
    ]
    p["transforms.inc"] = [
        ("vt", "v", "vtransform(<1, -2, 0.5>, T)"),
        ("vi", "v", "vinv_transform(<1, -2, 0.5>, T)"),
        ("vt2", "v", "vtransform(<0.3, 4, -1>, T2)"),
        ("vi2", "v", "vinv_transform(vtransform(<0.3, 4, -1>, T2), T2)"),
    ]
    p["screen.inc"] = [
        ("R", "v", "CamR"),
        ("U", "v", "CamU"),
        ("D", "v", "CamD"),
        ("L", "v", "CamL"),
        ("zoom", "f", "Camera_Zoom"),
        ("aspect", "f", "Camera_Aspect_Ratio"),
        ("ball_lo", "v", "min_extent(Ball)"),
        ("ball_hi", "v", "max_extent(Ball)"),
        ("ball2_lo", "v", "min_extent(Ball2)"),
        ("ball2_hi", "v", "max_extent(Ball2)"),
        ("patch_lo", "v", "min_extent(Patch)"),
        ("patch_hi", "v", "max_extent(Patch)"),
        ("patch2_lo", "v", "min_extent(Patch2)"),
        ("patch2_hi", "v", "max_extent(Patch2)"),
    ]
    suns = [
        "2024, 6, 21, 12, 0, 15, 52.5, 13.4",
        "1999, 1, 1, 0, 30, 15, 40, -74",
        "2010, 11, 30, 23, 59, -120, -33, 151",
        "1985, 3, 20, 6, 15, 0, 0, 0",
    ]
    p["sunpos.inc"] = []
    for i, args in enumerate(suns):
        p["sunpos.inc"] += [
            (f"sun{i}", "v", f"SunPos({args})"),
            (f"al{i}", "f", "Al"),
            (f"az{i}", "f", "Az"),
            (f"pos{i}", "v", "SolarPosition"),
        ]
    p["strings.inc"] = [
        ("Str", "s", "Str(1.25)"),
        ("Str2", "s", "Str(-1/3)"),
        ("VStr", "s", "VStr(<1, 2.5, -3>)"),
        ("VStr2D", "s", "VStr2D(<0.1, 2>)"),
        ("Vstr", "s", "Vstr(<1, 2, 3>, 5, 2)"),
        ("Vstr2D", "s", "Vstr2D(<1, 2>, 0, 3)"),
        ("CRGBStr", "s", "CRGBStr(rgb <0.1, 0.2, 0.3>, 0, 3)"),
        ("CRGBFTStr", "s", "CRGBFTStr(rgbft <0.1, 0.2, 0.3, 0.4, 0.5>, 6, 2)"),
        ("Triangle_Str", "s", "Triangle_Str(x, y, z)"),
        ("Smooth_Triangle_Str", "s", "Smooth_Triangle_Str(x, <1, 2, 3>, y, -x, z, <0.5, 0, 1>)"),
    ]
    return p


VALUE_PROBES = _value_probes()


def _value_scene(name: str) -> str:
    out = [
        "#version 3.7;",
        f'#include "{name}"',
        _SUM_MACRO,
        _VALUE_PRELUDES[name],
        '#fopen Probe_Out "values.txt" write',
    ]
    for key, kind, expr in VALUE_PROBES[name]:
        value = {
            "f": f"str({expr}, 0, 17)",
            "v": f'vstr(3, {expr}, ",", 0, 17)',
            "s": expr,
        }[kind]
        out.append(f'#write (Probe_Out, "@@{key}=", {value}, "\\n")')
    out.append("#fclose Probe_Out")
    return "\n".join(out) + "\n"


def _read_values(folder: Path, name: str) -> dict[str, str]:
    found = dict(re.findall(r"@@(\w+)=([^\n]*)", (folder / "values.txt").read_text()))
    assert len(found) == len(VALUE_PROBES[name])
    return found


def _agree(name: str, got: dict[str, str], want: dict[str, str], tol: float) -> list[str]:
    wrong = []
    for key, kind, expr in VALUE_PROBES[name]:
        if kind == "s":
            ok = got[key] == want[key]
        else:
            g = [float(v) for v in got[key].split(",")]
            w = [float(v) for v in want[key].split(",")]
            ok = g == pytest.approx(w, rel=tol, abs=tol)
        if not ok:
            wrong.append(f"{expr}: {got[key]} != {want[key]}")
    return wrong


@pytest.fixture(scope="module")
def povray_values(tmp_path_factory):
    """The value probes of each file as POV-Ray computes them with its own include files."""
    if not shutil.which("povray") or not POV_INCLUDE.exists():
        pytest.skip("POV-Ray is not installed")
    cache: dict[str, dict[str, str]] = {}

    def get(name: str) -> dict[str, str]:
        if name not in cache:
            folder = tmp_path_factory.mktemp("pov_values")
            run_povray(folder, _value_scene(name), with_stdlib=False, size=(8, 6))
            cache[name] = _read_values(folder, name)
        return cache[name]

    return get


# vtransform and Screen_Object go through object extents, which POV-Ray keeps in single
# precision; where POV-Ray runs strala's files those values agree to that precision only.
_POVRAY_EXTENT_TOL = {"transforms.inc": 1e-6, "screen.inc": 1e-6}


@pytest.mark.povray
@needs_pov_includes
@pytest.mark.parametrize("name", sorted(VALUE_PROBES))
def test_povray_running_the_new_stdlib_files_agrees_with_its_own(tmp_path, povray_values, name):
    # Independent of strala's evaluator: strala's file, run by POV-Ray, gives POV-Ray's values.
    run_povray(tmp_path, _value_scene(name), with_stdlib=True, size=(8, 6))
    ours = _read_values(tmp_path, name)
    assert _agree(name, ours, povray_values(name), _POVRAY_EXTENT_TOL.get(name, 1e-9)) == []


@pytest.mark.povray
@needs_pov_includes
@pytest.mark.parametrize("name", sorted(VALUE_PROBES))
def test_strala_values_of_the_new_stdlib_files_agree_with_povray(tmp_path, povray_values, name):
    from runtime.queries import RuntimeQueries

    (tmp_path / "scene.pov").write_text(_value_scene(name))
    # with the renderer's geometry queries: VRand_In_Obj asks inside()
    result = compile_file(
        tmp_path / "scene.pov", image_width=8, image_height=6, queries=RuntimeQueries
    )
    assert errors(result) == []
    ours = _read_values(tmp_path, name)
    # screen.inc's extents are POV-Ray's single-precision bounding boxes
    tol = 1e-6 if name == "screen.inc" else 1e-9
    assert _agree(name, ours, povray_values(name), tol) == []


# ----------------------------------------- oracle 9: POV-Ray renders the newer files
_SHAPESQ = (
    "Bicorn Crossed_Trough Cubic_Cylinder Cubic_Saddle_1 Devils_Curve Folium Glob_5 Twin_Glob "
    "Helix Helix_1 Hyperbolic_Torus_40_12 Lemniscate Quartic_Loop_1 Monkey_Saddle "
    "Parabolic_Torus_40_12 Piriform Quartic_Paraboloid Quartic_Cylinder Steiner_Surface "
    "Torus_40_12 Witch_Hat Sinsurf"
).split()
# the big tori brought to the others' size
_SHAPESQ_SCALE = {
    "Hyperbolic_Torus_40_12": 0.12,
    "Parabolic_Torus_40_12": 0.12,
    "Torus_40_12": 0.12,
}


def _shapesq_cells() -> list[str]:
    return [
        f"intersection {{ object {{ {n} scale {_SHAPESQ_SCALE.get(n, 1)} }} box {{ -1.2, 1.2 }} }}"
        for n in _SHAPESQ
    ]


_HEAD = """#version 3.7;
global_settings { assumed_gamma 1.0 }
"""
_LIGHT = "light_source { <-20, 30, -40> rgb 1 }\nbackground { rgb <0.1, 0.2, 0.3> }\n"


def _grid(cells: list[str], columns: int, includes: str, pigment: str) -> str:
    rows = -(-len(cells) // columns)
    centre = f"<{(columns - 1) * 1.5}, {-(rows - 1) * 1.5}, 0>"
    lines = [
        _HEAD + includes,
        f"camera {{ orthographic location {centre} - 20*z look_at {centre} "
        f"right {columns * 3}*x up {rows * 3}*y }}",
        _LIGHT,
    ]
    for i, cell in enumerate(cells):
        place = f"<{(i % columns) * 3}, {-(i // columns) * 3}, 0>"
        lines.append(f"object {{ {cell} rotate <20, 30, 10> translate {place} {pigment} }}")
    return "\n".join(lines) + "\n"


_SURFACE = "pigment { rgb <1, 0.6, 0.3> } finish { phong 0.5 }"
_MORE_SHAPES_HEAD = """#include "shapes.inc"
#declare Wavy = function (x, y, z) { 0.2*sin(6*x)*cos(5*z) }
#declare Slope = function (u, v, w) { 0.3*u*v }
"""
_MORE_SHAPES = [
    'HF_Square(Wavy, 0, 0, 12, 1, "", <-1, 0, -1>, <1, 0.5, 1>)',
    'HF_Square(Slope, 1, 1, <6, 9>, 0, "", <-1, -0.2, -1>, <1, 0.3, 1>)',
    'HF_Sphere(Slope, 1, 1, <10, 8>, 0, "", <0, 0, 0>, 0.8, 1)',
    'HF_Sphere(Wavy, 0, 0, 12, 1, "", <0.1, 0, 0>, 0.9, 0.5)',
    'HF_Cylinder(Wavy, 0, 0, 10, 1, "", <0, -0.5, 0>, <0.3, 0.8, 0>, 0.5, 0.5)',
    'HF_Torus(Slope, 1, 0, <16, 8>, 1, "", 0.8, 0.3, 1)',
    "Supercone(<0, -0.8, 0>, 0.6, 0.3, <0.3, 0.8, 0.2>, 0.2, 0.5)",
    "Supercone(<0, 0.8, 0>, 0.3, 0.5, <0, -0.8, 0>, 0.7, 0.2)",
    "Supercone(<0, 0, 0.8>, 0.5, 0.5, <0, 0, -0.8>, 0.2, 0.6)",
    'Bevelled_Text("timrom.ttf", "Ab", 4, 40, 0.1, 0.4, 0, yes) translate <-0.8, -0.3, 0>',
    'Bevelled_Text("timrom.ttf", "G", 6, 30, 0.2, 0.5, 0.1, no) translate <-0.4, -0.3, 0>',
    'Circle_Text("timrom.ttf", "Round", 0.4, 0, 0.1, 0.7, 0, Align_Center, 90)',
    'Circle_Text("timrom.ttf", "Left", 0.4, 0.05, 0.1, 0.7, 1, Align_Left, 0)',
    'Circle_Text("timrom.ttf", "Right", 0.4, 0, 0.1, 0.7, 0, Align_Right, 200)',
    'Circle_Text_Valigned("timrom.ttf", "Up", 0.5, 0.05, 0.1, 0.6, 1, Align_Center, 270, -90)',
]
_PATTERNS = [
    "Irregular_Bricks_Ptrn(0.1, 1, 0.5, 0.5) color_map { [0.01 rgb 0.9] [0.01 rgb 0.3] } scale 0.3",
    "Irregular_Bricks_Ptrn(0.05, 2, 0.2, 0.9) scale 0.4",
    "Hex_Tiles_Ptrn() rotate -90*x scale 0.3",
    "Tiles_Ptrn() scale 0.4",
    "Star_Ptrn(1, 5, 2) color_map { [0 rgb 1] [1 rgb <0, 0, 0.5>] }",
    "Star_Ptrn(0.9, 6, 2)",
    "Star_Ptrn(0.9, 7, 3)",
    "Star_Ptrn(1, 8, 1)",
]


def _pattern_gallery() -> str:
    # each pattern on a flat square facing the camera, lit by itself
    cells = [
        f"box {{ <-1.4, -1.4, 0>, <1.4, 1.4, 0.1> pigment {{ {p} }} finish {{ ambient 1 "
        "diffuse 0 } }"
        for p in _PATTERNS
    ]
    lines = [
        _HEAD + '#include "textures.inc"',
        "camera { orthographic location <6, -1.5, -20> look_at <6, -1.5, 0> right 15*x up 6*y }",
    ]
    for i, cell in enumerate(cells):
        lines.append(f"object {{ {cell} translate <{(i % 4) * 3 + 1.5}, {-(i // 4) * 3}, 0> }}")
    return "\n".join(lines) + "\n"


_LOGO_STARS = (
    _HEAD
    + '#include "logo.inc"\n#include "stars.inc"\n'
    + "camera { location <0, 0, -4> look_at 0 angle 60 }\n"
    + "light_source { <-20, 30, -40> rgb 1 }\n"
    + "sky_sphere { pigment { granite color_map { [0.7 rgb 0] [1 rgb 0.5] } } }\n"
    + "".join(
        f"sphere {{ <{-2.5 + i}, -1.2, 0>, 0.45 texture {{ Starfield{i + 1} scale 0.3 }} }}\n"
        for i in range(6)
    )
    + "object { Povray_Logo translate <-1.5, 0.5, 0> pigment { rgb <1, 0.8, 0.2> } }\n"
    + "object { Povray_Logo_Prism rotate 20*y translate <0, 0.5, 0> pigment { rgb 0.8 } }\n"
    + "object { Povray_Logo_Bevel rotate -20*y translate <1.5, 0.5, 0> pigment { rgb x } }\n"
)
_STAGE1 = (
    _HEAD
    + '#include "stage1.inc"\n'
    + "sphere { 0, 3 texture { Jade } }\n"
    + "object { Round_Box(<-5, -5, -1>, <-3, -2, 1>, 0.3, no) pigment { rgb <0.3, 0.5, 1> } }\n"
)
_SCREEN = (
    _HEAD
    + '#include "screen.inc"\n'
    + "Set_Camera(<3, 2, -5>, <0, 1, 0>, 50)\n"
    + "light_source { <-20, 30, -40> rgb 1 }\n"
    + "plane { y, 0 pigment { checker rgb 1, rgb 0.5 } }\n"
    + "sphere { <0, 1, 0>, 1 pigment { rgb <1, 0.5, 0.2> } }\n"
    + "Screen_Object(sphere { 0, 0.1 pigment { rgb x } }, <0.1, 0.9>, 0.01, 1, 0.5)\n"
    + "Screen_Object(box { -0.1, 0.1 pigment { rgb y } }, <1, 0>, <0.02, 0.01>, 1, 2)\n"
    + "Screen_Plane(texture { pigment { rgbt <0, 0, 1, 0.5> } }, 0.25, <0.6, 0.6>, <0.9, 0.9>)\n"
)
_NEW_GALLERIES = {
    "shapesq": (_grid(_shapesq_cells(), 6, '#include "shapes.inc"\n#include "shapesq.inc"',
                      _SURFACE), (192, 128)),
    "shapes": (_grid(_MORE_SHAPES, 5, _MORE_SHAPES_HEAD, _SURFACE), (160, 96)),
    "patterns": (_pattern_gallery(), (200, 80)),
    "logo_stars": (_LOGO_STARS, (160, 120)),
    "stage1": (_STAGE1, (80, 60)),
    "screen": (_SCREEN, (80, 60)),
}  # fmt: skip


@pytest.mark.povray
@needs_pov_includes
@pytest.mark.parametrize("gallery", sorted(_NEW_GALLERIES))
def test_povray_renders_the_newer_stdlib_files_exactly_like_its_own(tmp_path, gallery):
    # Independent of strala's evaluator: the same pixels from POV-Ray's files and strala's.
    from OpenImageIO import UINT8, ImageBuf

    scene, size = _NEW_GALLERIES[gallery]
    images = []
    for with_stdlib in (False, True):
        folder = tmp_path / ("stdlib" if with_stdlib else "pov")
        folder.mkdir()
        run_povray(folder, scene, with_stdlib=with_stdlib, size=size)
        images.append(ImageBuf(str(folder / "scene.png")).get_pixels(UINT8).astype(int))
    assert images[0].std() > 10  # the gallery shows something
    assert abs(images[0] - images[1]).max() == 0


@pytest.mark.parametrize("gallery", sorted(_NEW_GALLERIES))
def test_strala_builds_the_newer_galleries(tmp_path, gallery):
    scene, size = _NEW_GALLERIES[gallery]
    result = compile_text(tmp_path, scene)
    assert errors(result) == []
    assert result.scene is not None and result.scene.objects


# ------------------------------- strala renders the newer files as POV-Ray does (tolerant)
_STRALA_GOLDEN = {
    # a few polynomial surfaces: the torus, a lemniscate, the pear, the Roman surface …
    "shapesq": _grid(
        [
            "object { Torus_40_12 scale 0.15 }",
            "intersection { object { Lemniscate } box { -1.2, 1.2 } }",
            "intersection { object { Piriform } box { -1.2, 1.2 } }",
            "intersection { object { Steiner_Surface } box { -1.2, 1.2 } }",
            "intersection { object { Quartic_Paraboloid scale 0.5 } box { -1.2, 1.2 } }",
            "intersection { object { Bicorn } box { -1.2, 1.2 } }",
        ],
        3,
        '#include "shapes.inc"\n#include "shapesq.inc"',  # POV-Ray's Helix needs shapes.inc
        _SURFACE,
    ),
    # the patterns strala draws (not Hex_Tiles_Ptrn, see README.md)
    "patterns": _pattern_gallery().replace(
        "Hex_Tiles_Ptrn() rotate -90*x", "Tiles_Ptrn() rotate 45*z"
    ),
}


@pytest.mark.povray
@needs_pov_includes
@pytest.mark.parametrize("gallery", sorted(_STRALA_GOLDEN))
def test_strala_renders_the_newer_files_like_povray(tmp_path, gallery):
    from conftest import image_errors, povray_image, strala_image

    scene = _STRALA_GOLDEN[gallery]
    ref = povray_image(scene, tmp_path, 120, 80)
    ours, messages = strala_image(scene, tmp_path, 120, 80)
    assert not [m for m in messages if "not supported" in m], messages
    rmse, off = image_errors(ours, ref)
    assert ref.std() > 0.05
    assert rmse < 0.01 and off < 0.005, (rmse, off)


# --------------------------------------------------------- files the macros write
_WRITING = """#version 3.7;
#include "shapes.inc"
#include "arrays.inc"
#declare Wavy = function (x, y, z) { 0.2*sin(6*x)*cos(5*z) }
HF_Square(Wavy, 0, 1, <4, 3>, 1, "square.inc", <-1, 0, -1>, <1, 0.5, 1>)
HF_Torus(Wavy, 1, 0, 3, 0, "torus.inc", 1, 0.3, 1)
#declare G = array[2][3] {{0, 0.5, 1}, {0.25, 0.75, 0.1}}
ARRAYS_WriteDF3(G, "g8.df3", 8)
#declare G3 = array[2][2][2] {{{0, 0.1}, {0.2, 0.3}}, {{0.4, 0.5}, {0.6, 1}}}
ARRAYS_WriteDF3(G3, "g16.df3", 16)
"""
_WRITTEN = ("square.inc", "torus.inc", "g8.df3", "g16.df3")


@pytest.mark.povray
@needs_pov_includes
def test_povray_writes_the_same_files_with_the_stdlib(tmp_path):
    # HF_* with a file name and ARRAYS_WriteDF3 write, byte for byte, what POV-Ray's write.
    written = []
    for with_stdlib in (False, True):
        folder = tmp_path / str(with_stdlib)
        folder.mkdir()
        run_povray(folder, _WRITING, with_stdlib=with_stdlib, size=(1, 1))
        written.append([(folder / f).read_bytes() for f in _WRITTEN])
    assert all(written[0]), "POV-Ray wrote an empty file"
    assert written[0] == written[1]


@pytest.mark.povray
@needs_pov_includes
def test_strala_writes_the_height_field_files_as_povray(tmp_path):
    # (not the df3 files: strala's #write has no uint8/uint16be yet). Compared without
    # white space: POV-Ray writes a space after each vector, strala does not (yet).
    scene = _WRITING.split("#declare G =")[0]
    for side in ("pov", "strala"):
        (tmp_path / side).mkdir()
    run_povray(tmp_path / "pov", scene, with_stdlib=False, size=(1, 1))
    (tmp_path / "strala" / "scene.pov").write_text(scene)
    assert errors(compile_file(tmp_path / "strala" / "scene.pov")) == []
    for name in ("square.inc", "torus.inc"):
        theirs = re.sub(r"\s+", "", (tmp_path / "pov" / name).read_text())
        ours = re.sub(r"\s+", "", (tmp_path / "strala" / name).read_text())
        numbers = re.compile(r"-?\d+(?:\.\d+)?(?:e[-+]?\d+)?")
        assert numbers.sub("#", ours) == numbers.sub("#", theirs), name
        got = [float(v) for v in numbers.findall(ours)]
        want = [float(v) for v in numbers.findall(theirs)]
        assert got == pytest.approx(want, rel=1e-6, abs=1e-6), name


# ----------------------------------------------------- rad_def.inc and debug.inc
@needs_pov_includes
@pytest.mark.parametrize("preset", range(11))
def test_rad_settings_give_povray_files_settings(tmp_path, preset):
    # strala evaluates POV-Ray's rad_def.inc and its own: the same radiosity settings.
    scene = tmp_path / "scene.pov"
    scene.write_text(
        '#version 3.7;\n#include "rad_def.inc"\n'
        f"global_settings {{ radiosity {{ Rad_Settings({preset}, on, off) }} }}\n"
    )
    results = [compile_file(scene, library_paths=lib) for lib in ((str(POV_INCLUDE),), ())]
    for result in results:
        assert errors(result) == []
    pov, ours = (r.scene.settings for r in results)
    assert differences(pov, ours, "settings") == []


_DEBUG_SCENE = """#version 3.7;
#include "debug.inc"
Debug_Message("one\\n")
Set_Debug(false)
Debug_Message("hidden\\n")
Set_Debug(true)
Debug((1 < 2), "two\\n")
Debug((2 < 1), "not this\\n")
Warning(yes, "three")
Error(no, "never")
Debug_Inc_Stack()
#ifdef (View_POV_Include_Stack) #debug "four\\n" #end
"""


@pytest.mark.povray
@needs_pov_includes
def test_debug_macros_print_what_povray_prints(tmp_path):
    from conftest import povray_debug

    scene = tmp_path / "scene.pov"
    scene.write_text(_DEBUG_SCENE)
    printed = povray_debug(scene)
    for shown in ("one", "two", "three", "four"):
        assert shown in printed
    for hidden in ("hidden", "not this", "never"):
        assert hidden not in printed
    messages = [d.message.strip() for d in compile_file(scene).diagnostics]
    assert [m for m in messages if m in ("one", "two", "three", "four")] == [
        "one", "two", "three", "four"
    ]  # fmt: skip
    assert not {"hidden", "not this", "never"} & set(messages)
