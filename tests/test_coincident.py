"""Boxes whose faces coincide in different textures get a located warning: POV-Ray's pick
between the two tied hits varies from pixel to pixel, strala's does not."""

from __future__ import annotations

import pytest

from lang import ir
from lang.eval.coincident import coincident_faces
from lang.evaluate import compile_source


def warnings_of(text: str) -> list:
    result = compile_source(text, "scene.pov")
    assert result.scene is not None
    return [d for d in result.diagnostics if d.code == "W0315"]


BOARD = """#version 3.7;
camera {{ location <0, 5, -8> {camera} look_at 0 }}
#declare Square = box {{ -1, 1 pigment {{ rgb <0.3, 0.1, 0> }} translate <-1, -1, 1> }}
union {{
  object {{ Square }}
  object {{ Square translate <2, 0, 0> }}
  box {{ <-4, -0.5, -4>, <4, 0, 4> {board} }}
  pigment {{ rgb <0.8, 0.7, 0.3> }}
}}
"""


def test_squares_sunk_into_a_board_flush_with_its_top_are_named():
    (w,) = warnings_of(BOARD.format(board="", camera=""))
    # at the first square (line 5), naming the board's box (line 7) and the plane
    assert (w.span.line, w.span.col) == (5, 3)
    assert "scene.pov:7:" in w.message and "y = 0" in w.message
    assert "and 1 more pairs" in w.message
    assert "move one surface" in w.hint


@pytest.mark.parametrize(
    "board",
    [
        "translate 0.001*y",  # the board's top above the squares': no tie
        "pigment { rgb <0.3, 0.1, 0> }",  # both one texture: either pick looks the same
    ],
)
def test_no_warning_without_a_visible_tie(board):
    assert warnings_of(BOARD.format(board=board, camera="")) == []


def test_faces_looking_away_from_the_camera_are_not_named():
    # from below the board, its top faces (and the squares') are out of sight
    assert warnings_of(BOARD.format(board="", camera="translate -10*y")) == []


def test_boxes_touching_face_to_face_or_turned_are_not_named():
    touching = """box { 0, 1 pigment { rgb 1 } } box { <1, 0, 0>, <2, 1, 1> pigment { rgb 0 } }"""
    assert warnings_of(touching) == []  # their shared face points opposite ways
    turned = """box { 0, 1 pigment { rgb 1 } rotate 30*y }
box { <0, 0, 0>, <0.5, 1, 0.5> pigment { rgb 0 } rotate 30*y }"""
    assert warnings_of(turned) == []  # not compared: turned faces rarely tie exactly
    cut = """difference { box { 0, 1 pigment { rgb 1 } } box { <0.2, 0.2, 0.5>, <0.8, 0.8, 1>
  pigment { rgb 0 } } }"""
    assert warnings_of(cut) == []  # CSG that cuts surfaces away is left alone


def test_many_flush_boxes_are_checked_quickly():
    """A 60 x 60 grid of tiles on one plane: the sweep meets neighbours only."""
    import time

    tiles = "camera { location <30, 20, -10> look_at <30, 0, 30> }\n" + "\n".join(
        f"box {{ <{i}, -1, {j}>, <{i + 1}, 0, {j + 1}> pigment {{ rgb {(i + j) % 2} }} }}"
        for i in range(60)
        for j in range(60)
    )
    start = time.perf_counter()
    assert warnings_of(tiles) == []  # neighbours touch along edges only
    board = tiles + "\nbox { <0, -2, 0>, <60, 0, 60> pigment { rgb 0.5 } }"
    (w,) = warnings_of(board)  # the tiles' tops on the board's top
    assert "(and 999+ more pairs)" in w.message  # the search stops at 1000 pairs
    assert time.perf_counter() - start < 60


@pytest.mark.parametrize("far", ["scale <1, 1, 1e300> scale 1e300", "scale <1, 1, 0>"])
def test_boxes_out_to_infinity_or_flattened_are_left_alone(far):
    """A box whose bounds overflow (or a degenerate scale) is no face to tie with: no
    warning and no crash (a hypothesis mutant of a scene found the NaN)."""
    text = BOARD.format(board="", camera="") + f"box {{ -1, 1 pigment {{ rgb 1 }} {far} }}\n"
    result = compile_source(text, "scene.pov")
    assert not [d for d in result.diagnostics if d.code.startswith("E0000")]


def _boxes(corners) -> tuple[ir.Object, ...]:
    return tuple(ir.Object(shape=ir.Box(lo, hi)) for lo, hi in corners)


def test_faces_in_a_row_are_swept_along_the_row():
    """The fuzzing job's hang (seed 221, a mutated parallel_lights.pov whose #while ran to
    the budget): 20,000 boxes alike in x and y, in a row along z. Swept along y, each face
    met every other (2e8 pairs: 71 s for `check`); along z, its neighbours only."""
    row = _boxes(((0, 50, z), (40, 50.5, z + 3)) for z in range(0, 8 * 20000, 8))
    assert coincident_faces(row, most=100_000) == ([], False)  # done within 100,000 looks


def test_boxes_stacked_in_one_place_stop_the_search_early():
    """Every one of them overlaps every other: the search stops after MAX_LOOKS pairs of
    faces (said as `N+ more pairs`), never minutes."""
    import time

    one = ((0.0, 0.0, 0.0), (1.0, 1.0, 1.0))
    stack = _boxes([one] * 20000)
    start = time.perf_counter()
    pairs, stopped = coincident_faces(stack)
    assert pairs == [] and stopped  # one texture: no pair to name, and not all looked at
    assert time.perf_counter() - start < 30  # about 1 s; 2e8 pairs were minutes
    white = ir.Texture(pigment=ir.Pigment(color=ir.WHITE))
    two = (ir.Object(shape=ir.Box(*one), texture=white), *stack)
    pairs, stopped = coincident_faces(two, most=50_000)
    assert stopped and pairs and all(first is two[0] for first, _, _, _ in pairs)
