"""The stone include files (stdlib/stones.inc, stones1.inc, stones2.inc, stoneold.inc)
against POV-Ray 3.7's.

Oracles (each skipped where POV-Ray or its include files are not installed):
- POV-Ray's files evaluated by strala: every texture and colour equal, layer by layer
  (tests/test_stdlib.py's test_stdlib_matches_povray_include; the layered-texture part of
  its comparison is checked here to see a difference in any layer).
- POV-Ray itself rendering every stone texture once with its own files and once with
  strala's: the very same pixels. (One render thread: `crand` grain is drawn from a
  random stream that several threads share out differently from one run to the next.)
- strala's own render of a few stones against POV-Ray's (tolerant, stated below).
"""

from __future__ import annotations

import dataclasses
import re

import pytest
from test_stdlib import (
    POV_INCLUDE,
    STDLIB,
    compile_text,
    differences,
    errors,
    needs_pov_includes,
    povray_both_ways,
)

from lang import ir, paths, values

_STONE_FILES = ("stones1.inc", "stones2.inc", "stoneold.inc")
_TEXTURE = re.compile(r"#declare\s+(\w+)\s*=\s*texture\b")
_CELL = 24  # pixels per gallery sphere


def _stone_textures() -> list[str]:
    """Every texture POV-Ray's stone files declare, in file order."""
    names: list[str] = []
    for name in _STONE_FILES:
        text = re.sub(r"//[^\n]*", "", (POV_INCLUDE / name).read_text())
        text = re.sub(r"/\*.*?\*/", "", text, flags=re.S)
        names += [n for n in _TEXTURE.findall(text) if n not in names]
    return names


def _gallery(names: list[str], columns: int = 16) -> str:
    """Each texture on its own sphere in a grid over a checkered wall (which the clear
    parts of the layers show)."""
    rows = -(-len(names) // columns)
    centre = f"<{(columns - 1) / 2}, {-(rows - 1) / 2}, 0>"
    lines = [
        "#version 3.7;",
        "global_settings { assumed_gamma 1.0 }",
        '#include "colors.inc"',  # POV-Ray's stones1.inc and stones2.inc need it first
        '#include "stones.inc"',
        '#include "stoneold.inc"',
        f"camera {{ orthographic location {centre} - 20*z look_at {centre} "
        f"right {columns}*x up {rows}*y }}",
        "light_source { <-20, 30, -40> rgb 1 }",
        "plane { z, 1 pigment { checker rgb 1, rgb <0.2, 0.3, 0.8> scale 0.5 } }",
    ]
    for i, name in enumerate(names):
        place = f"<{i % columns}, {-(i // columns)}, 0>"
        lines.append(f"sphere {{ {place}, 0.45 texture {{ {name} }} }}")
    return "\n".join(lines) + "\n"


@pytest.mark.povray
@needs_pov_includes
def test_povray_renders_every_stone_exactly_like_its_own(tmp_path):
    # Independent of strala's evaluator: all 164 stone textures of the four files.
    names = _stone_textures()
    assert len(names) == 83 + 20 + 61  # stones1 (not g1..g4), stones2, stoneold
    size = (16 * _CELL, -(-len(names) // 16) * _CELL)
    theirs, ours = povray_both_ways(tmp_path, _gallery(names), size, options=("+WT1",))
    assert theirs.std() > 10
    changed = abs(theirs - ours).max(axis=2)
    cells = {(y // _CELL) * 16 + x // _CELL for y, x in zip(*changed.nonzero(), strict=True)}
    assert changed.max() == 0, [names[c] for c in sorted(cells) if c < len(names)][:20]


def test_strala_builds_the_stone_gallery(tmp_path):
    if not (POV_INCLUDE / "stones1.inc").exists():
        names = ["T_Stone1", "T_Stone44", "Grnt0"]
    else:
        names = _stone_textures()
    result = compile_text(tmp_path, _gallery(names))
    assert errors(result) == []
    assert result.scene is not None and len(result.scene.objects) == len(names) + 1


def test_stones_inc_brings_both_halves_and_no_scratch_names(tmp_path):
    result = compile_text(tmp_path, '#include "stones.inc"\n#include "stoneold.inc"\n')
    assert errors(result) == []
    sym = result.symbols
    for name in ("T_Grnt0", "T_Grnt24a", "T_Crack4", "T_Stone24", "T_Stone25", "T_Stone44"):
        assert isinstance(sym[name], ir.Texture), name
    assert len(sym["T_Stone8"].layers) == 2 and len(sym["T_Stone25"].layers) == 2
    assert differences(sym["Stone8"], sym["T_Stone8"]) == []
    assert differences(sym["Grnt2a"], sym["T_Grnt2a"]) == []
    assert sym["g4"].rgbft == pytest.approx((0.03, 0.18, 0.08, 0.0, 0.0))
    # the files' working values are #local: none is left in the scene (their macros are)
    scratch = [n for n in sym if n.startswith("Strala_") and not n.endswith("_Inc")]
    assert [n for n in scratch if not isinstance(sym[n], values.MacroValue)] == []
    # nor does stones1.inc bring colors.inc's names along
    assert "White" not in sym and "Clear" not in sym


def test_layered_textures_are_compared_layer_by_layer(tmp_path):
    # The value oracle must see a change in any layer, down to one colour of one map.
    stone = compile_text(tmp_path, '#include "stones2.inc"\n').symbols["T_Stone25"]
    top = stone.layers[-1]
    (pos, colour), *rest = top.pigment.color_map
    changed_map = ((pos, (colour[0] + 0.001, *colour[1:])), *rest)
    changed_top = dataclasses.replace(
        top, pigment=dataclasses.replace(top.pigment, color_map=changed_map)
    )
    changed = dataclasses.replace(stone, layers=(*stone.layers[:-1], changed_top))
    assert differences(stone, stone, "T_Stone25") == []
    (found,) = differences(stone, changed, "T_Stone25")
    assert found.startswith("T_Stone25.layers[1].pigment.color_map[0][1]")
    dropped = dataclasses.replace(stone, layers=stone.layers[:-1])
    assert differences(stone, dropped, "T_Stone25")


def test_stones_come_from_the_stdlib_before_povrays_folder(tmp_path):
    # Even with POV-Ray's include folder named by -L, strala's own stone files are read.
    for name in ("stones.inc", *_STONE_FILES):
        found = paths.find(name, tmp_path, [str(POV_INCLUDE)])
        assert found is not None and found.kind == "stdlib", name
        assert found.path == str((STDLIB / name).resolve())


# ---------------------------------- strala renders the stones as POV-Ray does (tolerant)
_STRALA_STONES = (
    "T_Grnt0",
    "T_Grnt25",
    "T_Stone1",
    "T_Stone4",
    "T_Stone13",
    "T_Stone25",
    "T_Stone31",
    "T_Stone36",
    "T_Stone40",
    "T_Stone44",
)


@pytest.mark.povray
@needs_pov_includes
def test_strala_renders_stones_like_povray(tmp_path):
    from conftest import strala_against_povray

    scene = _gallery(list(_STRALA_STONES), columns=5)
    rmse, off, ref = strala_against_povray(scene, tmp_path, 150, 60)
    assert ref.std() > 0.05
    # granite, crackle, agate, onion and wrinkles layers as POV-Ray draws them
    assert rmse < 0.01 and off < 0.005, (rmse, off)  # measured 0.0024 and 0
