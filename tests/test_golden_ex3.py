"""The first milestone: the seed's Ex3 rendered by strala looks like POV-Ray 3.7's render.

Both images are compared as [0, 1] display values (what lands in the PNG): the RMSE must
stay below 0.05 and fewer than 3% of the pixels may differ by more than 0.1 in any channel
(edges and the reflected checker alias differently in two ray tracers). Also here: the
seed's own listing, stray brace included, and `check` staying light.
"""

from __future__ import annotations

import shutil
import subprocess
import sys
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pytest
from conftest import EXAMPLES, ROOT, SEED, run_cli

from runtime import cli

EX3 = EXAMPLES / "ex3.scene"
POVRAY_INCLUDE = Path("/usr/share/povray-3.7/include")
RMSE_LIMIT = 0.05
OUTLIER_DIFF = 0.1
OUTLIER_LIMIT = 0.03


@dataclass(frozen=True)
class Comparison:
    rmse: float
    outliers: float  # fraction of pixels whose largest channel difference exceeds 0.1
    mean_diff: tuple[float, float, float]  # signed strala − POV-Ray per channel (bias)

    def __str__(self) -> str:
        bias = ", ".join(f"{v:+.4f}" for v in self.mean_diff)
        return f"RMSE {self.rmse:.4f}, outliers {self.outliers * 100:.2f}%, bias ({bias})"


def compare(ours: np.ndarray, theirs: np.ndarray) -> Comparison:
    assert ours.shape == theirs.shape, (ours.shape, theirs.shape)
    diff = ours.astype(np.float64) - theirs.astype(np.float64)
    return Comparison(
        rmse=float(np.sqrt(np.mean(diff**2))),
        outliers=float(np.mean(np.abs(diff).max(axis=2) > OUTLIER_DIFF)),
        mean_diff=tuple(float(v) for v in diff.reshape(-1, diff.shape[2]).mean(axis=0)),
    )


def povray_render(scene: Path, width: int, height: int, aa: float | None, workdir: Path) -> Path:
    """POV-Ray's render of `scene`, run in `workdir` so its side files land there."""
    pov = workdir / (scene.stem + ".pov")
    shutil.copyfile(scene, pov)
    out = workdir / "povray.png"
    cmd = ["povray", f"+I{pov.name}", f"+O{out.name}", f"+W{width}", f"+H{height}", "-D", "-V"]
    cmd.append(f"+A{aa}" if aa is not None else "-A")
    if POVRAY_INCLUDE.is_dir():
        cmd.append(f"+L{POVRAY_INCLUDE}")
    proc = subprocess.run(cmd, cwd=workdir, capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0 and out.exists(), proc.stderr[-2000:]
    return out


def strala_render(scene: Path, width: int, height: int, aa: float | None, workdir: Path) -> Path:
    out = workdir / "strala.png"
    argv = ["render", str(scene), "-W", str(width), "-H", str(height), "-o", str(out), "-q"]
    argv += ["--aa", str(aa)] if aa is not None else ["--no-aa"]
    assert cli.main(argv) == 0
    return out


def _save_diff(ours: np.ndarray, theirs: np.ndarray, path: Path) -> None:
    """A picture of the difference (amplified 4x) beside the two renders, for whoever debugs."""
    from runtime.image import write_pixels

    write_pixels(path, np.clip(np.abs(ours - theirs) * 4.0, 0.0, 1.0))


@pytest.mark.povray
@pytest.mark.parametrize("aa", [None, 0.3], ids=["no-aa", "aa0.3"])
@pytest.mark.parametrize("size", [(256, 256), (320, 240)], ids=["256x256", "320x240"])
def test_ex3_matches_povray(tmp_path, size, aa):
    from runtime.image import read_image

    width, height = size
    theirs = read_image(povray_render(EX3, width, height, aa, tmp_path))
    ours = read_image(strala_render(EX3, width, height, aa, tmp_path))
    result = compare(ours, theirs)
    _save_diff(ours, theirs, tmp_path / "diff.png")
    print(f"\nEx3 {width}x{height} aa={aa}: {result}  (images in {tmp_path})")
    assert result.rmse < RMSE_LIMIT, str(result)
    assert result.outliers < OUTLIER_LIMIT, str(result)


def test_compare_measures_what_it_says():
    a = np.zeros((10, 10, 3))
    b = a.copy()
    b[0, :2, 1] = 0.5  # 2 of 100 pixels off by 0.5 in green
    result = compare(b, a)
    assert result.outliers == pytest.approx(0.02)
    assert result.rmse == pytest.approx(np.sqrt(2 * 0.25 / 300))
    assert result.mean_diff == pytest.approx((0.0, 0.01, 0.0))


# ----------------------------------------------------------- the seed's listing
def seed_listing() -> str:
    """Ex3 as printed in the seed (lines 79–116 of the notes), stray `}` and all."""
    if not SEED.exists():
        pytest.skip("the seed document is not beside the repository")
    lines = SEED.read_text(encoding="utf-8").splitlines()
    start = lines.index("> cat Ex3.pov") + 1
    end = lines.index("```", start)
    return "\n".join(lines[start:end]) + "\n"


def test_check_reports_the_seeds_stray_brace(tmp_path):
    listing = seed_listing()
    assert listing.splitlines()[37] == "}"  # its line 38: one brace too many
    pov = tmp_path / "Ex3.pov"
    pov.write_text(listing, encoding="utf-8")
    proc = run_cli("check", str(pov))
    assert proc.returncode == 1, proc.stdout + proc.stderr
    assert f"{pov}:38:" in proc.stdout
    assert "hint: unmatched `}`" in proc.stdout
    assert "Traceback" not in proc.stdout + proc.stderr


def test_seed_listing_without_the_stray_brace_is_clean(tmp_path):
    pov = tmp_path / "Ex3.pov"
    pov.write_text("\n".join(seed_listing().splitlines()[:37]) + "\n", encoding="utf-8")
    proc = run_cli("check", str(pov))
    assert proc.returncode == 0, proc.stdout + proc.stderr


def test_check_does_not_import_numpy_embree_or_oiio():
    # the checker must start in well under 0.3 s (timed in tests/bench): no heavy imports
    code = (
        f"import sys; from runtime.cli import main; rc = main(['check', {str(EX3)!r}]);"
        "heavy = sorted(m for m in ('numpy', 'embreex', 'OpenImageIO') if m in sys.modules);"
        "print(rc, heavy)"
    )
    proc = subprocess.run(
        [sys.executable, "-c", code], cwd=ROOT, capture_output=True, text=True, timeout=120
    )
    assert proc.stdout.strip().endswith("0 []"), proc.stdout + proc.stderr
