"""Which files a scene may read (#include, file_exists(), image and data files) and write
(#fopen … write, the output image), as POV-Ray 3.7's povray.conf decides: its `[File I/O
Security]` level and its `[Permitted Paths]` (`read` and `read+write`, with `*` for the
folders below). The levels, as povray.conf's own text documents them:

- none: read and write anywhere;
- read-only: read anywhere; write only in the `read+write` paths;
- restricted: read only in the `read` and `read+write` paths; write only in the latter.

POV-Ray's configuration folders (the system's, the user's ~/.povray/3.7) are never written
above `none`. A path in povray.conf that is not absolute is taken from the current folder (as
POV-Ray's CanonicalizePath does: `.` is the current folder); %INSTALLDIR% and %HOME% are
replaced. POV-Ray reads the system's povray.conf, then the user's: the user's level is taken
only when it is at least as strict, and then its paths replace the system's.

strala adds the scene's folder (and below): always readable with the library folders, and
always writable by `#fopen`, whatever the level. Without any povray.conf a render reads
anywhere and writes beside the scene (POV-Ray's documented default, read-only, with no
`read+write` path); the output image is then the user's choice, anywhere. A povray.conf (or
`render --io-restrictions`) holds the output image to the write rule too.

`check` and the language server open files an editor hands them, often someone else's: they
read only the scene's folder and the library folders, whatever povray.conf says, and write
nothing. `render --io-restrictions` sets the level over povray.conf's.

(POV-Ray 3.7's own reading of the level compares it the wrong way round, so its builds take
every povray.conf as unset, and do not restrict at all; strala follows the documentation.)"""

from __future__ import annotations

import os
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from pathlib import Path

from lang import paths

LEVELS = ("none", "read-only", "restricted")  # POV-Ray's [File I/O Security]


@dataclass(frozen=True)
class ReadAccess:
    """folders: readable with everything below them; shallow: readable, not below;
    writes_anywhere: written anywhere (level `none`); writable, writable_shallow: povray.conf's
    `read+write*` and `read+write` paths; excluded: never written (POV-Ray's configuration
    folders); confines_output: the output image keeps to the write rule (a povray.conf or
    --io-restrictions set the level); why, write_why: what restricts reads, and writes, said
    when one is refused."""

    restricted: bool
    folders: tuple[Path, ...] = ()
    shallow: tuple[Path, ...] = ()
    why: str = ""
    writes_anywhere: bool = False
    writable: tuple[Path, ...] = ()
    writable_shallow: tuple[Path, ...] = ()
    excluded: tuple[Path, ...] = ()
    confines_output: bool = False
    write_why: str = ""

    def allows(self, path: str | os.PathLike[str]) -> bool:
        if not self.restricted:
            return True
        real = _real(path)
        if real is None:
            return False
        if any(real.parent == f for f in self.shallow):
            return True
        return any(real == f or f in real.parents for f in self.folders)

    def allows_write(
        self, path: str | os.PathLike[str], scene_folder: str | os.PathLike[str] | None = None
    ) -> bool:
        """Whether `path` may be written: anywhere at `none`; else beside the scene (its
        folder and below) and in the `read+write` paths, never in the excluded folders."""
        if self.writes_anywhere:
            return True
        real = _real(path)
        if real is None:
            return False
        if any(real == f or f in real.parents for f in self.excluded):
            return False
        scene = _real(scene_folder) if scene_folder is not None else None
        if scene is not None and (real == scene or scene in real.parents):
            return True
        if any(real.parent == f for f in self.writable_shallow):
            return True
        return any(f in real.parents for f in self.writable)

    def writes_permitted(self) -> bool:
        """Whether povray.conf names folders to write in (its read+write paths)."""
        return bool(self.writable or self.writable_shallow)

    def write_places(self) -> str:
        """Where writes may go, said in a refusal."""
        return "beside the scene" + (
            " and in its read+write paths" if self.writes_permitted() else " only"
        )


def _real(path: str | os.PathLike[str] | None) -> Path | None:
    if path is None:
        return None
    try:
        return Path(path).resolve()
    except (OSError, RuntimeError, ValueError):
        return None


UNRESTRICTED = ReadAccess(False)


def _library_folders(libraries: Iterable[str]) -> list[Path]:
    out = [Path(p).resolve() for p in libraries] + [paths.STDLIB.resolve()]
    inc = paths.povray_include()
    if inc is not None:
        out.append(inc.resolve())
    return out


def confined(scene_folder: Path, libraries: Iterable[str], why: str) -> ReadAccess:
    """Reads only in the scene's folder and the library folders (check, the editor)."""
    return ReadAccess(True, (scene_folder.resolve(), *_library_folders(libraries)), (), why)


def povray_conf() -> tuple[Path, ...]:
    """The povray.conf files POV-Ray 3.7 reads, in its order: the system's, then the user's."""
    found = [d / "povray.conf" for d in paths.POVRAY_CONF_DIRS]
    system = next((c for c in found if c.is_file()), None)
    out = [system] if system is not None else []
    user = _user_folder()
    if user is not None and (user / "povray.conf").is_file():
        out.append(user / "povray.conf")
    return tuple(out)


def _user_folder() -> Path | None:
    home = os.environ.get("HOME")
    return Path(home) / ".povray" / "3.7" if home else None


# the levels from the least strict; an unknown level in the system's file is POV-Ray's
# "I/O restrictions are disabled", in the user's the system's level
_STRICTNESS = {"none": 0, "read-only": 1, "restricted": 2}


@dataclass
class _Conf:
    """What one povray.conf sets: its level (None: not said) and its permitted paths, each
    (folder, below too, writable)."""

    file: Path
    level: str | None
    permitted: list[tuple[Path, bool, bool]]


def from_povray_conf(
    conf: Path | Sequence[Path] | None,
    scene_folder: Path,
    libraries: Iterable[str],
    level: str | None = None,
) -> ReadAccess:
    """What povray.conf permits a render (`conf`: the files POV-Ray reads, as povray_conf
    gives them; none: reads anywhere, writes beside the scene); `level`, one of LEVELS
    (--io-restrictions), overrides its `[File I/O Security]`."""
    files = [conf] if isinstance(conf, Path) else list(conf or ())
    settings = [_conf_settings(f) for f in files]
    chosen = _combined(settings)
    conf_level = (chosen.level if chosen is not None else None) or "read-only"
    permitted = chosen.permitted if chosen is not None else []
    if level is None:
        level = conf_level
        why = f"povray.conf ({chosen.file}) restricts reads" if chosen else ""
        write_why = f"povray.conf ({chosen.file})" if chosen else "strala"
    else:
        why = write_why = f"--io-restrictions {level}"
    confines = chosen is not None or write_why.startswith("--")
    if level == "none":
        return ReadAccess(False, why=why, writes_anywhere=True, write_why=write_why)
    user = _user_folder()
    excluded = tuple(
        p.resolve() for p in (*paths.POVRAY_CONF_DIRS, *([user] if user else [])) if p.is_dir()
    )
    writable = tuple(f for f, below, w in permitted if w and below)
    writable_shallow = tuple(f for f, below, w in permitted if w and not below)
    if level != "restricted":
        folders: tuple[Path, ...] = ()
        shallow: tuple[Path, ...] = ()
        why = ""
    else:
        deep = [f for f, below, _w in permitted if below]
        shallow = tuple(f for f, below, _w in permitted if not below)
        folders = (scene_folder.resolve(), *_library_folders(libraries), *deep)
    return ReadAccess(
        level == "restricted",
        folders,
        shallow,
        why,
        writable=writable,
        writable_shallow=writable_shallow,
        excluded=excluded,
        confines_output=confines,
        write_why=write_why,
    )


def _combined(settings: list[_Conf]) -> _Conf | None:
    """The system's povray.conf, then the user's: the user's level only when it is at least
    as strict (and then its paths replace the system's); no path at all: POV-Ray's
    installed folder (and below) and its configuration folder, read only."""
    if not settings:
        return None
    system, users = settings[0], settings[1:]
    chosen = _Conf(system.file, system.level, list(system.permitted))
    if chosen.level is not None and chosen.level not in _STRICTNESS:
        chosen.level = "none"  # POV-Ray: an unknown system level disables the restrictions
    for user in users:
        level = user.level if user.level in _STRICTNESS else chosen.level
        if _STRICTNESS.get(level or "", -1) >= _STRICTNESS.get(chosen.level or "", -1):
            chosen = _Conf(user.file, level, list(user.permitted))
    if not chosen.permitted:
        share = next((d for d in paths.POVRAY_SHARE_DIRS if d.is_dir()), paths.POVRAY_SHARE_DIRS[0])
        chosen.permitted = [
            (share.resolve(), True, False),
            (system.file.parent.resolve(), False, False),
        ]
    return chosen


def _conf_settings(conf: Path) -> _Conf:
    """One povray.conf's level and permitted paths."""
    try:
        lines = conf.read_text(errors="replace").splitlines()
    except OSError:
        return _Conf(conf, None, [])
    section, level = "", None
    permitted: list[tuple[Path, bool, bool]] = []
    home = os.environ.get("HOME", "")
    share = paths.POVRAY_SHARE_DIRS[0]
    for raw in lines:
        line = raw.split(";", 1)[0].strip()
        if not line:
            continue
        if line.startswith("["):
            section = line.strip("[]").strip().lower()
        elif section == "file i/o security":
            level = line.lower()
        elif section == "permitted paths" and line.startswith("read") and "=" in line:
            kind, _, where = (part.strip() for part in line.partition("="))
            where = where.strip("\"'")
            if not where:
                continue
            where = where.replace("%INSTALLDIR%", str(share)).replace("%HOME%", home)
            # POV-Ray's CanonicalizePath: a path that is not absolute is the current folder's
            folder = Path(where) if os.path.isabs(where) else Path.cwd() / where
            permitted.append((folder.resolve(), kind.endswith("*"), kind.startswith("read+write")))
    return _Conf(conf, level, permitted)
