"""The seed's radiosity examples render as the seed describes them."""

from __future__ import annotations

from pathlib import Path

import pytest

from lang.evaluate import compile_source
from runtime.render import render_scene

EXAMPLES = Path(__file__).resolve().parent.parent / "examples"


def test_white_object_in_a_red_room_turns_reddish():
    # The example as it is, with a smaller patch budget to keep the test quick.
    text = (EXAMPLES / "red_room.scene").read_text()
    assert "radiosity { converged on }" in text
    text = text.replace("radiosity { converged on }", "radiosity { converged on max_patches 800 }")
    result = compile_source(text, str(EXAMPLES / "red_room.scene"))
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


def test_cornell_room_renders_from_the_command_line(tmp_path):
    """The Cornell-style room through `strala render` (small): no errors or warnings, the
    panel shows its emission, the walls their colours, and the white tall box, turned
    toward the red wall, is reddened by it (colour bleeding needs the interreflection)."""
    import OpenImageIO as oiio
    from conftest import run_cli

    # The example as it is, with a smaller patch budget to keep the test quick.
    text = (EXAMPLES / "cornell.scene").read_text()
    assert "radiosity { converged on }" in text
    scene = tmp_path / "cornell.scene"
    scene.write_text(text.replace("radiosity { }", "radiosity { max_patches 1000 }"))
    out = tmp_path / "cornell.exr"
    proc = run_cli("render", str(scene), "-W", "48", "-H", "48", "-o", str(out))
    assert proc.returncode == 0, proc.stderr
    assert "warning" not in proc.stderr and "error" not in proc.stderr
    img = oiio.ImageBuf(str(out)).get_pixels(oiio.FLOAT)[..., :3]
    assert img[2, 24] == pytest.approx([14.0, 12.0, 9.0], rel=1e-4)  # the panel
    red_wall, green_wall, tall_box = img[24, 3], img[24, 44], img[24, 15]
    assert red_wall[0] > 3 * red_wall[1] and green_wall[1] > 2 * green_wall[0]
    assert tall_box[0] > 1.5 * tall_box[1] > 0


@pytest.mark.parametrize(("radiosity", "loaded"), [("", False), ("radiosity { count 35 }", True)])
def test_the_solver_is_loaded_only_for_scenes_that_ask_for_it(radiosity, loaded):
    """Without `radiosity {}` no module of runtime.radiosity is imported or run."""
    import subprocess
    import sys

    scene = (
        f"global_settings {{ {radiosity} }} camera {{ location <0, 1, -3> look_at 0 }}"
        "light_source { <2, 4, -3>, 1 } box { -1, 1 pigment { rgb 1 } }"
        "plane { y, -1 pigment { rgb 0.5 } }"
    )
    code = (
        "import sys; from runtime import api;"
        f"img = api.render(api.compile_string({scene!r}), width=8, height=6);"
        "print(img.shape, sorted(m for m in sys.modules if m.startswith('runtime.radiosity')))"
    )
    root = EXAMPLES.parent
    proc = subprocess.run([sys.executable, "-c", code], cwd=root, capture_output=True,
                          text=True, timeout=300)  # fmt: skip
    assert proc.returncode == 0, proc.stderr
    shape, _, modules = proc.stdout.strip().partition(") ")
    assert shape == "(6, 8, 3"
    assert (modules != "[]") == loaded, proc.stdout
