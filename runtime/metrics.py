"""Image error metrics for benchmarks and golden tests: RMSE, the share of pixels off by
more than a threshold, and SSIM (Wang, Bovik, Sheikh & Simoncelli 2004) on luminance.

Images are (H, W, 3) floats in display space [0, 1], as image files hold them."""

from __future__ import annotations

import numpy as np

# SSIM's constants for a dynamic range of 1 (the paper's K1 = 0.01, K2 = 0.03), and its
# 11-tap Gaussian window of σ = 1.5.
SSIM_C1 = (0.01 * 1.0) ** 2
SSIM_C2 = (0.03 * 1.0) ** 2
SSIM_SIGMA = 1.5
SSIM_RADIUS = 5
# Rec. 709 luma weights: SSIM is computed on the grey image people compare.
LUMA = np.array([0.2126, 0.7152, 0.0722])


def rmse(a: np.ndarray, b: np.ndarray) -> float:
    return float(np.sqrt(np.mean((np.asarray(a, float) - np.asarray(b, float)) ** 2)))


def off_share(a: np.ndarray, b: np.ndarray, threshold: float = 0.1) -> float:
    """The share of pixels whose largest channel difference exceeds `threshold`."""
    diff = np.abs(np.asarray(a, float) - np.asarray(b, float))
    return float(np.mean(diff.max(axis=-1) > threshold)) if diff.ndim == 3 else 0.0


def _blur(img: np.ndarray) -> np.ndarray:
    """Separable Gaussian filter, valid part only (no padding, as the paper's windows)."""
    x = np.arange(-SSIM_RADIUS, SSIM_RADIUS + 1)
    k = np.exp(-(x**2) / (2 * SSIM_SIGMA**2))
    k /= k.sum()
    rows = sum(w * img[:, i : img.shape[1] - 2 * SSIM_RADIUS + i] for i, w in enumerate(k))
    return sum(w * rows[i : rows.shape[0] - 2 * SSIM_RADIUS + i, :] for i, w in enumerate(k))


def ssim(a: np.ndarray, b: np.ndarray) -> float:
    """Mean SSIM of the luminance of two images (1 = identical). Images smaller than the
    window fall back to one global window."""
    ga = np.asarray(a, float) @ LUMA if np.ndim(a) == 3 else np.asarray(a, float)
    gb = np.asarray(b, float) @ LUMA if np.ndim(b) == 3 else np.asarray(b, float)
    if min(ga.shape) <= 2 * SSIM_RADIUS:
        mu_a, mu_b = ga.mean(), gb.mean()
        va, vb = ga.var(), gb.var()
        cov = ((ga - mu_a) * (gb - mu_b)).mean()
    else:
        mu_a, mu_b = _blur(ga), _blur(gb)
        va = _blur(ga * ga) - mu_a**2
        vb = _blur(gb * gb) - mu_b**2
        cov = _blur(ga * gb) - mu_a * mu_b
    num = (2 * mu_a * mu_b + SSIM_C1) * (2 * cov + SSIM_C2)
    den = (mu_a**2 + mu_b**2 + SSIM_C1) * (va + vb + SSIM_C2)
    return float(np.mean(num / den))
