"""A folder of pickled entries kept between runs, for `lang.parse_store` (parsed files) and
`lang.scene_store` (evaluated scenes).

Where: $STRALA_CACHE, else $XDG_CACHE_HOME/strala, else ~/.cache/strala; STRALA_CACHE=off
turns every store off. Each store keeps its entries in a folder of its own named for a
fingerprint of the code whose results it holds, so changed code starts an empty folder.
Entries are written to a temporary name and renamed, so a reader never sees half a file;
an entry that cannot be read counts as absent. Past a store's entry limit the least
recently used quarter is removed.
"""

from __future__ import annotations

import hashlib
import os
import pickle
import secrets
from collections.abc import Callable, Iterable
from pathlib import Path
from typing import Any

ENV = "STRALA_CACHE"


def base() -> Path | None:
    """The folder every store lives in, or None when the stores are off."""
    env = os.environ.get(ENV, "")
    if env.lower() == "off":
        return None
    if env:
        return Path(env)
    xdg = os.environ.get("XDG_CACHE_HOME")
    try:
        return (Path(xdg) if xdg else Path.home() / ".cache") / "strala"
    except (RuntimeError, KeyError):  # no home folder (a bare container user): no store
        return None


def folder(name: str, code: Callable[[], str]) -> Path | None:
    """A store's folder, `name-<code()>` in the base (code: the fingerprint of the code whose
    results it keeps); None when the stores are off or that code's files cannot be read
    (better to work again than to guess)."""
    where = base()
    if where is None:
        return None
    try:
        return where / f"{name}-{code()}"
    except OSError:
        return None


def fingerprint(files: Iterable[Path], extra: str = "") -> str:
    """A short digest of the files' names, sizes and modification times (and `extra`)."""
    h = hashlib.sha256(extra.encode())
    for path in files:
        st = path.stat()
        h.update(f"{path}:{st.st_size}:{st.st_mtime_ns};".encode())
    return h.hexdigest()[:16]


def read(path: Path) -> Any | None:
    """The entry stored at `path`, or None when there is none or it cannot be read."""
    try:
        with open(path, "rb") as f:
            value = pickle.load(f)
            os.utime(f.fileno())  # least recently used first, when pruning
    except (
        OSError,
        EOFError,
        pickle.UnpicklingError,
        AttributeError,
        ValueError,
        TypeError,
        ImportError,
        IndexError,
        KeyError,
        RecursionError,
    ):
        return None  # damaged, or written by other code
    return value


def write(path: Path, value: Any, max_entries: int, max_bytes: int | None = None) -> bool:
    """Store `value` at `path` (atomically); False when it could not be (a read-only home,
    a full disk, a value that does not pickle, or one larger than `max_bytes`)."""
    tmp = path.with_name(f".{path.name}.{os.getpid()}.{secrets.token_hex(4)}")
    try:
        data = pickle.dumps(value, protocol=pickle.HIGHEST_PROTOCOL)
        if max_bytes is not None and len(data) > max_bytes:
            return False
        path.parent.mkdir(parents=True, exist_ok=True)
        with open(tmp, "wb") as f:
            f.write(data)
        os.replace(tmp, path)
        _prune(path.parent, max_entries)
        return True
    except (OSError, pickle.PicklingError, RecursionError, TypeError, AttributeError):
        # A store that cannot be written only costs speed.
        try:
            tmp.unlink()
        except OSError:
            pass
        return False


def _prune(where: Path, max_entries: int) -> None:
    entries = list(where.glob("*.pickle"))
    if len(entries) <= max_entries:
        return
    by_age = sorted(entries, key=lambda p: p.stat().st_mtime)
    for old in by_age[: len(entries) // 4]:
        try:
            old.unlink()
        except OSError:
            pass
