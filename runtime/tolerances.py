"""Every numerical tolerance of the geometry runtime, each with the reason for its size.

Offsets are scale-aware: a ray that leaves a surface ignores hits closer than a distance
relative to where it starts and to the size of the object it might hit, never a fixed
epsilon that is too large for a small scene and too small for one a million units away.
"""

from __future__ import annotations

# float64 carries ~1e-16 relative precision; a hit point computed as o + t*d, through a
# transform and back, is off by a few hundred ulps of |o| at worst, so 1e-9 * |origin| clears
# it with a wide margin while staying invisible at any scene scale.
ORIGIN_REL: float = 1e-9

# Near-tangent quadratic roots are only accurate to ~sqrt(eps) ~ 1.5e-8 of the object's size,
# so a ray leaving such a point must skip the twin root: 1e-7 of the object's size.
OBJECT_REL: float = 1e-7

# Absolute floor for rays starting at the world origin on a tiny object: below any geometry
# strala can represent meaningfully, above float64 noise at unit scale.
ABS_FLOOR: float = 1e-12

# Embree intersects in float32 (~6e-8 relative): a ray leaving a mesh at a grazing angle can
# meet its own triangle again anywhere within ~1e-6 of (|origin| + mesh size). Such a hit
# (refined in float64, it falls at the ray's start) is cast again from past it, by a step
# growing tenfold per round up to this fraction of (|hit distance| + mesh size).
EMBREE_REL: float = 1e-5

# The first cast of a triangle ray starts only this fraction of (|origin| + mesh size) out:
# float32 rounding of the origin (~6e-8), no more, so an object resting closer than
# EMBREE_REL of the scene's mesh size above a mesh still shadows it. Self-hits that get
# through are refined, rejected and cast again (EMBREE_ROUNDS).
EMBREE_START_REL: float = 1e-7

# A triangle object inside CSG reports every crossing along a ray by casting again past
# each one: the next cast starts this fraction of (|origin| + mesh size) beyond the last hit
# (15x Embree's float32 rounding, so the same triangle is not met again); two crossings
# closer than that count as one.
EMBREE_NEXT_REL: float = 1e-6

# At most this many crossings of one triangle object along one ray are reported (a ray
# skimming a height field crosses it a few times per cell): beyond that the ray is taken to
# meet no more.
MAX_MESH_CROSSINGS: int = 256

# Newton refinement steps for a float32 (Embree) or eigenvalue (torus) root: each step
# doubles the correct digits, two take a 1e-7 guess to float64 precision.
NEWTON_STEPS: int = 2

# A quartic root is accepted as real when its imaginary part is below this fraction of its
# magnitude (+1): eigenvalue solvers smear a double (tangent) root into a conjugate pair of
# size ~sqrt(eps).
QUARTIC_IMAG_REL: float = 1e-6

# A direction component below this is treated as parallel to an axis / a plane (avoids
# inf*0 = nan in slab tests and plane intersections); far below any real direction component.
PARALLEL_EPS: float = 1e-300

# Bounding boxes are widened by this much (relative to the entry/exit distances, plus an
# absolute floor) so a ray that touches an object exactly on its box is never culled; a
# looser box only costs an extra exact intersection.
BOX_PAD_REL: float = 1e-9
BOX_PAD_ABS: float = 1e-12

# An object counts as walled off by a plane (runtime.occlusion) only when it lies beyond the
# plane by more than this fraction of the coordinates involved, and the camera and lights
# count as on the near side only as far inside: rounding of the plane's offset and of a
# hit's distance to it (~1e-16 relative) can never decide it. Objects resting on the plane
# are kept.
OCCLUDED_MARGIN_REL: float = 1e-9

# Automatic tessellation tolerance never goes below this fraction of the surface's extent
# (a camera placed on the surface would otherwise ask for infinitely many triangles).
TESSELLATION_REL: float = 1e-6

# Newton polishing of quartic (torus) roots only accepts corrections below this fraction of
# the shape's size: near a double root the derivative vanishes and a full step could jump to
# the wrong root; the eigenvalue guess is already that close.
NEWTON_MAX_STEP_REL: float = 0.1

# Casts per ray when a float64-refined Embree hit falls at or before the ray start (a
# self-hit at a grazing angle): the retries step 1e-6 and then 1e-5 of the reach past it;
# rays leaving a mesh 1e-2 radians above it need both (one cast only: 1 in 5 is lost).
EMBREE_ROUNDS: int = 3

# Automatic chord-error bound for NURBS / subdivision tessellation: this many pixels at the
# surface's nearest distance from the eye (half a pixel: facets stay below visibility).
AUTO_TESSELLATION_PIXELS: float = 0.5

# Inside tests (CSG, clipped_by) on planes and cylinders allow this much, as POV-Ray's
# EPSILON does, so a point computed on the surface is classified like POV-Ray classifies it.
INSIDE_EPS: float = 1e-10

# Swept shapes (lathe, sor, prism, text) ------------------------------------------------
# POV-Ray closes a prism's sub-shape when a point repeats its first point to within its
# EPSILON (1e-10); the same bound decides which spline segments join end to start.
SPLINE_CLOSE_EPS: float = 1e-10

# A crossing at a joint of two spline segments must count once: segment parameters are
# accepted in [-e, 1 - e) when the segment continues into another, [-e, 1 + e] at a free
# end. Root errors after polishing are far below this; it is far below any visible size.
SPLINE_PARAM_EPS: float = 1e-9

# A polynomial's leading coefficients below this fraction of its largest are dropped before
# root finding: their roots lie beyond ~1/LEAD_REL, far outside the unit range the callers
# scale their variable to, and the Newton polish on the full polynomial restores the
# accuracy of the roots that matter. Keeping them would cost more: a closed-form cubic with
# roots 1e8 apart loses the small ones entirely.
LEAD_REL: float = 1e-6

# Normals of swept shapes are turned outward by an inside test this fraction of the
# shape's size off the surface: far above root noise, far below any feature of a curve.
SWEEP_SIDE_REL: float = 1e-7

# A lathe ray whose unit direction has a y component below this is treated as horizontal
# (height fixed, then the circle along the ray): eliminating k = (Y - P_y) / D_y would turn
# its two hits into a nearly double root the eigenvalue solver cannot separate. The joint
# Newton polish removes the small error of either path.
LATHE_FLAT_DIR: float = 1e-6

# POV-Ray leaves out a sor cap whose squared radius is below its depth tolerance (1e-4).
SOR_CAP_MIN_R2: float = 1e-4

# Iterations of the bracketed Newton/bisection root solver (runtime.prims.roots): bisection
# alone halves the bracket each step, so 200 reach float64 precision from any bracket that
# fits in float64 (2^-1074 .. 2^1024); Newton usually stops it after a handful.
ROOT_MAX_ITER: int = 200

# POV-Ray's poly/cubic/quartic count a point as inside while the polynomial is below this
# (its INSIDE_TOLERANCE; quadrics use <= 0): the surface itself is inside, as in POV-Ray.
POLY_INSIDE: float = 1e-4

# Polynomial surfaces are unbounded: roots are sought within this many object sizes of the
# ray's closest approach to the object's origin. Farther crossings are beyond any scene.
POLY_REACH: float = 1e6

# A polynomial coefficient along a ray below this fraction of the largest one does not set
# the degree for the root bound (it would only add roots ~1e14 sizes away, beyond the reach).
POLY_LEAD_REL: float = 1e-14

# A superellipsoid is searched inside its box widened by this fraction, so a ray along a
# face (where the surface touches the box) is not clipped away by rounding.
SUPERELLIPSOID_BOX_PAD: float = 1e-9

# Pinched superellipsoids (e or n > 2) are not convex: their chord is cut into this many
# equal cells (besides the planes of symmetry) before extrema and sign changes are sought.
# Where both e, n >= 2 f is concave between the axis planes and one cell is exact; mixed
# shapes need ~8 (measured on random rays); 32 is the margin.
SUPERELLIPSOID_CELLS: int = 32

# The slope of a pinched superellipsoid's f is sampled this fraction of the chord inside
# each cell's ends: a cell end on an axis plane is a cusp, where the two sides slope
# differently; far below any feature, far above rounding of the chord.
SUPERELLIPSOID_INSET: float = 1e-9

# Bisection steps for the minimum of f along a chord: the minimum only decides whether the
# ray dips inside and splits the chord, and f there is off by ~f''·dt²/2; 32 halvings of a
# chord of at most 2 sqrt(3) leave dt < 1e-9, so f is off by ~1e-18·f'' (a grazing ray).
SUPERELLIPSOID_MIN_ITER: int = 32

# POV-Ray's superellipsoid inside test accepts f < EPSILON (1e-10): the surface is inside.
SUPERELLIPSOID_INSIDE: float = 1e-10

# POV-Ray's blob counts a point as inside when its density exceeds threshold - 1e-6 (its
# INSIDE_TOLERANCE): the surface itself is inside.
BLOB_INSIDE: float = 1e-6

# POV-Ray's MIN_ISECT_DEPTH: a crossing closer than this to the ray's origin is no hit. The
# julia_fractal, which reports the crossings POV-Ray's marching finds, drops them the same way.
MIN_ISECT_DEPTH: float = 1e-4

# POV-Ray's hypercomplex julia_fractal takes its distance estimate only where the orbit's
# normal slopes against the ray by more than this (hcmplx.cpp's Fractal_Tolerance).
JULIA_SLOPE_TOLERANCE: float = 1e-8

# A julia_fractal hit point handed back for its normal matches the point its crossing was
# found at within this fraction of its size (transform round trips are off by ~1e-15).
NORMAL_CACHE_REL: float = 1e-9
