"""Radiosity as the reflectance goes to 1: the white furnace (a closed sphere or box that
emits E and reflects rho, seen from inside) has the exact answer E / (1 - rho) in every
pixel. At rho = 0.999 that is 1000 E, a sum of thousands of bounces: an iterative solver
that stops early, or leaks energy through the seams between patches, misses it by far more
than 1%. tests/test_radiosity_furnace.py covers rho up to 0.99 through the command line;
here the same scene is solved in process at 0.999, also scaled to 1e-3 and 1e6 (with its
patch size), and in a box, whose flat patches meet at right-angled seams."""

from __future__ import annotations

import numpy as np
import pytest

from runtime import api
from stress.acne import num

E = 0.05
RHO = 0.999

SPHERE = "sphere { <0.1, 0.2, 0.3>, 2"
BOX = "box { <-2, -2, -2>, <2.5, 2, 2>"


def furnace(shape: str, s: float, patch: float) -> np.ndarray:
    text = f"""#version 3.7;
global_settings {{ assumed_gamma 1.0 radiosity {{ converged on patch_size {num(patch * s)} }} }}
camera {{ location <0.3, -0.4, -0.5> look_at <1, 0.2, 1> angle 100 scale {num(s)} }}
{shape} scale {num(s)}
  pigment {{ rgb 1 }} finish {{ ambient 0 diffuse {RHO} emission {E} }} }}
"""
    return api.render(api.compile_string(text), width=16, height=16, linear=True)


@pytest.mark.parametrize(
    "shape, s, patch",
    [(SPHERE, 1e-3, 1.0), (SPHERE, 1.0, 1.0), (SPHERE, 1e6, 1.0), (BOX, 1e-3, 2.0),
     (BOX, 1e6, 2.0)],
)  # fmt: skip
def test_white_furnace_at_rho_0999(shape, s, patch):
    img = furnace(shape, s, patch)
    exact = E / (1 - RHO)
    assert np.isfinite(img).all()
    # The worst pixel, not a mean, within 1% (measured: 4e-5 or better).
    assert np.abs(img / exact - 1).max() < 0.01, (img.min(), img.max(), exact)
