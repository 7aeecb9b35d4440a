"""The store of evaluated scenes (lang.scene_store): a stored result is the evaluation's own,
it is used only while every file the evaluation read holds the same text and the options
match, and an evaluation that depended on anything else is never stored."""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

from lang import evaluate, scene_store
from lang.eval.interpreter import Interpreter
from lang.serialize import dumps

ROOT = Path(__file__).resolve().parents[1]
STDLIB = str(ROOT / "stdlib")


@pytest.fixture
def store(tmp_path, monkeypatch):
    monkeypatch.setenv("STRALA_CACHE", str(tmp_path / "store"))
    runs = []
    real = Interpreter.run

    def counted(self, text, filename):
        runs.append(filename)
        return real(self, text, filename)

    monkeypatch.setattr(Interpreter, "run", counted)
    return tmp_path, runs


SCENE = (
    '#include "part.inc"\ncamera { location -5*z look_at 0 }\n'
    "light_source { <2, 4, -3>, rgb 1 }\nsphere { 0, R pigment { Col } }\n"
)


def _scene(folder: Path, include: str, body: str = SCENE) -> Path:
    (folder / "part.inc").write_text(include)
    main = folder / "main.scene"
    main.write_text(body)
    return main


def _compile(path: Path, libraries=(STDLIB,), **options):
    return evaluate.compile_file(str(path), list(libraries), store=True, **options)


def test_a_stored_evaluation_is_the_evaluations_own(store):
    folder, runs = store
    main = _scene(folder, '#declare R = 1.5;\n#declare Col = rgb <1, 0.5, 0>;\n#debug "hi"\n')
    first = _compile(main)
    again = _compile(main)
    assert len(runs) == 1  # the second came from the store
    assert dumps(again.scene) == dumps(first.scene)
    assert again.diagnostics == first.diagnostics
    assert again.files == first.files
    plain = evaluate.compile_file(str(main), [STDLIB])  # without the store
    assert dumps(plain.scene) == dumps(first.scene)


def test_changed_include_text_is_evaluated_again(store):
    folder, runs = store
    main = _scene(folder, "#declare R = 1.5;\n#declare Col = rgb 1;\n")
    _compile(main)
    (folder / "part.inc").write_text("#declare R = 0.5;\n#declare Col = rgb 1;\n")
    result = _compile(main)
    assert len(runs) == 2
    assert result.scene.objects[0].shape.radius == 0.5


def test_a_file_that_now_shadows_an_include_is_read(store, tmp_path):
    # The include was found in a library folder; a file of the same name now stands in the
    # scene's folder, which is searched first: the scene must see it.
    folder, runs = store
    lib = tmp_path / "lib"
    lib.mkdir()
    (lib / "colours.inc").write_text("#declare Col = rgb 1;\n")
    main = folder / "main.scene"
    main.write_text(
        '#include "colours.inc"\ncamera { location -5*z look_at 0 }\n'
        "sphere { 0, 1 pigment { Col } }\n"
    )
    first = _compile(main, libraries=(str(lib), STDLIB))
    assert first.scene.objects[0].texture.pigment.color[:3] == (1.0, 1.0, 1.0)
    (folder / "colours.inc").write_text("#declare Col = rgb <1, 0, 0>;\n")
    second = _compile(main, libraries=(str(lib), STDLIB))
    assert len(runs) == 2
    assert second.scene.objects[0].texture.pigment.color[:3] == (1.0, 0.0, 0.0)


def test_the_options_are_part_of_the_key(store):
    folder, runs = store
    main = _scene(
        folder,
        "#declare R = clock + image_width / 100;\n#declare Col = rgb 1;\n",
    )
    a = _compile(main, clock=0.0, image_width=100, image_height=100)
    b = _compile(main, clock=0.5, image_width=100, image_height=100)
    c = _compile(main, clock=0.0, image_width=200, image_height=100)
    assert len(runs) == 3
    radii = [r.scene.objects[0].shape.radius for r in (a, b, c)]
    assert radii == [1.0, 1.5, 2.0]
    _compile(main, clock=0.5, image_width=100, image_height=100)
    assert len(runs) == 3


@pytest.mark.parametrize(
    "what",
    [
        '#fopen F "out.txt" write\n#write (F, "x")\n#fclose F\n',
        '#if (file_exists("part.inc")) #end\n',
        "#declare T = now;\n",
        "#declare P = trace(sphere { 0, 1 }, <0, 0, -5>, z);\n",
        'plane { y, -1 pigment { image_map { png "missing.png" } } }\n',
        "#declare Broken = ;\n",
    ],
    ids=["file-io", "file_exists", "now", "trace", "image", "error"],
)
def test_what_depends_on_more_than_text_is_not_stored(store, what):
    folder, runs = store
    main = _scene(folder, "#declare R = 1;\n#declare Col = rgb 1;\n", SCENE + what)
    for _ in range(2):
        evaluate.compile_file(str(main), [STDLIB], store=True, queries=lambda: _NoQueries())
    assert len(runs) == 2


class _NoQueries:
    def trace(self, *args):
        return None

    def inside(self, *args):
        return False


def test_debug_text_is_printed_again(store, capsys):
    folder, runs = store
    main = _scene(folder, '#declare R = 1;\n#declare Col = rgb 1;\n#debug "from the include\\n"\n')
    for _ in range(2):
        _compile(main, debug_to_stderr=True)
    assert len(runs) == 1
    assert capsys.readouterr().err.count("from the include\n") == 2


def test_off_stores_nothing(tmp_path, monkeypatch):
    monkeypatch.setenv("STRALA_CACHE", "off")
    assert scene_store.folder() is None
    _compile(_scene(tmp_path, "#declare R = 1;\n#declare Col = rgb 1;\n"))
    assert not any(tmp_path.rglob("*.pickle"))


def test_a_damaged_entry_is_evaluated_again(store):
    folder, runs = store
    main = _scene(folder, "#declare R = 1;\n#declare Col = rgb 1;\n")
    first = _compile(main)
    for entry in scene_store.folder().glob("*.pickle"):
        entry.write_bytes(b"\x80\x05not a pickle")
    again = _compile(main)
    assert len(runs) == 2
    assert dumps(again.scene) == dumps(first.scene)


def test_the_command_line_uses_the_store(tmp_path, monkeypatch):
    from conftest import run_cli

    main = _scene(tmp_path, "#declare R = 1;\n#declare Col = rgb 1;\n")
    env_store = tmp_path / "cli-store"
    monkeypatch.setenv("STRALA_CACHE", str(env_store))  # run_cli passes the environment on
    for k in range(2):
        done = run_cli("render", str(main), "-W", "8", "-H", "6", "-q", "-o",
                       str(tmp_path / f"{k}.png"))  # fmt: skip
        assert done.returncode == 0, done.stderr
    assert len(list(env_store.glob("scene-*/*.pickle"))) == 1
    assert (tmp_path / "0.png").read_bytes() == (tmp_path / "1.png").read_bytes()


# Every place the evaluator looks at a file, and why a stored result stays right there.
# A new one fails the test below: decide whether it is a dependency the store must follow
# (as includes are) or one that makes a result unstorable (Interpreter.depends_outside).
FILE_ACCESS = {
    ("evaluate", "compile_file"): "the main file: its text is part of the key",
    ("eval.unknown", "_declaring_include"): "a hint for an error: errors are not stored",
    ("eval.interpreter", "_d_include"): "an include: its text's digest is kept",
    ("eval.interpreter", "source_text"): "a file already read (the main file, an include "
    "whose digest is kept), read again for its tokens",
    ("paths", "find"): "include probes are kept; resolve (other files) depends_outside",
    ("paths", "povray_include"): "searched last: a stored scene found its files before it",
    ("paths", "povray_ini"): "read before evaluating: its library folders are in the key",
    ("ini", "ini_tokens"): "read before evaluating: its library folders are in the key",
    ("eval.fileio", "file_op"): "file I/O: depends_outside",
    ("eval.images", "unreadable_image"): "after resolve found the image: depends_outside",
    ("eval.images", "palette_size"): "after resolve found the image: depends_outside",
    ("builtins", "_file_exists"): "sets BuiltinState.looked_outside",
    ("eval.data_shapes", "_font_fallback"): "text objects call depends_outside",
    ("font_metrics", "load"): "text objects call depends_outside",
    ("scene_store", "file_digest"): "the store's own check",
    ("scene_store", "_fingerprint"): "the store's own files",
    ("store", "fingerprint"): "the store's own files",
    ("store", "read"): "the store's own files",
    ("store", "write"): "the store's own files",
    ("store", "_prune"): "the store's own files",
    ("grammar", "get_parser"): "the grammar",
    ("eval.budget", "resident_bytes"): "the process's own size (/proc), not an input",
    ("read_access", "povray_conf"): "read before evaluating: what it permits is in the key",
    ("read_access", "_conf_settings"): "read before evaluating: what it permits is in the key",
}
_LOOKS = {"open", "read_text", "read_bytes", "is_file", "exists", "isfile", "listdir", "stat",
          "glob", "scandir", "iterdir", "utime"}  # fmt: skip
# Modules the evaluation does not run: the editor's and the translator's own.
_NOT_EVALUATION = {"lsp", "lsp_analysis", "translate", "chunks"}


def test_every_file_the_evaluator_looks_at_is_accounted_for():
    found = set()
    for path in sorted((ROOT / "lang").rglob("*.py")):
        module = ".".join(path.relative_to(ROOT / "lang").with_suffix("").parts)
        if module in _NOT_EVALUATION:
            continue
        tree = ast.parse(path.read_text())
        for fn in ast.walk(tree):
            if not isinstance(fn, ast.FunctionDef):
                continue
            for node in ast.walk(fn):
                if isinstance(node, ast.Call):
                    f = node.func
                    name = f.attr if isinstance(f, ast.Attribute) else getattr(f, "id", "")
                    if name in _LOOKS:
                        found.add((module, fn.name))
    unknown = sorted(found - set(FILE_ACCESS))
    assert not unknown, f"file access not accounted for by the scene store: {unknown}"
    stale = sorted(set(FILE_ACCESS) - found)
    assert not stale, f"listed but no longer looking at files: {stale}"
