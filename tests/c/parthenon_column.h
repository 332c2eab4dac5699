/*
 * parthenon_column.h -- the default column of the C tests and benchmarks, one text
 * (Column.parthenon(), pycolfrag/data/column_parthenon.json: 12 drums, 10-gon, tapering from
 * 0.825 m to 0.64 m in radius over 9.38 m, radii as Python holds them, then the capital:
 * echinus frustum + square abacus, one block), for tests/c/test_solver.c,
 * tests/c/result_hashes.c, bench/solver_profile.c and bench/batch_profile.c.
 */
#ifndef CF_PARTHENON_COLUMN_H
#define CF_PARTHENON_COLUMN_H
#include "geometry.h"

enum { PARTHENON_NB = 13 };

/* seg: 14 segments, nseg: 13 blocks */
static void parthenon_column(cf_geometry_segment *seg, int *nseg)
{
    static const double r[13] = {0.825, 0.8095833333333333, 0.7941666666666666, 0.7787499999999999,
                                 0.7633333333333333, 0.7479166666666667, 0.7324999999999999,
                                 0.7170833333333333, 0.7016666666666667, 0.68625, 0.6708333333333333,
                                 0.6554166666666666, 0.64};
    int i;
    for (i = 0; i < 12; i++) {
        seg[i].height = 0.7816666666666667;
        seg[i].r_bottom = r[i]; seg[i].r_top = r[i + 1];
        seg[i].phase_rad = 0.0; seg[i].n_sides = 10;
        nseg[i] = 1;
    }
    seg[12].height = 0.4; seg[12].r_bottom = 0.64; seg[12].r_top = 0.83; seg[12].phase_rad = 0.0; seg[12].n_sides = 10;
    seg[13].height = 0.3; seg[13].r_bottom = 1.2232947314527272; seg[13].r_top = 1.2232947314527272;
    seg[13].phase_rad = 0.7853981633974483; seg[13].n_sides = 4;
    nseg[12] = 2;
}

#endif
