/* solver_points_w4.c -- the wide points runner (solver_points_wide.h) on 4 lanes (AVX2) */
#define CF_BW 4
#include "solver_points_wide.h"
