"""Which files a scene may read (#include, file_exists(), image and data files), as POV-Ray
3.7's povray.conf decides: its `[File I/O Security]` level (none, read-only, restricted) and,
when restricted, its `[Permitted Paths]` (`read`/`read+write`, with `*` for the folders
below). The scene's folder and the library folders are always readable.

`check` and the language server open files an editor hands them, often someone else's: they
read only the scene's folder and the library folders, whatever povray.conf says. A render
follows povray.conf, or, without one, reads anywhere (POV-Ray's own default, read-only);
`render --io-restrictions` sets the level over povray.conf's.

The same levels decide `#fopen`: reading as any other read; writing beside the scene (its
folder and below), or anywhere at `none`. (POV-Ray also lets `read-only` and `restricted`
write in povray.conf's `read+write` paths; strala keeps writes beside the scene.)"""

from __future__ import annotations

import os
from collections.abc import Iterable
from dataclasses import dataclass
from pathlib import Path

from lang import paths

LEVELS = ("none", "read-only", "restricted")  # POV-Ray's [File I/O Security]


@dataclass(frozen=True)
class ReadAccess:
    """folders: readable with everything below them; shallow: readable, not below;
    writes_anywhere: `#fopen` may write outside the scene's folder (level `none`)."""

    restricted: bool
    folders: tuple[Path, ...] = ()
    shallow: tuple[Path, ...] = ()
    why: str = ""
    writes_anywhere: bool = False

    def allows(self, path: str | os.PathLike[str]) -> bool:
        if not self.restricted:
            return True
        try:
            real = Path(path).resolve()
        except (OSError, RuntimeError):
            return False
        if any(real.parent == f for f in self.shallow):
            return True
        return any(real == f or f in real.parents for f in self.folders)


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


def povray_conf() -> Path | None:
    """The povray.conf POV-Ray 3.7 would read: the user's, else the system's."""
    home = os.environ.get("HOME")
    candidates = [Path(home) / ".povray" / "3.7" / "povray.conf"] if home else []
    candidates += [d / "povray.conf" for d in paths.POVRAY_CONF_DIRS]
    return next((c for c in candidates if c.is_file()), None)


def from_povray_conf(
    conf: Path | None, scene_folder: Path, libraries: Iterable[str], level: str | None = None
) -> ReadAccess:
    """The reads povray.conf permits a render (no file: reads anywhere); `level`, one of
    LEVELS (--io-restrictions), overrides its `[File I/O Security]`."""
    conf_level, deep, shallow = _conf_settings(conf) if conf is not None else ("read-only", [], [])
    if level is None:
        level, why = conf_level, f"povray.conf ({conf}) restricts reads"
    else:
        why = f"--io-restrictions {level}"
    if level == "none":
        return ReadAccess(False, why=why, writes_anywhere=True)
    if level != "restricted":
        return UNRESTRICTED
    folders = (scene_folder.resolve(), *_library_folders(libraries), *deep)
    return ReadAccess(True, folders, tuple(shallow), why)


def _conf_settings(conf: Path) -> tuple[str, list[Path], list[Path]]:
    """povray.conf's level and its permitted paths: (level, deep folders, shallow ones)."""
    try:
        lines = conf.read_text(errors="replace").splitlines()
    except OSError:
        return "read-only", [], []
    section, level = "", "read-only"
    deep: list[Path] = []
    shallow: list[Path] = []
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
        elif section == "permitted paths" and "=" in line:
            kind, _, where = (part.strip() for part in line.partition("="))
            where = where.strip('"').replace("%INSTALLDIR%", str(share)).replace("%HOME%", home)
            folder = (conf.parent / where if not os.path.isabs(where) and where != "." else
                      Path(where)).resolve()  # fmt: skip
            (deep if kind.endswith("*") else shallow).append(folder)
    return level, deep, shallow
