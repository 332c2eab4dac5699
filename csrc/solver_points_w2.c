/* solver_points_w2.c -- the wide points runner (solver_points_wide.h) on 2 lanes (SSE2, part of every x86-64 CPU) */
#define CF_BW 2
#include "solver_points_wide.h"
