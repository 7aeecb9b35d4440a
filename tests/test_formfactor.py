"""Form factors against closed forms (NOTES.md §6 and the standard catalogue).

Error budget, stated per test: the point-to-polygon kernel is exact (float64 rounding);
polygon-to-polygon values carry the outer Gauss quadrature error (given per order below);
curved surfaces (disk, sphere, hemisphere) carry the faceting error of their inscribed
polygons, O(h²) in the patch size h.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from lang import ir
from runtime.prepare import prepare
from runtime.radiosity.formfactor import (
    clip_to_hemisphere,
    form_factors,
    point_form_factors,
    point_polygon,
    polygon_normal_area,
    polygon_quadrature,
    projected_solid_angle,
    tracer_visibility,
)
from runtime.radiosity.patches import Mesher, box_faces

PARALLEL = 0.1998249  # unit squares, 1 apart, aligned
PERPENDICULAR = 0.2000438  # unit squares sharing an edge at 90°
AXIS_POINT = 0.239456  # point 1 below the centre of a unit square, facing it

# z = 0 unit square facing +z, its parallel twin at z = 1 facing −z, and the square in the
# y = 0 plane facing +y that shares the edge y = z = 0 with the first.
BOTTOM = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]], dtype=float)
TOP = np.array([[0, 0, 1], [0, 1, 1], [1, 1, 1], [1, 0, 1]], dtype=float)
SIDE = np.array([[0, 0, 0], [0, 0, 1], [1, 0, 1], [1, 0, 0]], dtype=float)


def regular_polygon(n: int, radius: float, height: float, up: bool) -> np.ndarray:
    a = 2 * np.pi * np.arange(n) / n
    pts = np.stack([radius * np.cos(a), radius * np.sin(a), np.full(n, height)], axis=1)
    return pts if up else pts[::-1]


def test_normals_follow_the_right_hand_rule():
    n, a = polygon_normal_area(np.stack([BOTTOM, TOP, SIDE]))
    assert np.allclose(n, [[0, 0, 1], [0, 0, -1], [0, 1, 0]])
    assert np.allclose(a, 1.0)


def test_point_to_square_on_its_axis():
    square = BOTTOM - [0.5, 0.5, -1.0]  # centred over the origin at height 1
    f = point_polygon([[0, 0, 0]], [[0, 0, 1]], square)
    assert f[0] == pytest.approx(AXIS_POINT, abs=1e-6)
    # Winding does not matter for the geometric kernel.
    assert point_polygon([[0, 0, 0]], [[0, 0, 1]], square[::-1])[0] == pytest.approx(f[0])


def test_point_sees_nothing_behind_it():
    square = BOTTOM - [0.5, 0.5, 1.0]  # below the tangent plane
    assert point_polygon([[0, 0, 0]], [[0, 0, 1]], square)[0] == 0.0


def test_clipped_kernel_matches_monte_carlo():
    """A polygon crossing the tangent plane: only the part above counts (fixed-seed MC,
    400k cosine-distributed directions: standard error 7e-4, tolerance 4σ)."""
    poly = np.array([[-1, -0.5, 1.0], [1, -0.5, 1.0], [1, 0.5, -0.5], [-1, 0.5, -0.5]])
    f = point_polygon([[0, 0, 0]], [[0, 0, 1]], poly)[0]
    rng = np.random.default_rng(7)
    u1, u2 = rng.random(400_000), rng.random(400_000)
    r, ph = np.sqrt(u1), 2 * np.pi * u2
    d = np.stack([r * np.cos(ph), r * np.sin(ph), np.sqrt(1 - u1)], axis=1)
    nrm, _ = polygon_normal_area(poly[None])
    t = (nrm[0] @ poly[0]) / (d @ nrm[0])
    x = d * t[:, None] - poly[0]
    e1, e2 = poly[1] - poly[0], poly[3] - poly[0]
    a, b = x @ e1 / (e1 @ e1), x @ e2 / (e2 @ e2)
    hit = (t > 0) & (a >= 0) & (a <= 1) & (b >= 0) & (b <= 1)
    assert f == pytest.approx(hit.mean(), abs=4 * 7e-4)


coord = st.floats(-2.0, 2.0, allow_nan=False)


@given(
    st.tuples(coord, coord, st.floats(-1.0, 2.0)),
    st.floats(0.2, 2.0),
    st.floats(0.2, 2.0),
    st.floats(-1.0, 1.0),
)
def test_kernel_is_additive_over_pieces(corner, sx, sy, tilt):
    """Splitting a polygon (straddling the tangent plane or not) into four pieces must not
    change the total: this exercises the hemisphere clipping on every piece."""
    c = np.array(corner)
    eu = np.array([sx, 0, 0.0])
    ev = np.array([0, sy, tilt])
    whole = np.array([c, c + eu, c + eu + ev, c + ev])
    pieces = [
        np.array([c + a * eu + b * ev, c + (a + 0.5) * eu + b * ev,
                  c + (a + 0.5) * eu + (b + 0.5) * ev, c + a * eu + (b + 0.5) * ev])
        for a in (0, 0.5) for b in (0, 0.5)
    ]  # fmt: skip
    p = np.array([[0.1, -0.2, 0.0]])
    n = np.array([[0.0, 0.0, 1.0]])
    total = sum(point_polygon(p, n, piece)[0] for piece in pieces)
    assert point_polygon(p, n, whole)[0] == pytest.approx(total, abs=1e-9)
    assert 0.0 <= total <= 1.0 + 1e-12


@given(st.floats(0, 2 * np.pi), st.tuples(coord, coord, coord))
def test_kernel_is_invariant_under_rigid_motion(angle, shift):
    c, s = math.cos(angle), math.sin(angle)
    rot = np.array([[c, 0, s], [0, 1, 0], [-s, 0, c]]) @ np.array(
        [[1, 0, 0], [0, c, -s], [0, s, c]]
    )
    poly = BOTTOM - [0.3, 0.6, -0.7]
    p, n = np.array([[0.0, 0.0, 0.0]]), np.array([[0.0, 0.0, 1.0]])
    f0 = point_polygon(p, n, poly)[0]
    f1 = point_polygon(p @ rot.T + shift, n @ rot.T, poly @ rot.T + shift)[0]
    assert f1 == pytest.approx(f0, abs=1e-12)


def test_quadrature_weights_sum_to_area():
    hexagon = regular_polygon(6, 1.0, 0.0, True)
    for verts in (np.stack([BOTTOM, SIDE * 2]), hexagon[None]):
        _, area = polygon_normal_area(verts)
        for order in (1, 3, 5):
            _, w = polygon_quadrature(verts, order)
            assert np.allclose(w.sum(axis=1), area)


@pytest.mark.parametrize(("order", "tol"), [(3, 3e-5), (6, 1e-7)])
def test_parallel_unit_squares(order, tol):
    f = form_factors(BOTTOM[None], TOP[None], order=order)[0, 0]
    assert f == pytest.approx(PARALLEL, abs=tol)


@pytest.mark.parametrize(("order", "tol"), [(3, 1e-5), (8, 1e-7)])
def test_perpendicular_unit_squares_sharing_an_edge(order, tol):
    # The kernel has an x·log x term at the shared edge: Gauss converges more slowly here.
    f = form_factors(BOTTOM[None], SIDE[None], order=order)[0, 0]
    assert f == pytest.approx(PERPENDICULAR, abs=tol)


def test_one_sided_patches_exchange_nothing_back_to_back():
    flipped = TOP[::-1]  # normal +z: faces away from BOTTOM
    assert form_factors(BOTTOM[None], flipped[None])[0, 0] == 0.0
    assert form_factors(flipped[None], BOTTOM[None])[0, 0] == 0.0


def test_coaxial_unit_disks():
    """Unit disks 1 apart: (3 − √5)/2. Disks as inscribed 512-gons; the faceting changes
    the value by O((2π/512)²) ≈ 1.5e-4, the tolerance is 3e-4."""
    lower = regular_polygon(512, 1.0, 0.0, True)
    upper = regular_polygon(512, 1.0, 1.0, False)
    f = form_factors(lower[None], upper[None], order=4)[0, 0]
    assert f == pytest.approx((3 - math.sqrt(5)) / 2, abs=3e-4)


def test_unit_cube_faces_from_one_face():
    """Inward faces of a unit cube: from the floor, the ceiling gets PARALLEL, each wall
    PERPENDICULAR, itself 0, and the six sum to 1 (to rounding: every quadrature point sees
    the closed cube, so the sum of the exact kernels is 1 point by point)."""
    faces = np.array([[p0, p0 + ev, p0 + ev + eu, p0 + eu] for p0, eu, ev in
                      box_faces(np.zeros(3), np.ones(3))])  # fmt: skip
    normals, _ = polygon_normal_area(faces)
    centres = faces.mean(axis=1)
    assert np.all(np.einsum("nc,nc->n", normals, 0.5 - centres) > 0)  # inward
    F = form_factors(faces, order=8)
    assert np.allclose(F.sum(axis=1), 1.0, atol=1e-12)
    assert np.allclose(np.diag(F), 0.0)
    floor = 2  # y = 0
    opposite = 3
    walls = [0, 1, 4, 5]
    assert F[floor, opposite] == pytest.approx(PARALLEL, abs=1e-6)
    assert np.allclose(F[floor, walls], PERPENDICULAR, atol=1e-6)


def _inside_sphere(size: float):
    m = Mesher(size)
    m.sphere(np.eye(4), rho=0.5, outside=False, inside=True)
    return m.patches()


def test_inside_a_sphere_form_factor_is_area_fraction():
    """Inside a sphere F_ij = A_j / A for every pair. Flat facets inscribed in the sphere
    make this hold only approximately: measured, the median relative error is 2.3% at patch
    size h = 0.5 and 0.54% at h = 0.25 (O(h²)); the worst row's L1 error Σ_j |F_ij − A_j/A|
    is 0.073 and 0.043 (O(h), from neighbours meeting at grazing angles). Tolerances 1.3×
    those, and the errors must shrink with h. Row sums are 1 to rounding; reciprocity to
    the quadrature error of neighbours at grazing angles (measured 3.7e-3 of the largest
    A_i F_ij at h = 0.5; tolerance 6e-3)."""
    medians, l1s = [], []
    for size, med_tol, l1_tol in ((0.5, 0.03, 0.095), (0.25, 0.007, 0.056)):
        p = _inside_sphere(size)
        F = form_factors(p.verts, order=3)
        expected = np.broadcast_to(p.area[None, :] / p.area.sum(), F.shape)
        off = ~np.eye(len(p), dtype=bool)
        medians.append(float(np.median(np.abs(F[off] - expected[off]) / expected[off])))
        l1s.append(float(np.abs(F - expected).sum(axis=1).max()))
        assert medians[-1] < med_tol
        assert l1s[-1] < l1_tol
        assert np.allclose(F.sum(axis=1), 1.0, atol=1e-12)
        g = p.area[:, None] * F
        assert np.abs(g - g.T).max() < 6e-3 * g.max()
    assert medians[1] < medians[0] / 3
    assert l1s[1] < l1s[0] * 0.7


def test_worked_example_disk_under_hemisphere():
    """NOTES.md §6: unit disk A1 under a unit hemisphere A2: F12 = 1, F21 = 1/2,
    F22 = 1/2, A1 F12 = A2 F21. The hemisphere is meshed into inward patches and the disk
    is the polygon through its rim vertices, so the pair is a closed polyhedron:
    F12 = 1 and F21 + F22 = 1 to rounding; F21 = A1/A2 of the facets, which differs from
    1/2 by the faceting error (measured 7e-4 at patch size 0.25; tolerance 2e-3);
    reciprocity to the quadrature error (tolerance 1e-3 relative)."""
    m = Mesher(0.25)
    m.sphere(np.eye(4), rho=0.5, outside=False, inside=True, theta=(0.0, 0.5))
    hemi = m.patches()
    n_phi = int(np.ceil(2 * np.pi / 0.25))
    a = 2 * np.pi * np.arange(n_phi) / n_phi
    disk = np.stack([np.cos(a), np.zeros(n_phi), np.sin(a)], axis=1)
    nrm, area = polygon_normal_area(disk[None])
    if nrm[0, 1] < 0:
        disk = disk[::-1]
    a1, a2 = float(area[0]), float(hemi.area.sum())
    f12 = form_factors(disk[None], hemi.verts, order=3).sum()
    to_disk = form_factors(hemi.verts, disk[None], order=3)[:, 0]
    f21 = float((hemi.area * to_disk).sum() / a2)
    f22 = float((hemi.area[:, None] * form_factors(hemi.verts, order=3)).sum() / a2)
    assert f12 == pytest.approx(1.0, abs=1e-12)
    assert f21 + f22 == pytest.approx(1.0, abs=1e-12)
    assert f21 == pytest.approx(0.5, abs=2e-3)
    assert f22 == pytest.approx(0.5, abs=2e-3)
    assert a1 * f12 == pytest.approx(a2 * f21, rel=1e-3)


def test_visibility_callable_scales_form_factors():
    """A blocker over half of the target (y < 0.5) halves the parallel-square factor (by
    symmetry). 64 Latin-hypercube segments stratify the target's y to 1/64, so the estimate
    is within 1/64 of the exact half; tolerance 0.02 (relative)."""

    def none_visible(o, t):
        return np.zeros(len(o))

    assert form_factors(BOTTOM[None], TOP[None], visible=none_visible)[0, 0] == 0.0

    def half(o, t):
        return (t[:, 1] >= 0.5).astype(float)

    f = form_factors(BOTTOM[None], TOP[None], visible=half, vis_samples=64)[0, 0]
    assert f == pytest.approx(PARALLEL / 2, abs=0.02 * PARALLEL)


def test_tracer_visibility_with_a_real_occluder():
    """Embree/analytic tracing as the visibility oracle: a sphere between two parallel
    squares hides all of one from the other; with no sphere, everything is visible."""
    sphere = ir.Object(ir.Sphere((0.5, 0.5, 0.5), 5.0))
    scene = ir.Scene(camera=ir.Camera(), objects=(sphere,))
    vis = tracer_visibility(prepare(scene, 8, 8).tracer)
    lo, hi = BOTTOM - [0, 0, 10], TOP + [0, 0, 10]
    assert form_factors(lo[None], hi[None], visible=vis)[0, 0] == 0.0
    clear = tracer_visibility(prepare(ir.Scene(camera=ir.Camera()), 8, 8).tracer)
    assert form_factors(BOTTOM[None], TOP[None], visible=clear)[0, 0] == pytest.approx(
        PARALLEL, abs=1e-4
    )


def test_clip_keeps_unclipped_polygons_and_empties_hidden_ones():
    rel = np.stack([BOTTOM + [0, 0, 1], BOTTOM - [0, 0, 1]])
    n = np.array([[0, 0, 1.0], [0, 0, 1.0]])
    out = clip_to_hemisphere(rel, n)
    assert projected_solid_angle(out, n)[1] == 0.0
    assert projected_solid_angle(out, n)[0] == pytest.approx(
        projected_solid_angle(rel[:1], n[:1])[0]
    )


def test_point_form_factors_match_the_kernel_and_visibility():
    square = BOTTOM - [0.5, 0.5, -1.0]
    faces_down = square[::-1]  # one-sided: must face the point below it
    k = point_form_factors([[0, 0, 0]], [[0, 0, 1]], faces_down[None])
    assert k[0, 0] == pytest.approx(AXIS_POINT, abs=1e-6)
    assert point_form_factors([[0, 0, 0]], [[0, 0, 1]], square[None])[0, 0] == 0.0
    targets = np.full((1, 4, 3), [0.0, 0.0, 1.0])

    def none_visible(o, t):
        return np.zeros(len(o))

    hidden = point_form_factors(
        [[0, 0, 0]], [[0, 0, 1]], faces_down[None], visible=none_visible, targets=targets
    )
    assert hidden[0, 0] == 0.0


def test_symmetric_mode_is_reciprocal_and_close_to_the_full_matrix():
    """Integrating each pair once and filling the other direction by reciprocity: exact
    A_i F_ij = A_j F_ji; on the inside of a sphere (91 patches, order 3) the row sums then
    hold to the quadrature error (measured 3.5e-5; tolerance 1e-4) instead of rounding,
    and entries differ from the full matrix by at most 3.6e-4 (tolerance 1e-3)."""
    p = _inside_sphere(0.5)
    full = form_factors(p.verts, order=3)
    sym = form_factors(p.verts, order=3, symmetric=True)
    g = p.area[:, None] * sym
    assert np.allclose(g, g.T, rtol=1e-12, atol=1e-15)
    assert np.abs(sym.sum(axis=1) - 1).max() < 1e-4
    assert np.abs(sym - full).max() < 1e-3


@pytest.mark.parametrize("gap", [8.0, 20.0])
def test_point_to_point_kernel_for_distant_pairs(gap):
    """Coaxial unit squares `gap` apart: the exact value is within the point-to-point
    kernel's O((size/distance)²) of 1/(π gap²); with point_ratio the far pair takes that
    kernel (to 1.5% at gap 8, 0.3% at 20) and reciprocity still holds exactly."""
    top = TOP + np.array([0.0, 0.0, gap - 1.0])
    verts = np.stack([BOTTOM, top])
    exact = form_factors(verts, order=6)[0, 1]
    approx = form_factors(verts, order=3, point_ratio=4.0)
    assert approx[0, 1] == pytest.approx(1 / (math.pi * gap**2), rel=1e-12)
    assert approx[0, 1] == pytest.approx(exact, rel=1.0 / gap**2)
    assert approx[0, 1] == pytest.approx(approx[1, 0], rel=1e-12)  # equal areas
    back = form_factors(np.stack([BOTTOM, BOTTOM + [0, 0, gap]]), point_ratio=4.0)
    assert np.all(back == 0.0)  # one-sided: the second square faces away


def test_point_tier_keeps_the_matrix_close():
    """Inside a unit sphere (338 patches), the point tier beyond 5 radii (38% of the
    pairs) changes entries by at most 2.4% of the largest (tolerance 3%) and row sums by
    1.7e-3 (tolerance 2e-3); the default ratio, 8, halves both."""
    p = _inside_sphere(0.25)
    base = form_factors(p.verts, far_order=1, far_ratio=2.0)
    tiered = form_factors(p.verts, far_order=1, far_ratio=2.0, point_ratio=5.0)
    assert np.abs(tiered - base).max() < 0.03 * base.max()
    assert np.abs(tiered.sum(axis=1) - base.sum(axis=1)).max() < 2e-3
    assert (tiered != base).mean() > 0.3  # the tier was used


def test_visibility_is_the_same_on_any_number_of_threads(monkeypatch):
    """Visibility batches run on threads; the segment pairing is drawn up front, so the
    matrix is identical whatever the thread count (small batches: many of them)."""
    from runtime.radiosity import formfactor
    from runtime.radiosity.visibility import PatchVisibility

    monkeypatch.setattr(formfactor, "_VIS_BATCH_RAYS", 4096)

    m = Mesher(0.5)
    m.box([0, 0, 0], [3, 3, 3], rho=0.5, inside=True, outside=False)
    m.box([1, 0, 1], [2, 1.5, 2], rho=0.5)
    p = m.patches()
    vis = PatchVisibility(p.verts)
    one = form_factors(p.verts, far_order=1, visible=vis, workers=1, seed=3)
    two = form_factors(p.verts, far_order=1, visible=vis, workers=2, seed=3)
    assert np.array_equal(one, two)
    assert 0 < (one < form_factors(p.verts, far_order=1)).mean() < 1  # some occlusion
