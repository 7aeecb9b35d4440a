"""Pure-Python 4x4 matrices in POV-Ray's conventions (no numpy: `lang` must start fast).

Matrices follow ir.Matrix: row-major, acting on column vectors (p' = M @ (p, 1)). POV-Ray's
own source uses row vectors, so its `matrix <…12 values…>` is the transpose of ours.
Rotations are POV-Ray's: degrees, about x, then y, then z, in a left-handed world (which
with column vectors is the usual right-hand-rule matrix: rotate <0,90,0> takes x to -z).
"""

from __future__ import annotations

import math
from collections.abc import Sequence

from lang.ir import FAR_LIMIT, IDENTITY, Matrix

# Below this a matrix counts as singular (POV-Ray warns about a zero scale component and
# substitutes a tiny value; we report it instead of dividing by zero).
SINGULAR_EPSILON = 1e-12


def _m(rows: Sequence[Sequence[float]]) -> Matrix:
    return tuple(tuple(float(v) for v in r) for r in rows)  # type: ignore[return-value]


def compose(a: Matrix, b: Matrix) -> Matrix:
    """a @ b: apply b first, then a. Both affine (last row 0 0 0 1), unrolled for speed:
    scenes with big CSG trees compose thousands of these."""
    if a is IDENTITY and b is IDENTITY:
        # exactly the product, and shared: a scene's untransformed objects then hold one
        # matrix, not one each (a stored scene loads them once)
        return IDENTITY
    a0, a1, a2 = a[0], a[1], a[2]
    b0, b1, b2 = b[0], b[1], b[2]
    rows = []
    for r in (a0, a1, a2):
        x, y, z, w = r
        rows.append(
            (
                x * b0[0] + y * b1[0] + z * b2[0],
                x * b0[1] + y * b1[1] + z * b2[1],
                x * b0[2] + y * b1[2] + z * b2[2],
                x * b0[3] + y * b1[3] + z * b2[3] + w,
            )
        )
    return (rows[0], rows[1], rows[2], (0.0, 0.0, 0.0, 1.0))


def then(first: Matrix, second: Matrix) -> Matrix:
    """The matrix that applies `first`, then `second` (POV-Ray's order of modifiers)."""
    return compose(second, first)


def translate(v: Sequence[float]) -> Matrix:
    return _m([[1, 0, 0, v[0]], [0, 1, 0, v[1]], [0, 0, 1, v[2]], [0, 0, 0, 1]])


def scale(v: Sequence[float]) -> Matrix:
    return _m([[v[0], 0, 0, 0], [0, v[1], 0, 0], [0, 0, v[2], 0], [0, 0, 0, 1]])


def _rot_x(deg: float) -> Matrix:
    c, s = math.cos(math.radians(deg)), math.sin(math.radians(deg))
    return _m([[1, 0, 0, 0], [0, c, -s, 0], [0, s, c, 0], [0, 0, 0, 1]])


def _rot_y(deg: float) -> Matrix:
    c, s = math.cos(math.radians(deg)), math.sin(math.radians(deg))
    return _m([[c, 0, s, 0], [0, 1, 0, 0], [-s, 0, c, 0], [0, 0, 0, 1]])


def _rot_z(deg: float) -> Matrix:
    c, s = math.cos(math.radians(deg)), math.sin(math.radians(deg))
    return _m([[c, -s, 0, 0], [s, c, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]])


def rotate(v: Sequence[float]) -> Matrix:
    """POV-Ray's `rotate <a, b, c>`: about x by a, then y by b, then z by c (degrees)."""
    m = IDENTITY
    if v[0]:
        m = then(m, _rot_x(v[0]))
    if v[1]:
        m = then(m, _rot_y(v[1]))
    if v[2]:
        m = then(m, _rot_z(v[2]))
    return m


def axis_rotate(axis: Sequence[float], deg: float) -> Matrix:
    """Rotation about an axis through the origin, as POV-Ray's `vaxis_rotate` (and
    transforms.inc's Axis_Rotate_Trans): positive angles turn like `rotate` about x/y/z."""
    length = math.sqrt(sum(a * a for a in axis[:3]))
    if length == 0.0:
        raise ZeroDivisionError("rotation axis of zero length")
    x, y, z = (a / length for a in axis[:3])
    c, s = math.cos(math.radians(deg)), math.sin(math.radians(deg))
    t = 1.0 - c
    return _m(
        [
            [t * x * x + c, t * x * y - s * z, t * x * z + s * y, 0],
            [t * x * y + s * z, t * y * y + c, t * y * z - s * x, 0],
            [t * x * z - s * y, t * y * z + s * x, t * z * z + c, 0],
            [0, 0, 0, 1],
        ]
    )


def from_pov_matrix(values: Sequence[float]) -> Matrix:
    """POV-Ray's `matrix <m00, m01, m02, m10, … m32>` (row-vector form, last row = translation)."""
    if len(values) != 12:
        raise ValueError(f"`matrix` needs 12 values, got {len(values)}")
    r = [values[0:3], values[3:6], values[6:9], values[9:12]]
    return _m(
        [
            [r[0][0], r[1][0], r[2][0], r[3][0]],
            [r[0][1], r[1][1], r[2][1], r[3][1]],
            [r[0][2], r[1][2], r[2][2], r[3][2]],
            [0, 0, 0, 1],
        ]
    )


def determinant3(m: Matrix) -> float:
    return (
        m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1])
        - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0])
        + m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0])
    )


def out_of_reach(m: Matrix) -> str | None:
    """Why an object with this transform cannot be traced in float64 (it is not finite,
    flattens the object, takes it beyond FAR_LIMIT or shrinks it below its inverse), None
    when it can: distances to it are squared, and squared again, on the way to a pixel."""
    if not all(math.isfinite(v) for row in m[:3] for v in row):
        return "its transform is not finite (a value in it overflowed)"
    det = abs(determinant3(m))
    if det == 0:
        return "its transform is singular (a zero scale?)"
    reach = max(abs(v) for row in m[:3] for v in row)
    if reach > FAR_LIMIT:
        return f"its transform takes it {reach:.3g} units out, beyond {FAR_LIMIT:.0e}"
    if det < FAR_LIMIT**-3:
        return f"its transform shrinks it by {det ** (1 / 3):.3g}, below {1 / FAR_LIMIT:.0e}"
    return None


def inverse(m: Matrix) -> Matrix:
    """Inverse of an affine matrix (last row 0 0 0 1), by the 3x3 adjugate."""
    det = determinant3(m)
    if abs(det) < SINGULAR_EPSILON:
        raise ZeroDivisionError("singular transformation matrix")
    a = m
    inv3 = [
        [
            (a[1][1] * a[2][2] - a[1][2] * a[2][1]) / det,
            (a[0][2] * a[2][1] - a[0][1] * a[2][2]) / det,
            (a[0][1] * a[1][2] - a[0][2] * a[1][1]) / det,
        ],
        [
            (a[1][2] * a[2][0] - a[1][0] * a[2][2]) / det,
            (a[0][0] * a[2][2] - a[0][2] * a[2][0]) / det,
            (a[0][2] * a[1][0] - a[0][0] * a[1][2]) / det,
        ],
        [
            (a[1][0] * a[2][1] - a[1][1] * a[2][0]) / det,
            (a[0][1] * a[2][0] - a[0][0] * a[2][1]) / det,
            (a[0][0] * a[1][1] - a[0][1] * a[1][0]) / det,
        ],
    ]
    t = [a[0][3], a[1][3], a[2][3]]
    rows = [inv3[i] + [-sum(inv3[i][k] * t[k] for k in range(3))] for i in range(3)]
    return _m(rows + [[0, 0, 0, 1]])


def apply_point(m: Matrix, p: Sequence[float]) -> tuple[float, float, float]:
    return tuple(m[i][0] * p[0] + m[i][1] * p[1] + m[i][2] * p[2] + m[i][3] for i in range(3))  # type: ignore[return-value]


def apply_direction(m: Matrix, d: Sequence[float]) -> tuple[float, float, float]:
    return tuple(m[i][0] * d[0] + m[i][1] * d[1] + m[i][2] * d[2] for i in range(3))  # type: ignore[return-value]


def apply_normal(m: Matrix, n: Sequence[float]) -> tuple[float, float, float]:
    """Normals transform by the inverse transpose."""
    inv = inverse(m)
    return tuple(inv[0][i] * n[0] + inv[1][i] * n[1] + inv[2][i] * n[2] for i in range(3))  # type: ignore[return-value]


def cross(a: Sequence[float], b: Sequence[float]) -> tuple[float, float, float]:
    """The cross product a × b."""
    return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])


def is_identity(m: Matrix, tol: float = 0.0) -> bool:
    if tol == 0.0:
        return m == IDENTITY  # tuple equality: the common, fast case
    return all(abs(m[i][j] - IDENTITY[i][j]) <= tol for i in range(4) for j in range(4))
