"""8-bit file values in one pass (runtime/kernel/pixels.c), wrapped by runtime/color.py."""

import numpy as np

def quantise8(values: np.ndarray, thresholds: np.ndarray, out: np.ndarray, /) -> None: ...
