/*
 * solver_band.c -- largest eigenvalue of a symmetric band matrix, for the stability
 * limit of tall stacks.
 *
 * The stiffness of a stack couples each block only with its neighbours: with 6 DOFs
 * per block the matrix is banded (half-bandwidth 11). The dense Householder path of
 * solver_timestep.c costs O(n^3) (114 s for 800 drums, n = 4800); here the count of
 * eigenvalues below x is read from the signs of the pivots of the band LDL^T
 * factorisation of A - x I (Sylvester's law of inertia), O(n b^2) per count, and
 * bisection on x finds the largest eigenvalue to full precision (about 60 counts).
 *
 * Storage: ab[i * (b + 1) + d] = A[i][i - d] for d = 0..b (the lower band, row by row;
 * entries with i - d < 0 unused).
 */
#include <math.h>
#include <stdlib.h>

#include "solver_internal.h"

/* Number of eigenvalues of A below x (A - x I = L D L^T without pivoting; a zero
 * pivot is nudged to a tiny negative number, as the Sturm count of a tridiagonal). */
static int count_below(const double *ab, int n, int b, double x, double *l, double *dg)
{
    int i, j, k, below = 0, w = b + 1;
    for (i = 0; i < n; i++) {
        int j0 = i - b > 0 ? i - b : 0;
        /* row i of L (columns j0 .. i-1): l[i][j] = (a[i][j] - sum_k l[i][k] l[j][k] d[k]) / d[j] */
        for (j = j0; j < i; j++) {
            double sum = ab[(size_t)i * w + (i - j)];
            int k0 = i - b > j - b ? i - b : j - b;
            if (k0 < 0) k0 = 0;
            for (k = k0; k < j; k++) sum -= l[(size_t)i * w + (i - k)] * l[(size_t)j * w + (j - k)] * dg[k];
            l[(size_t)i * w + (i - j)] = sum / dg[j];
        }
        {
            double d = ab[(size_t)i * w] - x;
            for (k = j0; k < i; k++) {
                double lik = l[(size_t)i * w + (i - k)];
                d -= lik * lik * dg[k];
            }
            if (d == 0.0) d = -1e-300;
            dg[i] = d;
            below += d < 0.0;
        }
    }
    return below;
}

double cf_solver_band_max_eig(const double *ab, int n, int b)
{
    int i, it, w;
    double lo = INFINITY, hi = -INFINITY, *l, *dg;
    if (n < 1 || b < 0) return NAN;
    if (b > n - 1) return NAN;   /* a band wider than the matrix: store it with b = n - 1 */
    w = b + 1;
    /* Gershgorin bounds */
    for (i = 0; i < n; i++) {
        double r = 0.0, c = ab[(size_t)i * w];
        int j;
        for (j = (i - b > 0 ? i - b : 0); j < i; j++) r += fabs(ab[(size_t)i * w + (i - j)]);
        for (j = i + 1; j <= i + b && j < n; j++) r += fabs(ab[(size_t)j * w + (j - i)]);
        if (c + r > hi) hi = c + r;
        if (c - r < lo) lo = c - r;
    }
    if (!isfinite(lo) || !isfinite(hi)) return NAN;
    l = (double *)malloc(sizeof(double) * (size_t)n * (size_t)w);
    dg = (double *)malloc(sizeof(double) * (size_t)n);
    if (!l || !dg) { free(l); free(dg); return NAN; }
    /* bisection: the smallest x below which all n eigenvalues lie */
    for (it = 0; it < 200 && hi - lo > 1e-15 * (fabs(hi) + fabs(lo)); it++) {
        double x = 0.5 * (lo + hi);
        if (count_below(ab, n, b, x, l, dg) == n) hi = x; else lo = x;
    }
    free(l); free(dg);
    return hi;
}
