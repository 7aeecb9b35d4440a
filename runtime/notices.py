"""What the renderer says while it prepares and traces a scene: warnings, a line each on
standard error (never standard output, where an image may be going), and a way to silence
them (`strala render -q`). Errors are exceptions and never come through here. Each caller
keeps its own rule for saying a thing once."""

from __future__ import annotations

import sys
import threading
from collections.abc import Iterator
from contextlib import contextmanager

_lock = threading.Lock()
_silenced = 0  # how many `silenced()` blocks are open (tiles on other threads warn too)


def say(line: str) -> None:
    """Write one line on standard error unless silenced."""
    if not _silenced:
        print(line, file=sys.stderr)


def warn(message: str, span: object = None) -> None:
    """`FILE:LINE:COL: warning: message` when the source is known, else `strala: warning: …`."""
    say(f"{span if span is not None else 'strala'}: warning: {message}")


@contextmanager
def silenced(on: bool = True) -> Iterator[None]:
    """Within the block, say nothing (when `on`)."""
    global _silenced
    if not on:
        yield
        return
    with _lock:
        _silenced += 1
    try:
        yield
    finally:
        with _lock:
            _silenced -= 1
