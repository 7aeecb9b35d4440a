"""Where `#include` finds its files (lang/paths.py): the including file's folder, -L, the
`Library_Path` of the INI file POV-Ray reads by default ($POVINI, ./povray.ini,
~/.povray/3.7/povray.ini, the system one: the first that exists), $STRALA_LIBRARY_PATH,
strala's stdlib, then POV-Ray's installed include folder, with every folder inside POV-Ray's
installation after the stdlib (tests/test_paths.py has the search without INI files, and
strala's woods.inc and stones.inc rendered through it)."""

from __future__ import annotations

import shutil
import subprocess
from pathlib import Path

import pytest

from lang import paths
from runtime import api


@pytest.fixture
def place(tmp_path, monkeypatch) -> Path:
    """A machine of its own: no $POVINI, a home, a current folder and POV-Ray folders in
    tmp_path (so the real system's povray.ini and include folder play no part)."""
    for name in ("work", "home", "etc", "share/include", "scenes"):
        (tmp_path / name).mkdir(parents=True)
    (tmp_path / "share" / "include" / "colors.inc").write_text("#declare Theirs = 1;\n")
    monkeypatch.delenv("POVINI", raising=False)
    monkeypatch.delenv(paths.LIBRARY_PATH_VARIABLE, raising=False)
    monkeypatch.delenv("STRALA_POVRAY_INCLUDE", raising=False)
    monkeypatch.setenv("HOME", str(tmp_path / "home"))
    monkeypatch.chdir(tmp_path / "work")
    monkeypatch.setattr(paths, "POVRAY_CONF_DIRS", (tmp_path / "etc",))
    monkeypatch.setattr(paths, "POVRAY_OLD_CONF_DIRS", ())
    monkeypatch.setattr(paths, "POVRAY_SHARE_DIRS", (tmp_path / "share",))
    monkeypatch.setattr(paths, "POVRAY_INCLUDE_FOLDERS", (tmp_path / "share" / "include",))
    paths.povray_include.cache_clear()
    yield tmp_path
    paths.povray_include.cache_clear()


def _library(root: Path, name: str, value: float) -> Path:
    """A folder holding which.inc, which declares Which = value."""
    folder = root / name
    folder.mkdir()
    (folder / "which.inc").write_text(f"#declare Which = {value};\n")
    return folder


def _which(place: Path, library_paths=()) -> float:
    """The value of Which in a scene (in its own folder) that includes which.inc."""
    scene = place / "scenes" / "scene.pov"
    scene.write_text('#include "which.inc"\nsphere { 0, Which }\n')
    compiled = api.compile_file(scene, library_paths=library_paths)
    (sphere,) = compiled.scene.objects
    return sphere.shape.radius


def test_the_current_folders_povray_ini_names_library_folders(place):
    lib = _library(place, "lib", 2)
    (place / "work" / "povray.ini").write_text(f'Width=64\nLibrary_Path="{lib}"\n')
    assert _which(place) == 2


def test_povini_names_the_ini_file_and_wins_over_the_current_folders(place, monkeypatch):
    # POV-Ray reads one INI file by default, the first that exists: $POVINI first
    a, b = _library(place, "a", 1), _library(place, "b", 2)
    (place / "a.ini").write_text(f"Library_Path={a}\n")
    (place / "work" / "povray.ini").write_text(f"Library_Path={b}\n")
    monkeypatch.setenv("POVINI", str(place / "a.ini"))
    assert _which(place) == 1


def test_the_users_and_then_the_system_ini_file(place):
    a, b = _library(place, "a", 1), _library(place, "b", 2)
    (place / "etc" / "povray.ini").write_text(f"Library_Path={b}\n")
    assert _which(place) == 2
    user = place / "home" / ".povray" / "3.7"
    user.mkdir(parents=True)
    (user / "povray.ini").write_text(f"+L{a}\n")
    assert _which(place) == 1


def test_the_command_lines_folders_come_before_the_ini_files(place):
    a, b = _library(place, "a", 1), _library(place, "b", 2)
    (place / "work" / "povray.ini").write_text(f"Library_Path={a}\n")
    assert _which(place, library_paths=[b]) == 2


def test_the_scenes_folder_comes_first(place):
    lib = _library(place, "lib", 2)
    (place / "scenes" / "which.inc").write_text("#declare Which = 3;\n")
    assert _which(place, library_paths=[lib]) == 3


def test_the_not_found_message_lists_every_folder_in_order(place, monkeypatch):
    given, from_ini, from_env = (place / n for n in ("given", "from_ini", "from_env"))
    (place / "work" / "povray.ini").write_text(f"Library_Path={from_ini}\n")
    monkeypatch.setenv(paths.LIBRARY_PATH_VARIABLE, str(from_env))
    scene = place / "scenes" / "scene.pov"
    scene.write_text('#include "nowhere.inc"\n')
    with pytest.raises(api.CompileError) as caught:
        api.compile_file(scene, library_paths=[given])
    (error,) = [d for d in caught.value.diagnostics if d.code == "E0220"]
    assert "include file `nowhere.inc` not found" in error.message
    folders = [place / "scenes", given, from_ini, from_env, paths.STDLIB, place / "share/include"]
    assert error.hint == "searched " + ", ".join(str(f) for f in folders)


def test_the_stdlib_wins_over_povrays_own_files(place):
    povray = place / "share" / "include"
    (povray / "only_theirs.inc").write_text("#declare Theirs = 1;\n")
    # named by -L, by POV-Ray's INI file, or the folder of one of POV-Ray's files: after ours
    (place / "etc" / "povray.ini").write_text(f"Library_Path={povray}\n")
    # (a file of POV-Ray's finds the one beside it in its own folder, searched last)
    cases = ((place / "scenes", [str(povray)], "povray"), (povray, [], "local"))
    for folder, libraries, kind in cases:
        found = paths.find("colors.inc", folder, paths.library_paths(libraries))
        assert found is not None and found.kind == "stdlib"
        assert found.path == str(paths.STDLIB / "colors.inc")
        found = paths.find("only_theirs.inc", folder, paths.library_paths(libraries))
        assert found is not None and found.kind == kind
        assert found.path == str(povray / "only_theirs.inc")


def test_a_users_library_folder_wins_over_the_stdlib(place):
    mine = place / "mine"
    mine.mkdir()
    (mine / "colors.inc").write_text("#declare Mine = 1;\n")
    found = paths.find("colors.inc", place / "scenes", paths.library_paths([mine]))
    assert found is not None and found.path == str(mine / "colors.inc")


def test_povray_include_off_leaves_the_folders_povrays_ini_names_out(place, monkeypatch):
    povray = place / "share" / "include"
    (povray / "only_theirs.inc").write_text("#declare Theirs = 1;\n")
    mine = _library(place, "mine", 4)
    (place / "etc" / "povray.ini").write_text(f"Library_Path={povray}\nLibrary_Path={mine}\n")
    libraries = paths.library_paths()
    assert libraries == (str(povray), str(mine))
    kinds = [(k, w) for k, w in paths.search_folders(place / "scenes", libraries)]
    assert kinds == [
        ("local", place / "scenes"),
        ("library", mine),
        ("stdlib", paths.STDLIB),
        ("povray", povray),
    ]
    monkeypatch.setenv("STRALA_POVRAY_INCLUDE", "off")
    paths.povray_include.cache_clear()
    kinds = [(k, w) for k, w in paths.search_folders(place / "scenes", libraries)]
    assert kinds == [("local", place / "scenes"), ("library", mine), ("stdlib", paths.STDLIB)]
    assert paths.find("only_theirs.inc", place / "scenes", libraries) is None
    assert _which(place) == 4  # the user's own folder from the INI file is still read
    # a file of POV-Ray's still finds the files beside it
    found = paths.find("only_theirs.inc", povray, libraries)
    assert found is not None and found.kind == "local"


def test_this_machines_defaults_read_the_stdlibs_colors_inc(tmp_path):
    """Whatever POV-Ray's INI file here names (its own include folder, on a system where
    POV-Ray is installed), strala's colors.inc is the one found."""
    found = paths.find("colors.inc", tmp_path, paths.library_paths())
    assert found is not None and found.kind == "stdlib"


# ------------------------------------------------------------ POV-Ray, the oracle
needs_povray = pytest.mark.skipif(shutil.which("povray") is None, reason="POV-Ray is absent")


@pytest.mark.povray
@needs_povray
def test_povray_reads_povini_before_the_current_folders_ini_and_before_plus_l(tmp_path):
    """What the order above follows: POV-Ray takes $POVINI's file over ./povray.ini, and an
    INI file's Library_Path over +L (strala puts -L first: see the test above)."""
    a, b = _library(tmp_path, "a", 1), _library(tmp_path, "b", 2)
    for lib in (a, b):
        (lib / "which.inc").write_text(f'#debug "from {lib.name}\\n"\n')
    (tmp_path / "a.ini").write_text(f"Library_Path={a}\n")
    (tmp_path / "povray.ini").write_text(f"Library_Path={b}\n")
    (tmp_path / "scene.pov").write_text('#include "which.inc"\n')

    def run(*extra: str, povini: bool) -> str:
        import os

        env = dict(os.environ)
        env.pop("POVINI", None)
        if povini:
            env["POVINI"] = str(tmp_path / "a.ini")
        done = subprocess.run(
            ["povray", "+Iscene.pov", "-D", "+W1", "+H1", "+O/dev/null", "-V", *extra],
            cwd=tmp_path, env=env, capture_output=True, text=True, timeout=60,
        )  # fmt: skip
        return done.stderr

    assert "from b" in run(povini=False)
    assert "from a" in run(povini=True)
    assert "from a" in run(f"+L{b}", povini=True)
