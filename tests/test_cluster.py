"""Frames and tiles on Dask distributed (runtime.cluster, runtime.bundle, runtime.render_job):
one LocalCluster of two worker processes for the module; tiny images.

Checked: frames rendered on the cluster are the files a local render writes, byte for byte;
a tiled image equals the untiled one bit for bit (anti-aliasing, an area light; media and
focal blur in the tiling property below); --resume renders only what is missing; a frame
whose scene has errors is reported at its file:line:col and the others are written; a
killed worker's task runs again and the job completes."""

from __future__ import annotations

import os
import signal
import threading
import time
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

pytest.importorskip("distributed")

from conftest import run_cli  # noqa: E402

from lang.diagnostics import Diagnostic, Severity, Span  # noqa: E402
from lang.evaluate import animation_values, compile_file  # noqa: E402
from runtime import api, bundle, cli, cluster  # noqa: E402
from runtime.queries import RuntimeQueries  # noqa: E402
from runtime.render import render_scene  # noqa: E402

W, H = 32, 24

INCLUDE = """
#declare Ball = sphere { 0, 0.7 pigment { rgb <1, 0.4, 0.2> } finish { reflection 0.2 } }
"""
# an include beside the scene (it must travel to the workers), an area light, a pattern
SCENE = """
#include "parts.inc"
camera { location <0, 1.2, -4> look_at <0, 0.5, 0> }
light_source { <3, 5, -3> color rgb 1 area_light <1, 0, 0>, <0, 0, 1>, 3, 3 adaptive 1 }
plane { y, 0 pigment { checker rgb 1 rgb 0.2 } }
object { Ball translate <clock * 2 - 1, 0.7, 0> }
box { <-1.8, 0, 0.5>, <-1, 0.9, 1.2> pigment { granite } }
"""
# frame 2 hits an error in the include (a sphere without its radius)
BROKEN_INCLUDE = """
#macro Thing()
  #if (frame_number = 2)
    sphere { <0, 1, 0> pigment { rgb 1 } }
  #else
    sphere { <0, 1, 0>, 0.5 pigment { rgb 1 } }
  #end
#end
"""
BROKEN = """
#include "thing.inc"
camera { location <0, 1, -4> look_at <0, 0.5, 0> }
light_source { <3, 5, -3> color rgb 1 }
object { Thing() }
"""
MEDIA = """
camera { location <0, 1, -4> look_at <0, 0.5, 0> }
light_source { <3, 5, -3> color rgb 1 }
plane { y, 0 pigment { checker rgb 1 rgb 0.2 } }
sphere { <0, 0.8, 0>, 0.8 pigment { rgbt 1 } hollow
  interior { media { scattering { 1, 0.5 } intervals 2 samples 3, 3 } } }
"""
BLUR = """
camera { location <0, 1, -4> look_at <0, 0.5, 0> aperture 0.4 blur_samples 8
  focal_point <0, 0.8, 0> }
light_source { <3, 5, -3> color rgb 1 }
plane { y, 0 pigment { checker rgb 1 rgb 0.2 } }
sphere { <0, 0.8, 0>, 0.8 pigment { rgb <1, 0.3, 0.2> } }
"""


@pytest.fixture(scope="module")
def client(tmp_path_factory):
    # the workers (started now, with this environment) keep their bundles in pytest's folder
    before = os.environ.get(bundle.BUNDLE_DIR_VARIABLE)
    os.environ[bundle.BUNDLE_DIR_VARIABLE] = str(tmp_path_factory.mktemp("bundles"))
    try:
        with cluster.connect("local:2") as c:
            yield c
    finally:
        if before is None:
            os.environ.pop(bundle.BUNDLE_DIR_VARIABLE, None)
        else:
            os.environ[bundle.BUNDLE_DIR_VARIABLE] = before


@pytest.fixture(scope="module")
def scenes(tmp_path_factory) -> Path:
    folder = tmp_path_factory.mktemp("scenes")
    (folder / "parts.inc").write_text(INCLUDE)
    (folder / "anim.pov").write_text(SCENE)
    (folder / "thing.inc").write_text(BROKEN_INCLUDE)
    (folder / "broken.pov").write_text(BROKEN)
    return folder


def _render(argv: list[str], capsys) -> tuple[int, str]:
    code = cli.main(argv)
    return code, capsys.readouterr().err


def _leftovers(folder: Path) -> list[str]:
    """Temporary files an interrupted write would leave (image.write_pixels' `.NAME…`)."""
    return [p.name for p in folder.iterdir() if p.name.startswith(".")]


def test_frames_on_a_scheduler_are_the_files_a_local_render_writes(client, scenes, tmp_path,
                                                                   capsys):  # fmt: skip
    scene = str(scenes / "anim.pov")
    size = ["-W", str(W), "-H", str(H), "--aa", "0.3"]
    code, err = _render(["render", scene, "-o", str(tmp_path / "local.png"), *size,
                         "+KFI1", "+KFF3", "-q"], capsys)  # fmt: skip
    assert code == 0, err
    address = client.scheduler.address  # a running scheduler, as `dask scheduler` gives
    code, err = _render(["render", scene, "-o", str(tmp_path / "dist.png"), *size,
                         "--frames", "1..3", "--cluster", address], capsys)  # fmt: skip
    assert code == 0, err
    assert "dashboard" in err and "wrote 3 image(s)" in err
    for n in (1, 2, 3):
        local, dist = tmp_path / f"local{n}.png", tmp_path / f"dist{n}.png"
        assert dist.read_bytes() == local.read_bytes(), n
    assert _leftovers(tmp_path) == []


def test_quiet_says_nothing(client, scenes, tmp_path, capsys):
    code, err = _render(["render", str(scenes / "anim.pov"), "-o", str(tmp_path / "q.png"),
                         "-W", "8", "-H", "6", "--tiles", "2", "--cluster",
                         client.scheduler.address, "-q"], capsys)  # fmt: skip
    assert (code, err) == (0, "")
    assert (tmp_path / "q.png").is_file()


# a clip the renderer cannot use: a warning from the workers' prepare, not the compile
UNCLIPPABLE = """#version 3.7;
global_settings { assumed_gamma 1 }
camera { location <0, 1, -4> look_at <0, 0.5, 0> }
light_source { <3, 5, -3> color rgb 1 }
sphere { <0, 0.8, 0>, 0.8 pigment { rgb 1 }
  clipped_by { triangle { <-1, 0, 0>, <1, 0, 0>, <0, 1, 0> } } }
"""


def test_quiet_silences_the_workers_too(tmp_path):
    """-q leaves only errors with a cluster of its own as without one: its workers' warnings
    are the client's to print (a worker writing on its own stderr was not silenced)."""
    scene = tmp_path / "clip.pov"
    scene.write_text(UNCLIPPABLE)
    quiet = run_cli("render", str(scene), "-W", "8", "-H", "6", "-o", str(tmp_path / "q.png"),
                    "--cluster", "local:1", "-q")  # fmt: skip
    assert (quiet.returncode, quiet.stdout, quiet.stderr) == (0, "", "")
    assert (tmp_path / "q.png").is_file()


def test_the_workers_warnings_reach_the_client_once_under_its_paths(client, tmp_path, capsys):
    """A worker's warning is printed by the client, once for all tiles and frames, naming
    the scene where the client has it (not the worker's copy), and again in the next job
    (a worker renders many jobs in one process)."""
    scene = tmp_path / "clip.pov"
    scene.write_text(UNCLIPPABLE)
    argv = ["render", str(scene), "-W", "8", "-H", "6", "-o", str(tmp_path / "c.png"),
            "--frames", "1..2", "--tiles", "2", "--cluster", client.scheduler.address]  # fmt: skip
    for _ in range(2):
        code, err = _render(argv, capsys)
        assert code == 0, err
        warned = [line for line in err.splitlines() if "has no inside" in line]
        assert warned == [f"{scene}:6:16: warning: clipped_by Triangle has no inside: ignored"]
    code, err = _render([*argv, "-q"], capsys)
    assert (code, err) == (0, "")


def test_a_tiled_image_equals_the_untiled_one_bit_for_bit(client, scenes):
    path = scenes / "anim.pov"
    whole = api.render(path, width=W, height=H, aa=0.3, clock=0.3)
    tiled = api.render(path, width=W, height=H, aa=0.3, clock=0.3, client=client, tiles=5)
    assert tiled.dtype == whole.dtype and np.array_equal(tiled, whole)
    # a compiled scene travels as its IR; the same pixels, a partial render's black too
    compiled = api.compile_file(path, width=W, height=H, clock=0.3)
    region = (3, 2, 29, 21)
    part = api.render(compiled, aa=0.3, region=region, client=client, tiles=3)
    assert np.array_equal(part, api.render(compiled, aa=0.3, region=region))


def test_render_frames_on_a_client_gives_the_local_frames(client, scenes):
    path = scenes / "anim.pov"
    local = list(api.render_frames(path, 1, 3, width=W, height=H))
    remote = list(api.render_frames(path, 1, 3, width=W, height=H, client=client, tiles=2))
    assert [t for t, _ in remote] == [t for t, _ in local] == [0.0, 0.5, 1.0]
    for (_, a), (_, b) in zip(local, remote, strict=True):
        assert np.array_equal(a, b)


@pytest.mark.parametrize("text", [SCENE, MEDIA, BLUR], ids=["area-light", "media", "blur"])
@settings(max_examples=3, deadline=None)
@given(cols=st.integers(1, 9), rows=st.integers(1, 7))
def test_pixels_do_not_depend_on_the_tiling(tmp_path_factory, text, cols, rows):
    """Random numbers are the ray's (runtime.ray_random), AA compares first-ray colours:
    a render cut into any regions is the whole render."""
    folder = tmp_path_factory.getbasetemp() / "tiling"
    folder.mkdir(exist_ok=True)
    (folder / "parts.inc").write_text(INCLUDE)
    (folder / "t.pov").write_text(text)
    w, h = 20, 14
    scene = compile_file(str(folder / "t.pov"), image_width=w, image_height=h,
                         queries=RuntimeQueries).scene  # fmt: skip
    assert scene is not None
    whole = render_scene(scene, w, h, antialias=0.3, threads=1)
    cut = np.zeros_like(whole)
    for y0 in range(0, h, rows):
        for x0 in range(0, w, cols):
            r = (x0, y0, min(w, x0 + cols), min(h, y0 + rows))
            part = render_scene(scene, w, h, antialias=0.3, threads=1, region=r)
            cut[r[1] : r[3], r[0] : r[2]] = part[r[1] : r[3], r[0] : r[2]]
    assert np.array_equal(cut, whole)


def test_resume_renders_only_the_missing_frames(client, scenes, tmp_path, capsys):
    argv = ["render", str(scenes / "anim.pov"), "-o", str(tmp_path / "f.png"), "-W", str(W),
            "-H", str(H), "--frames", "1..4", "--cluster", client.scheduler.address]  # fmt: skip
    assert _render(argv, capsys)[0] == 0
    (tmp_path / "f2.png").unlink()
    (tmp_path / "f3.png").write_bytes((tmp_path / "f1.png").read_bytes())  # right size: kept
    kept = {n: (tmp_path / f"f{n}.png").stat().st_mtime_ns for n in (1, 3, 4)}
    code, err = _render([*argv, "--resume"], capsys)
    assert code == 0, err
    assert "3 frame(s) already written" in err and "wrote 1 image(s)" in err
    assert {n: (tmp_path / f"f{n}.png").stat().st_mtime_ns for n in (1, 3, 4)} == kept
    assert (tmp_path / "f2.png").is_file()
    # an image of another size is not this render's: it is rendered again
    code, err = _render([*argv[:4], "-W", "16", *argv[6:], "--resume"], capsys)
    assert code == 0 and "wrote 4 image(s)" in err


def test_a_frame_with_errors_is_reported_and_the_others_written(client, scenes, tmp_path,
                                                                capsys):  # fmt: skip
    code, err = _render(["render", str(scenes / "broken.pov"), "-o", str(tmp_path / "b.png"),
                         "-W", "8", "-H", "6", "--frames", "1..3", "--tiles", "2",
                         "--cluster", client.scheduler.address], capsys)  # fmt: skip
    assert code == 1
    assert f"{scenes / 'thing.inc'}:4:" in err  # the client's path, line and column
    assert "radius" in err and "frame 2/3 failed" in err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["b1.png", "b3.png"]


def test_the_python_api_raises_the_scenes_errors(client, scenes):
    # frame 2 of 1..3 is clock 0.5
    text = BROKEN_INCLUDE.replace("frame_number = 2", "clock = 0.5")
    (scenes / "clocked.inc").write_text(text)
    (scenes / "clocked.pov").write_text(BROKEN.replace("thing.inc", "clocked.inc"))
    frames = api.render_frames(scenes / "clocked.pov", 1, 3, width=8, height=6, client=client)
    first = next(frames)  # the frames before the broken one come out
    assert first[0] == 0.0 and first[1].shape == (6, 8, 3)
    with pytest.raises(api.CompileError, match="clocked.inc:4"):
        next(frames)


def test_tile_bands_cover_the_region_in_order():
    for region, n in [((0, 0, 32, 24), 5), ((3, 2, 29, 21), 8), ((0, 0, 4, 3), 9)]:
        rects = cluster.tile_rects(region, n)
        assert len(rects) == min(n, region[3] - region[1])
        assert rects[0][1] == region[1] and rects[-1][3] == region[3]
        assert all(a[3] == b[1] for a, b in zip(rects, rects[1:], strict=False))
        assert all((r[0], r[2]) == (region[0], region[2]) and r[3] > r[1] for r in rects)


def test_a_bundle_ships_the_includes_not_the_stdlib_and_maps_paths_back(scenes, tmp_path,
                                                                        monkeypatch):  # fmt: skip
    (scenes / "uses_stdlib.pov").write_text('#include "colors.inc"\n' + SCENE)
    result = compile_file(str(scenes / "uses_stdlib.pov"), queries=RuntimeQueries)
    b = bundle.of_files(scenes / "uses_stdlib.pov", result.files, result.scene, ())
    assert sorted(Path(f).name for f in b.files) == ["parts.inc", "uses_stdlib.pov"]
    again = bundle.of_files(scenes / "uses_stdlib.pov", result.files, result.scene, ())
    assert again.digest == b.digest  # the same content, the same name on the workers
    monkeypatch.setenv(bundle.BUNDLE_DIR_VARIABLE, str(tmp_path))
    root = bundle.materialise(b)
    assert root.parent == tmp_path and bundle.materialise(b) == root
    entry, _ = bundle.worker_paths(b, root)
    assert Path(entry).read_bytes() == (scenes / "uses_stdlib.pov").read_bytes()
    there = Diagnostic(Severity.ERROR, "E0211", "bad", Span(str(root / "a/b.pov"), 3, 4, 3, 9))
    assert bundle.client_diagnostic(there, root).span.file == os.sep + "a/b.pov"


def test_a_killed_workers_task_runs_again(client, scenes):
    """Kill the process of a worker that holds a task: the scheduler gives the task to
    another worker (the nanny starts a new one) and every frame still comes out right."""
    path = scenes / "anim.pov"
    w, h = 64, 48  # tasks long enough to be caught running
    r = compile_file(str(path), image_width=w, image_height=h, queries=RuntimeQueries)
    shipped = bundle.of_files(path, r.files, r.scene, ())
    frames = [cluster.Frame(n, (n - 1) / 3) for n in range(1, 5)]
    opts = cluster.Options(w, h, aa=0.3)
    killed: list[str] = []
    pids = client.run(os.getpid)  # the worker processes this module's cluster started

    def kill_one() -> None:
        deadline = time.monotonic() + 60
        while time.monotonic() < deadline and not killed:
            busy = [a for a, keys in client.processing().items() if keys]
            if busy:
                killed.append(busy[0])
                os.kill(pids[busy[0]], signal.SIGKILL)
                return
            time.sleep(0.02)

    killer = threading.Thread(target=kill_one)
    killer.start()
    try:
        got = dict(cluster.run(client, shipped, opts, frames))
    finally:
        killer.join()
        client.wait_for_workers(2, timeout=60)  # the nanny's new worker, for later tests
    assert killed, "no task was seen running"
    assert killed[0] not in client.scheduler_info()["workers"]
    for frame in frames:
        outcome = got[frame]
        assert outcome.ok, outcome.error
        again = compile_file(str(path), clock=frame.clock, image_width=w, image_height=h,
                             queries=RuntimeQueries).scene  # fmt: skip
        assert again is not None
        assert np.array_equal(outcome.image, render_scene(again, w, h, antialias=0.3))


def test_resume_works_without_a_cluster_too(scenes, tmp_path, capsys):
    argv = ["render", str(scenes / "anim.pov"), "-o", str(tmp_path / "l.png"), "-W", "8",
            "-H", "6", "--frames", "1..2"]  # fmt: skip
    assert _render([*argv, "-q"], capsys)[0] == 0
    (tmp_path / "l1.png").unlink()
    kept = (tmp_path / "l2.png").stat().st_mtime_ns
    code, err = _render([*argv, "--resume"], capsys)
    assert code == 0 and "l2.png is there, skipped" in err and "l1.png (8x6" in err
    assert (tmp_path / "l2.png").stat().st_mtime_ns == kept


def test_declares_and_read_restrictions_hold_on_the_cluster(client, tmp_path, capsys, monkeypatch):
    """`Declare=` values reach the workers' compiles (the frame equals the local render's
    bytes), and a read povray.conf refuses is refused there too: the client ships only
    what its own compile, under the same restrictions, read."""
    home = tmp_path / "home"
    (home / ".povray" / "3.7").mkdir(parents=True)
    (home / ".povray" / "3.7" / "povray.conf").write_text("[File I/O Security]\nrestricted\n")
    monkeypatch.setenv("HOME", str(home))
    (tmp_path / "outside").mkdir()
    (tmp_path / "outside" / "o.inc").write_text(INCLUDE)
    folder = tmp_path / "scene"
    folder.mkdir()
    (folder / "parts.inc").write_text(INCLUDE)
    body = "camera { location -4*z look_at 0 }\nlight_source { <3, 5, -3> rgb 1 }\n"
    (folder / "d.pov").write_text('#include "parts.inc"\n' + body + "object { Ball scale S }\n")
    (folder / "r.pov").write_text('#include "../outside/o.inc"\n' + body + "object { Ball }\n")
    size = ["-W", "8", "-H", "6", "--declare", "S=1.3", "-q"]
    address = client.scheduler.address
    code, err = _render(["render", str(folder / "d.pov"), "-o", str(folder / "l.png"), *size],
                        capsys)  # fmt: skip
    assert code == 0, err
    code, err = _render(["render", str(folder / "d.pov"), "-o", str(folder / "c.png"), *size,
                         "--cluster", address], capsys)  # fmt: skip
    assert code == 0, err
    assert (folder / "c.png").read_bytes() == (folder / "l.png").read_bytes()
    for where in ([], ["--cluster", address]):
        out = folder / "r.png"  # beside the scene: povray.conf permits no other write
        code, err = _render(["render", str(folder / "r.pov"), "-o", str(out), *size, *where],
                            capsys)  # fmt: skip
        assert code == 1 and "o.inc" in err and not out.exists(), (where, err)


def test_a_tiled_image_streams_to_its_file_in_bounded_memory(client, tmp_path, capsys):
    """The client writes each band of rows as it comes in (image.Bands) and never holds the
    image: in 24 bands, its peak of traced memory (numpy's arrays included) for an image
    four times as tall grows by a few of the larger bands (those that came out of order,
    the one being received and converted), where assembling the image whole grew by all
    of it; the files are the local render's, byte for byte, and nothing else is left."""
    import tracemalloc

    scene = tmp_path / "tall.pov"
    scene.write_text(BLUR.replace("aperture 0.4 blur_samples 8", ""))
    w, tiles = 240, 24
    peaks = {}
    for h in (600, 2400):
        size = ["-W", str(w), "-H", str(h), "-q"]
        local, tiled = tmp_path / f"l{h}.png", tmp_path / f"c{h}.png"
        code, err = _render(["render", str(scene), "-o", str(local), *size], capsys)
        assert code == 0, err
        argv = ["render", str(scene), "-o", str(tiled), *size, "--tiles", str(tiles),
                "--cluster", client.scheduler.address]  # fmt: skip
        _render(argv, capsys)  # the first job's imports and caches are not the image's
        tracemalloc.start()
        try:
            code, err = _render(argv, capsys)
            peaks[h] = tracemalloc.get_traced_memory()[1]
        finally:
            tracemalloc.stop()
        assert code == 0, err
        assert tiled.read_bytes() == local.read_bytes()
    band = w * (2400 // tiles) * 3 * 4  # the larger image's band, float32 working values
    grown = peaks[2400] - peaks[600]
    assert grown < 8 * band, (peaks, band, f"the whole image: {tiles * band}")
    assert _leftovers(tmp_path) == []


RADIOSITY = """#version 3.7;
global_settings { assumed_gamma 1 radiosity { count 20 max_patches 200 } }
camera { location <clock * 0.6 - 0.3, 1.2, -3.5> look_at <0, 0.6, 0> }
light_source { <2, 4, -2> color rgb 1 }
plane { y, 0 pigment { rgb <0.8, 0.8, 0.7> } }
box { <-1.5, 0, 1>, <1.5, 2, 1.2> pigment { rgb <0.9, 0.2, 0.2> } }
sphere { <0, 0.6, 0>, 0.6 pigment { rgb 0.9 } }
"""


def test_a_radiosity_solution_is_solved_once_and_shipped_to_every_tile(client, tmp_path):
    """Two workers, six bands of one frame: one solution, computed by one task and shipped
    to every tile (none solves it itself), and the pixels are the local render's bit for
    bit. Then three frames of a walkthrough (the camera moves with the clock, the solution
    does not): the workers have the solution already and solve nothing; and once the
    scene changes, one solution for the three frames."""
    path = tmp_path / "rad.pov"
    path.write_text(RADIOSITY)
    w, h = 24, 18
    r = compile_file(str(path), image_width=w, image_height=h, clock=0.5, queries=RuntimeQueries)
    assert r.scene is not None and r.scene.settings.radiosity is not None
    shipped = bundle.of_files(path, r.files, r.scene, ())
    opts = cluster.Options(w, h, aa=0.3)
    frame = cluster.Frame(None, 0.5, radiosity=True)
    tiles: list[cluster.TaskResult] = []
    got = dict(cluster.run(client, shipped, opts, [frame], tiles=6,
                           on_tile=lambda _, t: tiles.append(t)))[frame]  # fmt: skip
    assert got.ok, (got.error, got.diagnostics)
    assert got.radiosity_solves == 1
    assert len(tiles) == 6 and all(t.radiosity_solves == 0 for t in tiles)
    assert len({t.solution.key for t in tiles if t.solution is not None}) == 1
    assert all(t.solution is not None and t.solution.solved for t in tiles)
    assert np.array_equal(got.image, render_scene(r.scene, w, h, antialias=0.3))

    walk = [cluster.Frame(n, (n - 1) / 2, radiosity=True) for n in (1, 2, 3)]
    outcomes = dict(cluster.run(client, shipped, opts, walk, tiles=4))
    assert all(o.ok for o in outcomes.values())
    assert sum(o.radiosity_solves for o in outcomes.values()) == 0  # the workers had it
    path.write_text(RADIOSITY.replace("rgb 0.9 }", "rgb 0.8 }"))  # another solution
    r2 = compile_file(str(path), image_width=w, image_height=h, queries=RuntimeQueries)
    assert r2.scene is not None
    shipped = bundle.of_files(path, r2.files, r2.scene, ())
    outcomes = dict(cluster.run(client, shipped, opts, walk, tiles=4))
    assert sum(o.radiosity_solves for o in outcomes.values()) == 1
    for f in walk:
        again = compile_file(str(path), image_width=w, image_height=h, clock=f.clock,
                             queries=RuntimeQueries).scene  # fmt: skip
        assert again is not None
        assert np.array_equal(outcomes[f].image, render_scene(again, w, h, antialias=0.3)), f


# each frame includes a file of its own and maps an image of its own; every frame reads a
# data file (#fopen/#read)
PER_FRAME = """#version 3.7;
global_settings { assumed_gamma 1 }
#include concat("f", str(frame_number, 0, 0), ".inc")
#fopen Data "data.txt" read
#read (Data, Size)
camera { location <0, 1, -4> look_at <0, 0.5, 0> }
light_source { <3, 5, -3> color rgb 1 }
plane { z, 2 pigment { image_map { png concat("m", str(frame_number, 0, 0), ".png") }
  translate <-0.5, -0.5, 0> scale 6 } }
sphere { <0, 0.7, 0>, Size pigment { rgb Col } }
"""


def _per_frame_scene(folder: Path) -> Path:
    from runtime import image

    folder.mkdir()
    for n, col in ((1, "<1, 0.2, 0.1>"), (2, "<0.1, 1, 0.2>"), (3, "<0.2, 0.1, 1>")):
        (folder / f"f{n}.inc").write_text(f"#declare Col = {col};\n")
        ramp = np.zeros((4, 4, 3), np.float32)
        ramp[..., n - 1] = np.linspace(0.2, 1.0, 16).reshape(4, 4)
        image.write_pixels(folder / f"m{n}.png", ramp, 8)
    (folder / "data.txt").write_text("0.55,\n")
    (folder / "s.pov").write_text(PER_FRAME)
    return folder / "s.pov"


def test_every_frames_files_travel_to_the_workers(client, tmp_path, capsys):
    """A later frame's include and image map and a data file read by #fopen/#read are in
    the bundle (the client compiles every frame for its reads): the frames the cluster
    writes are the local render's files, byte for byte."""
    scene = _per_frame_scene(tmp_path / "scene")
    size = ["-W", "16", "-H", "12", "--frames", "1..3"]
    code, err = _render(["render", str(scene), "-o", str(tmp_path / "l.png"), *size, "-q"],
                        capsys)  # fmt: skip
    assert code == 0, err
    address = client.scheduler.address
    code, err = _render(["render", str(scene), "-o", str(tmp_path / "c.png"), *size,
                         "--tiles", "2", "--cluster", address], capsys)  # fmt: skip
    assert code == 0, err
    images = [(tmp_path / f"c{n}.png").read_bytes() for n in (1, 2, 3)]
    assert images == [(tmp_path / f"l{n}.png").read_bytes() for n in (1, 2, 3)]
    assert len(set(images)) == 3  # each frame has its own include and image


def test_the_bundle_alone_carries_the_files(client, tmp_path):
    """The workers read nothing of the client's folders: with every frame's reads in the
    bundle, the scene's folder moved away before the job runs, the frames are still the
    local render's pixels."""
    scene = _per_frame_scene(tmp_path / "scene")
    w, h = 16, 12
    frames, local, read, scenes = [], [], [], []
    for n in (1, 2, 3):
        values = animation_values((n - 1) / 2, (1, 3), n)
        r = compile_file(str(scene), image_width=w, image_height=h, clock=(n - 1) / 2,
                         animation=values, queries=RuntimeQueries)  # fmt: skip
        assert r.scene is not None, r.diagnostics
        read += r.files
        scenes.append(r.scene)
        frames.append(cluster.Frame(n, (n - 1) / 2, tuple(values.items())))
        local.append(render_scene(r.scene, w, h))
    assert str(tmp_path / "scene" / "data.txt") in read
    shipped = bundle.of_files(scene, read, scenes, ())
    names = sorted(Path(f).name for f in shipped.files)
    assert names == ["data.txt", "f1.inc", "f2.inc", "f3.inc", "m1.png", "m2.png", "m3.png",
                     "s.pov"]  # fmt: skip
    (tmp_path / "scene").rename(tmp_path / "gone")
    got = dict(cluster.run(client, shipped, cluster.Options(w, h), frames, tiles=2))
    for frame, expected in zip(frames, local, strict=True):
        assert got[frame].ok, got[frame].diagnostics
        assert np.array_equal(got[frame].image, expected), frame.number


# the animation's identifiers in the colour: each frame is another image only if it sees
# its own values
IDENTIFIERS = """#version 3.7;
global_settings { assumed_gamma 1 }
camera { location <0, 1, -4> look_at <0, 0.5, 0> }
light_source { <3, 5, -3> color rgb 1 }
sphere { <0, 0.7, 0>, 0.7 pigment { rgb <frame_number / 10, (final_frame - initial_frame) / 10,
  clock_delta + clock_on / 4> } }
"""


def test_render_frames_gives_the_scene_the_animations_identifiers(client, tmp_path, capsys):
    """api.render_frames, here and on a cluster, gives the scene frame_number,
    initial_frame, final_frame, clock_delta and clock_on as `--frames 2..5` does: the
    images are the command line's files' values (8 bits, exactly)."""
    scene = tmp_path / "ids.pov"
    scene.write_text(IDENTIFIERS)
    code, err = _render(["render", str(scene), "-o", str(tmp_path / "f.png"), "-W", "12",
                         "-H", "9", "--frames", "2..5", "-q"], capsys)  # fmt: skip
    assert code == 0, err
    local = list(api.render_frames(scene, 2, 5, width=12, height=9))
    remote = list(api.render_frames(scene, 2, 5, width=12, height=9, client=client, tiles=2))
    assert [t for t, _ in local] == [t for t, _ in remote] == [0.0, 1 / 3, 2 / 3, 1.0]
    from runtime import image

    for n, (_, a), (_, b) in zip(range(2, 6), local, remote, strict=True):
        written = np.rint(image.read_image(tmp_path / f"f{n}.png") * 255)
        off = np.abs(np.rint(a * 255) - written)
        assert not off.any(), (n, off.max(), np.count_nonzero(off))
        assert np.array_equal(a, b), n
    assert len({a.tobytes() for _, a in local}) == 4  # frame_number differs
