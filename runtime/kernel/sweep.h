/* Swept 2D spline curves: POV-Ray's prism and text (runtime/prims/prism.py Sweep, with the
 * root finding of runtime/prims/spline2d.py), for the compiled kernel.
 *
 * A sweep's closed curves lie in the (u, v) plane and are swept along w from h1 to h2
 * (straight, or for a conic sweep scaled by w toward the apex). Walls are where the ray's
 * line, projected along the sweep, crosses a segment: one cubic per segment the line's box
 * test keeps. Caps are end-plane hits inside the curves by the even-odd rule; several groups
 * of curves (glyphs) form a union. Every step follows the numpy formulas in their order.
 *
 * The packed sweep (whitted.py pack_sweep) is a row of the sweep table: groups (SG values:
 * box, first segment, count), then segments (SS values: x and y cubics highest power first,
 * their exact box, whether the end joins a start). */
#ifndef STRALA_SWEEP_H
#define STRALA_SWEEP_H

#include <math.h>

/* an object's sweep parameters (in its primitive slots) */
enum { SW_AT, SW_NGROUP, SW_NSEG, SW_H1, SW_H2, SW_AXES, SW_CONIC = SW_AXES + 3, SW_OPEN,
       SW_SIZE, SW_LO, SW_HI = SW_LO + 3, SW_DEGENERATE = SW_HI + 3 };
enum { SG_LO, SG_HI = 2, SG_FIRST = 4, SG_COUNT, SG };
enum { SS_X, SS_Y = 4, SS_LO = 8, SS_HI = 10, SS_JOINED = 12, SS };
/* a face id of 2 + segment index modulo SWEEP_WALL_MOD, as prism.WALL_MOD */
#define SWEEP_WALL_MOD 126
/* crossings of one sweep along one ray that are kept (the nearest) */
#define SWEEP_MAX_CROSS 64

typedef struct {
    double parallel, abs_floor, lead_rel, newton_max_step, param_eps, side_rel;
    int newton_steps;
} SweepTol;

typedef struct {
    const double *groups, *segs;
    int ngroup, nseg;
} SweepView;

static inline SweepView sweep_view(const double *table, const double *prim) {
    SweepView v;
    v.groups = table + (size_t)prim[SW_AT];
    v.ngroup = (int)prim[SW_NGROUP];
    v.nseg = (int)prim[SW_NSEG];
    v.segs = v.groups + (size_t)v.ngroup * SG;
    return v;
}

static inline double sp_polyval(const double *c, int n, double t) {
    double out = 0.0;
    for (int k = 0; k < n; k++) out = out * t + c[k];
    return out;
}

/* spline2d._cubic: a cubic's real roots, closed form; nan-padded */
static void sp_cubic(const double *c, double *out) {
    double A = c[1] / c[0], B = c[2] / c[0], C = c[3] / c[0];
    double Q = (A * A - 3 * B) / 9;
    double R = (2 * pow(A, 3) - 9 * A * B + 27 * C) / 54;
    double q3 = pow(Q, 3);
    if (R * R < q3) {
        double sq = sqrt(Q), x = R / pow(sq, 3);
        double th = acos(x < -1.0 ? -1.0 : (x > 1.0 ? 1.0 : x));
        static const double shift[3] = {0.0, 2 * M_PI, -2 * M_PI};
        for (int k = 0; k < 3; k++) out[k] = -2 * sq * cos((th + shift[k]) / 3) - A / 3;
        return;
    }
    double diff = R * R - q3;
    double sign = R > 0 ? 1.0 : (R < 0 ? -1.0 : 0.0);
    double big = -sign * cbrt(fabs(R) + sqrt(diff > 0.0 ? diff : 0.0));
    double small = big != 0 ? Q / big : 0.0;
    out[0] = big + small - A / 3;
    out[1] = out[2] = NAN;
}

/* spline2d.real_roots then polish, for one cubic c (highest power first): 3 roots,
 * nan-padded; leading terms below lead_rel of the largest are dropped */
static void sp_roots(const SweepTol *tl, const double *c, double *out) {
    double scale = 0.0, cn[4];
    for (int k = 0; k < 4; k++)
        if (fabs(c[k]) > scale) scale = fabs(c[k]);
    for (int k = 0; k < 4; k++) cn[k] = c[k] / (scale > 0 ? scale : 1.0);
    int first = 4;
    for (int k = 0; k < 4 && first == 4; k++)
        if (fabs(cn[k]) > tl->lead_rel) first = k;
    int deg = first == 4 ? 0 : 3 - first;
    out[0] = out[1] = out[2] = NAN;
    if (deg == 1) {
        out[0] = -cn[3] / cn[2];
    } else if (deg == 2) {
        double a = cn[1], b = cn[2], cc = cn[3], disc = b * b - 4 * a * cc;
        if (disc >= 0) {
            double q = -0.5 * (b + copysign(sqrt(disc), b));
            out[0] = q / a;
            out[1] = q != 0 ? cc / q : q / a;
        }
    } else if (deg == 3) {
        sp_cubic(cn, out);
    }
    double dc[3] = {cn[0] * 3.0, cn[1] * 2.0, cn[2] * 1.0};
    for (int r = 0; r < 3; r++) {
        double x = out[r];
        for (int it = 0; it < tl->newton_steps + 1; it++) {
            double f = sp_polyval(cn, 4, x), fp = sp_polyval(dc, 3, x);
            double step = fp != 0 ? f / fp : 0.0;
            if (fabs(step) < tl->newton_max_step * (1.0 + fabs(x))) x = x - step;
        }
        out[r] = x;
    }
}

/* spline2d.in_window: a crossing at a joint counts once */
static inline int sp_in_window(const SweepTol *tl, double t, int joined) {
    double e = tl->param_eps, hi = joined ? 1.0 - e : 1.0 + e;
    return t >= -e && t < hi;
}

static inline double sp_clip01(double t) {
    if (t != t) t = 0.0; /* nan_to_num, then the clip */
    return t < 0.0 ? 0.0 : (t > 1.0 ? 1.0 : t);
}

/* Curve.contains: crossings of the ray from q toward +x, odd */
static int sp_contains(const SweepTol *tl, const double *segs, int first, int count,
                       const double *q) {
    int total = 0;
    for (int i = first; i < first + count; i++) {
        const double *sg = segs + (size_t)i * SS;
        if (!(sg[SS_LO + 1] <= q[1] && sg[SS_HI + 1] >= q[1] && sg[SS_HI] >= q[0])) continue;
        double py[4] = {sg[SS_Y], sg[SS_Y + 1], sg[SS_Y + 2], sg[SS_Y + 3] - q[1]}, t[3];
        sp_roots(tl, py, t);
        for (int r = 0; r < 3; r++) {
            int ok = sp_in_window(tl, t[r], (int)sg[SS_JOINED]);
            double x = sp_polyval(sg + SS_X, 4, sp_clip01(t[r]));
            total += ok && x >= q[0];
        }
    }
    return total % 2 == 1;
}

/* Sweep.in_region: inside some group's curves */
static int sweep_in_region(const SweepTol *tl, const SweepView *v, const double *q) {
    for (int g = 0; g < v->ngroup; g++) {
        const double *gr = v->groups + (size_t)g * SG;
        if (q[0] >= gr[SG_LO] && q[1] >= gr[SG_LO + 1] && q[0] <= gr[SG_HI] &&
            q[1] <= gr[SG_HI + 1] &&
            sp_contains(tl, v->segs, (int)gr[SG_FIRST], (int)gr[SG_COUNT], q))
            return 1;
    }
    return 0;
}

static inline void sweep_uvw(const double *prim, const double *p, double *out) {
    for (int k = 0; k < 3; k++) out[k] = p[(int)prim[SW_AXES + k]];
}

/* Sweep.inside: h1 <= w < h2 and inside the curves (POV-Ray's rule) */
static int sweep_inside(const SweepTol *tl, const double *table, const double *prim,
                        const double *p) {
    SweepView v = sweep_view(table, prim);
    double uvw[3], q[2];
    sweep_uvw(prim, p, uvw);
    q[0] = uvw[0], q[1] = uvw[1];
    if ((int)prim[SW_CONIC]) {
        if (!(fabs(uvw[2]) > tl->parallel)) return 0;
        q[0] = q[0] / uvw[2], q[1] = q[1] / uvw[2];
    }
    if (!(uvw[2] >= prim[SW_H1] && uvw[2] < prim[SW_H2])) return 0;
    return sweep_in_region(tl, &v, q);
}

/* Keeps the nearest `cap` crossings: *n of them in t/face. */
static inline void sweep_keep(double k, int f, double *t, int *face, int *n, int cap) {
    if (*n < cap) {
        t[*n] = k, face[*n] = f, (*n)++;
        return;
    }
    int far = 0;
    for (int j = 1; j < cap; j++)
        if (t[j] > t[far]) far = j;
    if (k < t[far]) t[far] = k, face[far] = f;
}

/* A line a u + b v + c = 0 meets the box [lo, hi]: its sign changes over the corners. */
static inline int sp_line_meets(const double *L, const double *lo, const double *hi) {
    double v0 = L[0] * lo[0] + L[1] * lo[1] + L[2], v1 = L[0] * hi[0] + L[1] * lo[1] + L[2];
    double v2 = L[0] * lo[0] + L[1] * hi[1] + L[2], v3 = L[0] * hi[0] + L[1] * hi[1] + L[2];
    if (v0 != v0 || v1 != v1 || v2 != v2 || v3 != v3) return 0; /* numpy's min keeps a nan */
    double mn = fmin(fmin(v0, v1), fmin(v2, v3)), mx = fmax(fmax(v0, v1), fmax(v2, v3));
    return mn <= 0 && mx >= 0;
}

/* Sweep.crossings for an object-space ray: the walls' and caps' ray parameters (at most
 * cap of them, the nearest), face ids 0 and 1 for the caps, 2 + segment mod WALL_MOD. */
static int sweep_crossings(const SweepTol *tl, const double *table, const double *prim,
                           const double *o, const double *d, double *t, int *face, int cap) {
    if ((int)prim[SW_DEGENERATE]) return 0;
    SweepView v = sweep_view(table, prim);
    const double *lo = prim + SW_LO, *hi = prim + SW_HI;
    /* recentred on the shape: far origins would cancel in the line terms */
    double centre[3], dd = d[0] * d[0] + d[1] * d[1] + d[2] * d[2], t0 = 0.0, oc[3];
    for (int k = 0; k < 3; k++) centre[k] = 0.5 * (lo[k] + hi[k]);
    if (dd > 0) {
        double cd = (centre[0] - o[0]) * d[0] + (centre[1] - o[1]) * d[1] +
                    (centre[2] - o[2]) * d[2];
        t0 = cd / dd;
    }
    for (int k = 0; k < 3; k++) oc[k] = o[k] + t0 * d[k];
    double P[3], D[3];
    sweep_uvw(prim, oc, P);
    sweep_uvw(prim, d, D);
    int conic = (int)prim[SW_CONIC], n = 0;
    double h1 = prim[SW_H1], h2 = prim[SW_H2];
    double L[3];
    if (conic) { /* the plane through the apex and the ray meets w = 1 in a line */
        L[0] = P[1] * D[2] - P[2] * D[1];
        L[1] = P[2] * D[0] - P[0] * D[2];
        L[2] = P[0] * D[1] - P[1] * D[0];
    } else {
        L[0] = D[1], L[1] = -D[0], L[2] = D[0] * P[1] - D[1] * P[0];
    }
    double scale = fmax(fabs(L[0]), fabs(L[1]));
    if (scale > tl->parallel * (1.0 + fabs(L[2]))) {
        for (int k = 0; k < 3; k++) L[k] = L[k] / scale;
        for (int g = 0; g < v.ngroup; g++) {
            const double *gr = v.groups + (size_t)g * SG;
            if (!sp_line_meets(L, gr + SG_LO, gr + SG_HI)) continue;
            int first = (int)gr[SG_FIRST], count = (int)gr[SG_COUNT];
            for (int i = first; i < first + count; i++) {
                const double *sg = v.segs + (size_t)i * SS;
                if (!sp_line_meets(L, sg + SS_LO, sg + SS_HI)) continue;
                double pc[4], r[3];
                for (int k = 0; k < 4; k++) pc[k] = L[0] * sg[SS_X + k] + L[1] * sg[SS_Y + k];
                pc[3] += L[2];
                sp_roots(tl, pc, r);
                for (int j = 0; j < 3; j++) {
                    double u = r[j];
                    if (!sp_in_window(tl, u, (int)sg[SS_JOINED])) continue;
                    u = u < 0.0 ? 0.0 : (u > 1.0 ? 1.0 : u);
                    double X = sp_polyval(sg + SS_X, 4, u), Y = sp_polyval(sg + SS_Y, 4, u), k;
                    if (conic) { /* P + k D = s (X, Y, 1) */
                        double V[3] = {X, Y, 1.0}, pv[3], dv[3];
                        pv[0] = P[1] * V[2] - P[2] * V[1], dv[0] = D[1] * V[2] - D[2] * V[1];
                        pv[1] = P[2] * V[0] - P[0] * V[2], dv[1] = D[2] * V[0] - D[0] * V[2];
                        pv[2] = P[0] * V[1] - P[1] * V[0], dv[2] = D[0] * V[1] - D[1] * V[0];
                        double den = dv[0] * dv[0] + dv[1] * dv[1] + dv[2] * dv[2];
                        k = -(pv[0] * dv[0] + pv[1] * dv[1] + pv[2] * dv[2]) / den;
                    } else {
                        double den = D[0] * D[0] + D[1] * D[1];
                        k = ((X - P[0]) * D[0] + (Y - P[1]) * D[1]) / den;
                    }
                    double w = P[2] + k * D[2];
                    if (isfinite(k) && w >= h1 && w <= h2)
                        sweep_keep(k + t0, 2 + i % SWEEP_WALL_MOD, t, face, &n, cap);
                }
            }
        }
    }
    if (!(int)prim[SW_OPEN]) {
        for (int f = 0; f < 2; f++) {
            double h = f == 0 ? h1 : h2;
            if (conic && fabs(h) <= tl->parallel) continue;
            if (!(fabs(D[2]) > tl->parallel)) continue;
            double k = (h - P[2]) / D[2];
            if (!isfinite(k)) continue;
            double q[2] = {P[0] + k * D[0], P[1] + k * D[1]};
            if (conic) q[0] = q[0] / h, q[1] = q[1] / h;
            if (sweep_in_region(tl, &v, q)) sweep_keep(k + t0, f, t, face, &n, cap);
        }
    }
    return n;
}

/* spline2d.locate: the segment (among first, first + step, ... below nseg) and parameter
 * (*t_out) of the curve point nearest q, over the roots of x(t) = qx, y(t) = qy and the
 * ends; -1 when every distance is nan */
static int sp_locate(const SweepTol *tl, const double *segs, int first, int nseg, int step,
                     const double *q, double *t_out) {
    int best_seg = -1;
    double best_t = 0.0, best = INFINITY;
    for (int c = first; c < nseg; c += step) {
        const double *sg = segs + (size_t)c * SS;
        double ts[8];
        for (int a = 0; a < 2; a++) {
            const double *cf = sg + (a ? SS_Y : SS_X);
            double pc[4] = {cf[0], cf[1], cf[2], cf[3] - q[a]};
            sp_roots(tl, pc, ts + 3 * a);
        }
        ts[6] = 0.0, ts[7] = 1.0;
        for (int j = 0; j < 8; j++) {
            double tt = sp_clip01(ts[j]);
            double dx = sp_polyval(sg + SS_X, 4, tt) - q[0], dy = sp_polyval(sg + SS_Y, 4, tt) - q[1];
            double dist = dx * dx + dy * dy;
            if (dist < best) best = dist, best_seg = c, best_t = tt;
        }
    }
    *t_out = best_t;
    return best_seg;
}

/* Sweep.normal at an object-space surface point (not unit): caps along w; a wall's
 * segment found again by spline2d.locate among those of its face id, turned outward. */
static void sweep_normal(const SweepTol *tl, const double *table, const double *prim,
                         const double *p, int face, double *n) {
    int iu = (int)prim[SW_AXES], iv = (int)prim[SW_AXES + 1], iw = (int)prim[SW_AXES + 2];
    n[0] = n[1] = n[2] = 0.0;
    if (face == 0 || face == 1) {
        n[iw] = face == 0 ? -1.0 : 1.0;
        return;
    }
    SweepView v = sweep_view(table, prim);
    if (v.nseg == 0) return;
    int conic = (int)prim[SW_CONIC];
    double uvw[3], q[2];
    sweep_uvw(prim, p, uvw);
    q[0] = uvw[0], q[1] = uvw[1];
    if (conic) {
        double w = fabs(uvw[2]) > tl->parallel ? uvw[2] : 1.0;
        q[0] = q[0] / w, q[1] = q[1] / w;
    }
    double best_t;
    int best_seg = sp_locate(tl, v.segs, face - 2, v.nseg, SWEEP_WALL_MOD, q, &best_t);
    if (best_seg < 0) best_seg = face - 2, best_t = 0.0; /* every distance nan */
    const double *sg = v.segs + (size_t)best_seg * SS;
    double dx[3] = {sg[SS_X] * 3.0, sg[SS_X + 1] * 2.0, sg[SS_X + 2] * 1.0};
    double dy[3] = {sg[SS_Y] * 3.0, sg[SS_Y + 1] * 2.0, sg[SS_Y + 2] * 1.0};
    double tan0 = sp_polyval(dx, 3, best_t), tan1 = sp_polyval(dy, 3, best_t);
    double n2[2] = {tan1, -tan0}, len = sqrt(n2[0] * n2[0] + n2[1] * n2[1]);
    if (len > 0) n2[0] = n2[0] / len, n2[1] = n2[1] / len;
    /* outward: just off the wall along n2 lies outside the curves */
    double step = tl->side_rel * fmax(prim[SW_SIZE], tl->abs_floor);
    if (conic) step = step / fmax(fabs(uvw[2]), tl->abs_floor);
    double off[2] = {q[0] + step * n2[0], q[1] + step * n2[1]};
    if (sweep_in_region(tl, &v, off)) n2[0] = -n2[0], n2[1] = -n2[1];
    n[iu] = n2[0], n[iv] = n2[1];
    if (conic) {
        double w = uvw[2];
        n[iw] = fabs(w) > tl->parallel ? -(uvw[0] * n2[0] + uvw[1] * n2[1]) / w : 0.0;
    }
}

#endif
