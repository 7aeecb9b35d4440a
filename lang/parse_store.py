"""Parsed include files kept between runs.

Parsing is most of compiling a typical scene: colors.inc, metals.inc, glass.inc … are
parsed again on every render (spheres_on_checker: 0.15 s of its 0.18 s compile). An
included file's syntax tree and parse diagnostics depend only on its text, its name (the
spans carry it) and the parser, so they are stored under a key of those three and loaded
instead of parsed when the key matches: a pickled tree loads several times faster than
lark parses it.

The entries live in a folder `parse-<parser fingerprint>` of `lang.store` (which says where,
and how STRALA_CACHE=off turns it off); an entry that cannot be read is parsed again and
rewritten. A scene edited between renders leaves an entry per version: past MAX_ENTRIES the
least recently used quarter is removed.
"""

from __future__ import annotations

import hashlib
import importlib.util
from functools import cache
from pathlib import Path

from lang import store, syntax
from lang.diagnostics import Diagnostic

ENV = store.ENV
MAX_ENTRIES: int = 2000  # about 30 KB each: a store of at most ~60 MB
# The modules whose code decides what a parse gives: any change to them is a new store.
_PARSER_FILES = (
    "grammar.lark",
    "parser.py",
    "grammar.py",
    "lexical.py",
    "chunks.py",
    "syntax.py",
    "diagnostics.py",
    "keywords.py",
    "schema.py",
)


@cache
def _fingerprint() -> str:
    here = Path(__file__).resolve().parent
    files = [here / name for name in _PARSER_FILES]
    lark = importlib.util.find_spec("lark")  # the installed lark, found without importing it
    if lark is not None and lark.origin:
        files.append(Path(lark.origin))
    return store.fingerprint(files)


def folder() -> Path | None:
    """The store's folder for this parser, or None when the store is off."""
    return store.folder("parse", _fingerprint)


def _key(text: str, filename: str) -> str:
    h = hashlib.sha256(filename.encode("utf-8", "surrogatepass"))
    h.update(b"\0")
    h.update(text.encode("utf-8", "surrogatepass"))
    return h.hexdigest()


def load(text: str, filename: str) -> tuple[syntax.SourceFile, list[Diagnostic]] | None:
    where = folder()
    if where is None:
        return None
    got = store.read(where / f"{_key(text, filename)}.pickle")
    if not (isinstance(got, tuple) and len(got) == 2 and isinstance(got[0], syntax.SourceFile)):
        return None
    return got


def save(text: str, filename: str, tree: syntax.SourceFile, diags: list[Diagnostic]) -> None:
    where = folder()
    if where is not None:
        store.write(where / f"{_key(text, filename)}.pickle", (tree, diags), MAX_ENTRIES)
