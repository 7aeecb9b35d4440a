"""The box tree's build in C (runtime/kernel/boxtree.c), wrapped by runtime/trace.py."""

import numpy as np

def build(
    n: int,
    leaf: int,
    lo: np.ndarray,
    hi: np.ndarray,
    node_lo: np.ndarray,
    node_hi: np.ndarray,
    kids: np.ndarray,
    first: np.ndarray,
    count: np.ndarray,
    order: np.ndarray,
    /,
) -> int: ...
