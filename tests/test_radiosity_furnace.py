"""White furnace through the real command line: the camera inside a closed sphere that
emits E and reflects ρ sees L = E/(1−ρ) everywhere (every bounce, no bias), ρ up to 0.99.

POV-Ray multiplies emission by the pigment colour, and the reflectance is pigment ×
diffuse, so with `pigment { rgb 1 }` the emitted light is E and ρ = diffuse: the exact
image is E/(1−ρ) in every pixel and channel (E = 0.05: 0.1, 0.5 and 5.0 for ρ = 0.5, 0.9,
0.99). The image is written as linear EXR, so no transfer curve stands in between.
"""

from __future__ import annotations

import numpy as np
import pytest
from conftest import run_cli

E = 0.05

FURNACE = """#version 3.7;
global_settings {{ assumed_gamma 1.0 radiosity {{ patch_size 1 converged on }} }}
camera {{ location <0.3, -0.4, -0.5> look_at <1, 0.2, 1> angle 100 }}
sphere {{ <0.1, 0.2, 0.3>, 2
  pigment {{ rgb 1 }} finish {{ ambient 0 diffuse {rho} emission {e} }} }}
"""


def _read(path) -> np.ndarray:
    import OpenImageIO as oiio

    return oiio.ImageBuf(str(path)).get_pixels(oiio.FLOAT)[..., :3]


@pytest.mark.parametrize("rho", [0.5, 0.9, 0.99])
def test_closed_sphere_renders_the_exact_furnace(tmp_path, rho):
    scene = tmp_path / "furnace.pov"
    scene.write_text(FURNACE.format(rho=rho, e=E))
    out = tmp_path / "furnace.exr"
    proc = run_cli("render", str(scene), "-W", "32", "-H", "32", "-o", str(out))
    assert proc.returncode == 0, proc.stderr
    img = _read(out)
    exact = E / (1 - rho)
    assert img.shape == (32, 32, 3)
    # Uniformly: the worst pixel, not a mean, within 1%.
    assert np.abs(img / exact - 1).max() < 0.01, (img.min(), img.max(), exact)
    assert "warning" not in proc.stderr
    # The solver's figures on stderr: patches, iterations, residual, solve time.
    line = next(s for s in proc.stderr.splitlines() if s.startswith("radiosity:"))
    assert " patches, " in line and " iterations, residual " in line and "solve " in line


def test_quiet_render_prints_no_radiosity_figures(tmp_path):
    scene = tmp_path / "furnace.pov"
    scene.write_text(FURNACE.format(rho=0.5, e=E))
    out = tmp_path / "furnace.exr"
    proc = run_cli("render", str(scene), "-W", "8", "-H", "8", "-o", str(out), "-q")
    assert proc.returncode == 0, proc.stderr
    assert "radiosity:" not in proc.stderr
    assert np.allclose(_read(out), E / 0.5, rtol=0.01)


def test_cached_solution_is_reported_and_reused_from_another_camera(tmp_path):
    """A second render from another camera inside the same sphere takes the solution
    from --radiosity-cache and says so; the furnace value is unchanged."""
    cache = tmp_path / "cache"
    first = FURNACE.format(rho=0.9, e=E)
    other = first.replace("location <0.3, -0.4, -0.5>", "location <-0.6, 0.5, 0.2>")
    lines = []
    for i, text in enumerate((first, other)):
        scene = tmp_path / f"view{i}.pov"
        scene.write_text(text)
        out = tmp_path / f"view{i}.exr"
        proc = run_cli("render", str(scene), "-W", "8", "-H", "8", "-o", str(out),
                       "--radiosity-cache", str(cache))  # fmt: skip
        assert proc.returncode == 0, proc.stderr
        assert np.allclose(_read(out), E / (1 - 0.9), rtol=0.01)
        lines.append(next(s for s in proc.stderr.splitlines() if s.startswith("radiosity:")))
    assert "iterations" in lines[0] and "from the cache" not in lines[0]
    assert lines[1].endswith("patches, solution from the cache")
