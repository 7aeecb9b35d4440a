/* The compiled Whitted kernel: camera rays traced to colours, one ray at a time, for scenes
 * whose every feature it knows (runtime/whitted.py decides which and packs the scene).
 *
 * It computes what runtime/integrate.py computes with numpy (the same POV-Ray 3.7 rules,
 * the same formulas, in the same order, float64), but depth first per ray instead of in
 * waves: a numpy wave makes dozens of passes over arrays of a million rays, which is where
 * the time of a simple scene goes. tests/test_whitted_kernel.py holds the two to the same
 * images.
 *
 * The scene arrives as one float64 array (layout constants below, mirrored in whitted.py
 * and checked by `layout()`); the GIL is released while tracing so tiles run in parallel.
 */
#define PY_SSIZE_T_CLEAN
#include <Python.h>
#include "buffer.h"
#include "noise.h"
#include "poly.h"
#include "slab.h"
#include "superellipsoid.h"
#include "sweep.h"
#include "lathe.h"
#include "bump_map.h"
#include <math.h>
#include <stdlib.h>
#include <string.h>

/* ---- layout of the packed scene (keep in step with runtime/whitted.py) ---- */
#define HDR 128
#define FOG 20
#define OBJ 64
#define TEX 64
/* a texture of more layers renders through numpy (whitted.py MAX_LAYERS) */
#define MAX_LAYERS 16
#define LIT 32
#define PIG 56
/* a normal: a pattern row (PIG values), then its own (NR_ below) */
#define NRM (PIG + 32)
/* pigments inside pigments (pigment maps, checkers of pigments) at most this deep */
#define PIGMENT_DEPTH 32
#define NODE 16
#define BVH 11
#define BVH_STACK 128
/* crossings gathered for one CSG tree along one ray (whitted.py caps its leaves at half) */
#define MAX_CROSS 1024
/* crossings of one leaf at most: a superellipsoid's, a sweep's kept ones (a polynomial has
 * its degree, a capped cone 4); a blob has room for all of its own (leaf_room) */
#define MAX_OF(a, b) ((a) > (b) ? (a) : (b))
#define MAX_LEAF MAX_OF(SE_MAX_CROSS, MAX_OF(SWEEP_MAX_CROSS, POLY_MAX_DEGREE))

enum { H_NOBJ, H_NTEX, H_NLIGHT, H_MAXLEVEL, H_BAILOUT, H_AMB, H_BG = 8, H_LEGACY = 11,
       H_ANYTRANS, H_CAMKIND, H_WIDTH, H_HEIGHT, H_LOC, H_DIR = 19, H_RIGHT = 22, H_UP = 25,
       H_TOL = 28, H_NPIG = 39, H_NSKY, H_NNODE, H_NROOT, H_NCHILD, H_NUNB, H_NBVH, H_NITEM,
       H_MASK, H_NLOOSE, H_CAMIN = 56, H_NOISE = 76, H_MAPS, H_NMAPS, H_FOGS = 80, H_NFOG, H_FOGMAX,
       H_TERMS, H_NTERMS, H_POLY_REACH, H_POLY_LEAD, H_ROOT_ITER, H_NRMS, H_NNRM,
       H_TRIS = 90, H_NTRI, H_TBVH, H_NTBVH, H_TITEMS, H_NTITEM, H_SWEEPS = 96, H_NSWEEP,
       H_SWEEP_TOL, H_BLOBS = 103, H_NBLOB, H_BLOB_INSIDE, H_CAMNRM = 109, H_IMAGES,
       H_NIMAGE };
/* the camera's projection (H_CAMKIND) and what the other projections read (camera.py):
 * the angle in radians, the cylinder type, the spherical angles, the lengths of right and
 * up, the unit right, up and direction, tan(135 degrees) for omnimax */
enum { CAM_PERSPECTIVE, CAM_ORTHOGRAPHIC, CAM_FISHEYE, CAM_OMNIMAX, CAM_PANORAMIC, CAM_ULTRA_WIDE,
       CAM_CYLINDER, CAM_SPHERICAL };
enum { H_CAMANGLE = 112, H_CAMCYL, H_CAMH, H_CAMV, H_CAMLR, H_CAMLU, H_CAMRN, H_CAMUN = H_CAMRN + 3,
       H_CAMDN = H_CAMUN + 3, H_CAMTAN = H_CAMDN + 3 };

/* a fog: distance, rgbft, type, unit up, offset, alt, turbulence (on, vector, octaves, omega,
 * lambda, depth) */
enum { F_DIST, F_COL, F_TYPE = 6, F_UP, F_OFFSET = 10, F_ALT, F_HASTURB, F_TURB, F_OCTAVES = 16,
       F_OMEGA, F_LAMBDA, F_TDEPTH };
enum { O_KIND, O_IDENT, O_FLIP, O_SIZE, O_TEX, O_FLAGS, O_DOUBLE, O_IOR, O_MINV = 8,
       O_PRIM = 20, O_FADEPOW = 44, O_FADEDIST, O_FADECOL, O_INTERIOR = 49, O_CAUSTICS,
       O_INSIDE_TEX };
/* O_INSIDE_TEX: the interior_texture's row (-1: none), shown where the raw normal points
 * along the ray (context.texture_of) */
enum { T_PIG, T_TRANS = 23, T_LIT, T_AMB, T_EMIS = 28,
       T_DIFF = 31, T_BRIL, T_SPEC, T_ROUGH, T_PHONG, T_PHSIZE, T_METAL, T_RMIN, T_RMAX = 41,
       T_FALLOFF = 44, T_REXP, T_RMETAL, T_CONSERVE, T_NEXT, T_CRAND, T_DBACK, T_FRESNEL,
       T_IRID, T_BACKLIT = T_IRID + 3, T_NRM, T_BUMPY, T_PAT };
/* T_PAT: a patterned texture (checker, texture_map, average of textures): T_PIG names its
 * pattern row, whose entries (P_SUBS == SUBS_TEXTURES) name texture rows */
enum { SUBS_NONE, SUBS_PIGMENTS, SUBS_TEXTURES };
/* an area light (L_AREA): its grid (L_N1 x L_N2), adaptive level, orient and circular
 * flags and axes */
enum { L_KIND, L_POS, L_COL = 4, L_SHADOWLESS = 7, L_FADEPOW, L_FADEDIST, L_AXIS,
       L_TIGHT = 13, L_COSR, L_COSF, L_AREA, L_N1, L_N2, L_ADAPTIVE, L_ORIENT, L_CIRCULAR,
       L_A1, L_A2 = L_A1 + 3 };

/* P_MAP: where the colour map's P_N entries (6 values each: key, rgbft) start in the map
 * table; then the turbulence (vector, octaves, omega, lambda, on), the noise generator and
 * agate_turb. P_SUBS: the entries name pigment rows instead (key, row: a pigment map, a
 * checker of pigments), evaluated at the world point or (P_MAPAT) at the pattern point
 * taken back through the forward transform P_FWD (patterns.map_points: its turbulence). */
enum { P_KIND, P_INV, P_ORIENT = 13, P_FREQ = 16, P_PHASE, P_WAVE, P_WEXP, P_N, P_MAP,
       P_TURB, P_OCTAVES = P_TURB + 3, P_OMEGA, P_LAMBDA, P_HASTURB, P_GEN, P_AGATE, P_SUBS,
       P_FWD, P_MAPAT = P_FWD + 12, P_FORM, P_METRIC = P_FORM + 3, P_OFFSET, P_SOLID, P_WAVES,
       P_NWAVES };
/* the slots other patterns read where crackle's are: a brick's size and mortar, a spiral's
 * arms, quilted's control points; ripples and waves (P_WAVES, P_NWAVES): their wave sources
 * in the map table (frequency, x, y, z) */
enum { P_BRICK = P_FORM, P_MORTAR = P_METRIC, P_ARMS = P_OFFSET, P_CONTROL = P_FORM };
/* the fractals' slots from P_FORM on: iterations, exponent, the julia constant, the exterior
 * and interior colourings (type, factor), the magnet type and form (1: julia) */
enum { P_ITER = P_FORM, P_POWER, P_CONST, P_EXT = P_CONST + 2, P_INT = P_EXT + 2,
       P_MAGNET = P_INT + 2, P_MFORM };
enum { PK_SOLID, PK_CHECKER, PK_GRADIENT, PK_ONION, PK_SPHERICAL, PK_CYLINDRICAL, PK_PLANAR,
       PK_BOXED, PK_RADIAL, PK_BOZO, PK_GRANITE, PK_MARBLE, PK_WOOD, PK_WRINKLES, PK_AGATE,
       PK_AVERAGE, PK_CRACKLE, PK_HEXAGON, PK_BRICK, PK_LEOPARD, PK_SPIRAL1, PK_SPIRAL2,
       PK_RIPPLES, PK_WAVES, PK_DENTS, PK_QUILTED, PK_MANDEL, PK_JULIA, PK_MAGNET, PK_IMAGE,
       PK_LAST = PK_IMAGE };
/* an image_map's slots from P_FORM on: where its pixels start in the images' table, its
 * width, height and channels (4: RGBA; 6: and each pixel's filter and transmit), map_type,
 * bilinear (interpolate 2 or 4), once, use_alpha, every pixel's filter and transmit */
enum { P_IMG = P_FORM, P_IMGW, P_IMGH, P_IMGCH, P_MAPTYPE, P_BILINEAR, P_ONCE, P_ALPHA, P_IMGF,
       P_IMGT };
/* a bump_map normal's slots are an image's (heights: one channel), with its interpolate
 * (0, 2, 3, 4) and use_index where bilinear and use_alpha are */
enum { P_BM_INTERP = P_BILINEAR, P_BM_INDEX = P_ALPHA };
/* the list patterns: their value is the entry shown (0, 1, 2), no wave */
static inline int list_kind(int kind) {
    return kind == PK_CHECKER || kind == PK_HEXAGON || kind == PK_BRICK;
}
/* the patterns that read POV-Ray's noise whatever their turbulence */
static inline int noise_kind(int kind) {
    return (kind >= PK_BOZO && kind <= PK_AGATE) || kind == PK_CRACKLE || kind == PK_DENTS;
}
/* the patterns whose turbulence is part of the pattern, not a warp of the point */
static inline int builtin_turbulence(int kind) {
    return kind == PK_MARBLE || kind == PK_WOOD || kind == PK_AGATE || kind == PK_SPIRAL1 ||
           kind == PK_SPIRAL2;
}
enum { W_RAMP, W_TRIANGLE, W_SINE, W_SCALLOP, W_CUBIC, W_POLY };
/* a normal row after its pattern part: kind, depth, accuracy, no_bump_scale, whether it has
 * a linear part, the linear part and its inverse (3x3 row-major), its wave sources in the
 * map table (frequency, x, y, z: ripples and waves), its slope map there (key, height,
 * slope) */
enum { NR_KIND = PIG, NR_DEPTH, NR_ACC, NR_KEEP, NR_HASLIN, NR_LIN, NR_LININV = NR_LIN + 9,
       NR_WAVES = NR_LININV + 9, NR_NWAVES, NR_SLOPES, NR_NSLOPES, NR_NMAP, NR_NMAPAT };
/* NR_NMAP, NR_NMAPAT: a normal_map's (NK_MAP, NK_AVERAGE) entries in the map table (key,
 * the entry's normal row), how many and where */
enum { NK_NONE, NK_BUMPS, NK_DENTS, NK_WRINKLES, NK_RIPPLES, NK_WAVES, NK_SLOPE, NK_QUILTED,
       NK_MAP, NK_AVERAGE, NK_BUMPMAP };

enum { K_SPHERE, K_PLANE, K_BOX, K_DISC, K_CONE, K_TORUS, K_POLY, K_SWEEP, K_POLYGON, K_MESH,
       K_BLOB, K_SUPERELLIPSOID, K_LATHE = 12, K_SOR };
/* a triangle (runtime/triangles.py TriangleSet, world space): its first vertex, edges, unit
 * geometric normal, vertex normals (NaN: flat), object, texture row, the object's size (the
 * self-hit floor's); K_MESH objects own triangles and are met only through their box tree */
#define TRI 24
enum { TR_V0, TR_E1 = 3, TR_E2 = 6, TR_NG = 9, TR_VN = 12, TR_OBJ = 21, TR_TEX, TR_SIZE };
/* a polynomial's parameters: its terms in the terms table, their count, its degree, its
 * inside tolerance, its size (polynomial.PolyPrim) */
enum { Y_TERMS, Y_NTERMS, Y_DEGREE, Y_INSIDE, Y_SIZE };
/* a disc's parameters: centre, unit normal, radius^2, hole radius^2; a cone's (shapes.ConePrim,
 * canonical frame: axis +z from 0 to 1): the object-to-canonical rows, r0, r1, open */
enum { D_C, D_N = 3, D_R2 = 6, D_H2 };
/* a polygon (shapes.PolygonPrim): unit normal, D of its plane, the two axes it is projected
 * on, where its edges (ax, ay, bx, by each, projected) start in the sweeps' table, their
 * number, degenerate */
enum { PG_N, PG_D = 3, PG_K0, PG_K1, PG_AT, PG_COUNT, PG_DEGEN };
enum { C_FRAME_INV, C_R0 = 12, C_R1, C_OPEN };
/* the node table: leaves (an object) and CSG operations over child nodes */
enum { N_KIND, N_OP, N_INV, N_LEAF, N_FIRST, N_COUNT, N_LO = 8, N_HI = 11 };
enum { NK_LEAF, NK_CSG };
/* the box tree over the bounded roots (trace.BoxTree): a row per tree node */
enum { B_LO, B_HI = 3, B_LEFT = 6, B_RIGHT, B_FIRST, B_COUNT, B_AXIS };
/* OP_CLIP: clipped_by, the first child's crossings inside every other child (trace.ClipNode) */
enum { OP_UNION, OP_INTERSECTION, OP_DIFFERENCE, OP_MERGE, OP_CLIP };
enum { SKIP_NONE = 0, SKIP_NO_IMAGE = 1, SKIP_NO_REFLECTION = 2, SKIP_NO_SHADOW = 4 };

/* ---- tolerances: runtime/tolerances.py and runtime/shading.py send theirs in the header
 * (H_TOL on), so a test that changes one there changes it here too ---- */
enum { TOL_ORIGIN_REL, TOL_OBJECT_REL, TOL_ABS_FLOOR, TOL_PARALLEL, TOL_EPSILON, TOL_SHADOW,
       TOL_CHECKER, TOL_CROSSINGS, TOL_INSIDE, TOL_BOX_PAD_REL, TOL_BOX_PAD_ABS };
#define ORIGIN_REL (s->tol[TOL_ORIGIN_REL])
#define OBJECT_REL (s->tol[TOL_OBJECT_REL])
#define ABS_FLOOR (s->tol[TOL_ABS_FLOOR])
#define PARALLEL_EPS (s->tol[TOL_PARALLEL])
#define EPSILON (s->tol[TOL_EPSILON])
#define SHADOW_TOLERANCE (s->tol[TOL_SHADOW])
#define CHECKER_OFFSET (s->tol[TOL_CHECKER])
#define MAX_SHADOW_CROSSINGS ((int)s->tol[TOL_CROSSINGS])
#define INSIDE_EPS (s->tol[TOL_INSIDE])
#define BOX_PAD_REL (s->tol[TOL_BOX_PAD_REL])
#define BOX_PAD_ABS (s->tol[TOL_BOX_PAD_ABS])
static const double GREY[3] = {0.297, 0.589, 0.114};

typedef struct {
    const double *h, *obj, *tex, *light, *tol, *pig, *node, *child, *unb, *loose, *bvh, *item;
    const double *nrm;    /* the normals, NRM values each */
    const double *sweeps; /* the sweeps' groups and segments (kernel/sweep.h) */
    const double *blobs;  /* the blobs' pieces (kernel/blob.h) */
    double blob_inside;   /* tolerances.BLOB_INSIDE */
    SweepTol swt;
    /* per box-tree node: may camera rays (column 0), or shadow rays from their hits toward
     * light l (column 1 + l), meet it (whitted.py view masks); NULL: not packed */
    const double *mask, *start; /* start: per class, the node its walk begins at (-1: none) */
    Noise noise;                /* POV-Ray's noise tables, when a pigment needs them */
    const double *map;          /* the colour maps' entries */
    const double *fog;          /* the fogs, FOG values each */
    const double *terms;        /* the polynomials' terms, POLY_TERM values each */
    const double *img;          /* the image maps' pixels, row by row from the top */
    const double *tri, *tbvh, *titem; /* the triangles, their box tree, its leaves' triangles */
    int ntri, ntbvh, ntitem;
    int has_noise, nfog, mwidth, nnrm;
    int camnrm; /* the camera's normal row (-1: none) */
    int nobj, ntex, nlight, npig, nsky, nnode, nroot, nchild, nunb, nloose, nbvh, nitem, maxlevel,
        legacy, anytrans;
    double bailout;
    long long rays, shadow_rays;
} Scene;

typedef struct {
    double t;
    int obj, face, flip;
    int tri; /* the triangle hit (-1: the object's own surface) */
} Hit;

static inline double dot(const double *a, const double *b) {
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
}

/* numpy's cross, component by component */
static inline void cross3(const double *a, const double *b, double *out) {
    out[0] = a[1] * b[2] - a[2] * b[1];
    out[1] = a[2] * b[0] - a[0] * b[2];
    out[2] = a[0] * b[1] - a[1] * b[0];
}

static inline void affine(const double *m, const double *p, double *out) {
    for (int i = 0; i < 3; i++)
        out[i] = m[4 * i] * p[0] + m[4 * i + 1] * p[1] + m[4 * i + 2] * p[2] + m[4 * i + 3];
}

static inline void linear(const double *m, const double *v, double *out) {
    for (int i = 0; i < 3; i++)
        out[i] = m[4 * i] * v[0] + m[4 * i + 1] * v[1] + m[4 * i + 2] * v[2];
}

static inline void normalize3(double *v) {
    double len = sqrt(dot(v, v));
    if (len > 0) {
        v[0] /= len, v[1] /= len, v[2] /= len;
    } else {
        v[0] = v[1] = v[2] = 0.0;
    }
}

/* d mirrored about n: d - 2 (d.n) n (not normalised; shading.reflect's formula). */
static inline void mirror(const double *d, const double *n, double *out) {
    double dn = dot(d, n);
    for (int i = 0; i < 3; i++) out[i] = d[i] - 2.0 * dn * n[i];
}

/* Roots of a t^2 + 2 b t + c = 0 without cancellation (shapes.stable_quadratic). */
static void stable_quadratic(double a, double b, double c, double disc, double *lo, double *hi) {
    if (!(disc >= 0)) {
        *lo = *hi = INFINITY;
        return;
    }
    double sq = sqrt(disc);
    double q = -(b + copysign(sq, b));
    double t1, t2;
    if (a == 0) {
        t1 = -c / (2 * b);
        t2 = INFINITY;
    } else {
        t1 = q / a;
        t2 = (q == 0) ? t1 : c / q;
    }
    if (!isfinite(t1)) t1 = INFINITY;
    if (!isfinite(t2)) t2 = INFINITY;
    *lo = t1 < t2 ? t1 : t2;
    *hi = t1 < t2 ? t2 : t1;
}

/* the blob uses the quadratic above and poly.h's roots */
#include "blob.h"

/* shapes.ConePrim.crossings: the lateral surface (recentred at the axis midpoint; for a
 * cylinder the discriminant recentred in 2D, as for the sphere) and the two caps. */
static int cone_crossings(const Scene *s, const double *p, const double *o, const double *d,
                          double *t, int *face) {
    double oq[3], dq[3];
    affine(p + C_FRAME_INV, o, oq);
    linear(p + C_FRAME_INV, d, dq);
    double dd = dot(dq, dq), t0 = 0.0;
    if (dd > 0) {
        double to_c[3] = {-oq[0], -oq[1], 0.5 - oq[2]};
        t0 = dot(to_c, dq) / dd;
    }
    double oc[3] = {oq[0] + t0 * dq[0], oq[1] + t0 * dq[1], oq[2] + t0 * dq[2]};
    double r0 = p[C_R0], r1 = p[C_R1], k = r1 - r0;
    double rho = r0 + k * oc[2];
    double a = dq[0] * dq[0] + dq[1] * dq[1] - (k * dq[2]) * (k * dq[2]);
    double b = oc[0] * dq[0] + oc[1] * dq[1] - k * dq[2] * rho;
    double c = oc[0] * oc[0] + oc[1] * oc[1] - rho * rho;
    double disc;
    if (k == 0) {
        double lx = oc[0] - b / a * dq[0], ly = oc[1] - b / a * dq[1];
        double ln = hypot(lx, ly);
        disc = a * (fabs(r0) - ln) * (fabs(r0) + ln);
    } else {
        disc = b * b - a * c;
    }
    double ts[2];
    stable_quadratic(a, b, c, disc, &ts[0], &ts[1]);
    for (int j = 0; j < 2; j++) {
        double z = oc[2] + (isfinite(ts[j]) ? ts[j] : 0.0) * dq[2];
        int ok = isfinite(ts[j]) && z >= 0 && z <= 1;
        if (k != 0) ok = ok && (r0 + k * z) >= 0; /* not the mirror nappe */
        t[j] = ok ? ts[j] + t0 : INFINITY;
        face[j] = j;
    }
    for (int j = 0; j < 2; j++) {
        double zc = j, rc = j ? r1 : r0;
        t[2 + j] = INFINITY;
        face[2 + j] = 2 + j;
        if ((int)p[C_OPEN] || rc == 0) continue;
        double tc = (zc - oq[2]) / dq[2];
        if (!(isfinite(tc) && fabs(dq[2]) > PARALLEL_EPS)) continue;
        double x = oq[0] + tc * dq[0], y = oq[1] + tc * dq[1];
        if (x * x + y * y <= rc * rc) t[2 + j] = tc;
    }
    return 4;
}

/* ---- torus: POV-Ray's, around y in the x-z plane (shapes.TorusPrim). The numpy path finds
 * the quartic's roots as companion-matrix eigenvalues; here they are bracketed between the
 * critical points (the roots of the derivatives, down to a quadratic) and refined by
 * bisection-safeguarded Newton, then both polish on the torus equation alike. */
static inline double quartic_at(const double *c, double u) {
    return (((u + c[3]) * u + c[2]) * u + c[1]) * u + c[0];
}

/* A root of f in [a, b] where f(a), f(b) differ in sign: bisection with Newton steps. */
static double bracketed_root(const double *c, int deg, double a, double b) {
    double fa = 0;
    for (int it = 0; it < 200; it++) {
        double m = 0.5 * (a + b);
        if (m <= a || m >= b) return m;
        double f, df;
        if (deg == 4) {
            f = quartic_at(c, m);
            df = ((4 * m + 3 * c[3]) * m + 2 * c[2]) * m + c[1];
        } else { /* the derivative, a cubic 4u^3 + 3c3 u^2 + 2c2 u + c1 */
            f = ((4 * m + 3 * c[3]) * m + 2 * c[2]) * m + c[1];
            df = (12 * m + 6 * c[3]) * m + 2 * c[2];
        }
        if (it == 0) {
            fa = deg == 4 ? quartic_at(c, a) : ((4 * a + 3 * c[3]) * a + 2 * c[2]) * a + c[1];
        }
        if (f == 0) return m;
        if ((f < 0) == (fa < 0)) a = m, fa = f;
        else b = m;
        if (df != 0) { /* a Newton step that stays inside the bracket replaces the halving */
            double n = m - f / df;
            if (n > a && n < b && fabs(n - m) < 0.25 * (b - a)) {
                double fn = deg == 4 ? quartic_at(c, n)
                                     : ((4 * n + 3 * c[3]) * n + 2 * c[2]) * n + c[1];
                if (fn == 0) return n;
                if ((fn < 0) == (fa < 0)) a = n, fa = fn;
                else b = n;
            }
        }
        if (b - a <= 1e-15 * (fabs(a) + fabs(b))) break;
    }
    return 0.5 * (a + b);
}

/* Real roots of u^4 + c3 u^3 + c2 u^2 + c1 u + c0 in [-e, e], ascending; returns how many. */
static int quartic_roots(const double *c, double e, double *out) {
    double q[4];
    int nq = 0; /* critical points of the derivative: roots of 12u^2 + 6c3 u + 2c2 */
    double A = 12, B = 6 * c[3], C = 2 * c[2], disc = B * B - 4 * A * C;
    q[0] = -e;
    if (disc > 0) {
        double sq = sqrt(disc), r1 = (-B - sq) / (2 * A), r2 = (-B + sq) / (2 * A);
        if (r1 > -e && r1 < e) q[1 + nq++] = r1;
        if (r2 > -e && r2 < e) q[1 + nq++] = r2;
    }
    q[1 + nq] = e;
    int nseg = nq + 2;
    double s[5];
    int ns = 0; /* critical points of the quartic: roots of its derivative */
    s[ns++] = -e;
    for (int i = 0; i + 1 < nseg; i++) {
        double a = q[i], b = q[i + 1];
        double fa = ((4 * a + 3 * c[3]) * a + 2 * c[2]) * a + c[1];
        double fb = ((4 * b + 3 * c[3]) * b + 2 * c[2]) * b + c[1];
        if ((fa < 0) != (fb < 0)) s[ns++] = bracketed_root(c, 3, a, b);
    }
    s[ns++] = e;
    int n = 0;
    for (int i = 0; i + 1 < ns; i++) {
        double a = s[i], b = s[i + 1];
        double fa = quartic_at(c, a), fb = quartic_at(c, b);
        if (fa == 0 && i == 0) out[n++] = a;
        if (fb == 0) out[n++] = b;
        else if (fa != 0 && (fa < 0) != (fb < 0)) out[n++] = bracketed_root(c, 4, a, b);
        if (n >= 4) break;
    }
    return n;
}

static int torus_crossings(const Scene *s, const double *p, const double *o, const double *d,
                           double *t, int *face) {
    double R = p[0], r = p[1], R2 = R * R;
    double dl = sqrt(dot(d, d));
    for (int j = 0; j < 4; j++) t[j] = INFINITY, face[j] = 0;
    if (!(dl > 0)) return 4;
    double du[3] = {d[0] / dl, d[1] / dl, d[2] / dl};
    double dd = dot(d, d), t0 = -dot(o, d) / dd; /* recentred on the torus' centre */
    double oc[3] = {o[0] + t0 * d[0], o[1] + t0 * d[1], o[2] + t0 * d[2]};
    double e = fabs(R) + fabs(r);
    double bound = e * (1 + BOX_PAD_REL);
    if (dot(oc, oc) > bound * bound) return 4;
    double H = 2 * dot(oc, du), I = dot(oc, oc) + R2 - r * r;
    double J2 = du[0] * du[0] + du[2] * du[2], J1 = oc[0] * du[0] + oc[2] * du[2];
    double J0 = oc[0] * oc[0] + oc[2] * oc[2];
    double c[4] = {I * I - 4 * R2 * J0, 2 * H * I - 8 * R2 * J1, H * H + 2 * I - 4 * R2 * J2,
                   2 * H};
    double u[4];
    int n = quartic_roots(c, bound, u);
    for (int j = 0; j < n; j++) {
        /* polished on the torus equation, as the numpy path (tolerances.NEWTON_STEPS = 2,
         * NEWTON_MAX_STEP_REL = 0.1) */
        for (int k = 0; k < 3; k++) {
            double q[3] = {oc[0] + u[j] * du[0], oc[1] + u[j] * du[1], oc[2] + u[j] * du[2]};
            double sq = dot(q, q) + R2 - r * r;
            double f = sq * sq - 4 * R2 * (q[0] * q[0] + q[2] * q[2]);
            double fp = 4 * sq * dot(q, du) - 8 * R2 * (q[0] * du[0] + q[2] * du[2]);
            double step = fp != 0 ? f / fp : 0.0;
            if (fabs(step) < 0.1 * e) u[j] -= step;
        }
        t[j] = u[j] / dl + t0;
    }
    for (int a = 1; a < n; a++) /* ascending, as numpy's sort */
        for (int b = a; b > 0 && t[b] < t[b - 1]; b--) {
            double x = t[b];
            t[b] = t[b - 1], t[b - 1] = x;
        }
    return 4;
}

static inline Poly poly_of(const Scene *s, const double *p) {
    return (Poly){s->terms + (size_t)p[Y_TERMS] * POLY_TERM, (int)p[Y_NTERMS], (int)p[Y_DEGREE]};
}

/* PolyPrim.crossings: the ray recentred on the object's origin and made unit, the
 * polynomial along it, its roots (quadratic formula for a quadric; roots_in in the
 * Fujiwara bound capped at POLY_REACH sizes otherwise). */
static int poly_crossings(const Scene *s, const double *p, const double *o, const double *d,
                          double *t, int *face) {
    Poly pl = poly_of(s, p);
    int n = pl.degree;
    for (int j = 0; j < n; j++) t[j] = INFINITY, face[j] = 0;
    if (n == 0) {
        t[0] = INFINITY, face[0] = 0;
        return 1;
    }
    double dl = sqrt(dot(d, d));
    int ok = dl > 0;
    double du[3] = {d[0] / (ok ? dl : 1.0), d[1] / (ok ? dl : 1.0), d[2] / (ok ? dl : 1.0)};
    double dd = dot(d, d), t0 = 0.0;
    if (dd > 0) {
        double c[3] = {-o[0], -o[1], -o[2]};
        t0 = dot(c, d) / dd;
    }
    double oc[3] = {o[0] + t0 * d[0], o[1] + t0 * d[1], o[2] + t0 * d[2]};
    double cf[POLY_MAX_DEGREE + 1], u[POLY_MAX_DEGREE];
    poly_along(&pl, oc, du, cf);
    if (n == 1) {
        u[0] = -cf[0] / cf[1];
        if (!isfinite(u[0])) u[0] = INFINITY;
    } else if (n == 2) {
        double b = 0.5 * cf[1];
        stable_quadratic(cf[2], b, cf[0], b * b - cf[2] * cf[0], &u[0], &u[1]);
    } else {
        double bound = fujiwara(cf, n, s->h[H_POLY_LEAD], ABS_FLOOR);
        double reach = s->h[H_POLY_REACH] * (p[Y_SIZE] + sqrt(dot(oc, oc)));
        if (reach < bound) bound = reach;
        roots_in(cf, n, -bound, bound, (int)s->h[H_ROOT_ITER], u);
    }
    for (int j = 0; j < n; j++) t[j] = ok && isfinite(u[j]) ? u[j] / (ok ? dl : 1.0) + t0 : INFINITY;
    return n;
}

/* All crossings of one primitive along o + t d (object space); returns how many. */
static int crossings(const Scene *s, const double *ob, const double *o, const double *d, double *t, int *face) {
    const double *p = ob + O_PRIM;
    switch ((int)ob[O_KIND]) {
    case K_SPHERE: {
        double oc[3] = {o[0] - p[0], o[1] - p[1], o[2] - p[2]};
        double r = p[3];
        double a = dot(d, d), b = dot(oc, d), c = dot(oc, oc) - r * r;
        double k = b / a;
        double lv[3] = {oc[0] - k * d[0], oc[1] - k * d[1], oc[2] - k * d[2]};
        double l2 = dot(lv, lv);
        face[0] = face[1] = 0;
        /* Most rays pass by: when |l|^2 exceeds r^2 by more than rounding could undo, the
         * square root below is certain to exceed r, so skip it (the result is the same). */
        if (l2 > r * r * (1.0 + 1e-12)) {
            t[0] = t[1] = INFINITY;
            return 2;
        }
        double ln = sqrt(l2);
        stable_quadratic(a, b, c, a * (r - ln) * (r + ln), &t[0], &t[1]);
        face[0] = face[1] = 0;
        return 2;
    }
    case K_PLANE: {
        double denom = dot(d, p);
        t[0] = fabs(denom) > PARALLEL_EPS ? (p[3] - dot(o, p)) / denom : INFINITY;
        face[0] = 0;
        return 1;
    }
    case K_DISC: {
        double denom = dot(d, p + D_N);
        double co[3] = {p[0] - o[0], p[1] - o[1], p[2] - o[2]};
        double t0 = fabs(denom) > PARALLEL_EPS ? dot(co, p + D_N) / denom : INFINITY;
        face[0] = 0;
        t[0] = INFINITY;
        if (isfinite(t0)) {
            double q[3] = {o[0] + t0 * d[0] - p[0], o[1] + t0 * d[1] - p[1],
                           o[2] + t0 * d[2] - p[2]};
            double r2 = dot(q, q);
            if (r2 <= p[D_R2] && r2 >= p[D_H2]) t[0] = t0;
        }
        return 1;
    }
    case K_CONE:
        return cone_crossings(s, p, o, d, t, face);
    case K_TORUS:
        return torus_crossings(s, p, o, d, t, face);
    case K_POLY:
        return poly_crossings(s, p, o, d, t, face);
    case K_SWEEP:
        return sweep_crossings(&s->swt, s->sweeps, p, o, d, t, face, SWEEP_MAX_CROSS);
    case K_LATHE:
        return lathe_crossings(&s->swt, s->sweeps, p, o, d, t, face, SWEEP_MAX_CROSS);
    case K_SOR:
        return sor_crossings(&s->swt, s->sweeps, p, o, d, t, face, SWEEP_MAX_CROSS);
    case K_BLOB: { /* t has room for blob_room crossings (leaf_room) */
        int n = blob_crossings(s->blobs, p, s->blob_inside, (int)s->h[H_ROOT_ITER], o, d, t);
        for (int j = 0; j < n; j++) face[j] = 0;
        return n;
    }
    case K_SUPERELLIPSOID:
        return superellipsoid_crossings(p, o, d, t, face);
    case K_POLYGON: { /* the plane, then even-odd crossings of the projected edges */
        double denom = -dot(d, p + PG_N);
        double t0 = fabs(denom) > PARALLEL_EPS ? (dot(o, p + PG_N) + p[PG_D]) / denom : INFINITY;
        face[0] = 0;
        t[0] = INFINITY;
        if (isfinite(t0) && p[PG_DEGEN] == 0.0) {
            int k0 = (int)p[PG_K0], k1 = (int)p[PG_K1], odd = 0;
            double px = o[k0] + t0 * d[k0], py = o[k1] + t0 * d[k1];
            const double *e = s->sweeps + (size_t)p[PG_AT];
            for (int i = 0; i < (int)p[PG_COUNT]; i++, e += 4) {
                if ((e[1] > py) != (e[3] > py) && px < e[0] + (py - e[1]) * (e[2] - e[0]) / (e[3] - e[1]))
                    odd ^= 1;
            }
            if (odd) t[0] = t0;
        }
        return 1;
    }
    default: { /* box */
        const double *lo = p, *hi = p + 3;
        double n_ax[3], f_ax[3];
        for (int i = 0; i < 3; i++) {
            if (d[i] == 0) {
                int in = o[i] >= lo[i] && o[i] <= hi[i];
                n_ax[i] = in ? -INFINITY : INFINITY;
                f_ax[i] = in ? INFINITY : -INFINITY;
            } else {
                double t1 = (lo[i] - o[i]) / d[i], t2 = (hi[i] - o[i]) / d[i];
                n_ax[i] = t1 < t2 ? t1 : t2;
                f_ax[i] = t1 < t2 ? t2 : t1;
            }
        }
        /* argmax / argmin keep the first of equal values, as numpy's do */
        int an = 0, af = 0;
        for (int i = 1; i < 3; i++) {
            if (n_ax[i] > n_ax[an]) an = i;
            if (f_ax[i] < f_ax[af]) af = i;
        }
        double tn = n_ax[an], tf = f_ax[af];
        int hit = tn <= tf && isfinite(tn) && isfinite(tf);
        t[0] = hit ? tn : INFINITY;
        t[1] = hit ? tf : INFINITY;
        face[0] = 2 * an + (d[an] < 0);
        face[1] = 2 * af + (d[af] > 0);
        return 2;
    }
    }
}

static void object_normal(const Scene *s, const double *ob, const double *po, int face,
                          double *n) {
    const double *p = ob + O_PRIM;
    switch ((int)ob[O_KIND]) {
    case K_SPHERE:
        for (int i = 0; i < 3; i++) n[i] = (po[i] - p[i]) / p[3];
        break;
    case K_PLANE:
        n[0] = p[0], n[1] = p[1], n[2] = p[2];
        break;
    case K_DISC:
        n[0] = p[D_N], n[1] = p[D_N + 1], n[2] = p[D_N + 2];
        break;
    case K_POLYGON:
        n[0] = p[PG_N], n[1] = p[PG_N + 1], n[2] = p[PG_N + 2];
        break;
    case K_CONE: {
        const double *m = p + C_FRAME_INV;
        double q[3], cn[3];
        affine(m, po, q);
        double rho = p[C_R0] + (p[C_R1] - p[C_R0]) * q[2];
        cn[0] = q[0], cn[1] = q[1], cn[2] = -(p[C_R1] - p[C_R0]) * rho;
        if (face == 2) cn[0] = 0.0, cn[1] = 0.0, cn[2] = -1.0;
        if (face == 3) cn[0] = 0.0, cn[1] = 0.0, cn[2] = 1.0;
        /* canonical to object space: n @ frame_inv[:3,:3] */
        for (int i = 0; i < 3; i++) n[i] = cn[0] * m[i] + cn[1] * m[4 + i] + cn[2] * m[8 + i];
        break;
    }
    case K_POLY: {
        Poly pl = poly_of(s, p);
        poly_value(&pl, po, n);
        break;
    }
    case K_SWEEP:
        sweep_normal(&s->swt, s->sweeps, p, po, face, n);
        break;
    case K_LATHE:
        lathe_normal(&s->swt, s->sweeps, p, po, face, n);
        break;
    case K_SOR:
        sor_normal(s->sweeps, p, po, face, n);
        break;
    case K_BLOB:
        blob_normal(s->blobs, p, po, n);
        break;
    case K_SUPERELLIPSOID:
        se_gradient(p, po, n);
        break;
    case K_TORUS: {
        double R2 = p[0] * p[0], sq = dot(po, po) + R2 - p[1] * p[1];
        n[0] = po[0] * sq - 2 * R2 * po[0];
        n[1] = po[1] * sq;
        n[2] = po[2] * sq - 2 * R2 * po[2];
        break;
    }
    default:
        n[0] = n[1] = n[2] = 0.0;
        n[face / 2] = (face % 2 == 1) ? 1.0 : -1.0;
    }
}

static inline double default_tmin(const Scene *s, const double *o) {
    return ORIGIN_REL * sqrt(dot(o, o)) + ABS_FLOOR;
}

typedef struct {
    double t;
    int obj, face, flip;
} Cross;

/* An object's crossings along a world ray: the ray taken to object space (t stays the
 * world parameter: the direction is not normalised there). */
static inline int object_crossings(const Scene *s, const double *ob, const double *o,
                                   const double *d, double *t, int *face) {
    if ((int)ob[O_IDENT]) return crossings(s, ob, o, d, t, face);
    double oo[3], dd[3];
    affine(ob + O_MINV, o, oo);
    linear(ob + O_MINV, d, dd);
    return crossings(s, ob, oo, dd, t, face);
}

/* How many crossings an object can have along a ray: MAX_LEAF, a blob's all of its own. */
static inline int leaf_room(const double *ob) {
    if ((int)ob[O_KIND] != K_BLOB) return MAX_LEAF;
    int room = blob_room(ob + O_PRIM);
    return room > MAX_LEAF ? room : MAX_LEAF;
}

/* Room for one object's crossings: on the stack, or (a large blob) allocated. */
typedef struct {
    double tb[MAX_LEAF];
    int fb[MAX_LEAF];
    double *t;
    int *face;
    void *heap;
} LeafBuf;

static int leaf_buf(LeafBuf *b, const double *ob) {
    int room = leaf_room(ob);
    b->t = b->tb, b->face = b->fb, b->heap = NULL;
    if (room <= MAX_LEAF) return 1;
    b->heap = malloc((size_t)room * (sizeof(double) + sizeof(int)));
    if (b->heap == NULL) return 0;
    b->t = b->heap;
    b->face = (int *)(b->t + room);
    return 1;
}

/* A leaf's crossings in (tlo, thi), world t. */
static int leaf_crossings(const Scene *s, int obj, const double *o, const double *d, double tlo,
                          double thi, Cross *out) {
    const double *ob = s->obj + (size_t)obj * OBJ;
    LeafBuf b;
    if (!leaf_buf(&b, ob)) return 0;
    int k = object_crossings(s, ob, o, d, b.t, b.face), n = 0;
    for (int j = 0; j < k; j++)
        if (b.t[j] > tlo && b.t[j] < thi)
            out[n++] = (Cross){b.t[j], obj, b.face[j], (int)ob[O_FLIP]};
    free(b.heap);
    return n;
}

/* POV-Ray's inside test of a shape (outside: of its inverse; a surface point belongs to
 * whichever side each shape says, as in shapes.py). */
static int prim_inside(const Scene *s, const double *ob, const double *p, int outside) {
    const double *q = ob + O_PRIM;
    double po[3];
    if (!(int)ob[O_IDENT]) {
        affine(ob + O_MINV, p, po);
        p = po;
    }
    switch ((int)ob[O_KIND]) {
    case K_SPHERE: {
        double v[3] = {p[0] - q[0], p[1] - q[1], p[2] - q[2]};
        double r2 = q[3] * q[3], d2 = dot(v, v);
        return outside ? d2 > r2 : d2 < r2;
    }
    case K_PLANE: {
        double v = dot(p, q) - q[3];
        return outside ? v > -INSIDE_EPS : v < INSIDE_EPS;
    }
    case K_DISC: {
        double v[3] = {p[0] - q[D_C], p[1] - q[D_C + 1], p[2] - q[D_C + 2]};
        int in = dot(v, q + D_N) < 0;
        return outside ? !in : in;
    }
    case K_CONE: {
        double c[3];
        affine(q + C_FRAME_INV, p, c);
        double rho = q[C_R0] + (q[C_R1] - q[C_R0]) * c[2];
        double e = (int)q[C_OPEN] ? INSIDE_EPS : -INSIDE_EPS;
        double w2 = c[0] * c[0] + c[1] * c[1];
        int in = c[2] >= -e && c[2] <= 1 + e && w2 <= rho * rho + e;
        return outside ? !in : in;
    }
    case K_POLY: {
        Poly pl = poly_of(s, q);
        if (pl.degree == 0) return outside;
        double v = poly_value(&pl, p, NULL), e = q[Y_INSIDE];
        int in = e == 0 ? v <= 0 : v < e;
        return outside ? !in : in;
    }
    case K_SWEEP: {
        int in = sweep_inside(&s->swt, s->sweeps, q, p);
        return outside ? !in : in;
    }
    case K_LATHE: {
        int in = lathe_inside(&s->swt, s->sweeps, q, p);
        return outside ? !in : in;
    }
    case K_SOR: {
        int in = sor_inside(s->sweeps, q, p);
        return outside ? !in : in;
    }
    case K_BLOB: { /* POV-Ray: density above threshold - INSIDE_TOLERANCE */
        int in = blob_density(s->blobs, q, p) > q[BL_THR] - s->blob_inside;
        return outside ? !in : in;
    }
    case K_POLYGON: /* flat: no inside, nor has its inverse (as POV-Ray) */
        return 0;
    case K_SUPERELLIPSOID: {
        int in = superellipsoid_inside(q, p);
        return outside ? !in : in;
    }
    case K_TORUS: { /* distance to the core circle, surface included (as POV-Ray) */
        double rho = hypot(p[0], p[2]) - q[0];
        int in = p[1] * p[1] + rho * rho <= q[1] * q[1];
        return outside ? !in : in;
    }
    default: {
        int in = p[0] >= q[0] && p[0] <= q[3] && p[1] >= q[1] && p[1] <= q[4] && p[2] >= q[2] &&
                 p[2] <= q[5];
        return outside ? !in : in;
    }
    }
}

/* trace.CsgNode.inside / Leaf.inside: inside the node, or (inverted) inside its inverse. */
static int node_inside(const Scene *s, int node, const double *p, int inverted) {
    const double *nd = s->node + (size_t)node * NODE;
    if ((int)nd[N_KIND] == NK_LEAF) {
        const double *ob = s->obj + (size_t)nd[N_LEAF] * OBJ;
        return prim_inside(s, ob, p, (int)ob[O_FLIP] ^ inverted);
    }
    int op = (int)nd[N_OP], inv = (int)nd[N_INV] ^ inverted;
    const double *kids = s->child + (size_t)nd[N_FIRST];
    if (op == OP_CLIP) { /* inside the object and every clip; inverted: outside either */
        int clipped = 1;
        for (int j = 1; j < (int)nd[N_COUNT] && clipped; j++)
            clipped = node_inside(s, (int)kids[j], p, 0);
        int in = node_inside(s, (int)kids[0], p, inverted);
        return inverted ? in || !clipped : in && clipped;
    }
    int all_of = op == OP_INTERSECTION || op == OP_DIFFERENCE;
    if (inv) all_of = !all_of;
    for (int j = 0; j < (int)nd[N_COUNT]; j++) {
        int flag = op == OP_DIFFERENCE && j > 0;
        int in = node_inside(s, (int)kids[j], p, flag ^ inv);
        if (all_of && !in) return 0;
        if (!all_of && in) return 1;
    }
    return all_of;
}

/* trace.slab_hits for a finite box: may the segment (tmin, tmax) touch the box [lo, hi]?
 * (padded, so that a hit on the box surface is never culled). inv = 1/d, taken once per ray:
 * the divisions were most of a box test. Box-tree nodes come here directly (their boxes are
 * finite, scene_from checks): the finiteness tests were a tenth of a box test. */
static inline int slab_finite(const Scene *s, const double *lo, const double *hi,
                              const double *o, const double *inv, double tmin, double tmax) {
    return slab_padded(lo, hi, o, inv, tmin, tmax, BOX_PAD_REL, BOX_PAD_ABS);
}

/* The same for any box: an infinite one never culls. */
static inline int slab(const Scene *s, const double *lo, const double *hi, const double *o,
                       const double *inv, double tmin, double tmax) {
    for (int i = 0; i < 3; i++)
        if (!isfinite(lo[i]) || !isfinite(hi[i])) return 1;
    return slab_finite(s, lo, hi, o, inv, tmin, tmax);
}

/* trace.CsgNode.crossings: a child's crossing counts where the point is inside the other
 * children (outside them for merge; inside the inverses of the subtracted ones). Only
 * crossings in (tlo, thi) are gathered: the caller would drop the others. -1: too many. */
static int node_crossings(const Scene *s, int node, const double *o, const double *d,
                          const double *inv, double tlo, double thi, Cross *out, int cap) {
    const double *nd = s->node + (size_t)node * NODE;
    if ((int)nd[N_KIND] == NK_LEAF) {
        if (cap < leaf_room(s->obj + (size_t)nd[N_LEAF] * OBJ)) return -1;
        return leaf_crossings(s, (int)nd[N_LEAF], o, d, tlo, thi, out);
    }
    int op = (int)nd[N_OP], count = (int)nd[N_COUNT], n = 0;
    const double *kids = s->child + (size_t)nd[N_FIRST];
    if (op == OP_CLIP) { /* the object's crossings inside every clip (never hit themselves) */
        int m = node_crossings(s, (int)kids[0], o, d, inv, tlo, thi, out, cap);
        if (m < 0) return -1;
        for (int c = 0; c < m; c++) {
            Cross x = out[c];
            double p[3] = {o[0] + x.t * d[0], o[1] + x.t * d[1], o[2] + x.t * d[2]};
            int ok = 1;
            for (int j = 1; j < count && ok; j++) ok = node_inside(s, (int)kids[j], p, 0);
            if (ok) out[n++] = x;
        }
        return n;
    }
    for (int i = 0; i < count; i++) {
        /* A shape whose box the segment misses has no crossings there: skipping it changes
         * nothing (the others' inside tests are point tests), and a CSG of many parts no
         * longer tests every part (a few parts: their node's box was just tested). Only
         * shapes: an inner intersection's box (the overlap of its children's) can miss its
         * crossings, when a disc's half space is inside it. */
        const double *kd = s->node + (size_t)kids[i] * NODE;
        if (count > 4 && (int)kd[N_KIND] == NK_LEAF &&
            !slab(s, kd + N_LO, kd + N_HI, o, inv, tlo, thi))
            continue;
        int m = node_crossings(s, (int)kids[i], o, d, inv, tlo, thi, out + n, cap - n);
        if (m < 0) return -1;
        if (op != OP_UNION) {
            int w = 0;
            for (int c = 0; c < m; c++) {
                Cross x = out[n + c];
                double p[3] = {o[0] + x.t * d[0], o[1] + x.t * d[1], o[2] + x.t * d[2]};
                int ok = 1;
                for (int j = 0; j < count && ok; j++) {
                    if (j == i) continue;
                    if (op == OP_MERGE)
                        ok = !node_inside(s, (int)kids[j], p, 0);
                    else
                        ok = node_inside(s, (int)kids[j], p, op == OP_DIFFERENCE && j > 0);
                }
                if (!ok) continue;
                if (op == OP_DIFFERENCE && i > 0) x.flip = !x.flip;
                out[n + w++] = x;
            }
            m = w;
        }
        n += m;
    }
    if ((int)nd[N_INV])
        for (int c = 0; c < n; c++) out[c].flip = !out[c].flip;
    return n;
}

static int gather_hit(Scene *s, const Cross *buf, int n, double tmin, double limit, int skip,
                      int any, Hit *h);

/* Room for the crossings of a node's leaves (when a ray meets many). */
static size_t node_room(const Scene *s, int node) {
    const double *nd = s->node + (size_t)node * NODE;
    if ((int)nd[N_KIND] == NK_LEAF) return (size_t)leaf_room(s->obj + (size_t)nd[N_LEAF] * OBJ);
    size_t n = 0;
    for (int j = 0; j < (int)nd[N_COUNT]; j++)
        n += node_room(s, (int)s->child[(size_t)nd[N_FIRST] + j]);
    return n;
}

/* Test root node r; 1 when `any` and a hit was found (the caller stops). A CSG root is
 * culled by its box against the segment (tmin, cull). */
static int test_root(Scene *s, int r, const double *o, const double *d, const double *inv,
                     double tmin, double cull, int skip, int any, Hit *h, Cross *buf) {
    const double *nd = s->node + (size_t)r * NODE;
    double limit = h->t;
    int n;
    if ((int)nd[N_KIND] == NK_LEAF) {
        /* a plain shape: its crossings straight from the primitive, no gathering */
        int obj = (int)nd[N_LEAF];
        const double *ob = s->obj + (size_t)obj * OBJ;
        if (skip & (int)ob[O_FLAGS]) return 0;
        LeafBuf b;
        if (!leaf_buf(&b, ob)) return 0;
        int k = object_crossings(s, ob, o, d, b.t, b.face), found = 0;
        double floor = OBJECT_REL * ob[O_SIZE];
        if (tmin > floor) floor = tmin;
        for (int j = 0; j < k && !found; j++) {
            if (b.t[j] > floor && b.t[j] < limit) {
                limit = b.t[j];
                h->t = b.t[j], h->obj = obj, h->face = b.face[j], h->flip = (int)ob[O_FLIP];
                found = any;
            }
        }
        free(b.heap);
        return found;
    } else {
        if (!slab(s, nd + N_LO, nd + N_HI, o, inv, tmin, cull)) return 0;
        n = node_crossings(s, r, o, d, inv, tmin, limit, buf, MAX_CROSS);
        if (n < 0) {
            /* a ray through more leaves than the stack buffer holds (a CSG of hundreds of
             * shapes): once more with room for every leaf's crossings */
            size_t cap = node_room(s, r) + 4;
            Cross *big = malloc(cap * sizeof(Cross));
            if (big == NULL) return 0;
            n = node_crossings(s, r, o, d, inv, tmin, limit, big, (int)cap);
            int found = gather_hit(s, big, n, tmin, limit, skip, any, h);
            free(big);
            return found;
        }
    }
    return gather_hit(s, buf, n, tmin, limit, skip, any, h);
}

/* The closest of a root's gathered crossings beyond each object's floor. */
static int gather_hit(Scene *s, const Cross *buf, int n, double tmin, double limit, int skip,
                      int any, Hit *h) {
    for (int c = 0; c < n; c++) {
        const double *ob = s->obj + (size_t)buf[c].obj * OBJ;
        if (skip & (int)ob[O_FLAGS]) continue;
        double floor = OBJECT_REL * ob[O_SIZE];
        if (tmin > floor) floor = tmin;
        if (buf[c].t > floor && buf[c].t < limit) {
            limit = buf[c].t;
            h->t = buf[c].t, h->obj = buf[c].obj, h->face = buf[c].face, h->flip = buf[c].flip;
            if (any) return 1;
        }
    }
    return 0;
}

/* Barycentric weights (u of vertex 1, v of vertex 2) of p in a triangle's plane
 * (shapes.barycentric). */
static void tri_weights(const double *tr, const double *p, double *u, double *v) {
    const double *e1 = tr + TR_E1, *e2 = tr + TR_E2;
    double w[3] = {p[0] - tr[0], p[1] - tr[1], p[2] - tr[2]};
    double d00 = dot(e1, e1), d01 = dot(e1, e2), d11 = dot(e2, e2);
    double d20 = dot(w, e1), d21 = dot(w, e2), den = d00 * d11 - d01 * d01;
    *u = (d11 * d20 - d01 * d21) / den;
    *v = (d00 * d21 - d01 * d20) / den;
}

/* The nearest triangle in (its floor, h->t) through their box tree, in float64 as the numpy
 * path refines Embree's hits (triangles.TriangleSet: the distance to the plane, the object's
 * self-hit floor); 1 when `any` and one was found. */
static int triangle_hits(Scene *s, const double *o, const double *d, const double *inv,
                         double tmin, int skip, int any, Hit *h) {
    int stack[BVH_STACK], top = 0;
    stack[top++] = 0;
    while (top > 0) {
        const double *b = s->tbvh + (size_t)stack[--top] * BVH;
        if (!slab_finite(s, b + B_LO, b + B_HI, o, inv, tmin, h->t)) continue;
        if (b[B_LEFT] >= 0) {
            int axis_near_left = d[(int)b[B_AXIS]] >= 0;
            if (top + 2 > BVH_STACK) continue; /* deeper than any tree whitted.py packs */
            stack[top++] = (int)(axis_near_left ? b[B_RIGHT] : b[B_LEFT]);
            stack[top++] = (int)(axis_near_left ? b[B_LEFT] : b[B_RIGHT]);
            continue;
        }
        for (int k = 0; k < (int)b[B_COUNT]; k++) {
            int i = (int)s->titem[(size_t)b[B_FIRST] + k];
            const double *tr = s->tri + (size_t)i * TRI;
            int obj = (int)tr[TR_OBJ];
            if (skip & (int)s->obj[(size_t)obj * OBJ + O_FLAGS]) continue;
            const double *ng = tr + TR_NG;
            double w[3] = {tr[0] - o[0], tr[1] - o[1], tr[2] - o[2]};
            double t = dot(w, ng) / dot(d, ng);
            double floor = OBJECT_REL * tr[TR_SIZE];
            if (tmin > floor) floor = tmin;
            if (!(t > floor && t < h->t)) continue;
            double p[3] = {o[0] + t * d[0], o[1] + t * d[1], o[2] + t * d[2]}, u, v;
            tri_weights(tr, p, &u, &v);
            if (!(u >= 0.0 && v >= 0.0 && u + v <= 1.0)) continue;
            h->t = t, h->obj = obj, h->tri = i, h->face = 0, h->flip = 0;
            if (any) return 1;
        }
    }
    return 0;
}

/* Closest crossing in (floor, tmax) over all objects not flagged `skip`; 0 when none.
 * any: stop at the first one (shadow rays). Unbounded roots (planes) first: their hits
 * shorten the ray before the box tree is walked, as in trace.Tracer; the loose roots
 * (trace.Tracer.loose: CSG whose box may not hold their crossings) last, each culled by
 * its box against what the others left of the ray, whatever the order. */
static int find_hit(Scene *s, const double *o, const double *d, double tmax, int skip, int any,
                    int cls, Hit *h) {
    double tmin = default_tmin(s, o);
    h->t = tmax;
    h->obj = -1;
    h->tri = -1;
    Cross buf[MAX_CROSS];
    double inv[3] = {1.0 / d[0], 1.0 / d[1], 1.0 / d[2]}; /* inf for 0, as numpy's */
    for (int u = 0; u < s->nunb; u++)
        if (test_root(s, (int)s->unb[u], o, d, inv, tmin, h->t, skip, any, h, buf)) return 1;
    int stack[BVH_STACK], top = 0;
    /* a class's walk starts below the nodes only one of whose children it can meet */
    int first = cls >= 0 && s->mask ? (int)s->start[cls] : 0;
    if (s->nbvh > 0 && first >= 0) stack[top++] = first;
    while (top > 0) {
        int at = stack[--top];
        /* a ray of a class that cannot meet this node's box: not even its box is tested */
        if (cls >= 0 && s->mask && s->mask[(size_t)at * s->mwidth + cls] == 0.0) continue;
        const double *b = s->bvh + (size_t)at * BVH;
        /* The root's box holds the whole scene, which nearly every ray crosses: an inner
         * root is not tested, its children are (one box test fewer per ray). */
        if ((at != 0 || b[B_LEFT] < 0) && !slab_finite(s, b + B_LO, b + B_HI, o, inv, tmin, h->t))
            continue;
        if (b[B_LEFT] < 0) {
            for (int k = 0; k < (int)b[B_COUNT]; k++) {
                /* a leaf's own box is not tested: it costs about what a sphere does, and a
                 * tree leaf holds only a few roots */
                int r = (int)s->item[(size_t)b[B_FIRST] + k];
                if (test_root(s, r, o, d, inv, tmin, h->t, skip, any, h, buf)) return 1;
            }
        } else {
            /* the far child first, so the near one is popped (and shortens the ray) first;
             * the left child lies lower along the split axis */
            int axis_near_left = d[(int)b[B_AXIS]] >= 0;
            if (top + 2 > BVH_STACK) continue; /* deeper than any tree whitted.py packs */
            stack[top++] = (int)(axis_near_left ? b[B_RIGHT] : b[B_LEFT]);
            stack[top++] = (int)(axis_near_left ? b[B_LEFT] : b[B_RIGHT]);
        }
    }
    double cull = h->t;
    for (int u = 0; u < s->nloose; u++)
        if (test_root(s, (int)s->loose[u], o, d, inv, tmin, cull, skip, any, h, buf)) return 1;
    /* last, so that a triangle's hit is the only kind that can replace another after it */
    if (s->ntbvh > 0 && triangle_hits(s, o, d, inv, tmin, skip, any, h)) return 1;
    return h->obj >= 0;
}

static inline int closest(Scene *s, const double *o, const double *d, double tmax, int skip,
                          int cls, Hit *h) {
    return find_hit(s, o, d, tmax, skip, 0, cls, h);
}

static inline int occluded(Scene *s, const double *o, const double *d, double tmax, int cls) {
    Hit h;
    return find_hit(s, o, d, tmax, SKIP_NO_SHADOW, 1, cls, &h);
}

/* Unit world normal at the hit (before the viewer turn), flipped for inverse objects. */
static void hit_normal(Scene *s, const double *o, const double *d, const Hit *h, double *n) {
    if (h->tri >= 0) { /* the geometric normal, or the vertex normals' (triangles._record) */
        const double *tr = s->tri + (size_t)h->tri * TRI, *vn = tr + TR_VN;
        if (isnan(vn[0])) {
            n[0] = tr[TR_NG], n[1] = tr[TR_NG + 1], n[2] = tr[TR_NG + 2];
            return;
        }
        double p[3] = {o[0] + h->t * d[0], o[1] + h->t * d[1], o[2] + h->t * d[2]}, u, v;
        tri_weights(tr, p, &u, &v);
        for (int i = 0; i < 3; i++) n[i] = (1.0 - u - v) * vn[i] + u * vn[3 + i] + v * vn[6 + i];
        normalize3(n);
        return;
    }
    const double *ob = s->obj + (size_t)h->obj * OBJ;
    double po[3], on[3];
    if ((int)ob[O_IDENT]) {
        for (int i = 0; i < 3; i++) po[i] = o[i] + h->t * d[i];
        object_normal(s, ob, po, h->face, n);
    } else {
        double oo[3], dd[3];
        const double *m = ob + O_MINV;
        affine(m, o, oo);
        linear(m, d, dd);
        for (int i = 0; i < 3; i++) po[i] = oo[i] + h->t * dd[i];
        object_normal(s, ob, po, h->face, on);
        /* the inverse transpose: n @ m_inv[:3,:3] */
        for (int i = 0; i < 3; i++) n[i] = on[0] * m[i] + on[1] * m[4 + i] + on[2] * m[8 + i];
    }
    normalize3(n);
    if (h->flip) n[0] = -n[0], n[1] = -n[1], n[2] = -n[2];
}

#define WAVE_MODULUS 1.00001

/* POV-Ray's frequency/phase wrap, then the wave type (patterns.apply_wave). */
static double apply_wave(const double *pg, double v) {
    double freq = pg[P_FREQ];
    if (freq != 0.0) v = fmod(v * freq + pg[P_PHASE], WAVE_MODULUS);
    if (v < 0.0) v = v - floor(v);
    switch ((int)pg[P_WAVE]) {
    case W_TRIANGLE: {
        double f = v - floor(v);
        return f < 0.5 ? 2.0 * f : 2.0 - 2.0 * f;
    }
    case W_SINE: return (1.0 + sin(v * 2.0 * M_PI)) * 0.5;
    case W_SCALLOP: return fabs(sin(v * M_PI));
    case W_CUBIC: return v * v * (3.0 - 2.0 * v);
    case W_POLY: return pow(v, pg[P_WEXP]);
    default: return v;
    }
}

static inline double clip01(double v) { return v < 0.0 ? 0.0 : (v > 1.0 ? 1.0 : v); }

static inline double cycloidal(double v) { return sin(2.0 * M_PI * (v - floor(v))); }

/* The noise patterns' values (patterns.bozo, granite, marble, wood, wrinkles, agate). */
static double noise_pattern(const Noise *nz, int kind, const double *q, int turbulent,
                            const double *turb, int octaves, double omega, double lam, int gen,
                            const double *pg) {
    switch (kind) {
    case PK_GRANITE: {
        double total = 0.0, freq = 1.0;
        for (int i = 0; i < 6; i++) {
            double f = 4.0 * freq, r[3] = {q[0] * f, q[1] * f, q[2] * f};
            double n = noise_at(nz, r, gen), t;
            if (gen == 1) {
                t = fabs(0.5 - n);
            } else {
                t = fabs(1.0 - 2.0 * n);
                t = t < 0.5 ? t : 0.5;
            }
            total += t / freq;
            freq *= 2.0;
        }
        return total;
    }
    case PK_MARBLE:
        return q[0] + (turbulent ? turb[0] * turbulence_at(nz, q, octaves, omega, lam, gen) : 0.0);
    case PK_WOOD: {
        double x = q[0], y = q[1];
        if (turbulent) {
            double d[3];
            dturbulence_at(nz, q, octaves, omega, lam, d);
            x = x + cycloidal((x + d[0]) * turb[0]);
            y = y + cycloidal((y + d[1]) * turb[1]);
        }
        return hypot(x, y);
    }
    case PK_WRINKLES: {
        double total = 0.0, l = 2.0, w = 0.5;
        for (int i = 0; i < 10; i++) {
            double r[3] = {q[0] * l, q[1] * l, q[2] * l};
            double n = noise_at(nz, i ? r : q, gen);
            if (gen != 1) n = clip_unit(2.0 * n - 0.5);
            if (i == 0) {
                total = n;
                continue;
            }
            total += w * n;
            l *= 2.0;
            w *= 0.5;
        }
        return total / 2.0;
    }
    case PK_AGATE: {
        double t = pg[P_AGATE] * turbulence_at(nz, q, octaves, omega, lam, gen);
        double v = 0.5 * (cycloidal(1.3 * t + 1.1 * q[2]) + 1.0);
        return pow(clip_unit(v), 0.77);
    }
    default: return noise_at(nz, q, gen); /* bozo, spotted, bumps */
    }
}

/* Voronoi cells around one random point per unit cube (patterns.crackle): the distances
 * to the three nearest of the 81 cubes' points, in the row's metric, weighted by its form;
 * solid: the noise at the nearest point. */
static double crackle(const Noise *nz, const double *pg, const double *q) {
    double metric = pg[P_METRIC], best[3] = {INFINITY, INFINITY, INFINITY}, near[3] = {0};
    long long base[3];
    for (int a = 0; a < 3; a++) base[a] = (long long)floor(q[a] - 1.0e-10);
    for (int dx = -2; dx <= 2; dx++)
        for (int dy = -2; dy <= 2; dy++)
            for (int dz = -2; dz <= 2; dz++) {
                if ((abs(dx) == 2) + (abs(dy) == 2) + (abs(dz) == 2) > 1) continue;
                long long c[3] = {base[0] + dx, base[1] + dy, base[2] + dz};
                int seed = hash3d(nz, c[0], c[1], c[2]);
                double pt[3], d[3], sum;
                for (int a = 0; a < 3; a++) {
                    pt[a] = (double)c[a] + nz->rands[seed + a];
                    d[a] = fabs(pt[a] - q[a]);
                }
                if (metric == 2.0) sum = d[0] * d[0] + d[1] * d[1] + d[2] * d[2];
                else if (metric == 1.0) sum = d[0] + d[1] + d[2];
                else sum = pow(d[0], metric) + pow(d[1], metric) + pow(d[2], metric);
                if (sum < best[0]) {
                    best[2] = best[1], best[1] = best[0], best[0] = sum;
                    memcpy(near, pt, sizeof near);
                } else if (sum < best[1]) {
                    best[2] = best[1], best[1] = sum;
                } else if (sum < best[2]) {
                    best[2] = sum;
                }
            }
    if (pg[P_SOLID] != 0.0) return noise_at(nz, near, (int)pg[P_GEN]);
    double v = 0.0;
    for (int k = 0; k < 3; k++) {
        double t = best[k] + pg[P_OFFSET];
        v += (metric == 1.0 ? t : pow(t, 1.0 / metric)) * pg[P_FORM + k];
    }
    return clip01(v);
}

/* Hexagons of side 1 in the x-z plane (patterns.hexagon): the nearest lattice centre by
 * cube rounding (to even, as numpy's round), its colour of three. */
static double hexagon(const double *q) {
    double cx = (2.0 / 3.0) * q[0], cz = -q[0] / 3.0 + q[2] / sqrt(3.0), cy = -cx - cz;
    double rx = nearbyint(cx), ry = nearbyint(cy), rz = nearbyint(cz);
    double dx = fabs(rx - cx), dy = fabs(ry - cy), dz = fabs(rz - cz);
    int fix_x = dx > dy && dx > dz, fix_y = !fix_x && dy > dz;
    if (fix_x) rx = -ry - rz;
    if (fix_y) ry = -rx - rz;
    if (!fix_x && !fix_y) rz = -rx - ry;
    double m = fmod(2.0 * rx + rz, 3.0);
    if (m < 0.0) m += 3.0;
    return (double)(long long)m;
}

static inline double frac_of(double v) { return v - floor(v); }

/* 0 mortar, 1 brick (patterns.brick): courses along y, joints shifted half a brick in the
 * odd ones */
static double brick(const Scene *s, const double *pg, const double *q) {
    const double *size = pg + P_BRICK;
    double mortar = pg[P_MORTAR], r[3];
    for (int a = 0; a < 3; a++) r[a] = (q[a] + (CHECKER_OFFSET + mortar)) / size[a];
    int bed = frac_of(r[1]) <= mortar / size[1];
    int odd = frac_of(0.5 * r[1]) > 0.5;
    int end_x = (odd ? frac_of(r[0] + 0.5) : frac_of(r[0])) <= mortar / size[0];
    int face_z = (odd ? frac_of(r[2]) : frac_of(r[2] + 0.5)) <= mortar / size[2];
    return (bed || end_x || face_z) ? 0.0 : 1.0;
}

static inline double triangle_of(double v) {
    double f = v - floor(v);
    return f < 0.5 ? 2.0 * f : 2.0 - 2.0 * f;
}

/* patterns._spiral_arg: z + distance from the z axis + arms * angle / 2 pi + the built-in
 * turbulence; the distance to *rad when asked */
static double spiral(const Scene *s, const double *pg, const double *q, double *rad_out) {
    double x = q[0], y = q[1], z = q[2], rad = hypot(x, y), phi = 0.0;
    if (rad != 0.0) {
        double ratio = y / (rad > 0 ? rad : 1.0);
        ratio = ratio < -1.0 ? -1.0 : (ratio > 1.0 ? 1.0 : ratio);
        double a = asin(ratio);
        phi = x < 0 ? 1.5 * M_PI - a : 0.5 * M_PI + a;
    }
    double turb = 0.0;
    if (pg[P_HASTURB] != 0.0)
        turb = pg[P_TURB] * turbulence_at(&s->noise, q, (int)pg[P_OCTAVES], pg[P_OMEGA],
                                          pg[P_LAMBDA], (int)pg[P_GEN]);
    if (rad_out) *rad_out = rad;
    return z + rad + pg[P_ARMS] * phi / (2.0 * M_PI) + turb;
}

/* ripples and waves as pigments (patterns.ripples, patterns.waves): sines of the distance
 * to POV-Ray's wave sources, averaged */
static double wave_sources(const Scene *s, const double *pg, const double *q, int waves) {
    int count = (int)pg[P_NWAVES];
    const double *w = s->map + 6 * (size_t)pg[P_WAVES];
    double total = 0.0;
    for (int i = 0; i < count; i++, w += 6) {
        double d[3] = {q[0] - w[1], q[1] - w[2], q[2] - w[3]};
        double len = sqrt(dot(d, d));
        if (waves) {
            if (len == 0.0) len = 1.0;
            total += cycloidal(len * w[0]) / w[0];
        } else {
            total += cycloidal(len);
        }
    }
    return waves ? 0.2 * (2.5 + total / count) : 0.5 + total / (2.0 * count);
}

/* quilted's offset from the unit cube's centre, scaled by the cubic of its length
 * (patterns._quilt_offset) */
static void quilt_offset(const double *pg, const double *q, double *out) {
    double c0 = pg[P_CONTROL], c1 = pg[P_CONTROL + 1], v[3];
    for (int a = 0; a < 3; a++) v[a] = q[a] - floor(q[a]) - 0.5;
    double t = sqrt(dot(v, v)), it = 1.0 - t;
    double k = (pow(t, 3.0) + 3.0 * t * it * it * c0 + 3.0 * t * t * it * c1) * 1.154700538;
    for (int a = 0; a < 3; a++) out[a] = v[a] * k;
}

/* The fractals (runtime/fractal_patterns.py), in its arithmetic's order. */
static double fractal_coloured(int kind, double f, double a, double b) {
    switch (kind) {
    case 0: return f;
    case 2: return a * f;
    case 3: return b * f;
    case 4: return a * a * f;
    case 5: return b * b * f;
    default: return 0.0;
    }
}

static inline long long py_mod(long long a, long long n) { /* Python's %: n's sign */
    long long m = a % n;
    return (m != 0 && ((m < 0) != (n < 0))) ? m + n : m;
}

static double fractal_exterior(int kind, double f, int col, int it_max, double a, double b) {
    if (kind == 1) return (double)col / it_max;
    if (kind == 6) return sqrt(a * a + b * b) * f;
    if (kind == 7 && (long long)f > 0) return (double)py_mod(col, (long long)f) / f;
    if (kind == 8 && f != 0.0) {
        long long n = (long long)(1.0 + f);
        return n == 0 ? 0.0 : (double)py_mod(col, n) / f;
    }
    return fractal_coloured(kind, f, a, b);
}

static double fractal_interior(int kind, double f, double a, double b, double mind2) {
    if (kind == 1) return sqrt(mind2) * f;
    if (kind == 6) return a * a + b * b * f; /* POV-Ray's precedence, kept */
    return fractal_coloured(kind, f, a, b);
}

/* (a + bi)^n as POV-Ray's Mandel2/3/4 patterns write it out (a2, b2: the squares) */
static void fractal_power(int n, double a, double b, double a2, double b2, double *ra,
                          double *rb) {
    if (n == 3) {
        *ra = a2 * a - 3.0 * a * b2, *rb = 3.0 * a2 * b - b2 * b;
    } else if (n == 4) {
        *ra = a2 * a2 - 6.0 * a2 * b2 + b2 * b2, *rb = 4.0 * (a2 * a * b - a * b2 * b);
    } else {
        *ra = a2 - b2, *rb = 2.0 * a * b;
    }
}

/* a fractal row's exponent and iterations are ones the loops below take */
static int fractal_row_valid(const double *pg) {
    int kind = (int)pg[P_KIND];
    if (kind != PK_MANDEL && kind != PK_JULIA && kind != PK_MAGNET) return 1;
    if (!(pg[P_ITER] >= -2147483648.0 && pg[P_ITER] <= 2147483647.0)) return 0;
    return kind == PK_MAGNET || (pg[P_POWER] >= 2 && pg[P_POWER] <= 4);
}

/* mandel (c the point, z from it) and julia (c the constant): z -> z^n + c, escaping past
 * |z|^2 = 4 */
static double escape_fractal(const double *pg, const double *q, int julia) {
    int it_max = (int)pg[P_ITER], power = (int)pg[P_POWER];
    double cr = julia ? pg[P_CONST] : q[0], ci = julia ? pg[P_CONST + 1] : q[1];
    double a = q[0], b = q[1], a2 = a * a, b2 = b * b, mind2 = a2 + b2;
    for (int col = 0; col < it_max; col++) {
        fractal_power(power, a, b, a2, b2, &a, &b);
        a = a + cr, b = b + ci;
        a2 = a * a, b2 = b * b;
        double d2 = a2 + b2;
        if (d2 < mind2) mind2 = d2;
        if (d2 > 4.0) return fractal_exterior((int)pg[P_EXT], pg[P_EXT + 1], col, it_max, a, b);
    }
    return fractal_interior((int)pg[P_INT], pg[P_INT + 1], a, b, mind2);
}

/* a magnet point escapes past |z|^2 = 1e4 or is caught within 1e-4 (squared) of 1 */
static double magnet_fractal(const double *pg, const double *q) {
    int it_max = (int)pg[P_ITER], type2 = (int)pg[P_MAGNET] == 2;
    double cr, ci, a, b, mind2;
    if (pg[P_MFORM] != 0.0) {
        cr = pg[P_CONST], ci = pg[P_CONST + 1], a = q[0], b = q[1];
        mind2 = a * a + b * b;
    } else {
        cr = q[0], ci = q[1], a = 0.0, b = 0.0;
        mind2 = 10000.0;
    }
    double a2 = a * a, b2 = b * b;
    for (int col = 0; col < it_max; col++) {
        double nr, ni, dr, di;
        if (type2) {
            double c1r = cr - 1, c2r = cr - 2;
            double c12r = c1r * c2r - ci * ci, c12i = (c1r + c2r) * ci;
            nr = a2 * a - 3 * a * b2 + 3 * (a * c1r - b * ci) + c12r;
            ni = 3 * a2 * b - b2 * b + 3 * (a * ci + b * c1r) + c12i;
            dr = 3 * (a2 - b2) + 3 * (a * c2r - b * ci) + c12r + 1;
            di = 6 * a * b + 3 * (a * ci + b * c2r) + c12i;
        } else {
            nr = a2 - b2 + cr - 1, ni = 2 * a * b + ci;
            dr = 2 * a + cr - 2, di = 2 * b + ci;
        }
        double den = dr * dr + di * di;
        double qa = (nr * dr + ni * di) / den, qb = (ni * dr - nr * di) / den;
        a = qa * qa - qb * qb, b = 2 * qa * qb;
        a2 = a * a, b2 = b * b;
        double d2 = a2 + b2;
        if (d2 < mind2) mind2 = d2; /* a nan never replaces the minimum */
        if (d2 > 10000.0 || (a - 1.0) * (a - 1.0) + b2 < 1.0 / 10000.0)
            return fractal_exterior((int)pg[P_EXT], pg[P_EXT + 1], col, it_max, a, b);
    }
    return fractal_interior((int)pg[P_INT], pg[P_INT + 1], a, b, mind2);
}

/* A pattern's value at a pattern-space point q, turbulence warp already applied, after its
 * wave (patterns._pattern_value for the kinds packed; a checker's is its entry, 0 or 1). */
static double pattern_value(const Scene *s, const double *pg, const double *q) {
    int kind = (int)pg[P_KIND];
    double v;
    switch (kind) {
    case PK_CHECKER: {
        double sum = floor(q[0] + CHECKER_OFFSET) + floor(q[1] + CHECKER_OFFSET) +
                     floor(q[2] + CHECKER_OFFSET);
        return (double)(((long long)sum) & 1);
    }
    case PK_HEXAGON: return hexagon(q);
    case PK_BRICK: return brick(s, pg, q);
    case PK_LEOPARD: {
        double m = (sin(q[0]) + sin(q[1]) + sin(q[2])) / 3.0;
        v = m * m;
        break;
    }
    case PK_SPIRAL1: v = spiral(s, pg, q, NULL); break;
    case PK_SPIRAL2: {
        double rad, arg = spiral(s, pg, q, &rad);
        v = triangle_of(rad) + triangle_of(arg);
        break;
    }
    case PK_RIPPLES:
    case PK_WAVES: v = wave_sources(s, pg, q, kind == PK_WAVES); break;
    case PK_DENTS: v = pow(noise_at(&s->noise, q, (int)pg[P_GEN]), 3.0); break;
    case PK_QUILTED: {
        double off[3];
        quilt_offset(pg, q, off);
        v = (fabs(off[0]) + fabs(off[1]) + fabs(off[2])) / 3.0;
        break;
    }
    case PK_MANDEL:
    case PK_JULIA: v = escape_fractal(pg, q, kind == PK_JULIA); break;
    case PK_MAGNET: v = magnet_fractal(pg, q); break;
    case PK_GRADIENT: v = dot(q, pg + P_ORIENT); break;
    case PK_ONION: v = fmod(sqrt(dot(q, q)), 1.0); break;
    case PK_SPHERICAL: v = clip01(1.0 - sqrt(dot(q, q))); break;
    case PK_CYLINDRICAL: v = clip01(1.0 - hypot(q[0], q[2])); break;
    case PK_PLANAR: v = clip01(1.0 - fabs(q[1])); break;
    case PK_BOXED: {
        double m = fabs(q[0]) > fabs(q[1]) ? fabs(q[0]) : fabs(q[1]);
        m = m > fabs(q[2]) ? m : fabs(q[2]);
        v = clip01(1.0 - m);
        break;
    }
    case PK_CRACKLE: v = crackle(&s->noise, pg, q); break;
    case PK_RADIAL:
        v = (fabs(q[0]) < 0.001 && fabs(q[2]) < 0.001)
                ? 0.25
                : 0.25 + (atan2(q[0], q[2]) + M_PI) / (2.0 * M_PI);
        break;
    default:
        v = noise_pattern(&s->noise, kind, q, pg[P_HASTURB] != 0.0, pg + P_TURB,
                          (int)pg[P_OCTAVES], pg[P_OMEGA], pg[P_LAMBDA], (int)pg[P_GEN], pg);
    }
    return apply_wave(pg, v);
}

/* A pattern row's point in its pattern space with the classic turbulence warp (the noise
 * patterns with their own turbulence, marble, wood and agate, take it inside). */
static void pattern_point(const Scene *s, const double *pg, const double *p, double *q) {
    affine(pg + P_INV, p, q);
    int kind = (int)pg[P_KIND];
    if (pg[P_HASTURB] != 0.0 && !builtin_turbulence(kind)) {
        double dt[3]; /* patterns.turbulence_warp */
        dturbulence_at(&s->noise, q, (int)pg[P_OCTAVES], pg[P_OMEGA], pg[P_LAMBDA], dt);
        for (int a = 0; a < 3; a++) q[a] = q[a] + dt[a] * pg[P_TURB + a];
    }
}

/* POV-Ray's Search_Blend_Map (patterns.blend_indices) over n map entries: the two to blend
 * and the weight of hi. */
static double blend(const double *map, int n, double v, int *lo_out, int *hi_out) {
    int hi = 0;
    while (hi < n && map[6 * hi] < v) hi++;
    if (hi > n - 1) hi = n - 1;
    int lo = hi > 0 ? hi - 1 : 0;
    if (v >= map[6 * (n - 1)]) hi = n - 1;
    if (v >= map[6 * (n - 1)] || map[6 * hi] == v || v <= map[0]) lo = hi;
    double span = map[6 * hi] - map[6 * lo];
    *lo_out = lo, *hi_out = hi;
    return span > 0 ? (v - map[6 * lo]) / span : 0.0;
}

/* numpy's float mod (npy_divmod): the sign of the divisor, a zero result signed as it */
static inline double float_mod(double a, double b) {
    double m = fmod(a, b);
    if (m != 0.0) {
        if ((b < 0) != (m < 0)) m += b;
    } else m = copysign(0.0, b);
    return m;
}

/* An image_map's RGBFT at a pattern-space point (patterns.image_uv, patterns.image_map). */
static void image_at(const Scene *s, const double *pg, const double *q, double *out) {
    double x = q[0], y = q[1], z = q[2], u = x, v = y;
    int type = (int)pg[P_MAPTYPE];
    if (type == 1 || type == 2 || type == 5) {
        u = float_mod(atan2(z, x) / (2.0 * M_PI), 1.0);
        if (type == 2) v = y;
        else if (type == 5) {
            double d = hypot(x, z) - 1.0;
            v = float_mod(-atan2(y, -d) / (2.0 * M_PI), 1.0);
        } else {
            double r = sqrt(x * x + y * y + z * z), safe = r > 0 ? r : 1.0, c = y / safe;
            v = asin(c < -1.0 ? -1.0 : (c > 1.0 ? 1.0 : c)) / M_PI + 0.5;
        }
    }
    int inside = u >= 0 && u < 1 && v >= 0 && v < 1;
    u = u - floor(u);
    v = v - floor(v);
    long long w = (long long)pg[P_IMGW], h = (long long)pg[P_IMGH], ch = (long long)pg[P_IMGCH];
    const double *img = s->img + (size_t)pg[P_IMG];
    double fx = u * (double)w, fy = (1.0 - v) * (double)h, px[6] = {0};
    if (!(fx == fx && fy == fy)) fx = fy = 0.0; /* a point at infinity: a pixel, not garbage */
    if (pg[P_BILINEAR] != 0.0) {
        double x0f = floor(fx - 0.5), y0f = floor(fy - 0.5);
        double tx = (fx - 0.5) - x0f, ty = (fy - 0.5) - y0f;
        long long x0 = py_mod((long long)x0f, w), y0 = py_mod((long long)y0f, h);
        long long x1 = (x0 + 1) % w, y1 = (y0 + 1) % h;
        const double *a = img + (size_t)(y0 * w + x0) * ch, *b = img + (size_t)(y0 * w + x1) * ch;
        const double *c = img + (size_t)(y1 * w + x0) * ch, *d = img + (size_t)(y1 * w + x1) * ch;
        double wa = (1 - tx) * (1 - ty), wb = tx * (1 - ty), wc = (1 - tx) * ty, wd = tx * ty;
        for (int k = 0; k < ch; k++) px[k] = a[k] * wa + b[k] * wb + c[k] * wc + d[k] * wd;
    } else {
        long long xi = (long long)fx, yi = (long long)fy;
        xi = xi < 0 ? 0 : (xi > w - 1 ? w - 1 : xi);
        yi = yi < 0 ? 0 : (yi > h - 1 ? h - 1 : yi);
        memcpy(px, img + (size_t)(yi * w + xi) * ch, (size_t)ch * sizeof(double));
    }
    out[0] = px[0], out[1] = px[1], out[2] = px[2];
    if (ch == 6) out[3] = px[4], out[4] = px[5];
    else out[3] = pg[P_IMGF], out[4] = pg[P_IMGT];
    if (pg[P_ALPHA] != 0.0) {
        double clear = 1.0 - px[3];
        out[4] = out[4] >= clear ? out[4] : clear; /* np.maximum */
    }
    if (pg[P_ONCE] != 0.0 && !inside) {
        out[0] = out[1] = out[2] = out[3] = 0.0;
        out[4] = 1.0;
    }
}

/* RGBFT colour of a pigment at a point (patterns.evaluate for the kinds packed). */
static void pigment_in(const Scene *s, const double *pg, const double *p, double *out,
                       int depth) {
    const double *map = s->map + 6 * (size_t)pg[P_MAP];
    int kind = (int)pg[P_KIND], subs = pg[P_SUBS] != 0.0;
    if (kind == PK_SOLID) {
        memcpy(out, map + 1, 5 * sizeof(double));
        return;
    }
    if (depth >= PIGMENT_DEPTH) { /* deeper than whitted.py packs: black */
        memset(out, 0, 5 * sizeof(double));
        return;
    }
    double q[3];
    pattern_point(s, pg, p, q);
    if (kind == PK_IMAGE) {
        image_at(s, pg, q, out);
        return;
    }
    if (kind == PK_AVERAGE) { /* patterns.evaluate: the weighted mean of the map's pigments */
        double at[3], e[5], total = 0.0;
        if (pg[P_MAPAT] != 0.0) affine(pg + P_FWD, q, at);
        else memcpy(at, p, sizeof at);
        memset(out, 0, 5 * sizeof(double));
        for (int i = 0; i < (int)pg[P_N]; i++) {
            double w = map[6 * i];
            pigment_in(s, s->pig + (size_t)map[6 * i + 1] * PIG, at, e, depth + 1);
            for (int k = 0; k < 5; k++) out[k] += w * e[k];
            total += w;
        }
        if (total == 0.0) total = 1.0;
        for (int k = 0; k < 5; k++) out[k] /= total;
        return;
    }
    double v = pattern_value(s, pg, q);
    if (list_kind(kind)) { /* the entry the value names (patterns._select clips it) */
        int i = (int)v, n = (int)pg[P_N];
        const double *e = map + 6 * (i < n - 1 ? i : n - 1);
        if (subs) pigment_in(s, s->pig + (size_t)e[1] * PIG, p, out, depth + 1);
        else memcpy(out, e + 1, 5 * sizeof(double));
        return;
    }
    int lo, hi;
    double frac = blend(map, (int)pg[P_N], v, &lo, &hi);
    if (!subs) {
        for (int k = 0; k < 5; k++)
            out[k] = map[6 * lo + 1 + k] * (1.0 - frac) + map[6 * hi + 1 + k] * frac;
        return;
    }
    /* a pigment map (patterns._map): the two entries around the value, weighted */
    double at[3], a[5], b[5];
    if (pg[P_MAPAT] != 0.0) affine(pg + P_FWD, q, at);
    else memcpy(at, p, sizeof at);
    pigment_in(s, s->pig + (size_t)map[6 * lo + 1] * PIG, at, a, depth + 1);
    if (lo == hi) {
        double w = (1.0 - frac) + frac;
        for (int k = 0; k < 5; k++) out[k] = w * a[k];
        return;
    }
    pigment_in(s, s->pig + (size_t)map[6 * hi + 1] * PIG, at, b, depth + 1);
    for (int k = 0; k < 5; k++) out[k] = (1.0 - frac) * a[k] + frac * b[k];
}

static inline void pigment(const Scene *s, const double *pg, const double *p, double *out) {
    pigment_in(s, pg, p, out, 0);
}

/* A normal pattern's value for its slope (patterns._pattern_value), its slope map applied
 * (POV-Ray's Do_Slope_Map: a cubic Hermite curve between the entries around the value). */
static double normal_value(const Scene *s, const double *nr, const double *q) {
    double v = pattern_value(s, nr, q);
    int n = (int)nr[NR_NSLOPES];
    if (n == 0) return v;
    const double *map = s->map + 6 * (size_t)nr[NR_SLOPES];
    int lo, hi;
    double t = blend(map, n, v, &lo, &hi);
    double h1 = map[6 * lo + 1], s1 = map[6 * lo + 2], h2 = map[6 * hi + 1], s2 = map[6 * hi + 2];
    if (lo == hi) return h2;
    double tt = t * t;
    return tt * t * (s1 + s2 + 2.0 * (h1 - h2)) - tt * (2.0 * s1 + s2 + 3.0 * (h1 - h2)) +
           t * s1 + h1;
}

/* POV-Ray's sampling tetrahedron for a pattern's slope (patterns._PYRAMID) */
static const double PYRAMID[4][3] = {
    {0.9428090415820635, -1.0 / 3.0, 0.0},
    {-0.47140452079103173, -1.0 / 3.0, 0.8164965809277259},
    {-0.47140452079103173, -1.0 / 3.0, -0.8164965809277259},
    {0.0, 1.0, 0.0},
};
#define NORMAL_DELTA 0.02
#define SLOPE_GAIN (-5.0)

/* The unit normal after a `normal { … }` at world point p (patterns.perturb_normal, not a
 * normal_map): perturbed in pattern space, taken back to world space. */
static void perturb_in(const Scene *s, const double *nr, const double *p, const double *nw,
                       int unit, int depth, double *out);

/* A normal_map (patterns._normal_map) at pattern point q, normal n (pattern space): the
 * normals of the two entries around the pattern's value, blended by weight; an average's
 * every entry by its key's share. The entries' rows (map entries: key, row) are unit-less
 * perturbations (unit 0), as POV-Ray's blend takes them. */
static void normal_map(const Scene *s, const double *nr, const double *q, const double *n,
                       int depth, double *acc) {
    const double *map = s->map + 6 * (size_t)nr[NR_NMAPAT];
    int count = (int)nr[NR_NMAP];
    double e[3];
    acc[0] = acc[1] = acc[2] = 0.0;
    if (depth >= PIGMENT_DEPTH) { /* deeper than whitted.py packs: unbent */
        memcpy(acc, n, 3 * sizeof(double));
        return;
    }
    if ((int)nr[NR_KIND] == NK_AVERAGE) {
        double total = 0.0;
        for (int i = 0; i < count; i++) total += map[6 * i];
        if (total == 0.0) total = 1.0;
        for (int i = 0; i < count; i++) {
            perturb_in(s, s->nrm + (size_t)map[6 * i + 1] * NRM, q, n, 0, depth + 1, e);
            double w = map[6 * i] / total;
            for (int a = 0; a < 3; a++) acc[a] += w * e[a];
        }
        return;
    }
    int lo, hi;
    double f = blend(map, count, pattern_value(s, nr, q), &lo, &hi);
    for (int i = 0; i < count; i++) {
        if (i != lo && i != hi) continue;
        double w = (i == lo ? 1.0 - f : 0.0) + (i == hi ? f : 0.0);
        perturb_in(s, s->nrm + (size_t)map[6 * i + 1] * NRM, q, n, 0, depth + 1, e);
        for (int a = 0; a < 3; a++) acc[a] += w * e[a];
    }
}

static void perturb(const Scene *s, const double *nr, const double *p, const double *nw,
                    double *out) {
    perturb_in(s, nr, p, nw, 1, 0, out);
}

/* patterns.perturb_normal; `unit` off (a normal_map's entry): the result is left
 * unnormalised where no_bump_scale says so. */
static void perturb_in(const Scene *s, const double *nr, const double *p, const double *nw,
                       int unit, int depth, double *out) {
    double q[3], n[3];
    affine(nr + P_INV, p, q);
    const double *lin = nr + NR_LIN, *inv = nr + NR_LININV;
    int haslin = nr[NR_HASLIN] != 0.0;
    for (int j = 0; j < 3; j++)
        n[j] = haslin ? nw[0] * lin[j] + nw[1] * lin[3 + j] + nw[2] * lin[6 + j] : nw[j];
    if (nr[NR_KEEP] == 0.0) {
        double len = sqrt(dot(n, n));
        len = len > 1e-300 ? len : 1e-300;
        for (int j = 0; j < 3; j++) n[j] = n[j] / len;
    }
    double amount = nr[NR_DEPTH];
    int kind = (int)nr[NR_KIND];
    if (kind == NK_NONE || amount == 0.0) {
        memcpy(out, nw, 3 * sizeof(double));
        return;
    }
    const Noise *nz = &s->noise;
    int pk = (int)nr[P_KIND];
    int builtin = (kind == NK_SLOPE || kind == NK_MAP) && builtin_turbulence(pk);
    if (nr[P_HASTURB] != 0.0 && !builtin) {
        double dt[3]; /* patterns.turbulence_warp */
        dturbulence_at(nz, q, (int)nr[P_OCTAVES], nr[P_OMEGA], nr[P_LAMBDA], dt);
        for (int a = 0; a < 3; a++) q[a] = q[a] + dt[a] * nr[P_TURB + a];
    }
    switch (kind) {
    case NK_MAP:
    case NK_AVERAGE: {
        double acc[3];
        normal_map(s, nr, q, n, depth, acc);
        memcpy(n, acc, sizeof acc);
        unit = unit || kind != NK_AVERAGE; /* POV-Ray normalises a blend, not an average */
        break;
    }
    case NK_BUMPMAP: { /* its heights in the images' table, its settings in P_IMG on */
        BumpMap b = {s->img + (size_t)nr[P_IMG], (long long)nr[P_IMGW], (long long)nr[P_IMGH],
                     (int)nr[P_MAPTYPE], (int)nr[P_BM_INTERP], nr[P_ONCE] != 0.0,
                     nr[P_BM_INDEX] != 0.0};
        bump_map_perturb(&b, amount, q, n);
        break;
    }
    case NK_BUMPS: {
        double g[3];
        dnoise_at(nz, q, g);
        for (int a = 0; a < 3; a++) n[a] = n[a] + amount * g[a];
        break;
    }
    case NK_DENTS: {
        double g[3], v = noise_at(nz, q, (int)nr[P_GEN]);
        double k = pow(v, 3.0) * amount; /* numpy's ** 3 is pow */
        dnoise_at(nz, q, g);
        for (int a = 0; a < 3; a++) n[a] = n[a] + k * g[a];
        break;
    }
    case NK_WRINKLES: {
        double total[3] = {0.0, 0.0, 0.0}, scale = 1.0;
        for (int i = 0; i < 10; i++) {
            double r[3] = {q[0] * scale, q[1] * scale, q[2] * scale}, g[3];
            dnoise_at(nz, r, g);
            for (int a = 0; a < 3; a++) total[a] += fabs(g[a]) / scale;
            scale *= 2.0;
        }
        for (int a = 0; a < 3; a++) n[a] = n[a] + amount * total[a];
        break;
    }
    case NK_QUILTED: { /* the offset is added, not differentiated (normal.cpp's quilted) */
        double off[3];
        quilt_offset(nr, q, off);
        for (int a = 0; a < 3; a++) n[a] = n[a] + amount * off[a];
        break;
    }
    case NK_RIPPLES:
    case NK_WAVES: {
        double freq = nr[P_FREQ], phase = nr[P_PHASE];
        int count = (int)nr[NR_NWAVES];
        const double *w = s->map + 6 * (size_t)nr[NR_WAVES];
        for (int i = 0; i < count; i++, w += 6) {
            double d[3] = {q[0] - w[1], q[1] - w[2], q[2] - w[3]};
            double len = sqrt(dot(d, d)), sv;
            len = len > 0 ? len : 1.0;
            if (kind == NK_RIPPLES) sv = cycloidal(len * freq + phase) * amount / count;
            else sv = cycloidal(len * freq * w[0] + phase) * amount / (count * w[0]);
            for (int a = 0; a < 3; a++) n[a] = n[a] + (d[a] / len) * sv;
        }
        break;
    }
    default: { /* a pattern's slope: the tetrahedron's samples (patterns._slope) */
        double delta = nr[NR_ACC], g[3] = {0.0, 0.0, 0.0};
        for (int k = 0; k < 4; k++) {
            const double *u = PYRAMID[k];
            double r[3] = {q[0] + delta * u[0], q[1] + delta * u[1], q[2] + delta * u[2]};
            double v = normal_value(s, nr, r);
            for (int a = 0; a < 3; a++) g[a] += v * u[a];
        }
        if (delta != NORMAL_DELTA)
            for (int a = 0; a < 3; a++) g[a] = g[a] * (NORMAL_DELTA / delta);
        double gain = SLOPE_GAIN * amount;
        for (int a = 0; a < 3; a++) n[a] = n[a] + gain * g[a];
    }
    }
    if (haslin) {
        double m[3] = {n[0], n[1], n[2]};
        for (int j = 0; j < 3; j++) n[j] = m[0] * inv[j] + m[1] * inv[3 + j] + m[2] * inv[6 + j];
    }
    if (nr[NR_KEEP] != 0.0 && !unit) {
        memcpy(out, n, 3 * sizeof(double));
        return;
    }
    double len = sqrt(dot(n, n));
    if (len > 0)
        for (int a = 0; a < 3; a++) out[a] = n[a] / len;
    else
        memcpy(out, nw, 3 * sizeof(double));
}

static inline const double *texture_pigment(const Scene *s, const double *tx) {
    return s->pig + (size_t)tx[T_PIG] * PIG;
}

static inline double opacity(const double *c, int legacy) {
    if (legacy) {
        double m = c[0] > c[1] ? c[0] : c[1];
        m = m > c[2] ? m : c[2];
        return 1.0 - (c[3] * m + c[4]);
    }
    return 1.0 - c[3] - c[4];
}

static inline double fresnel_metallic(double cos_angle) {
    double c = cos_angle < -1.0 ? -1.0 : (cos_angle > 1.0 ? 1.0 : cos_angle);
    double x = fabs(acos(c)) / (M_PI / 2.0);
    double f = 0.014567225 / ((x - 1.12) * (x - 1.12)) - 0.011612903;
    return f < 0.0 ? 0.0 : (f > 1.0 ? 1.0 : f);
}

/* view: a ray seen through the surface, which POV-Ray fades whatever fade_power is (a
 * power of 0 halves it); a shadow ray is faded only for a positive power (trace.cpp) */
static double interior_fade(const Scene *s, const double *ob, double depth, int ch, int view) {
    double power = ob[O_FADEPOW], fd = ob[O_FADEDIST], fc = ob[O_FADECOL + ch];
    if ((power <= 0 && !view) || fabs(fd) <= EPSILON) return 1.0;
    double x = depth / fd;
    if (power >= 1000) return exp(-(1.0 - fc) * x);
    return fc + (1.0 - fc) / (1.0 + pow(fabs(x), power));
}

static inline double cubic_spline(double low, double high, double pos) {
    if (high == low) return pos >= high ? 1.0 : 0.0;
    double t = (pos - low) / (high - low);
    t = t < 0 ? 0 : (t > 1 ? 1 : t);
    if (pos < low) return 0.0;
    if (pos >= high) return 1.0;
    return (3.0 - 2.0 * t) * t * t;
}

/* A patterned texture resolved at p into the plain textures it shows, with their shares
 * (context.resolve_textures): a list pattern's entry, a map's two around the value, an
 * average's all by weight; at most MAX_LAYERS, appended from *n. */
static void resolve_texture(const Scene *s, int row, const double *p, double share, int depth,
                            int *rows, double *w, int *n) {
    const double *tx = s->tex + (size_t)row * TEX;
    if (tx[T_PAT] == 0.0) {
        if (*n < MAX_LAYERS) rows[*n] = row, w[(*n)++] = share;
        return;
    }
    if (depth >= PIGMENT_DEPTH) return;
    const double *pg = s->pig + (size_t)tx[T_PIG] * PIG;
    const double *map = s->map + 6 * (size_t)pg[P_MAP];
    int k = (int)pg[P_N], kind = (int)pg[P_KIND];
    if (kind == PK_AVERAGE) { /* patterns.entry_weights: keys / their sum */
        double total = 0.0;
        for (int i = 0; i < k; i++) total += map[6 * i];
        if (total == 0.0) total = 1.0;
        for (int i = 0; i < k; i++) {
            double wi = map[6 * i] / total;
            if (wi > 0.0) resolve_texture(s, (int)map[6 * i + 1], p, share * wi, depth + 1, rows, w, n);
        }
        return;
    }
    double q[3];
    pattern_point(s, pg, p, q);
    double v = pattern_value(s, pg, q);
    if (list_kind(kind)) { /* a list pattern: the entry its value names */
        int i = (int)v < 0 ? 0 : ((int)v > k - 1 ? k - 1 : (int)v);
        resolve_texture(s, (int)map[6 * i + 1], p, share, depth + 1, rows, w, n);
        return;
    }
    int lo, hi;
    double frac = blend(map, k, v, &lo, &hi);
    if (lo == hi) {
        double wi = (1.0 - frac) + frac;
        if (wi > 0.0) resolve_texture(s, (int)map[6 * lo + 1], p, share * wi, depth + 1, rows, w, n);
        return;
    }
    if (1.0 - frac > 0.0)
        resolve_texture(s, (int)map[6 * lo + 1], p, share * (1.0 - frac), depth + 1, rows, w, n);
    if (frac > 0.0) resolve_texture(s, (int)map[6 * hi + 1], p, share * frac, depth + 1, rows, w, n);
}

/* What a plain texture's layers let through toward a light (lights.shadow_filter), t
 * multiplied by it: each layer's filter and transmit, brightened by faked caustics,
 * 1 + |N.L|^exponent about the layer's normal turned against the ray (`against`). */
static void layers_through(const Scene *s, const double *tx, const double *pt,
                           const double *against, double caustics, const double *ldir,
                           double *t) {
    const double *ly = tx;
    for (int k = 0; ly && k < MAX_LAYERS; k++) {
        double c[5];
        pigment(s, texture_pigment(s, ly), pt, c);
        for (int i = 0; i < 3; i++) t[i] *= c[3] * c[i] + c[4];
        if (caustics != 0.0) {
            double ln[3];
            if (ly[T_NRM] >= 0) perturb(s, s->nrm + (size_t)ly[T_NRM] * NRM, pt, against, ln);
            else memcpy(ln, against, sizeof ln);
            double f = 1.0 + pow(fabs(dot(ln, ldir)), caustics);
            for (int i = 0; i < 3; i++) t[i] *= f;
        }
        ly = ly[T_NEXT] < 0 ? NULL : s->tex + (size_t)ly[T_NEXT] * TEX;
    }
}

/* Light let through from p toward a light at distance `dist` (integrate.shadow_filter); cls:
 * the shadow ray's class for the view masks (-1: none). */
/* The texture row shown at a hit: a triangle's own (a mesh's per-face textures), else the
 * object's, and where the ray leaves the object (`leaving`) its interior_texture
 * (context.texture_of). */
static inline int hit_texture(const Scene *s, const Hit *h, int leaving) {
    const double *ob = s->obj + (size_t)h->obj * OBJ;
    if (leaving && ob[O_INSIDE_TEX] >= 0) return (int)ob[O_INSIDE_TEX];
    if (h->tri >= 0) return (int)s->tri[(size_t)h->tri * TRI + TR_TEX];
    return (int)ob[O_TEX];
}

static void shadow_filter(Scene *s, const double *p, const double *ldir, double dist,
                          int cls, double *mult) {
    double tol = 1e-6 * dist;
    double tmax = dist * (1.0 - 1e-9) - (SHADOW_TOLERANCE < tol ? SHADOW_TOLERANCE : tol);
    s->shadow_rays++;
    mult[0] = mult[1] = mult[2] = 1.0;
    if (!s->anytrans) {
        if (occluded(s, p, ldir, tmax, cls)) mult[0] = mult[1] = mult[2] = 0.0;
        return;
    }
    double o[3] = {p[0], p[1], p[2]}, remaining = tmax;
    for (int k = 0; k < MAX_SHADOW_CROSSINGS; k++) {
        Hit h;
        if (!closest(s, o, ldir, remaining, SKIP_NO_SHADOW, cls, &h)) return;
        const double *ob = s->obj + (size_t)h.obj * OBJ;
        double pt[3], n[3];
        int leaving = 0, normal_known = ob[O_INSIDE_TEX] >= 0;
        if (normal_known) { /* which texture the light crosses */
            hit_normal(s, o, ldir, &h, n);
            leaving = dot(n, ldir) > 0;
        }
        int texture = hit_texture(s, &h, leaving);
        const double *tx = s->tex + (size_t)texture * TEX;
        for (int i = 0; i < 3; i++) pt[i] = o[i] + h.t * ldir[i];
        if (!(int)tx[T_TRANS]) {
            mult[0] = mult[1] = mult[2] = 0.0;
            return;
        }
        if (!normal_known) {
            hit_normal(s, o, ldir, &h, n);
            leaving = dot(n, ldir) > 0;
        }
        double t[3] = {1.0, 1.0, 1.0}, against[3];
        for (int i = 0; i < 3; i++) against[i] = leaving ? -n[i] : n[i];
        if (tx[T_PAT] != 0.0) { /* the shares of the textures shown there that let light by */
            int rows[MAX_LAYERS], nleaf = 0;
            double share[MAX_LAYERS];
            resolve_texture(s, texture, pt, 1.0, 0, rows, share, &nleaf);
            t[0] = t[1] = t[2] = 0.0;
            for (int k = 0; k < nleaf; k++) {
                const double *lt = s->tex + (size_t)rows[k] * TEX;
                if (!(int)lt[T_TRANS]) continue;
                double tk[3] = {1.0, 1.0, 1.0};
                layers_through(s, lt, pt, against, ob[O_CAUSTICS], ldir, tk);
                for (int i = 0; i < 3; i++) t[i] += share[k] * tk[i];
            }
        } else {
            layers_through(s, tx, pt, against, ob[O_CAUSTICS], ldir, t);
        }
        double big = 0.0;
        for (int i = 0; i < 3; i++) {
            double f = t[i];
            if (leaving) f *= interior_fade(s, ob, h.t, i, 0);
            mult[i] *= f;
            if (fabs(mult[i]) > big) big = fabs(mult[i]);
        }
        o[0] = pt[0], o[1] = pt[1], o[2] = pt[2];
        remaining -= h.t;
        if (!(big > EPSILON)) return;
    }
    mult[0] = mult[1] = mult[2] = 0.0;
}

/* The interiors a ray is in, innermost last (runtime/interiors.py, POV-Ray's interior
 * list): each with its ior. */
#define INSIDE_DEPTH 8
typedef struct {
    int n;
    int id[INSIDE_DEPTH];
    double ior[INSIDE_DEPTH];
} Inside;

/* Crossing a surface of interior iid (ior `here`), as runtime/interiors.cross: was the ray
 * inside it, the ratio of the iors on both sides, the list past the surface. */
static int cross(const Inside *in, int iid, double here, int side_leaving, double *ratio,
                 Inside *after) {
    Inside st = *in;
    if (st.n == 0 && side_leaving) { /* started inside: as if it had entered */
        st.n = 1, st.id[0] = iid, st.ior[0] = here;
    }
    int member = 0;
    for (int k = 0; k < st.n; k++) member |= st.id[k] == iid;
    int innermost = member && st.id[st.n - 1] == iid;
    double outer = st.n > 0 ? st.ior[st.n - 1] : 1.0;
    after->n = 0;
    for (int k = 0; k < st.n; k++)
        if (!member || st.id[k] != iid) {
            after->id[after->n] = st.id[k], after->ior[after->n] = st.ior[k];
            after->n++;
        }
    if (!member && after->n < INSIDE_DEPTH) {
        after->id[after->n] = iid, after->ior[after->n] = here;
        after->n++;
    }
    double beyond = 1.0;
    if (innermost && after->n > 0) beyond = after->ior[after->n - 1];
    if (st.n == 0) *ratio = 1.0 / here;
    else if (innermost) *ratio = here / beyond;
    else if (member) *ratio = 1.0;
    else *ratio = outer / here;
    return member;
}

static void trace(Scene *s, const double *o, const double *d, double weight, int level,
                  int skip, int continued, int cls, const Inside *in, double *out);

/* POV-Ray's relative ior for fresnel reflection (ComputeRelativeIOR; interiors.cross):
 * entering I: I over the ior outside; leaving I alone: 1/I; else the innermost's over I. */
static double fresnel_ior(const Inside *in, int iid, double here, int side_leaving) {
    int count = in->n, member = 0;
    if (count == 0 && side_leaving) return 1.0 / here; /* started inside: as if it entered */
    for (int k = 0; k < count; k++) member |= in->id[k] == iid;
    double outer = count > 0 ? in->ior[count - 1] : 1.0;
    if (count == 0) return here;
    if (member) return count == 1 ? 1.0 / here : outer / here;
    return here / outer;
}

static int transmit(Scene *s, const double *p, const double *d, const double *top,
                    const double *raw, const double *tx, const double *ob, const double *fil,
                    const Hit *h, double weight, int level, int skip, int leaving, int cls,
                    const Inside *in, double *out);

/* A light as a hit sees it, for every layer of its texture: the direction, the colour that
 * arrives (attenuated, shadowed), and whether the layers' finishes take it at all. */
typedef struct {
    double ld[3], lc[3], cos_l;
    int ok, front, shadowless;
} LightAt;

#define LIGHTS_ON_STACK 16

/* An area light's sub-lights as lights.shadow samples them: the four corners of a region of
 * the grid, split into quarters (sharing their middle row and column) while the level is
 * below `adaptive` or two neighbouring corners differ by more than 0.1; a region not split
 * adds the mean of its corners. Each sub-light is traced once (cache). */
typedef struct {
    Scene *s;
    const double *lt, *p;
    double ax1[3], ax2[3];
    int n1, n2;
    double (*f)[3];
    unsigned char *done;
} Area;

static const double *sub_light(Area *a, int u, int v) {
    int k = u * a->n2 + v;
    if (a->done[k]) return a->f[k];
    const double *lt = a->lt;
    double cu, cv; /* shading.area_offsets */
    if ((int)lt[L_CIRCULAR] && a->n1 > 1 && a->n2 > 1) {
        double ju = (double)u / (a->n1 - 1) - 0.5 + 0.001, jv = (double)v / (a->n2 - 1) - 0.5 + 0.001;
        double scale = (fabs(ju) > fabs(jv) ? fabs(ju) : fabs(jv)) / hypot(ju, jv);
        cu = ju * scale, cv = jv * scale;
    } else {
        cu = a->n1 > 1 ? (double)u / (a->n1 - 1) - 0.5 : 0.0;
        cv = a->n2 > 1 ? (double)v / (a->n2 - 1) - 0.5 : 0.0;
    }
    double c[3], to[3];
    for (int i = 0; i < 3; i++) {
        if ((int)lt[L_ORIENT]) c[i] = lt[L_POS + i] + cu * a->ax1[i] + cv * a->ax2[i];
        else c[i] = lt[L_POS + i] + (cu * a->ax1[i] + cv * a->ax2[i]);
        to[i] = c[i] - a->p[i];
    }
    double depth = sqrt(dot(to, to)), dd = depth > 0 ? depth : 1.0;
    for (int i = 0; i < 3; i++) to[i] /= dd;
    /* no view-mask class: the masks know the light's centre only */
    shadow_filter(a->s, a->p, to, depth, -1, a->f[k]);
    a->done[k] = 1;
    return a->f[k];
}

static void area_region(Area *a, int u1, int v1, int u2, int v2, int level, double weight,
                        double *out) {
    const double *c[4] = {sub_light(a, u1, v1), sub_light(a, u2, v1), sub_light(a, u1, v2),
                          sub_light(a, u2, v2)};
    int divisible = u2 - u1 > 1 || v2 - v1 > 1;
    int differ = level < (int)a->lt[L_ADAPTIVE];
    static const int pairs[4][2] = {{0, 1}, {1, 3}, {3, 2}, {2, 0}};
    for (int k = 0; k < 4 && !differ; k++) {
        const double *x = c[pairs[k][0]], *y = c[pairs[k][1]];
        differ = fabs(x[0] - y[0]) + fabs(x[1] - y[1]) + fabs(x[2] - y[2]) > 0.1;
    }
    if (!(divisible && differ)) {
        for (int i = 0; i < 3; i++) out[i] += (weight / 4.0) * (c[0][i] + c[1][i] + c[2][i] + c[3][i]);
        return;
    }
    double mu = (u1 + u2) / 2.0, mv = (v1 + v2) / 2.0;
    int lo_u = (int)floor(mu), hi_u = (int)ceil(mu), lo_v = (int)floor(mv), hi_v = (int)ceil(mv);
    area_region(a, u1, v1, lo_u, lo_v, level + 1, weight / 4.0, out);
    area_region(a, hi_u, v1, u2, lo_v, level + 1, weight / 4.0, out);
    area_region(a, u1, hi_v, lo_u, v2, level + 1, weight / 4.0, out);
    area_region(a, hi_u, hi_v, u2, v2, level + 1, weight / 4.0, out);
}

/* The share of an area light reaching p (lights.shadow); ld: the unit way to its centre. */
static void area_shadow(Scene *s, const double *lt, const double *p, const double *ld,
                        double *f) {
    Area a = {.s = s, .lt = lt, .p = p, .n1 = (int)lt[L_N1], .n2 = (int)lt[L_N2]};
    size_t k = (size_t)a.n1 * (size_t)a.n2;
    a.f = malloc(k * sizeof *a.f);
    a.done = calloc(k, 1);
    f[0] = f[1] = f[2] = 0.0;
    if (a.f == NULL || a.done == NULL) {
        free(a.f), free(a.done);
        return;
    }
    if ((int)lt[L_ORIENT]) { /* shading.area_centres: axes square to the way to the light */
        const double *a1 = lt + L_A1;
        double length = sqrt(dot(a1, a1));
        int vertical = fabs(fabs(ld[2]) - 1.0) < 0.01;
        double helper[3] = {0.0, vertical ? 1.0 : 0.0, vertical ? 0.0 : 1.0};
        cross3(ld, helper, a.ax1);
        double n1 = sqrt(dot(a.ax1, a.ax1));
        for (int i = 0; i < 3; i++) a.ax1[i] /= n1;
        cross3(ld, a.ax1, a.ax2);
        double n2 = sqrt(dot(a.ax2, a.ax2));
        for (int i = 0; i < 3; i++) a.ax2[i] /= n2;
        for (int i = 0; i < 3; i++) a.ax1[i] *= length, a.ax2[i] *= length;
    } else {
        memcpy(a.ax1, lt + L_A1, sizeof a.ax1);
        memcpy(a.ax2, lt + L_A2, sizeof a.ax2);
    }
    area_region(&a, 0, 0, a.n1 - 1, a.n2 - 1, 0, 1.0, f);
    free(a.f), free(a.done);
}

static void light_at(Scene *s, const double *lt, int l, const double *p, const double *n,
                     int lit, int dbl, int back_lit, int cls, LightAt *la) {
    double *ld = la->ld;
    ld[0] = lt[L_POS] - p[0], ld[1] = lt[L_POS + 1] - p[1], ld[2] = lt[L_POS + 2] - p[2];
    double depth = sqrt(dot(ld, ld));
    if (depth > 0) ld[0] /= depth, ld[1] /= depth, ld[2] /= depth;
    double att = 1.0;
    if ((int)lt[L_KIND] == 1) { /* spotlight */
        double ct = dot(ld, lt + L_AXIS);
        ct = depth > 0 ? -ct : ct;
        att = ct > 0 ? pow(ct, lt[L_TIGHT]) : 0.0;
        if (lt[L_COSR] > 0 && ct < lt[L_COSR]) att *= cubic_spline(lt[L_COSF], lt[L_COSR], ct);
    }
    double power = lt[L_FADEPOW], fd = lt[L_FADEDIST];
    if (power > 0 && fabs(fd) > EPSILON) {  /* as shading.attenuation: both set, or no fade */
        double fade = 2.0 / (1.0 + pow(fabs(depth) / fd, power));
        if (att > 0) att *= fade;
    }
    double big = 0.0;
    for (int i = 0; i < 3; i++) {
        la->lc[i] = att * lt[L_COL + i];
        if (fabs(la->lc[i]) > big) big = fabs(la->lc[i]);
    }
    la->cos_l = dot(n, ld);
    la->front = la->cos_l >= EPSILON;
    la->shadowless = (int)lt[L_SHADOWLESS];
    la->ok = lit && (la->front || dbl || back_lit) && big > EPSILON;
    if (la->ok && !la->shadowless) {
        double f[3];
        /* from a camera ray's hit, the shadow ray stays inside the view's half spaces that
         * hold the light: its own class */
        if ((int)lt[L_AREA]) area_shadow(s, lt, p, ld, f);
        else shadow_filter(s, p, ld, depth, cls == 0 ? 1 + l : -1, f);
        la->lc[0] *= f[0], la->lc[1] *= f[1], la->lc[2] *= f[2];
    }
}

/* shading.grain: a deterministic random number in [0, 1) per surface point (crand) */
static inline double grain(const double *p) {
    double h = sin(p[0] * 12.9898 + p[1] * 78.233 + p[2] * 37.719) * 43758.5453;
    return h - floor(h);
}

static const double IRID_WAVELENGTHS[3] = {0.70, 0.52, 0.48};

/* The thin-film factor of an iridescent finish toward direction l (shading.iridescence). */
static void iridescence(const Scene *s, const double *tx, const double *n, const double *d,
                        const double *l, const double *p, double *out) {
    double amount = tx[T_IRID], film = tx[T_IRID + 1], turb = tx[T_IRID + 2];
    double cos_l = fabs(dot(n, l)), cos_e = fabs(dot(n, d));
    if (turb != 0) film = film * (1.0 + turb * (2.0 * turbulence_at(&s->noise, p, 5, 0.5, 2.0, 2) - 1.0));
    double phase = 2.0 * M_PI * film * (cos_l + cos_e);
    for (int i = 0; i < 3; i++) out[i] = 1.0 + amount * cos(phase / IRID_WAVELENGTHS[i]);
}

/* One layer's own light (ambient, emission, each light's diffuse, diffuse_back, crand,
 * highlights and iridescence) into acc (integrate.shade_texture, shading.light_terms). */
static void layer_light(const Scene *s, const double *tx, const double *col, double op,
                        const double *p, const double *d, const double *n, int dbl,
                        const LightAt *la, double *acc) {
    const double *hd = s->h, *pig = col;
    for (int i = 0; i < 3; i++)
        acc[i] = pig[i] * (tx[T_AMB + i] * hd[H_AMB + i] + tx[T_EMIS + i]) * op;
    double crand = tx[T_CRAND], rnd = crand > 0 ? grain(p) : 0.0;
    double diffuse = tx[T_DIFF], dback = tx[T_DBACK];
    for (int l = 0; l < s->nlight; l++) {
        const LightAt *a = la + l;
        if (!a->ok) continue;
        const double *ld = a->ld, *lc = a->lc;
        /* the layer's (perhaps bumpy) normal decides the side; the smooth one which lights
         * were tested (light_at) */
        double cos_l = dot(n, ld);
        int front = cos_l >= EPSILON;
        int lit = front || dbl, back = !front && !dbl && dback != 0.0;
        double term[3] = {0.0, 0.0, 0.0};
        if ((diffuse > 0 || dback > 0) && (lit || back)) {
            double c = fabs(cos_l), dif = back ? dback : diffuse;
            double in = (tx[T_BRIL] == 1.0 ? c : pow(c, tx[T_BRIL])) * (dif > 0 ? dif : 0.0) * op;
            if (crand > 0) in = in - rnd * crand;
            for (int i = 0; i < 3; i++) term[i] += in * pig[i] * lc[i];
        }
        /* POV-Ray gives a shadowless (fill) light no highlights, nor the far side */
        if (!a->shadowless && lit) {
            double metal = tx[T_METAL];
            double tint[3] = {1.0, 1.0, 1.0};
            if (metal > 0 && (tx[T_PHONG] > 0 || tx[T_SPEC] > 0)) {
                double f = fresnel_metallic(cos_l);
                for (int i = 0; i < 3; i++) tint[i] = 1.0 + metal * (1.0 - f) * (pig[i] - 1.0);
            }
            if (tx[T_PHONG] > 0) {
                double r[3];
                mirror(d, n, r);
                double c = dot(r, ld);
                if (c > 0 && (tx[T_PHSIZE] < 60 || c > 0.0008)) {
                    double in = tx[T_PHONG] * pow(c, tx[T_PHSIZE]);
                    for (int i = 0; i < 3; i++) term[i] += in * lc[i] * tint[i];
                }
            }
            if (tx[T_SPEC] > 0) {
                double half[3] = {0.5 * (-d[0] + ld[0]), 0.5 * (-d[1] + ld[1]),
                                  0.5 * (-d[2] + ld[2])};
                double len = sqrt(dot(half, half));
                double c = dot(half, n) / (len > 0 ? len : 1.0);
                if (len > 0 && c > 0) {
                    double rough = tx[T_ROUGH];
                    double in = tx[T_SPEC] * pow(c, rough != 0 ? 1.0 / rough : 0.0);
                    for (int i = 0; i < 3; i++) term[i] += in * lc[i] * tint[i];
                }
            }
        }
        if (tx[T_IRID] > 0) {
            double f[3];
            iridescence(s, tx, n, d, ld, p, f);
            for (int i = 0; i < 3; i++) term[i] = term[i] * f[i];
        }
        for (int i = 0; i < 3; i++) acc[i] += term[i];
    }
}

/* A layer's reflectivity (shading.reflectivity): 1 with refl and the weight factor set
 * when it reflects, 0 when its finish has no reflection. */
static int layer_reflection(const Scene *s, const double *tx, const double *col,
                            const double *d, const double *n, double rel_ior, double *refl,
                            double *wfac) {
    const double *rmin = tx + T_RMIN, *rmax = tx + T_RMAX;
    int reflects = 0;
    for (int i = 0; i < 3; i++) reflects |= rmax[i] > 0 || rmin[i] > 0;
    refl[0] = refl[1] = refl[2] = 0.0;
    if (!reflects) return 0;
    double cos_i = -dot(d, n);
    *wfac = 0.0;
    double frac;
    if (tx[T_FRESNEL] != 0.0) { /* POV-Ray's ComputeReflectivity with fresnel */
        double sqx = rel_ior * rel_ior + cos_i * cos_i - 1.0;
        double g = sqrt(sqx > 0 ? sqx : 0.0), f = 1.0;
        if (sqx > 0) {
            double gm = g - cos_i, gp = g + cos_i;
            f = 0.5 * (gm * gm) / (gp * gp);
            double u = cos_i * gp - 1.0, v = cos_i * gm + 1.0;
            f = f * (1.0 + (u * u) / (v * v));
            f = f != f ? 1.0 : (f < 0.0 ? 0.0 : (f > 1.0 ? 1.0 : f));
        }
        frac = f;
    } else {
        for (int i = 0; i < 3; i++) {
            if (rmax[i] > *wfac) *wfac = rmax[i];
            if (rmin[i] > *wfac) *wfac = rmin[i];
        }
        frac = 1.0 - cos_i;
        if (fabs(tx[T_FALLOFF] - 1.0) > EPSILON) frac = pow(frac < 0 ? 0 : frac, tx[T_FALLOFF]);
    }
    double rm = tx[T_RMETAL], fm = rm != 0.0 ? fresnel_metallic(cos_i) : 0.0;
    for (int i = 0; i < 3; i++) {
        refl[i] = frac * rmax[i] + (1.0 - frac) * rmin[i];
        if (tx[T_FRESNEL] != 0.0 && refl[i] > *wfac) *wfac = refl[i];
        if (rm != 0.0) refl[i] *= 1.0 + rm * (1.0 - fm) * (col[i] - 1.0);
    }
    return 1;
}

/* The unit mirror direction of d about a layer's normal nl (shading.reflect): where a bumpy
 * normal would send it into the surface (behind the smooth normal raw), POV-Ray's fix. */
static void reflect_dir(const double *d, const double *nl, const double *raw, double *out) {
    mirror(d, nl, out);
    double k = dot(out, raw);
    if (k < 0) {
        if (dot(out, nl) < 0) mirror(d, raw, out);
        else
            for (int i = 0; i < 3; i++) out[i] = out[i] - 2.0 * k * raw[i];
    }
    normalize3(out);
}

/* The colour of a hit (integrate.shade_texture): the texture's layers from the top, each
 * lit and seen through the filter of those above it; each layer's reflection and the light
 * through them all traced after. */
/* A reflected ray to trace, after the transmitted one; `top`: about the top layer's normal
 * (total internal reflection replaces those) */
typedef struct {
    double refl[3], weight, ex, dir[3];
    int top;
} Mirror;

/* A plain texture's layers at a hit (integrate.shade_texture): each lit and seen through
 * the filter of those above (added to out), what they let through (fil), their reflections
 * appended to m (at most MAX_LAYERS), the top layer's normal (top). */
static void shade_layers(Scene *s, const double *tx, const double *p, const double *d,
                         const double *n, const double *ob, double weight, int level,
                         int leaving, int dbl, const LightAt *la, const Inside *in,
                         double *rel_ior, double *out, double *fil, double *top, Mirror *m,
                         int *nm) {
    double trans = 1.0;
    const double *ly = tx;
    for (int k = 0; ly && k < MAX_LAYERS; k++) {
        if (!(trans > s->bailout)) break;
        double col[5], acc[3], refl[3], wfac = 0.0, bumped[3];
        const double *nl = n; /* the layer's normal */
        if (ly[T_NRM] >= 0) {
            perturb(s, s->nrm + (size_t)ly[T_NRM] * NRM, p, n, bumped);
            nl = bumped;
        }
        if (k == 0) memcpy(top, nl, 3 * sizeof(double));
        pigment(s, texture_pigment(s, ly), p, col);
        double op = opacity(col, s->legacy);
        layer_light(s, ly, col, op, p, d, nl, dbl, la, acc);
        for (int i = 0; i < 3; i++) out[i] += acc[i] * fil[i];
        if (ly[T_FRESNEL] != 0.0 && *rel_ior != *rel_ior)
            *rel_ior = fresnel_ior(in, (int)ob[O_INTERIOR], ob[O_IOR], leaving && level != 1);
        int reflects = layer_reflection(s, ly, col, d, nl, *rel_ior, refl, &wfac);
        if (reflects && *nm < MAX_LAYERS) {
            double big = fabs(refl[0]);
            if (fabs(refl[1]) > big) big = fabs(refl[1]);
            if (fabs(refl[2]) > big) big = fabs(refl[2]);
            if (big > 0) {
                double *rd = m[*nm].dir;
                reflect_dir(d, nl, n, rd);
                if (ly[T_IRID] > 0) { /* the film tints the reflection too */
                    double f[3];
                    iridescence(s, ly, nl, d, rd, p, f);
                    for (int i = 0; i < 3; i++) refl[i] = refl[i] * f[i];
                }
                m[*nm].top = fabs(nl[0] - top[0]) <= EPSILON && fabs(nl[1] - top[1]) <= EPSILON &&
                             fabs(nl[2] - top[2]) <= EPSILON;
                memcpy(m[*nm].refl, refl, sizeof refl);
                m[*nm].weight = weight * trans * wfac;
                m[(*nm)++].ex = ly[T_REXP];
            }
        }
        for (int i = 0; i < 3; i++) {
            fil[i] *= col[3] * col[i] + col[4];
            if ((int)ly[T_CONSERVE] && reflects) fil[i] *= (1.0 - refl[i]) < 1.0 ? 1.0 - refl[i] : 1.0;
        }
        trans = fabs(dot(fil, GREY));
        if (trans > 1.0) trans = 1.0;
        ly = ly[T_NEXT] < 0 ? NULL : s->tex + (size_t)ly[T_NEXT] * TEX;
    }
}

static void shade(Scene *s, const double *o, const double *d, const Hit *h, double weight,
                  int level, int skip, int cls, const Inside *in, double *out) {
    const double *ob = s->obj + (size_t)h->obj * OBJ;
    double p[3], n[3];
    for (int i = 0; i < 3; i++) p[i] = o[i] + h->t * d[i];
    hit_normal(s, o, d, h, n);
    int leaving = dot(n, d) > 0, texture = hit_texture(s, h, leaving);
    const double *tx = s->tex + (size_t)texture * TEX;
    if (leaving) n[0] = -n[0], n[1] = -n[1], n[2] = -n[2];
    out[0] = out[1] = out[2] = 0.0;
    LightAt on_stack[LIGHTS_ON_STACK], *la = on_stack;
    if (s->nlight > LIGHTS_ON_STACK && !(la = malloc((size_t)s->nlight * sizeof *la))) return;
    int lit = (int)tx[T_LIT], dbl = (int)ob[O_DOUBLE];
    double rel_ior = NAN; /* found when a layer's fresnel reflection asks for it */
    /* a bumpy normal may face a light the smooth one does not: those are tested too */
    int any_side = (int)tx[T_BACKLIT] || (int)tx[T_BUMPY];
    for (int l = 0; l < s->nlight; l++)
        light_at(s, s->light + (size_t)l * LIT, l, p, n, lit, dbl, any_side, cls, la + l);
    Mirror mirrored[MAX_LAYERS];
    int nmirrored = 0;
    double fil[3] = {1.0, 1.0, 1.0}, top[3] = {n[0], n[1], n[2]};
    if (tx[T_PAT] == 0.0) {
        shade_layers(s, tx, p, d, n, ob, weight, level, leaving, dbl, la, in, &rel_ior, out, fil,
                     top, mirrored, &nmirrored);
    } else {
        /* each texture shown there shaded whole, then added up by share: colour, filter
         * and reflections (POV-Ray blends a texture_map's fully lit textures); the light
         * goes through about the smooth normal */
        int rows[MAX_LAYERS], nleaf = 0;
        double share[MAX_LAYERS], other[3];
        resolve_texture(s, texture, p, 1.0, 0, rows, share, &nleaf);
        fil[0] = fil[1] = fil[2] = 0.0;
        for (int k = 0; k < nleaf; k++) {
            double res[3] = {0.0, 0.0, 0.0}, fk[3] = {1.0, 1.0, 1.0};
            int first = nmirrored;
            shade_layers(s, s->tex + (size_t)rows[k] * TEX, p, d, n, ob, weight * share[k], level,
                         leaving, dbl, la, in, &rel_ior, res, fk, other, mirrored, &nmirrored);
            for (int i = 0; i < 3; i++) {
                out[i] += share[k] * res[i];
                fil[i] += share[k] * fk[i];
            }
            for (int m = first; m < nmirrored; m++)
                for (int i = 0; i < 3; i++) mirrored[m].refl[i] *= share[k];
        }
    }
    if (la != on_stack) free(la);
    /* total internal reflection carries the mirrored light itself, so the layers'
     * reflections about the same normal (the top layer's) are then not traced */
    int tir = transmit(s, p, d, top, n, tx, ob, fil, h, weight, level, skip, leaving, cls, in,
                       out);
    for (int k = 0; k < nmirrored; k++) {
        double rc[3];
        if (tir && mirrored[k].top) continue;
        trace(s, p, mirrored[k].dir, mirrored[k].weight, level, SKIP_NO_REFLECTION, 0, -1, in,
              rc);
        double ex = mirrored[k].ex;
        if (ex != 0.0 && 1.0 / ex != 1.0) {
            for (int i = 0; i < 3; i++) rc[i] = pow(rc[i] < 0 ? 0 : rc[i], 1.0 / ex);
        }
        for (int i = 0; i < 3; i++) out[i] += mirrored[k].refl[i] * rc[i];
    }
}

/* The ray through a transparent surface, added to out: straight on where the ior is 1,
 * refracted otherwise about the top layer's normal turned toward the ray (raw: the smooth
 * normal, for the reflection fix); returns 1 where it reflected totally instead. */
static int transmit(Scene *s, const double *p, const double *d, const double *top,
                    const double *raw, const double *tx, const double *ob, const double *fil,
                    const Hit *h, double weight, int level, int skip, int leaving, int cls,
                    const Inside *in, double *out) {
    if (!(int)tx[T_TRANS]) return 0;
    double trans = fabs(dot(fil, GREY));
    if (trans > 1.0) trans = 1.0;
    if (!(trans > s->bailout)) return 0;
    double big = fabs(fil[0]);
    if (fabs(fil[1]) > big) big = fabs(fil[1]);
    if (fabs(fil[2]) > big) big = fabs(fil[2]);
    double w = weight * big, ratio;
    Inside past;
    /* not for camera rays (hits at level 1): the objects holding the camera bend and fade
     * nothing here (whitted.reasons), so an empty list there says the ray enters */
    int inside = cross(in, (int)ob[O_INTERIOR], ob[O_IOR], leaving && level != 1, &ratio, &past);
    int straight = fabs(ratio - 1.0) < EPSILON;
    double td[3] = {d[0], d[1], d[2]}, mult[3] = {fil[0], fil[1], fil[2]};
    int tir = 0;
    if (!straight) {
        double n[3] = {top[0], top[1], top[2]};
        if (dot(d, top) > 0) n[0] = -n[0], n[1] = -n[1], n[2] = -n[2];
        double n_cos = -dot(d, n);
        double tt = 1.0 + ratio * ratio * (n_cos * n_cos - 1.0);
        if (tt < 0) { /* total internal reflection: mirrored, not filtered */
            reflect_dir(d, top, raw, td);
            mult[0] = mult[1] = mult[2] = 1.0;
            tir = 1;
        } else {
            double t2 = ratio * n_cos - sqrt(tt);
            for (int i = 0; i < 3; i++) td[i] = ratio * d[i] + t2 * n[i];
            double len = sqrt(dot(td, td));
            len = len > 1e-300 ? len : 1e-300;
            td[0] /= len, td[1] /= len, td[2] /= len;
        }
    }
    if (inside)
        for (int i = 0; i < 3; i++) mult[i] *= interior_fade(s, ob, h->t, i, 1);
    double tc[3];
    /* a totally reflected ray stays where it was (POV-Ray reflects the incoming ray) */
    trace(s, p, td, w, level, skip, straight, straight ? cls : -1, tir ? in : &past, tc);
    for (int i = 0; i < 3; i++) out[i] += mult[i] * tc[i];
    return tir;
}

/* What a ray that hits nothing sees: sky_sphere layers over the background
 * (integrate.sky). */
static void sky(Scene *s, const double *d, double *out) {
    if (s->legacy && s->nsky) { /* before 3.7: the layers' accumulated filter/transmit */
        double acc[5] = {1.0, 1.0, 1.0, 1.0, 1.0}, pass = 1.0;
        for (int l = 0; l < s->nsky; l++) {
            double c[5];
            pigment(s, s->pig + (size_t)(s->npig - s->nsky + l) * PIG, d, c);
            double op = pass * (1.0 - c[3] - c[4]);
            for (int k = 0; k < 3; k++) out[k] += c[k] * op;
            for (int k = 0; k < 5; k++) acc[k] *= c[k];
            pass = fabs(acc[3]) + fabs(acc[4]);
        }
        for (int k = 0; k < 3; k++) out[k] += s->h[H_BG + k] * (acc[k] * acc[3] + acc[4]);
        return;
    }
    /* 3.7: each layer filters those behind it */
    double fil[3] = {1.0, 1.0, 1.0};
    for (int l = 0; l < s->nsky; l++) {
        double c[5];
        pigment(s, s->pig + (size_t)(s->npig - s->nsky + l) * PIG, d, c);
        double op = 1.0 - c[3] - c[4];
        for (int k = 0; k < 3; k++) {
            out[k] += c[k] * op * fil[k];
            fil[k] *= c[3] * c[k] + c[4];
        }
    }
    for (int k = 0; k < 3; k++) out[k] += s->h[H_BG + k] * fil[k];
}

/* Mean ground-fog density between heights a and b (fog.ground_fog_density). */
static double ground_fog_density(const Scene *s, double a, double b) {
    if (a <= 0 && b <= 0) return 1.0;
    if (a <= 0) return (atan(b) - a) / (b - a != 0 ? b - a : 1.0);
    if (b <= 0) return (atan(a) - b) / (a - b != 0 ? a - b : 1.0);
    double delta = a - b;
    if (fabs(delta) <= EPSILON) return 1.0 / (a * a + 1.0);
    return (atan(a) - atan(b)) / delta;
}

/* The share of light one fog lets through over `width` along a ray (fog.fog_attenuation). */
static double fog_attenuation(const Scene *s, const double *fg, double width, const double *o,
                              const double *d) {
    double density = 1.0;
    if ((int)fg[F_TYPE] == 2 && fg[F_ALT] != 0) {
        const double *up = fg + F_UP;
        double q[3] = {o[0] + d[0] * width, o[1] + d[1] * width, o[2] + d[2] * width};
        double a = (dot(o, up) - fg[F_OFFSET]) / fg[F_ALT];
        double b = (dot(q, up) - fg[F_OFFSET]) / fg[F_ALT];
        density = ground_fog_density(s, a, b);
    }
    if (fg[F_HASTURB] != 0.0) {
        double half = width / 2.0, mid[3];
        for (int i = 0; i < 3; i++) mid[i] = (o[i] + d[i] * half) * fg[F_TURB + i];
        double t = turbulence_at(&s->noise, mid, (int)fg[F_OCTAVES], fg[F_OMEGA], fg[F_LAMBDA], 2);
        double k = exp(-width / fg[F_DIST]), m = t * fg[F_TDEPTH];
        width = width * (1.0 - k * (m < 1.0 ? m : 1.0));
    }
    return exp(-width * density / fg[F_DIST]);
}

/* POV-Ray's ComputeFog over every fog of the scene (fog.apply_fogs), for a ray that went
 * `depth` from o along d and brought `col`. */
static void apply_fogs(const Scene *s, double depth, const double *o, const double *d,
                       double *col) {
    double width = isfinite(depth) ? depth : s->h[H_FOGMAX];
    double sum_att[3] = {1.0, 1.0, 1.0}, sum_col[3] = {0.0, 0.0, 0.0};
    for (int f = 0; f < s->nfog; f++) {
        const double *fg = s->fog + (size_t)f * FOG, *fc = fg + F_COL;
        if (fabs(fg[F_DIST]) <= EPSILON) continue;
        double att = fog_attenuation(s, fg, width, o, d);
        if (att < fc[4]) att = fc[4];
        for (int i = 0; i < 3; i++) {
            sum_att[i] = sum_att[i] * (att * ((1.0 - fc[3]) + fc[3] * fc[i]));
            sum_col[i] = sum_col[i] + (1.0 - att) * fc[i];
        }
    }
    for (int i = 0; i < 3; i++) col[i] = sum_col[i] + sum_att[i] * col[i];
}

/* The colour of one ray (integrate.trace): `level` is the trace level of the surface that
 * spawned it; a `continued` ray (straight through an ior-1 surface) keeps that level. cls is
 * 0 for a camera ray (also continued: the same line), -1 for others. */
static void trace(Scene *s, const double *o, const double *d, double weight, int level,
                  int skip, int continued, int cls, const Inside *in, double *out) {
    out[0] = out[1] = out[2] = 0.0;
    if (level >= s->maxlevel || weight < s->bailout) return;
    s->rays++;
    Hit h;
    if (!closest(s, o, d, INFINITY, skip, cls, &h)) {
        sky(s, d, out);
        if (s->nfog) apply_fogs(s, INFINITY, o, d, out);
        return;
    }
    shade(s, o, d, &h, weight, level + (continued ? 0 : 1), skip, cls, in, out);
    if (s->nfog) apply_fogs(s, h.t, o, d, out);
}

/* Every one of the n indices in [0, bound). */
static int indices_below(const double *v, int n, int bound) {
    for (int i = 0; i < n; i++)
        if (!(v[i] >= 0 && v[i] < bound)) return 0;
    return 1;
}

/* A box tree's n rows (whitted.py box_tree): finite boxes, leaves' runs inside the nitem
 * items, children after their parent (the walk always ends) and a split axis. */
static int box_tree_valid(const double *bvh, int n, int nitem) {
    for (int i = 0; i < n; i++) {
        const double *b = bvh + (size_t)i * BVH;
        for (int k = 0; k < 6; k++)
            if (!isfinite(b[B_LO + k])) return 0;
        if (b[B_LEFT] < 0) {
            if (!(b[B_FIRST] >= 0 && b[B_COUNT] >= 0 && b[B_FIRST] + b[B_COUNT] <= nitem)) return 0;
        } else if (!(b[B_LEFT] > i && b[B_LEFT] < n && b[B_RIGHT] > i && b[B_RIGHT] < n &&
                     b[B_AXIS] >= 0 && b[B_AXIS] < 3)) {
            return 0;
        }
    }
    return 1;
}

/* The Scene view of a packed array; -1 with an exception set when it is too short. */
static int scene_from(const Py_buffer *sb, Scene *s) {
    const double *h = sb->buf;
    /* counts are checked as doubles first: casting a NaN or a huge value to int is
     * undefined behaviour */
    static const int counts[] = {H_NOBJ, H_NTEX, H_NLIGHT, H_MAXLEVEL, H_NPIG, H_NSKY, H_NNODE,
                                 H_NROOT, H_NCHILD, H_NUNB, H_NBVH, H_NITEM, H_NLOOSE};
    for (size_t i = 0; i < sizeof counts / sizeof counts[0]; i++)
        if (!(h[counts[i]] >= 0 && h[counts[i]] <= 1e9)) {
            PyErr_SetString(PyExc_ValueError, "scene: a count in its header is not a count");
            return -1;
        }
    *s = (Scene){.h = h, .nobj = (int)h[H_NOBJ], .ntex = (int)h[H_NTEX],
                 .nlight = (int)h[H_NLIGHT], .maxlevel = (int)h[H_MAXLEVEL],
                 .bailout = h[H_BAILOUT], .legacy = (int)h[H_LEGACY],
                 .anytrans = (int)h[H_ANYTRANS], .npig = (int)h[H_NPIG],
                 .nsky = (int)h[H_NSKY], .nnode = (int)h[H_NNODE],
                 .nroot = (int)h[H_NROOT], .nchild = (int)h[H_NCHILD],
                 .nunb = (int)h[H_NUNB], .nloose = (int)h[H_NLOOSE], .nbvh = (int)h[H_NBVH],
                 .nitem = (int)h[H_NITEM]};
    Py_ssize_t need = HDR + (Py_ssize_t)s->nobj * OBJ + (Py_ssize_t)s->ntex * TEX +
                      (Py_ssize_t)s->nlight * LIT + (Py_ssize_t)s->npig * PIG +
                      (Py_ssize_t)s->nnode * NODE + s->nchild + s->nunb + s->nloose +
                      (Py_ssize_t)s->nbvh * BVH + s->nitem;
    if (!(h[H_MASK] == 0.0 || h[H_MASK] == 1.0)) {
        PyErr_SetString(PyExc_ValueError, "scene: the header's mask flag is not 0 or 1");
        return -1;
    }
    int masked = h[H_MASK] == 1.0;
    if (masked) need += (Py_ssize_t)(s->nbvh + 1) * (1 + s->nlight);
    if (s->nobj < 0 || s->ntex < 0 || s->nlight < 0 || s->npig < 0 || s->nsky < 0 ||
        s->nnode < 0 || s->nroot < 0 || s->nchild < 0 || s->nroot > s->nnode ||
        s->nunb < 0 || s->nloose < 0 || s->nbvh < 0 || s->nitem < 0 ||
        s->nsky > s->npig || sb->len < need * 8) {
        PyErr_SetString(PyExc_ValueError, "scene: array shorter than its header says");
        return -1;
    }
    s->tol = h + H_TOL;
    s->obj = h + HDR;
    s->tex = s->obj + (size_t)s->nobj * OBJ;
    s->light = s->tex + (size_t)s->ntex * TEX;
    s->pig = s->light + (size_t)s->nlight * LIT;
    s->node = s->pig + (size_t)s->npig * PIG;
    s->child = s->node + (size_t)s->nnode * NODE;
    s->unb = s->child + s->nchild;
    s->loose = s->unb + s->nunb;
    s->bvh = s->loose + s->nloose;
    s->item = s->bvh + (size_t)s->nbvh * BVH;
    s->mwidth = 1 + s->nlight;
    s->mask = masked ? s->item + s->nitem : NULL;
    s->start = masked ? s->mask + (size_t)s->nbvh * s->mwidth : NULL;
    if (masked)
        for (int c = 0; c < s->mwidth; c++)
            if (!(s->start[c] >= -1 && s->start[c] < s->nbvh)) goto bad;
    if (!indices_below(s->unb, s->nunb, s->nroot) ||
        !indices_below(s->loose, s->nloose, s->nroot) ||
        !indices_below(s->item, s->nitem, s->nroot) || !box_tree_valid(s->bvh, s->nbvh, s->nitem))
        goto bad;
    for (int i = 0; i < s->nnode; i++) {
        const double *nd = s->node + (size_t)i * NODE;
        if ((int)nd[N_KIND] == NK_LEAF) {
            if (!(nd[N_LEAF] >= 0 && nd[N_LEAF] < s->nobj)) goto bad;
        } else {
            if (!(nd[N_FIRST] >= 0 && nd[N_COUNT] >= 1 && nd[N_FIRST] + nd[N_COUNT] <= s->nchild))
                goto bad;
            if (!(nd[N_OP] >= OP_UNION && nd[N_OP] <= OP_CLIP)) goto bad;
            /* children come after their parent: the recursion always ends */
            for (int j = 0; j < (int)nd[N_COUNT]; j++) {
                double c = s->child[(size_t)nd[N_FIRST] + j];
                if (!(c > i && c < s->nnode)) goto bad;
            }
        }
    }
    for (int l = 0; l < s->nlight; l++) { /* an area light's grid fits what it allocates */
        const double *lt = s->light + (size_t)l * LIT;
        if ((int)lt[L_AREA] && !(lt[L_N1] >= 1 && lt[L_N2] >= 1 && lt[L_N1] * lt[L_N2] <= 1e6 &&
                                 lt[L_ADAPTIVE] >= 0 && lt[L_ADAPTIVE] <= 1e6))
            goto bad;
    }
    /* indices between the tables are checked once here, so tracing never reads outside */
    for (int i = 0; i < s->nobj; i++) {
        double t = s->obj[(size_t)i * OBJ + O_TEX], it = s->obj[(size_t)i * OBJ + O_INSIDE_TEX];
        if (!(t >= 0 && t < s->ntex)) goto bad;
        if (!(it == -1 || (it >= 0 && it < s->ntex))) goto bad;
    }
    for (int i = 0; i < s->ntex; i++) {
        double g = s->tex[(size_t)i * TEX + T_PIG];
        if (!(g >= 0 && g < s->npig)) goto bad;
        /* a patterned texture's row names a pattern of textures, a layer's a pigment */
        int textures = s->pig[(size_t)g * PIG + P_SUBS] == SUBS_TEXTURES;
        if (textures != (s->tex[(size_t)i * TEX + T_PAT] != 0.0)) goto bad;
        /* a layer's next layer comes after it: the walk over them always ends */
        double next = s->tex[(size_t)i * TEX + T_NEXT];
        if (!(next == -1 || (next > i && next < s->ntex))) goto bad;
    }
    double nrms = h[H_NRMS], nnrm = h[H_NNRM];
    if (!(nnrm >= 0 && nnrm < 1e9 && (nnrm == 0 || (nrms >= need && nrms + NRM * nnrm <= sb->len / 8))))
        goto bad;
    s->nrm = h + (size_t)nrms;
    s->nnrm = (int)nnrm;
    for (int i = 0; i < s->ntex; i++) {
        double r = s->tex[(size_t)i * TEX + T_NRM];
        if (!(r == -1 || (r >= 0 && r < s->nnrm))) goto bad;
    }
    double cam_nrm = h[H_CAMNRM];
    if (!(cam_nrm == -1 || (cam_nrm >= 0 && cam_nrm < s->nnrm))) goto bad;
    s->camnrm = (int)cam_nrm;
    double maps = h[H_MAPS], nmaps = h[H_NMAPS];
    if (!(maps >= need && nmaps >= 0 && maps + 6 * nmaps <= sb->len / 8)) goto bad;
    s->map = h + (size_t)maps;
    double fogs = h[H_FOGS], nfog = h[H_NFOG];
    if (!(nfog >= 0 && nfog < 1e6 && (nfog == 0 || (fogs >= need && fogs + FOG * nfog <= sb->len / 8))))
        goto bad;
    s->fog = h + (size_t)fogs;
    s->nfog = (int)nfog;
    double terms = h[H_TERMS], nterms = h[H_NTERMS];
    if (!(nterms >= 0 && (nterms == 0 || (terms >= need && terms + POLY_TERM * nterms <= sb->len / 8))))
        goto bad;
    s->terms = h + (size_t)terms;
    for (int i = 0; i < s->nobj; i++) {
        const double *ob = s->obj + (size_t)i * OBJ, *q = ob + O_PRIM;
        if ((int)ob[O_KIND] != K_POLY) continue;
        if (!(q[Y_DEGREE] >= 0 && q[Y_DEGREE] <= POLY_MAX_DEGREE && q[Y_TERMS] >= 0 &&
              q[Y_NTERMS] >= 0 && q[Y_TERMS] + q[Y_NTERMS] <= nterms))
            goto bad;
        for (int k = 0; k < (int)q[Y_NTERMS]; k++) {
            const double *tm = s->terms + (size_t)(q[Y_TERMS] + k) * POLY_TERM;
            if (!(tm[0] >= 0 && tm[1] >= 0 && tm[2] >= 0 && tm[0] + tm[1] + tm[2] <= q[Y_DEGREE]))
                goto bad;
        }
    }
    double images = h[H_IMAGES], nimage = h[H_NIMAGE];
    if (!(nimage >= 0 && (nimage == 0 || (images >= need && images + nimage <= sb->len / 8))))
        goto bad;
    s->img = h + (size_t)images;
    double sweeps = h[H_SWEEPS], nsweep = h[H_NSWEEP];
    if (!(nsweep >= 0 && (nsweep == 0 || (sweeps >= need && sweeps + nsweep <= sb->len / 8))))
        goto bad;
    s->sweeps = h + (size_t)sweeps;
    const double *stl = h + H_SWEEP_TOL;
    s->swt = (SweepTol){.parallel = PARALLEL_EPS, .abs_floor = ABS_FLOOR, .lead_rel = stl[0],
                        .newton_steps = (int)stl[1], .newton_max_step = stl[2],
                        .param_eps = stl[3], .side_rel = stl[4]};
    if (!(stl[1] >= 0 && stl[1] <= 100)) goto bad;
    for (int i = 0; i < s->nobj; i++) {
        const double *ob = s->obj + (size_t)i * OBJ, *q = ob + O_PRIM;
        if ((int)ob[O_KIND] == K_POLYGON) {
            if (!(q[PG_AT] >= 0 && q[PG_COUNT] >= 0 && q[PG_AT] + 4 * q[PG_COUNT] <= nsweep &&
                  q[PG_K0] >= 0 && q[PG_K0] <= 2 && q[PG_K1] >= 0 && q[PG_K1] <= 2))
                goto bad;
            continue;
        }
        if ((int)ob[O_KIND] == K_LATHE) {
            if (!(q[LA_AT] >= 0 && q[LA_NSEG] >= 0 && q[LA_AT] + SS * q[LA_NSEG] <= nsweep &&
                  q[LA_ROOT_ITER] >= 0 && q[LA_ROOT_ITER] <= 1e4))
                goto bad;
            continue;
        }
        if ((int)ob[O_KIND] == K_SOR) {
            if (!(q[SO_AT] >= 0 && q[SO_NSEG] >= 0 && q[SO_AT] + SOR_SEG * q[SO_NSEG] <= nsweep))
                goto bad;
            continue;
        }
        if ((int)ob[O_KIND] == K_SUPERELLIPSOID) { /* its buffers hold this many cells */
            if (!(q[SE_CELLS] >= 1 && q[SE_CELLS] <= SE_MAX_CELLS && q[SE_MIN_ITER] >= 0 &&
                  q[SE_MIN_ITER] <= 1e4 && q[SE_ROOT_ITER] >= 0 && q[SE_ROOT_ITER] <= 1e4))
                goto bad;
            continue;
        }
        if ((int)ob[O_KIND] != K_SWEEP) continue;
        if (!(q[SW_AT] >= 0 && q[SW_NGROUP] >= 0 && q[SW_NSEG] >= 0 &&
              q[SW_AT] + SG * q[SW_NGROUP] + SS * q[SW_NSEG] <= nsweep))
            goto bad;
        for (int k = 0; k < 3; k++)
            if (!(q[SW_AXES + k] >= 0 && q[SW_AXES + k] <= 2)) goto bad;
        SweepView v = sweep_view(s->sweeps, q);
        for (int g = 0; g < v.ngroup; g++) {
            const double *gr = v.groups + (size_t)g * SG;
            if (!(gr[SG_FIRST] >= 0 && gr[SG_COUNT] >= 0 && gr[SG_FIRST] + gr[SG_COUNT] <= v.nseg))
                goto bad;
        }
    }
    double blobs = h[H_BLOBS], nblob = h[H_NBLOB];
    if (!(nblob >= 0 && nblob < 1e12 && (nblob == 0 || (blobs >= need && blobs + nblob <= sb->len / 8))))
        goto bad;
    s->blobs = h + (size_t)blobs;
    s->blob_inside = h[H_BLOB_INSIDE];
    for (int i = 0; i < s->nobj; i++) {
        const double *ob = s->obj + (size_t)i * OBJ, *q = ob + O_PRIM;
        if ((int)ob[O_KIND] != K_BLOB) continue;
        /* (at most a million pieces: blob_room stays an int) */
        if (!(q[BL_AT] >= 0 && q[BL_N] >= 0 && q[BL_N] <= 1e6 &&
              q[BL_AT] + BLOB_PIECE * q[BL_N] <= nblob))
            goto bad;
    }
    double tris = h[H_TRIS], ntri = h[H_NTRI], tbvh = h[H_TBVH], ntbvh = h[H_NTBVH];
    double titems = h[H_TITEMS], ntitem = h[H_NTITEM];
    if (!(ntri >= 0 && ntri < 1e9 && ntbvh >= 0 && ntbvh < 1e9 && ntitem >= 0 && ntitem < 1e9))
        goto bad;
    double end = (double)(sb->len / 8);
    if ((ntri > 0 && !(tris >= need && tris + TRI * ntri <= end)) ||
        (ntbvh > 0 && !(tbvh >= need && tbvh + BVH * ntbvh <= end)) ||
        (ntitem > 0 && !(titems >= need && titems + ntitem <= end)))
        goto bad;
    s->ntri = (int)ntri, s->ntbvh = (int)ntbvh, s->ntitem = (int)ntitem;
    s->tri = h + (size_t)tris, s->tbvh = h + (size_t)tbvh, s->titem = h + (size_t)titems;
    if (!box_tree_valid(s->tbvh, s->ntbvh, s->ntitem) ||
        !indices_below(s->titem, s->ntitem, s->ntri))
        goto bad;
    for (int i = 0; i < s->ntri; i++) {
        const double *tr = s->tri + (size_t)i * TRI;
        if (!(tr[TR_OBJ] >= 0 && tr[TR_OBJ] < s->nobj && tr[TR_TEX] >= 0 && tr[TR_TEX] < s->ntex))
            goto bad;
    }
    double at = h[H_NOISE];
    if (at != 0.0) {
        if (!(at >= need && at + NOISE_LEN <= sb->len / 8)) goto bad;
        noise_view(h + (size_t)at, &s->noise);
        if (!noise_valid(&s->noise)) goto bad;
        s->has_noise = 1;
    }
    for (int f = 0; f < s->nfog; f++)
        if (s->fog[(size_t)f * FOG + F_HASTURB] != 0.0 && !s->has_noise) goto bad;
    for (int i = 0; i < s->nnrm; i++) {
        const double *nr = s->nrm + (size_t)i * NRM;
        if (!(nr[NR_KIND] >= NK_NONE && nr[NR_KIND] <= NK_BUMPMAP)) goto bad;
        if (nr[NR_KIND] == NK_BUMPMAP &&
            !(nr[P_IMGW] >= 0 && nr[P_IMGH] >= 0 && nr[P_IMGW] < 1e6 && nr[P_IMGH] < 1e6 &&
              nr[P_IMG] >= 0 && nr[P_IMG] + nr[P_IMGW] * nr[P_IMGH] <= h[H_NIMAGE]))
            goto bad;
        if (nr[NR_KIND] == NK_MAP || nr[NR_KIND] == NK_AVERAGE) {
            /* a normal_map's entries: rows after its own (the recursion always ends) */
            if (!(nr[NR_NMAP] >= 1 && nr[NR_NMAPAT] >= 0 && nr[NR_NMAPAT] + nr[NR_NMAP] <= nmaps))
                goto bad;
            for (int e = 0; e < (int)nr[NR_NMAP]; e++) {
                double row = s->map[6 * ((size_t)nr[NR_NMAPAT] + e) + 1];
                if (!(row > i && row < s->nnrm)) goto bad;
            }
            if (nr[NR_KIND] == NK_MAP && (nr[P_KIND] == PK_SOLID || nr[P_KIND] == PK_IMAGE))
                goto bad;
            if ((nr[P_KIND] == PK_RIPPLES || nr[P_KIND] == PK_WAVES) &&
                !(nr[P_NWAVES] >= 1 && nr[P_WAVES] >= 0 && nr[P_WAVES] + nr[P_NWAVES] <= nmaps))
                goto bad;
        }
        if (!(nr[P_KIND] >= PK_SOLID && nr[P_KIND] <= PK_LAST && nr[P_KIND] != PK_AVERAGE))
            goto bad;
        if (!fractal_row_valid(nr)) goto bad;
        /* every normal but none reads POV-Ray's noise (its turbulence, dents, bumps, ...) */
        if (nr[NR_KIND] != NK_NONE &&
            !(s->has_noise && nr[P_GEN] >= 1 && nr[P_GEN] <= 3 && nr[P_OCTAVES] >= 0 &&
              nr[P_OCTAVES] <= 1e6))
            goto bad;
        if (!(nr[NR_NWAVES] >= 0 && nr[NR_WAVES] >= 0 && nr[NR_WAVES] + nr[NR_NWAVES] <= nmaps))
            goto bad;
        if (!(nr[NR_NSLOPES] >= 0 && nr[NR_SLOPES] >= 0 &&
              nr[NR_SLOPES] + nr[NR_NSLOPES] <= nmaps))
            goto bad;
        if (nr[NR_KIND] == NK_SLOPE && !(nr[NR_ACC] > 0)) goto bad;
    }
    for (int i = 0; i < s->npig; i++) {
        const double *pg = s->pig + (size_t)i * PIG;
        double n = pg[P_N];
        if (!(n >= 1 && pg[P_MAP] >= 0 && pg[P_MAP] + n <= nmaps)) goto bad;
        if (!(pg[P_SUBS] >= SUBS_NONE && pg[P_SUBS] <= SUBS_TEXTURES)) goto bad;
        if (pg[P_SUBS] == SUBS_PIGMENTS) {
            if (pg[P_KIND] == PK_CHECKER && n < 2) goto bad;
            for (int e = 0; e < (int)n; e++) {
                double row = s->map[6 * ((size_t)pg[P_MAP] + e) + 1];
                if (!(row >= 0 && row < s->npig)) goto bad;
                if (s->pig[(size_t)row * PIG + P_SUBS] == SUBS_TEXTURES) goto bad;
            }
        }
        if (pg[P_SUBS] == SUBS_TEXTURES) { /* a patterned texture's pattern and textures */
            if (pg[P_KIND] == PK_SOLID || i >= s->npig - s->nsky) goto bad;
            for (int e = 0; e < (int)n; e++) {
                double row = s->map[6 * ((size_t)pg[P_MAP] + e) + 1];
                if (!(row >= 0 && row < s->ntex)) goto bad;
            }
        }
        if (!(pg[P_KIND] >= PK_SOLID && pg[P_KIND] <= PK_LAST)) goto bad;
        if (pg[P_KIND] == PK_AVERAGE && pg[P_SUBS] == 0.0) goto bad;
        if (pg[P_KIND] == PK_IMAGE &&
            !(pg[P_SUBS] == SUBS_NONE && pg[P_IMGW] >= 1 && pg[P_IMGH] >= 1 && pg[P_IMGW] < 1e6 &&
              pg[P_IMGH] < 1e6 && (pg[P_IMGCH] == 4 || pg[P_IMGCH] == 6) && pg[P_IMG] >= 0 &&
              pg[P_IMG] + pg[P_IMGW] * pg[P_IMGH] * pg[P_IMGCH] <= nimage))
            goto bad;
        if (!fractal_row_valid(pg)) goto bad;
        if ((pg[P_KIND] == PK_RIPPLES || pg[P_KIND] == PK_WAVES) &&
            !(pg[P_NWAVES] >= 1 && pg[P_WAVES] >= 0 && pg[P_WAVES] + pg[P_NWAVES] <= nmaps))
            goto bad;
        if ((noise_kind((int)pg[P_KIND]) || pg[P_HASTURB] != 0.0) &&
            !(s->has_noise && pg[P_GEN] >= 1 && pg[P_GEN] <= 3 && pg[P_OCTAVES] >= 0 &&
              pg[P_OCTAVES] <= 1e6))
            goto bad;
    }
    return 0;
bad:
    PyErr_SetString(PyExc_ValueError, "scene: an index between its tables is out of range");
    return -1;
}

/* The screen point's angle around the centre, as POV-Ray takes it (camera._polar_angle) */
static double polar_angle(double x0, double y0, double rad) {
    double q = y0 / (rad == 0 ? 1.0 : rad);
    double phi = asin(q < -1.0 ? -1.0 : (q > 1.0 ? 1.0 : q));
    return rad == 0 ? 0.0 : (x0 < 0 ? M_PI - phi : phi);
}

/* Rodrigues (camera._rotate): v turned by `angle` about the unit axis */
static void rotate_about(const double *v, const double *axis, double angle, double *out) {
    double c = cos(angle), sn = sin(angle), x[3], along = dot(v, axis);
    cross3(axis, v, x);
    for (int k = 0; k < 3; k++) out[k] = v[k] * c + x[k] * sn + axis[k] * along * (1.0 - c);
}

/* A camera ray through screen point (sx, sy) by the projection's formulas (camera.py,
 * POV-Ray 3.7's); 0 where the projection traces none (outside a fisheye's circle). */
static int camera_ray(const double *h, double sx, double sy, double *o, double *d) {
    const double *loc = h + H_LOC, *dir = h + H_DIR, *right = h + H_RIGHT, *up = h + H_UP;
    const double *rn = h + H_CAMRN, *un = h + H_CAMUN, *dn = h + H_CAMDN;
    double angle = h[H_CAMANGLE];
    int traced = 1;
    memcpy(o, loc, 3 * sizeof(double));
    switch ((int)h[H_CAMKIND]) {
    case CAM_ORTHOGRAPHIC:
        for (int k = 0; k < 3; k++) o[k] = loc[k] + sx * right[k] + sy * up[k], d[k] = dir[k];
        break;
    case CAM_FISHEYE: {
        double x0 = 2.0 * sx * h[H_CAMLR], y0 = 2.0 * sy * h[H_CAMLU], rad = hypot(x0, y0);
        double phi = polar_angle(x0, y0, rad), theta = rad * angle / 2.0;
        double a = cos(phi) * sin(theta), b = sin(phi) * sin(theta), c = cos(theta);
        for (int k = 0; k < 3; k++) d[k] = a * rn[k] + b * un[k] + c * dn[k];
        traced = rad <= 1.0;
        break;
    }
    case CAM_OMNIMAX: {
        double aspect = h[H_CAMLR] / h[H_CAMLU], x0 = 2.0 * sx, y0 = 2.0 * sy;
        if (aspect > 1.0) {
            if (aspect > 1.283458) {
                x0 = x0 * aspect / 1.283458;
                y0 = (y0 - 1.0) / 1.283458 + 1.0;
            } else {
                y0 = (y0 - 1.0) / aspect + 1.0;
            }
        } else {
            y0 = y0 / aspect;
        }
        double rad = hypot(x0, y0), phi = polar_angle(x0, y0, rad);
        double theta = 1.411269 * rad - 0.09439 * pow(rad, 3.0) + 0.25674 * pow(rad, 5.0);
        double sp = sin(phi), st = sin(theta), ct = cos(theta), a = cos(phi) * st, b = sp * st;
        for (int k = 0; k < 3; k++) d[k] = a * rn[k] + b * un[k] + ct * dn[k];
        traced = rad <= 1.0 && !(sp * st < h[H_CAMTAN] * ct);
        break;
    }
    case CAM_PANORAMIC: {
        double lon = (0.5 - sx) * M_PI, lat = M_PI * sy;
        double ty = fabs(M_PI / 2 - fabs(lat)) < 1e-10 ? (lat > 0 ? 1e30 : (lat < 0 ? -1e30 : 0.0))
                                                     : tan(lat);
        double a = cos(lon), c = sin(lon);
        for (int k = 0; k < 3; k++) d[k] = a * right[k] + ty * up[k] + c * dir[k];
        break;
    }
    case CAM_ULTRA_WIDE: {
        double aspect = h[H_CAMLU] / h[H_CAMLR], x0 = sx * angle, y0 = sy * angle * aspect;
        double a = sin(x0), b = sin(y0), c = cos(x0) * cos(y0);
        for (int k = 0; k < 3; k++) d[k] = a * rn[k] + b * un[k] + c * dn[k];
        break;
    }
    case CAM_CYLINDER: { /* 1 and 3 about up, 2 and 4 about right; 3 and 4 move the origin */
        int kind = (int)h[H_CAMCYL], around_up = kind == 1 || kind == 3;
        const double *side = around_up ? rn : un, *axis = around_up ? un : rn;
        double s_side = around_up ? sx : sy, s_axis = around_up ? sy : sx;
        double length = around_up ? h[H_CAMLU] : h[H_CAMLR], theta = s_side * angle;
        double a = sin(theta), c = cos(theta), off = s_axis * length;
        for (int k = 0; k < 3; k++) {
            d[k] = a * side[k] + c * dn[k];
            if (kind <= 2) d[k] = d[k] + off * axis[k];
            else o[k] = loc[k] + off * axis[k];
        }
        break;
    }
    case CAM_SPHERICAL: {
        double lat = sy * h[H_CAMV], lon = sx * h[H_CAMH], v1[3];
        rotate_about(dir, rn, -lat, v1);
        rotate_about(v1, un, lon, d);
        break;
    }
    default:
        for (int k = 0; k < 3; k++) d[k] = dir[k] + sx * right[k] + sy * up[k];
    }
    return traced;
}

/* The colour of the camera ray through continuous pixel coordinates (x, y). */
static void trace_pixel(Scene *s, double x, double y, double *out) {
    const double *h = s->h;
    double sx = x / h[H_WIDTH] - 0.5, sy = 0.5 - y / h[H_HEIGHT];
    double o[3], d[3];
    if (!camera_ray(h, sx, sy, o, d)) { /* black, as POV-Ray */
        out[0] = out[1] = out[2] = 0.0;
        return;
    }
    double len = sqrt(dot(d, d));
    d[0] /= len, d[1] /= len, d[2] /= len;
    if (s->camnrm >= 0) { /* camera.bend: the pattern at the screen point <sx, sy, 0> */
        double at[3] = {sx, sy, 0.0}, bent[3];
        perturb(s, s->nrm + (size_t)s->camnrm * NRM, at, d, bent);
        len = sqrt(dot(bent, bent));
        d[0] = bent[0] / len, d[1] = bent[1] / len, d[2] = bent[2] / len;
    }
    /* the objects holding the camera (runtime/containers.py), as POV-Ray's camera rays */
    Inside held = {0};
    held.n = (int)s->h[H_CAMIN];
    for (int k = 0; k < held.n && k < INSIDE_DEPTH; k++) {
        held.id[k] = (int)s->h[H_CAMIN + 1 + k];
        held.ior[k] = s->h[H_CAMIN + 1 + INSIDE_DEPTH + k];
    }
    trace(s, o, d, 1.0, 0, SKIP_NO_IMAGE, 0, 0, &held, out);
}

/* The anti-aliasing of a tile whose first rays are traced (render_tile): the pixels
 * that differ from a neighbour supersampled into `out`; the count of them. */
static long long refine_tile(Scene *s, int x0, int y0, int x1, int y1, int ew, int eh,
                             double threshold, double metric_power, int depth,
                             const double *first, double *metric, unsigned char *mask,
                             double *out) {
    int tw = x1 - x0;
    long long supersampled = 0;
    /* the last value and its power per channel: a background or a flat colour repeats
     * along a row, and the power was a tenth of the render */
    double last_v[3] = {0.0, 0.0, 0.0}, last_m[3] = {0.0, 0.0, 0.0};
    for (size_t i = 0; i < (size_t)ew * eh; i++)
        for (int k = 0; k < 3; k++) {
            double v = first[3 * i + k];
            if (v != last_v[k]) {
                last_v[k] = v;
                last_m[k] = v > 0 ? pow(v, metric_power) : 0.0;
            }
            metric[3 * i + k] = last_m[k];
        }
    for (int r = 0; r < eh; r++)
        for (int c = 0; c < ew; c++) {
            size_t i = (size_t)r * ew + c;
            const double *m = metric + 3 * i;
            if (c > 0) {
                const double *l = m - 3;
                if (fabs(m[0] - l[0]) + fabs(m[1] - l[1]) + fabs(m[2] - l[2]) >= threshold)
                    mask[i] = mask[i - 1] = 1;
            }
            if (r > 0) {
                const double *t = m - 3 * ew;
                if (fabs(m[0] - t[0]) + fabs(m[1] - t[1]) + fabs(m[2] - t[2]) >= threshold)
                    mask[i] = mask[i - ew] = 1;
            }
        }
    double step = 1.0 / depth, base = 0.5 - 0.5 * step;
    for (int y = y0; y < y1; y++)
        for (int x = x0; x < x1; x++) {
            size_t i = (size_t)(y - y0 + 1) * ew + (x - x0 + 1);
            double *dst = out + 3 * ((size_t)(y - y0) * tw + (x - x0));
            double acc[3] = {first[3 * i], first[3 * i + 1], first[3 * i + 2]};
            if (mask[i]) {
                double sum[3] = {0.0, 0.0, 0.0};
                for (int a = 0; a < depth; a++)
                    for (int b = 0; b < depth; b++) {
                        double col[3];
                        trace_pixel(s, x + 0.5 + (b * step - base), y + 0.5 + (a * step - base),
                                    col);
                        sum[0] += col[0], sum[1] += col[1], sum[2] += col[2];
                    }
                for (int k = 0; k < 3; k++) acc[k] = (acc[k] + sum[k]) / (depth * depth + 1);
                supersampled++;
            }
            dst[0] = acc[0], dst[1] = acc[1], dst[2] = acc[2];
        }
    return supersampled;
}

/* One tile with POV-Ray's anti-aliasing method 1, as runtime/antialias.py does it: first
 * rays for the tile plus one row above and one column to the left (and one below / to the
 * right where the image goes on), colours compared in the AA metric space (working value
 * clipped at 0, to the power `metric_power`), both pixels of a differing pair supersampled
 * with a depth x depth grid averaged with the first ray. threshold < 0: no anti-aliasing.
 * stage 1 only traces the first rays into `first` (the extended tile, ew x eh x 3) and
 * stage 2 only refines them into `out`, so the caller can show a tile's first rays before
 * its refinement; stage 0 (the default) does both with a buffer of its own. */
static PyObject *render_tile(PyObject *self, PyObject *args) {
    PyObject *scene_o, *out_o, *first_o = Py_None;
    int x0, y0, x1, y1, depth, stage = 0;
    double threshold, metric_power;
    if (!PyArg_ParseTuple(args, "OiiiiddiO|iO", &scene_o, &x0, &y0, &x1, &y1, &threshold,
                          &metric_power, &depth, &out_o, &stage, &first_o))
        return NULL;
    int tw = x1 - x0, th = y1 - y0;
    if (tw <= 0 || th <= 0 || depth < 1) {
        PyErr_SetString(PyExc_ValueError, "render_tile: empty tile or depth < 1");
        return NULL;
    }
    if (stage < 0 || stage > 2 || (stage != 0 && (threshold < 0 || first_o == Py_None))) {
        PyErr_SetString(PyExc_ValueError,
                        "render_tile: stage 1 or 2 needs a threshold and a first-ray buffer");
        return NULL;
    }
    Py_buffer sb, ob, fb;
    if (checked_buffer(scene_o, &sb, HDR, 8, 0, "scene")) return NULL;
    if (checked_buffer(out_o, &ob, (Py_ssize_t)3 * tw * th, 8, 1, "out")) {
        PyBuffer_Release(&sb);
        return NULL;
    }
    Scene s;
    if (scene_from(&sb, &s)) {
        PyBuffer_Release(&ob);
        PyBuffer_Release(&sb);
        return NULL;
    }
    int width = (int)s.h[H_WIDTH], height = (int)s.h[H_HEIGHT];
    int ex1 = x1 < width ? x1 + 1 : x1, ey1 = y1 < height ? y1 + 1 : y1;
    int ew = ex1 - (x0 - 1), eh = ey1 - (y0 - 1);
    size_t np_ = (size_t)ew * eh;
    int given = stage != 0;
    if (given && checked_buffer(first_o, &fb, (Py_ssize_t)(3 * np_), 8, 1, "first")) {
        PyBuffer_Release(&ob);
        PyBuffer_Release(&sb);
        return NULL;
    }
    double *out = ob.buf;
    long long supersampled = 0;
    int failed = 0;
    Py_BEGIN_ALLOW_THREADS
    if (threshold < 0) {
        for (int y = y0; y < y1; y++)
            for (int x = x0; x < x1; x++)
                trace_pixel(&s, x + 0.5, y + 0.5, out + 3 * ((size_t)(y - y0) * tw + (x - x0)));
    } else {
        double *first = given ? fb.buf : malloc(np_ * 3 * sizeof(double));
        double *metric = stage == 1 ? NULL : malloc(np_ * 3 * sizeof(double));
        unsigned char *mask = stage == 1 ? NULL : calloc(np_, 1);
        if (!first || (stage != 1 && (!metric || !mask))) {
            failed = 1;
        } else {
            if (stage != 2)
                for (int r = 0; r < eh; r++)
                    for (int c = 0; c < ew; c++)
                        trace_pixel(&s, x0 - 1 + c + 0.5, y0 - 1 + r + 0.5,
                                    first + 3 * ((size_t)r * ew + c));
            if (stage != 1)
                supersampled = refine_tile(&s, x0, y0, x1, y1, ew, eh, threshold, metric_power,
                                           depth, first, metric, mask, out);
        }
        if (!given) free(first);
        free(metric);
        free(mask);
    }
    Py_END_ALLOW_THREADS
    if (given) PyBuffer_Release(&fb);
    PyBuffer_Release(&ob);
    PyBuffer_Release(&sb);
    if (failed) return PyErr_NoMemory();
    return Py_BuildValue("LLL", s.rays, s.shadow_rays, supersampled);
}

static PyObject *layout(PyObject *self, PyObject *noargs) {
    return Py_BuildValue("{s:i,s:i,s:i,s:i,s:i,s:i,s:i,s:i,s:i,s:i,s:i,s:i,s:i,s:i,s:i,s:i}",
                         "header", HDR,
                         "object", OBJ, "texture", TEX, "light", LIT, "pigment", PIG,
                         "normal", NRM,
                         "map_entry", 6, "node", NODE, "max_crossings", MAX_CROSS, "bvh", BVH,
                         "bvh_stack", BVH_STACK, "fog", FOG, "max_layers", MAX_LAYERS,
                         "triangle", TRI, "blob_piece", BLOB_PIECE, "superellipsoid_cells",
                         SE_MAX_CELLS);
}

/* The nearest surface along one ray (queries.trace, the scene language's trace()): (t,
 * normal) or None, the normal as Tracer.closest gives it (unit, before the viewer turn). */
static PyObject *first_hit(PyObject *self, PyObject *args) {
    PyObject *scene_o;
    double o[3], d[3];
    if (!PyArg_ParseTuple(args, "O(ddd)(ddd)", &scene_o, &o[0], &o[1], &o[2], &d[0], &d[1], &d[2]))
        return NULL;
    Py_buffer sb;
    if (checked_buffer(scene_o, &sb, HDR, 8, 0, "scene")) return NULL;
    Scene s;
    if (scene_from(&sb, &s)) {
        PyBuffer_Release(&sb);
        return NULL;
    }
    Hit h = {.t = INFINITY, .obj = -1, .tri = -1};
    PyObject *out;
    if (closest(&s, o, d, INFINITY, SKIP_NONE, -1, &h)) {
        double n[3];
        hit_normal(&s, o, d, &h, n);
        out = Py_BuildValue("d(ddd)", h.t, n[0], n[1], n[2]);
    } else {
        out = Py_NewRef(Py_None);
    }
    PyBuffer_Release(&sb);
    return out;
}

static PyMethodDef methods[] = {
    {"first_hit", first_hit, METH_VARARGS,
     "first_hit(scene, origin, direction) -> (t, normal) of the nearest surface, or None."},
    {"render_tile", render_tile, METH_VARARGS,
     "render_tile(scene, x0, y0, x1, y1, threshold, metric_power, depth, out, stage=0, "
     "first=None) -> (rays, shadow_rays, supersampled): one tile's colours, anti-aliased "
     "(threshold < 0: not); stage 1 traces the first rays into `first`, 2 refines them."},
    {"layout", layout, METH_NOARGS, "The packed scene's strides."},
    {NULL, NULL, 0, NULL}};

static struct PyModuleDef module = {PyModuleDef_HEAD_INIT, "_whitted",
                                    "The compiled Whitted kernel (see runtime/whitted.py).", -1,
                                    methods};

PyMODINIT_FUNC PyInit__whitted(void) { return PyModule_Create(&module); }
