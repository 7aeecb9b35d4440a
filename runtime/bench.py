"""`strala bench`: what each quality setting of a scene costs and buys.

The knobs that matter are read off the compiled scene (anti-aliasing always; area-light
samples, radiosity patch budget, nurbs tolerance, subdivision level and max_trace_level
only when the scene has what they act on). Each knob is swept alone from the scene's own
settings and compared with a reference: the image given with --reference, else strala's
render with every knob at its finest value. With --vs-povray, POV-Ray renders the same file
in the same run at its own quality settings (+A thresholds and depths; radiosity count /
error_bound when the scene has radiosity), compared with the same reference.

Both renderers are timed the same way: the wall time of a whole process that starts, reads
the scene file, renders and writes an 8-bit PNG (strala's is `python -m runtime.bench`,
which does what `strala render` does with the setting applied to the compiled scene, its
compile cache included, as a user's next render has it), the median of `runs` runs per
point. The result is a table, a CSV and a plot of error against time (log-log) with every
point labelled with its setting, strala's Pareto front joined and the reference drawn.
"""

from __future__ import annotations

import argparse
import csv
import dataclasses
import math
import os
import re
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from lang import ir
from runtime import metrics

# The anti-aliasing ladder: (threshold or None, depth), cheapest first.
AA_STEPS = ((None, 1), (0.3, 2), (0.3, 3), (0.1, 3), (0.03, 4))
AREA_SCALES = (0.25, 0.5, 1.0, 2.0)
PATCH_BUDGETS = (250, 1000, 4000, 16000)
NURBS_TOLERANCES = (1e-1, 1e-2, 1e-3, 1e-4)
SUBDIVISION_LEVELS = (1, 2, 3, 4, 5)
TRACE_LEVELS = (1, 2, 3, 5, 10)
POVRAY_AA = ((None, 1), (0.3, 2), (0.3, 3), (0.1, 3), (0.03, 4))
POVRAY_RADIOSITY = ((35, 1.8), (100, 1.0), (400, 0.5), (1600, 0.25))
RUNS = 3  # processes timed per point: their median is the point's time
REFERENCE = "reference"


@dataclass
class Setting:
    """One point of a sweep: how to change the scene and the render options."""

    knob: str
    label: str
    scene: Callable[[ir.Scene], ir.Scene] = lambda s: s
    aa: float | None = None
    aa_depth: int = 3


@dataclass
class Row:
    renderer: str
    knob: str
    label: str
    seconds: float  # the median of `times`
    rmse: float = math.nan
    ssim: float = math.nan
    pareto: bool = False
    image: np.ndarray | None = field(default=None, repr=False)
    times: tuple[float, ...] = ()  # each run's wall time

    @property
    def reference(self) -> bool:
        return self.knob == REFERENCE


# ----------------------------------------------------------- scene edits
def _map_objects(scene: ir.Scene, fn: Callable[[ir.Object], ir.Object]) -> ir.Scene:
    def walk(obj: ir.Object) -> ir.Object:
        obj = fn(obj)
        if isinstance(obj.shape, ir.CSG):
            kids = tuple(walk(c) for c in obj.shape.children)
            obj = dataclasses.replace(obj, shape=dataclasses.replace(obj.shape, children=kids))
        return obj

    return dataclasses.replace(scene, objects=tuple(walk(o) for o in scene.objects))


def _objects(scene: ir.Scene) -> list[ir.Object]:
    """Every object, CSG children included."""
    out: list[ir.Object] = []

    def walk(obj: ir.Object) -> None:
        out.append(obj)
        if isinstance(obj.shape, ir.CSG):
            for c in obj.shape.children:
                walk(c)

    for o in scene.objects:
        walk(o)
    return out


def _shapes(scene: ir.Scene) -> list:
    return [o.shape for o in _objects(scene)]


def _with_shape_field(kind: type, name: str, value) -> Callable[[ir.Scene], ir.Scene]:
    def edit(scene: ir.Scene) -> ir.Scene:
        def fn(obj: ir.Object) -> ir.Object:
            if isinstance(obj.shape, kind):
                return dataclasses.replace(
                    obj, shape=dataclasses.replace(obj.shape, **{name: value})
                )
            return obj

        return _map_objects(scene, fn)

    return edit


def _area_scale(k: float) -> Callable[[ir.Scene], ir.Scene]:
    def edit(scene: ir.Scene) -> ir.Scene:
        lights = []
        for light in scene.lights:
            a = light.area
            if a is not None:
                a = dataclasses.replace(
                    a, size1=max(1, round(a.size1 * k)), size2=max(1, round(a.size2 * k))
                )
                light = dataclasses.replace(light, area=a)
            lights.append(light)
        return dataclasses.replace(scene, lights=tuple(lights))

    return edit


def _settings_edit(**changes) -> Callable[[ir.Scene], ir.Scene]:
    def edit(scene: ir.Scene) -> ir.Scene:
        s = scene.settings
        if "radiosity" in changes:
            assert s.radiosity is not None  # knobs() offers these only with radiosity
            rad = dataclasses.replace(s.radiosity, **changes["radiosity"])
            return dataclasses.replace(scene, settings=dataclasses.replace(s, radiosity=rad))
        return dataclasses.replace(scene, settings=dataclasses.replace(s, **changes))

    return edit


def knobs(scene: ir.Scene) -> dict[str, list[Setting]]:
    """The sweeps that apply to this scene, each cheapest first."""
    out: dict[str, list[Setting]] = {
        "antialias": [
            Setting("antialias", "AA off" if t is None else f"+A{t} +R{d}", aa=t, aa_depth=d)
            for t, d in AA_STEPS
        ]
    }
    if any(getattr(light, "area", None) is not None for light in scene.lights):
        out["area_light"] = [
            Setting("area_light", f"area samples x{k:g}", _area_scale(k)) for k in AREA_SCALES
        ]
    if scene.settings.radiosity is not None:
        out["radiosity"] = [
            Setting(
                "radiosity",
                f"radiosity max_patches {n}",
                _settings_edit(radiosity={"max_patches": n}),
            )
            for n in PATCH_BUDGETS
        ]
    shapes = _shapes(scene)
    if any(isinstance(s, ir.Nurbs) for s in shapes):
        out["nurbs"] = [
            Setting("nurbs", f"nurbs tolerance {t:g}", _with_shape_field(ir.Nurbs, "tolerance", t))
            for t in NURBS_TOLERANCES
        ]
    if any(isinstance(s, ir.Subdivision) for s in shapes):
        out["subdivision"] = [
            Setting(
                "subdivision",
                f"subdivision levels {n}",
                _with_shape_field(ir.Subdivision, "levels", n),
            )
            for n in SUBDIVISION_LEVELS
        ]
    from runtime.prepare import texture_reflects, texture_transparent

    objects = _objects(scene)
    reflective = any(texture_reflects(o.texture) for o in objects if o.texture is not None)
    transparent = any(texture_transparent(o.texture) for o in objects if o.texture is not None)
    if reflective or transparent:
        out["max_trace_level"] = [
            Setting("max_trace_level", f"max_trace_level {n}", _settings_edit(max_trace_level=n))
            for n in TRACE_LEVELS
        ]
    return out


def finest(sweeps: dict[str, list[Setting]]) -> Setting:
    """Every knob at its finest value at once: the reference when none is given."""
    edits = [s[-1].scene for s in sweeps.values()]
    aa = sweeps["antialias"][-1]

    def edit(scene: ir.Scene) -> ir.Scene:
        for e in edits:
            scene = e(scene)
        return scene

    return Setting(REFERENCE, "finest", edit, aa=aa.aa, aa_depth=aa.aa_depth)


# ------------------------------------------------------------------ runs
def default_prefix(path: Path) -> Path:
    """Where the CSV and plot go without -o: beside the scene, where `strala render` writes
    the scene's image by default (and POV-Ray 3.7 its output, from any current folder)."""
    return path.with_name(f"{path.stem}-bench")


def timed(cmd: list[str], cwd: Path, runs: int, env: dict[str, str] | None = None) -> list[float]:
    """The wall time of each of `runs` runs of a whole process, from its start to its exit.
    A failing run raises RuntimeError with the end of what it said."""
    times = []
    for _ in range(runs):
        t0 = time.perf_counter()
        done = subprocess.run(
            cmd, capture_output=True, text=True, errors="replace", cwd=cwd, env=env,
            stdin=subprocess.DEVNULL, timeout=3600,
        )  # fmt: skip
        times.append(time.perf_counter() - t0)
        if done.returncode != 0:
            raise RuntimeError(f"{' '.join(cmd[:3])} … failed: {done.stderr.strip()[-400:]}")
    return times


def _strala_env() -> dict[str, str]:
    """The environment for strala's processes: this strala importable, whatever the cwd."""
    root = str(Path(__file__).resolve().parent.parent)
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join(p for p in (root, env.get("PYTHONPATH")) if p)
    return env


def strala_command(
    path: Path, knob: str, index: int, width: int, height: int, out: Path, library: list[str]
) -> list[str]:
    libs = [a for d in library for a in ("-L", str(d))]
    return [sys.executable, "-m", "runtime.bench", str(path), knob, str(index),
            str(width), str(height), str(out), *libs]  # fmt: skip


def _measure(renderer: str, knob: str, label: str, cmd: list[str], out: Path, cwd: Path,
             runs: int, env: dict[str, str] | None = None) -> Row:  # fmt: skip
    from runtime.image import read_image

    times = timed(cmd, cwd, runs, env)
    if not out.is_file():
        raise RuntimeError(f"{renderer} wrote no image for {knob} {label}")
    img = read_image(out)[..., :3]
    out.unlink()
    return Row(renderer, knob, label, statistics.median(times), image=img, times=tuple(times))


def _povray_text(text: str, count: int, error_bound: float) -> str:
    """The scene's text with its radiosity block's count and error_bound replaced (added
    when absent)."""
    m = re.search(r"radiosity\s*\{", text)
    if m is None:
        return text
    body_start = m.end()
    return text[:body_start] + f" count {count} error_bound {error_bound} " + text[body_start:]


def povray_rows(
    path: Path, width: int, height: int, library: list[str], radiosity: bool, runs: int = RUNS
) -> list[Row]:
    """POV-Ray's own quality curve on the same file, timed in this run as strala's is."""
    exe = shutil.which("povray")
    if exe is None:
        raise RuntimeError("POV-Ray is not installed (apt-get install povray)")
    rows: list[Row] = []
    with tempfile.TemporaryDirectory() as tmp:
        plan: list[tuple[str, str, list[str], Path]] = [
            ("antialias", "AA off" if t is None else f"+A{t} +R{d}",
             [] if t is None else [f"+A{t}", f"+R{d}"], path)
            for t, d in POVRAY_AA
        ]  # fmt: skip
        if radiosity:
            text = path.read_text(errors="replace")
            for count, eb in POVRAY_RADIOSITY:
                variant = Path(tmp) / path.name.replace(path.suffix, f"_{count}{path.suffix}")
                # strip the block's own count/error_bound so the ones put first win
                body = re.sub(r"(radiosity\s*\{[^}]*?)\bcount\s+[\d.]+", r"\1", text)
                body = re.sub(r"(radiosity\s*\{[^}]*?)\berror_bound\s+[\d.]+", r"\1", body)
                variant.write_text(_povray_text(body, count, eb))
                label = f"radiosity count {count} error_bound {eb}"
                plan.append(("radiosity", label, ["+A0.3"], variant))
        for knob, label, opts, scene_path in plan:
            out = Path(tmp) / "pov.png"
            libs = [f"+L{d}" for d in (path.parent, *library)]
            cmd = [exe, f"+I{scene_path}", f"+O{out}", f"+W{width}", f"+H{height}", "-D",
                   "-V", "-GA", *opts, *libs]  # fmt: skip
            try:
                rows.append(_measure("povray", knob, label, cmd, out, path.parent, runs))
            except RuntimeError:
                continue  # a setting POV-Ray refuses is left out, as before
    return rows


def score(rows: list[Row], reference: np.ndarray) -> None:
    for r in rows:
        if r.image is not None and r.image.shape == reference.shape:
            r.rmse = metrics.rmse(r.image, reference)
            r.ssim = metrics.ssim(r.image, reference)


def mark_pareto(rows: list[Row]) -> None:
    """Strala's settings that no other strala setting beats on both time and error (the
    reference, every knob at once, is the yardstick, not a setting of the front)."""
    ours = [
        r for r in rows if r.renderer == "strala" and r.knob != REFERENCE and math.isfinite(r.rmse)
    ]
    for r in ours:
        r.pareto = not any(
            (o.seconds <= r.seconds and o.rmse <= r.rmse)
            and (o.seconds < r.seconds or o.rmse < r.rmse)
            for o in ours
        )


# ------------------------------------------------------------------ output
def table(rows: list[Row]) -> str:
    runs = max((len(r.times) for r in rows), default=1)
    lines = [f"{'renderer':8} {'knob':16} {'setting':28} {'seconds':>8} {'RMSE':>8} {'SSIM':>7}"]
    for r in rows:
        star = " *" if r.pareto else ""
        lines.append(
            f"{r.renderer:8} {r.knob:16} {r.label:28} {r.seconds:8.3f} {r.rmse:8.4f} "
            f"{r.ssim:7.4f}{star}"
        )
    lines.append(
        f"seconds: the whole process (start, read the scene, render, write the image), "
        f"the median of {runs} run{'s' if runs != 1 else ''}"
    )
    lines.append("* on strala's Pareto front (no other setting is both faster and closer)")
    return "\n".join(lines)


def write_csv(rows: list[Row], path: Path) -> None:
    tmp = path.with_name(f".{path.name}.tmp")
    with open(tmp, "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(["renderer", "knob", "setting", "seconds", "runs", "seconds_min",
                    "seconds_max", "rmse", "ssim", "pareto"])  # fmt: skip
        for r in rows:
            times = r.times or (r.seconds,)
            w.writerow([r.renderer, r.knob, r.label, f"{r.seconds:.4f}", len(times),
                        f"{min(times):.4f}", f"{max(times):.4f}", f"{r.rmse:.6f}",
                        f"{r.ssim:.6f}", int(r.pareto)])  # fmt: skip
    tmp.replace(path)


def run(
    path: Path,
    width: int,
    height: int,
    library: list[str],
    reference_image: Path | None = None,
    vs_povray: bool = False,
    out_prefix: Path | None = None,
    log: Callable[[str], None] = print,
    runs: int = RUNS,
) -> list[Row]:
    """The whole benchmark; returns its rows (images dropped) and writes CSV and plot."""
    from runtime.api import compile_file
    from runtime.bench_plot import plot
    from runtime.image import read_image

    compiled = compile_file(path, library_paths=library, width=width, height=height)
    sweeps = knobs(compiled.scene)
    log(f"knobs: {', '.join(sweeps)}; {runs} timed run{'s' if runs != 1 else ''} a point")
    rows: list[Row] = []
    env = _strala_env()
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp) / "strala.png"

        def strala(knob: str, index: int, label: str) -> Row:
            cmd = strala_command(path, knob, index, width, height, out, library)
            return _measure("strala", knob, label, cmd, out, path.parent, runs, env)

        if reference_image is not None:
            ref = read_image(reference_image)[..., :3]
            if ref.shape[:2] != (height, width):
                raise ValueError(
                    f"the reference is {ref.shape[1]}x{ref.shape[0]}, the bench renders "
                    f"{width}x{height}"
                )
        else:
            best = strala(REFERENCE, 0, "finest (every knob)")
            assert best.image is not None
            ref = best.image
            rows.append(best)
            log(f"reference (every knob at its finest): {best.seconds:.2f} s")
        for settings in sweeps.values():
            for i, s in enumerate(settings):
                rows.append(strala(s.knob, i, s.label))
                log(f"  strala {s.label}: {rows[-1].seconds:.3f} s")
    if vs_povray:
        radiosity = compiled.scene.settings.radiosity is not None
        pov = povray_rows(path, width, height, library, radiosity, runs)
        for r in pov:
            log(f"  povray {r.label}: {r.seconds:.3f} s")
        rows.extend(pov)
    score(rows, ref)
    mark_pareto(rows)
    for r in rows:
        r.image = None
    prefix = out_prefix or default_prefix(path)
    write_csv(rows, prefix.with_suffix(".csv"))
    plot(rows, prefix.with_suffix(".png"), f"{path.name} {width}x{height}: error vs time")
    return rows


# ------------------------------------------------------------------ one point
def render_point(argv: list[str]) -> None:
    """A strala point as its own process (python -m runtime.bench SCENE KNOB INDEX W H OUT):
    compile the scene file, apply the setting, render and write an 8-bit PNG, as
    `strala render` does."""
    p = argparse.ArgumentParser(prog="python -m runtime.bench")
    for name in ("scene", "knob"):
        p.add_argument(name)
    for name in ("index", "width", "height"):
        p.add_argument(name, type=int)
    p.add_argument("output")
    p.add_argument("-L", dest="library", action="append", default=[])
    a = p.parse_args(argv)
    from runtime.api import compile_file, render
    from runtime.image import write_pixels

    compiled = compile_file(a.scene, library_paths=a.library, width=a.width, height=a.height)
    sweeps = knobs(compiled.scene)
    s = finest(sweeps) if a.knob == REFERENCE else sweeps[a.knob][a.index]
    edited = s.scene(compiled.scene)
    img = render(edited, width=a.width, height=a.height, aa=s.aa, aa_depth=s.aa_depth)
    write_pixels(a.output, img, 8)


if __name__ == "__main__":
    render_point(sys.argv[1:])
