"""`strala bench`: the knobs it finds, its Pareto front, its files, and SSIM against an
independent implementation."""

from __future__ import annotations

import csv
import math

import numpy as np
import pytest
from conftest import EXAMPLES, run_cli
from hypothesis import given
from hypothesis import strategies as st

from lang.evaluate import compile_source
from runtime import bench, metrics


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
    (setting,) = [s for s in bench.knobs(scene)["area_light"] if s.label == "samples x0.5"]
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


def test_bench_writes_table_csv_and_plot(tmp_path):
    scene = tmp_path / "s.pov"
    scene.write_text(
        "camera { location <0,1,-4> look_at 0 } light_source { <5,5,-5> rgb 1 }\n"
        "sphere { 0, 1 pigment { checker rgb 1, rgb 0 scale 0.3 } finish { reflection 0.3 } }\n"
        "plane { y, -1 pigment { rgb 0.5 } }\n"
    )
    r = run_cli("bench", str(scene), "-W", "32", "-H", "24", "-o", str(tmp_path / "b"))
    assert r.returncode == 0, r.stderr
    assert "Pareto" in r.stdout and "antialias" in r.stdout
    rows = list(csv.DictReader(open(tmp_path / "b.csv")))
    assert {row["knob"] for row in rows} == {"antialias", "max_trace_level"}
    errors = {row["setting"]: float(row["rmse"]) for row in rows if row["knob"] == "antialias"}
    assert errors["off"] > errors["+A0.03 +R4"]  # the finest AA is the reference
    assert all(math.isfinite(float(row["seconds"])) for row in rows)
    import OpenImageIO as oiio

    assert oiio.ImageBuf(str(tmp_path / "b.png")).spec().width == 760


@pytest.mark.povray
def test_bench_measures_povray_in_the_same_run(tmp_path):
    scene = tmp_path / "s.pov"
    scene.write_text(
        "camera { location <0,1,-4> look_at 0 } light_source { <5,5,-5> rgb 1 }\n"
        "sphere { 0, 1 pigment { checker rgb 1, rgb 0 scale 0.3 } }\n"
    )
    r = run_cli("bench", str(scene), "-W", "32", "-H", "24", "--vs-povray", "-o",
                str(tmp_path / "b"))  # fmt: skip
    assert r.returncode == 0, r.stderr
    rows = list(csv.DictReader(open(tmp_path / "b.csv")))
    pov = [row for row in rows if row["renderer"] == "povray"]
    assert len(pov) == len(bench.POVRAY_AA)
    assert all(float(row["rmse"]) < 0.1 for row in pov)  # the same picture as strala's


def test_bench_reports_a_missing_file(tmp_path):
    r = run_cli("bench", str(tmp_path / "nope.pov"))
    assert r.returncode == 2 and "no such scene" in r.stderr
