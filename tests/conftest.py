"""Shared test fixtures: repository paths, the POV-Ray marker, the CLI as a subprocess."""

from __future__ import annotations

import importlib.util
import os
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

import pytest
from hypothesis import HealthCheck, settings

ROOT = Path(__file__).resolve().parent.parent

# Parsed files are stored between runs (lang.parse_store): the tests, and the commands they
# start, use a store of their own rather than the user's.
os.environ.setdefault("STRALA_CACHE", tempfile.mkdtemp(prefix="strala-test-store-"))
EXAMPLES = ROOT / "examples"
SEED = ROOT.parent / "shared" / "seed" / "000_5c225423005c2bbd.txt"

# Two cores and a ray tracer under test: keep property tests small and free of deadlines
# (the first call into numpy-heavy code is slow and would trip hypothesis' 200 ms deadline).
settings.register_profile(
    "strala", max_examples=40, deadline=None, suppress_health_check=[HealthCheck.too_slow]
)
settings.load_profile(os.environ.get("HYPOTHESIS_PROFILE", "strala"))


def pytest_collection_modifyitems(config, items):
    """`povray`-marked tests need the oracle, `xvfb`-marked ones a virtual X screen; skip
    them (visibly) where it is not installed (.ci/run installs both)."""
    needs = {
        "povray": (shutil.which("povray"), "POV-Ray is not installed (apt-get install povray)"),
        "xvfb": (
            shutil.which("Xvfb") and importlib.util.find_spec("tkinter"),
            "Xvfb or Tk is not installed (apt-get install xvfb python3-tk)",
        ),
    }
    for marker, (there, reason) in needs.items():
        if there:
            continue
        skip = pytest.mark.skip(reason=reason)
        for item in items:
            if marker in item.keywords:
                item.add_marker(skip)


def run_cli(*args: str, cwd: Path | None = None, extra: tuple[str, ...] = ()):
    """Run `python -m runtime.cli ARGS` the way a user would, from the repo root by default."""
    env = dict(os.environ)
    env["PYTHONPATH"] = str(ROOT) + os.pathsep + env.get("PYTHONPATH", "")
    return subprocess.run(
        [sys.executable, *extra, "-m", "runtime.cli", *args],
        cwd=cwd or ROOT,
        env=env,
        stdin=subprocess.DEVNULL,  # never wait on the terminal (`strala lsp` reads stdin)
        capture_output=True,
        text=True,
        timeout=600,
    )


@pytest.fixture
def cli():
    return run_cli


def povray_image(scene_text: str, folder: Path, width: int, height: int):
    """POV-Ray's render of a scene (the oracle), as (H, W, 3) floats in [0, 1]."""
    import OpenImageIO as oiio

    (folder / "oracle.pov").write_text(scene_text)
    subprocess.run(
        ["povray", "+Ioracle.pov", "+Ooracle.png", f"+W{width}", f"+H{height}", "-D", "-V",
         "-GA"],
        cwd=folder,
        check=True,
        capture_output=True,
        timeout=600,
    )  # fmt: skip
    return oiio.ImageBuf(str(folder / "oracle.png")).get_pixels(oiio.FLOAT)[..., :3]


def strala_image(scene_text: str, folder: Path, width: int, height: int, name="scene.pov"):
    """strala's render of a scene in-process, as the display values an image file holds
    (H, W, 3) in [0, 1]; returns (image, diagnostic messages). The scene is compiled as if
    it were `folder/name`, so files beside it (images, fonts) are found."""
    from lang.evaluate import compile_source
    from runtime.color import to_display
    from runtime.queries import RuntimeQueries
    from runtime.render import render_scene

    # with the renderer's answers to trace() and function calls, as `strala render`
    result = compile_source(scene_text, str(folder / name), queries=RuntimeQueries)
    messages = [d.message for d in result.diagnostics]
    assert result.scene is not None, messages
    image = to_display(render_scene(result.scene, width, height), result.scene.settings)
    return image, messages


def image_errors(ours, ref, threshold: float = 0.1) -> tuple[float, float]:
    """(RMSE, share of pixels off by more than `threshold` in some channel)."""
    from runtime.metrics import off_share, rmse

    return rmse(ours, ref), off_share(ours, ref, threshold)


def strala_against_povray(scene_text: str, folder: Path, width: int, height: int):
    """(RMSE, share of pixels off, POV-Ray's image) of strala's render of a scene against
    POV-Ray's; strala must render all of it (no "not supported" warning)."""
    ref = povray_image(scene_text, folder, width, height)
    ours, messages = strala_image(scene_text, folder, width, height)
    assert not [m for m in messages if "not supported" in m], messages
    rmse, off = image_errors(ours, ref)
    return rmse, off, ref


def povray_debug(scene: Path) -> str:
    """What POV-Ray prints (its #debug stream goes to stderr) parsing a scene at 1×1 pixel."""
    return subprocess.run(
        [shutil.which("povray") or "povray", f"+I{scene}", "-D", "+W1", "+H1", "+O/dev/null",
         "-V"],
        capture_output=True,
        text=True,
        cwd=scene.parent,
        timeout=60,
    ).stderr  # fmt: skip


# an image's mapping types (0 planar, 1 spherical, 2 cylindrical, 5 torus) and a shape
# each is made for: the shape's opening text (its block left open) and a pattern placement
MAPPED_SHAPES = {
    0: ("box { <-1, -1, -0.1>, <1, 1, 0.1>", "translate <-0.5, -0.5, 0> scale 2"),
    1: ("sphere { 0, 1.2", "rotate y*20"),
    2: ("cylinder { -y, y, 1", "translate -0.5*y scale 2"),
    5: ("torus { 1, 0.4 rotate x*-40", "rotate y*30"),
}


def same_on_kernel_and_numpy(text: str, monkeypatch, width: int = 64, height: int = 48):
    """A scene's working-space image, asserted the same (every channel within 1e-9) from
    the compiled kernel, which must cover it, and from the numpy path."""
    import numpy as np

    from runtime import api

    fast, slow = kernel_and_numpy(api.compile_string(text).scene, width, height, monkeypatch)
    assert np.abs(fast - slow).max() < 1e-9
    return fast


def kernel_and_numpy(scene, width: int, height: int, monkeypatch, aa=None):
    """A compiled scene traced by the compiled kernel (which must cover it) and by the numpy
    path, its reference: the two working-space images."""
    from runtime import whitted
    from runtime.prepare import prepare
    from runtime.render import render_scene

    assert whitted.reasons(prepare(scene, width, height), scene.camera) == []
    fast = render_scene(scene, width, height, antialias=aa)
    monkeypatch.setenv(whitted.ENV, "numpy")
    slow = render_scene(scene, width, height, antialias=aa)
    monkeypatch.delenv(whitted.ENV)
    return fast, slow


def write_palette_png(path: Path, index, palette: bytes) -> None:
    """An 8-bit palette PNG (which image libraries do not write) of these indices (2-D
    array) and this palette (RGB triples), for the tests of palette entries."""
    import struct
    import zlib

    import numpy as np

    h, w = index.shape
    raw = b"".join(b"\x00" + bytes(row) for row in np.asarray(index).astype(np.uint8))

    def chunk(tag: bytes, body: bytes) -> bytes:
        return struct.pack(">I", len(body)) + tag + body + struct.pack(">I", zlib.crc32(tag + body))

    path.write_bytes(
        b"\x89PNG\r\n\x1a\n"
        + chunk(b"IHDR", struct.pack(">IIBBBBB", w, h, 8, 3, 0, 0, 0))
        + chunk(b"PLTE", palette)
        + chunk(b"IDAT", zlib.compress(raw))
        + chunk(b"IEND", b"")
    )
