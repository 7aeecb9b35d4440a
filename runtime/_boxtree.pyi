"""The box tree's build and queries in C (runtime/kernel/boxtree.c), wrapped by
runtime/trace.py."""

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
def slab(
    o: np.ndarray,
    inv: np.ndarray,
    tmin: np.ndarray,
    tmax: np.ndarray,
    lo: np.ndarray,
    hi: np.ndarray,
    rel: float,
    abs: float,
    out: np.ndarray,
    /,
) -> None: ...
def query(
    node_lo: np.ndarray,
    node_hi: np.ndarray,
    kids: np.ndarray,
    first: np.ndarray,
    count: np.ndarray,
    order: np.ndarray,
    o: np.ndarray,
    inv: np.ndarray,
    tmin: np.ndarray,
    tmax: np.ndarray,
    rel: float,
    abs: float,
    n_items: int,
    starts: np.ndarray,
    /,
) -> bytearray: ...
