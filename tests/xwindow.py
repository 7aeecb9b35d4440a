"""A test's own X client (Xlib through ctypes): a virtual screen (Xvfb), and the windows on
it found by title, read back pixel by pixel from the X server, sent keys and closed as a
window manager closes them (WM_DELETE_WINDOW). Nothing of strala is used here: what the
window shows is what the X server holds."""

from __future__ import annotations

import ctypes
import ctypes.util
import os
import shutil
import subprocess
import time
from collections.abc import Iterator

import numpy as np

_ZPIXMAP = 2
_CLIENT_MESSAGE = 33
_KEY_PRESS, _KEY_RELEASE = 2, 3
_KEY_PRESS_MASK = 1


class _XImage(ctypes.Structure):
    _fields_ = [
        ("width", ctypes.c_int),
        ("height", ctypes.c_int),
        ("xoffset", ctypes.c_int),
        ("format", ctypes.c_int),
        ("data", ctypes.c_void_p),
        ("byte_order", ctypes.c_int),
        ("bitmap_unit", ctypes.c_int),
        ("bitmap_bit_order", ctypes.c_int),
        ("bitmap_pad", ctypes.c_int),
        ("depth", ctypes.c_int),
        ("bytes_per_line", ctypes.c_int),
        ("bits_per_pixel", ctypes.c_int),
        ("red_mask", ctypes.c_ulong),
        ("green_mask", ctypes.c_ulong),
        ("blue_mask", ctypes.c_ulong),
    ]


class _ClientMessage(ctypes.Structure):
    _fields_ = [
        ("type", ctypes.c_int),
        ("serial", ctypes.c_ulong),
        ("send_event", ctypes.c_int),
        ("display", ctypes.c_void_p),
        ("window", ctypes.c_ulong),
        ("message_type", ctypes.c_ulong),
        ("format", ctypes.c_int),
        ("data", ctypes.c_long * 5),
    ]


class _KeyEvent(ctypes.Structure):
    _fields_ = [
        ("type", ctypes.c_int),
        ("serial", ctypes.c_ulong),
        ("send_event", ctypes.c_int),
        ("display", ctypes.c_void_p),
        ("window", ctypes.c_ulong),
        ("root", ctypes.c_ulong),
        ("subwindow", ctypes.c_ulong),
        ("time", ctypes.c_ulong),
        ("x", ctypes.c_int),
        ("y", ctypes.c_int),
        ("x_root", ctypes.c_int),
        ("y_root", ctypes.c_int),
        ("state", ctypes.c_uint),
        ("keycode", ctypes.c_uint),
        ("same_screen", ctypes.c_int),
    ]


class _XEvent(ctypes.Union):
    _fields_ = [("client", _ClientMessage), ("key", _KeyEvent), ("pad", ctypes.c_long * 24)]


def _xlib() -> ctypes.CDLL:
    lib = ctypes.CDLL(ctypes.util.find_library("X11") or "libX11.so.6")
    lib.XOpenDisplay.restype = ctypes.c_void_p
    lib.XOpenDisplay.argtypes = [ctypes.c_char_p]
    lib.XDefaultRootWindow.restype = ctypes.c_ulong
    lib.XDefaultRootWindow.argtypes = [ctypes.c_void_p]
    ulong_p = ctypes.POINTER(ctypes.c_ulong)
    lib.XQueryTree.argtypes = [
        ctypes.c_void_p, ctypes.c_ulong, ulong_p, ulong_p,
        ctypes.POINTER(ulong_p), ctypes.POINTER(ctypes.c_uint),
    ]  # fmt: skip
    lib.XFetchName.argtypes = [ctypes.c_void_p, ctypes.c_ulong, ctypes.POINTER(ctypes.c_char_p)]
    lib.XFree.argtypes = [ctypes.c_void_p]
    uint_p = ctypes.POINTER(ctypes.c_uint)
    int_p = ctypes.POINTER(ctypes.c_int)
    lib.XGetGeometry.argtypes = [
        ctypes.c_void_p, ctypes.c_ulong, ulong_p, int_p, int_p, uint_p, uint_p, uint_p, uint_p,
    ]  # fmt: skip
    lib.XGetImage.restype = ctypes.POINTER(_XImage)
    lib.XGetImage.argtypes = [
        ctypes.c_void_p, ctypes.c_ulong, ctypes.c_int, ctypes.c_int, ctypes.c_uint,
        ctypes.c_uint, ctypes.c_ulong, ctypes.c_int,
    ]  # fmt: skip
    lib.XInternAtom.restype = ctypes.c_ulong
    lib.XInternAtom.argtypes = [ctypes.c_void_p, ctypes.c_char_p, ctypes.c_int]
    lib.XSendEvent.argtypes = [
        ctypes.c_void_p, ctypes.c_ulong, ctypes.c_int, ctypes.c_long, ctypes.POINTER(_XEvent),
    ]  # fmt: skip
    lib.XStringToKeysym.restype = ctypes.c_ulong
    lib.XStringToKeysym.argtypes = [ctypes.c_char_p]
    lib.XKeysymToKeycode.restype = ctypes.c_ubyte
    lib.XKeysymToKeycode.argtypes = [ctypes.c_void_p, ctypes.c_ulong]
    lib.XSetInputFocus.argtypes = [ctypes.c_void_p, ctypes.c_ulong, ctypes.c_int, ctypes.c_ulong]
    lib.XFlush.argtypes = [ctypes.c_void_p]
    lib.XSync.argtypes = [ctypes.c_void_p, ctypes.c_int]
    lib.XCloseDisplay.argtypes = [ctypes.c_void_p]
    return lib


class Screen:
    """A connection to the X display `name` (":99")."""

    def __init__(self, name: str):
        self.x = _xlib()
        self.display = self.x.XOpenDisplay(name.encode())
        if not self.display:
            raise OSError(f"cannot open X display {name}")
        self.root = self.x.XDefaultRootWindow(self.display)

    def close(self) -> None:
        self.x.XCloseDisplay(self.display)

    def _children(self, window: int) -> list[int]:
        root, parent = ctypes.c_ulong(), ctypes.c_ulong()
        kids = ctypes.POINTER(ctypes.c_ulong)()
        n = ctypes.c_uint()
        if not self.x.XQueryTree(
            self.display, window, ctypes.byref(root), ctypes.byref(parent), ctypes.byref(kids),
            ctypes.byref(n),
        ):  # fmt: skip
            return []
        out = [kids[i] for i in range(n.value)]
        if kids:
            self.x.XFree(kids)
        return out

    def _windows(self, window: int) -> Iterator[int]:
        for child in self._children(window):
            yield child
            yield from self._windows(child)

    def title(self, window: int) -> str | None:
        name = ctypes.c_char_p()
        if not self.x.XFetchName(self.display, window, ctypes.byref(name)) or not name.value:
            return None
        text = name.value.decode("utf-8", "replace")
        self.x.XFree(name)
        return text

    def find(self, prefix: str) -> list[tuple[int, str]]:
        """(window, title) of every window whose title starts with `prefix`."""
        found = []
        for w in self._windows(self.root):
            t = self.title(w)
            if t is not None and t.startswith(prefix):
                found.append((w, t))
        return found

    def wait_for(self, prefix: str, timeout: float = 60.0, contains: str = "") -> int:
        """The window whose title starts with `prefix` (and holds `contains`), once there."""
        end = time.monotonic() + timeout
        while time.monotonic() < end:
            for w, t in self.find(prefix):
                if contains in t:
                    return w
            time.sleep(0.05)
        seen = [t for _, t in self.find("")]
        raise TimeoutError(f"no window titled {prefix!r}…{contains!r} in {timeout} s; {seen}")

    def wait_title(self, window: int, contains: str, timeout: float = 60.0) -> str:
        """The title of `window` once it holds `contains`, looked at every 2 ms (a timing
        is not rounded up to the 50 ms `wait_for` looks at all windows with)."""
        end = time.monotonic() + timeout
        while time.monotonic() < end:
            title = self.title(window)
            if title is not None and contains in title:
                return title
            time.sleep(0.002)
        raise TimeoutError(f"the window's title never held {contains!r}: {self.title(window)}")

    def size(self, window: int) -> tuple[int, int]:
        root = ctypes.c_ulong()
        x, y = ctypes.c_int(), ctypes.c_int()
        w, h, border, depth = ctypes.c_uint(), ctypes.c_uint(), ctypes.c_uint(), ctypes.c_uint()
        self.x.XGetGeometry(
            self.display, window, ctypes.byref(root), ctypes.byref(x), ctypes.byref(y),
            ctypes.byref(w), ctypes.byref(h), ctypes.byref(border), ctypes.byref(depth),
        )  # fmt: skip
        return w.value, h.value

    def pixels(self, window: int) -> np.ndarray:
        """(H, W, 3) uint8: the window's contents as the X server holds them (24-bit
        TrueColor, 32 bits a pixel, as Xvfb's default screen is)."""
        w, h = self.size(window)
        img = self.x.XGetImage(self.display, window, 0, 0, w, h, ~0 & 0xFFFFFFFF, _ZPIXMAP)
        if not img:
            raise OSError("XGetImage failed")
        im = img.contents
        if im.bits_per_pixel != 32 or (im.red_mask, im.green_mask, im.blue_mask) != (
            0xFF0000, 0xFF00, 0xFF,
        ):  # fmt: skip
            raise OSError(f"unexpected visual: {im.bits_per_pixel} bits, masks {im.red_mask:x}")
        raw = ctypes.string_at(im.data, im.bytes_per_line * im.height)
        rows = np.frombuffer(raw, dtype="<u4").reshape(im.height, im.bytes_per_line // 4)
        rows = rows[:, : im.width]
        out = np.stack([(rows >> 16) & 255, (rows >> 8) & 255, rows & 255], axis=-1)
        self.x.XFree(im.data)
        self.x.XFree(img)
        return out.astype(np.uint8)

    def close_window(self, window: int) -> None:
        """What a window manager's close button sends: WM_DELETE_WINDOW."""
        event = _XEvent()
        event.client.type = _CLIENT_MESSAGE
        event.client.window = window
        event.client.message_type = self.x.XInternAtom(self.display, b"WM_PROTOCOLS", 0)
        event.client.format = 32
        event.client.data[0] = self.x.XInternAtom(self.display, b"WM_DELETE_WINDOW", 0)
        event.client.data[1] = 0  # CurrentTime
        self.x.XSendEvent(self.display, window, 0, 0, ctypes.byref(event))
        self.x.XSync(self.display, 0)

    def key(self, window: int, key: str) -> None:
        """Press and release `key` in the window, giving it the keyboard focus first."""
        self.x.XSetInputFocus(self.display, window, 2, 0)  # RevertToParent, CurrentTime
        self.x.XSync(self.display, 0)
        time.sleep(0.1)  # the focus change reaches the client before the key does
        code = self.x.XKeysymToKeycode(self.display, self.x.XStringToKeysym(key.encode()))
        for kind in (_KEY_PRESS, _KEY_RELEASE):
            event = _XEvent()
            k = event.key
            k.type, k.window, k.root, k.keycode, k.same_screen = kind, window, self.root, code, 1
            self.x.XSendEvent(self.display, window, 1, _KEY_PRESS_MASK, ctypes.byref(event))
        self.x.XSync(self.display, 0)


class VirtualScreen:
    """An Xvfb server of its own (a free display number, chosen by Xvfb), 24-bit."""

    def __init__(self, width: int = 1600, height: int = 1200):
        xvfb = shutil.which("Xvfb")
        if xvfb is None:
            raise FileNotFoundError("Xvfb is not installed (Debian: apt-get install xvfb)")
        read, write = os.pipe()
        self.proc = subprocess.Popen(
            [xvfb, "-displayfd", str(write), "-screen", "0", f"{width}x{height}x24",
             "-nolisten", "tcp"],
            pass_fds=(write,), stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
        )  # fmt: skip
        os.close(write)
        with os.fdopen(read) as f:
            number = f.readline().strip()
        if not number:
            self.proc.kill()
            raise OSError("Xvfb did not start")
        self.name = f":{number}"

    def stop(self) -> None:
        self.proc.terminate()
        self.proc.wait(timeout=10)
