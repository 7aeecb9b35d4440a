"""A one-line progress bar with an ETA, drawn on a terminal and silent everywhere else.

The renderer reports work as `progress(done, total)` (any unit: pixels, tiles, patches);
calling the bar is all it needs to know. A first call with done == 0 says the work starts:
the time before it (compiling, preparing) does not count in the estimate of the time left.
Redraws are throttled so a fast stream of small tiles costs nothing; with `tick`, a thread
redraws the line that often between reports, so the elapsed time never stands still and the
ETA counts down. The bar never writes to a pipe or a log file unless forced.
"""

from __future__ import annotations

import math
import shutil
import sys
import threading
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

    enabled=None means "only when `stream` is a terminal"; tick: seconds between the
    redraws of a thread of its own (None: redraw only when called)."""

    def __init__(
        self,
        label: str = "",
        *,
        stream: TextIO | None = None,
        enabled: bool | None = None,
        interval: float = 0.1,
        clock: Callable[[], float] = time.monotonic,
        tick: float | None = None,
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
        self._work_start: float | None = None  # when the work began (the first report)
        self._estimate: tuple[float, float] | None = None  # (when, seconds left then)
        self._lock = threading.Lock()  # the ticker and the caller draw in turn
        self._stopped = threading.Event()
        self._ticker: threading.Thread | None = None
        if enabled and tick:
            self._ticker = threading.Thread(target=self._tick, args=(tick,), daemon=True)
            self._ticker.start()

    def __call__(self, done: float, total: float) -> None:
        now = self.clock()
        with self._lock:
            if self._work_start is None:
                self._work_start = now if done <= 0 else self.start
            if (done, total) != (self.done, self.total) and 0 < done < total:
                # the rate so far, over the work's own time: the estimate the line counts
                # down from until the next report
                self._estimate = (now, (now - self._work_start) * (total - done) / done)
            self.done, self.total = done, total
            if not self.enabled:
                return
            # always draw the final state, otherwise at most once per interval
            if done < total and now - self._last_draw < self.interval:
                return
            self._draw(now)

    def line(self, now: float, width: int) -> str:
        """The status text for the current state, at most `width` characters."""
        frac = 0.0 if self.total <= 0 else min(max(self.done / self.total, 0.0), 1.0)
        elapsed = now - self.start
        if frac >= 1.0:
            tail = f"{format_seconds(elapsed)}"
        elif frac > 0.0 and self._estimate is not None:
            when, left = self._estimate
            left = max(left - (now - when), 0.0)
            tail = f"{format_seconds(elapsed)} elapsed, ETA {format_seconds(left)}"
        else:
            tail = f"{format_seconds(elapsed)} elapsed"
        head = f"{self.label} " if self.label else ""
        text = f" {frac * 100:3.0f}%  {tail}"
        bar_width = max(width - len(head) - len(text) - 2, 0)
        if bar_width >= 10:
            filled = int(round(frac * bar_width))
            return f"{head}[{'#' * filled}{'.' * (bar_width - filled)}]{text}"
        return (head + text.strip())[:width]

    def _tick(self, every: float) -> None:
        while not self._stopped.wait(every):
            with self._lock:
                if self._stopped.is_set():
                    return
                self._draw(self.clock())

    def _draw(self, now: float) -> None:
        self._last_draw = now
        width = shutil.get_terminal_size((80, 24)).columns - 1
        # \r + clear-to-end: the line is rewritten in place, shorter lines leave no debris
        self.stream.write("\r" + self.line(now, width) + "\x1b[K")
        self.stream.flush()
        self._drawn = True

    def close(self) -> None:
        """Stop the ticker; finish the line (only if something was drawn)."""
        self._stopped.set()
        if self._ticker is not None:
            self._ticker.join()
            self._ticker = None
        with self._lock:
            if self.enabled and self._drawn:
                self.stream.write("\n")
                self.stream.flush()
                self._drawn = False

    def __enter__(self) -> Progress:
        return self

    def __exit__(self, *exc) -> None:
        self.close()


class Stages:
    """One progress report over stages of work that cost differently (a radiosity solve,
    its pretrace passes, the tracing), in seconds: `done` the time the work has taken,
    `total` that and what each stage has left: the stage under way as its share done says
    (the time it took so far, stretched to the whole), a stage to come as `expect` said.
    A bar fed these estimates the time left as the sum of the stages' own."""

    def __init__(self, report: ProgressFn, clock: Callable[[], float] = time.perf_counter):
        self._report = report
        self._clock = clock
        self._start = clock()
        self._expected: dict[str, float] = {}
        self._ended: set[str] = set()
        self._stage: str | None = None
        self._began = self._start
        self._share = 0.0
        report(0.0, 1.0)  # the work starts now: what the bar counts the time left from

    def expect(self, stage: str, seconds: float) -> None:
        """What a stage to come (or under way, before it says its share) will take."""
        self._expected[stage] = max(float(seconds), 0.0)

    def begin(self, stage: str) -> None:
        """The stage under way ends (if any) and `stage` begins."""
        if self._stage is not None:
            self._ended.add(self._stage)
        self._stage, self._began, self._share = stage, self._clock(), 0.0
        self._emit()

    def part(self, share: float) -> None:
        """The stage under way is `share` (0 to 1) done."""
        self._share = min(max(float(share), 0.0), 1.0)
        self._emit()

    def end(self) -> None:
        """All done."""
        done = self._clock() - self._start
        self._report(done, done)

    def left(self, now: float) -> float | None:
        """Seconds the work has left (None: no estimate yet)."""
        ran = now - self._began
        later = sum(
            s for k, s in self._expected.items() if k not in self._ended and k != self._stage
        )
        if self._share > 0.0:
            return ran * (1.0 - self._share) / self._share + later
        here = self._expected.get(self._stage or "")
        if here is None and later <= 0.0:
            return None
        return max((here or 0.0) - ran, 0.0) + later

    def _emit(self) -> None:
        now = self._clock()
        left = self.left(now)
        done = now - self._start
        if left is None or done <= 0.0:
            return  # nothing to estimate from: the bar's last estimate counts down
        self._report(done, done + max(left, 1e-9))
