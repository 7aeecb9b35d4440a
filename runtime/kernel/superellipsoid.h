/* POV-Ray's superellipsoid for the compiled kernel: runtime/prims/superellipsoid.py, formula
 * for formula and in its order (its docstring says why the search is as it is). Included by
 * whitted.c only.
 *
 * The exponents and every tolerance come in the object's primitive slots (whitted.py packs
 * them from the prim and runtime/tolerances.py). Powers are numpy's `array ** float`: its
 * exact cases (2, 0.5, 1, -1, 0: a product, a square root, the value) are taken here too,
 * the others are libm's pow where numpy has its own (SIMD on some CPUs), as are log and
 * exp: those agree to an ulp or so, not bit for bit (tests/test_superellipsoid_kernel.py
 * states and tests the bound this leaves on crossings and images). */
#ifndef STRALA_SUPERELLIPSOID_H
#define STRALA_SUPERELLIPSOID_H

#include "bracket.h"
#include <math.h>

/* a superellipsoid's slots: its exponents e, n, the norms' p = 2/e and q = 2/n, whether it
 * is convex, then its tolerances (tolerances.py SUPERELLIPSOID_*, ABS_FLOOR, PARALLEL_EPS,
 * ROOT_MAX_ITER) */
enum { SE_E, SE_N, SE_P, SE_Q, SE_CONVEX, SE_BOX_PAD, SE_CELLS, SE_INSET, SE_MIN_ITER,
       SE_INSIDE, SE_ABS_FLOOR, SE_PARALLEL, SE_ROOT_ITER };
/* more cells renders through numpy (whitted.py SUPERELLIPSOID_MAX_CELLS) */
#define SE_MAX_CELLS 32
/* the cut points of a chord (the cells' ends and the nine planes), and the most crossings
 * the search can report: one per gap between them and the extrema between them */
#define SE_MAX_POINTS (SE_MAX_CELLS + 10)
#define SE_MAX_CROSS (2 * SE_MAX_POINTS - 2)

static inline double se_dot(const double *a, const double *b) {
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
}

/* numpy's `x ** y` for a Python float y (its fast scalar powers, then the power ufunc) */
static inline double se_pow(double x, double y) {
    if (y == 2.0) return x * x;
    if (y == 0.5) return sqrt(x);
    if (y == 1.0) return x;
    if (y == -1.0) return 1.0 / x;
    if (y == 0.0) return 1.0;
    return pow(x, y);
}

static inline double se_sign(double v) { return v > 0 ? 1.0 : (v < 0 ? -1.0 : (v == v ? 0.0 : v)); }

/* SuperellipsoidPrim._g: max(|x|,|y|) (1 + (min/max)^p)^(1/p) */
static inline double se_g(const double *sp, double ax, double ay) {
    double big = ax > ay ? ax : ay, small = ax < ay ? ax : ay;
    double ratio = big > 0 ? small / big : 0.0;
    return big * se_pow(1.0 + se_pow(ratio, sp[SE_P]), 1.0 / sp[SE_P]);
}

/* SuperellipsoidPrim.value: f at x */
static inline double se_value(const double *sp, const double *x) {
    double ax = fabs(x[0]), ay = fabs(x[1]), az = fabs(x[2]);
    return se_pow(se_g(sp, ax, ay), sp[SE_Q]) + se_pow(az, sp[SE_Q]) - 1.0;
}

/* SuperellipsoidPrim.gradient: grad f's direction, its largest component 1 (by logs) */
static void se_gradient(const double *sp, const double *x, double *n) {
    double p = sp[SE_P], q = sp[SE_Q];
    double ax = fabs(x[0]), ay = fabs(x[1]), az = fabs(x[2]);
    double lg = log(se_g(sp, ax, ay));
    double l[3];
    l[0] = ax > 0 ? (q - 1) * lg + (p - 1) * (log(ax) - lg) : -INFINITY;
    l[1] = ay > 0 ? (q - 1) * lg + (p - 1) * (log(ay) - lg) : -INFINITY;
    l[2] = az > 0 ? (q - 1) * log(az) : -INFINITY;
    double top = l[0];
    for (int i = 1; i < 3 && top == top; i++) /* numpy's max: a NaN wins */
        if (l[i] > top || l[i] != l[i]) top = l[i];
    if (!isfinite(top)) top = 0.0;
    /* a coordinate exactly 0 across which f has a cusp: that axis (see the numpy method) */
    int cusp[3] = {ax == 0 && p < 1, ay == 0 && p < 1, az == 0 && q < 1};
    int on_cusp = cusp[0] || cusp[1] || cusp[2], flat = 1;
    for (int i = 0; i < 3; i++) {
        double mag = exp(l[i] - top);
        if (mag != mag) mag = 1.0; /* two infinite logs: share the direction */
        n[i] = on_cusp ? (double)cusp[i] : mag * se_sign(x[i]);
        if (n[i] != 0) flat = 0;
    }
    if (flat) n[0] = 0.0, n[1] = 0.0, n[2] = 1.0;
}

/* SuperellipsoidPrim.exact_gradient: grad f itself (inf at cusps) */
static void se_exact_gradient(const double *sp, const double *x, double *n) {
    double p = sp[SE_P], q = sp[SE_Q];
    double ax = fabs(x[0]), ay = fabs(x[1]), az = fabs(x[2]);
    double g = se_g(sp, ax, ay);
    double common = q * se_pow(g, q - 1);
    n[0] = (ax > 0 ? common * se_pow(ax / g, p - 1) : 0.0) * se_sign(x[0]);
    n[1] = (ay > 0 ? common * se_pow(ay / g, p - 1) : 0.0) * se_sign(x[1]);
    n[2] = (az > 0 ? q * se_pow(az, q - 1) : 0.0) * se_sign(x[2]);
}

/* a ray in the shape's box: its origin, unit direction and the shape's slots */
typedef struct {
    const double *sp, *o, *d;
} SeRay;

static inline void se_at(const SeRay *r, double t, double *x) {
    for (int i = 0; i < 3; i++) x[i] = r->o[i] + t * r->d[i];
}

/* SuperellipsoidPrim._slope: the sign-carrying slope of f along the ray at t */
static double se_slope(const SeRay *r, double t) {
    double x[3], n[3];
    se_at(r, t, x);
    if ((int)r->sp[SE_CONVEX]) se_exact_gradient(r->sp, x, n);
    else se_gradient(r->sp, x, n);
    return se_dot(n, r->d);
}

/* SuperellipsoidPrim._extremum: bisection on the slope's sign between a and b */
static double se_extremum(const SeRay *r, double a, double b, int falling) {
    for (int it = 0; it < (int)r->sp[SE_MIN_ITER]; it++) {
        double mid = 0.5 * (a + b);
        int left = (se_slope(r, mid) < 0) == falling;
        if (left) a = mid;
        else b = mid;
    }
    return 0.5 * (a + b);
}

/* the crossings' fdf: S^(1/q) - 1 and its slope along the ray (S = f + 1) */
static void se_fdf(const void *ctx, double t, double *f, double *df) {
    const SeRay *r = ctx;
    double x[3], n[3], q = r->sp[SE_Q];
    se_at(r, t, x);
    double big = se_value(r->sp, x) + 1.0;
    double root = se_pow(big, 1.0 / q);
    se_exact_gradient(r->sp, x, n);
    *f = root - 1.0;
    *df = root / (q * big) * se_dot(n, r->d);
}

/* ascending, tags along; stable (superellipsoid._sorted); tag NULL: none */
static void se_sort(double *v, int *tag, int n) {
    for (int a = 1; a < n; a++)
        for (int b = a; b > 0 && v[b] < v[b - 1]; b--) {
            double x = v[b];
            v[b] = v[b - 1], v[b - 1] = x;
            if (tag) {
                int k = tag[b];
                tag[b] = tag[b - 1], tag[b - 1] = k;
            }
        }
}

/* the planes through the axes the chord is cut along (superellipsoid._PLANES) */
static const double SE_PLANES[9][3] = {{1, 0, 0}, {0, 1, 0},  {0, 0, 1},  {1, 1, 0}, {1, -1, 0},
                                        {1, 0, 1}, {1, 0, -1}, {0, 1, 1}, {0, 1, -1}};
/* the axis each zeroes (superellipsoid._PLANE_AXIS; -1: a diagonal) */
static const int SE_PLANE_AXIS[9] = {0, 1, 2, -1, -1, -1, -1, -1, -1};

/* SuperellipsoidPrim._chord_crossings: the crossings in [lo, hi] of the unit ray r into u
 * (sorted, as many as returned) */
static int se_chord_crossings(const SeRay *r, double lo, double hi, double *u) {
    const double *sp = r->sp;
    /* on[]: the axis of the plane x=0, y=0 or z=0 a cut point lies on, f taken with that
     * coordinate 0 (-1: none; see the numpy module) */
    double pts[SE_MAX_POINTS], all[2 * SE_MAX_POINTS - 1];
    int on[2 * SE_MAX_POINTS - 1];
    int k = 0;
    if ((int)sp[SE_CONVEX]) {
        on[k] = -1, pts[k++] = lo;
        on[k] = -1, pts[k++] = hi;
    } else {
        int cells = (int)sp[SE_CELLS];
        double step = 1.0 / cells; /* np.linspace(0, 1, cells + 1) */
        for (int i = 0; i <= cells; i++)
            on[k] = -1, pts[k++] = lo + (hi - lo) * (i == cells ? 1.0 : i * step);
        for (int j = 0; j < 9; j++) {
            const double *a = SE_PLANES[j];
            double tp = -(r->o[0] * a[0] + r->o[1] * a[1] + r->o[2] * a[2]) /
                        (r->d[0] * a[0] + r->d[1] * a[1] + r->d[2] * a[2]);
            int cut = tp > lo && tp < hi;
            on[k] = cut ? SE_PLANE_AXIS[j] : -1, pts[k++] = cut ? tp : hi;
        }
        se_sort(pts, on, k);
    }
    double inset = sp[SE_INSET] * (hi - lo);
    int m = 0;
    for (int c = 0; c < k; c++) all[m++] = pts[c];
    for (int c = 0; c + 1 < k; c++) {
        double a = pts[c] + inset, b = pts[c + 1] - inset;
        double s_a = se_slope(r, a), s_b = se_slope(r, b);
        on[m] = -1;
        all[m++] = s_a * s_b < 0 && b > a ? se_extremum(r, a, b, s_a < 0) : hi;
    }
    se_sort(all, on, m);
    int n = 0, neg_prev = 0;
    for (int c = 0; c < m; c++) {
        double x[3];
        se_at(r, all[c], x);
        if (on[c] >= 0) x[on[c]] = 0.0;
        int neg = se_value(sp, x) < 0;
        if (c > 0 && neg != neg_prev)
            u[n++] = bracket_root(se_fdf, r, all[c - 1], all[c], neg_prev, sp[SE_ABS_FLOOR],
                                  (int)sp[SE_ROOT_ITER], 1);
        neg_prev = neg;
    }
    return n;
}

/* superellipsoid._box_chord: the line's entry and exit of the box [-h, h]^3 */
static void se_box_chord(const double *o, const double *d, double h, double parallel,
                         double *lo, double *hi) {
    for (int i = 0; i < 3; i++) {
        double inv = 1.0 / d[i], t1 = (-h - o[i]) * inv, t2 = (h - o[i]) * inv;
        if (fabs(d[i]) <= parallel) {
            int in = fabs(o[i]) <= h;
            t1 = in ? -INFINITY : INFINITY;
            t2 = in ? INFINITY : -INFINITY;
        }
        double near = t1 < t2 ? t1 : t2, far = t1 < t2 ? t2 : t1;
        if (i == 0 || near > *lo) *lo = near;
        if (i == 0 || far < *hi) *hi = far;
    }
}

/* SuperellipsoidPrim.crossings along o + t d (object space): the ray recentred on the
 * origin and made unit, clipped to the padded box, searched; returns how many (sorted) */
static int superellipsoid_crossings(const double *sp, const double *o, const double *d,
                                    double *t, int *face) {
    double dd = se_dot(d, d), dl = sqrt(dd), t0 = 0.0;
    int good = dl > 0;
    double du[3] = {d[0] / (good ? dl : 1.0), d[1] / (good ? dl : 1.0), d[2] / (good ? dl : 1.0)};
    if (dd > 0) {
        double c[3] = {0.0 - o[0], 0.0 - o[1], 0.0 - o[2]};
        t0 = se_dot(c, d) / dd;
    }
    double oc[3] = {o[0] + t0 * d[0], o[1] + t0 * d[1], o[2] + t0 * d[2]}, lo, hi;
    se_box_chord(oc, du, 1.0 + sp[SE_BOX_PAD], sp[SE_PARALLEL], &lo, &hi);
    if (!(good && lo < hi)) return 0;
    SeRay r = {sp, oc, du};
    int n = se_chord_crossings(&r, lo, hi, t);
    for (int j = 0; j < n; j++) t[j] = t[j] / dl + t0, face[j] = 0;
    se_sort(t, NULL, n);
    return n;
}

static inline int superellipsoid_inside(const double *sp, const double *x) {
    return se_value(sp, x) < sp[SE_INSIDE];
}

#endif
