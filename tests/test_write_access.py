"""Writes where povray.conf permits them (lang.read_access): `#fopen … write` and the output
image go beside the scene and into the `read+write` paths of povray.conf's [Permitted Paths]
(`read+write*`: the folders below too) at `read-only` and `restricted`, anywhere at `none`;
never into POV-Ray's configuration folders. Writes elsewhere are refused: a located error for
`#fopen`, a command-line error before any work for the image. Before, strala wrote only
beside the scene whatever povray.conf said, and the output image anywhere.

POV-Ray's own builds read every level as unset (its comparison of the level is the wrong
way round) and so restrict nothing: the documented rules are the reference here."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest
from conftest import ROOT
from hypothesis import given, settings
from hypothesis import strategies as st

from lang import paths, read_access
from lang.evaluate import compile_file


@pytest.fixture
def place(tmp_path, monkeypatch):
    """A scene folder, a `read+write*` folder, a `read+write` one, a `read*` one and one not
    in povray.conf; no system povray.conf, a user's in a fresh HOME."""
    monkeypatch.setattr(paths, "POVRAY_CONF_DIRS", (tmp_path / "etc",))
    home = tmp_path / "home"
    monkeypatch.setenv("HOME", str(home))
    folders = {n: tmp_path / n for n in ("scene", "deep", "flat", "readonly", "other")}
    for f in folders.values():
        (f / "sub").mkdir(parents=True)
    (home / ".povray" / "3.7").mkdir(parents=True)
    return folders, home


def _conf(home: Path, level: str, folders: dict[str, Path], extra: str = "") -> Path:
    conf = home / ".povray" / "3.7" / "povray.conf"
    conf.write_text(
        f"[File I/O Security]\n{level}\n[Permitted Paths]\n"
        f'read+write* = {folders["deep"]}\nread+write = "{folders["flat"]}"\n'
        f"read* = {folders['readonly']}\n{extra}"
    )
    return conf


@pytest.mark.parametrize("level", ["read-only", "restricted"])
def test_read_write_paths_are_written_and_nothing_else(place, level):
    folders, home = place
    _conf(home, level, folders, f"read+write* = {home}\n")
    access = read_access.from_povray_conf(read_access.povray_conf(), folders["scene"], [])
    scene = folders["scene"]

    def writes(path: Path) -> bool:
        return access.allows_write(path, scene)

    assert writes(scene / "x.txt") and writes(scene / "sub" / "x.txt")  # strala's own rule
    assert writes(folders["deep"] / "x.txt") and writes(folders["deep"] / "sub" / "x.txt")
    assert writes(folders["flat"] / "x.txt") and not writes(folders["flat"] / "sub" / "x.txt")
    assert not writes(folders["readonly"] / "x.txt") and not writes(folders["other"] / "x.txt")
    # POV-Ray's configuration folders, even under a read+write* path
    assert writes(home / "x.txt") and not writes(home / ".povray" / "3.7" / "povray.conf")
    assert not writes(scene / ".." / "other" / "x.txt")  # resolved before it is judged
    assert access.confines_output
    # write implies read; reads at read-only are anywhere
    assert access.allows(folders["flat"] / "x.inc") and access.allows(folders["deep"] / "x")
    assert access.allows(folders["other"] / "x.inc") == (level == "read-only")


def test_none_writes_anywhere_and_no_povray_conf_keeps_to_the_scene(place):
    folders, home = place
    _conf(home, "none", folders)
    none = read_access.from_povray_conf(read_access.povray_conf(), folders["scene"], [])
    assert none.allows_write(folders["other"] / "x.txt", folders["scene"])
    (home / ".povray" / "3.7" / "povray.conf").unlink()
    assert read_access.povray_conf() == ()
    default = read_access.from_povray_conf(read_access.povray_conf(), folders["scene"], [])
    assert default.allows_write(folders["scene"] / "x.txt", folders["scene"])
    assert not default.allows_write(folders["other"] / "x.txt", folders["scene"])
    assert not default.confines_output  # the image named on the command line: anywhere
    given = read_access.from_povray_conf((), folders["scene"], [], "read-only")
    assert given.confines_output and "--io-restrictions read-only" in given.write_why


def test_a_relative_path_in_povray_conf_is_the_current_folders(place, monkeypatch):
    folders, home = place
    monkeypatch.chdir(folders["other"])
    (home / ".povray" / "3.7" / "povray.conf").write_text(
        "[File I/O Security]\nread-only\n[Permitted Paths]\nread+write = .\nread+write* = sub\n"
    )
    access = read_access.from_povray_conf(read_access.povray_conf(), folders["scene"], [])
    assert access.allows_write(folders["other"] / "x.txt")
    assert access.allows_write(folders["other"] / "sub" / "deeper" / "x.txt")
    assert not access.allows_write(folders["deep"] / "x.txt")


def test_the_users_povray_conf_only_makes_it_stricter(place):
    folders, home = place
    system = paths.POVRAY_CONF_DIRS[0]
    system.mkdir()
    (system / "povray.conf").write_text(
        f"[File I/O Security]\nrestricted\n[Permitted Paths]\nread+write = {folders['other']}\n"
    )
    _conf(home, "read-only", folders)  # less strict: the system's level and paths stay
    access = read_access.from_povray_conf(read_access.povray_conf(), folders["scene"], [])
    assert access.restricted and access.allows_write(folders["other"] / "x.txt")
    assert not access.allows_write(folders["deep"] / "x.txt")
    assert not access.allows_write(system / "x.txt")  # the configuration folder
    _conf(home, "restricted", folders)  # as strict: its paths replace the system's
    access = read_access.from_povray_conf(read_access.povray_conf(), folders["scene"], [])
    assert access.allows_write(folders["deep"] / "x.txt")
    assert not access.allows_write(folders["other"] / "x.txt")


WRITE = '#fopen F "{path}" write\n#write (F, "made")\n#fclose F\nsphere {{ 0, 1 }}\n'


@pytest.mark.parametrize(
    "where, written",
    [("deep/sub/w.txt", True), ("flat/w.txt", True), ("flat/sub/w.txt", False),
     ("readonly/w.txt", False), ("other/w.txt", False)],
)  # fmt: skip
def test_fopen_writes_in_read_write_paths_and_is_refused_elsewhere(place, where, written):
    folders, home = place
    conf = _conf(home, "restricted", folders)
    scene = folders["scene"]
    target = scene.parent / where
    (scene / "s.pov").write_text(WRITE.format(path=f"../{where}"))
    access = read_access.from_povray_conf(read_access.povray_conf(), scene, [])
    r = compile_file(str(scene / "s.pov"), reads=access)
    errors = [d for d in r.diagnostics if d.severity.name == "ERROR"]
    assert target.exists() == written
    if written:
        assert not errors and target.read_text() == "made"
    else:
        assert errors and errors[0].code == "E0260"  # (then `#write` to a file not open)
        e = errors[0]
        assert (e.span.file, e.span.line, e.span.col) == (str(scene / "s.pov"), 1, 1)
        assert where in e.message and str(conf) in e.message and "read+write" in e.hint


@settings(max_examples=60, deadline=None)
@given(
    st.lists(st.sampled_from(["a", "b", "..", ".", "sub"]), min_size=1, max_size=5),
    st.sampled_from(["deep", "flat", "readonly", "other", "scene"]),
)
def test_a_write_is_permitted_exactly_where_its_resolved_folder_is(tmp_path_factory, parts, top):
    """The rule on any path, `..` and `.` included: the resolved folder decides."""
    root = tmp_path_factory.mktemp("w")
    folders = {n: root / n for n in ("scene", "deep", "flat", "readonly", "other")}
    for f in folders.values():
        f.mkdir()
    access = read_access.ReadAccess(
        False, writable=(folders["deep"],), writable_shallow=(folders["flat"],)
    )
    path = folders[top].joinpath(*parts, "x.txt")
    real = Path(os.path.abspath(path))  # no links here: resolving is normalising
    folder = real.parent
    expected = (
        folder.is_relative_to(folders["scene"])
        or folder.is_relative_to(folders["deep"])
        or folder == folders["flat"]
    )
    assert access.allows_write(path, folders["scene"]) == expected


def _render(scene: Path, home: Path, out: Path, *extra: str):
    env = dict(os.environ, PYTHONPATH=str(ROOT), HOME=str(home), STRALA_CACHE=str(home / "c"))
    return subprocess.run(
        [sys.executable, "-m", "runtime.cli", "render", "s.pov", "-W", "8", "-H", "6",
         "-o", str(out), *extra],
        cwd=scene, env=env, capture_output=True, text=True, timeout=300,
    )  # fmt: skip


def test_the_output_image_keeps_to_the_write_rule(place):
    """A user's povray.conf at `restricted` (as strict as any system one) decides: the image
    in a read+write path is written, elsewhere refused before any work (no file, not even the
    probe of the folder), and --io-restrictions none writes it anywhere."""
    folders, home = place
    conf = _conf(home, "restricted", folders)
    scene = folders["scene"]
    (scene / "s.pov").write_text("sphere { 0, 1 pigment { rgb 1 } }\n")
    r = _render(scene, home, folders["deep"] / "sub" / "i.png")
    assert r.returncode == 0 and (folders["deep"] / "sub" / "i.png").is_file(), r.stderr
    assert _render(scene, home, scene / "i.png").returncode == 0  # beside the scene
    r = _render(scene, home, folders["other"] / "i.png")
    assert r.returncode == 2, r.stderr
    assert f"cannot write {folders['other'] / 'i.png'}" in r.stderr and str(conf) in r.stderr
    assert "Traceback" not in r.stderr and list((folders["other"]).iterdir()) == [
        folders["other"] / "sub"
    ]
    r = _render(scene, home, folders["other"] / "i.png", "--io-restrictions", "none")
    assert r.returncode == 0 and (folders["other"] / "i.png").is_file(), r.stderr
