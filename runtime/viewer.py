"""The display window's own process: a Tk window that draws the tiles it is sent.

Started by runtime.display as `python -I -S viewer.py NAME` (the standard library only, not
even site-packages, so it starts in tens of milliseconds and imports nothing of strala); it
reads messages from standard input and answers on standard output, one line each:

    in:   kind (1 byte), length (4 bytes, big-endian), payload
          S  (empty) show the window: the command line is accepted (or F shows it)
          F  {"width", "height", "label"} json: a new image of that size, black
          T  x, y, w, h (4 x uint32) and w*h*3 bytes of 8-bit RGB: a tile to draw (a later
             one at the same place replaces it: a tile's first rays, then the tile refined)
          L  utf-8 text: the title, once what came before it is drawn (a preview pass)
          P  done, total (2 x float64): the render's progress, for the title
          D  1 byte, pause: the render is done (q and closing now only close)
          C  close (as is the end of the input: the render's process has gone)
    out:  `ready W H` (the screen's size) or `error MESSAGE` once, then `save` (the user
          pressed s) and `stop` (q or the close button before the render is done)

A process and not a thread of the render's: Tk holds Python's lock while it starts
(60 ms) and the tiles' drawing would take it from the render's threads too. It is started
before the scene is read, on the core the parsing leaves idle, and its window stays hidden
until the command line is accepted (one refused shows none). Each
tile becomes a photo image on a canvas of its own: putting a tile into one big photo took
half as long again. The tiles that came in are drawn together, DRAW_MS after the first of
them, so that a tile's first rays refined within that time are never drawn at all.
"""

from __future__ import annotations

import json
import os
import queue
import struct
import sys
import threading
import time

DRAW_MS = 100  # tiles that came in are drawn at most this often: 10 a second
TITLE_MS = 500  # the time left in the title is counted down this often
# The window's priority below the render's: on a machine whose cores the render fills, the
# window's drawing waits for the render instead of stretching it (Linux: the idle class,
# which runs only what the render leaves; elsewhere Unix nice).
NICE = 10
READ_SIZE = 1 << 20


def _format_seconds(seconds: float) -> str:
    """As runtime.progress says times (not imported: this process loads no strala)."""
    if seconds < 60:
        return f"{seconds:.1f}s"
    minutes, secs = divmod(int(round(seconds)), 60)
    if minutes < 60:
        return f"{minutes}m{secs:02d}s"
    hours, minutes = divmod(minutes, 60)
    return f"{hours}h{minutes:02d}m"


class Messages:
    """The messages in a stream of bytes that comes in pieces."""

    def __init__(self) -> None:
        self.buffer = bytearray()

    def feed(self, data: bytes) -> list[tuple[bytes, bytes]]:
        self.buffer += data
        out, at = [], 0
        while len(self.buffer) - at >= 5:
            kind, length = struct.unpack_from(">cI", self.buffer, at)
            if len(self.buffer) - at - 5 < length:
                break
            out.append((kind, bytes(self.buffer[at + 5 : at + 5 + length])))
            at += 5 + length
        del self.buffer[:at]
        return out


def _say(line: str) -> None:
    try:
        sys.stdout.write(line + "\n")
        sys.stdout.flush()
    except (BrokenPipeError, ValueError):  # the render's process has gone
        pass


class Viewer:
    def __init__(self, name: str, root, tkinter):
        self.name = name
        self.root = root
        self.tk = tkinter
        self.photos: dict[tuple[int, int, int, int], object] = {}  # Tk frees unheld photos
        self.pending: dict[tuple[int, int, int, int], bytes] = {}  # tiles not drawn yet
        self.draw_due = False
        self.label = ""
        self.size = (0, 0)
        self.started = time.monotonic()
        self.progress = (0.0, 0.0)
        self.done = False
        self.pause = False
        self.stopping = False
        self.ended = False
        self.title = ""
        root.title(name)
        root.resizable(False, False)
        self.canvas = tkinter.Canvas(
            root, width=1, height=1, highlightthickness=0, borderwidth=0, background="black"
        )
        self.canvas.pack()
        root.protocol("WM_DELETE_WINDOW", self.close_asked)
        for key in ("q", "Q"):
            root.bind(f"<KeyPress-{key}>", lambda _e: self.close_asked())
        for key in ("s", "S"):
            root.bind(f"<KeyPress-{key}>", lambda _e: _say("save"))
        root.after(TITLE_MS, self.tick)

    def handle(self, messages: list[tuple[bytes, bytes]] | None) -> None:
        """Messages that came in, in order; None: the input has ended."""
        for kind, payload in messages or ():
            if kind == b"T":
                self.tile(payload)
                continue
            if kind == b"P":  # the title has it at the next draw or tick
                self.progress = struct.unpack(">dd", payload)
                continue
            self.draw()  # what came before is drawn before anything else changes
            if kind == b"C":
                messages = None
                break
            if kind == b"S":
                self.show()
            elif kind == b"F":
                self.start(json.loads(payload))
            elif kind == b"L":
                self.set_title(f"{self.name} — {payload.decode()}")
            elif kind == b"D":
                self.done, self.pause = True, payload == b"\x01"
                self.update_title()
        if messages is None and not self.ended:
            self.ended = True
            self.root.quit()

    def tile(self, payload: bytes) -> None:
        x, y, w, h = struct.unpack_from(">IIII", payload)
        if x == y == 0 and (w, h) == self.size:  # a whole image: what was pending is under it
            self.pending.clear()
        self.pending[(x, y, w, h)] = payload
        if not self.draw_due:
            self.draw_due = True
            self.root.after(DRAW_MS, self.draw)

    def draw(self) -> None:
        """The tiles that came in, drawn (the later of two at one place only)."""
        self.draw_due = False
        if not self.pending:
            return
        for key, payload in self.pending.items():
            ppm = b"P6 %d %d 255\n" % key[2:] + payload[16:]
            photo = self.photos.get(key)
            if photo is None:
                photo = self.tk.PhotoImage(master=self.root, data=ppm, format="ppm")
                self.photos[key] = photo
                self.canvas.create_image(key[0], key[1], image=photo, anchor="nw")
            else:  # a tile drawn again (refined): into its photo, no new canvas item
                self.root.tk.call(photo, "put", ppm, "-format", "ppm")
        self.pending.clear()
        # drawn before the title changes, so a title never speaks of what is not shown
        self.root.update_idletasks()
        self.update_title()

    def start(self, frame: dict) -> None:
        self.label = frame["label"]
        self.size = (frame["width"], frame["height"])
        self.started = time.monotonic()
        self.progress = (0.0, 0.0)
        self.done = False
        self.canvas.configure(width=frame["width"], height=frame["height"])
        self.canvas.delete("all")
        self.photos.clear()
        self.pending.clear()
        self.show()

    def show(self) -> None:
        if self.root.state() == "withdrawn":
            self.root.deiconify()

    def tick(self) -> None:
        self.update_title()
        self.root.after(TITLE_MS, self.tick)

    def update_title(self) -> None:
        if not self.label:
            return
        if self.done:
            took = _format_seconds(time.monotonic() - self.started)
            what = "done" if self.label == "rendering" else f"{self.label} done"
            tail = "; q or close to quit" if self.pause else ""
            self.set_title(f"{self.name} — {what} in {took}{tail}")
            return
        done, total = self.progress
        if total <= 0:
            return
        frac = min(max(done / total, 0.0), 1.0)
        elapsed = time.monotonic() - self.started
        left = f", {_format_seconds(elapsed / frac - elapsed)} left" if frac > 0 else ""
        self.set_title(f"{self.name} — {self.label} {frac * 100:.0f}%{left}")

    def set_title(self, text: str) -> None:
        if text != self.title:  # a title change is a round trip to the window manager
            self.title = text
            self.root.title(text)

    def close_asked(self) -> None:
        if self.done:
            self.root.quit()
        elif not self.stopping:  # the render stops; its process's end closes the window
            self.stopping = True
            _say("stop")


def _listen(viewer: Viewer, tkinter) -> None:
    """Standard input into `viewer.handle`: woken by Tk when there is input (Unix), or read
    by a thread and looked at every DRAW_MS (where Tk watches no files: Windows)."""
    fd = sys.stdin.fileno()  # read as it comes: what is there, no waiting for more
    messages = Messages()
    watch = getattr(viewer.root.tk, "createfilehandler", None)
    if watch is not None:

        def readable(_file, _mask) -> None:
            try:
                data = os.read(fd, READ_SIZE)
            except OSError:
                data = b""
            if not data:
                viewer.root.tk.deletefilehandler(fd)
            viewer.handle(messages.feed(data) if data else None)

        watch(fd, tkinter.READABLE, readable)
        return
    inbox: queue.SimpleQueue = queue.SimpleQueue()

    def read() -> None:
        while data := os.read(fd, READ_SIZE):
            inbox.put(data)
        inbox.put(None)

    def poll() -> None:
        while True:
            try:
                data = inbox.get_nowait()
            except queue.Empty:
                break
            viewer.handle(messages.feed(data) if data is not None else None)
            if data is None:
                return
        viewer.root.after(DRAW_MS, poll)

    threading.Thread(target=read, daemon=True).start()
    poll()


def _lower_priority() -> None:
    """The window below the render (see NICE); as it is where neither is allowed."""
    try:
        os.sched_setscheduler(0, os.SCHED_IDLE, os.sched_param(0))
        return
    except (AttributeError, OSError):
        pass
    try:
        os.nice(NICE)
    except (AttributeError, OSError):
        pass


def main(argv: list[str]) -> int:
    name = argv[1] if len(argv) > 1 else "strala"
    try:
        import tkinter

        root = tkinter.Tk(className="strala")
        root.withdraw()  # shown with the first image
    except Exception as exc:  # no Tk, a display that refuses us: said in one line
        text = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
        _say(f"error {text}")
        return 1
    # Tk started at the normal priority: on a busy machine the idle class would hold it
    _lower_priority()
    viewer = Viewer(name, root, tkinter)
    _listen(viewer, tkinter)
    _say(f"ready {root.winfo_screenwidth()} {root.winfo_screenheight()}")
    root.mainloop()
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
