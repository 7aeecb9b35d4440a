"""The swept primitives (lathe, sor, prism, text): every crossing along a line lies on the
surface, crossings come sorted and flip the inside state, normals are perpendicular and
point out; simple profiles equal the shapes they describe (cylinder, box, sphere); POV-Ray's
spline point rules; prism holes and glyph holes; the TrueType reader."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from conftest import run_cli
from hypothesis import example, given, settings
from hypothesis import strategies as st

from lang import ir
from runtime.prims import spline2d as sp
from runtime.prims.lathe import LathePrim, SorPrim
from runtime.prims.prism import PrismPrim
from runtime.prims.text import TextPrim
from runtime.prims.truetype import FontError, contour_segments, load_font
from runtime.shapes import BoxPrim, ConePrim

FONTS = Path("/usr/share/povray-3.7/include")
TIMROM = FONTS / "timrom.ttf"
needs_fonts = pytest.mark.skipif(not TIMROM.is_file(), reason="POV-Ray's fonts are not installed")

SQUARE = ((0, 0), (1, 0), (1, 1), (0, 1), (0, 0))
FRAME = (
    (-2, -2), (2, -2), (2, 2), (-2, 2), (-2, -2),
    (-1, -1), (1, -1), (1, 1), (-1, 1), (-1, -1),
)  # fmt: skip
ROUND = ((0, 2), (2, 0), (0, -2), (-2, 0), (0, 2), (2, 0), (0, -2))  # closed cubic

SHAPES = {
    "prism square": ir.Prism("linear_spline", "linear_sweep", 0, 1, SQUARE),
    "prism frame": ir.Prism("linear_spline", "linear_sweep", -1, 1, FRAME),
    "prism cubic": ir.Prism("cubic_spline", "linear_sweep", -1, 1, ROUND),
    "prism quadratic conic": ir.Prism(
        "quadratic_spline",
        "conic_sweep",
        0.5,
        1,
        ((0, 2), (2, 0), (0, -2), (-2, 0), (0, 2), (2, 0)),
    ),
    "prism bezier": ir.Prism(
        "bezier_spline",
        "linear_sweep",
        -1,
        1,
        ((0, 0), (1, 0), (1, 1), (0, 1), (0, 1), (-1, 1), (-1, 0), (0, 0)),
    ),  # fmt: skip
    "lathe linear": ir.Lathe("linear_spline", ((0, 0), (1, 0), (1, 1), (0.5, 1.5), (0, 1.5))),
    "lathe quadratic": ir.Lathe("quadratic_spline", ((0, -1), (0, -1), (1, 0), (0.5, 1), (0, 1.2))),
    "lathe cubic": ir.Lathe("cubic_spline", ((0, -1), (0, -1), (1, 0), (0, 1), (0, 1))),
    "lathe bezier": ir.Lathe("bezier_spline", ((0, -1), (1.3, -1), (1.3, 1), (0, 1))),
    "sor": ir.Sor(((0, -1.2), (1, -1), (1.5, 0), (1, 1), (0.2, 1.2))),
}
# Open shapes are no solids (their inside is the closed shape's): no flip property.
SOR_OPEN = ir.Sor(((0, -1.2), (1, -1), (1.5, 0), (1, 1), (0.2, 1.2)), open=True)


def prim_of(shape):
    if isinstance(shape, ir.Lathe):
        return LathePrim(shape)
    if isinstance(shape, ir.Sor):
        return SorPrim(shape)
    if isinstance(shape, ir.Text):
        return TextPrim(shape)
    return PrismPrim(shape)


def random_rays(seed: int, n: int, spread: float = 3.0, aim=None):
    """Origins in a cube; directions random, or (aim = a primitive) towards points of its
    bounding box. Directions are not unit, so t is scaled too."""
    rng = np.random.default_rng(seed)
    o = rng.uniform(-spread, spread, (n, 3))
    if aim is None:
        d = rng.normal(size=(n, 3))
    else:
        lo, hi = aim.bounds()
        d = rng.uniform(lo, hi, (n, 3)) - o
    return o, d * rng.uniform(0.2, 5.0, (n, 1))


def check_crossings(prim, o, d) -> int:
    """Sorted crossings, inside state flipping at each, outward unit-able normals."""
    t, face = prim.crossings(o, d)
    assert t.shape == face.shape and t.shape[0] == len(o)
    fin = np.isfinite(t)
    key = np.where(fin, t, 1e300)
    assert np.all(np.diff(key, axis=1)[fin[:, 1:]] >= 0), "crossings not sorted"
    assert np.all(fin[:, :-1] | ~fin[:, 1:]), "crossings after a missing one"
    # Between consecutive crossings (and beyond the ends) the inside state alternates.
    rows, cols = np.nonzero(fin)
    if len(rows) == 0:
        return 0
    lo = np.where(fin, t, np.inf).min(axis=1)
    hi = np.where(fin, t, -np.inf).max(axis=1)
    prev = np.where(cols > 0, t[rows, np.maximum(cols - 1, 0)], lo[rows] - 1.0)
    nxt_col = np.minimum(cols + 1, t.shape[1] - 1)
    nxt = np.where((cols + 1 < t.shape[1]) & fin[rows, nxt_col], t[rows, nxt_col], hi[rows] + 1.0)
    before = prim.inside(o[rows] + (0.5 * (prev + t[rows, cols]))[:, None] * d[rows])
    after = prim.inside(o[rows] + (0.5 * (nxt + t[rows, cols]))[:, None] * d[rows])
    assert np.all(before != after), f"{np.sum(before == after)} crossings do not flip inside"
    p = o[rows] + t[rows, cols, None] * d[rows]
    n = prim.normal(p, face[rows, cols])
    length = np.linalg.norm(n, axis=1)
    assert np.all(length > 0)
    n = n / length[:, None]
    eps = 1e-6 * prim.size
    assert np.all(~prim.inside(p + eps * n) & prim.inside(p - eps * n)), "normal not outward"
    return len(rows)


@pytest.mark.parametrize("name", sorted(SHAPES))
@settings(max_examples=10)  # x 10 shapes x 300 rays
@given(seed=st.integers(0, 2**31 - 1))
def test_crossings_flip_inside_and_normals_point_out(name, seed):
    prim = prim_of(SHAPES[name])
    o, d = random_rays(seed, 300, aim=prim)
    check_crossings(prim, o, d)


def test_random_rays_do_hit():
    # Guard against a vacuous property above: the rays hit every shape many times.
    for name, shape in SHAPES.items():
        prim = prim_of(shape)
        o, d = random_rays(7, 300, aim=prim)
        assert check_crossings(prim, o, d) > 300, name


@given(seed=st.integers(0, 2**31 - 1))
def test_hits_lie_on_the_lathe_profile(seed):
    prim = LathePrim(SHAPES["lathe cubic"])
    o, d = random_rays(seed, 200)
    t, face = prim.crossings(o, d)
    fin = np.isfinite(t)
    p = (o[:, None, :] + np.where(fin, t, 0)[..., None] * d[:, None, :])[fin]
    q = np.stack([np.hypot(p[:, 0], p[:, 2]), p[:, 1]], axis=1)
    seg, u = prim.curve.locate(face[fin].astype(np.int64), 127, q)
    assert np.max(np.abs(prim.curve.point(seg, u) - q), initial=0.0) < 1e-9


@given(seed=st.integers(0, 2**31 - 1))
def test_hits_lie_on_the_sor_surface(seed):
    prim = SorPrim(SOR_OPEN)
    o, d = random_rays(seed, 200)
    t, _ = prim.crossings(o, d)
    fin = np.isfinite(t)
    p = (o[:, None, :] + np.where(fin, t, 0)[..., None] * d[:, None, :])[fin]
    f = sp.polyval(prim.coef[prim.segment_of(p[:, 1])], p[:, 1])
    assert np.max(np.abs(p[:, 0] ** 2 + p[:, 2] ** 2 - f), initial=0.0) < 1e-9


def same_crossings(a, b, o, d) -> None:
    ta, _ = a.crossings(o, d)
    tb, _ = b.crossings(o, d)
    for ra, rb in zip(ta, tb, strict=True):
        fa, fb = np.sort(ra[np.isfinite(ra)]), np.sort(rb[np.isfinite(rb)])
        assert len(fa) == len(fb)
        assert np.allclose(fa, fb, rtol=1e-9, atol=1e-9)


def test_linear_lathe_of_a_rectangle_is_a_cylinder():
    lathe = LathePrim(ir.Lathe("linear_spline", ((0, 0), (1, 0), (1, 2), (0, 2))))
    cyl = ConePrim((0, 0, 0), (0, 2, 0), 1.0, 1.0, False)
    o, d = random_rays(3, 2000)
    same_crossings(lathe, cyl, o, d)
    p = np.array([[0.5, 1.0, 0.2], [1.5, 1.0, 0.0], [0.0, 2.5, 0.0]])
    assert list(lathe.inside(p)) == [True, False, False]


def test_prism_of_a_square_is_a_box():
    prism = PrismPrim(ir.Prism("linear_spline", "linear_sweep", 0, 1, SQUARE))
    box = BoxPrim((0, 0, 0), (1, 1, 1))
    o, d = random_rays(4, 2000)
    same_crossings(prism, box, o, d)
    lo, hi = prism.bounds()
    assert np.allclose(lo, 0) and np.allclose(hi, 1)


def test_sphere_like_profiles():
    # Bezier quarter circles (k = 0.5523) stay within 3e-4 of the unit sphere; a sor
    # through points of the circle within 5e-2 (POV-Ray's finite-difference slopes are
    # poor at the poles).
    k = 0.5523
    lathe = LathePrim(ir.Lathe("bezier_spline", ((0, -1), (k, -1), (1, -k), (1, 0),
                                                   (1, 0), (1, k), (k, 1), (0, 1))))  # fmt: skip
    ys = np.linspace(-1.2, 1.2, 13)
    sor = SorPrim(ir.Sor(tuple((float(np.sqrt(max(1 - y * y, 0.0))), float(y)) for y in ys)))
    o, d = random_rays(5, 2000, spread=2.0)
    for prim, err in ((lathe, 3e-4), (sor, 5e-2)):
        t, face = prim.crossings(o, d)
        fin = np.isfinite(t)
        p = (o[:, None, :] + np.where(fin, t, 0)[..., None] * d[:, None, :])[fin]
        assert len(p) > 500
        curved = face[fin] == 2 if prim is sor else np.ones(len(p), dtype=bool)
        assert np.max(np.abs(np.linalg.norm(p[curved], axis=1) - 1.0)) < err
        n = prim.normal(p[curved], face[fin][curved])
        n /= np.linalg.norm(n, axis=1)[:, None]
        assert (
            np.min(np.einsum("ij,ij->i", n, p[curved] / np.linalg.norm(p[curved], axis=1)[:, None]))
            > 0.95
        )


def test_prism_hole_lets_rays_through():
    prism = PrismPrim(ir.Prism("linear_spline", "linear_sweep", -1, 1, FRAME))
    o = np.array([[0.0, 5.0, 0.0], [1.5, 5.0, 0.0], [-5.0, 0.0, 0.0]])
    d = np.array([[0.0, -1.0, 0.0], [0.0, -1.0, 0.0], [1.0, 0.0, 0.0]])
    t, _ = prism.crossings(o, d)
    counts = np.isfinite(t).sum(axis=1)
    assert list(counts) == [0, 2, 4]  # hole; solid frame; across frame, hole, frame
    assert np.allclose(np.sort(t[2][np.isfinite(t[2])]), [3, 4, 6, 7])


def test_open_shapes_have_no_caps():
    closed = PrismPrim(ir.Prism("linear_spline", "linear_sweep", 0, 1, SQUARE))
    opened = PrismPrim(ir.Prism("linear_spline", "linear_sweep", 0, 1, SQUARE, open=True))
    o, d = np.array([[0.5, 3.0, 0.5]]), np.array([[0.0, -1.0, 0.0]])
    assert np.isfinite(closed.crossings(o, d)[0]).sum() == 2
    assert np.isfinite(opened.crossings(o, d)[0]).sum() == 0
    sor_o = SorPrim(SOR_OPEN)
    assert np.isfinite(sor_o.crossings(np.array([[0.0, 3.0, 0.0]]), d)[0]).sum() == 0


def test_conic_prism_scales_with_height():
    # A unit square swept conically from y = 1 to 2: at height y it spans 0..y.
    prism = PrismPrim(ir.Prism("linear_spline", "conic_sweep", 1, 2, SQUARE))
    o = np.array([[-1.0, 1.5, 0.5], [-1.0, 1.5, 1.4], [-1.0, 1.5, 1.6]])
    d = np.array([[1.0, 0.0, 0.0]] * 3)
    t, _ = prism.crossings(o, d)
    assert np.allclose(t[0][np.isfinite(t[0])], [1.0, 2.5])
    assert np.isfinite(t[1]).sum() == 2 and np.isfinite(t[2]).sum() == 0
    assert np.allclose(prism.bounds()[1], [2, 2, 2])


def test_spline_point_rules():
    pts = ((0, 0), (1, 1), (2, 0), (3, 1), (4, 0))
    ends = lambda c: (c[:, :, 3], c.sum(axis=2))  # noqa: E731 - values at t = 0 and 1
    s, e = ends(sp.lathe_segments("linear_spline", pts))
    assert len(s) == 4 and np.allclose(s[0], (0, 0)) and np.allclose(e[-1], (4, 0))
    # quadratic: the first point only steers; the curve runs P1 .. P4
    s, e = ends(sp.lathe_segments("quadratic_spline", pts))
    assert len(s) == 3 and np.allclose(s[0], (1, 1)) and np.allclose(e[-1], (4, 0))
    # cubic: first and last only steer; the curve runs P1 .. P3
    s, e = ends(sp.lathe_segments("cubic_spline", pts))
    assert len(s) == 2 and np.allclose(s[0], (1, 1)) and np.allclose(e[-1], (3, 1))
    s, e = ends(sp.lathe_segments("bezier_spline", pts[:4]))
    assert len(s) == 1 and np.allclose(s[0], (0, 0)) and np.allclose(e[0], (3, 1))


def test_prism_sub_shapes_close_on_their_first_point():
    # Two triangles in one linear point list: 3 segments each.
    tri = ((0, 0), (1, 0), (0, 1), (0, 0), (5, 5), (6, 5), (5, 6), (5, 5))
    assert len(sp.prism_segments("linear_spline", tri)) == 6
    # Quadratic: control, points..., first point again; then the next shape.
    q = ((-1, 0), (0, 0), (1, 0), (0, 1), (0, 0), (4, 0), (5, 0), (6, 0), (5, 1), (5, 0))
    segs = sp.prism_segments("quadratic_spline", q)
    assert len(segs) == 6
    assert np.allclose(segs[3, :, 3], (5, 0))  # the second shape starts at its point 2


@given(st.lists(st.floats(-10, 10), min_size=2, max_size=7))
@example([0.0, 7.0, 0.0, -2.0316436572192536e-15])  # a near-double pair at +-1.7e-8
def test_real_roots_match_numpy(coeffs):
    c = np.array(coeffs)
    if abs(c[0]) < 1e-3:
        c[0] = 1.0
    ours = sp.real_roots(c[None, :])[0]
    ours = np.sort(ours[np.isfinite(ours)])
    ref = np.roots(c)
    # numpy's simple real roots come back with no imaginary part at all; a conjugate pair
    # with a tiny one (x² + 1e-134) is not a real root, however close
    ref = np.sort(ref.real[ref.imag == 0])
    # Every clearly real root is found, and every root found is a root. A root is clearly
    # real when no change of the coefficients by a few thousand ulps can turn it (and a
    # neighbour) complex: near a pair's double root f ~ f'^2 / (2 f''), so the pair
    # survives a change of the constant term by delta only while f'^2 / (2|f''|) > delta.
    # x^3 + 7x^2 - 2e-15 has roots +-1.7e-8 that 3 ulps of 7 would take away: a tangent
    # touch, which a ray may miss (and must not count twice).
    deriv = np.polyder(c)
    deriv2 = np.polyder(deriv)
    for r in ref:
        noise = 4096 * np.finfo(float).eps * np.abs(c).max() * (1 + abs(r)) ** len(c)
        f1, f2 = abs(np.polyval(deriv, r)), abs(np.polyval(deriv2, r))
        if f1 * f1 <= 2 * f2 * noise or f1 <= 1e-9 * np.abs(c).max() * (1 + abs(r)) ** len(c):
            continue
        assert np.min(np.abs(ours - r), initial=np.inf) < 1e-6 * (1 + abs(r))
    scale = np.abs(c).max() * (1 + np.abs(ours)) ** (len(c) - 1)
    assert np.all(np.abs(np.polyval(c, ours)) <= 1e-6 * scale)


# ---------------------------------------------------------------------------- text
def text_prim(string: str, font: Path = TIMROM, thickness: float = 0.5, offset=(0, 0, 0)):
    return TextPrim(ir.Text(str(font), string, thickness, offset))


@needs_fonts
def test_glyph_topology():
    o_glyph, i_glyph = text_prim("O"), text_prim("I")
    for prim in (o_glyph, i_glyph):
        lo, hi = prim.bounds()
        assert lo[0] == pytest.approx(0.0, abs=1e-12)  # the first glyph starts at x = 0
        assert 0.6 < hi[1] < 0.75 and -0.02 < lo[1] < 0.02  # cap height, on the baseline
        assert lo[2] == 0 and hi[2] == 0.5
    d = np.array([[0.0, 0.0, 1.0]])
    for prim, expect in ((o_glyph, 0), (i_glyph, 2)):
        lo, hi = prim.bounds()
        centre = np.array([[0.5 * (lo[0] + hi[0]), 0.5 * (lo[1] + hi[1]), -1.0]])
        t, face = prim.crossings(centre, d)
        assert np.isfinite(t).sum() == expect
        if expect:
            assert np.allclose(np.sort(t[np.isfinite(t)]), [1.0, 1.5])
            assert set(face[np.isfinite(t)]) == {0, 1}
    # Through the O's ring: front cap, back cap.
    lo, hi = o_glyph.bounds()
    ring = np.array([[lo[0] + 0.02, 0.5 * (lo[1] + hi[1]), -1.0]])
    assert np.isfinite(o_glyph.crossings(ring, d)[0]).sum() == 2


@needs_fonts
@settings(max_examples=15)
@given(seed=st.integers(0, 2**31 - 1))
def test_text_crossings_flip_inside(seed):
    prim = text_prim("Ok8", thickness=0.3)
    rng = np.random.default_rng(seed)
    o = rng.uniform([-0.5, -0.5, -1], [2.0, 1.0, 1.5], (300, 3))
    d = rng.normal(size=(300, 3))
    check_crossings(prim, o, d)


@needs_fonts
def test_text_layout_advances_and_offset():
    font = load_font(str(TIMROM))
    one = text_prim("I")
    two = text_prim("II")
    spaced = text_prim("II", offset=(0.25, 0.1, 0))
    i = font.glyph_index("I")
    # The first I is moved left by its bearing, the second sits at the pen (advance less
    # bearing) plus its bearing: one full advance further.
    adv = font.advance[i] / font.units_per_em
    assert two.bounds()[1][0] == pytest.approx(one.bounds()[1][0] + adv, abs=1e-12)
    assert spaced.bounds()[1][0] == pytest.approx(two.bounds()[1][0] + 0.25, abs=1e-12)
    assert spaced.bounds()[1][1] == pytest.approx(two.bounds()[1][1] + 0.1, abs=1e-12)


@needs_fonts
def test_font_tables():
    font = load_font(str(TIMROM))
    assert font.units_per_em == 1000
    assert len(font.glyph(font.glyph_index("O")).contours) == 2
    assert len(font.glyph(font.glyph_index("8")).contours) == 3
    assert font.glyph(font.glyph_index(" ")).contours == []
    assert font.advance[font.glyph_index("W")] > font.advance[font.glyph_index("i")]
    assert font.kern, "timrom carries kerning pairs"
    assert load_font(str(TIMROM)) is font  # cached


DEJAVU = Path("/usr/share/fonts/truetype/dejavu/DejaVuSerif.ttf")


@pytest.mark.skipif(not DEJAVU.is_file(), reason="no font with composite glyphs installed")
def test_composite_glyphs_gather_their_parts():
    font = load_font(str(DEJAVU))
    a = font.glyph(font.glyph_index("A"))
    a_grave = font.glyph(font.glyph_index("À"))
    assert len(a_grave.contours) > len(a.contours)
    assert max(y for c in a_grave.contours for _, y, _ in c) > max(
        y for c in a.contours for _, y, _ in c
    )


def test_contours_become_lines_and_quadratics():
    # on, off, off, on: the implied midpoint splits two quadratics; closing line back.
    segs = contour_segments([(0, 0, True), (1, 1, False), (2, 1, False), (3, 0, True)])
    assert len(segs) == 3
    assert np.allclose(segs[1].sum(axis=1), (3, 0))  # second quadratic ends on point 4
    assert np.allclose(segs[0].sum(axis=1), (1.5, 1))  # the implied on-curve point
    assert np.all(segs[:, :, 0] == 0)  # no cubic terms


def test_not_a_font(tmp_path):
    bad = tmp_path / "bad.ttf"
    bad.write_bytes(b"\0\1\0\0" + b"\0" * 20)
    with pytest.raises(FontError):
        load_font(str(bad))


def test_broken_font_is_a_warning_at_the_text(tmp_path):
    (tmp_path / "bad.ttf").write_bytes(b"not a font, only some bytes of text")
    scene = tmp_path / "s.pov"
    scene.write_text(
        "camera { location <0, 0, -3> look_at 0 }\n"
        'text { ttf "bad.ttf" "Hi" 0.2, 0 pigment { rgb 1 } }\n'
    )
    res = run_cli("render", str(scene), "-o", str(tmp_path / "s.png"), "-W", "8", "-H", "6")
    assert res.returncode == 0, res.stderr
    assert "s.pov:2:1: warning: text skipped" in res.stderr
    assert "not a readable TrueType font" in res.stderr
    assert "Traceback" not in res.stderr
