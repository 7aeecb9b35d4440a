"""The display window's own process: a Tk window that draws the tiles it is sent.

Started by runtime.display as `python -I viewer.py NAME` (the standard library only, so
it starts in tens of milliseconds and imports nothing of strala); it reads messages from
standard input and answers on standard output, one line each:

    in:   kind (1 byte), length (4 bytes, big-endian), payload
          F  {"width", "height", "label"} json: a new image of that size, black
          T  x, y, w, h (4 x uint32) and w*h*3 bytes of 8-bit RGB: a tile to draw
          L  utf-8 text: the title, once what came before it is drawn (a preview pass)
          P  done, total (2 x float64): the render's progress, for the title
          D  1 byte, pause: the render is done (q and closing now only close)
          C  close (as is the end of the input: the render's process has gone)
    out:  `ready W H` (the screen's size) or `error MESSAGE` once, then `save` (the user
          pressed s) and `stop` (q or the close button before the render is done)

A process and not a thread of the render's: Tk holds Python's lock while it starts
(60 ms) and the tiles' drawing would take it from the render's threads too. Each tile
becomes a photo image on a canvas of its own: putting a tile into one big photo took twice
the time (Tk redraws its whole instance for every put).
"""

from __future__ import annotations

import json
import os
import queue
import struct
import sys
import threading
import time

POLL_MS = 50  # how often the window draws the tiles that came in: 20 a second
# The window's priority below the render's (Unix nice): on a machine whose cores the render
# fills, the window's drawing waits for the render instead of stretching it.
NICE = 10


def _format_seconds(seconds: float) -> str:
    """As runtime.progress says times (not imported: this process loads no strala)."""
    if seconds < 60:
        return f"{seconds:.1f}s"
    minutes, secs = divmod(int(round(seconds)), 60)
    if minutes < 60:
        return f"{minutes}m{secs:02d}s"
    hours, minutes = divmod(minutes, 60)
    return f"{hours}h{minutes:02d}m"


def _read(stream, inbox: queue.SimpleQueue) -> None:
    """The messages on standard input into `inbox`; None at its end."""
    while True:
        head = stream.read(5)
        if len(head) < 5:
            break
        kind, length = struct.unpack(">cI", head)
        payload = stream.read(length)
        if len(payload) < length:
            break
        inbox.put((kind, payload))
    inbox.put(None)


def _say(line: str) -> None:
    try:
        sys.stdout.write(line + "\n")
        sys.stdout.flush()
    except (BrokenPipeError, ValueError):  # the render's process has gone
        pass


class Viewer:
    def __init__(self, name: str, root, tkinter, inbox: queue.SimpleQueue):
        self.name = name
        self.root = root
        self.tk = tkinter
        self.inbox = inbox
        self.photos: list = []  # the canvas' images: Tk frees a photo nobody holds
        self.label = ""
        self.started = time.monotonic()
        self.progress = (0.0, 0.0)
        self.done = False
        self.pause = False
        self.stopping = False
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

    def poll(self) -> None:
        """Draw what came in since the last poll, then look again in POLL_MS."""
        while True:
            try:
                item = self.inbox.get_nowait()
            except queue.Empty:
                break
            if item is None or item[0] == b"C":
                self.root.quit()
                return
            kind, payload = item
            if kind == b"T":
                self.draw(payload)
            elif kind == b"F":
                self.start(json.loads(payload))
            elif kind == b"P":
                self.progress = struct.unpack(">dd", payload)
            elif kind == b"L":
                self.root.update_idletasks()  # the pass drawn before its title says so
                self.set_title(f"{self.name} — {payload.decode()}")
            elif kind == b"D":
                self.done, self.pause = True, payload == b"\x01"
        # drawn before the title changes, so a title never speaks of what is not shown
        self.root.update_idletasks()
        self.update_title()
        self.root.after(POLL_MS, self.poll)

    def start(self, frame: dict) -> None:
        self.label = frame["label"]
        self.started = time.monotonic()
        self.progress = (0.0, 0.0)
        self.canvas.configure(width=frame["width"], height=frame["height"])
        self.canvas.delete("all")
        self.photos.clear()

    def draw(self, payload: bytes) -> None:
        x, y, w, h = struct.unpack(">IIII", payload[:16])
        ppm = b"P6 %d %d 255\n" % (w, h) + payload[16:]
        photo = self.tk.PhotoImage(master=self.root, data=ppm, format="ppm")
        self.photos.append(photo)
        self.canvas.create_image(x, y, image=photo, anchor="nw")

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


def main(argv: list[str]) -> int:
    name = argv[1] if len(argv) > 1 else "strala"
    try:  # the window takes the time the render leaves, not the render's
        os.nice(NICE)
    except (AttributeError, OSError):  # no nice (Windows) or not allowed: as it is
        pass
    try:
        import tkinter

        root = tkinter.Tk(className="strala")
    except Exception as exc:  # no Tk, a display that refuses us: said in one line
        text = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
        _say(f"error {text}")
        return 1
    inbox: queue.SimpleQueue = queue.SimpleQueue()
    threading.Thread(target=_read, args=(sys.stdin.buffer, inbox), daemon=True).start()
    viewer = Viewer(name, root, tkinter, inbox)
    _say(f"ready {root.winfo_screenwidth()} {root.winfo_screenheight()}")
    viewer.poll()
    root.mainloop()
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
