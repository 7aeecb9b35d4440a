"""Primary rays: the seed's pixel-to-world formula (NOTES.md §1) and POV-Ray's camera model."""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from lang import ir
from runtime.camera import primary_rays


def _rotation(a: float, b: float, c: float) -> np.ndarray:
    ca, sa, cb, sb, cc, sc = np.cos(a), np.sin(a), np.cos(b), np.sin(b), np.cos(c), np.sin(c)
    rx = np.array([[1, 0, 0], [0, ca, -sa], [0, sa, ca]])
    ry = np.array([[cb, 0, sb], [0, 1, 0], [-sb, 0, cb]])
    rz = np.array([[cc, -sc, 0], [sc, cc, 0], [0, 0, 1]])
    return rz @ ry @ rx


angles = st.floats(-np.pi, np.pi, allow_nan=False)


@settings(max_examples=60, deadline=None)
@given(
    a=angles,
    b=angles,
    c=angles,
    half=st.floats(0.05, 20),
    dist=st.floats(0.05, 50),
    eye=st.tuples(*[st.floats(-1e3, 1e3)] * 3),
    h=st.integers(1, 64),
)
def test_seed_pixel_to_world(a, b, c, half, dist, eye, h):
    """For A = |right|/2 = |up|/2, N = |direction| and an HxH image, the ray through pixel
    corner (col, row) passes through the seed's P_w = P0 - N z_v + x_v x_v^ + y_v y_v^ with
    x_v = A(-1 + 2 col/H), y_v = A(-1 + 2 row/H) (row counted upward, as the seed's y).
    The seed's view space is right-handed and looks down -z_v; POV-Ray's camera looks along
    +direction, so the seed's z_v^ is minus our forward axis (the z sign convention)."""
    rot = _rotation(a, b, c)
    x_hat, y_hat, fwd = rot[:, 0], rot[:, 1], rot[:, 2]
    z_v = -fwd
    cam = ir.Camera(
        location=tuple(eye),
        direction=tuple(dist * fwd),
        right=tuple(2 * half * x_hat),
        up=tuple(2 * half * y_hat),
    )
    cols, rows = np.meshgrid(np.arange(h + 1), np.arange(h + 1))
    cols = cols.ravel().astype(float)
    rows = rows.ravel().astype(float)
    # Our pixel rows run downward from the top edge.
    origins, dirs = primary_rays(cam, h, h, cols, h - rows)
    x_v = half * (-1 + 2 * cols / h)
    y_v = half * (-1 + 2 * rows / h)
    p0 = np.array(eye)
    p_w = p0 - dist * z_v + x_v[:, None] * x_hat + y_v[:, None] * y_hat
    expect = (p_w - p0) / np.linalg.norm(p_w - p0, axis=1, keepdims=True)
    assert np.allclose(origins, p0, rtol=0, atol=0)
    # The reference loses digits in P_w - P0 when the eye is far from the origin.
    assert np.allclose(dirs, expect, rtol=0, atol=1e-13 * (1 + np.linalg.norm(p0) / dist))
    # And the ray really reaches P_w: P0 + |P_w - P0| * dir.
    reach = p0 + np.linalg.norm(p_w - p0, axis=1, keepdims=True) * dirs
    assert np.allclose(reach, p_w, rtol=1e-12, atol=1e-9)


def test_pixel_centres_and_orientation():
    cam = ir.Camera(location=(0, 0, 0), direction=(0, 0, 1), right=(1, 0, 0), up=(0, 1, 0))
    # 3x3 image: the centre pixel looks straight ahead, the top-left one up and left.
    o, d = primary_rays(cam, 3, 3, np.array([1.5, 0.5]), np.array([1.5, 0.5]))
    assert np.allclose(d[0], [0, 0, 1])
    assert d[1, 0] < 0 and d[1, 1] > 0
    assert np.allclose(np.linalg.norm(d, axis=1), 1)


def test_default_right_squeezes_square_image():
    """POV-Ray's default right <1.33,0,0>: on a square image the right edge of the frame is at
    x/z = 0.665, not 0.5 (that is why Ex3 looks squeezed)."""
    cam = ir.Camera()
    o, d = primary_rays(cam, 100, 100, np.array([100.0]), np.array([50.0]))
    assert abs(d[0, 0] / d[0, 2] - 0.665) < 1e-12
    assert abs(d[0, 1]) < 1e-12


def test_orthographic_rays_are_parallel():
    cam = ir.Camera(
        kind="orthographic", location=(1, 2, 3), direction=(0, 0, 2), right=(4, 0, 0), up=(0, 4, 0)
    )
    o, d = primary_rays(cam, 4, 4, np.array([0.0, 4.0]), np.array([0.0, 4.0]))
    assert np.allclose(d, [[0, 0, 1], [0, 0, 1]])
    assert np.allclose(o, [[-1, 4, 3], [3, 0, 3]])


@settings(max_examples=40, deadline=None)
@given(a=angles, b=angles, c=angles, ortho=st.booleans(), seed=st.integers(0, 1000))
def test_view_planes_hold_exactly_what_the_camera_traces(a, b, c, ortho, seed):
    from runtime.camera import view_planes

    rot = _rotation(a, b, c)
    cam = ir.Camera(
        kind="orthographic" if ortho else "perspective",
        location=(3.0, -2.0, 1.0),
        direction=tuple(1.5 * rot[:, 2]),
        right=tuple(1.33 * rot[:, 0]),
        up=tuple(rot[:, 1]),
    )
    rng = np.random.default_rng(seed)
    # the image and the 2 pixels beyond each edge that anti-aliasing traces
    xs = rng.uniform(-1.99, 65.99, 200)
    ys = rng.uniform(-1.99, 49.99, 200)
    o, d = primary_rays(cam, 64, 48, xs, ys)
    inside = o + rng.uniform(0.01, 100, (200, 1)) * d
    # Just outside that: 2% of the width past it.
    o2, d2 = primary_rays(cam, 64, 48, np.full(200, 66 + 64 * 0.02), ys)
    outside = o2 + rng.uniform(0.01, 100, (200, 1)) * d2
    behind = o - rng.uniform(0.01, 100, (200, 1)) * d
    planes = view_planes(cam, 64, 48)
    worst_in = max(float(((inside - p0) @ n).max()) for n, p0 in planes)
    assert worst_in <= 1e-9
    worst_out = np.max([(outside - p0) @ n for n, p0 in planes], axis=0)
    assert (worst_out > 0).all()
    assert (np.max([(behind - p0) @ n for n, p0 in planes], axis=0) > 0).all()
