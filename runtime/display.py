"""The display window (POV-Ray's `+D`): the image on screen as it renders, in Tk.

Tk runs on a thread of its own, so the render keeps its thread and its ^C handling; every
Tk object is made, used and let go on that thread (Tcl interpreters are bound to theirs).
The render only hands its finished tiles over (`tile`: a queue, no work on its thread);
the window's thread turns them into the file's 8-bit values (`color.to_display8`, so the
window shows the pixels the PNG holds) and draws what came in every POLL_MS. Each tile
becomes a photo image on a canvas of its own: putting a tile into one big photo took twice
the time (Tk redraws its whole instance for every put).

Keys: `s` saves what is shown so far (beside the output, SCENE.shown.png), `q` or closing
the window calls `on_stop` while the render runs (the command line stops as on ^C) and
closes the window once it is done.
"""

from __future__ import annotations

import gc
import math
import os
import queue
import sys
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from lang import ir
from runtime import color
from runtime.progress import format_seconds

POLL_MS = 50  # how often the window draws the tiles that came in: 20 a second
OPEN_TIMEOUT = 10.0  # seconds to wait for Tk to reach the display before rendering without
SCREEN_SHARE = 0.9  # an image larger than this share of the screen is shown subsampled


def unavailable() -> str | None:
    """Why no window can open here (None: try). Only what is known without connecting;
    a display that refuses the connection is reported by `Window.problem`."""
    if not os.environ.get("DISPLAY"):
        if os.environ.get("WAYLAND_DISPLAY"):
            return "Tk needs an X display and $DISPLAY is not set (Wayland without XWayland?)"
        return "no display ($DISPLAY is not set)"
    try:
        import tkinter  # noqa: F401  (only whether it is there)
    except ImportError:
        return "Tk is not installed (Debian: apt-get install python3-tk)"
    return None


@dataclass(frozen=True)
class _Frame:
    width: int
    height: int
    settings: ir.Settings
    label: str
    save_to: Path


class Window:
    """A window showing one image at a time (an animation's frames in turn).

    `name` heads the title (the scene's file name); `on_stop` is called from the window's
    thread when the user presses q or closes the window before `finish`."""

    def __init__(self, name: str, on_stop: Callable[[], None]):
        self.name = name
        self.on_stop = on_stop
        self.problem: str | None = None  # why the window could not open, once it tried
        self._inbox: queue.SimpleQueue = queue.SimpleQueue()
        self._ready = threading.Event()
        self._closed = threading.Event()
        self._finished = False
        self._progress = (0.0, 0.0)
        self._thread = threading.Thread(target=self._run, name="strala-display", daemon=True)
        self._thread.start()

    # ---------------------------------------------------- the render's side (any thread)
    def opened(self, timeout: float = OPEN_TIMEOUT) -> bool:
        """Wait until Tk has reached the display; False (and `problem` says why) if not."""
        if not self._ready.wait(timeout):
            self.problem = self.problem or f"the display did not answer in {timeout:.0f} s"
        return self.problem is None

    def frame(
        self, width: int, height: int, settings: ir.Settings, label: str, save_to: Path
    ) -> None:
        """Start showing a new image (black), of which `label` says what it is."""
        self._progress = (0.0, 0.0)
        self._inbox.put(_Frame(width, height, settings, label, save_to))

    def tile(self, rect: tuple[int, int, int, int], working: np.ndarray) -> None:
        """A finished tile's working-space colours at rect (x0, y0, x1, y1); kept, not
        copied: the render does not write it again."""
        self._inbox.put(("tile", rect, working))

    def whole(self, working: np.ndarray, label: str) -> None:
        """A whole image at once (a preview pass, already enlarged to the frame's size)."""
        self._inbox.put(("whole", label, working))

    def progress(self, done: float, total: float) -> None:
        self._progress = (done, total)  # read by the window's thread when it draws

    def finish(self, pause: bool) -> None:
        """The render is done: q and closing now only close. With `pause` wait until the
        user closes the window (POV-Ray's +P), else close it now."""
        self._finished = True
        self._inbox.put(("done", pause))
        if pause:
            while not self._closed.wait(0.2):  # in slices: ^C still reaches this thread
                pass
        self.close()

    def close(self) -> None:
        self._inbox.put(("close",))
        self._thread.join(timeout=2.0)

    @property
    def closed(self) -> bool:
        return self._closed.is_set()

    # ------------------------------------------------------------- the window's thread
    def _run(self) -> None:
        try:
            import tkinter

            root = tkinter.Tk(className="strala")
        except Exception as exc:  # no tkinter, a display that refuses us: said once, above
            self.problem = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
            self._ready.set()
            self._closed.set()
            return
        try:
            screen = _Screen(self, root, tkinter)
            self._ready.set()
            screen.poll()
            root.mainloop()
        finally:
            self._closed.set()
            try:
                root.destroy()
            except tkinter.TclError:
                pass  # destroyed already (closed by the user)
            del root, screen
            gc.collect()  # Tk objects in cycles must go on this thread, not at some later one


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


class _Screen:
    """The Tk side: a canvas of tile photos, the title, the keys. Lives on the window's
    thread only."""

    def __init__(self, window: Window, root, tkinter):
        self.window = window
        self.root = root
        self.tk = tkinter
        self.frame: _Frame | None = None
        self.step = 1  # 1 pixel shown for step x step of the image
        self.shown = np.zeros((1, 1, 3), dtype=np.uint8)  # the file values drawn so far
        self.photos: list = []  # the canvas' images: Tk frees a photo nobody holds
        self.started = time.monotonic()
        self.done = False
        self.pause = False
        self.title = ""
        root.title(window.name)
        root.resizable(False, False)
        self.canvas = tkinter.Canvas(
            root, width=1, height=1, highlightthickness=0, borderwidth=0, background="black"
        )
        self.canvas.pack()
        root.protocol("WM_DELETE_WINDOW", self.close_asked)
        for key in ("q", "Q"):
            root.bind(f"<KeyPress-{key}>", lambda _e: self.close_asked())
        for key in ("s", "S"):
            root.bind(f"<KeyPress-{key}>", lambda _e: self.save())

    def poll(self) -> None:
        """Draw what came in since the last poll, then look again in POLL_MS."""
        inbox = self.window._inbox
        while True:
            try:
                item = inbox.get_nowait()
            except queue.Empty:
                break
            if isinstance(item, _Frame):
                self.start(item)
            elif item[0] == "tile":
                self.draw(item[1], item[2])
            elif item[0] == "whole":
                self.clear()
                self.draw((0, 0, item[2].shape[1], item[2].shape[0]), item[2])
                self.root.update_idletasks()
                self.set_title(f"{self.window.name} — {item[1]}")
            elif item[0] == "done":
                self.done, self.pause = True, item[1]
            elif item[0] == "close":
                self.root.quit()
                return
        # drawn before the title changes, so a title never speaks of what is not shown
        self.root.update_idletasks()
        self.update_title()
        self.root.after(POLL_MS, self.poll)

    def start(self, frame: _Frame) -> None:
        self.frame = frame
        self.started = time.monotonic()
        screen_w, screen_h = self.root.winfo_screenwidth(), self.root.winfo_screenheight()
        fits = max(
            frame.width / (screen_w * SCREEN_SHARE), frame.height / (screen_h * SCREEN_SHARE)
        )
        self.step = max(1, math.ceil(fits))
        self.shown = np.zeros((frame.height, frame.width, 3), dtype=np.uint8)
        w, h = -(-frame.width // self.step), -(-frame.height // self.step)
        self.canvas.configure(width=w, height=h)
        self.clear()

    def clear(self) -> None:
        self.canvas.delete("all")
        self.photos.clear()

    def draw(self, rect: tuple[int, int, int, int], working: np.ndarray) -> None:
        if self.frame is None:
            return
        x0, y0, x1, y1 = rect
        values = color.to_display8(working, self.frame.settings)
        self.shown[y0:y1, x0:x1] = values
        k = self.step
        if k > 1:  # the pixels on the grid of every k-th, where this tile has any
            fx, fy = -(-x0 // k) * k, -(-y0 // k) * k
            values = values[fy - y0 :: k, fx - x0 :: k]
            x0, y0 = fx // k, fy // k
        h, w = values.shape[:2]
        if not w or not h:
            return
        ppm = b"P6 %d %d 255\n" % (w, h) + np.ascontiguousarray(values).tobytes()
        photo = self.tk.PhotoImage(master=self.root, data=ppm, format="ppm")
        self.photos.append(photo)
        self.canvas.create_image(x0, y0, image=photo, anchor="nw")

    def update_title(self) -> None:
        frame = self.frame
        if frame is None:
            return
        if self.done:
            took = format_seconds(time.monotonic() - self.started)
            what = "done" if frame.label == "rendering" else f"{frame.label} done"
            tail = "; q or close to quit" if self.pause else ""
            self.set_title(f"{self.window.name} — {what} in {took}{tail}")
            return
        done, total = self.window._progress
        if total <= 0:
            return
        frac = min(max(done / total, 0.0), 1.0)
        elapsed = time.monotonic() - self.started
        left = f", {format_seconds(elapsed / frac - elapsed)} left" if frac > 0 else ""
        self.set_title(f"{self.window.name} — {frame.label} {frac * 100:.0f}%{left}")

    def set_title(self, text: str) -> None:
        if text != self.title:  # a title change is a round trip to the window manager
            self.title = text
            self.root.title(text)

    def close_asked(self) -> None:
        if not self.window._finished:
            self.window.on_stop()  # the command line leaves here (exit 130) while rendering
        self.root.quit()

    def save(self) -> None:
        if self.frame is None:
            return
        from runtime import image

        target = self.frame.save_to
        try:
            image.write_pixels(target, self.shown, 8)
        except OSError as exc:
            print(f"strala: cannot save what the window shows: {exc}", file=sys.stderr)
            return
        print(f"saved what the window shows to {target}", file=sys.stderr)
