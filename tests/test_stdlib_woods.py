"""The wood include files (stdlib/woods.inc, stdlib/woodmaps.inc) against POV-Ray 3.7.

Oracles (each skipped where POV-Ray or its include files are not installed):
- POV-Ray itself renders every wood texture, grain pigment and colour map once with its own
  include files and once with strala's: the very same pixels (independent of strala's
  evaluator). test_stdlib.py compares the values, evaluated by strala, to 1e-9.
- strala renders the same gallery close to what POV-Ray renders with its own files.
"""

from __future__ import annotations

import re

import pytest
from test_stdlib import POV_INCLUDE, compile_text, errors, needs_pov_includes, povray_both_ways

_DECLARED = re.compile(r"#declare\s+(\w+)\s*=\s*(texture|pigment|colou?r_map)\b")
_COLUMNS = 16
_CELL = 24  # pixels per gallery sphere


def _declared(name: str) -> list[tuple[str, str]]:
    """(name, block type) of what POV-Ray's include file `name` declares, in its order."""
    text = re.sub(r"/\*.*?\*/", "", (POV_INCLUDE / name).read_text(), flags=re.S)
    text = re.sub(r"//[^\n]*", "", text)
    return [(m.group(1), m.group(2)) for m in _DECLARED.finditer(text)]


def _cells() -> list[str]:
    """What each gallery sphere wears: every texture, pigment and colour map of the two files."""
    wear = {
        "texture": "texture {{ {} }}",
        "pigment": "pigment {{ {} }}",
        "color_map": "pigment {{ wood color_map {{ {} }} scale 0.3 }}",
        "colour_map": "pigment {{ wood color_map {{ {} }} scale 0.3 }}",
    }
    blocks = _declared("woods.inc") + _declared("woodmaps.inc")
    # a few degrees about x make the grain run in long curves, as real boards show it
    return [f"{wear[kind].format(name)} rotate <3, 40, 0>" for name, kind in blocks]


def _gallery(cells: list[str], columns: int = _COLUMNS) -> str:
    rows = -(-len(cells) // columns)
    centre = f"<{(columns - 1) / 2}, {-(rows - 1) / 2}, 0>"
    lines = [
        "#version 3.7;",
        "global_settings { assumed_gamma 1.0 }",
        '#include "woods.inc"',
        f"camera {{ orthographic location {centre} - 20*z look_at {centre} "
        f"right {columns}*x up {rows}*y }}",
        "light_source { <-20, 30, -40> rgb 1 }",
        "background { rgb <0.1, 0.2, 0.3> }",
    ]
    for i, cell in enumerate(cells):
        lines.append(f"sphere {{ 0, 0.47 {cell} translate <{i % columns}, {-(i // columns)}, 0> }}")
    return "\n".join(lines) + "\n"


@pytest.mark.povray
@needs_pov_includes
def test_povray_renders_the_stdlib_woods_exactly_like_its_own(tmp_path):
    cells = _cells()
    assert len(cells) == 35 + 38 + 38  # textures, grain pigments, colour maps
    size = (_COLUMNS * _CELL, -(-len(cells) // _COLUMNS) * _CELL)
    theirs, ours = povray_both_ways(tmp_path, _gallery(cells), size)
    assert theirs.std() > 10  # the gallery shows something
    changed = abs(theirs - ours).max(axis=2)
    spots = {(y // _CELL) * _COLUMNS + x // _CELL for y, x in zip(*changed.nonzero(), strict=True)}
    assert changed.max() == 0, [cells[c] for c in sorted(spots) if c < len(cells)][:10]


def test_strala_builds_the_woods_gallery(tmp_path):
    cells = _cells() if (POV_INCLUDE / "woods.inc").exists() else []
    if not cells:  # without POV-Ray's file to list them, the textures by name
        cells = [f"texture {{ T_Wood{i} }}" for i in range(1, 36)]
    result = compile_text(tmp_path, _gallery(cells))
    assert errors(result) == []
    assert result.scene is not None and len(result.scene.objects) == len(cells)
    assert not [d for d in result.diagnostics if "not supported" in d.message]


@pytest.mark.povray
@needs_pov_includes
def test_strala_renders_the_woods_like_povray(tmp_path):
    # the whole gallery, strala with its stdlib against POV-Ray with its own files
    # (measured: RMSE 0.0014, 0.02% of pixels off by more than 0.1)
    from conftest import strala_against_povray

    cells = _cells()
    size = (_COLUMNS * _CELL, -(-len(cells) // _COLUMNS) * _CELL)
    rmse, off, ref = strala_against_povray(_gallery(cells), tmp_path, *size)
    assert ref.std() > 0.05
    assert rmse < 0.01 and off < 0.003, (rmse, off)
