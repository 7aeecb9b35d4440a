"""What a render task on another machine needs: the scene's files, named by a content hash.

Workers share no filesystem with the client. A `Bundle` holds the text of the scene file,
of every file it included, every data file it read (`#fopen`) and every data file its IR
names (image maps, height fields, fonts, density files), over all the frames of a job (the
client compiles each frame to learn them: a later frame may include other files), keyed by
the client's absolute paths; strala's own stdlib is left
out (every worker has it). A worker writes the files once per bundle under a folder named
by the hash (`materialise`), with the client's absolute paths re-rooted there, so the
scene's relative includes and `-L` folders resolve as on the client; diagnostics are
mapped back to the client's paths (`client_diagnostic`) so file:line:col reads as a local
render's. A compiled IR (a `.json` file, or a scene object from the Python API) travels
as it is, hashed the same way.
"""

from __future__ import annotations

import dataclasses
import hashlib
import os
import pickle
import secrets
import shutil
import tempfile
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field
from pathlib import Path

from lang import ir, paths
from lang.diagnostics import Diagnostic

# The folder a worker keeps bundles in (one subfolder per hash); $STRALA_BUNDLE_DIR wins.
BUNDLE_DIR_VARIABLE = "STRALA_BUNDLE_DIR"


@dataclass(frozen=True)
class Bundle:
    """The files of a scene (path → bytes), or a compiled scene (`scene`), with their hash.

    `entry` is the scene file's absolute path; `libraries` the client's -L folders."""

    entry: str
    files: dict[str, bytes] = field(default_factory=dict)
    libraries: tuple[str, ...] = ()
    scene: ir.Scene | None = None
    digest: str = ""

    @property
    def size(self) -> int:
        return sum(len(b) for b in self.files.values())


def _digest(entry: str, files: dict[str, bytes], libraries: Sequence[str], extra: bytes) -> str:
    h = hashlib.sha256()
    h.update(entry.encode() + b"\0" + "\0".join(libraries).encode() + b"\0" + extra)
    for name in sorted(files):
        h.update(name.encode() + b"\0" + hashlib.sha256(files[name]).digest())
    return h.hexdigest()


def of_scene(scene: ir.Scene, name: str = "<scene>") -> Bundle:
    """A compiled scene as a bundle (the IR travels whole)."""
    data = pickle.dumps(scene, protocol=pickle.HIGHEST_PROTOCOL)
    return Bundle(name, scene=scene, digest=_digest(name, {}, (), data))


def of_files(entry: str | os.PathLike, read: Iterable[str],
             scene: ir.Scene | Iterable[ir.Scene] | None,
             libraries: Sequence[str]) -> Bundle:  # fmt: skip
    """The bundle of the scene file `entry`: the files its compiles `read` (includes, data
    files #fopen read), those its IR `scene` names (image maps, height fields, fonts …;
    one scene, or every frame's), and the scene file itself. Files of strala's stdlib
    stay out."""
    main = str(Path(entry).resolve())
    wanted = {main, *(str(Path(f).resolve()) for f in read if not f.startswith("<"))}
    for one in [scene] if isinstance(scene, ir.Scene) else scene or ():
        wanted |= set(named_files(one))
    files: dict[str, bytes] = {}
    for name in sorted(wanted):
        path = Path(name)
        if path.is_relative_to(paths.STDLIB) or not path.is_file():
            continue
        files[name] = path.read_bytes()
    libs = tuple(str(Path(p).resolve()) for p in libraries)
    return Bundle(main, files, libs, digest=_digest(main, files, libs, b""))


def named_files(scene: ir.Scene) -> list[str]:
    """Absolute paths of existing files that strings in the IR name (resolved data files)."""
    found: set[str] = set()
    seen: set[int] = set()
    stack: list[object] = [scene]
    while stack:
        v = stack.pop()
        if isinstance(v, str):
            if os.path.isabs(v) and os.path.isfile(v):
                found.add(v)
        elif isinstance(v, tuple | list):
            # runs of numbers (mesh vertices, spline points) hold no names
            if v and not isinstance(v[0], int | float):
                stack.extend(v)
        elif isinstance(v, dict):
            stack.extend(v.values())
        elif dataclasses.is_dataclass(v) and not isinstance(v, type):
            if id(v) in seen:
                continue
            seen.add(id(v))
            stack.extend(getattr(v, f.name) for f in dataclasses.fields(v))
    return sorted(found)


def _bundle_root() -> Path:
    where = os.environ.get(BUNDLE_DIR_VARIABLE)
    return Path(where) if where else Path(tempfile.gettempdir()) / "strala-bundles"


def rooted(root: Path, client_path: str) -> Path:
    """Where the client's absolute path `client_path` lives under a bundle's root."""
    return root / Path(client_path).relative_to(Path(client_path).anchor)


def materialise(bundle: Bundle) -> Path:
    """The bundle's files written under a folder named by its hash (once: an existing
    folder is complete, since it is renamed into place only when every file is written).
    Returns the root folder."""
    root = _bundle_root() / bundle.digest
    if root.is_dir():
        return root
    root.parent.mkdir(parents=True, exist_ok=True)
    tmp = root.with_name(f".{bundle.digest}.{os.getpid()}.{secrets.token_hex(4)}")
    try:
        for name, data in bundle.files.items():
            target = rooted(tmp, name)
            target.parent.mkdir(parents=True, exist_ok=True)
            target.write_bytes(data)
        tmp.mkdir(parents=True, exist_ok=True)
        try:
            os.replace(tmp, root)
        except OSError:  # another worker process of this machine was first: use its copy
            if not root.is_dir():
                raise
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    return root


def worker_paths(bundle: Bundle, root: Path) -> tuple[str, tuple[str, ...]]:
    """(scene file, library folders) under the bundle's root: the client's -L folders, then
    the folders of shipped files found in none of them (POV-Ray's include folder, say)."""
    libs = [str(rooted(root, p)) for p in bundle.libraries]
    scene_folder = str(Path(bundle.entry).parent)
    covered = {scene_folder, *bundle.libraries}
    for name in sorted(bundle.files):
        folder = str(Path(name).parent)
        if folder not in covered:
            covered.add(folder)
            libs.append(str(rooted(root, folder)))
    return str(rooted(root, bundle.entry)), tuple(libs)


def client_diagnostic(d: Diagnostic, root: Path) -> Diagnostic:
    """A worker's diagnostic with the client's path of its file (and of the root in text)."""
    file = client_text(d.span.file, root)
    hint = client_text(d.hint, root) if d.hint else d.hint
    return dataclasses.replace(
        d, span=d.span._replace(file=file), message=client_text(d.message, root), hint=hint
    )


def client_text(text: str, root: Path) -> str:
    """Text a worker wrote (a message, a warning's line) with the client's paths in it."""
    return text.replace(str(root) + os.sep, os.sep)
