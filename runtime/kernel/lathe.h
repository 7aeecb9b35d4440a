/* POV-Ray's lathe and sor for the compiled kernel: runtime/prims/lathe.py LathePrim, formula for
 * formula and in its order (the ray recentred and made unit, each segment's bounding shell,
 * the polynomial of twice the spline's degree in u solved by roots_in over LATHE_WINDOW,
 * the joint Newton polish of (u, k), in_window). Included by whitted.c after sweep.h and
 * poly.h; the profile's segments are rows of the sweeps' table (SS values each: x and y
 * cubics, exact box, joined end), as a prism's are. */
#ifndef STRALA_LATHE_H
#define STRALA_LATHE_H

#include <math.h>

/* a lathe's primitive slots: its segments in the sweeps' table, how many, box, size, the
 * profile's height range, whether it has no segment; the tolerances it reads (tolerances.py:
 * ROOT_MAX_ITER, LATHE_FLAT_DIR, BOX_PAD_REL, BOX_PAD_ABS) */
enum { LA_AT, LA_NSEG, LA_LO, LA_HI = LA_LO + 3, LA_SIZE = LA_HI + 3, LA_YLO, LA_YHI,
       LA_DEGENERATE, LA_ROOT_ITER, LA_FLAT, LA_PAD_REL, LA_PAD_ABS };
/* lathe.LATHE_MOD, LATHE_WINDOW */
#define LATHE_MOD 127
#define LATHE_WLO (-0.2)
#define LATHE_WHI 1.2

/* lathe._cylinder_pairs for one segment: can the line P + k D (unit D) meet the shell
 * rmin..rmax between heights h1..h2? (pad_rel, pad_abs: tolerances.BOX_PAD_*) */
static int shell_pair(const SweepTol *tl, double pad_rel, double pad_abs, double h1, double h2,
                      double rmin, double rmax, const double *P, const double *D) {
    double pad = pad_rel * (1.0 + fabs(h2 - h1)) + pad_abs;
    double Py = P[1], Dy = D[1];
    int flat = fabs(Dy) <= tl->parallel;
    double ka = flat ? -INFINITY : (h1 - pad - Py) / Dy, kb = flat ? INFINITY : (h2 + pad - Py) / Dy;
    double a = ka < kb ? ka : kb, b = ka < kb ? kb : ka; /* np.minimum, np.maximum */
    if (ka != ka || kb != kb) a = b = NAN;
    int within = !flat || (Py >= h1 - pad && Py <= h2 + pad);
    double r = D[0] * D[0] + D[2] * D[2], m = P[0] * D[0] + P[2] * D[2];
    double rho0 = P[0] * P[0] + P[2] * P[2];
    double kstar = r > 0 ? -m / r : 0.0;
    kstar = kstar < a ? a : kstar; /* np.clip */
    kstar = kstar > b ? b : kstar;
    double k3[3] = {kstar, a, b}, v[3];
    for (int j = 0; j < 3; j++) {
        double k = k3[j];
        v[j] = isinf(k) ? (r > 0 ? INFINITY : rho0) : r * k * k + 2 * m * k + rho0;
    }
    double lo = v[0], hi = v[1] > v[2] ? v[1] : v[2];
    if (v[1] != v[1] || v[2] != v[2]) hi = NAN;
    double rpad = 1.0 + 1e-6;
    return within && lo <= rmax * rmax * rpad + pad && hi >= rmin * rmin / rpad - pad;
}

/* a lathe segment's shell: its box's heights, the radii its x reaches (LathePrim) */
static int lathe_pair(const SweepTol *tl, const double *prim, const double *sg, const double *P,
                      const double *D) {
    double xl = sg[SS_LO], xh = sg[SS_HI];
    double rmax = fabs(xl) > fabs(xh) ? fabs(xl) : fabs(xh);
    double rmin = (xl <= 0 && xh >= 0) ? 0.0 : (fabs(xl) < fabs(xh) ? fabs(xl) : fabs(xh));
    return shell_pair(tl, prim[LA_PAD_REL], prim[LA_PAD_ABS], sg[SS_LO + 1], sg[SS_HI + 1], rmin,
                      rmax, P, D);
}

/* lathe._unit_recentred: the unit direction D, the origin moved to the line's point P
 * nearest the box's centre; t = t0 + k / dl */
static void unit_recentred(const double *prim_lo, const double *prim_hi, const double *o,
                           const double *d, double *P, double *D, double *t0, double *dl_out) {
    double dl = sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]), c[3];
    dl = dl > 0 ? dl : 1.0;
    for (int j = 0; j < 3; j++) D[j] = d[j] / dl;
    for (int j = 0; j < 3; j++) c[j] = 0.5 * (prim_lo[j] + prim_hi[j]) - o[j];
    double k0 = c[0] * D[0] + c[1] * D[1] + c[2] * D[2];
    for (int j = 0; j < 3; j++) P[j] = o[j] + k0 * D[j];
    *t0 = k0 / dl, *dl_out = dl;
}

/* LathePrim._polish for one candidate: 1 when (u, k) settle on the surface */
static int lathe_polish(const SweepTol *tl, const double *sg, double scale, const double *P,
                        const double *D, double *u_io, double *k_io) {
    const double *X = sg + SS_X, *Y = sg + SS_Y;
    double dX[3] = {X[0] * 3.0, X[1] * 2.0, X[2] * 1.0};
    double dY[3] = {Y[0] * 3.0, Y[1] * 2.0, Y[2] * 1.0};
    double u = *u_io, k = *k_io;
    for (int it = 0; it < tl->newton_steps + 1; it++) {
        double x = sp_polyval(X, 4, u), y = sp_polyval(Y, 4, u);
        double xp = sp_polyval(dX, 3, u), yp = sp_polyval(dY, 3, u);
        double qx = P[0] + k * D[0], qz = P[2] + k * D[2];
        double f1 = y - P[1] - k * D[1], f2 = qx * qx + qz * qz - x * x;
        double j11 = yp, j12 = -D[1], j21 = -2 * x * xp, j22 = 2 * (qx * D[0] + qz * D[2]);
        double det = j11 * j22 - j12 * j21;
        double du = (f1 * j22 - j12 * f2) / det, dk = (j11 * f2 - j21 * f1) / det;
        if (isfinite(du) && isfinite(dk) && fabs(du) < tl->newton_max_step &&
            fabs(dk) < tl->newton_max_step * scale)
            u = u - du, k = k - dk;
    }
    double x = sp_polyval(X, 4, u), y = sp_polyval(Y, 4, u);
    double qx = P[0] + k * D[0], qz = P[2] + k * D[2];
    double f1 = fabs(y - P[1] - k * D[1]), f2 = fabs(sqrt(qx * qx + qz * qz) - fabs(x));
    *u_io = u, *k_io = k;
    return f1 <= tl->side_rel * scale && f2 <= tl->side_rel * scale;
}

/* LathePrim.crossings for an object-space ray: at most cap (the nearest), face ids the
 * segment index mod LATHE_MOD. */
static int lathe_crossings(const SweepTol *tl, const double *table, const double *prim,
                           const double *o, const double *d, double *t, int *face, int cap) {
    if ((int)prim[LA_DEGENERATE]) return 0;
    const double *segs = table + (size_t)prim[LA_AT];
    int nseg = (int)prim[LA_NSEG], n = 0, max_iter = (int)prim[LA_ROOT_ITER];
    double P[3], D[3], t0, dl;
    unit_recentred(prim + LA_LO, prim + LA_HI, o, d, P, D, &t0, &dl);
    double scale = fmax(prim[LA_SIZE], tl->abs_floor);
    double Dy = D[1], r = D[0] * D[0] + D[2] * D[2], m = P[0] * D[0] + P[2] * D[2];
    double rho0 = P[0] * P[0] + P[2] * P[2];
    int flat = fabs(Dy) <= prim[LA_FLAT];
    for (int si = 0; si < nseg; si++) {
        const double *sg = segs + (size_t)si * SS;
        if (!lathe_pair(tl, prim, sg, P, D)) continue;
        const double *X = sg + SS_X;
        double W[4] = {sg[SS_Y], sg[SS_Y + 1], sg[SS_Y + 2], sg[SS_Y + 3] - P[1]};
        double u[6], k[6];
        int nc = 0;
        if (!flat) { /* r W^2 + 2 Dy m W + Dy^2 (rho0 - X^2) = 0 (k = W / Dy eliminated) */
            double WW[7] = {0}, XX[7] = {0}, poly[7], low[7], ug[6];
            for (int i = 0; i < 4; i++)
                for (int j = 0; j < 4; j++) WW[i + j] += W[i] * W[j];
            for (int i = 0; i < 4; i++)
                for (int j = 0; j < 4; j++) XX[i + j] += X[i] * X[j];
            double two = 2 * (Dy * m), dy2 = Dy * Dy;
            for (int j = 0; j < 7; j++) poly[j] = r * WW[j];
            for (int j = 0; j < 4; j++) poly[3 + j] += two * W[j];
            for (int j = 0; j < 7; j++) poly[j] -= dy2 * XX[j];
            poly[6] += dy2 * rho0;
            for (int j = 0; j < 7; j++) low[j] = poly[6 - j];
            roots_in(low, 6, LATHE_WLO, LATHE_WHI, max_iter, ug);
            for (int j = 0; j < 6; j++) {
                double uj = isfinite(ug[j]) ? ug[j] : NAN;
                u[j] = uj;
                k[j] = sp_polyval(W, 4, uj == uj ? uj : 0.0) / Dy;
            }
            nc = 6;
        } else { /* height fixed: Y(u) = P_y, then the circle of radius X(u) along the ray */
            double uh[3];
            sp_roots(tl, W, uh);
            for (int j = 0; j < 3; j++) {
                double xr = sp_polyval(X, 4, uh[j] == uh[j] ? uh[j] : 0.0);
                double disc = m * m - r * (rho0 - xr * xr), sq = disc >= 0 ? sqrt(disc) : NAN;
                k[j] = (-m - sq) / r, k[3 + j] = (-m + sq) / r;
                u[j] = u[3 + j] = uh[j];
            }
            nc = 6;
        }
        for (int j = 0; j < nc; j++) {
            double uj = u[j], kj = k[j];
            if (!(isfinite(uj) && isfinite(kj) && uj > LATHE_WLO && uj < LATHE_WHI)) continue;
            int settled = lathe_polish(tl, sg, scale, P, D, &uj, &kj);
            if (!settled || !sp_in_window(tl, uj, (int)sg[SS_JOINED]) || !isfinite(kj)) continue;
            sweep_keep(t0 + kj / dl, si % LATHE_MOD, t, face, &n, cap);
        }
    }
    return n;
}

/* LathePrim.inside: in the profile's height range and inside the curve (even-odd) */
static int lathe_inside(const SweepTol *tl, const double *table, const double *prim,
                        const double *p) {
    if ((int)prim[LA_DEGENERATE]) return 0;
    double q[2] = {hypot(p[0], p[2]), p[1]};
    if (!(q[1] >= prim[LA_YLO] && q[1] <= prim[LA_YHI])) return 0;
    return sp_contains(tl, table + (size_t)prim[LA_AT], 0, (int)prim[LA_NSEG], q);
}

/* LathePrim.normal at an object-space surface point (not unit): the segment found again
 * among those of its face id (spline2d.locate), its profile normal turned outward and
 * about the axis; a pole (on the axis) along y. */
static void lathe_normal(const SweepTol *tl, const double *table, const double *prim,
                         const double *p, int face, double *n) {
    const double *segs = table + (size_t)prim[LA_AT];
    int nseg = (int)prim[LA_NSEG];
    n[0] = n[1] = n[2] = 0.0;
    if (nseg == 0) return;
    double q[2] = {hypot(p[0], p[2]), p[1]};
    double best_t;
    int best_seg = sp_locate(tl, segs, face % LATHE_MOD, nseg, LATHE_MOD, q, &best_t);
    if (best_seg < 0) best_seg = face % LATHE_MOD < nseg ? face % LATHE_MOD : 0, best_t = 0.0;
    const double *sg = segs + (size_t)best_seg * SS;
    double dx[3] = {sg[SS_X] * 3.0, sg[SS_X + 1] * 2.0, sg[SS_X + 2] * 1.0};
    double dy[3] = {sg[SS_Y] * 3.0, sg[SS_Y + 1] * 2.0, sg[SS_Y + 2] * 1.0};
    double tan0 = sp_polyval(dx, 3, best_t), tan1 = sp_polyval(dy, 3, best_t);
    double n2[2] = {tan1, -tan0}, len = sqrt(n2[0] * n2[0] + n2[1] * n2[1]);
    len = len > 0 ? len : 1.0;
    n2[0] = n2[0] / len, n2[1] = n2[1] / len;
    double step = tl->side_rel * fmax(prim[LA_SIZE], tl->abs_floor);
    double side[2] = {q[0] + step * n2[0], q[1] + step * n2[1]};
    double off[2] = {fabs(side[0]), side[1]};
    if (sp_contains(tl, segs, 0, nseg, off)) n2[0] = -n2[0], n2[1] = -n2[1];
    double rr = q[0];
    if (rr <= tl->abs_floor) {
        n[1] = n2[1] >= 0 ? 1.0 : -1.0;
        return;
    }
    n[0] = n2[0] * p[0] / rr, n[1] = n2[1], n[2] = n2[0] * p[2] / rr;
}

/* A sor's primitive slots (runtime/prims/lathe.py SorPrim): its segments in the sweeps'
 * table (SOR_SEG values each: the cubic of radius squared in y highest power first, the
 * heights it spans, its least and largest radius), how many, box, size, height range,
 * open, the caps' radii squared, whether it has no segment, and the tolerances it reads
 * (SOR_CAP_MIN_R2, BOX_PAD_REL, BOX_PAD_ABS) */
enum { SO_AT, SO_NSEG, SO_LO, SO_HI = SO_LO + 3, SO_SIZE = SO_HI + 3, SO_YLO, SO_YHI, SO_OPEN,
       SO_BASE_R2, SO_CAP_R2, SO_DEGENERATE, SO_CAP_MIN, SO_PAD_REL, SO_PAD_ABS };
enum { SR_A, SR_B, SR_C, SR_D, SR_Y1, SR_Y2, SR_RMIN, SR_RMAX, SOR_SEG };

/* SorPrim.crossings for an object-space ray: the curved surface (face 2), then the caps
 * (0: base, 1: top); at most cap, the nearest. */
static int sor_crossings(const SweepTol *tl, const double *table, const double *prim,
                         const double *o, const double *d, double *t, int *face, int cap) {
    if ((int)prim[SO_DEGENERATE]) return 0;
    const double *segs = table + (size_t)prim[SO_AT];
    int nseg = (int)prim[SO_NSEG], n = 0;
    double P[3], D[3], t0, dl;
    unit_recentred(prim + SO_LO, prim + SO_HI, o, d, P, D, &t0, &dl);
    double py = P[1], dy = D[1], r = D[0] * D[0] + D[2] * D[2];
    double m = P[0] * D[0] + P[2] * D[2], rho0 = P[0] * P[0] + P[2] * P[2];
    double s = fmax(prim[SO_SIZE], tl->abs_floor);
    for (int si = 0; si < nseg; si++) {
        const double *sg = segs + (size_t)si * SOR_SEG;
        if (!shell_pair(tl, prim[SO_PAD_REL], prim[SO_PAD_ABS], sg[SR_Y1], sg[SR_Y2], sg[SR_RMIN],
                        sg[SR_RMAX], P, D))
            continue;
        double A = sg[SR_A], B = sg[SR_B], C = sg[SR_C], Dc = sg[SR_D], k3[3];
        /* f(P_y + k D_y) - |P_xz + k D_xz|^2 as a cubic in k = s kappa */
        double poly[4] = {A * (dy * dy * dy) * (s * s * s),
                          (dy * dy * (3 * A * py + B) - r) * (s * s),
                          (dy * (py * (3 * A * py + 2 * B) + C) - 2 * m) * s,
                          py * (py * (A * py + B) + C) + Dc - rho0};
        sp_roots(tl, poly, k3);
        int last = si == nseg - 1;
        for (int j = 0; j < 3; j++) {
            double k = k3[j] * s, hgt = py + k * dy;
            if (hgt >= sg[SR_Y1] && (hgt < sg[SR_Y2] || (last && hgt <= sg[SR_Y2])) && isfinite(k))
                sweep_keep(t0 + k / dl, 2, t, face, &n, cap);
        }
    }
    if (!(int)prim[SO_OPEN]) {
        for (int f = 0; f < 2; f++) {
            double h = f == 0 ? prim[SO_YLO] : prim[SO_YHI];
            double r2 = f == 0 ? prim[SO_BASE_R2] : prim[SO_CAP_R2];
            if (!(r2 > prim[SO_CAP_MIN]) || !(fabs(D[1]) > tl->parallel)) continue;
            double k = (h - P[1]) / D[1], x = P[0] + k * D[0], z = P[2] + k * D[2];
            if (x * x + z * z <= r2) sweep_keep(t0 + k / dl, f, t, face, &n, cap);
        }
    }
    return n;
}

/* SorPrim.segment_of: the first segment whose top is at or above y (clipped) */
static int sor_segment(const double *segs, int nseg, double y) {
    int i = 0;
    while (i < nseg && segs[(size_t)i * SOR_SEG + SR_Y2] < y) i++;
    return i < nseg ? i : nseg - 1;
}

static int sor_inside(const double *table, const double *prim, const double *p) {
    if ((int)prim[SO_DEGENERATE]) return 0;
    const double *segs = table + (size_t)prim[SO_AT];
    double y = p[1], rho2 = p[0] * p[0] + p[2] * p[2];
    const double *sg = segs + (size_t)sor_segment(segs, (int)prim[SO_NSEG], y) * SOR_SEG;
    double f = sp_polyval(sg + SR_A, 4, y);
    return y >= prim[SO_YLO] && y <= prim[SO_YHI] && rho2 <= f;
}

/* SorPrim.normal (not unit): (x, -f'(y) / 2, z) on the surface, the caps along y */
static void sor_normal(const double *table, const double *prim, const double *p, int face,
                       double *n) {
    n[0] = n[1] = n[2] = 0.0;
    if (face == 0 || face == 1) {
        n[1] = face == 0 ? -1.0 : 1.0;
        return;
    }
    if ((int)prim[SO_NSEG] == 0) return;
    const double *segs = table + (size_t)prim[SO_AT];
    const double *sg = segs + (size_t)sor_segment(segs, (int)prim[SO_NSEG], p[1]) * SOR_SEG;
    double dc[3] = {sg[SR_A] * 3.0, sg[SR_B] * 2.0, sg[SR_C] * 1.0};
    double slope = sp_polyval(dc, 3, p[1]);
    n[0] = p[0], n[1] = -0.5 * slope, n[2] = p[2];
}

#endif
