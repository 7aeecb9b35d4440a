"""The display window (POV-Ray's `+D`): the image on screen as it renders.

The window is a process of its own (runtime.viewer, Tk): a thread here would hold Python's
lock while Tk starts and while it draws, which the render's threads need. It is started
before numpy is imported and the scene read, so Tk comes up on the core that leaves idle.
The render hands its finished tiles to `Window.tile` on its own thread; they are turned
into the file's 8-bit values there (`color.to_display8`, compiled and without the lock, so
the window shows the pixels the PNG holds), kept (for `s`), and sent down a pipe by a
thread that waits on it, so a slow window never holds up the render. A tile's first rays
(`Window.first`, before anti-aliasing refines them) are held FIRST_DELAY and sent only if
the tile is not done by then: a fast render converts and draws each pixel once.

Keys: `s` saves what is shown so far (beside the output, SCENE.shown.png), `q` or closing
the window calls `on_stop` while the render runs (the command line stops as on ^C) and
closes the window once it is done.
"""

from __future__ import annotations

import collections
import importlib.util
import json
import math
import os
import queue
import struct
import subprocess
import sys
import threading
import time
from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING

from lang import ir

if TYPE_CHECKING:  # numpy is imported once the window's process is started
    import numpy as np

VERDICT_TIMEOUT = 5.0  # seconds a closing window may take to say whether it could open
SCREEN_SHARE = 0.9  # an image larger than this share of the screen is shown subsampled
# Seconds a tile's first rays wait for the tile to be done before they are shown: the
# refinement of most tiles takes less, and their first rays are then never converted.
FIRST_DELAY = 0.1


def unavailable() -> str | None:
    """Why no window can open here (None: try). Only what is known without connecting;
    a display that refuses the connection is reported by `Window.problem`."""
    if not os.environ.get("DISPLAY"):
        if os.environ.get("WAYLAND_DISPLAY"):
            return "Tk needs an X display and $DISPLAY is not set (Wayland without XWayland?)"
        return "no display ($DISPLAY is not set)"
    try:
        found = all(importlib.util.find_spec(m) for m in ("tkinter", "_tkinter"))
    except (ImportError, ValueError):  # a module set to None (not there) in sys.modules
        found = False
    if not found:
        return "Tk is not installed (Debian: apt-get install python3-tk)"
    return None


class Window:
    """A window showing one image at a time (an animation's frames in turn).

    `name` heads the title (the scene's file name); `on_stop` is called (from a thread of
    this module's) when the user presses q or closes the window before `finish`;
    `on_problem(why)` if the window cannot open. Nothing here waits for the window: the
    render starts as soon as it can, and what it hands over is sent once the window is up."""

    def __init__(self, name: str, on_stop: Callable[[], None], on_problem: Callable[[str], None]):
        self.name = name
        self.on_stop = on_stop
        self.on_problem = on_problem
        self.problem: str | None = None  # why the window could not open, once it tried
        self.screen = (0, 0)
        self.shown: np.ndarray | None = None  # this frame's file values so far
        self._done: set[tuple[int, int, int, int]] = set()  # this frame's finished tiles
        self._lock = threading.Lock()  # `shown` and `_done` between the tiles' threads
        self.settings: ir.Settings | None = None
        self.save_to: Path | None = None
        self._ready = threading.Event()
        self._closed = threading.Event()
        self._finished = False
        self._closing = False
        self._outbox: queue.SimpleQueue = queue.SimpleQueue()
        viewer = Path(__file__).with_name("viewer.py")
        # -I: the standard library only, not this folder's modules named as some of it;
        # -S: not even site-packages (their start-up hooks cost a tenth of Tk's start)
        self._proc = subprocess.Popen(
            [sys.executable, "-I", "-S", str(viewer), name],
            stdin=subprocess.PIPE,
            stdout=subprocess.PIPE,
        )
        threading.Thread(target=self._listen, name="strala-display-in", daemon=True).start()
        threading.Thread(target=self._send, name="strala-display-out", daemon=True).start()

    # ------------------------------------------------------------------ the render's side
    def show(self) -> None:
        """Show the window (started hidden: a command line refused shows none)."""
        self._put(b"S", b"")

    def frame(
        self, width: int, height: int, settings: ir.Settings, label: str, save_to: Path
    ) -> None:
        """Start showing a new image (black), of which `label` says what it is."""
        import numpy as np

        with self._lock:
            self.shown = np.zeros((height, width, 3), dtype=np.uint8)
            self._done = set()
        self.settings, self.save_to = settings, save_to
        self._outbox.put(("frame", self.shown, label))

    def tile(self, rect: tuple[int, int, int, int], working: np.ndarray) -> None:
        """A finished tile's working-space colours at rect (x0, y0, x1, y1)."""
        from runtime import color

        if self.settings is None or self.shown is None:
            return
        x0, y0, x1, y1 = rect
        values = color.to_display8(working, self.settings)
        with self._lock:
            self._done.add(rect)
            self.shown[y0:y1, x0:x1] = values
        self._outbox.put(("tile", self.shown, rect))

    def first(self, rect: tuple[int, int, int, int], working: np.ndarray) -> None:
        """A tile's first-ray colours, before anti-aliasing refines them (the render's
        on_first, from the thread tracing it): shown if the tile is not done within
        FIRST_DELAY. `working` is the render's own array, not written again."""
        if self.settings is not None and self.shown is not None:
            due = time.monotonic() + FIRST_DELAY
            self._outbox.put(("first", self.shown, rect, working, due))

    def _first_shown(self, shown: np.ndarray, rect, working: np.ndarray) -> bool:
        """A held tile's first rays into `shown`, unless the tile is done meanwhile or a
        new frame has begun (False: nothing to send)."""
        from runtime import color

        assert self.settings is not None
        x0, y0, x1, y1 = rect
        if shown is not self.shown or rect in self._done:
            return False
        values = color.to_display8(working, self.settings)
        with self._lock:
            if shown is not self.shown or rect in self._done:
                return False
            shown[y0:y1, x0:x1] = values
        return True

    def file_values(self) -> np.ndarray:
        """The frame's 8-bit file values (`color.to_display8`), once the render has given
        the window every tile (black where none was: outside a partial render's region);
        what `image.save_render` would compute again for an 8-bit file."""
        assert self.shown is not None
        return self.shown

    def whole(self, working: np.ndarray, label: str) -> None:
        """A whole image at once (a preview pass, already enlarged to the frame's size)."""
        from runtime import color

        if self.settings is None or self.shown is None:
            return
        self.shown[:] = color.to_display8(working, self.settings)
        # as it is now: the final pass' tiles overwrite `shown` before a late window draws
        self._outbox.put(("tile", self.shown.copy(), (0, 0, *working.shape[1::-1])))
        self._put(b"L", label.encode())

    def progress(self, done: float, total: float) -> None:
        self._put(b"P", struct.pack(">dd", done, total))

    def _message(self, item, step: int) -> tuple[bytes, int]:
        import numpy as np

        """The bytes for the viewer of an item of the outbox, and the frame's step (1 pixel
        shown for step x step of an image larger than the screen)."""
        if isinstance(item, bytes):
            return item, step
        kind, shown, *rest = item
        if kind == "frame":
            height, width = shown.shape[:2]
            screen_w, screen_h = self.screen
            fits = max(width / (screen_w * SCREEN_SHARE), height / (screen_h * SCREEN_SHARE))
            step = max(1, math.ceil(fits))
            size = {"width": -(-width // step), "height": -(-height // step)}
            return _framed(b"F", json.dumps({**size, "label": rest[0]}).encode()), step
        x0, y0, x1, y1 = rest[0]
        # the pixels on the grid of every step-th, where this tile has any
        fx, fy = -(-x0 // step) * step, -(-y0 // step) * step
        values = shown[fy:y1:step, fx:x1:step]
        h, w = values.shape[:2]
        if not w or not h:
            return b"", step
        head = struct.pack(">IIII", fx // step, fy // step, w, h)
        return _framed(b"T", head + np.ascontiguousarray(values).tobytes()), step

    def finish(self, pause: bool) -> None:
        """The render is done: q and closing now only close. With `pause` wait until the
        user closes the window (POV-Ray's +P), else close it now."""
        self._finished = True
        self._put(b"D", b"\x01" if pause else b"\x00")
        if pause:
            while not self._closed.wait(0.2):  # in slices: ^C still reaches this thread
                pass
        self.close()

    def close(self) -> None:
        """Close the window now (its drawing may lag the render: it is not waited for)."""
        # a window still coming up is given the time to say whether it could: a render
        # shorter than Tk's start must not hide that the display refused it
        self._ready.wait(VERDICT_TIMEOUT)
        self._closing = True  # its end now is no problem to report
        self._outbox.put(None)
        if self._proc.poll() is None:
            self._proc.terminate()
        try:
            self._proc.wait(timeout=2.0)
        except subprocess.TimeoutExpired:
            self._proc.kill()

    @property
    def closed(self) -> bool:
        return self._closed.is_set()

    # -------------------------------------------------------------------- the pipes
    def _put(self, kind: bytes, payload: bytes) -> None:
        self._outbox.put(_framed(kind, payload))

    def _send(self) -> None:
        """The outbox down the pipe, once the window is up (it says the screen's size)."""
        pipe = self._proc.stdin
        assert pipe is not None
        self._ready.wait()
        step = 1
        held: collections.deque = collections.deque()  # first rays, by the time they are due
        while True:
            now = time.monotonic()
            if held and held[0][-1] <= now:  # the first rays held longest are due
                _, shown, rect, working, _ = held.popleft()
                if not self._first_shown(shown, rect, working):
                    continue
                item = ("tile", shown, rect)
            else:
                try:
                    item = self._outbox.get(timeout=held[0][-1] - now if held else None)
                except queue.Empty:
                    continue
            if self.problem is not None:
                continue  # no window: the render goes on, what it hands over is dropped
            if isinstance(item, tuple) and item[0] == "first":
                held.append(item)
                continue
            try:
                if item is None:
                    pipe.write(_framed(b"C", b""))
                    pipe.close()
                    return
                message, step = self._message(item, step)
                pipe.write(message)
                pipe.flush()
            except (BrokenPipeError, OSError, ValueError):  # the window has gone
                return

    def _listen(self) -> None:
        assert self._proc.stdout is not None
        for raw in self._proc.stdout:
            word, _, rest = raw.decode(errors="replace").strip().partition(" ")
            if word == "ready":
                w, h = rest.split()
                self.screen = (int(w), int(h))
                self._ready.set()
            elif word == "error":
                self.problem = rest
                self.on_problem(rest)  # said before close() may go on and the process end
                self._ready.set()
            elif word == "save":
                self._save()
            elif word == "stop" and not self._finished:
                self.on_stop()  # the command line leaves here (exit 130) while rendering
        if not self._ready.is_set():
            self.problem = "the window's process ended before it opened"
            self._ready.set()
            if not self._closing:
                self.on_problem(self.problem)
        self._closed.set()

    def _save(self) -> None:
        if self.save_to is None or self.shown is None:
            return
        from runtime import image

        try:
            image.write_pixels(self.save_to, self.shown, 8)
        except OSError as exc:
            print(f"strala: cannot save what the window shows: {exc}", file=sys.stderr)
            return
        print(f"saved what the window shows to {self.save_to}", file=sys.stderr)


def shown_path(output: Path) -> Path:
    """Where `s` saves what the window shows: beside the output, never over it."""
    return output.with_name(f"{output.stem}.shown.png")


class Frames:
    """The window fed with the tiles of many frames at once (a cluster renders them side by
    side, runtime.render_job): it shows one frame at a time, the first to have a tile in;
    the tiles of the others wait until it is complete (or failed), then the next one in is
    shown with all it has so far. `key` tells the frames apart."""

    def __init__(self, window: Window, width: int, height: int):
        self.window = window
        self.size = (width, height)
        self.current: object = None
        self.waiting: dict[object, tuple[str, Path, ir.Settings, list]] = {}

    def tile(
        self,
        key: object,
        label: str,
        output: Path,
        rect: tuple[int, int, int, int],
        pixels: np.ndarray,
        settings: ir.Settings,
    ) -> None:
        if self.current is None:
            self.current = key
            self.window.frame(*self.size, settings, label, shown_path(output))
        if key == self.current:
            self.window.tile(rect, pixels)
        else:
            self.waiting.setdefault(key, (label, output, settings, []))[3].append((rect, pixels))

    def ended(self, key: object) -> None:
        """The frame `key` is written (or failed): the next one in takes the window."""
        self.waiting.pop(key, None)
        if key != self.current:
            return
        self.current = None
        if self.waiting:
            after = next(iter(self.waiting))
            label, output, settings, tiles = self.waiting.pop(after)
            for rect, pixels in tiles:
                self.tile(after, label, output, rect, pixels, settings)


def _framed(kind: bytes, payload: bytes) -> bytes:
    """A message for runtime.viewer: its kind, its length, itself."""
    return struct.pack(">cI", kind, len(payload)) + payload
