"""The hint an unknown identifier's error gives: a visible name close to it, else the include
file that declares it, else a keyword close to it.

Found once per name (and count of visible names) in an evaluation: a loop that meets the
same unknown name at every pass read every library include file at each one, and compared
the name with every visible one (a fuzzed scene spent minutes there under check's budget)."""

from __future__ import annotations

import difflib
import os
import re
from collections.abc import Iterable, MutableMapping, Sequence
from pathlib import Path

from lang import paths
from lang.keywords import ALL_WORDS

Hints = MutableMapping[tuple[str, int], str | None]


def hint(
    name: str, scopes: Iterable[Iterable[str]], cache: Hints, folder: Path, libraries: Sequence[str]
) -> str | None:
    """The hint for `name`, unknown where it is read in a file of `folder`; `cache` is the
    evaluation's (by name and count of visible names: a declaration since may change it)."""
    visible: set[str] = set()
    for scope in scopes:
        visible |= set(scope)
    key = (name, len(visible))
    if key not in cache:
        cache[key] = _hint(name, visible, folder, libraries)
    return cache[key]


def _hint(name: str, visible: set[str], folder: Path, libraries: Sequence[str]) -> str | None:
    close = difflib.get_close_matches(name, sorted(visible), n=1, cutoff=0.75)
    if close:
        return f"did you mean `{close[0]}`?"
    found = _declaring_include(name, folder, libraries)
    if found:
        return f'`{name}` is declared in {found}: add `#include "{found}"`'
    kw = difflib.get_close_matches(name, sorted(ALL_WORDS), n=1, cutoff=0.8)
    return f"did you mean the keyword `{kw[0]}`?" if kw else None


def _declaring_include(name: str, here: Path, libraries: Sequence[str]) -> str | None:
    pat = re.compile(rf"#\s*declare\s+{re.escape(name)}\s*=")
    searched = paths.search_folders(here, libraries)
    for folder in [str(where) for kind, where in searched if kind != "local"]:
        try:
            entries = sorted(os.listdir(folder))
        except OSError:
            continue
        for f in entries:
            if not f.endswith(".inc"):
                continue
            try:
                if pat.search(Path(folder, f).read_text(errors="replace")):
                    return f
            except OSError:
                continue
    return None
