"""Colour spaces: POV-Ray 3.7's gamma rules, sRGB encoding, and the anti-aliasing metric.

The renderer computes in the scene's *working* space (colour literals are used as written,
exactly as POV-Ray 3.7 does). `ir.Settings` says what that space is:
- `assumed_gamma g` given: a working value c stands for the linear value c**g;
- no `assumed_gamma`, `#version` >= 3.7: the working space is linear (g = 1);
- no `assumed_gamma`, no `#version` or one below 3.7: *legacy*, no gamma handling at all,
  working values go to the file unchanged.
Files get the sRGB encoding of the linear value (POV-Ray 3.7's default file gamma).
"""

from __future__ import annotations

import numpy as np

from lang import ir

# POV-Ray 3.7's default `Antialias_Gamma`: colours are compared for anti-aliasing after
# this encoding of the linear value, so the threshold is perceptual, not linear.
AA_GAMMA: float = 2.5


def working_gamma(settings: ir.Settings) -> float | None:
    """The working gamma, or None for legacy scenes (no gamma handling)."""
    if settings.assumed_gamma is not None:
        return float(settings.assumed_gamma)
    if settings.version is not None and settings.version >= 3.7:
        return 1.0
    return None


def image_gamma(settings: ir.Settings) -> float | None:
    """The gamma image files are decoded into, or None to take their values unchanged: a
    scene before 3.7 (no #version, or one below 3.7) reads them unchanged even with an
    assumed_gamma (POV-Ray's 3.6 gamma mode makes a file's default gamma the working
    gamma)."""
    if settings.version is None or settings.version < 3.7:
        return None
    return working_gamma(settings)


def _signed_pow(x: np.ndarray, p: float) -> np.ndarray:
    # Negative working values (crand, negative light colours) keep their sign instead of
    # turning into NaN; POV-Ray's power-law curves do the same.
    return np.sign(x) * np.abs(x) ** p


def srgb_encode(linear: np.ndarray) -> np.ndarray:
    """The sRGB transfer function (IEC 61966-2-1) on linear values (not clipped)."""
    x = np.asarray(linear, dtype=np.float64)
    a = np.abs(x)
    enc = np.where(a <= 0.0031308, 12.92 * a, 1.055 * np.power(a, 1.0 / 2.4) - 0.055)
    return np.sign(x) * enc


def srgb_decode(encoded: np.ndarray) -> np.ndarray:
    """Inverse of `srgb_encode`."""
    x = np.asarray(encoded, dtype=np.float64)
    a = np.abs(x)
    dec = np.where(a <= 0.04045, a / 12.92, np.power((a + 0.055) / 1.055, 2.4))
    return np.sign(x) * dec


def to_linear(working: np.ndarray, settings: ir.Settings) -> np.ndarray:
    """Linear-light values for float files (EXR). Legacy scenes have no defined gamma; their
    working values are taken as linear (what POV-Ray writes to an EXR in that case)."""
    w = np.asarray(working, dtype=np.float64)
    g = working_gamma(settings)
    if g is None or g == 1.0:
        return w.astype(np.float32)
    return _signed_pow(w, g).astype(np.float32)


def to_display(working: np.ndarray, settings: ir.Settings) -> np.ndarray:
    """[0,1] values for an 8/16-bit file, clipped (POV-Ray 3.7's gamma rules).

    In float32 (the file holds 8 or 16 bits) and with one power per value: the sRGB
    encoding of w**g is 1.055 w**(g/2.4) - 0.055 above the linear toe (a 1280x960 image
    took 0.3 s through `srgb_encode` in float64)."""
    w = np.clip(np.asarray(working, dtype=np.float32), 0.0, 1.0)
    g = working_gamma(settings)
    if g is None:
        return w
    # Black is common (a third of the seed scene's channels) and slow in a vectorised
    # power: those values take the power of 1 and are set to 0 after it.
    black = w <= 0.0
    out = np.power(np.where(black, np.float32(1.0), w), np.float32(g / 2.4))
    out *= np.float32(1.055)
    out -= np.float32(0.055)
    out[black] = 0.0
    toe = (w <= np.float32(0.0031308 ** (1.0 / g))) & ~black
    if toe.any():
        out[toe] = np.float32(12.92) * np.power(w[toe], np.float32(g))
    return out


def display_thresholds(settings: ir.Settings, levels: int = 256) -> np.ndarray:
    """(levels - 1,) working values at which an integer file value steps up: level k holds
    the working values whose display value rounds to k / (levels - 1), so these are the
    display values (k + 1/2) / (levels - 1) taken back through sRGB and the working gamma."""
    d = (np.arange(levels - 1, dtype=np.float64) + 0.5) / (levels - 1)
    g = working_gamma(settings)
    if g is None:
        return d
    return srgb_decode(d) ** (1.0 / g)


def to_display8(working: np.ndarray, settings: ir.Settings) -> np.ndarray:
    """uint8 file values of a working-space image: `to_display` rounded to 8 bits, in one
    compiled pass when the pixel kernel is built (see kernel/pixels.c)."""
    try:
        from runtime import _pixels
    except ImportError:  # pragma: no cover - depends on the build
        _pixels = None  # type: ignore[assignment]  # typed by the import: module or None
    if _pixels is None:
        return np.rint(to_display(working, settings) * 255.0).astype(np.uint8)
    src = np.ascontiguousarray(working, dtype=np.float32)
    out = np.empty(src.shape, dtype=np.uint8)
    _pixels.quantise8(src, display_thresholds(settings), out)
    return out


def aa_metric_power(settings: ir.Settings, gamma: float = AA_GAMMA) -> float:
    """The one power that takes a (clipped) working value to the anti-aliasing metric
    space: through the working gamma to linear, then encoded with 1/gamma (+AG, POV-Ray's
    Antialias_Gamma; 0 or less: compared linear, as POV-Ray then has no curve)."""
    g = working_gamma(settings)
    return (1.0 if g is None else g) / (gamma if gamma > 0.0 else 1.0)


def aa_metric_space(
    working: np.ndarray, settings: ir.Settings, gamma: float = AA_GAMMA
) -> np.ndarray:
    """Colours as POV-Ray compares them for anti-aliasing: working → linear (through the
    working gamma, skipped for legacy scenes) → encoded with 1/gamma, in one power."""
    w = np.clip(np.asarray(working, dtype=np.float64), 0.0, None)
    return w ** aa_metric_power(settings, gamma)


def colour_distance(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """POV-Ray's colour distance: the sum of absolute channel differences (last axis)."""
    return np.abs(np.asarray(a) - np.asarray(b)).sum(axis=-1)
