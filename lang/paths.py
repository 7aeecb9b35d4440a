"""Where scene files find their includes and data files: the bundled stdlib, the library
folders (`-L`, an INI file's `Library_Path`, the Python API's `library_paths`, then
`$STRALA_LIBRARY_PATH`), POV-Ray's own include folder where POV-Ray is installed, and the
one search every tool makes (the evaluator, the language server, translate): the including
file's folder, the library folders in order, the stdlib, then POV-Ray's folder (for the
files strala's stdlib does not have, such as woods.inc: POV-Ray finds them there through
the Library_Path of its own povray.ini)."""

from __future__ import annotations

import functools
import os
from collections.abc import Iterable, MutableMapping, Sequence
from dataclasses import dataclass
from pathlib import Path

STDLIB = Path(__file__).resolve().parent.parent / "stdlib"
LIBRARY_PATH_VARIABLE = "STRALA_LIBRARY_PATH"
# Where POV-Ray 3.7's packages install its include files (Debian's and a source build's).
POVRAY_INCLUDE_FOLDERS = (
    Path("/usr/share/povray-3.7/include"),
    Path("/usr/local/share/povray-3.7/include"),
)


@functools.cache
def povray_include() -> Path | None:
    """POV-Ray's installed include folder, if there is one and STRALA_POVRAY_INCLUDE is not
    `off` (which measures what strala's own stdlib covers)."""
    if os.environ.get("STRALA_POVRAY_INCLUDE", "").lower() == "off":
        return None
    return next((p for p in POVRAY_INCLUDE_FOLDERS if (p / "colors.inc").is_file()), None)


def library_paths(given: Iterable[str | os.PathLike[str]] = ()) -> tuple[str, ...]:
    """The given folders, then those of $STRALA_LIBRARY_PATH (separated by os.pathsep)."""
    env = os.environ.get(LIBRARY_PATH_VARIABLE, "")
    return tuple(str(p) for p in given) + tuple(p for p in env.split(os.pathsep) if p)


@dataclass(frozen=True, slots=True)
class Found:
    kind: str  # "absolute", "local" (the including file's folder), "library" or "stdlib"
    probed: str  # the path that was tried, as written
    path: str  # the same file, resolved


def search_folders(folder: Path, libraries: Sequence[str]) -> list[tuple[str, Path]]:
    """(kind, folder) in the order a name is looked up from a file in `folder`."""
    found = [("local", folder), *(("library", Path(p)) for p in libraries), ("stdlib", STDLIB)]
    installed = povray_include()
    if installed is not None:
        found.append(("povray", installed))
    return found


def searched(folder: Path, libraries: Sequence[str]) -> str:
    """The folders a name was looked for in, for a message."""
    return ", ".join(str(where) for _, where in search_folders(folder, libraries))


def find(
    name: str,
    folder: Path,
    libraries: Sequence[str],
    misses: MutableMapping[str, str | None] | None = None,
) -> Found | None:
    """The file `name` names from a file in `folder`; an absolute name is itself. Every path
    tried in vain is recorded in `misses` (the scene store follows them: a file that appears
    there later changes the scene)."""
    if os.path.isabs(name):
        candidates = [("absolute", Path("/"))]
    else:
        candidates = search_folders(folder, libraries)
    for kind, where in candidates:
        p = where / name
        if p.is_file():
            return Found(kind, str(p), str(p.resolve()))
        if misses is not None:
            misses.setdefault(str(p), None)
    return None
