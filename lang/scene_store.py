"""Evaluated scenes kept between runs, for the command line.

Rendering an unchanged scene again (another size, another anti-aliasing setting, a
benchmark's next run) evaluated it again: the declarations of colors.inc and its kin, or a
thousand object statements. An evaluation's result depends on the scene's text and name,
the options it was given, the evaluator's code and the include files it read, so it is
stored under a key of the first three, with the files as a list of what each probed path
held (a digest of its text, or nothing); a stored result is used only while every one of
those paths holds what it did.

Only an evaluation that depended on nothing else is stored: one that used file I/O,
file_exists(), `now`, trace()/inside(), an image, font or data file, or that ended with
an error, is not (`Interpreter.outside` names why). `#debug` text the evaluation printed is
stored and printed again. The entries live in a folder `scene-<code fingerprint>` of
`lang.store`; STRALA_CACHE=off turns it off.
"""

from __future__ import annotations

import hashlib
import os
import sys
from dataclasses import dataclass
from functools import cache
from pathlib import Path

from lang import ir, store

MAX_ENTRIES: int = 200
MAX_BYTES: int = 32 << 20  # a scene of large meshes is evaluated again rather than stored


@dataclass(frozen=True)
class Entry:
    """A stored evaluation: what it read, what it gave and what it printed."""

    files: tuple[tuple[str, str | None], ...]  # (path probed, digest of its text or None)
    scene: ir.Scene
    diagnostics: tuple
    read: tuple[str, ...]  # every file read, as `Result.files`
    printed: tuple[str, ...]  # `#debug` text written to stderr, in order


@cache
def _fingerprint() -> str:
    here = Path(__file__).resolve().parent
    # the evaluator is lang/ and its builders in lang/eval/
    files = sorted([*here.glob("*.py"), *here.glob("eval/*.py"), *here.glob("*.lark")])
    np = sys.modules.get("numpy")  # transforms are numpy products: its version counts
    return store.fingerprint(files, extra=getattr(np, "__version__", ""))


def folder() -> Path | None:
    """The store's folder for this evaluator, or None when the store is off."""
    return store.folder("scene", _fingerprint)


def digest(text: str) -> str:
    return hashlib.sha256(text.encode("utf-8", "surrogatepass")).hexdigest()


def file_digest(path: str) -> str | None:
    """The digest of a file's text as the evaluator reads it, None when it is not a file."""
    try:
        return digest(Path(path).read_text(encoding="utf-8", errors="replace"))
    except (OSError, ValueError):
        return None


def key(text: str, filename: str, options: tuple) -> str:
    """The entry name for a scene's text, name and options (the working folder included:
    relative names resolve against it)."""
    h = hashlib.sha256(repr((filename, os.getcwd(), options)).encode("utf-8", "surrogatepass"))
    h.update(b"\0")
    h.update(text.encode("utf-8", "surrogatepass"))
    return h.hexdigest()


def load(name: str) -> Entry | None:
    """The stored evaluation `name`, when every file it read still holds the same text."""
    where = folder()
    if where is None:
        return None
    entry = store.read(where / f"{name}.pickle")
    if not isinstance(entry, Entry):
        return None
    for path, was in entry.files:
        if file_digest(path) != was:
            return None
    return entry


def save(name: str, entry: Entry) -> bool:
    where = folder()
    if where is None:
        return False
    return store.write(where / f"{name}.pickle", entry, MAX_ENTRIES, MAX_BYTES)
