/* roots.bracketed for one problem, for any f: the root finder the compiled shapes share
 * (poly.h's polynomials, superellipsoid.h's field). Included by them only. */
#ifndef STRALA_BRACKET_H
#define STRALA_BRACKET_H

#include <float.h>
#include <math.h>

/* f and f' at x of the problem `ctx` */
typedef void (*BracketFdf)(const void *ctx, double x, double *f, double *df);

/* A root in [a, b] (either order) where f(a) < 0 is neg_a and f(b) has the other sign;
 * Newton from the end evaluated last, bisection otherwise (roots.bracketed, step for step;
 * cusp_ends: no Newton step from a and b themselves). Static inline with a constant `fdf`
 * at each call: the compiler inlines f there. */
static inline double bracket_root(BracketFdf fdf, const void *ctx, double a, double b,
                                  int neg_a, double atol, int max_iter, int cusp_ends) {
    double fa, dfa, fb, dfb;
    fdf(ctx, a, &fa, &dfa);
    fdf(ctx, b, &fb, &dfb);
    if (cusp_ends) dfa = dfb = NAN;
    double f_ref = fmin(fabs(fa), fabs(fb));
    int newest_b = fabs(fb) < fabs(fa);
    const double tiny = 4 * DBL_EPSILON;
    for (int it = 0; it < max_iter; it++) {
        double lo = a < b ? a : b, hi = a < b ? b : a;
        double eps = tiny * fmax(fabs(lo), fabs(hi)) + atol;
        double da = fa / dfa, db = fb / dfb, na = a - da, nb = b - db;
        int ok_a = isfinite(na) && na >= lo && na <= hi;
        int ok_b = isfinite(nb) && nb >= lo && nb <= hi;
        int use_b = ok_b && (!ok_a || newest_b);
        double step = use_b ? fabs(db) : fabs(da);
        int newton = (ok_a || ok_b) && it > 0;
        if (it % 4 == 3) {
            double f_now = fmin(fabs(fa), fabs(fb));
            newton = newton && !(f_now > 0.5 * f_ref);
            f_ref = f_now;
        }
        double x = newton ? (use_b ? nb : na) : 0.5 * (lo + hi);
        if (fa == 0 || fb == 0 || hi - lo <= eps || (newton && step <= eps))
            return fa == 0 ? a : (fb == 0 ? b : x);
        double f, df;
        fdf(ctx, x, &f, &df);
        int same = (f < 0) == neg_a;
        if (same) a = x, fa = f, dfa = df;
        else b = x, fb = f, dfb = df;
        newest_b = !same;
    }
    return 0.5 * (a + b);
}

#endif
