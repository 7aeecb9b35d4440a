"""Primary rays: POV-Ray's camera model on final camera vectors (see `ir.Camera`)."""

from __future__ import annotations

import numpy as np

from lang import ir


def screen_coords(width: int, height: int, xs: np.ndarray, ys: np.ndarray):
    """Continuous pixel coordinates (row 0 at the top) to normalised screen coordinates in
    [-0.5, 0.5], sx to the right and sy up."""
    sx = np.asarray(xs, dtype=np.float64) / width - 0.5
    sy = 0.5 - np.asarray(ys, dtype=np.float64) / height
    return sx, sy


def primary_rays(
    camera: ir.Camera, width: int, height: int, xs: np.ndarray, ys: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Origins (N,3) and unit directions (N,3) for pixel coordinates xs, ys (N,).

    Pixel (col, row) has its centre at (col + 0.5, row + 0.5)."""
    sx, sy = screen_coords(width, height, xs, ys)
    sx = sx.reshape(-1, 1)
    sy = sy.reshape(-1, 1)
    loc = np.asarray(camera.location, dtype=np.float64)
    dirv = np.asarray(camera.direction, dtype=np.float64)
    right = np.asarray(camera.right, dtype=np.float64)
    up = np.asarray(camera.up, dtype=np.float64)
    if camera.kind == "orthographic":
        origins = loc + sx * right + sy * up
        d = dirv / np.linalg.norm(dirv)
        directions = np.broadcast_to(d, origins.shape).copy()
    else:
        if camera.kind != "perspective":
            _warn_kind(camera.kind)
        directions = dirv + sx * right + sy * up
        directions /= np.linalg.norm(directions, axis=1, keepdims=True)
        origins = np.broadcast_to(loc, directions.shape).copy()
    return origins, directions


_warned: set[str] = set()


def _warn_kind(kind: str) -> None:
    # The evaluator already reports unsupported camera kinds; this only says what we did.
    if kind not in _warned:
        _warned.add(kind)
        print(f"strala: camera type {kind!r} not supported, rendering as perspective")


def view_planes(camera: ir.Camera) -> list[tuple[np.ndarray, np.ndarray]]:
    """Half-spaces (n, p0) with n . (x - p0) <= 0 holding every point the camera can see:
    the four sides of the view pyramid (or box, orthographic) and the plane through the
    eye facing forward. Used to skip work for what lies outside (see prepare)."""
    loc = np.asarray(camera.location, dtype=np.float64)
    fwd = np.asarray(camera.direction, dtype=np.float64)
    right = np.asarray(camera.right, dtype=np.float64)
    up = np.asarray(camera.up, dtype=np.float64)
    planes = [(-fwd / np.linalg.norm(fwd), loc)]
    for side, across in ((right, up), (-right, up), (up, right), (-up, right)):
        if camera.kind == "orthographic":
            n = side - (side @ _unit(fwd)) * _unit(fwd)
            planes.append((_unit(n), loc + side / 2))
        else:
            # The side face holds the eye and the two frame corners fwd + side/2 +- across/2.
            n = np.cross(fwd + side / 2 - across / 2, fwd + side / 2 + across / 2)
            if n @ fwd > 0:
                n = -n
            planes.append((_unit(n), loc))
    return planes


def _unit(v: np.ndarray) -> np.ndarray:
    return v / np.linalg.norm(v)
