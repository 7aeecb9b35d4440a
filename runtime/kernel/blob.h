/* POV-Ray's blob for the compiled kernel: runtime/prims/blob.py BlobPrim, formula for
 * formula and in its order (its sums in order, its powers as products).
 *
 * A blob's pieces (a sphere; a cylinder's middle and its two caps) are rows of the blobs'
 * table (BlobPrim.table: BLOB_PIECE values each: the 3x4 frame to the piece's unit space,
 * whether z counts, the cap's shift, the piece's z range, its strength). Along a ray each
 * piece met adds a quartic on an interval; the interval ends cut the ray into pieces of one
 * quartic each, solved on [0, 1] by roots_in with the signs at shared ends taken once.
 * Included by whitted.c only, after poly.h and its stable_quadratic. */
#ifndef STRALA_BLOB_H
#define STRALA_BLOB_H

#include <math.h>
#include <stdlib.h>

#define BLOB_PIECE 17
/* a blob's parameters (in its primitive slots): its first piece's place in the table, the
 * number of pieces, the threshold, the centre its rays are recentred on */
enum { BL_AT, BL_N, BL_THR, BL_CENTRE };
enum { BP_W, BP_USE_Z = 12, BP_SHIFT, BP_ZLO, BP_ZHI, BP_S };
/* pieces whose working arrays fit on the stack; a blob of more allocates them per ray */
#define BLOB_STACK_PIECES 32

/* the most crossings a blob of n pieces can have along a ray: four per piece of the ray */
static inline int blob_room(const double *prim) {
    int n = (int)prim[BL_N];
    return n > 0 ? 4 * (2 * n - 1) : 1;
}

static inline double bl_maximum(double a, double b) { /* np.maximum: a nan wins */
    return (a != a || b != b) ? NAN : (a > b ? a : b);
}

static inline double bl_minimum(double a, double b) {
    return (a != a || b != b) ? NAN : (a < b ? a : b);
}

/* A piece's point p in its unit frame (BlobPrim._local's, before the shift). */
static inline void bl_apply(const double *w, const double *p, double *out) {
    for (int i = 0; i < 3; i++)
        out[i] = w[4 * i] * p[0] + w[4 * i + 1] * p[1] + w[4 * i + 2] * p[2] + w[4 * i + 3];
}

/* The piece's local offset lp and its weight 1 - d^2 (0 outside it): BlobPrim._active */
static inline double bl_active(const double *pc, const double *p, double *lp) {
    bl_apply(pc + BP_W, p, lp);
    lp[2] -= pc[BP_SHIFT];
    double z = lp[2] + pc[BP_SHIFT];
    if (pc[BP_USE_Z] == 0.0) lp[2] = 0.0;
    double d2 = lp[0] * lp[0] + lp[1] * lp[1] + lp[2] * lp[2];
    return d2 < 1 && z >= pc[BP_ZLO] && z < pc[BP_ZHI] ? 1 - d2 : 0.0;
}

/* BlobPrim.density: the pieces' s (1 - d^2)^2, summed in order */
static double blob_density(const double *table, const double *prim, const double *p) {
    const double *pc = table + (size_t)prim[BL_AT];
    double sum = 0.0, lp[3];
    for (int k = 0; k < (int)prim[BL_N]; k++, pc += BLOB_PIECE) {
        double w = bl_active(pc, p, lp);
        double v = w * w * pc[BP_S];
        sum = k == 0 ? v : sum + v;
    }
    return sum;
}

/* BlobPrim.normal: minus the density's gradient, in blob space */
static void blob_normal(const double *table, const double *prim, const double *p, double *n) {
    const double *pc = table + (size_t)prim[BL_AT];
    double lp[3];
    n[0] = n[1] = n[2] = 0.0;
    for (int k = 0; k < (int)prim[BL_N]; k++, pc += BLOB_PIECE) {
        double w = bl_active(pc, p, lp), f = 4 * pc[BP_S] * w;
        double g[3] = {f * lp[0], f * lp[1], f * lp[2]};
        for (int j = 0; j < 3; j++) {
            const double *c = pc + BP_W;
            double e = g[0] * c[j] + g[1] * c[4 + j] + g[2] * c[8 + j];
            n[j] = k == 0 ? e : n[j] + e;
        }
    }
}

typedef struct {
    double t;
    int k; /* k < c: piece k enters; else piece k - c leaves (numpy's order of ties) */
} BlobEvent;

static int bl_event_cmp(const void *x, const void *y) {
    const BlobEvent *a = x, *b = y;
    if (a->t < b->t) return -1;
    if (a->t > b->t) return 1;
    return (a->k > b->k) - (a->k < b->k);
}

/* binomial(i, k) / binomial(4, k): power basis on [0, 1] to Bernstein (blob._BERNSTEIN) */
static const double BL_BERNSTEIN[5][5] = {{1, 0, 0, 0, 0},
                                          {1, 1.0 / 4, 0, 0, 0},
                                          {1, 2.0 / 4, 1.0 / 6, 0, 0},
                                          {1, 3.0 / 4, 3.0 / 6, 1.0 / 4, 0},
                                          {1, 1, 1, 1, 1}};

/* BlobPrim._solve for one ray: the crossings (unit-ray parameters) of its c pieces met
 * (intervals tin-tout, quartics q, positive strengths pos) into u; returns how many. */
static int bl_solve(int c, const double *tin, const double *tout, const double *q,
                    const double *pos, double thr, double inside_tol, int max_iter,
                    BlobEvent *ev, double *coef, int *okl, unsigned char *cand, double *u) {
    int ne = 2 * c, nsub = ne - 1, nu = 0;
    for (int j = 0; j < c; j++) ev[j] = (BlobEvent){tin[j], j}, ev[c + j] = (BlobEvent){tout[j], c + j};
    if (ne <= 64) { /* insertion sort: stable, as numpy's, and (t, k) orders ties the same */
        for (int a = 1; a < ne; a++)
            for (int b = a; b > 0 && bl_event_cmp(&ev[b], &ev[b - 1]) < 0; b--) {
                BlobEvent x = ev[b];
                ev[b] = ev[b - 1], ev[b - 1] = x;
            }
    } else {
        qsort(ev, (size_t)ne, sizeof(BlobEvent), bl_event_cmp);
    }
    double sums[5] = {0.0}, reach = 0.0, floor = thr - inside_tol * (1 + fabs(thr));
    int nok = 0;
    for (int k = 0; k < nsub; k++) {
        int j = ev[k].k < c ? ev[k].k : ev[k].k - c;
        double sign = ev[k].k < c ? 1.0 : -1.0;
        for (int i = 0; i < 5; i++) {
            double dv = sign > 0 ? q[5 * j + i] : -q[5 * j + i];
            sums[i] = k == 0 ? dv : sums[i] + dv;
        }
        double dp = sign > 0 ? pos[j] : -pos[j];
        reach = k == 0 ? dp : reach + dp;
        double left = ev[k].t, right = ev[k + 1].t;
        if (!(isfinite(right) && right > left)) continue;
        okl[nok] = k;
        cand[nok] = reach > floor;
        if (cand[nok]) { /* the quartic on [0, 1] from the sub-interval's left end */
            double *cf = coef + 5 * (size_t)nok;
            for (int i = 0; i < 5; i++) cf[i] = sums[i];
            for (int i = 0; i < 4; i++) /* blob._taylor_shift */
                for (int m = 3; m >= i; m--) cf[m] += left * cf[m + 1];
            cf[0] -= thr;
            double w = right - left, w2 = w * w;
            cf[1] *= w, cf[2] *= w2, cf[3] *= w2 * w, cf[4] *= w2 * w2;
        }
        nok++;
    }
    double outside = thr > 0 ? -1.0 : -thr;
    for (int m = 0; m < nok; m++) {
        if (!cand[m]) continue;
        const double *cf = coef + 5 * (size_t)m;
        double f_lo = m > 0 && cand[m - 1] ? cf[0] : outside;
        double f_hi = m + 1 < nok && cand[m + 1] ? coef[5 * (size_t)(m + 1)] : outside;
        int all_pos = f_lo >= 0 && f_hi >= 0, all_neg = f_lo < 0 && f_hi < 0;
        for (int r = 0; r < 5; r++) {
            double b = cf[0] * BL_BERNSTEIN[r][0];
            for (int i = 1; i < 5; i++) b = b + cf[i] * BL_BERNSTEIN[r][i];
            all_pos = all_pos && b > 0;
            all_neg = all_neg && b < 0;
        }
        if (all_pos || all_neg) continue;
        double x[4], left = ev[okl[m]].t, w = ev[okl[m] + 1].t - left;
        roots_in_ends(cf, 4, 0.0, 1.0, 1, f_lo, f_hi, max_iter, x);
        for (int r = 0; r < 4; r++)
            if (isfinite(x[r])) u[nu++] = left + w * x[r];
    }
    return nu;
}

/* BlobPrim.crossings for an object-space ray: every crossing, ascending, into t (room for
 * blob_room of them); returns how many. */
static int blob_crossings(const double *table, const double *prim, double inside_tol,
                          int max_iter, const double *o, const double *d, double *t) {
    int np = (int)prim[BL_N];
    if (np == 0) return 0;
    double dd = d[0] * d[0] + d[1] * d[1] + d[2] * d[2], dl = sqrt(dd);
    int good = dl > 0;
    if (!good) return 0;
    double du[3] = {d[0] / dl, d[1] / dl, d[2] / dl};
    const double *ctr = prim + BL_CENTRE;
    double co[3] = {ctr[0] - o[0], ctr[1] - o[1], ctr[2] - o[2]};
    double t0 = dd > 0 ? (co[0] * d[0] + co[1] * d[1] + co[2] * d[2]) / dd : 0.0;
    double oc[3] = {o[0] + t0 * d[0], o[1] + t0 * d[1], o[2] + t0 * d[2]};
    /* per piece: tin, tout, quartic (5), positive strength, then 5 per sub-interval (its
     * quartic); events; the sub-intervals of positive width and their candidacy */
    double stack_d[BLOB_STACK_PIECES * 18];
    BlobEvent stack_e[2 * BLOB_STACK_PIECES];
    int stack_i[2 * BLOB_STACK_PIECES];
    unsigned char stack_c[2 * BLOB_STACK_PIECES];
    double *work = stack_d;
    BlobEvent *ev = stack_e;
    int *okl = stack_i;
    unsigned char *cand = stack_c;
    void *heap = NULL;
    if (np > BLOB_STACK_PIECES) {
        size_t nd = (size_t)np * 18, ne = 2 * (size_t)np;
        heap = malloc(nd * sizeof(double) + ne * (sizeof(BlobEvent) + sizeof(int) + 1));
        if (heap == NULL) return 0;
        work = heap;
        ev = (BlobEvent *)(work + nd);
        okl = (int *)(ev + ne);
        cand = (unsigned char *)(okl + ne);
    }
    double *tin = work, *tout = work + np, *q = work + 2 * np, *pos = work + 7 * np;
    double *coef = work + 8 * np; /* 5 per sub-interval: 2 np - 1 of them */
    const double *pc = table + (size_t)prim[BL_AT];
    int c = 0;
    for (int k = 0; k < np; k++, pc += BLOB_PIECE) {
        double lo[3], ld[3];
        const double *w = pc + BP_W;
        bl_apply(w, oc, lo);
        for (int i = 0; i < 3; i++) ld[i] = w[4 * i] * du[0] + w[4 * i + 1] * du[1] + w[4 * i + 2] * du[2];
        double z0 = lo[2], dz = ld[2], mask = pc[BP_USE_Z] != 0.0 ? 1.0 : 0.0;
        lo[2] -= pc[BP_SHIFT];
        lo[2] *= mask;
        ld[2] *= mask;
        double qa = ld[0] * ld[0] + ld[1] * ld[1] + ld[2] * ld[2];
        double qb = lo[0] * ld[0] + lo[1] * ld[1] + lo[2] * ld[2];
        double qc = lo[0] * lo[0] + lo[1] * lo[1] + lo[2] * lo[2];
        double t1, t2, cc = qc - 1;
        stable_quadratic(qa, qb, cc, qb * qb - qa * cc, &t1, &t2);
        if (qa <= 0) { /* along a cylinder's axis: its distance to the axis never changes */
            t1 = qc < 1 ? -INFINITY : INFINITY;
            t2 = qc < 1 ? INFINITY : -INFINITY;
        }
        double zlo = pc[BP_ZLO], zhi = pc[BP_ZHI], zin, zout;
        if (dz == 0) {
            int in_slab = z0 >= zlo && z0 < zhi;
            zin = in_slab ? -INFINITY : INFINITY;
            zout = in_slab ? INFINITY : -INFINITY;
        } else {
            double za = (zlo - z0) / dz, zb = (zhi - z0) / dz;
            zin = fmin(za, zb), zout = fmax(za, zb);
        }
        double a = bl_maximum(t1, zin), b = bl_minimum(t2, zout);
        if (!(isfinite(a) && a < b)) continue;
        double s = pc[BP_S], w0 = 1 - qc, w1 = -2 * qb, w2 = -qa;
        tin[c] = a, tout[c] = b, pos[c] = s > 0 ? s : 0.0;
        double *qq = q + 5 * (size_t)c;
        qq[0] = s * (w0 * w0);
        qq[1] = s * (2 * w0 * w1);
        qq[2] = s * (w1 * w1 + 2 * w0 * w2);
        qq[3] = s * (2 * w1 * w2);
        qq[4] = s * (w2 * w2);
        c++;
    }
    int n = 0;
    if (c > 0) {
        double u[4 * (2 * BLOB_STACK_PIECES - 1)], *us = u;
        double *uh = NULL;
        if (c > BLOB_STACK_PIECES) {
            uh = malloc(sizeof(double) * 4 * (2 * (size_t)c - 1));
            if (uh == NULL) {
                free(heap);
                return 0;
            }
            us = uh;
        }
        int nu = bl_solve(c, tin, tout, q, pos, prim[BL_THR], inside_tol, max_iter, ev, coef,
                          okl, cand, us);
        for (int j = 0; j < nu; j++)
            if (isfinite(us[j])) t[n++] = us[j] / dl + t0;
        free(uh);
        qsort(t, (size_t)n, sizeof(double), cmp_double); /* ascending, as roots.compact */
    }
    free(heap);
    return n;
}

#endif
