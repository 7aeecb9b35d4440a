"""Where scene files find their includes and data files, and the one search every tool
makes (the evaluator, the language server, translate). In order:

1. the including file's folder, then the main scene's folder (POV-Ray looks for a name
   from where it runs, the scene's folder: so a file a stdlib macro writes and then
   includes, as meshmaker.inc's do, is found);
2. the library folders: `-L`/`+L` (and an INI file given on the command line), the Python
   API's `library_paths`, then the `Library_Path` entries of the INI file POV-Ray 3.7 reads
   by itself (povray_ini), then `$STRALA_LIBRARY_PATH`;
3. strala's stdlib;
4. POV-Ray's installed include folder, where POV-Ray is installed (for the data files
   strala's stdlib does not have, such as ash.map: POV-Ray finds them there through the
   Library_Path of its own povray.ini).

Folders inside POV-Ray's installation, wherever they are named (by -L, by POV-Ray's own
povray.ini, or as the folder of one of POV-Ray's files), are searched after the stdlib:
strala's stdlib files are written for strala and replace POV-Ray's files of the same name,
while the POV-Ray files the stdlib lacks are still found. `STRALA_POVRAY_INCLUDE=off` leaves
POV-Ray's folders out (which measures what strala's own stdlib covers); an including file's
own folder is still searched."""

from __future__ import annotations

import functools
import os
from collections.abc import Iterable, MutableMapping, Sequence
from dataclasses import dataclass
from pathlib import Path

from lang.ini import library_paths_of

STDLIB = Path(__file__).resolve().parent.parent / "stdlib"
LIBRARY_PATH_VARIABLE = "STRALA_LIBRARY_PATH"
# Where POV-Ray 3.7's packages install its include files (Debian's and a source build's).
POVRAY_INCLUDE_FOLDERS = (
    Path("/usr/share/povray-3.7/include"),
    Path("/usr/local/share/povray-3.7/include"),
)
POVINI_VARIABLE = "POVINI"
# POV-Ray 3.7's configuration folder (POVCONFDIR) and the one before it (SYSCONFDIR) as a
# distribution's package and a source build (prefix /usr/local) install them
POVRAY_CONF_DIRS = (Path("/etc/povray/3.7"), Path("/usr/local/etc/povray/3.7"))
POVRAY_OLD_CONF_DIRS = (Path("/etc"), Path("/usr/local/etc"))
# POV-Ray 3.7's data folder (POVLIBDIR), which holds include/, ini/, scenes/…
POVRAY_SHARE_DIRS = (Path("/usr/share/povray-3.7"), Path("/usr/local/share/povray-3.7"))


def povray_left_out() -> bool:
    """Whether STRALA_POVRAY_INCLUDE=off leaves POV-Ray's folders out of the search."""
    return os.environ.get("STRALA_POVRAY_INCLUDE", "").lower() == "off"


@functools.cache
def povray_include() -> Path | None:
    """POV-Ray's installed include folder, if there is one and STRALA_POVRAY_INCLUDE is not
    `off` (which measures what strala's own stdlib covers)."""
    if povray_left_out():
        return None
    return next((p for p in POVRAY_INCLUDE_FOLDERS if (p / "colors.inc").is_file()), None)


def povray_ini_candidates() -> list[Path]:
    """The INI files POV-Ray 3.7's Unix front end looks for before reading the command line,
    in its order (vfe/unix/unixoptions.cpp, Process_povray_ini): $POVINI, ./povray.ini,
    ~/.povray/3.7/povray.ini, the system povray.ini, then the old ~/.povrayrc and
    <sysconfdir>/povray.ini. It reads the first one that exists, and that one only."""
    found: list[Path] = []
    povini = os.environ.get(POVINI_VARIABLE)
    if povini:
        found.append(Path(povini))
    found.append(Path("povray.ini"))
    home = os.environ.get("HOME", "")
    if home:
        found.append(Path(home, ".povray", "3.7", "povray.ini"))
    found += [d / "povray.ini" for d in POVRAY_CONF_DIRS]
    if home:
        found.append(Path(home, ".povrayrc"))
    found += [d / "povray.ini" for d in POVRAY_OLD_CONF_DIRS]
    return found


def povray_ini() -> Path | None:
    """The INI file POV-Ray would read by default here, or None."""
    return next((p for p in povray_ini_candidates() if p.is_file()), None)


def ini_library_paths() -> list[str]:
    """The `Library_Path` folders of the INI file POV-Ray reads by default."""
    ini = povray_ini()
    return [] if ini is None else library_paths_of(ini)


def library_paths(given: Iterable[str | os.PathLike[str]] = ()) -> tuple[str, ...]:
    """The given folders, then the default POV-Ray INI file's `Library_Path` entries, then
    those of $STRALA_LIBRARY_PATH (separated by os.pathsep)."""
    env = os.environ.get(LIBRARY_PATH_VARIABLE, "")
    return (
        tuple(str(p) for p in given)
        + tuple(ini_library_paths())
        + tuple(p for p in env.split(os.pathsep) if p)
    )


def in_povray(folder: Path) -> bool:
    """Whether `folder` is inside POV-Ray's installed data folder or its include folder."""
    installed = povray_include()
    roots = [*POVRAY_SHARE_DIRS, *([installed] if installed is not None else [])]
    try:
        here = folder.resolve()
        return any(here.is_relative_to(d.resolve()) for d in roots)
    except OSError:
        return False


@dataclass(frozen=True, slots=True)
class Found:
    # "absolute", "local" (the including file's folder), "scene" (the main scene's folder),
    # "library", "stdlib", "povray"
    kind: str
    probed: str  # the path that was tried, as written
    path: str  # the same file, resolved


def search_folders(
    folder: Path, libraries: Sequence[str], scene: Path | None = None
) -> list[tuple[str, Path]]:
    """(kind, folder) in the order a name is looked up from a file in `folder` of the scene
    in the folder `scene` (the module's docstring); a folder met twice is searched the
    first time."""
    ours: list[tuple[str, Path]] = []
    theirs: list[tuple[str, Path]] = []
    seen: set[str] = set()
    installed = povray_include()
    given = [("local", folder)]
    if scene is not None:
        given.append(("scene", scene))
    given += [("library", Path(p)) for p in libraries]
    if installed is not None:
        given.append(("povray", installed))
    left_out = povray_left_out()
    for kind, where in given:
        key = os.path.normpath(os.path.abspath(where))
        if key in seen:
            continue
        seen.add(key)
        if not in_povray(where):
            ours.append((kind, where))
        elif kind in ("local", "scene"):  # a POV-Ray file's own folder, or a scene of POV-Ray's
            theirs.append((kind, where))
        elif not left_out:
            theirs.append(("povray", where))
    return [*ours, ("stdlib", STDLIB), *theirs]


def searched(folder: Path, libraries: Sequence[str], scene: Path | None = None) -> str:
    """The folders a name was looked for in, in order, for a message."""
    return ", ".join(str(where) for _, where in search_folders(folder, libraries, scene))


def find(
    name: str,
    folder: Path,
    libraries: Sequence[str],
    misses: MutableMapping[str, str | None] | None = None,
    scene: Path | None = None,
) -> Found | None:
    """The file `name` names from a file in `folder`; an absolute name is itself. Every path
    tried in vain is recorded in `misses` (the scene store follows them: a file that appears
    there later changes the scene)."""
    if os.path.isabs(name):
        candidates = [("absolute", Path("/"))]
    else:
        candidates = search_folders(folder, libraries, scene)
    for kind, where in candidates:
        p = where / name
        if p.is_file():
            return Found(kind, str(p), str(p.resolve()))
        if misses is not None:
            misses.setdefault(str(p), None)
    return None
