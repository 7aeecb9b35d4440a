"""The plot `strala bench` writes: error (RMSE) against wall time, both log scale.

Every point is labelled with its setting; strala's are blue with its Pareto front joined,
POV-Ray's red, the reference green. A point with no error at all (the reference, and any
setting that gives the reference's very image) cannot stand on a log scale: it is drawn on
a row of its own under the lowest decade, marked "0". Labels are placed where they cover no
other label or marker when there is such a place. The legend, above the plot, names only what
is drawn. Laid out first (`layout`, what tests read), then drawn with OpenImageIO."""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Protocol

import numpy as np

W, H, LEFT, RIGHT, TOP, BOTTOM = 760, 500, 80, 20, 64, 60
LABEL_SIZE = 11
LEGEND_ROW = 50  # the legend's baseline, between the title and the plot
ZERO_ROW = 14  # the no-error row, this far above the x axis
LOG_FLOOR = 34  # the lowest decade, this far above the x axis
Colour = tuple[float, float, float]
BLACK: Colour = (0.0, 0.0, 0.0)
GREY: Colour = (0.8, 0.8, 0.8)
BLUE: Colour = (0.1, 0.3, 0.9)
RED: Colour = (0.85, 0.15, 0.1)
GREEN: Colour = (0.1, 0.6, 0.2)
LEGEND = {"strala": ("strala (front joined)", BLUE), "povray": ("POV-Ray 3.7", RED)}


class Row(Protocol):
    """A measured setting (runtime.bench.Row)."""

    renderer: str
    label: str
    seconds: float
    rmse: float
    pareto: bool
    times: tuple[float, ...]

    @property
    def reference(self) -> bool: ...


@dataclass
class Point:
    row: Row
    x: int
    y: int
    colour: Colour
    size: int  # half the marker's side


Box = tuple[int, int, int, int]  # left, top, right, bottom


@dataclass
class Label:
    x: int  # where the text starts, on its baseline
    y: int
    text: str
    colour: Colour
    box: Box  # what it covers


@dataclass
class Layout:
    points: list[Point] = field(default_factory=list)
    labels: list[Label] = field(default_factory=list)
    # (text, colour, x): one row above the plot, each entry after a marker at x
    legend: list[tuple[str, Colour, int]] = field(default_factory=list)
    front: list[tuple[int, int, int, int]] = field(default_factory=list)
    # grid lines (x or y, pixel, tick text)
    ticks: list[tuple[str, int, str]] = field(default_factory=list)


def _colour(r: Row) -> Colour:
    if r.reference:
        return GREEN
    return BLUE if r.renderer == "strala" else RED


def layout(rows: Sequence[Row]) -> Layout:
    """Where each point, label, legend entry and grid line goes."""
    out = Layout()
    pts = [r for r in rows if math.isfinite(r.rmse) and r.rmse >= 0 and r.seconds > 0]
    if not pts:
        return out
    tx = np.log10([r.seconds for r in pts])
    errors = [r.rmse for r in pts if r.rmse > 0]
    ey = np.log10(errors) if errors else np.array([-3.0])
    x0, x1 = math.floor(tx.min()), math.ceil(tx.max() + 1e-9)
    y0, y1 = math.floor(ey.min()), math.ceil(ey.max() + 1e-9)
    x1, y1 = max(x1, x0 + 1), max(y1, y0 + 1)
    floor = H - BOTTOM - LOG_FLOOR

    def px(t: float) -> int:
        return int(round(LEFT + (math.log10(t) - x0) / (x1 - x0) * (W - LEFT - RIGHT)))

    def py(e: float) -> int:
        if e <= 0:
            return H - BOTTOM - ZERO_ROW
        return int(round(floor - (math.log10(e) - y0) / (y1 - y0) * (floor - TOP)))

    for k in range(x0, x1 + 1):
        out.ticks.append(
            ("x", int(LEFT + (k - x0) / (x1 - x0) * (W - LEFT - RIGHT)), f"{10.0**k:g}")
        )
    for k in range(y0, y1 + 1):
        out.ticks.append(("y", py(10.0**k), f"{10.0**k:g}"))
    out.ticks.append(("y", py(0.0), "0"))
    for r in pts:
        colour = _colour(r)
        point = Point(r, px(r.seconds), py(r.rmse), colour, 5 if r.reference else 3)
        out.points.append(point)
    taken = [_marker_box(p) for p in out.points]
    # the reference and the front first: their labels get the free places
    for p in sorted(out.points, key=lambda p: (not p.row.reference, not p.row.pareto)):
        text = "reference: " + p.row.label if p.row.reference else p.row.label
        label = _place(p, text, [b for b in taken if b != _marker_box(p)])
        out.labels.append(label)
        taken.append(label.box)
    front = sorted((p for p in out.points if p.row.pareto), key=lambda p: p.row.seconds)
    out.front = [(a.x, a.y, b.x, b.y) for a, b in zip(front, front[1:], strict=False)]
    drawn = {p.row.renderer for p in out.points if not p.row.reference}
    entries = [LEGEND[name] for name in LEGEND if name in drawn]
    if any(p.row.reference for p in out.points):
        entries.append(("reference (error 0)", GREEN))
    x = LEFT
    for text, colour in entries:
        out.legend.append((text, colour, x))
        x += 24 + _text_width(text, 14)
    return out


def _text_width(text: str, size: int) -> int:
    import OpenImageIO as oiio

    return int(oiio.ImageBufAlgo.text_size(text, size, "").width)


def _marker_box(p: Point) -> Box:
    return (p.x - p.size, p.y - p.size, p.x + p.size, p.y + p.size)


def overlaps(a: Box, b: Box) -> bool:
    return a[0] <= b[2] and b[0] <= a[2] and a[1] <= b[3] and b[1] <= a[3]


def _place(p: Point, text: str, taken: list[Box]) -> Label:
    """The first place beside the point (right, left, above, below, then right a row or
    more up or down) inside the plot that covers nothing taken; else the right, covering."""
    w, up, down = _text_width(text, LABEL_SIZE), 8, 1  # the text's extent about its baseline
    gap = p.size + 3
    places = [(p.x + gap, p.y + 4), (p.x - gap - w, p.y + 4),
              (p.x - w // 2, p.y - gap - down), (p.x - w // 2, p.y + gap + up)]  # fmt: skip
    for k in (1, -1, 2, -2, 3, -3):
        places.append((p.x + gap, p.y + 4 + k * (up + down + 2)))
    boxes = [(x, y, (x, y - up, x + w, y + down)) for x, y in places]
    inside = [
        b for b in boxes if b[2][0] > LEFT and b[2][2] < W and TOP <= b[2][1] < b[2][3] < H - BOTTOM
    ]
    for x, y, box in inside:
        if not any(overlaps(box, t) for t in taken):
            return Label(x, y, text, p.colour, box)
    x, y, box = (inside or boxes)[0]
    return Label(x, y, text, p.colour, box)


def plot(rows: Sequence[Row], path: Path, title: str) -> None:
    """Draw the layout and write it (temporary file and rename)."""
    import OpenImageIO as oiio

    draw = oiio.ImageBufAlgo
    runs = max((len(r.times) for r in rows), default=1)
    buf = oiio.ImageBuf(oiio.ImageSpec(W, H, 3, oiio.FLOAT))
    draw.fill(buf, (1.0, 1.0, 1.0))
    plan = layout(rows)
    for axis, at, text in plan.ticks:
        if axis == "x":
            draw.render_line(buf, at, TOP, at, H - BOTTOM, GREY)
            draw.render_text(buf, at - 14, H - BOTTOM + 20, text, 14, "", BLACK)
        else:
            draw.render_line(buf, LEFT, at, W - RIGHT, at, GREY)
            draw.render_text(buf, 8, at + 5, text, 14, "", BLACK)
    for x0, y0, x1, y1 in plan.front:
        draw.render_line(buf, x0, y0, x1, y1, BLUE)
    for label in plan.labels:
        draw.render_text(buf, label.x, label.y, label.text, LABEL_SIZE, "", label.colour)
    for p in plan.points:  # over the labels: a label never hides a point
        draw.render_box(buf, p.x - p.size, p.y - p.size, p.x + p.size, p.y + p.size, p.colour,
                        fill=True)  # fmt: skip
    draw.render_line(buf, LEFT, TOP, LEFT, H - BOTTOM, BLACK)
    draw.render_line(buf, LEFT, H - BOTTOM, W - RIGHT, H - BOTTOM, BLACK)
    draw.render_text(buf, LEFT, 24, title, 16, "", BLACK)
    x_title = f"wall time of the whole process (s), median of {runs} run{'s' if runs != 1 else ''}"
    draw.render_text(buf, W // 2 - 190, H - 12, x_title, 14, "", BLACK)
    draw.render_text(buf, 8, TOP - 8, "RMSE", 14, "", BLACK)
    for text, colour, x in plan.legend:
        draw.render_box(buf, x, LEGEND_ROW - 9, x + 8, LEGEND_ROW - 1, colour, fill=True)
        draw.render_text(buf, x + 14, LEGEND_ROW, text, 14, "", colour)
    tmp = path.with_name(f".{path.name}.tmp{path.suffix}")
    if not buf.write(str(tmp)):
        raise OSError(f"cannot write {path}: {buf.geterror()}")
    tmp.replace(path)
