"""The seed's radiosity examples render as the seed describes them."""

from __future__ import annotations

from pathlib import Path

from lang.evaluate import compile_file, compile_source
from runtime.render import render_scene

EXAMPLES = Path(__file__).resolve().parent.parent / "examples"


def test_white_object_in_a_red_room_turns_reddish():
    result = compile_file(str(EXAMPLES / "red_room.scene"))
    assert result.scene is not None and result.scene.settings.radiosity is not None
    img = render_scene(result.scene, 80, 60)
    r, g, b = img[38, 40]  # the white sphere's centre (pigment rgb 0.8 on every channel)
    assert r > 1.5 * g and r > 1.5 * b, (r, g, b)


def test_egg_compiles_with_and_without_radiosity():
    for flag in (0, 1):
        text = (EXAMPLES / "egg.scene").read_text()
        text = text.replace("#ifndef (Radiosity) #declare Radiosity = 1; #end",
                            f"#declare Radiosity = {flag};")  # fmt: skip
        result = compile_source(text, str(EXAMPLES / "egg.scene"))
        assert result.scene is not None
        assert (result.scene.settings.radiosity is not None) == bool(flag)
