"""Print the shadow-acne table (share of must-be-lit pixels that come out shadowed, per
shape and scale), for the record: `python tests/stress/report_acne.py` from the repository
root. The same measurements are asserted by test_acne.py."""

from __future__ import annotations

import sys
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path[:0] = [str(HERE.parent.parent), str(HERE.parent)]

from stress import acne  # noqa: E402


def main() -> None:
    start = time.perf_counter()
    rows = acne.table()
    print(acne.format_table(rows))
    w, h = acne.SIZE
    print(
        f"\n{w}x{h} pixels, N·L margin {acne.MARGIN}; acne required 0 on "
        f"{acne.ACNE_SCALES[0]:.0e}..{acne.ACNE_SCALES[-1]:.0e}; "
        f"{time.perf_counter() - start:.1f} s"
    )


if __name__ == "__main__":
    main()
