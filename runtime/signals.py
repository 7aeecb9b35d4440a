"""What a stopped command leaves behind: nothing. Files being written (an image's hidden
temporary file, a preview) are registered while they exist; SIGINT, SIGTERM and SIGHUP
remove them and end the process at once with the shell's code for the signal (130, 143,
129). An ordinary KeyboardInterrupt would have to unwind through a render's thread pool,
which finishes every queued tile first; nothing on disk is lost by leaving at once, since
outputs are written to a temporary name and renamed when complete.

A render on a cluster (`--cluster local:N`) has worker processes to stop, and the client's
own exits stop them (the LocalCluster's close ends its workers and releases what it holds):
inside `unwinding`, a signal says its line at once and raises Stopped in the main thread, so
those exits run; the exit code is the same. Should they take longer than the grace given,
the process kills its children and ends at once as elsewhere; so does a second signal.

SIGKILL cannot be caught: a temporary file it leaves is removed by the next write of the
same output (stale_temporaries), once the process that made it is gone."""

from __future__ import annotations

import os
import signal
import sys
import threading
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

# the shell's exit code for a process ended by each signal: 128 + its number
EXIT_CODES = {signal.SIGINT: 130, signal.SIGTERM: 143, signal.SIGHUP: 129}
_NAMES = {signal.SIGINT: "interrupted", signal.SIGTERM: "terminated", signal.SIGHUP: "hung up"}

_pending: set[Path] = set()
_lock = threading.Lock()
_grace: float | None = None  # inside `unwinding`: the seconds a stop may take to unwind
_stopping = False  # a signal came and is unwinding
_asked: tuple[str, int] | None = None  # what `stop_from_thread` asked the signal to say


class Stopped(BaseException):
    """A signal inside `unwinding`: a BaseException, so that no handler on the way takes it
    for an error; `code` is the exit code (130, 143, 129)."""

    def __init__(self, message: str, code: int) -> None:
        super().__init__(message)
        self.code = code


@contextmanager
def unwinding(grace: float) -> Iterator[None]:
    """While the block runs, a signal raises Stopped in the main thread (see the module's
    doc); after `grace` seconds of unwinding the process ends at once, its children killed."""
    global _grace
    old, _grace = _grace, grace
    try:
        yield
    finally:
        _grace = old


@contextmanager
def removed_if_stopped(path: Path) -> Iterator[Path]:
    """`path` is removed if a signal ends the process while the block runs."""
    with _lock:
        _pending.add(path)
    try:
        yield path
    finally:
        with _lock:
            _pending.discard(path)


def stop(message: str, code: int) -> None:
    """End the process at once, as a signal does: the registered files removed, one line
    said (the display window's q uses it too)."""
    _say(message)
    _end(code)


def stop_from_thread(message: str, code: int) -> None:
    """A stop asked from another thread (the display window's q): at once as `stop`, or
    inside `unwinding` as a signal unwinds the main thread, with this line and code (a
    cluster's client then cancels its tasks on the way out)."""
    global _asked
    if _grace is None or threading.current_thread() is threading.main_thread():
        stop(message, code)
        return
    _asked = (message, code)
    main = threading.main_thread().ident
    assert main is not None  # the main thread is running
    signal.pthread_kill(main, signal.SIGINT)


def _say(message: str) -> None:
    try:
        sys.stderr.write(f"\nstrala: {message}\n")
        sys.stderr.flush()
    except (OSError, ValueError):
        pass


def _end(code: int) -> None:
    with _lock:
        for path in list(_pending):
            try:
                path.unlink(missing_ok=True)
            except OSError:
                pass
    os._exit(code)


def _kill_children() -> None:
    """Kill the processes this one started (a cluster's workers), and theirs."""
    try:
        import psutil  # with strala[cluster] (Dask's distributed needs it)
    except ImportError:
        return
    try:
        children = psutil.Process().children(recursive=True)
    except psutil.Error:
        return
    for child in children:
        try:
            child.kill()
        except psutil.Error:
            pass
    psutil.wait_procs(children, timeout=2)


def _give_up(code: int) -> None:
    """The unwinding took too long: end at once."""
    _kill_children()
    _end(code)


def _stop(signum: int, frame) -> None:
    global _stopping
    sig = signal.Signals(signum)
    message, code = _NAMES.get(sig, "stopped"), EXIT_CODES.get(sig, 128 + signum)
    if _asked is not None and sig == signal.SIGINT:  # sent by stop_from_thread
        message, code = _asked
    grace = _grace
    if grace is None:
        stop(message, code)
        return
    if _stopping:  # a second signal: no more waiting
        _give_up(code)
    _stopping = True
    _say(message)
    watchdog = threading.Timer(grace, _give_up, (code,))
    watchdog.daemon = True
    watchdog.start()
    raise Stopped(message, code)


def install() -> None:
    """Handle SIGINT, SIGTERM and SIGHUP as above (from the main thread; a signal that is
    ignored or has someone else's handler keeps it)."""
    if threading.current_thread() is not threading.main_thread():
        return
    for sig in EXIT_CODES:
        if signal.getsignal(sig) in (signal.SIG_DFL, signal.default_int_handler):
            signal.signal(sig, _stop)


def temporary_name(target: Path, suffix: str) -> Path:
    """The hidden name `target` is written under before it is renamed into place (the
    process id in it lets stale_temporaries tell whose it is)."""
    import secrets

    return target.with_name(f".{target.name}.{os.getpid()}.{secrets.token_hex(4)}{suffix}")


def stale_temporaries(target: Path) -> list[Path]:
    """Temporary files of `target` left by processes that no longer run (a SIGKILL)."""
    found = []
    try:
        candidates = list(target.parent.glob(f".{target.name}.*.*"))
    except OSError:
        return []
    for path in candidates:
        parts = path.name[len(target.name) + 2 :].split(".")
        if len(parts) < 2 or not parts[0].isdigit():
            continue
        pid = int(parts[0])
        if pid == os.getpid():
            continue
        try:
            os.kill(pid, 0)
        except ProcessLookupError:
            found.append(path)
        except (PermissionError, OverflowError):
            continue  # someone else's process: its file
    return found
