"""`strala bench`: what each quality setting of a scene costs and buys.

The knobs that matter are read off the compiled scene (anti-aliasing always; area-light
samples, radiosity patch budget, nurbs tolerance, subdivision level and max_trace_level
only when the scene has what they act on). Each knob is swept alone from the scene's own
settings; every render is timed (wall clock) and compared with a reference: the image given
with --reference, else strala's render with every knob at its finest value. With
--vs-povray, POV-Ray renders the same file in the same run at its own quality settings
(+A thresholds and depths; radiosity count / error_bound when the scene has radiosity),
compared with the same reference. The result is a table, a CSV and a plot of error
against time (log-log) with the Pareto front of strala's settings marked.
"""

from __future__ import annotations

import csv
import dataclasses
import math
import re
import shutil
import subprocess
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
    seconds: float
    rmse: float = math.nan
    ssim: float = math.nan
    pareto: bool = False
    image: np.ndarray | None = field(default=None, repr=False)


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
            Setting("antialias", "off" if t is None else f"+A{t} +R{d}", aa=t, aa_depth=d)
            for t, d in AA_STEPS
        ]
    }
    if any(getattr(light, "area", None) is not None for light in scene.lights):
        out["area_light"] = [
            Setting("area_light", f"samples x{k:g}", _area_scale(k)) for k in AREA_SCALES
        ]
    if scene.settings.radiosity is not None:
        out["radiosity"] = [
            Setting("radiosity", f"max_patches {n}", _settings_edit(radiosity={"max_patches": n}))
            for n in PATCH_BUDGETS
        ]
    shapes = _shapes(scene)
    if any(isinstance(s, ir.Nurbs) for s in shapes):
        out["nurbs"] = [
            Setting("nurbs", f"tolerance {t:g}", _with_shape_field(ir.Nurbs, "tolerance", t))
            for t in NURBS_TOLERANCES
        ]
    if any(isinstance(s, ir.Subdivision) for s in shapes):
        out["subdivision"] = [
            Setting("subdivision", f"levels {n}", _with_shape_field(ir.Subdivision, "levels", n))
            for n in SUBDIVISION_LEVELS
        ]
    from runtime.prepare import texture_reflects, texture_transparent

    objects = _objects(scene)
    reflective = any(texture_reflects(o.texture) for o in objects if o.texture is not None)
    transparent = any(texture_transparent(o.texture) for o in objects if o.texture is not None)
    if reflective or transparent:
        out["max_trace_level"] = [
            Setting("max_trace_level", f"{n}", _settings_edit(max_trace_level=n))
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

    return Setting("reference", "finest", edit, aa=aa.aa, aa_depth=aa.aa_depth)


# ------------------------------------------------------------------ runs
def _render(scene: ir.Scene, s: Setting, width: int, height: int) -> tuple[np.ndarray, float]:
    from runtime.api import render

    edited = s.scene(scene)
    t0 = time.perf_counter()
    img = render(edited, width=width, height=height, aa=s.aa, aa_depth=s.aa_depth)
    return img, time.perf_counter() - t0


def _povray_text(text: str, count: int, error_bound: float) -> str:
    """The scene's text with its radiosity block's count and error_bound replaced (added
    when absent)."""
    m = re.search(r"radiosity\s*\{", text)
    if m is None:
        return text
    body_start = m.end()
    return text[:body_start] + f" count {count} error_bound {error_bound} " + text[body_start:]


def povray_rows(
    path: Path, width: int, height: int, library: list[str], radiosity: bool
) -> list[Row]:
    """POV-Ray's own quality curve on the same file, timed in this run."""
    import OpenImageIO as oiio

    exe = shutil.which("povray")
    if exe is None:
        raise RuntimeError("POV-Ray is not installed (apt-get install povray)")
    rows: list[Row] = []
    with tempfile.TemporaryDirectory() as tmp:
        runs: list[tuple[str, str, list[str], Path]] = [
            ("antialias", "off" if t is None else f"+A{t} +R{d}",
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
                runs.append(("radiosity", f"count {count} error_bound {eb}", ["+A0.3"], variant))
        for knob, label, opts, scene_path in runs:
            out = Path(tmp) / "pov.png"
            libs = [f"+L{d}" for d in (path.parent, *library)]
            cmd = [exe, f"+I{scene_path}", f"+O{out}", f"+W{width}", f"+H{height}", "-D",
                   "-V", "-GA", *opts, *libs]  # fmt: skip
            t0 = time.perf_counter()
            done = subprocess.run(cmd, capture_output=True, cwd=path.parent, timeout=3600)
            seconds = time.perf_counter() - t0
            if done.returncode != 0 or not out.is_file():
                continue
            pixels = oiio.ImageBuf(str(out)).get_pixels(oiio.FLOAT)
            assert pixels is not None  # None only when the file cannot be read
            img = pixels[..., :3]
            rows.append(Row("povray", knob, label, seconds, image=img))
            out.unlink()
    return rows


def score(rows: list[Row], reference: np.ndarray) -> None:
    for r in rows:
        if r.image is not None and r.image.shape == reference.shape:
            r.rmse = metrics.rmse(r.image, reference)
            r.ssim = metrics.ssim(r.image, reference)


def mark_pareto(rows: list[Row]) -> None:
    """Strala's settings that no other strala setting beats on both time and error."""
    ours = [r for r in rows if r.renderer == "strala" and math.isfinite(r.rmse)]
    for r in ours:
        r.pareto = not any(
            (o.seconds <= r.seconds and o.rmse <= r.rmse)
            and (o.seconds < r.seconds or o.rmse < r.rmse)
            for o in ours
        )


# ------------------------------------------------------------------ output
def table(rows: list[Row]) -> str:
    lines = [f"{'renderer':8} {'knob':16} {'setting':28} {'seconds':>8} {'RMSE':>8} {'SSIM':>7}"]
    for r in rows:
        star = " *" if r.pareto else ""
        lines.append(
            f"{r.renderer:8} {r.knob:16} {r.label:28} {r.seconds:8.3f} {r.rmse:8.4f} "
            f"{r.ssim:7.4f}{star}"
        )
    lines.append("* on strala's Pareto front (no other setting is both faster and closer)")
    return "\n".join(lines)


def write_csv(rows: list[Row], path: Path) -> None:
    tmp = path.with_name(f".{path.name}.tmp")
    with open(tmp, "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(["renderer", "knob", "setting", "seconds", "rmse", "ssim", "pareto"])
        for r in rows:
            w.writerow([r.renderer, r.knob, r.label, f"{r.seconds:.4f}", f"{r.rmse:.6f}",
                        f"{r.ssim:.6f}", int(r.pareto)])  # fmt: skip
    tmp.replace(path)


def plot(rows: list[Row], path: Path, title: str) -> None:
    """Error (RMSE) against wall time, both log scale: strala's points in blue with its
    Pareto front joined, POV-Ray's in red; drawn with OpenImageIO."""
    import OpenImageIO as oiio

    W, H, L, R, T, B = 760, 480, 80, 20, 40, 60
    pts = [r for r in rows if math.isfinite(r.rmse) and r.rmse > 0 and r.seconds > 0]
    buf = oiio.ImageBuf(oiio.ImageSpec(W, H, 3, oiio.FLOAT))
    oiio.ImageBufAlgo.fill(buf, (1.0, 1.0, 1.0))
    black, blue, red, grey = (0, 0, 0), (0.1, 0.3, 0.9), (0.85, 0.15, 0.1), (0.8, 0.8, 0.8)
    if pts:
        tx = np.log10([r.seconds for r in pts])
        ey = np.log10([r.rmse for r in pts])
        x0, x1 = math.floor(tx.min()), math.ceil(tx.max() + 1e-9)
        y0, y1 = math.floor(ey.min()), math.ceil(ey.max() + 1e-9)
        x1, y1 = max(x1, x0 + 1), max(y1, y0 + 1)

        def xy(t: float, e: float) -> tuple[int, int]:
            px = L + (math.log10(t) - x0) / (x1 - x0) * (W - L - R)
            py = H - B - (math.log10(e) - y0) / (y1 - y0) * (H - T - B)
            return int(round(px)), int(round(py))

        for k in range(x0, x1 + 1):
            px = L + (k - x0) / (x1 - x0) * (W - L - R)
            oiio.ImageBufAlgo.render_line(buf, int(px), T, int(px), H - B, grey)
            oiio.ImageBufAlgo.render_text(
                buf, int(px) - 14, H - B + 20, f"{10.0**k:g}", 14, "", black
            )
        for k in range(y0, y1 + 1):
            py = H - B - (k - y0) / (y1 - y0) * (H - T - B)
            oiio.ImageBufAlgo.render_line(buf, L, int(py), W - R, int(py), grey)
            oiio.ImageBufAlgo.render_text(buf, 8, int(py) + 5, f"{10.0**k:g}", 14, "", black)
        front = sorted((r for r in pts if r.pareto), key=lambda r: r.seconds)
        for a, b in zip(front, front[1:], strict=False):
            oiio.ImageBufAlgo.render_line(buf, *xy(a.seconds, a.rmse), *xy(b.seconds, b.rmse), blue)
        for r in pts:
            px, py = xy(r.seconds, r.rmse)
            colour = blue if r.renderer == "strala" else red
            oiio.ImageBufAlgo.render_box(buf, px - 3, py - 3, px + 3, py + 3, colour, fill=True)
    oiio.ImageBufAlgo.render_line(buf, L, T, L, H - B, black)
    oiio.ImageBufAlgo.render_line(buf, L, H - B, W - R, H - B, black)
    oiio.ImageBufAlgo.render_text(buf, L, 24, title, 16, "", black)
    oiio.ImageBufAlgo.render_text(buf, W // 2 - 60, H - 12, "wall time (s)", 14, "", black)
    oiio.ImageBufAlgo.render_text(buf, 8, T - 8, "RMSE", 14, "", black)
    oiio.ImageBufAlgo.render_text(buf, W - 230, T + 20, "strala (front joined)", 14, "", blue)
    oiio.ImageBufAlgo.render_text(buf, W - 230, T + 40, "POV-Ray 3.7", 14, "", red)
    tmp = path.with_name(f".{path.name}.tmp{path.suffix}")
    if not buf.write(str(tmp)):
        raise OSError(f"cannot write {path}: {buf.geterror()}")
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
) -> list[Row]:
    """The whole benchmark; returns its rows (images dropped) and writes CSV and plot."""
    import OpenImageIO as oiio

    from runtime.api import compile_file

    compiled = compile_file(path, library_paths=library, width=width, height=height)
    scene = compiled.scene
    sweeps = knobs(scene)
    log(f"knobs: {', '.join(sweeps)}")
    if reference_image is not None:
        ref_pixels = oiio.ImageBuf(str(reference_image)).get_pixels(oiio.FLOAT)
        assert ref_pixels is not None  # None only when the file cannot be read
        ref = ref_pixels[..., :3]
        if ref.shape[:2] != (height, width):
            raise ValueError(
                f"the reference is {ref.shape[1]}x{ref.shape[0]}, the bench renders "
                f"{width}x{height}"
            )
    else:
        best = finest(sweeps)
        ref, seconds = _render(scene, best, width, height)
        log(f"reference (every knob at its finest): {seconds:.2f} s")
    rows: list[Row] = []
    for settings in sweeps.values():
        for s in settings:
            img, seconds = _render(scene, s, width, height)
            rows.append(Row("strala", s.knob, s.label, seconds, image=img))
            log(f"  strala {s.knob} {s.label}: {seconds:.3f} s")
    if vs_povray:
        pov = povray_rows(path, width, height, library, scene.settings.radiosity is not None)
        for r in pov:
            log(f"  povray {r.knob} {r.label}: {r.seconds:.3f} s")
        rows.extend(pov)
    score(rows, ref)
    mark_pareto(rows)
    for r in rows:
        r.image = None
    prefix = out_prefix or path.with_name(path.stem + "-bench")
    write_csv(rows, prefix.with_suffix(".csv"))
    plot(rows, prefix.with_suffix(".png"), f"{path.name} {width}x{height}: error vs time")
    return rows
