"""What the renderer says while it prepares and traces a scene: warnings, a line each on
standard error (never standard output, where an image may be going), and a way to silence
them (`strala render -q`). Errors are exceptions and never come through here.

A thing said once (`say_once`, `warn_once`) is said once per process, or once per
`recorded()` block: a cluster's worker records what each task says and sends it to the
client, whose `-q` decides, under the client's file names (its stderr is not the user's,
and it renders many jobs in one process)."""

from __future__ import annotations

import sys
import threading
from collections.abc import Iterator
from contextlib import contextmanager

_lock = threading.Lock()
_silenced = 0  # how many `silenced()` blocks are open (tiles on other threads warn too)
_recording: list[list[str]] = []  # the lists of the open `recorded()` blocks
_said: set[str] = set()  # the lines said once (in this process, or this recorded block)


def say(line: str) -> None:
    """Write one line on standard error unless silenced (or keep it, while recorded)."""
    with _lock:
        if _recording:
            for kept in _recording:
                kept.append(line)
            return
        if _silenced:
            return
    print(line, file=sys.stderr)


def warn(message: str, span: object = None) -> None:
    """`FILE:LINE:COL: warning: message` when the source is known, else `strala: warning: …`."""
    say(warning_line(message, span))


def warning_line(message: str, span: object = None) -> str:
    return f"{span if span is not None else 'strala'}: warning: {message}"


def say_once(line: str) -> None:
    """`say`, the first time this line comes."""
    with _lock:
        if line in _said:
            return
        _said.add(line)
    say(line)


def warn_once(message: str, span: object = None) -> None:
    """`warn`, the first time this warning (at this place) comes."""
    say_once(warning_line(message, span))


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


@contextmanager
def recorded() -> Iterator[list[str]]:
    """Within the block, what would be said goes into the list yielded instead of standard
    error; what is said once is said once within the block (again in the next one). Blocks
    open at once on several threads each get every line (a worker running two tasks)."""
    global _said
    kept: list[str] = []
    with _lock:
        _recording.append(kept)
        before, _said = _said, set()
    try:
        yield kept
    finally:
        with _lock:
            _recording.remove(kept)
            if not _recording:  # what the block said was not said here
                _said = before
