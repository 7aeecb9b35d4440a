/* POV-Ray's polynomial surfaces (quadric, cubic, quartic, poly) for the compiled kernel:
 * runtime/prims/polynomial.py and runtime/prims/roots.py, formula for formula. Included
 * by whitted.c only; the terms (i, j, k, coefficient) come in a table of the packed scene. */
#ifndef STRALA_POLY_H
#define STRALA_POLY_H

#include "bracket.h"
#include <float.h>
#include <math.h>

/* a polynomial of a higher degree renders through numpy (whitted.py POLY_MAX_DEGREE) */
#define POLY_MAX_DEGREE 8
#define POLY_TERM 4

typedef struct {
    const double *terms; /* i, j, k, c each */
    int nterms, degree;
} Poly;

/* value and derivative of c (lowest power first, degree n) at x (roots.horner) */
static inline void horner(const double *c, int n, double x, double *p, double *dp) {
    double v = c[n], dv = 0.0;
    for (int k = n - 1; k >= 0; k--) {
        dv = dv * x + v;
        v = v * x + c[k];
    }
    *p = v, *dp = dv;
}

typedef struct {
    const double *c;
    int n;
} PolyFdf;

static void poly_fdf(const void *ctx, double x, double *f, double *df) {
    const PolyFdf *pf = ctx;
    horner(pf->c, pf->n, x, f, df);
}

/* roots.bracketed for one polynomial (bracket.h) */
static double bracketed(const double *c, int n, double a, double b, int neg_a, double atol,
                        int max_iter) {
    PolyFdf pf = {c, n};
    return bracket_root(poly_fdf, &pf, a, b, neg_a, atol, max_iter, 0);
}

static int cmp_double(const void *x, const void *y) {
    double a = *(const double *)x, b = *(const double *)y;
    return (a > b) - (a < b);
}

/* roots.roots_in: every real root of c (lowest power first, degree n <= POLY_MAX_DEGREE) in
 * [lo, hi] into out (n values, sorted, inf where none): the derivative's roots cut the
 * interval into monotone pieces, a piece holds a root where its ends differ in sign. With
 * `ends`, f_lo and f_hi stand for the values at lo and hi (a caller whose intervals abut
 * passes one value per shared end, so the signs chain: the blob's). */
static void roots_in_ends(const double *c, int n, double lo, double hi, int ends, double f_lo,
                          double f_hi, int max_iter, double *out) {
    for (int k = 0; k < n; k++) out[k] = INFINITY;
    if (n <= 0) return;
    double atol = DBL_EPSILON * (fmax(fabs(lo), fabs(hi)) + (hi - lo));
    if (n == 1) {
        double r = -c[0] / c[1];
        out[0] = isfinite(r) && r >= lo && r <= hi ? r : INFINITY;
        return;
    }
    double dc[POLY_MAX_DEGREE], crit[POLY_MAX_DEGREE], pts[POLY_MAX_DEGREE + 1];
    double vals[POLY_MAX_DEGREE + 1];
    for (int k = 1; k <= n; k++) dc[k - 1] = c[k] * (double)k;
    roots_in_ends(dc, n - 1, lo, hi, 0, 0.0, 0.0, max_iter, crit);
    pts[0] = lo;
    for (int k = 0; k < n - 1; k++) pts[1 + k] = isfinite(crit[k]) ? crit[k] : hi;
    pts[n] = hi;
    for (int k = 0; k <= n; k++) {
        double dv;
        horner(c, n, pts[k], &vals[k], &dv);
    }
    if (ends) vals[0] = f_lo, vals[n] = f_hi;
    for (int j = 0; j < n; j++) {
        int neg = vals[j] < 0, neg_next = vals[j + 1] < 0;
        if (neg != neg_next) out[j] = bracketed(c, n, pts[j], pts[j + 1], neg, atol, max_iter);
    }
    qsort(out, (size_t)n, sizeof(double), cmp_double);
}

static inline void roots_in(const double *c, int n, double lo, double hi, int max_iter,
                            double *out) {
    roots_in_ends(c, n, lo, hi, 0, 0.0, 0.0, max_iter, out);
}

/* polynomial._fujiwara: a bound on |root| of c (degree n), 0 when it is constant */
static double fujiwara(const double *c, int n, double lead_rel, double abs_floor) {
    double big = 0.0, lead = 0.0;
    int deg = 0;
    for (int k = 0; k <= n; k++) big = fmax(big, fabs(c[k]));
    for (int k = n; k >= 1; k--)
        if (deg == 0 && fabs(c[k]) > lead_rel * big) lead = fabs(c[k]), deg = k;
    if (deg == 0) return 0.0;
    double bound = 0.0;
    for (int k = 1; k <= n; k++) {
        int idx = deg - k;
        if (idx < 0) continue;
        double ratio = fabs(c[idx]) / lead;
        if (idx == 0) ratio = ratio / 2;
        double r = pow(ratio, 1.0 / k);
        if (r != r) r = 0.0;
        bound = fmax(bound, r);
    }
    return 2 * bound * (1 + 1e-9) + abs_floor;
}

/* the polynomial's coefficients (lowest power first) along o + u d (PolyPrim.along) */
static void poly_along(const Poly *pl, const double *o, const double *d, double *cf) {
    int n = pl->degree;
    /* pw[a][e]: (o_a + u d_a)^e as coefficients, lowest first */
    double pw[3][POLY_MAX_DEGREE + 1][POLY_MAX_DEGREE + 1];
    for (int a = 0; a < 3; a++) {
        for (int e = 0; e <= n; e++)
            for (int k = 0; k <= n; k++) pw[a][e][k] = 0.0;
        pw[a][0][0] = 1.0;
        for (int e = 1; e <= n; e++)
            for (int k = 0; k <= e; k++)
                pw[a][e][k] = (k < e ? pw[a][e - 1][k] * o[a] : 0.0) +
                              (k > 0 ? pw[a][e - 1][k - 1] * d[a] : 0.0);
    }
    for (int k = 0; k <= n; k++) cf[k] = 0.0;
    for (int t = 0; t < pl->nterms; t++) {
        const double *tm = pl->terms + (size_t)t * POLY_TERM;
        int i = (int)tm[0], j = (int)tm[1], k = (int)tm[2];
        double xy[2 * POLY_MAX_DEGREE + 1] = {0.0};
        for (int p = 0; p <= i; p++)
            for (int q = 0; q <= j; q++) xy[p + q] += pw[0][i][p] * pw[1][j][q];
        for (int p = 0; p <= i + j; p++)
            for (int q = 0; q <= k; q++) cf[p + q] += tm[3] * (xy[p] * pw[2][k][q]);
    }
}

/* the value and gradient of the polynomial at p (PolyPrim.value, gradient) */
static double poly_value(const Poly *pl, const double *p, double *grad) {
    double pw[3][POLY_MAX_DEGREE + 1];
    for (int a = 0; a < 3; a++) {
        pw[a][0] = 1.0;
        for (int e = 1; e <= pl->degree; e++) pw[a][e] = pw[a][e - 1] * p[a];
    }
    double v = 0.0;
    if (grad) grad[0] = grad[1] = grad[2] = 0.0;
    for (int t = 0; t < pl->nterms; t++) {
        const double *tm = pl->terms + (size_t)t * POLY_TERM;
        int i = (int)tm[0], j = (int)tm[1], k = (int)tm[2];
        double c = tm[3];
        v += pw[0][i] * pw[1][j] * pw[2][k] * c;
        if (grad) {
            int im = i > 0 ? i - 1 : 0, jm = j > 0 ? j - 1 : 0, km = k > 0 ? k - 1 : 0;
            grad[0] += pw[0][im] * pw[1][j] * pw[2][k] * (c * i);
            grad[1] += pw[0][i] * pw[1][jm] * pw[2][k] * (c * j);
            grad[2] += pw[0][i] * pw[1][j] * pw[2][km] * (c * k);
        }
    }
    return v;
}

#endif
