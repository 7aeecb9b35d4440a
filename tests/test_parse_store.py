"""The store of parsed files (lang.parse_store): a stored parse gives the same scene and the
same diagnostics as parsing, changed text is parsed again, a damaged entry is replaced,
the store can be turned off, and it stays bounded."""

from __future__ import annotations

from pathlib import Path

import pytest

from lang import evaluate, parse_store, parser
from lang.eval.interpreter import Interpreter
from lang.serialize import dumps

ROOT = Path(__file__).resolve().parents[1]


@pytest.fixture
def store(tmp_path, monkeypatch):
    monkeypatch.setenv(parse_store.ENV, str(tmp_path / "store"))
    return tmp_path


def _scene(folder: Path, include: str) -> Path:
    (folder / "part.inc").write_text(include)
    main = folder / "main.scene"
    main.write_text(
        '#include "part.inc"\ncamera { location -5*z look_at 0 }\n'
        "light_source { <2, 4, -3>, rgb 1 }\nsphere { 0, R pigment { Col } }\n"
    )
    return main


def _compile(path: Path):
    return evaluate.compile_file(str(path), [str(ROOT / "stdlib")])


def _entries() -> list[Path]:
    where = parse_store.folder()
    return sorted(where.glob("*.pickle")) if where and where.exists() else []


def test_a_stored_parse_gives_the_same_scene_without_parsing(store, monkeypatch):
    main = _scene(store, "#declare R = 1.5;\n#declare Col = rgb <1, 0.5, 0>;\n")
    first = _compile(main)
    assert len(_entries()) == 2  # the scene and its include

    def no_parse(*args, **kwargs):
        raise AssertionError("parsed although stored")

    monkeypatch.setattr(parser, "parse", no_parse)
    again = _compile(main)
    assert dumps(again.scene) == dumps(first.scene)
    assert again.diagnostics == first.diagnostics


def test_changed_text_is_parsed_again(store):
    main = _scene(store, "#declare R = 1.5;\n#declare Col = rgb 1;\n")
    _compile(main)
    (store / "part.inc").write_text("#declare R = 0.5;\n#declare Col = rgb 1;\n")
    result = _compile(main)
    assert result.scene.objects[0].shape.radius == 0.5
    assert len(_entries()) == 3


def test_parse_errors_come_back_from_the_store(store):
    main = _scene(store, "#declare R = 1;\n#declare Col = rgb 1;\nsphere { 0, 1 \n")
    first = [(d.code, d.span.line, d.span.col) for d in _compile(main).diagnostics]
    second = [(d.code, d.span.line, d.span.col) for d in _compile(main).diagnostics]
    assert first and first == second


def test_a_damaged_entry_is_parsed_and_replaced(store):
    main = _scene(store, "#declare R = 1;\n#declare Col = rgb 1;\n")
    first = _compile(main)
    for entry in _entries():
        entry.write_bytes(b"not a pickle")
    again = _compile(main)
    assert dumps(again.scene) == dumps(first.scene)
    assert all(e.read_bytes() != b"not a pickle" for e in _entries())


def test_off_stores_nothing(tmp_path, monkeypatch):
    monkeypatch.setenv(parse_store.ENV, "off")
    assert parse_store.folder() is None
    _compile(_scene(tmp_path, "#declare R = 1;\n#declare Col = rgb 1;\n"))
    assert not any(tmp_path.rglob("*.pickle"))


def test_the_store_stays_bounded(store, monkeypatch):
    monkeypatch.setattr(parse_store, "MAX_ENTRIES", 8)
    for i in range(20):
        _compile(_scene(store, f"#declare R = {i + 1};\n#declare Col = rgb 1;\n"))
    assert len(_entries()) <= 8


def test_interpreters_that_parse_their_own_way_keep_it(store):
    seen = []

    class Own(Interpreter):
        def parse_source(self, text, filename):
            seen.append(filename)
            return super().parse_source(text, filename)

    main = _scene(store, "#declare R = 1;\n#declare Col = rgb 1;\n")
    for _ in range(2):
        Own([str(ROOT / "stdlib")]).run(main.read_text(), str(main))
    assert len(seen) == 4 and not _entries()
