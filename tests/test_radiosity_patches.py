"""Patch meshing, the quadtree lookup and Gouraud display of a radiosity solution."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from runtime.radiosity.formfactor import polygon_centroid, polygon_normal_area, stratified_points
from runtime.radiosity.gouraud import VertexField, refine_mask
from runtime.radiosity.patches import Mesher, ear_clip


def _wall(size=0.5, sides=(False,)):
    m = Mesher(size)
    m.parallelogram([0, 0, 0], [2, 0, 0], [0, 1, 0], rho=0.5, sides=sides)
    return m.patches()


def test_parallelogram_grid_covers_the_face():
    p = _wall()
    assert len(p) == 8
    assert p.area.sum() == pytest.approx(2.0)
    assert np.all(p.edge_length() <= 0.5 + 1e-12)
    assert np.allclose(p.normal, [0, 0, 1])
    both = _wall(sides=(False, True))
    assert len(both) == 16 and np.allclose(both.normal[8:], [0, 0, -1])


def test_sphere_patches_face_out_or_in_even_when_mirrored():
    for matrix in (np.eye(4), np.diag([-1.0, 1.0, 1.0, 1.0])):
        m = Mesher(0.4)
        m.sphere(matrix, rho=0.5)
        p = m.patches()
        assert np.all(np.einsum("nc,nc->n", p.normal, p.centroid) > 0)
        # Facets are inscribed: area a little below 4π, converging with the patch size.
        assert 0.9 * 4 * np.pi < p.area.sum() < 4 * np.pi
    m = Mesher(0.4)
    m.sphere(np.eye(4), rho=0.5, outside=False, inside=True)
    p = m.patches()
    assert np.all(np.einsum("nc,nc->n", p.normal, p.centroid) < 0)


def test_polygon_ear_clipping_keeps_area_and_winding():
    ell = np.array([[0, 0, 0], [2, 0, 0], [2, 1, 0], [1, 1, 0], [1, 2, 0], [0, 2, 0]], float)
    tris = ear_clip(ell)
    assert len(tris) == 4
    verts = ell[np.array(tris)]
    n, a = polygon_normal_area(verts)
    assert a.sum() == pytest.approx(3.0)
    assert np.allclose(n, [0, 0, 1])
    m = Mesher(10.0)
    m.polygon(ell, rho=0.5)
    assert m.patches().area.sum() == pytest.approx(3.0)


@given(st.lists(st.booleans(), min_size=1, max_size=40), st.integers(0, 2**31 - 1))
def test_subdivision_keeps_area_and_lookup_finds_the_patch(split, seed):
    """After arbitrary splits the patches still tile the elements (planar: area exact), and
    locating random element points returns the leaf whose corners interpolate back to the
    same element coordinates."""
    m = Mesher(0.5)
    m.parallelogram([0, 0, 0], [1, 0, 0], [0, 1, 0], rho=0.5)
    m.triangle([0, 0, 1], [1, 0, 1], [0, 1, 1], rho=0.5)
    m.sphere(np.eye(4), rho=0.5)
    p = m.patches()
    planar_area = p.area[p.element < 5].sum()
    for _ in range(2):
        mask = np.resize(np.array(split), len(p))
        p.subdivide(mask)
    assert p.area[p.element < 5].sum() == pytest.approx(planar_area, rel=1e-12)
    rng = np.random.default_rng(seed)
    k = 200
    element = rng.integers(0, len(p.elements), k)
    uv = rng.random((k, 2))
    tri = p.element_arrays["kind"][element] == 1
    uv[tri] = np.where((uv[tri].sum(axis=1) > 1)[:, None], 1 - uv[tri], uv[tri])
    leaf, local = p.locate(element, uv)
    assert np.all(p.element[leaf] == element)
    c = p.uv[leaf]
    u, v = local[:, :1], local[:, 1:]
    back = np.where(
        p.is_tri[leaf][:, None],
        c[:, 0] + u * (c[:, 1] - c[:, 0]) + v * (c[:, 2] - c[:, 0]),
        (1 - u) * (1 - v) * c[:, 0]
        + u * (1 - v) * c[:, 1]
        + u * v * c[:, 2]
        + (1 - u) * v * c[:, 3],
    )
    assert np.allclose(back, uv, atol=1e-12)
    # And world points round-trip through element coordinates.
    pts = p.surface_points(element, uv)
    assert np.allclose(p.surface_points(element, p.element_uv(element, pts)), pts, atol=1e-9)


def test_gouraud_reproduces_constants_and_is_continuous():
    p = _wall(0.25)
    p.subdivide(np.arange(len(p)) % 3 == 0)
    field = VertexField(p, np.full((len(p), 3), 0.7))
    pts = np.column_stack([np.random.default_rng(1).random((500, 2)) * [2, 1], np.zeros(500)])
    el = np.searchsorted(np.arange(8), 0)  # any element: find the right one below
    del el
    elements = _element_of(p, pts)
    assert np.allclose(field.lookup(elements, pts), 0.7)
    # A linear field: the two sides of a shared vertex see the same value.
    vals = p.centroid[:, :1] * np.array([[1.0, 2.0, 3.0]])
    f = VertexField(p, vals)
    assert np.allclose(f.corner_values[:, :, 0], f.vertex_values[f.vertex][:, :, 0])
    flat = VertexField(p, vals, flat=True)
    leaf, local = p.locate(elements, p.element_uv(elements, pts))
    assert np.allclose(flat.at(leaf, local), vals[leaf])


def _element_of(p, pts):
    """Element of points on the z = 0 wall (grid of 0.25 cells over [0,2]×[0,1])."""
    i = np.minimum((pts[:, 0] / 0.25).astype(int), 7)
    j = np.minimum((pts[:, 1] / 0.25).astype(int), 3)
    return j * 8 + i


def test_interior_vertices_of_a_linear_field_are_exact():
    p = _wall(0.25)
    vals = np.repeat(p.centroid[:, :1] + 2 * p.centroid[:, 1:2], 3, axis=1)
    f = VertexField(p, vals)
    pos = p.surface_points(p.element[:, None], p.uv)
    interior = np.all(
        (pos[..., 0] > 0) & (pos[..., 0] < 2) & (pos[..., 1] > 0) & (pos[..., 1] < 1), axis=1
    )
    exact = pos[..., 0] + 2 * pos[..., 1]
    assert np.allclose(f.corner_values[interior][..., 0], exact[interior])


def test_groups_do_not_blend_across_a_crease():
    m = Mesher(0.5)
    m.parallelogram([0, 0, 0], [1, 0, 0], [0, 0, 1], rho=0.5)  # floor-ish
    m.parallelogram([0, 0, 0], [0, 1, 0], [1, 0, 0], rho=0.5)  # wall sharing the x edge
    p = m.patches()
    vals = np.where((p.group == 0)[:, None], 1.0, 0.0) * np.ones((1, 3))
    f = VertexField(p, vals)
    assert np.allclose(f.corner_values[p.group == 0], 1.0)
    assert np.allclose(f.corner_values[p.group == 1], 0.0)


def test_refine_mask_finds_the_step():
    p = _wall(0.25)
    vals = np.repeat((p.centroid[:, :1] > 1.0).astype(float), 3, axis=1)
    mask = refine_mask(VertexField(p, vals), threshold=0.1, min_size=0.1)
    near = np.abs(p.centroid[:, 0] - 1.0) < 0.25
    assert np.array_equal(mask, near)
    assert not refine_mask(VertexField(p, vals), threshold=0.1, min_size=1.0).any()


def test_refine_mask_within_a_budget_takes_the_worst_first():
    """Two steps, a big one at x = 1 and a small one at x = 0.5: with room for only some
    splits, the patches along the big step go first, and never more than the budget."""
    p = _wall(0.25)
    x = p.centroid[:, 0]
    vals = np.repeat((1.0 * (x > 1.0) + 0.2 * (x > 0.5))[:, None], 3, axis=1)
    field = VertexField(p, vals)
    everything = refine_mask(field, threshold=0.05, min_size=0.1)
    big = everything & (np.abs(x - 1.0) < 0.25)
    assert everything.sum() > big.sum() > 0
    mask = refine_mask(field, threshold=0.05, min_size=0.1, budget=int(big.sum()))
    assert np.array_equal(mask, big)
    assert refine_mask(field, threshold=0.05, min_size=0.1, budget=3).sum() == 3
    assert not refine_mask(field, threshold=0.05, min_size=0.1, budget=0).any()


def test_stratified_points_lie_on_their_polygons():
    rng = np.random.default_rng(0)
    quad = np.array([[[0, 0, 0], [2, 0, 0], [2, 1, 0], [0, 1, 0]]], float)
    tri = np.array([[[0, 0, 1], [1, 0, 1], [0, 1, 1], [0, 1, 1]]], float)
    hexagon = np.stack(
        [np.cos(np.arange(6) * np.pi / 3), np.sin(np.arange(6) * np.pi / 3), np.zeros(6)], 1
    )
    q = stratified_points(quad, 64, rng)[0]
    assert np.all((q[:, 0] >= 0) & (q[:, 0] <= 2) & (q[:, 1] >= 0) & (q[:, 1] <= 1))
    # Latin hypercube: exactly one point per 1/64 stratum of x.
    assert np.array_equal(np.sort((q[:, 0] / 2 * 64).astype(int)), np.arange(64))
    t = stratified_points(tri, 50, rng)[0]
    assert np.all(t[:, 0] + t[:, 1] <= 1 + 1e-12) and np.all(t[:, :2] >= 0)
    h = stratified_points(hexagon[None], 100, rng)[0]
    assert np.all(np.linalg.norm(h[:, :2], axis=1) <= 1 + 1e-12)
    assert abs(h[:, 0].mean()) < 0.1 and abs(h[:, 1].mean()) < 0.1


def test_t_vertices_are_conformed_so_the_field_has_no_seam():
    """Two unit cells side by side, the left one split twice: along the shared edge the
    split side's Gouraud values must equal the unsplit neighbour's linear edge values."""
    m = Mesher(1.0)
    m.parallelogram([0, 0, 0], [2, 0, 0], [0, 1, 0], rho=0.5)
    p = m.patches()
    p.subdivide(p.centroid[:, 0] < 1)
    p.subdivide(np.abs(p.centroid[:, 0] - 0.75) < 0.2)  # the column touching x = 1
    rng = np.random.default_rng(3)
    vals = rng.random((len(p), 3))
    f = VertexField(p, vals)
    assert len(f.t_vertices[0]) > 0
    y = np.linspace(0.01, 0.99, 57)
    left = np.column_stack([np.full_like(y, 1 - 1e-12), y, np.zeros_like(y)])
    right = np.column_stack([np.full_like(y, 1 + 1e-12), y, np.zeros_like(y)])
    el_l, el_r = np.zeros(len(y), int), np.ones(len(y), int)
    assert np.allclose(f.lookup(el_l, left), f.lookup(el_r, right), atol=1e-9)
    seam = VertexField(p, vals, conform=False)
    assert not np.allclose(seam.lookup(el_l, left), seam.lookup(el_r, right), atol=1e-3)


def test_centroids_ignore_padding_vertices():
    tri = np.array([[[0, 0, 0], [3, 0, 0], [0, 3, 0], [0, 3, 0]]], float)
    assert np.allclose(polygon_centroid(tri), [[1, 1, 0]])
    m = Mesher(10.0)
    m.triangle([0, 0, 0], [3, 0, 0], [0, 3, 0], rho=0.5)
    assert np.allclose(m.patches().centroid, [[1, 1, 0]])
