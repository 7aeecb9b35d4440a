/* trace.slab_hits for one ray and one finite box, shared by the compiled kernel (whitted.c)
 * and the numpy path's compiled box tests (boxtree.c): the numpy formula's operations in
 * its order. */
#ifndef STRALA_SLAB_H
#define STRALA_SLAB_H

#include <math.h>

/* numpy's fmin/fmax: a NaN (0 * inf, a ray in a slab's plane) loses to the other value.
 * Written out so they inline (the libm calls do not without -ffast-math). */
static inline double fmin_nan(double a, double b) { return (a < b || b != b) ? a : b; }
static inline double fmax_nan(double a, double b) { return (a > b || b != b) ? a : b; }

/* May the segment (tmin, tmax) of the ray o + t/inv touch the box [lo, hi]? Widened by
 * rel * (|t near| + |t far|) + abs, so that a hit on the box surface is never culled. */
static inline int slab_padded(const double *lo, const double *hi, const double *o,
                              const double *inv, double tmin, double tmax, double rel,
                              double abs_) {
    double tn = -INFINITY, tf = INFINITY;
    for (int i = 0; i < 3; i++) {
        double t1 = (lo[i] - o[i]) * inv[i], t2 = (hi[i] - o[i]) * inv[i];
        double near = fmin_nan(t1, t2), far = fmax_nan(t1, t2);
        tn = i == 0 ? near : fmax_nan(tn, near);
        tf = i == 0 ? far : fmin_nan(tf, far);
    }
    double pad = rel * (fabs(tn) + fabs(tf)) + abs_;
    return tn - pad <= tf + pad && tf + pad >= tmin && tn - pad <= tmax;
}

#endif
