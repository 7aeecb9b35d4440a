"""Hand-made inputs that broke the checker or the renderer (issue 22's list): each costs
bounded time and memory and ends in diagnostics, never an internal error."""

from __future__ import annotations

import resource
import subprocess
import sys
import time

import pytest

from lang.parser import parse


def _peak_mb_of(code: str) -> float:
    """The peak resident size of a fresh interpreter running `code`, in MB."""
    out = subprocess.run(
        [sys.executable, "-c", code + "\nimport resource\n"
         "print(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss)"],
        capture_output=True, text=True, check=True, timeout=300,
    )  # fmt: skip
    return int(out.stdout.split()[-1]) / 1024


def test_a_long_string_literal_costs_memory_in_proportion():
    # a 1 MB literal took 1 GB: the string pattern's repeated group kept state per character
    base = _peak_mb_of("from lang.parser import parse; parse('#declare S = \"a\";', 's.pov')")
    peak = _peak_mb_of(
        "from lang.parser import parse\nparse('#declare S = \"' + 'a' * 1_000_000 + '\";', 's.pov')"
    )
    assert peak - base < 100, (base, peak)
    assert resource.getrusage(resource.RUSAGE_SELF).ru_maxrss > 0


@pytest.mark.parametrize("flood", ["} ", ") ", "#end ", "#else ", "> "])
def test_syntax_recovery_is_linear(flood):
    # 8,000 unmatched `}` took 31 s: each one rescanned the braces from the chunk's start
    def took(n: int) -> float:
        start = time.perf_counter()
        parse(flood * n, "f.pov")
        return time.perf_counter() - start

    took(500)  # warm the parser
    small, large = took(2_000), took(16_000)
    assert large < 12 * max(small, 0.02), (small, large)  # 8 times the input
