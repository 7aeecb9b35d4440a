/* POV-Ray 3.7's solid noise for the compiled kernel: runtime/noise.py's formulas, operation
 * for operation, over its tables (packed by runtime/whitted.py from noise.tables(), so the
 * tables have one source). Included by whitted.c only. */
#ifndef STRALA_NOISE_H
#define STRALA_NOISE_H

#include <math.h>

#define NOISE_HASH 8192   /* the 4096-entry permutation, twice */
#define NOISE_VALUES 267  /* the value/gradient table */
#define NOISE_SOLID 2048  /* generator 3's gradients */
#define NOISE_SOLID_ROWS (2 * NOISE_SOLID + 2)
#define NOISE_RANDS 32768 /* the cells' and crackle's random values (noise._pattern_rands) */
/* packed: hash, rtable, half (0.5 rtable), solid permutation, solid gradients (3 a row),
 * the pattern rands */
#define NOISE_LEN (NOISE_HASH + 2 * NOISE_VALUES + 4 * NOISE_SOLID_ROWS + NOISE_RANDS)
#define NOISE_EPSILON 1.0e-10
#define NOISE_MIN_LATTICE (-10000)
#define NOISE_ROLLOVER 10000000.023157213

typedef struct {
    const double *hash, *rtable, *half, *perm, *grads, *rands;
} Noise;

static void noise_view(const double *at, Noise *nz) {
    nz->hash = at;
    nz->rtable = at + NOISE_HASH;
    nz->half = nz->rtable + NOISE_VALUES;
    nz->perm = nz->half + NOISE_VALUES;
    nz->grads = nz->perm + NOISE_SOLID_ROWS;
    nz->rands = nz->grads + 3 * NOISE_SOLID_ROWS;
}

/* POV-Ray's Hash3d of integer cells, each coordinate modulo 4096 (noise.hash3d) */
static inline int hash3d(const Noise *nz, long long ix, long long iy, long long iz) {
    int a = (int)nz->hash[ix & 0xFFF];
    int b = (int)nz->hash[a ^ (int)(iy & 0xFFF)];
    return (int)nz->hash[b ^ (int)(iz & 0xFFF)];
}

/* the packed tables' indices stay inside them (checked once per packed scene) */
static int noise_valid(const Noise *nz) {
    for (int i = 0; i < NOISE_HASH; i++)
        if (!(nz->hash[i] >= 0 && nz->hash[i] < 4096)) return 0;
    for (int i = 0; i < NOISE_SOLID_ROWS; i++)
        if (!(nz->perm[i] >= 0 && nz->perm[i] < NOISE_SOLID)) return 0;
    return 1;
}

static inline double s_curve(double t) { return t * t * (3.0 - 2.0 * t); }

/* 12-bit lattice index and fraction of a coordinate, floored as POV-Ray does */
static inline int lattice(double v, double *frac) {
    double t = v >= 0.0 ? trunc(v) : trunc(v - (1.0 - NOISE_EPSILON));
    *frac = v - t;
    return (int)(((long long)t - NOISE_MIN_LATTICE) & 0xFFF);
}

/* The eight corners' table entries and weights (noise._corners), in its order. */
static void corners(const Noise *nz, const double *p, int *k, double *w, double *dx,
                    double *dy, double *dz) {
    double fx, fy, fz;
    int ix = lattice(p[0], &fx), iy = lattice(p[1], &fy), iz = lattice(p[2], &fz);
    double sx = s_curve(fx), sy = s_curve(fy), sz = s_curve(fz);
    double wx[2] = {1.0 - sx, sx}, wy[2] = {1.0 - sy, sy}, wz[2] = {1.0 - sz, sz};
    double ex[2] = {fx, fx - 1.0}, ey[2] = {fy, fy - 1.0}, ez[2] = {fz, fz - 1.0};
    int c = 0;
    for (int cx = 0; cx < 2; cx++) {
        int hx = (int)nz->hash[ix + cx];
        for (int cy = 0; cy < 2; cy++) {
            int hxy = (int)nz->hash[hx ^ (iy + cy)];
            double wxy = wx[cx] * wy[cy];
            for (int cz = 0; cz < 2; cz++, c++) {
                k[c] = (int)nz->hash[hxy ^ (iz + cz)] & 0xFF;
                w[c] = wxy * wz[cz];
                dx[c] = ex[cx], dy[c] = ey[cy], dz[c] = ez[cz];
            }
        }
    }
}

static double raw_noise(const Noise *nz, const double *p) {
    int k[8];
    double w[8], dx[8], dy[8], dz[8], total = 0.0;
    corners(nz, p, k, w, dx, dy, dz);
    const double *r = nz->rtable;
    for (int c = 0; c < 8; c++)
        total += w[c] * (nz->half[k[c]] + r[k[c] + 1] * dx[c] + r[k[c] + 2] * dy[c] +
                         r[k[c] + 3] * dz[c]);
    return total;
}

static inline double lerp(double t, double a, double b) { return a + t * (b - a); }

/* Perlin's gradient noise (noise.solid_noise, generator 3) */
static double solid_noise(const Noise *nz, const double *p) {
    const int mask = NOISE_SOLID - 1;
    int b0[3], b1[3];
    double r0[3], r1[3], sc[3];
    for (int a = 0; a < 3; a++) {
        double t = p[a] + NOISE_ROLLOVER, it = floor(t);
        b0[a] = (int)((long long)it & mask);
        r0[a] = t - it;
        r1[a] = r0[a] - 1.0;
        b1[a] = (b0[a] + 1) & mask;
        sc[a] = s_curve(r0[a]);
    }
    int i = (int)nz->perm[b0[0]], j = (int)nz->perm[b1[0]];
    int rows[2][2] = {{(int)nz->perm[i + b0[1]], (int)nz->perm[i + b1[1]]},
                      {(int)nz->perm[j + b0[1]], (int)nz->perm[j + b1[1]]}};
    int bz[2] = {b0[2], b1[2]};
    double at[2][2][2];
    for (int cx = 0; cx < 2; cx++)
        for (int cy = 0; cy < 2; cy++)
            for (int cz = 0; cz < 2; cz++) {
                const double *g = nz->grads + 3 * (size_t)(rows[cx][cy] + bz[cz]);
                at[cx][cy][cz] = g[0] * (cx ? r1[0] : r0[0]) + g[1] * (cy ? r1[1] : r0[1]) +
                                 g[2] * (cz ? r1[2] : r0[2]);
            }
    double c = lerp(sc[1], lerp(sc[0], at[0][0][0], at[1][0][0]),
                    lerp(sc[0], at[0][1][0], at[1][1][0]));
    double d = lerp(sc[1], lerp(sc[0], at[0][0][1], at[1][0][1]),
                    lerp(sc[0], at[0][1][1], at[1][1][1]));
    return lerp(sc[2], c, d);
}

static inline double clip_unit(double v) { return v < 0.0 ? 0.0 : (v > 1.0 ? 1.0 : v); }

/* POV-Ray's Noise() in [0, 1] (noise.noise) */
static double noise_at(const Noise *nz, const double *p, int generator) {
    double v;
    if (generator == 3)
        v = 0.5 * (1.59 * solid_noise(nz, p) + 0.985);
    else if (generator == 1)
        v = raw_noise(nz, p) + 0.5;
    else
        v = (raw_noise(nz, p) + 1.05242) * 0.48985582;
    return clip_unit(v);
}

/* POV-Ray's DNoise() (noise.dnoise) */
static void dnoise_at(const Noise *nz, const double *p, double *out) {
    int k[8];
    double w[8], dx[8], dy[8], dz[8];
    corners(nz, p, k, w, dx, dy, dz);
    const double *r = nz->rtable;
    out[0] = out[1] = out[2] = 0.0;
    for (int c = 0; c < 8; c++)
        for (int a = 0; a < 3; a++) {
            int m = k[c] + 4 * a;
            out[a] += w[c] * (nz->half[m] + r[m + 1] * dx[c] + r[m + 2] * dy[c] +
                              r[m + 3] * dz[c]);
        }
}

static inline double octave_noise(const Noise *nz, const double *p, int generator, int first) {
    double n = noise_at(nz, p, generator);
    if (generator == 1) return n;
    n = 2.0 * n - 0.5;
    return first ? clip_unit(n) : n;
}

/* POV-Ray's Turbulence() (noise.turbulence); lambda and omega come in single precision */
static double turbulence_at(const Noise *nz, const double *p, int octaves, double omega,
                            double lam, int generator) {
    double value = octave_noise(nz, p, generator, 1);
    double scale = (float)lam, amp = (float)omega;
    lam = (float)lam, omega = (float)omega;
    for (int i = 2; i <= octaves; i++) {
        double q[3] = {p[0] * scale, p[1] * scale, p[2] * scale};
        value = value + amp * octave_noise(nz, q, generator, 0);
        scale *= lam;
        amp *= omega;
    }
    return value;
}

/* POV-Ray's DTurbulence() (noise.dturbulence) */
static void dturbulence_at(const Noise *nz, const double *p, int octaves, double omega,
                           double lam, double *out) {
    dnoise_at(nz, p, out);
    double scale = (float)lam, amp = (float)omega;
    lam = (float)lam, omega = (float)omega;
    for (int i = 2; i <= octaves; i++) {
        double q[3] = {p[0] * scale, p[1] * scale, p[2] * scale}, d[3];
        dnoise_at(nz, q, d);
        for (int a = 0; a < 3; a++) out[a] = out[a] + amp * d[a];
        scale *= lam;
        amp *= omega;
    }
}

#endif
