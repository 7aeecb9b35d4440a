"""The total work one evaluation may do: steps (statements, directives, loop passes, macro
calls) and memory (what the process holds beyond what it held when the evaluation began).

Per-loop limits do not bound a scene: two nested loops of a million passes each, or a macro
that calls itself twice per level forty levels deep, each stay under every per-construct
limit and never finish. A budget is counted across the whole evaluation, and exceeding it
stops the evaluation with one located error (E0238) at the statement that went past it,
keeping what was read before, as POV-Ray's #error does.

`check` and the language server read files an editor opens, often untrusted and half
written, and must answer quickly: their budgets are small (CHECK, EDITOR). A render reads
the scenes its user chose to render, so its budget is large (RENDER) and only there so that
a runaway scene ends with a message instead of filling the machine.
"""

from __future__ import annotations

import os
import threading
from dataclasses import dataclass

# How often (in steps) the process's resident size is read: a read of /proc costs a few
# microseconds, a step about twenty.
MEMORY_EVERY = 4096


def resident_bytes() -> int:
    """The process's resident size now (0 where it cannot be read: no bound then)."""
    try:
        with open("/proc/self/statm", "rb") as f:
            return int(f.read().split()[1]) * os.sysconf("SC_PAGE_SIZE")
    except (OSError, ValueError, IndexError, AttributeError):
        return 0


def physical_bytes() -> int:
    try:
        return os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES")
    except (ValueError, OSError, AttributeError):
        return 0


@dataclass(frozen=True)
class Budget:
    """steps: statements, directives, loop passes and macro calls in all; memory: bytes the
    evaluation may add to the process (0: no bound); who: what the limit is for, said in
    the message."""

    steps: int
    memory: int
    who: str


GIB = 2**30
# A render: about an hour of evaluation at the interpreter's speed, and most of the memory.
RENDER = Budget(steps=100_000_000, memory=max(physical_bytes() * 3 // 4, 2 * GIB), who="render")
# check: seconds, not minutes (a step costs 5-20 µs), and a small share of the machine.
# POV-Ray's benchmark.pov takes 228,159 steps, balcony.pov 134,945.
CHECK = Budget(steps=1_000_000, memory=2 * GIB, who="check")
# the language server re-reads the document at every edit
EDITOR = Budget(steps=300_000, memory=1 * GIB, who="the editor")


class Exceeded(Exception):
    """Raised when the budget is spent; the interpreter reports it once and stops."""

    def __init__(self, message: str, hint: str) -> None:
        super().__init__(message)
        self.message = message
        self.hint = hint


class Cancelled(BaseException):
    """Raised at the next step once the evaluation's `cancel` is set (the language server: a
    newer edit came). A BaseException: no handler of the interpreter's turns it into a
    diagnostic; the evaluation ends and its result is dropped."""


class Meter:
    """A budget being spent by one evaluation; `cancel`, when set, stops it at its next step."""

    def __init__(self, budget: Budget) -> None:
        self.budget = budget
        self.left = budget.steps
        self._until_memory = MEMORY_EVERY
        self._base = resident_bytes()
        self.cancel: threading.Event | None = None

    def step(self, n: int = 1) -> None:
        if self.cancel is not None and self.cancel.is_set():
            raise Cancelled
        self.left -= n
        if self.left < 0:
            raise Exceeded(
                f"the scene did more than {self.budget.steps:,} steps of evaluation "
                f"(the limit for {self.budget.who})",
                "a loop or a recursive macro runs far longer than meant; check its bounds",
            )
        self._until_memory -= n
        if self._until_memory <= 0:
            self._until_memory = MEMORY_EVERY
            self.reserve(0)

    def reserve(self, nbytes: int) -> None:
        """Before allocating `nbytes` (an array, a string): refuse when the evaluation
        would hold more than its memory budget."""
        if not self.budget.memory or not self._base:
            return
        held = resident_bytes() - self._base
        if held + nbytes > self.budget.memory:
            raise Exceeded(
                f"the scene would hold more than {self.budget.memory / GIB:,.1f} GiB "
                f"(the limit for {self.budget.who}; {held / GIB:,.1f} GiB held now)",
                "arrays, strings or objects made in a loop add up; check the sizes",
            )
