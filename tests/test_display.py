"""The display window (--display, POV-Ray's +D) on a virtual X screen, read back through the
X server (tests/xwindow.py), against the PNG the same render writes; the keys and the close
button; the line said where no window can open; the notebook's inline view."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
from conftest import EXAMPLES, ROOT, run_cli
from xwindow import Screen, VirtualScreen

from runtime import image, render

EX3 = EXAMPLES / "ex3.scene"


@pytest.fixture(scope="module")
def xscreen():
    vs = VirtualScreen(1600, 1200)
    screen = Screen(vs.name)
    yield screen, vs.name
    screen.close()
    vs.stop()


def _strala(display: str, *args: str, cwd: Path) -> subprocess.Popen:
    env = dict(os.environ, DISPLAY=display)
    env["PYTHONPATH"] = str(ROOT) + os.pathsep + env.get("PYTHONPATH", "")
    return subprocess.Popen(
        [sys.executable, "-m", "runtime.cli", "render", *args],
        cwd=cwd,
        env=env,
        stdin=subprocess.DEVNULL,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )


def _png8(path: Path) -> np.ndarray:
    return np.rint(image.read_image(path)[..., :3] * 255.0).astype(np.uint8)


def _finish(proc: subprocess.Popen, timeout: float = 60) -> tuple[int, str]:
    try:
        _, err = proc.communicate(timeout=timeout)
    except subprocess.TimeoutExpired:
        proc.kill()
        raise
    return proc.returncode, err


@pytest.mark.xvfb
def test_the_window_shows_the_pixels_of_the_written_png(xscreen, tmp_path):
    screen, name = xscreen
    out = tmp_path / "shown.png"
    proc = _strala(name, str(EX3), "--display", "--pause", "--aa", "-o", str(out), cwd=tmp_path)
    try:
        win = screen.wait_for("ex3.scene", contains="done")  # +P: it waits to be closed
        title = screen.title(win)
        shot = screen.pixels(win)
        screen.key(win, "s")  # what is shown, saved beside the output
        deadline = time.monotonic() + 10
        shown = tmp_path / "shown.shown.png"
        while not shown.exists() and time.monotonic() < deadline:
            time.sleep(0.05)
        screen.key(win, "q")
        code, err = _finish(proc)
    finally:
        proc.kill()
    assert code == 0, err
    assert title is not None and "q or close" in title
    written = _png8(out)
    assert shot.shape == written.shape == (240, 320, 3)
    # same pixels: the metric is the largest difference in 8-bit levels, and it must be 0
    assert int(np.abs(shot.astype(int) - written.astype(int)).max()) == 0
    assert np.array_equal(_png8(shown), written)
    assert "saved what the window shows" in err
    # the file written from the window's values is the one a render without it writes
    alone = tmp_path / "alone.png"
    assert run_cli(str(EX3), "--aa", "-o", str(alone), "-q").returncode == 0
    assert np.array_equal(_png8(alone), written)


@pytest.mark.xvfb
def test_an_image_larger_than_the_screen_is_shown_subsampled(tmp_path):
    vs = VirtualScreen(800, 600)
    screen = Screen(vs.name)
    try:
        out = tmp_path / "big.png"
        part = ("+SC0.1", "+EC0.75", "+SR0.2", "+ER0.9")  # a partial render: black around
        args = (str(EX3), "+D", "+P", "-W", "1000", "-H", "750", "-A", *part, "-o", str(out))
        proc = _strala(vs.name, *args, cwd=tmp_path)
        try:
            win = screen.wait_for("ex3.scene", contains="done")
            shot = screen.pixels(win)
            screen.close_window(win)  # once done, closing only closes
            code, err = _finish(proc)
        finally:
            proc.kill()
    finally:
        screen.close()
        vs.stop()
    assert code == 0, err
    # 1000x750 on 90% of 800x600 needs every other pixel: 500x375, each the image's own
    assert shot.shape == (375, 500, 3)
    assert np.array_equal(shot, _png8(out)[::2, ::2])
    alone = tmp_path / "alone.png"
    r = run_cli(str(EX3), "-W", "1000", "-H", "750", "-A", *part, "-o", str(alone), "-q")
    assert r.returncode == 0, r.stderr
    assert np.array_equal(_png8(alone), _png8(out))
    assert _png8(out)[:100].max() == 0 and _png8(out)[200:600, 200:600].max() > 0


@pytest.mark.xvfb
@pytest.mark.parametrize("where", ["here", "cluster"])
def test_an_animation_shows_its_frames_in_turn(xscreen, tmp_path, where):
    screen, name = xscreen
    scene = tmp_path / "turn.pov"
    scene.write_text(EX3.read_text(encoding="utf-8"), encoding="utf-8")
    args = [str(scene), "--display", "--pause", "--frames", "1..2", "-W", "96", "-H", "72"]
    if where == "cluster":  # the tiles come from the workers as they finish
        args += ["--tiles", "2", "--cluster", "local:2"]
    proc = _strala(name, *args, cwd=tmp_path)
    try:
        win = screen.wait_for("turn.pov", contains="done", timeout=120)
        title = screen.title(win)
        shot = screen.pixels(win)
        screen.close_window(win)
        code, err = _finish(proc)
    finally:
        proc.kill()
    assert code == 0, err
    assert title is not None
    number = title.split("frame ")[1].split("/")[0]
    assert number in ("1", "2") and "/2 done" in title
    assert np.array_equal(shot, _png8(tmp_path / f"turn{number}.png"))


# ~5 s here: the window is closed at its first tiles, long before the end
SLOW = ("-W", "800", "-H", "600", "--aa", "0", "--aa-depth", "4", "--threads", "1")


@pytest.mark.xvfb
@pytest.mark.parametrize("how", ["close", "q"])
def test_stopping_from_the_window_mid_render_leaves_no_file(xscreen, tmp_path, how):
    screen, name = xscreen
    out = tmp_path / f"stopped-{how}.png"
    proc = _strala(name, str(EX3), "--display", "--preview", *SLOW, "-o", str(out), cwd=tmp_path)
    titles: set[str] = set()
    try:
        deadline = time.monotonic() + 60
        win = None
        while time.monotonic() < deadline:  # until the final pass has tiles in
            for w, t in screen.find("ex3.scene"):
                titles.add(t)
                if t.endswith("left"):
                    win = w
            if win is not None:
                break
            time.sleep(0.02)
        assert win is not None, titles
        if how == "close":
            screen.close_window(win)
        else:
            screen.key(win, "q")
        code, err = _finish(proc)
    finally:
        proc.kill()
    assert code == 130, err
    assert "stopped from the window" in err
    assert not out.exists()
    assert not (tmp_path / f"stopped-{how}.preview.png").exists()
    assert list(tmp_path.iterdir()) == []  # no temporary file left either
    progress = [t for t in titles if t.endswith("left")]
    assert progress and all(t.startswith("ex3.scene — rendering ") for t in progress), titles
    assert 0 < float(progress[0].split()[3].rstrip("%,")) < 100


@pytest.mark.xvfb
def test_preview_passes_are_shown_before_the_final_one(xscreen, tmp_path):
    screen, name = xscreen
    out = tmp_path / "p.png"
    proc = _strala(name, str(EX3), "--display", "--preview", *SLOW, "-o", str(out), cwd=tmp_path)
    seen: list[tuple[str, np.ndarray]] = []
    try:
        deadline = time.monotonic() + 60
        while time.monotonic() < deadline and not any(t.endswith("left") for t, _ in seen):
            for w, t in screen.find("ex3.scene"):
                if "preview" in t and all(t != s for s, _ in seen):
                    seen.append((t, screen.pixels(w)))
                elif t.endswith("left"):
                    seen.append((t, screen.pixels(w)))
                    screen.close_window(w)
            time.sleep(0.01)
        code, err = _finish(proc)
    finally:
        proc.kill()
    assert code == 130, err
    previews = [(t, px) for t, px in seen if "preview" in t]
    assert previews, [t for t, _ in seen]
    # a pass at 1/8, 1/4 or 1/2 of the size is shown enlarged: blocks of 2 x 2 pixels of one
    # colour at least (the window may be a pass ahead of the title read before the shot)
    _, px = previews[0]
    blocks = px.reshape(300, 2, 400, 2, 3)
    assert np.all(blocks == blocks[:, :1, :, :1, :])
    assert px.max() > 0  # not the black of an empty window


def test_without_a_display_one_line_and_the_render_goes_on(tmp_path):
    out = tmp_path / "a.png"
    env_display = os.environ.pop("DISPLAY", None)
    wayland = os.environ.pop("WAYLAND_DISPLAY", None)
    try:
        r = run_cli(str(EX3), "+D", "-W", "64", "-H", "48", "-o", str(out), "-q")
        plain = run_cli(str(EX3), "-D", "-W", "64", "-H", "48", "-o", str(tmp_path / "b.png"))
    finally:
        if env_display is not None:
            os.environ["DISPLAY"] = env_display
        if wayland is not None:
            os.environ["WAYLAND_DISPLAY"] = wayland
    assert r.returncode == 0, r.stderr
    assert r.stderr.splitlines() == [
        "strala: no display window: no display ($DISPLAY is not set); rendering on"
    ]
    assert out.exists() and "window" not in plain.stderr


def test_what_is_missing_is_named(monkeypatch):
    from runtime import display

    monkeypatch.delenv("DISPLAY", raising=False)
    monkeypatch.setenv("WAYLAND_DISPLAY", "wayland-0")
    assert "$DISPLAY is not set" in display.unavailable() and "Wayland" in display.unavailable()
    monkeypatch.setenv("DISPLAY", ":5")
    monkeypatch.setitem(sys.modules, "tkinter", None)  # as where python3-tk is not installed
    assert display.unavailable() == "Tk is not installed (Debian: apt-get install python3-tk)"


def test_a_display_that_refuses_the_connection_is_said_in_one_line(tmp_path):
    out = tmp_path / "a.png"
    # a display number no server listens on: Tk's own words, in one line
    args = (str(EX3), "--display", "-W", "64", "-H", "48", "-o", str(out), "-q")
    r = _run_on(":987", *args)
    assert r.returncode == 0, r.stderr
    lines = r.stderr.splitlines()
    assert len(lines) == 1 and lines[0].startswith("strala: no display window: ")
    assert lines[0].endswith("; rendering on") and ":987" in lines[0]
    assert out.exists()


def _run_on(display: str, *args: str) -> subprocess.CompletedProcess:
    proc = _strala(display, *args, cwd=ROOT)
    code, err = _finish(proc)
    return subprocess.CompletedProcess(proc.args, code, "", err)


@pytest.fixture
def shell():
    """An IPython shell whose front end takes images, as a notebook's kernel does."""
    from IPython.core.interactiveshell import InteractiveShell

    yield InteractiveShell.instance()
    InteractiveShell.clear_instance()


def test_the_notebook_view_grows_per_tile_and_ends_on_the_returned_image(shell, monkeypatch):
    from IPython.utils.capture import capture_output

    from runtime import api, notebook

    monkeypatch.setattr(notebook, "INTERVAL", 0.0)  # every tile, to count them
    with capture_output() as captured:
        got = api.render(EX3, width=300, height=200, display=True)
    outputs = captured.outputs
    ids = {o.transient["display_id"] for o in outputs}
    assert len(ids) == 1  # one handle, shown once and updated
    assert [o.update for o in outputs] == [False] + [True] * (len(outputs) - 1)
    tiles = render.tile_order((0, 0, 300, 200), os.cpu_count() or 1)
    assert len(outputs) == 1 + len(tiles)  # shown, then once a tile
    last = _decode_png(outputs[-1].data["image/png"])
    # the file's 8-bit values (color.to_display8) against the float array rounded here: a
    # value a hair from a level's edge may round the other way, by one level at most
    diff = np.abs(last.astype(int) - np.rint(got * 255.0).astype(int))
    assert diff.max() <= 1 and np.count_nonzero(diff) < 0.001 * diff.size, np.count_nonzero(diff)
    first = _decode_png(outputs[0].data["image/png"])
    assert first.max() == 0  # black before the first tile


def _decode_png(data: str) -> np.ndarray:
    """A PNG as a notebook's message carries it (base64), read back by OpenImageIO."""
    import base64
    import tempfile

    with tempfile.NamedTemporaryFile(suffix=".png") as f:
        f.write(base64.b64decode(data))
        f.flush()
        return _png8(Path(f.name))


def test_display_outside_a_notebook_warns_and_renders():
    from runtime import api

    with pytest.warns(RuntimeWarning, match="notebook"):
        got = api.render(EX3, width=16, height=12, display=True)
    assert got.shape == (12, 16, 3)


@pytest.mark.xvfb
def test_a_stop_cancels_the_job_on_a_cluster(xscreen, tmp_path, monkeypatch):
    """A cluster reached by its address (`tcp://…`, not one the render starts): a stop of a
    render showing its window (the signal the window's q or close sends, as ^C) cancels the
    job's tasks there, the running one included, not only the client."""
    pytest.importorskip("distributed")
    from runtime import bundle, cluster

    screen, name = xscreen
    monkeypatch.setenv(bundle.BUNDLE_DIR_VARIABLE, str(tmp_path / "bundles"))
    out = tmp_path / "work" / "stopped.png"
    out.parent.mkdir()
    # one task of ~13 s on the one worker (every pixel supersampled 4 x 4, one thread): at
    # 1000x750 it took 3.3 s, and on busy cores it ended before the window's stop reached it
    slow = ("-W", "2000", "-H", "1500", "--aa", "0", "--aa-depth", "4", "--threads", "1")
    with cluster.connect("local:1") as client:
        address = client.scheduler.address
        assert address.startswith("tcp://")

        def executing() -> int:
            return sum(client.run(lambda dask_worker: dask_worker.state.executing_count).values())

        args = (str(EX3), "--display", *slow, "--cluster", address, "-o", str(out))
        proc = _strala(name, *args, cwd=out.parent)
        try:
            deadline = time.monotonic() + 60
            while executing() == 0 and time.monotonic() < deadline:  # the task has begun
                time.sleep(0.05)
            assert executing() == 1
            time.sleep(0.5)  # the render is well into its tiles
            # the stop as the window sends it (test_stopping_from_the_window_mid_render
            # closes the window itself): in full-suite runs a window closed here was not
            # acted on before the 12 s render ended, on cores kept busy (its idle class?)
            proc.send_signal(signal.SIGINT)
            code, err = _finish(proc)
            stopped = time.monotonic()
            while executing() and time.monotonic() < stopped + 20:
                time.sleep(0.05)
            left = executing()
            took = time.monotonic() - stopped
        finally:
            proc.kill()
        assert code == 130, err
        assert not out.exists() and list(out.parent.iterdir()) == []
        # the task stopped at its next tile, long before the ~10 s it takes to the end
        assert left == 0 and took < 3.0, (left, took)
        assert not client.processing() or not any(client.processing().values())


@pytest.mark.xvfb
def test_a_tile_is_shown_with_its_first_rays_then_refined(xscreen, tmp_path, monkeypatch):
    """Anti-aliasing refinement shown after: each tile's first rays (the pixels of a render
    without anti-aliasing) are on screen before the tile is refined, and the window ends
    on the written PNG's pixels."""
    import threading

    from runtime import api, color, display

    screen, name = xscreen
    monkeypatch.setenv("DISPLAY", name)
    monkeypatch.setattr(display, "FIRST_DELAY", 0.0)  # shown however fast the refinement
    w, h = 160, 120
    scene = api.compile_file(EX3, width=w, height=h).scene
    plain = render.render_scene(scene, w, h, threads=1)  # one ray a pixel
    window = display.Window("refined.pov", lambda: None, lambda why: pytest.fail(why))
    window.frame(w, h, scene.settings, "rendering", tmp_path / "r.shown.png")
    window.show()
    win = screen.wait_for("refined.pov")
    shown_first: list[tuple[int, int, int, int]] = []

    def first(rect, pixels) -> None:
        x0, y0, x1, y1 = rect
        # the first rays, unrefined (float64 here, held as float32 in the image)
        assert np.array_equal(pixels.astype(np.float32), plain[y0:y1, x0:x1])
        window.first(rect, pixels)
        want = color.to_display8(pixels, scene.settings)
        deadline = time.monotonic() + 10
        while time.monotonic() < deadline:  # the refinement waits until they are shown
            if np.array_equal(screen.pixels(win)[y0:y1, x0:x1], want):
                shown_first.append(rect)
                return
            time.sleep(0.01)

    got = render.render_scene(
        scene, w, h, antialias=0.3, threads=1, on_tile=window.tile, on_first=first
    )
    tiles = render.tile_order((0, 0, w, h), 1)
    assert sorted(shown_first) == sorted(tiles)  # every tile, first rays first
    out = tmp_path / "r.png"
    image.write_pixels(out, window.file_values(), 8)
    done = threading.Thread(target=window.finish, args=(True,))  # +P: open until closed
    done.start()
    try:
        screen.wait_title(win, "done", timeout=30)
        final = screen.pixels(win)
    finally:
        screen.close_window(win)
        done.join(10)
    assert np.array_equal(final, _png8(out))  # the window ends on the file's pixels
    # … which are the anti-aliased render's, bit for bit, not the first rays'
    alone = render.render_scene(scene, w, h, antialias=0.3, threads=2)
    assert np.array_equal(got, alone)
    assert np.array_equal(window.file_values(), color.to_display8(alone, scene.settings))
    refined = np.any(final != color.to_display8(plain, scene.settings), axis=-1)
    assert refined.sum() > 100  # the refinement did change what was shown first
