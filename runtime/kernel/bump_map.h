/* POV-Ray's bump_map for the compiled kernel: runtime/bump_map.py (map_pos, sample,
 * perturb, in_frame), formula for formula and in its order. Included by whitted.c; the
 * heights (grey values or palette indices, H x W, rows from the top) are in the images'
 * table, the parameters in the normal row's pattern slots (BM_ below, given by whitted.c). */
#ifndef STRALA_BUMP_MAP_H
#define STRALA_BUMP_MAP_H

#include <math.h>

/* bump_map._NUDGE and _PARALLEL */
#define BM_NUDGE 1.0e-10
#define BM_PARALLEL 1.0e-10

typedef struct {
    const double *table; /* h x w heights */
    long long w, h;
    int map_type, interp, once, use_index;
} BumpMap;

static inline double bm_norm(const double *v) { return sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]); }

static inline double bm_clip1(double x) { return x < -1.0 ? -1.0 : (x > 1.0 ? 1.0 : x); }

/* bump_map._theta: the angle around y from +x toward +z in [0, 2 pi), by acos */
static double bm_theta(double x, double z, double length) {
    double safe = length > 0 ? length : 1.0, t = acos(bm_clip1(x / safe));
    if (z < 0.0) t = 2.0 * M_PI - t;
    if (z == 0.0) t = x > 0 ? 0.0 : M_PI;
    return t;
}

/* bump_map._wrap: into [0, size) */
static inline double bm_wrap(double v, double size) {
    double r = fmod(v, size);
    if (r < 0.0) r = r + size;
    return r >= size ? 0.0 : r;
}

static inline double bm_wrap_once(double v, double size) {
    return v < 0.0 ? v + size : (v >= size ? v - size : v);
}

/* bump_map.map_pos: pixel coordinates of a pattern-space point, 0 when it maps nowhere */
static int bm_pos(const BumpMap *b, const double *p, double *xo, double *yo) {
    double x = p[0], y = p[1], z = p[2], u = 0.0, v = 0.0, w = (double)b->w, h = (double)b->h;
    int ok = 1;
    if (b->map_type == 1) { /* spherical */
        double r = bm_norm(p), rs = r > 0 ? r : 1.0;
        ok = ok && r > 0;
        v = 0.5 + asin(bm_clip1(y / rs)) / M_PI;
        double ring = hypot(x / rs, z / rs);
        double t = ring > 0 ? bm_theta(x / rs, z / rs, ring) : 0.0;
        u = t / (2.0 * M_PI) * w;
        v = v * h;
    } else if (b->map_type == 2) { /* cylindrical */
        if (b->once) ok = ok && y >= 0.0 && y <= 1.0;
        v = fmod(y * h, h);
        double r = bm_norm(p), rs = r > 0 ? r : 1.0, ring = hypot(x / rs, z / rs);
        ok = ok && r > 0 && ring > 0;
        u = bm_theta(x / rs, z / rs, ring) / (2.0 * M_PI) * w;
    } else if (b->map_type == 5) { /* torus of major radius 1 */
        double ring = hypot(x, z);
        ok = ok && ring > 0;
        double theta = -bm_theta(x, z, ring), dx = ring - 1.0, tube = hypot(dx, y);
        ok = ok && tube > 0;
        double phi = acos(bm_clip1(-dx / (tube > 0 ? tube : 1.0)));
        if (y > 0.0) phi = 2.0 * M_PI - phi;
        u = -theta / (2.0 * M_PI) * w;
        v = phi / (2.0 * M_PI) * h;
    } else { /* planar */
        if (b->once) ok = ok && x >= 0.0 && x <= 1.0 && y >= 0.0 && y <= 1.0;
        u = fmod(x * w, w);
        v = fmod(y * h, h);
    }
    u = u + BM_NUDGE;
    v = v + BM_NUDGE;
    if (b->once) ok = ok && u >= 0 && u < w && v >= 0 && v < h;
    ok = ok && isfinite(u) && isfinite(v);
    if (!ok) u = v = 0.0;
    *xo = bm_wrap(u, w), *yo = bm_wrap(-v, h);
    return ok;
}

/* bump_map._pixels: clamped to the edge for `once`, else wrapped */
static inline double bm_pixel(const BumpMap *b, long long ix, long long iy) {
    if (b->once) {
        ix = ix < 0 ? 0 : (ix > b->w - 1 ? b->w - 1 : ix);
        iy = iy < 0 ? 0 : (iy > b->h - 1 ? b->h - 1 : iy);
    } else {
        ix = ix % b->w, iy = iy % b->h;
        ix = ix < 0 ? ix + b->w : ix, iy = iy < 0 ? iy + b->h : iy;
    }
    return b->table[(size_t)(iy * b->w + ix)];
}

static void bm_cubic_weights(double p, double *f) {
    double q = 1.0 - p;
    f[0] = -0.5 * p * q * q;
    f[1] = 0.5 * q * (q * (3 * p + 1) + 1);
    f[2] = 0.5 * p * (p * (3 * q + 1) + 1);
    f[3] = -0.5 * q * p * p;
}

/* bump_map.sample then _height (a blended index truncated) */
static double bm_height(const BumpMap *b, double x, double y) {
    int interp = b->interp;
    if (!(interp == 2 || interp == 3 || interp == 4))
        return bm_pixel(b, (long long)x, (long long)y);
    x = x + 0.5, y = y + 0.5;
    long long ix = (long long)x, iy = (long long)y;
    double p = x - (double)ix, q = y - (double)iy, total = 0.0;
    if (interp == 3) {
        double fx[4], fy[4];
        bm_cubic_weights(p, fx);
        bm_cubic_weights(q, fy);
        for (int i = 0; i < 4; i++)
            for (int j = 0; j < 4; j++) total += fx[i] * fy[j] * bm_pixel(b, ix + i - 2, iy + j - 2);
    } else {
        static const int corners[4][2] = {{0, 0}, {-1, 0}, {0, -1}, {-1, -1}};
        double f[4];
        if (interp == 2) {
            f[0] = p * q, f[1] = (1 - p) * q, f[2] = p * (1 - q), f[3] = (1 - p) * (1 - q);
        } else { /* norm_dist_weights */
            double d[4] = {(1 - p) * (1 - p) + (1 - q) * (1 - q), p * p + (1 - q) * (1 - q),
                           (1 - p) * (1 - p) + q * q, p * p + q * q};
            int any_on = 0;
            for (int k = 0; k < 4; k++) any_on |= d[k] <= 0.0;
            for (int k = 0; k < 4; k++)
                f[k] = any_on ? (d[k] <= 0.0 ? 1.0 : 0.0) : (d[k] <= 0.0 ? 0.0 : 1.0 / d[k]);
            double sum = ((f[0] + f[1]) + f[2]) + f[3];
            for (int k = 0; k < 4; k++) f[k] = f[k] / sum;
        }
        for (int k = 0; k < 4; k++)
            total += f[k] * bm_pixel(b, ix + corners[k][0], iy + corners[k][1]);
    }
    return b->use_index ? trunc(total) : total;
}

/* bump_map.in_frame: bump (y along n) taken into n's space, its z negated */
static void bm_in_frame(const double *n, const double *bump, double *out) {
    double yp[3] = {n[0], n[1], n[2]};
    double xp[3] = {n[1] * 0.0 - n[2] * 1.0, n[2] * 0.0 - n[0] * 0.0, n[0] * 1.0 - n[1] * 0.0};
    double length = bm_norm(xp);
    if (length < BM_PARALLEL) {
        int up = fabs(n[1] - 1.0) < BM_PARALLEL;
        yp[0] = 0.0, yp[1] = up ? 1.0 : -1.0, yp[2] = 0.0;
        xp[0] = 1.0, xp[1] = 0.0, xp[2] = 0.0;
        length = 1.0;
    }
    for (int k = 0; k < 3; k++) xp[k] = xp[k] / length;
    double zp[3] = {xp[1] * yp[2] - xp[2] * yp[1], xp[2] * yp[0] - xp[0] * yp[2],
                    xp[0] * yp[1] - xp[1] * yp[0]};
    double zl = bm_norm(zp);
    for (int k = 0; k < 3; k++) zp[k] = zp[k] / zl;
    for (int k = 0; k < 3; k++) out[k] = bump[0] * xp[k] + bump[1] * yp[k] - bump[2] * zp[k];
}

/* bump_map.perturb: the normal n (pattern space) after the bump_map at point p, amount
 * bump_size; off the image (once) n stays. */
static void bump_map_perturb(const BumpMap *b, double amount, const double *p, double *n) {
    if (b->w <= 0 || b->h <= 0) return; /* no image: unbumped */
    double x, y, w = (double)b->w, h = (double)b->h;
    if (!bm_pos(b, p, &x, &y)) return;
    double x2 = bm_wrap_once(x - 1.0, w), y2 = bm_wrap_once(y + 1.0, h);
    double x3 = bm_wrap_once(x2 + 2.0, w);
    double h1 = amount * bm_height(b, x, y), h2 = amount * bm_height(b, x2, y2);
    double h3 = amount * bm_height(b, x3, y2);
    /* the triangle (0, h1, 0), (-1, h2, 1), (1, h3, 1): cross(yp, xp) */
    double xp[3] = {1.0, h1 - h2, -1.0}, yp[3] = {2.0, h3 - h2, 0.0};
    double bump[3] = {yp[1] * xp[2] - yp[2] * xp[1], yp[2] * xp[0] - yp[0] * xp[2],
                      yp[0] * xp[1] - yp[1] * xp[0]};
    double bl = bm_norm(bump);
    for (int k = 0; k < 3; k++) bump[k] = bump[k] / bl;
    double m[3] = {n[0], n[1], n[2]};
    bm_in_frame(m, bump, n);
}

#endif
