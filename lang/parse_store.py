"""Parsed include files kept between runs.

Parsing is most of compiling a typical scene: colors.inc, metals.inc, glass.inc … are
parsed again on every render (spheres_on_checker: 0.15 s of its 0.18 s compile). An
included file's syntax tree and parse diagnostics depend only on its text, its name (the
spans carry it) and the parser, so they are stored under a key of those three and loaded
instead of parsed when the key matches: a pickled tree loads several times faster than
lark parses it.

Where: $STRALA_CACHE, else $XDG_CACHE_HOME/strala, else ~/.cache/strala (a folder
`parse-<parser fingerprint>` inside it). STRALA_CACHE=off turns the store off. Entries are
written to a temporary name and renamed, so a reader never sees half a file; an entry that
cannot be read is parsed again and rewritten. A scene edited between renders leaves an
entry per version: past MAX_ENTRIES the least recently used quarter is removed.
"""

from __future__ import annotations

import hashlib
import importlib.util
import os
import pickle
import secrets
from functools import cache
from pathlib import Path

from lang import syntax
from lang.diagnostics import Diagnostic

ENV = "STRALA_CACHE"
MAX_ENTRIES: int = 2000  # about 30 KB each: a store of at most ~60 MB
# The modules whose code decides what a parse gives: any change to them is a new store.
_PARSER_FILES = (
    "grammar.lark",
    "parser.py",
    "chunks.py",
    "syntax.py",
    "diagnostics.py",
    "keywords.py",
)


@cache
def _fingerprint() -> str:
    here = Path(__file__).resolve().parent
    files = [here / name for name in _PARSER_FILES]
    lark = importlib.util.find_spec("lark")  # the installed lark, found without importing it
    if lark is not None and lark.origin:
        files.append(Path(lark.origin))
    h = hashlib.sha256()
    for path in files:
        st = path.stat()
        h.update(f"{path}:{st.st_size}:{st.st_mtime_ns};".encode())
    return h.hexdigest()[:16]


def folder() -> Path | None:
    """The store's folder for this parser, or None when the store is off."""
    env = os.environ.get(ENV, "")
    if env.lower() == "off":
        return None
    if env:
        base = Path(env)
    else:
        xdg = os.environ.get("XDG_CACHE_HOME")
        try:
            base = (Path(xdg) if xdg else Path.home() / ".cache") / "strala"
        except (RuntimeError, KeyError):  # no home folder (a bare container user): no store
            return None
    try:
        return base / f"parse-{_fingerprint()}"
    except OSError:  # the parser's own files cannot be read: better parse than guess
        return None


def _key(text: str, filename: str) -> str:
    h = hashlib.sha256(filename.encode("utf-8", "surrogatepass"))
    h.update(b"\0")
    h.update(text.encode("utf-8", "surrogatepass"))
    return h.hexdigest()


def load(text: str, filename: str) -> tuple[syntax.SourceFile, list[Diagnostic]] | None:
    where = folder()
    if where is None:
        return None
    try:
        with open(where / f"{_key(text, filename)}.pickle", "rb") as f:
            tree, diags = pickle.load(f)
            os.utime(f.fileno())  # least recently used first, when pruning
    except (OSError, EOFError, pickle.UnpicklingError, AttributeError, ValueError, TypeError):
        return None
    if not isinstance(tree, syntax.SourceFile):
        return None
    return tree, diags


def save(text: str, filename: str, tree: syntax.SourceFile, diags: list[Diagnostic]) -> None:
    where = folder()
    if where is None:
        return
    target = where / f"{_key(text, filename)}.pickle"
    tmp = target.with_name(f".{target.name}.{os.getpid()}.{secrets.token_hex(4)}")
    try:
        where.mkdir(parents=True, exist_ok=True)
        with open(tmp, "wb") as f:
            pickle.dump((tree, diags), f, protocol=pickle.HIGHEST_PROTOCOL)
        os.replace(tmp, target)
        _prune(where)
    except (OSError, pickle.PicklingError, RecursionError, TypeError, AttributeError):
        # A store that cannot be written (read-only home, full disk) only costs speed.
        try:
            tmp.unlink()
        except OSError:
            pass


def _prune(where: Path) -> None:
    entries = list(where.glob("*.pickle"))
    if len(entries) <= MAX_ENTRIES:
        return
    by_age = sorted(entries, key=lambda p: p.stat().st_mtime)
    for old in by_age[: len(entries) // 4]:
        try:
            old.unlink()
        except OSError:
            pass
