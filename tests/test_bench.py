"""`strala bench`: the knobs it finds, its Pareto front, its files, and SSIM against an
independent implementation."""

from __future__ import annotations

import csv
import math
import statistics
import sys
from pathlib import Path

import numpy as np
import pytest
from conftest import EXAMPLES, run_cli
from hypothesis import given
from hypothesis import strategies as st

from lang.evaluate import compile_source
from runtime import bench, metrics
from runtime.image import read_image


def knob_names(src: str) -> set[str]:
    return set(bench.knobs(compile_source(src).scene))


def test_knobs_follow_what_the_scene_has():
    base = "camera { location -5*z look_at 0 } light_source { <5,5,-5> rgb 1 }\n"
    assert knob_names(base + "sphere { 0, 1 pigment { rgb 1 } }") == {"antialias"}
    assert "max_trace_level" in knob_names(
        base + "sphere { 0, 1 pigment { rgb 1 } finish { reflection 0.5 } }"
    )
    assert "max_trace_level" in knob_names(base + "sphere { 0, 1 pigment { rgbf <1,1,1,0.5> } }")
    area = "light_source { 0, 1 area_light x, z, 4, 4 }\nsphere { 0, 1 pigment { rgb 1 } }"
    assert "area_light" in knob_names(base + area)
    rad = "global_settings { radiosity { } }\nsphere { 0, 1 pigment { rgb 1 } }"
    assert "radiosity" in knob_names(base + rad)
    sub = (EXAMPLES / "subdivision_creases.scene").read_text()
    assert "subdivision" in set(bench.knobs(compile_source(sub, str(EXAMPLES / "x.scene")).scene))


def test_area_light_knob_scales_the_samples():
    scene = compile_source(
        "camera { location -5*z look_at 0 } light_source { 0, 1 area_light x, z, 4, 6 }"
    ).scene
    (setting,) = [s for s in bench.knobs(scene)["area_light"] if s.label == "area samples x0.5"]
    area = setting.scene(scene).lights[0].area
    assert (area.size1, area.size2) == (2, 3)


@given(st.lists(st.tuples(st.floats(0.01, 10), st.floats(1e-4, 1)), min_size=1, max_size=12))
def test_pareto_front_is_exactly_the_undominated_settings(points):
    rows = [bench.Row("strala", "k", str(i), t, e) for i, (t, e) in enumerate(points)]
    bench.mark_pareto(rows)
    for r in rows:
        dominated = any(
            o.seconds <= r.seconds
            and o.rmse <= r.rmse
            and (o.seconds, o.rmse) != (r.seconds, r.rmse)
            for o in rows
        )
        assert r.pareto == (not dominated)
    assert any(r.pareto for r in rows)


def test_ssim_equals_scikit_image():
    skm = pytest.importorskip("skimage.metrics")
    rng = np.random.default_rng(3)
    a = rng.random((48, 64, 3))
    b = np.clip(a + 0.08 * rng.normal(size=a.shape), 0, 1)
    want = skm.structural_similarity(
        a @ metrics.LUMA, b @ metrics.LUMA, data_range=1.0, gaussian_weights=True,
        sigma=1.5, use_sample_covariance=False,
    )  # fmt: skip
    assert metrics.ssim(a, b) == pytest.approx(want, abs=1e-12)
    assert metrics.ssim(a, a) == pytest.approx(1.0)


SCENE = (
    "camera { location <0,1,-4> look_at 0 } light_source { <5,5,-5> rgb 1 }\n"
    "sphere { 0, 1 pigment { checker rgb 1, rgb 0 scale 0.3 } finish { reflection 0.3 } }\n"
    "plane { y, -1 pigment { rgb 0.5 } }\n"
)


def test_bench_writes_table_csv_and_plot_where_render_writes_the_image(tmp_path):
    # run from another folder: the files go beside the scene, where `strala render` puts
    # SCENE.png by default (POV-Ray 3.7's rule too: test_outputs_go_where_povray_puts_its)
    source, here = tmp_path / "src", tmp_path / "here"
    source.mkdir(), here.mkdir()
    scene = source / "s.pov"
    scene.write_text(SCENE)
    r = run_cli("render", str(Path("..") / "src" / "s.pov"), "-W", "8", "-H", "6", cwd=here)
    assert r.returncode == 0, r.stderr
    r = run_cli("bench", str(Path("..") / "src" / "s.pov"), "-W", "32", "-H", "24",
                "--runs", "2", cwd=here)  # fmt: skip
    assert r.returncode == 0, r.stderr
    assert sorted(p.name for p in here.iterdir()) == []
    assert sorted(p.name for p in source.iterdir()) == [
        "s-bench.csv", "s-bench.png", "s.png", "s.pov"
    ]  # fmt: skip
    assert "Pareto" in r.stdout and "antialias" in r.stdout and "median of 2 runs" in r.stdout
    rows = list(csv.DictReader(open(source / "s-bench.csv")))
    assert {row["knob"] for row in rows} == {"reference", "antialias", "max_trace_level"}
    errors = {row["setting"]: float(row["rmse"]) for row in rows if row["knob"] == "antialias"}
    assert errors["AA off"] > errors["+A0.03 +R4"]  # the finest AA is the reference
    (ref,) = [row for row in rows if row["knob"] == "reference"]
    assert float(ref["rmse"]) == 0 and ref["pareto"] == "0"
    for row in rows:  # each point's time: the median of its runs
        assert row["runs"] == "2"
        low, mid, high = (float(row[k]) for k in ("seconds_min", "seconds", "seconds_max"))
        assert low <= mid <= high and math.isclose(mid, (low + high) / 2, abs_tol=1e-3)
    import OpenImageIO as oiio

    assert oiio.ImageBuf(str(source / "s-bench.png")).spec().width == 760
    # -o a folder: SCENE-bench.* in it
    out = tmp_path / "out"
    out.mkdir()
    r = run_cli("bench", str(scene), "-W", "8", "-H", "6", "--runs", "1", "-o", f"{out}/")
    assert r.returncode == 0, r.stderr
    assert sorted(p.name for p in out.iterdir()) == ["s-bench.csv", "s-bench.png"]


@pytest.mark.povray
def test_outputs_go_where_povray_puts_its(tmp_path):
    """POV-Ray 3.7 names its image after the scene and writes it beside the scene, from
    any current folder; `strala render` and `strala bench` write theirs there too."""
    import subprocess

    source, here = tmp_path / "src", tmp_path / "here"
    source.mkdir(), here.mkdir()
    (source / "s.pov").write_text(SCENE)
    relative = str(Path("..") / "src" / "s.pov")
    subprocess.run(["povray", f"+I{relative}", "+W8", "+H6", "-D", "-V", "-GA"], cwd=here,
                   check=True, capture_output=True, timeout=120)  # fmt: skip
    assert sorted(p.name for p in here.iterdir()) == []
    (source / "s.png").rename(source / "povray.png")
    for argv in (["render", relative], ["bench", relative, "--runs", "1"]):
        r = run_cli(*argv, "-W", "8", "-H", "6", cwd=here)
        assert r.returncode == 0, r.stderr
    assert sorted(p.name for p in here.iterdir()) == []
    assert sorted(p.name for p in source.iterdir()) == [
        "povray.png", "s-bench.csv", "s-bench.png", "s.png", "s.pov"
    ]  # fmt: skip


def test_bench_refuses_an_unwritable_output_before_any_render(tmp_path):
    scene = tmp_path / "s.pov"
    scene.write_text(SCENE)
    r = run_cli("bench", str(scene), "-o", str(tmp_path / "missing" / "b"))
    assert r.returncode == 2 and "does not exist" in r.stderr and "knobs" not in r.stderr


def test_a_point_s_time_is_the_median_of_whole_process_runs(tmp_path):
    # a first run slowed (a cold cache, another job) moves the mean, not the median
    counter = tmp_path / "n"
    counter.write_text("0")
    script = (
        f"import pathlib, time; p = pathlib.Path(r'{counter}'); n = int(p.read_text()); "
        "p.write_text(str(n + 1)); time.sleep(0.8 if n == 0 else 0.01)"
    )
    times = bench.timed([sys.executable, "-c", script], tmp_path, 3)
    assert counter.read_text() == "3" and len(times) == 3
    assert times[0] >= 0.8 and statistics.median(times) < 0.2 and statistics.mean(times) > 0.25
    with pytest.raises(RuntimeError, match="boom"):
        bench.timed([sys.executable, "-c", "raise SystemExit('boom')"], tmp_path, 1)


@pytest.mark.povray
def test_both_renderers_are_timed_as_whole_processes(tmp_path, monkeypatch):
    # strala's points were in-process renders of an already compiled scene (0.004 s)
    # against POV-Ray's whole process (0.6 s): now each row is timed around a process
    timed_commands: list[list[str]] = []
    real = bench.timed

    def spy(cmd, cwd, runs, env=None):
        timed_commands.append(cmd)
        return real(cmd, cwd, runs, env)

    monkeypatch.setattr(bench, "timed", spy)
    monkeypatch.chdir(tmp_path)
    scene = tmp_path / "s.pov"
    scene.write_text("camera { location -4*z look_at 0 } light_source { <5,5,-5> rgb 1 }\n"
                     "sphere { 0, 1 pigment { rgb 1 } }\n")  # fmt: skip
    rows = bench.run(scene, 16, 12, [], vs_povray=True, log=lambda _: None, runs=1)
    assert len(timed_commands) == len(rows) == 1 + 2 * len(bench.AA_STEPS)
    kinds = [(c[0], c[1:3]) for c in timed_commands]
    assert kinds.count((sys.executable, ["-m", "runtime.bench"])) == 1 + len(bench.AA_STEPS)
    assert sum(Path(c[0]).name == "povray" for c in timed_commands) == len(bench.POVRAY_AA)
    interpreter = bench.timed([sys.executable, "-c", "pass"], tmp_path, 1)[0]
    for r in rows:
        assert len(r.times) == 1 and r.seconds == r.times[0] > interpreter
    assert {p.name for p in tmp_path.iterdir()} == {"s.pov", "s-bench.csv", "s-bench.png"}


def _row(renderer, knob, label, seconds, rmse, pareto=False):
    return bench.Row(renderer, knob, label, seconds, rmse, pareto=pareto, times=(seconds,))


def test_the_plot_labels_every_point_draws_the_reference_and_no_empty_legend(tmp_path):
    from runtime import bench_plot

    rows = [
        _row("strala", "reference", "finest", 2.0, 0.0),
        _row("strala", "antialias", "AA off", 0.5, 0.05, pareto=True),
        _row("strala", "antialias", "+A0.3 +R3", 0.9, 0.01, pareto=True),
        _row("strala", "antialias", "+A0.03 +R4", 1.5, 0.0, pareto=True),
        _row("strala", "max_trace_level", "max_trace_level 2", 0.52, 0.05),
        _row("strala", "max_trace_level", "max_trace_level 5", 0.53, 0.05),
    ]
    plan = bench_plot.layout(rows)
    assert [label.text for label in plan.labels if "reference" not in label.text] == [
        r.label for r in rows[1:] if r.pareto
    ] + [r.label for r in rows[1:] if not r.pareto]
    assert "reference: finest" in [label.text for label in plan.labels]
    # strala only: no POV-Ray entry; the reference has its own
    assert [text for text, _, _ in plan.legend] == ["strala (front joined)", "reference (error 0)"]
    # the error-free points stand on the zero row under the lowest decade
    (ref,) = [p for p in plan.points if p.row.reference]
    (exact,) = [p for p in plan.points if p.row.label == "+A0.03 +R4"]
    lowest = min(p.y for p in plan.points if p.row.rmse > 0)
    assert ref.y == exact.y > lowest and ref.colour == bench_plot.GREEN
    # there is room: no label covers another label or a marker
    boxes = [label.box for label in plan.labels]
    markers = [(p.x - p.size, p.y - p.size, p.x + p.size, p.y + p.size) for p in plan.points]
    for i, a in enumerate(boxes):
        assert not any(bench_plot.overlaps(a, b) for b in boxes[i + 1 :] + markers)
    path = tmp_path / "p.png"
    bench_plot.plot(rows, path, "t")
    pixels = read_image(path)
    assert np.allclose(pixels[ref.y, ref.x], bench_plot.GREEN, atol=0.01)
    # with POV-Ray's points, its entry; without a reference, none for it
    rows = rows[1:] + [_row("povray", "antialias", "AA off", 0.7, 0.05)]
    assert [text for text, _, _ in bench_plot.layout(rows).legend] == [
        "strala (front joined)",
        "POV-Ray 3.7",
    ]
    assert [text for text, _, _ in bench_plot.layout(rows[-1:]).legend] == ["POV-Ray 3.7"]
    assert bench_plot.layout([]).legend == []


@pytest.mark.povray
def test_bench_measures_povray_in_the_same_run(tmp_path):
    scene = tmp_path / "s.pov"
    scene.write_text(
        "camera { location <0,1,-4> look_at 0 } light_source { <5,5,-5> rgb 1 }\n"
        "sphere { 0, 1 pigment { checker rgb 1, rgb 0 scale 0.3 } }\n"
    )
    r = run_cli("bench", str(scene), "-W", "32", "-H", "24", "--vs-povray", "--runs", "1",
                "-o", str(tmp_path / "b"))  # fmt: skip
    assert r.returncode == 0, r.stderr
    rows = list(csv.DictReader(open(tmp_path / "b.csv")))
    pov = [row for row in rows if row["renderer"] == "povray"]
    assert len(pov) == len(bench.POVRAY_AA)
    assert all(float(row["rmse"]) < 0.1 for row in pov)  # the same picture as strala's


def test_bench_reports_a_missing_file(tmp_path):
    r = run_cli("bench", str(tmp_path / "nope.pov"))
    assert r.returncode == 2 and "no such scene" in r.stderr
