/* solver_points_w8.c -- the wide points runner (solver_points_wide.h) on 8 lanes (AVX-512F) */
#define CF_BW 8
#include "solver_points_wide.h"
