"""Where includes are found (lang.paths): the including file's folder, the library folders
in order, strala's stdlib, then POV-Ray's installed include folder, for the files strala's
stdlib does not have (ash.map, fonts …); a miss names every folder it searched."""

from __future__ import annotations

import shutil
import subprocess
from pathlib import Path

import numpy as np
import OpenImageIO as oiio
import pytest

from lang import paths
from lang.evaluate import compile_source
from runtime import api


@pytest.fixture
def povray_folder(tmp_path, monkeypatch):
    """A stand-in for POV-Ray's installed include folder."""
    folder = tmp_path / "povray-include"
    folder.mkdir()
    (folder / "colors.inc").write_text("#declare From_Povray = 1;\n")
    (folder / "only_povray.inc").write_text("#declare Only_Povray = 2;\n")
    monkeypatch.setattr(paths, "POVRAY_INCLUDE_FOLDERS", (tmp_path / "missing", folder))
    paths.povray_include.cache_clear()
    yield folder
    paths.povray_include.cache_clear()


def test_search_order(povray_folder, tmp_path):
    scene = tmp_path / "scene"
    lib = tmp_path / "lib"
    scene.mkdir()
    lib.mkdir()
    kinds = [k for k, _ in paths.search_folders(scene, [str(lib)])]
    assert kinds == ["local", "library", "stdlib", "povray"]
    (lib / "x.inc").write_text("")
    (scene / "x.inc").write_text("")
    assert paths.find("x.inc", scene, [str(lib)]).kind == "local"
    assert paths.find("x.inc", tmp_path, [str(lib)]).kind == "library"
    # strala's stdlib is written for strala: it wins over POV-Ray's file of the same name
    assert paths.find("colors.inc", scene, []).kind == "stdlib"
    found = paths.find("only_povray.inc", scene, [])
    assert found.kind == "povray" and Path(found.path).parent == povray_folder.resolve()


def test_the_scene_folder_comes_after_the_including_files(povray_folder, tmp_path):
    scene, lib = tmp_path / "scene", tmp_path / "lib"
    scene.mkdir()
    lib.mkdir()
    kinds = [k for k, _ in paths.search_folders(lib, [str(lib)], scene)]
    assert kinds == ["local", "scene", "stdlib", "povray"]  # lib met twice: searched once
    (scene / "x.inc").write_text("")
    assert paths.find("x.inc", lib, [], scene=scene).kind == "scene"
    (lib / "x.inc").write_text("")
    assert paths.find("x.inc", lib, [], scene=scene).kind == "local"


def test_an_include_file_finds_a_file_of_the_scenes_folder(povray_folder, tmp_path):
    # POV-Ray looks for names where it runs (the scene's folder), so a library macro can
    # #include a file the scene wrote or holds: meshmaker.inc's macros read their meshes back.
    lib = tmp_path / "lib"
    lib.mkdir()
    (lib / "reader.inc").write_text('#macro Read() #include "data.inc" #end\n')
    (tmp_path / "data.inc").write_text("#declare From_Scene = 3;\n")
    r = compile_source('#include "reader.inc"\nRead()\n', str(tmp_path / "s.pov"), [str(lib)])
    assert not [d for d in r.diagnostics if d.code == "E0220"]
    assert r.symbols["From_Scene"] == 3.0


@pytest.mark.parametrize("name", ["chars.inc", "makegrass.inc", "meshmaker.inc"])
def test_the_stdlib_mesh_files_come_before_povrays_even_when_named(tmp_path, name):
    installed = Path("/usr/share/povray-3.7/include")
    if not (installed / name).is_file():
        pytest.skip("POV-Ray's include files are not installed")
    found = paths.find(name, tmp_path, [str(installed)])
    assert found is not None and found.kind == "stdlib"
    assert Path(found.path).parent == paths.STDLIB.resolve()


def test_no_povray_folder_is_searched_where_none_is_installed(tmp_path, monkeypatch):
    monkeypatch.setattr(paths, "POVRAY_INCLUDE_FOLDERS", (tmp_path / "none",))
    paths.povray_include.cache_clear()
    try:
        assert [k for k, _ in paths.search_folders(tmp_path, [])] == ["local", "stdlib"]
    finally:
        paths.povray_include.cache_clear()


def test_povrays_folder_can_be_left_out(povray_folder, tmp_path, monkeypatch):
    monkeypatch.setenv("STRALA_POVRAY_INCLUDE", "off")
    paths.povray_include.cache_clear()
    assert [k for k, _ in paths.search_folders(tmp_path, [])] == ["local", "stdlib"]


def test_a_scene_reads_what_only_povray_has(povray_folder):
    r = compile_source('#include "only_povray.inc"\n#declare X = Only_Povray;\n', "s.pov")
    assert r.symbols["X"] == 2.0
    assert "From_Povray" not in r.symbols  # colors.inc came from the stdlib


def test_a_miss_names_every_folder_searched(povray_folder, tmp_path):
    lib = tmp_path / "lib"
    lib.mkdir()
    r = compile_source('#include "nowhere.inc"\n', str(tmp_path / "s.pov"), [str(lib)])
    (d,) = [d for d in r.diagnostics if d.code == "E0220"]
    assert d.hint == f"searched {tmp_path}, {lib}, {paths.STDLIB}, {povray_folder}"


@pytest.mark.povray
def test_stdlib_woods_and_stones_render_as_povray(tmp_path):
    if shutil.which("povray") is None or paths.povray_include() is None:
        pytest.skip("POV-Ray and its include files are not installed")
    scene = tmp_path / "w.pov"
    scene.write_text(
        '#version 3.7;\nglobal_settings { assumed_gamma 1 }\n#include "colors.inc"\n'
        '#include "woods.inc"\n#include "stones.inc"\n'
        "camera { location <0, 0, -4> look_at 0 }\nlight_source { <2, 4, -3>, rgb 1 }\n"
        "sphere { <-1.1, 0, 0>, 1 texture { T_Wood10 } }\n"
        "sphere { <1.1, 0, 0>, 1 texture { T_Stone8 } }\n"
    )
    subprocess.run(
        ["povray", f"+I{scene}", "+W80", "+H60", "-D", "-V", "+Opov.png"],
        cwd=tmp_path,
        capture_output=True,
        timeout=120,
        check=True,
    )
    theirs = oiio.ImageBuf(str(tmp_path / "pov.png")).get_pixels()
    ours = api.render(str(scene), width=80, height=60)
    diff = np.abs(np.asarray(theirs, dtype=np.float64) - ours)
    assert float(np.sqrt((diff**2).mean())) < 0.02  # RMSE, 8-bit PNG against strala's float
    assert float((diff.max(axis=2) > 0.1).mean()) < 0.03
