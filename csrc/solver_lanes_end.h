/* solver_lanes_end.h -- closes what solver_lanes.h opened for one width: its target region
 * and its names, so that the next width (or the rest of the file) starts clean. */
#ifdef CF_BW
#if CF_BW != 2
#pragma GCC pop_options
#endif
#undef CF_BN
#undef CF_BW_SQRT
#undef CF_BW_BITS
#undef CF_BW_SEL
#undef VD
#undef VM
#undef CF_BW
#endif
