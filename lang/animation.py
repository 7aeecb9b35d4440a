"""An animation's frames as POV-Ray 3.7 numbers them: the frame range (+KFI/+KFF), the
clock range (+KI/+KF), a cyclic animation (+KC), a subset of the frames (+SF/+EF) and a
frame step (+STP); each frame's clock and the identifiers the scene sees.

A cyclic animation counts one frame more than it renders (the one that would repeat the
first): clock_delta is (final_clock - initial_clock) / frames, not / (frames - 1), and the
scene sees that extra frame as final_frame, as POV-Ray's does.
"""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class Animation:
    initial_frame: int = 1
    final_frame: int = 1
    initial_clock: float = 0.0
    final_clock: float = 1.0
    cyclic: bool = False
    subset_start: float | None = None  # a frame number, or a fraction of the frames in (0, 1)
    subset_end: float | None = None
    frame_step: int = 1

    @property
    def first(self) -> int:
        return max(self.initial_frame, 0)

    @property
    def last(self) -> int:
        """The last frame counted (one past the last rendered when cyclic)."""
        last = max(self.final_frame, self.first)
        return last + 1 if self.cyclic and not self.is_still else last

    @property
    def is_still(self) -> bool:
        """One frame only: POV-Ray renders a still image (every animation identifier 0)."""
        return max(self.final_frame, self.first) == self.first

    @property
    def clock_delta(self) -> float:
        if self.is_still:
            return 0.0
        return (self.final_clock - self.initial_clock) / (self.last - self.first)

    @property
    def digits(self) -> int:
        """The width of the frame number in image names."""
        return len(str(self.last))

    def _subset(self, value: float | None, default: int) -> int:
        if value is None:
            return default
        value = max(value, 0.0)
        if value == 0.0 or value >= 1.0:
            return int(value)
        return int((self.last - self.first + 1) * value)

    def frames(self) -> list[int]:
        """The frame numbers rendered, in order."""
        if self.is_still:
            return [self.first]
        start = max(self._subset(self.subset_start, self.first), self.first)
        end = self._subset(self.subset_end, self.last - 1 if self.cyclic else self.last)
        return list(range(start, max(end, start) + 1, max(self.frame_step, 1)))

    def clock(self, frame: int) -> float:
        if self.is_still:
            return 0.0
        return self.clock_delta * (frame - self.first) + self.initial_clock

    def values(self, frame: int) -> dict[str, float]:
        """The identifiers frame `frame` sees (for a still image: all 0 but clock_on)."""
        if self.is_still:
            return {**dict.fromkeys(NAMES, 0.0), "clock_on": 0.0}
        return {
            "frame_number": float(frame),
            "initial_frame": float(self.first),
            "final_frame": float(self.last),
            "initial_clock": self.initial_clock,
            "final_clock": self.final_clock,
            "clock_delta": self.clock_delta,
            "clock_on": 1.0,
        }


NAMES = (
    "frame_number",
    "initial_frame",
    "final_frame",
    "initial_clock",
    "final_clock",
    "clock_delta",
    "clock_on",
)
