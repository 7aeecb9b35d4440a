"""POV-Ray's `text`: TrueType glyph outlines (lines and quadratic Béziers) in the x-y plane,
one em high per unit, baseline at y = 0, swept along z from 0 to the thickness.

Layout follows POV-Ray 3.7: the first glyph is moved so its left edge sits at x = 0 and the
pen then advances by its advance width less its left side bearing; every later glyph is
placed at the pen plus its bearing and the pair's kerning, and the pen moves on by its
advance width (plus kerning); the text's `offset` is added after each character (its z
is not used for placement, as in POV-Ray). Each glyph is filled by the even-odd rule and
the glyphs form a union.
"""

from __future__ import annotations

import numpy as np

from lang import ir
from runtime.prims import spline2d as sp
from runtime.prims.prism import Sweep
from runtime.prims.truetype import contour_segments, load_font


def glyph_curves(shape: ir.Text) -> list[sp.Curve]:
    """One Curve per visible glyph of the string, placed on the line."""
    font = load_font(shape.font)
    fu = 1.0 / font.units_per_em
    total = np.zeros(2)
    last = 0
    curves = []
    for i, ch in enumerate(shape.string):
        index = font.glyph_index(ch)
        glyph = font.glyph(index) if ch != " " else font.glyph(-1)
        metrics = glyph.metrics if ch != " " else index
        adv = int(font.advance[min(metrics, len(font.advance) - 1)])
        lsb = int(font.lsb[metrics]) if metrics < len(font.lsb) else 0
        if i == 0:
            pos = np.array([-glyph.xmin, 0.0])
            total[0] = (adv - lsb) * fu
        else:
            kern = max(font.kern.get((last, metrics), 0), -font.units_per_em)
            pos = np.array([total[0] + (lsb + kern) * fu - glyph.xmin, total[1]])
            total[0] += (adv + kern) * fu
        total += np.asarray(shape.offset[:2], dtype=np.float64)
        last = index
        segs = [contour_segments(c) for c in glyph.contours]
        coef = np.concatenate(segs) if segs else np.zeros((0, 2, 4))
        if len(coef):
            coef = coef.copy()
            coef[:, :, 3] += pos  # translate: the constant terms
            curves.append(sp.Curve(coef))
    return curves


class TextPrim(Sweep):
    """ir.Text: glyph curves in x (u) and y (v), swept along z from 0 to the thickness."""

    def __init__(self, shape: ir.Text):
        super().__init__(glyph_curves(shape), 0.0, float(shape.thickness), axes=(0, 1, 2))
