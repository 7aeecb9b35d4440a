"""How alike two renders are: the conformance criterion, on [0, 1] display values."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

RMSE_LIMIT = 0.05  # a match: RMSE below this …
OFF_DIFF = 0.1  # … and a pixel is "off" when some channel differs by more than this …
OFF_LIMIT = 0.03  # … and fewer than this share of the pixels are off


@dataclass(frozen=True)
class Comparison:
    rmse: float
    off: float  # share of pixels with some channel off by more than OFF_DIFF

    @property
    def match(self) -> bool:
        return self.rmse < RMSE_LIMIT and self.off < OFF_LIMIT


def compare(ours: np.ndarray, theirs: np.ndarray) -> Comparison:
    """RMSE over all channels and the share of off pixels; images are (H, W, 3)."""
    if ours.shape != theirs.shape:
        raise ValueError(f"image sizes differ: {ours.shape} vs {theirs.shape}")
    diff = ours.astype(np.float64) - theirs.astype(np.float64)
    return Comparison(
        rmse=float(np.sqrt(np.mean(diff**2))),
        off=float(np.mean(np.abs(diff).max(axis=2) > OFF_DIFF)),
    )


def read_rgb(path: Path) -> np.ndarray:
    """An image file as (H, W, 3) floats in [0, 1] (alpha dropped, grey expanded)."""
    import OpenImageIO as oiio

    buf = oiio.ImageBuf(str(path))
    pixels = buf.get_pixels(oiio.FLOAT)
    if buf.has_error or pixels is None or pixels.ndim != 3:
        raise OSError(f"cannot read {path}: {buf.geterror()}")
    if pixels.shape[2] < 3:
        pixels = np.repeat(pixels[..., :1], 3, axis=2)
    return pixels[..., :3]
