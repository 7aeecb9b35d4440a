"""The Python API (runtime.api): compile a file or a string, render to a numpy array with
the command line's options, and get the same pixels the command line writes."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from conftest import run_cli
from hypothesis import given, settings
from hypothesis import strategies as st

from runtime import api
from runtime.image import read_image

# A lit sphere on a grey background; `#version 3.7` with assumed_gamma 1: sRGB output.
SCENE = """#version 3.7;
global_settings { assumed_gamma 1 }
camera { location <0, 0, -5> look_at 0 }
light_source { <3, 4, -5>, rgb 1 }
background { rgb 0.2 }
sphere { 0, 1.2 pigment { rgb <1, 0.5, 0.2> } finish { phong 0.5 } }
"""


def srgb(v: float) -> float:
    return 12.92 * v if v <= 0.0031308 else 1.055 * v ** (1 / 2.4) - 0.055


def test_compile_string_gives_the_scene_and_its_warnings():
    compiled = api.compile_string(SCENE + "#declare Unused = 1;\n")
    assert len(compiled.scene.objects) == 1
    assert compiled.size == (320, 240)
    assert any("Unused" in d.message for d in compiled.warnings)


def test_errors_raise_with_every_diagnostic_and_its_position(tmp_path):
    path = tmp_path / "broken.pov"
    path.write_text("sphere { 0, 1 }\nsphere { 0, Nope }\nbox { 0, Nor }\n")
    with pytest.raises(api.CompileError) as info:
        api.compile_file(path)
    text = str(info.value)
    errors = [d for d in info.value.diagnostics if d.severity.value == "error"]
    assert text.startswith(f"{len(errors)} errors\n")
    assert {d.span.line for d in errors} == {2, 3}
    assert f"{path}:2:" in text and f"{path}:3:" in text
    assert "Nope" in text and "^" in text  # the caret display, as on the command line


def test_compile_string_errors_show_the_line_and_caret(tmp_path, monkeypatch):
    # the text given is the source shown, even where a file of that name holds other text
    monkeypatch.chdir(tmp_path)
    (tmp_path / "named.pov").write_text("// something else\n")
    for name in ("<string>", "named.pov"):
        with pytest.raises(api.CompileError) as info:
            api.compile_string("sphere { 0, 1 }\nsphere { 0, Nope }\n", filename=name)
        text = str(info.value)
        assert f"{name}:2:13: error" in text
        assert "    2 | sphere { 0, Nope }\n      |             ^~~~" in text


def test_a_missing_file_is_a_compile_error(tmp_path):
    with pytest.raises(api.CompileError, match="cannot read"):
        api.compile_file(tmp_path / "nowhere.pov")


def test_render_gives_display_values_of_the_right_shape():
    image = api.render(api.compile_string(SCENE), width=64, height=48)
    assert image.shape == (48, 64, 3) and image.dtype == np.float32
    assert 0.0 <= image.min() and image.max() <= 1.0
    assert np.allclose(image[0, 0], srgb(0.2), atol=1e-6)  # the background, sRGB-encoded
    centre = image[24, 32]
    assert centre[0] > centre[1] > centre[2] > 0.05  # the orange sphere, lit


def test_linear_output_undoes_the_display_encoding():
    compiled = api.compile_string(SCENE)
    linear = api.render(compiled, width=16, height=12, linear=True)
    assert np.allclose(linear[0, 0], 0.2, atol=1e-6)


def test_render_matches_the_command_line_pixel_for_pixel(tmp_path):
    scene = tmp_path / "scene.pov"
    scene.write_text(SCENE)
    out = tmp_path / "cli.png"
    proc = run_cli(
        "render", str(scene), "-W", "80", "-H", "60", "--aa", "0.3", "-o", str(out), "-q"
    )
    assert proc.returncode == 0, proc.stderr
    from_cli = read_image(out)[..., :3]
    ours = api.render(scene, width=80, height=60, aa=0.3)
    assert np.abs(ours - from_cli).max() <= 0.5 / 255 + 1e-6  # only the 8-bit rounding


def test_the_scene_sees_image_size_and_clock(tmp_path):
    text = "background { rgb <image_width / 100, image_height / 100, clock> }\n"
    compiled = api.compile_string("#version 3.7;\nglobal_settings { assumed_gamma 1 }\n" + text,
                                  width=50, height=25, clock=0.75)  # fmt: skip
    image = api.render(compiled, linear=True)  # the compiled size is the default
    assert image.shape == (25, 50, 3)
    assert np.allclose(image[0, 0], [0.5, 0.25, 0.75], atol=1e-6)
    path = tmp_path / "clocked.pov"
    path.write_text("#version 3.7;\nglobal_settings { assumed_gamma 1 }\n" + text)
    image = api.render(path, width=20, height=10, clock=0.5, linear=True)
    assert np.allclose(image[0, 0], [0.2, 0.1, 0.5], atol=1e-6)


def test_library_paths_are_searched_for_includes(tmp_path):
    lib = tmp_path / "lib"
    lib.mkdir()
    (lib / "mine.inc").write_text("#declare Mine = rgb <0, 1, 0>;\n")
    text = '#include "mine.inc"\nbackground { Mine }\n'
    with pytest.raises(api.CompileError):
        api.compile_string(text, filename=tmp_path / "scene.pov")
    compiled = api.compile_string(text, filename=tmp_path / "scene.pov", library_paths=[lib])
    assert np.allclose(api.render(compiled, width=4, height=3)[1, 1], [0, 1, 0])


def test_library_path_from_the_environment(tmp_path, monkeypatch):
    (tmp_path / "env.inc").write_text("#declare FromEnv = 1;\n")
    monkeypatch.setenv("STRALA_LIBRARY_PATH", str(tmp_path))
    api.compile_string('#include "env.inc"\nsphere { 0, FromEnv }\n')


def test_threads_do_not_change_the_image():
    compiled = api.compile_string(SCENE)
    one = api.render(compiled, width=300, height=20, threads=1)
    two = api.render(compiled, width=300, height=20, threads=2)
    assert np.array_equal(one, two)


def test_region_renders_part_of_the_image():
    compiled = api.compile_string(SCENE)
    whole = api.render(compiled, width=40, height=30)
    part = api.render(compiled, width=40, height=30, region=(10, 5, 30, 25))
    assert np.array_equal(part[5:25, 10:30], whole[5:25, 10:30])
    assert not part[:5].any() and not part[:, :10].any()


def test_render_frames_runs_the_clock_from_zero_to_one(tmp_path):
    path = tmp_path / "anim.pov"
    path.write_text(
        "#version 3.7;\nglobal_settings { assumed_gamma 1 }\nbackground { rgb clock }\n"
    )
    frames = list(api.render_frames(path, 1, 3, width=4, height=3, linear=True))
    assert [t for t, _ in frames] == [0.0, 0.5, 1.0]
    assert [float(img[0, 0, 0]) for _, img in frames] == pytest.approx([0.0, 0.5, 1.0])


def test_save_image_writes_what_render_returned(tmp_path):
    image = api.render(api.compile_string(SCENE), width=32, height=24)
    api.save_image(tmp_path / "out.png", image)
    back = read_image(tmp_path / "out.png")[..., :3]
    assert np.abs(back - image).max() <= 0.5 / 255 + 1e-6
    with pytest.raises(ValueError, match="cannot write"):
        api.save_image(tmp_path / "out.bmpx", image)


@pytest.mark.parametrize(
    "options", [{"width": 0}, {"height": -2}, {"aa": 4.0}, {"aa_depth": 0}, {"aa_depth": 10}]
)
def test_bad_options_raise_value_errors(options):
    with pytest.raises(ValueError):
        api.render(api.compile_string(SCENE), **options)


@settings(max_examples=8)
@given(st.integers(1, 24), st.integers(1, 24), st.sampled_from([None, 0.3]))
def test_any_size_gives_that_shape(width, height, aa):
    image = api.render(api.compile_string(SCENE), width=width, height=height, aa=aa)
    assert image.shape == (height, width, 3)
    assert np.isfinite(image).all()


def test_the_api_module_is_documented_in_the_readme():
    readme = (Path(__file__).resolve().parent.parent / "README.md").read_text()
    assert "from runtime import api" in readme
