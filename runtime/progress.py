"""A one-line progress bar with an ETA, drawn on a terminal and silent everywhere else.

The renderer reports work as `progress(done, total)` (any unit: pixels, tiles, patches);
calling the bar is all it needs to know. Redraws are throttled so a fast stream of small
tiles costs nothing, and the bar never writes to a pipe or a log file unless forced.
"""

from __future__ import annotations

import math
import shutil
import sys
import time
from collections.abc import Callable
from typing import TextIO

ProgressFn = Callable[[float, float], None]


def format_seconds(seconds: float) -> str:
    """`4.2s`, `3m05s`, `1h02m` — short enough for a status line."""
    if not math.isfinite(seconds):
        return "--"  # an ETA from a vanishingly small fraction done
    if seconds < 60:
        return f"{seconds:.1f}s"
    minutes, secs = divmod(int(round(seconds)), 60)
    if minutes < 60:
        return f"{minutes}m{secs:02d}s"
    hours, minutes = divmod(minutes, 60)
    return f"{hours}h{minutes:02d}m"


class Progress:
    """Callable progress bar: `bar(done, total)`; `bar.close()` ends the line.

    enabled=None means "only when `stream` is a terminal"."""

    def __init__(
        self,
        label: str = "",
        *,
        stream: TextIO | None = None,
        enabled: bool | None = None,
        interval: float = 0.1,
        clock: Callable[[], float] = time.monotonic,
    ):
        self.stream = stream if stream is not None else sys.stderr
        if enabled is None:
            isatty = getattr(self.stream, "isatty", None)
            enabled = bool(isatty and isatty())
        self.enabled = enabled
        self.label = label
        self.interval = interval
        self.clock = clock
        self.start = clock()
        self._last_draw = -float("inf")
        self._drawn = False
        self.done = 0.0
        self.total = 0.0

    def __call__(self, done: float, total: float) -> None:
        self.done, self.total = done, total
        if not self.enabled:
            return
        now = self.clock()
        # always draw the final state, otherwise at most once per interval
        if done < total and now - self._last_draw < self.interval:
            return
        self._last_draw = now
        self._draw(now)

    def line(self, now: float, width: int) -> str:
        """The status text for the current state, at most `width` characters."""
        frac = 0.0 if self.total <= 0 else min(max(self.done / self.total, 0.0), 1.0)
        elapsed = now - self.start
        if frac >= 1.0:
            tail = f"{format_seconds(elapsed)}"
        elif frac > 0.0:
            tail = (
                f"{format_seconds(elapsed)} elapsed, ETA {format_seconds(elapsed / frac - elapsed)}"
            )
        else:
            tail = f"{format_seconds(elapsed)} elapsed"
        head = f"{self.label} " if self.label else ""
        text = f" {frac * 100:3.0f}%  {tail}"
        bar_width = max(width - len(head) - len(text) - 2, 0)
        if bar_width >= 10:
            filled = int(round(frac * bar_width))
            return f"{head}[{'#' * filled}{'.' * (bar_width - filled)}]{text}"
        return (head + text.strip())[:width]

    def _draw(self, now: float) -> None:
        width = shutil.get_terminal_size((80, 24)).columns - 1
        # \r + clear-to-end: the line is rewritten in place, shorter lines leave no debris
        self.stream.write("\r" + self.line(now, width) + "\x1b[K")
        self.stream.flush()
        self._drawn = True

    def close(self) -> None:
        """Finish the line (only if something was drawn)."""
        if self.enabled and self._drawn:
            self.stream.write("\n")
            self.stream.flush()
            self._drawn = False

    def __enter__(self) -> Progress:
        return self

    def __exit__(self, *exc) -> None:
        self.close()
