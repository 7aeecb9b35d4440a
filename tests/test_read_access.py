"""Reads only where they belong (lang.read_access): `check` and the language server read the
scene's folder and the library folders only, and write nothing (no stored parse, no stored
scene); a render follows POV-Ray's povray.conf. Before, `#include "/etc/passwd"` printed its
lines in the diagnostics and file_exists("/etc/shadow") answered."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest
from conftest import ROOT

from lang import read_access
from lang.evaluate import compile_file, compile_source
from lang.lsp_analysis import analyse

LEAK = '#include "/etc/passwd"\nsphere { 0, 1 }\n'
PROBE = 'sphere { 0, 1 }\n#if (file_exists("/etc/passwd")) #error "seen" #end\n'


def _files(*folders: Path) -> set[Path]:
    return {p for f in folders for p in f.rglob("*")}


def _check(tmp_path: Path, name: str, env_extra: dict[str, str]):
    env = dict(os.environ, PYTHONPATH=str(ROOT), **env_extra)
    return subprocess.run(
        [sys.executable, "-m", "runtime.cli", "check", name, "--format", "sarif"],
        cwd=tmp_path, env=env, capture_output=True, text=True, timeout=300,
    )  # fmt: skip


@pytest.mark.skipif(not Path("/etc/passwd").is_file(), reason="no /etc/passwd here")
def test_check_reads_only_the_scene_and_library_folders_and_writes_nothing(tmp_path):
    scene = tmp_path / "scene"
    scene.mkdir()
    (scene / "leak.pov").write_text(LEAK)
    (scene / "probe.pov").write_text(PROBE)
    (scene / "own.inc").write_text("#declare R = 2;\n")
    (scene / "ok.pov").write_text('#include "own.inc"\n#include "colors.inc"\nsphere { 0, R }\n')
    cache, home = tmp_path / "cache", tmp_path / "home"
    cache.mkdir(), home.mkdir()
    env = {"STRALA_CACHE": str(cache), "HOME": str(home), "XDG_CACHE_HOME": str(cache)}
    before = _files(tmp_path)
    r = _check(scene, "leak.pov", env)
    assert r.returncode == 1 and "E0261" in r.stdout and "root:" not in r.stdout
    r = _check(scene, "probe.pov", env)
    assert r.returncode == 0 and "seen" not in r.stdout
    r = _check(scene, "ok.pov", env)
    assert r.returncode == 0, r.stdout
    assert _files(tmp_path) == before  # not a stored parse, not a stored scene


@pytest.mark.skipif(not Path("/etc/passwd").is_file(), reason="no /etc/passwd here")
def test_the_language_server_reads_only_the_scene_and_library_folders(tmp_path):
    diags = analyse(LEAK, str(tmp_path / "leak.pov"))
    assert [d.code for d in diags if d.severity.name == "ERROR"] == ["E0261"]
    assert not any("root:" in d.message for d in diags)
    assert not [d for d in analyse(PROBE, str(tmp_path / "p.pov")) if d.code == "E0240"]


def test_an_include_beside_the_scene_and_the_stdlib_stay_readable(tmp_path):
    (tmp_path / "own.inc").write_text("#declare R = 2;\n")
    diags = analyse('#include "own.inc"\n#include "colors.inc"\nsphere { 0, R }\n',
                    str(tmp_path / "s.pov"))  # fmt: skip
    assert not [d for d in diags if d.severity.name == "ERROR"], diags


def test_povray_conf_restricted_permits_its_paths_and_the_scene_folder(tmp_path):
    conf = tmp_path / "povray.conf"
    allowed, other, scene = tmp_path / "allowed", tmp_path / "other", tmp_path / "scene"
    for f in (allowed, other, scene):
        f.mkdir()
    (allowed / "deep").mkdir()
    conf.write_text(
        "; a comment\n[File I/O Security]\nrestricted ; only the permitted paths\n"
        f"[Shellout Security]\nforbidden\n[Permitted Paths]\nread* = {allowed}\n"
        f"read+write = {other}\n"
    )
    access = read_access.from_povray_conf(conf, scene, [])
    assert access.allows(allowed / "deep" / "x.inc")
    assert access.allows(other / "x.inc") and not access.allows(other / "sub" / "x.inc")
    assert access.allows(scene / "x.inc") and not access.allows("/etc/passwd")
    src = '#include "/etc/passwd"\n'
    r = compile_source(src, str(scene / "s.pov"), reads=access)
    assert [d.code for d in r.diagnostics if d.severity.name == "ERROR"] == ["E0261"]


@pytest.mark.parametrize("level", ["none", "read-only"])
def test_povray_conf_below_restricted_reads_anywhere(tmp_path, level):
    conf = tmp_path / "povray.conf"
    conf.write_text(f"[File I/O Security]\n{level}\n")
    assert read_access.from_povray_conf(conf, tmp_path, []).allows("/etc/passwd")
    assert read_access.from_povray_conf(None, tmp_path, []).allows("/etc/passwd")


# ------------------------------------------------ render --io-restrictions (POV-Ray's levels)
OPS = {
    "#include": '#include "../outside/o.inc"\nsphere { 0, R }\n',
    "#fopen read": '#fopen F "../outside/data.txt" read\n#read (F, S, N)\nsphere { 0, N }\n',
    "#fopen write": '#fopen W "../outside/w.txt" write\n#write (W, "x")\n#fclose W\n'
    "sphere { 0, 1 }\n",
}
# level -> the error each operation outside the scene's folder gets (None: it is done)
ALLOWED = {
    "none": {"#include": None, "#fopen read": None, "#fopen write": None},
    "read-only": {"#include": None, "#fopen read": None, "#fopen write": "E0260"},
    "restricted": {"#include": "E0261", "#fopen read": "E0261", "#fopen write": "E0260"},
}


def _beside(tmp_path: Path) -> tuple[Path, Path]:
    scene, outside = tmp_path / "scene", tmp_path / "outside"
    scene.mkdir(), outside.mkdir()
    (outside / "o.inc").write_text("#declare R = 2;\n")
    (outside / "data.txt").write_text('"text",2,\n')
    return scene, outside


@pytest.mark.parametrize("level", read_access.LEVELS)
@pytest.mark.parametrize("op", sorted(OPS))
def test_each_level_on_reads_and_writes_outside_the_scene_folder(tmp_path, level, op):
    scene, outside = _beside(tmp_path)
    # a povray.conf that says otherwise: the level given wins over it
    conf = tmp_path / "povray.conf"
    conf.write_text("[File I/O Security]\n" + ("none" if level == "restricted" else "restricted"))
    access = read_access.from_povray_conf(conf, scene, [], level)
    (scene / "s.pov").write_text(OPS[op])
    r = compile_file(str(scene / "s.pov"), reads=access)
    codes = [d.code for d in r.diagnostics if d.severity.name == "ERROR"]
    expected = ALLOWED[level][op]
    assert codes[:1] == ([expected] if expected else []), r.diagnostics  # (then N is undefined)
    if expected is None and op == "#fopen read":
        assert r.symbols["S"] == "text" and r.symbols["N"] == 2
    assert (outside / "w.txt").exists() == (op == "#fopen write" and expected is None)
    if expected:
        e = next(d for d in r.diagnostics if d.code == expected)
        assert e.span.line == 1 and "../outside/" in e.message
    # beside the scene every level reads and writes
    (scene / "data.txt").write_text('"in",1,\n')
    (scene / "o.inc").write_text("#declare R = 1;\n")
    (scene / "in.pov").write_text(OPS[op].replace("../outside/", ""))
    r = compile_file(str(scene / "in.pov"), reads=access)
    assert not [d for d in r.diagnostics if d.severity.name == "ERROR"], r.diagnostics


def _render(scene: Path, home: Path, *extra: str):
    # the image beside the scene: povray.conf's levels hold the output image to their write
    # rule too (tests/test_write_access.py)
    env = dict(os.environ, PYTHONPATH=str(ROOT), HOME=str(home), STRALA_CACHE=str(home / "c"))
    return subprocess.run(
        [sys.executable, "-m", "runtime.cli", "render", "s.pov", "-W", "8", "-H", "6",
         "-o", str(scene / "out.png"), *extra],
        cwd=scene, env=env, capture_output=True, text=True, timeout=300,
    )  # fmt: skip


def test_render_io_restrictions_overrides_povray_conf(tmp_path):
    scene, outside = _beside(tmp_path)
    home = tmp_path / "home"
    (home / ".povray" / "3.7").mkdir(parents=True)
    (home / ".povray" / "3.7" / "povray.conf").write_text("[File I/O Security]\nrestricted\n")
    (scene / "s.pov").write_text(OPS["#include"])
    r = _render(scene, home)  # the user's povray.conf: restricted
    assert r.returncode == 1 and "E0261" in r.stderr and "povray.conf" in r.stderr, r.stderr
    assert _render(scene, home, "--io-restrictions", "read-only").returncode == 0
    (scene / "s.pov").write_text(OPS["#fopen write"])
    r = _render(scene, home, "--io-restrictions", "read-only")
    assert r.returncode == 1 and "E0260" in r.stderr and not (outside / "w.txt").exists()
    r = _render(scene, home, "--io-restrictions", "none")
    assert r.returncode == 0 and (outside / "w.txt").read_text() == "x", r.stderr
    r = _render(scene, home, "--io-restrictions", "sometimes")
    assert r.returncode == 2 and "--io-restrictions" in r.stderr
