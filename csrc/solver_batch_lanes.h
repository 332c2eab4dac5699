/*
 * solver_batch_lanes.h -- the batch integrator, written once for any lane count.
 * Included by solver_batch.c once per width (CF_BW lanes: runs side by side), after
 * solver_lanes.h, whose lane operators of that width (VD, VM, CF_BN, CF_BW_SQRT, CF_BW_BITS,
 * CF_BW_SEL, ld / st / splat / mask) it is written over. Included without CF_BW (as the
 * Python build includes every header) it is empty.
 *
 * The runs side by side are those of a points model (batch_lanes of its registry entry): the
 * points' fixed data are read from its state (cf_points, solver_points_internal.h), each lane
 * keeps the points' per-run state of its own here. A column, a column with connectors or a scene
 * of several columns and beams (whose monitor reads every body: a lane's view has them all).
 *
 * Layout: every quantity of a run is a vector of CF_BW doubles, lane l the run in lane
 * l, indexed as the single run indexes its double (body i's x at x[3 i + c], point k's
 * shear at fsx[k], ...). Each phase is the single run's text: solver_phases.h for the
 * bodies, the chunk lane functions of solver_points.c for the joints (their lanes are
 * now the runs of one joint), CF_LAW_TRIAL / CF_LAW_TERMS of contact_law.h for a point
 * that stays in sticking contact, cf_point_law_at on the lane's own state for any
 * other point, the connectors' step of solver_connectors.c (after the contacts, as
 * cf_solver_step_contacts: its geometry on lane vectors, cf_solver_connectors_law_step per lane),
 * and cf_solver_run_pre / _post / _finish for the control of each run.
 * Sums stay per lane, in the single run's order (a lane adds exact +0.0 where the
 * single run adds nothing: a sum that starts at +0.0 never becomes -0.0, so this
 * leaves it unchanged).
 */
#ifdef CF_BW

typedef struct {
    VD *x, *v, *q, *w, *R, *F, *T, *ww, *vold, *wold, *fext_prev, *fdamp_prev, *tdamp_prev;
} CF_BN(state);

#define CF_PH_T VD
#define CF_PH_M VM
#define CF_PH_SEL CF_BW_SEL
#define CF_PH_SQRT CF_BW_SQRT
#define CF_PH_STATE CF_BN(state)
#define CF_PH_NAME(n) CF_BN(phase_##n)
#include "solver_phases.h"
#undef CF_PH_T
#undef CF_PH_M
#undef CF_PH_SQRT
#undef CF_PH_STATE
#undef CF_PH_NAME

/* Everything the batch keeps: the lanes' state, and per lane its run (cf_run), a view of
 * the lane as a cf_solver for the monitor (a copy of the set-up solver with the lane's
 * positions, rotations, quaternions, joint forces, history buffers and message) and its job. */
typedef struct {
    CF_BN(state) b;
    VD *jfn;                        /* nj: normal force of each joint this step */
    double *fsx, *fsy, *pst, *pen0; /* np x CF_BW: the points' state, lane innermost */
    int *hint;                      /* np x CF_BW */
    /* np x CF_BW each: the edge normals at the hint, the next and the previous edge of the face
     * the point is tested against, kept with the hint (loads instead of gathers) */
    double *he[6];
    const cf_face **pface;          /* np: that face */
    double *sleep;                  /* nj x CF_SLEEP_ND x CF_BW: each lane's sleep state of each joint, lane innermost */
    cf_run r[CF_BW];
    cf_solver view[CF_BW];
    int job[CF_BW];                 /* -1: idle */
    double *lane_mem[CF_BW];        /* the views' x, R, q, jfn */
    cf_connectors *conn[CF_BW];     /* each lane's connectors (its view's; NULL: the column has none) */
} CF_BN(batch);

/* The cached edge normals of point k in lane l, from its hint h: (ec, es) of edges h, h + 1, h - 1 */
static inline void CF_BN(hint_edges)(CF_BN(batch) *B, int k, int l)
{
    const cf_face *ff = B->pface[k];
    size_t i = (size_t)k * CF_BW + (size_t)l;
    int h = B->hint[i];
    B->he[0][i] = ff->ecw[h + 1]; B->he[1][i] = ff->esw[h + 1];
    B->he[2][i] = ff->ecw[h + 2]; B->he[3][i] = ff->esw[h + 2];
    B->he[4][i] = ff->ecw[h]; B->he[5][i] = ff->esw[h];
}

/* Lane l to the rest state of the column (what cf_solver_stack_reset gives a run). */
static void CF_BN(lane_reset)(const cf_solver *s, CF_BN(batch) *B, int l)
{
    const cf_points *pts = (const cf_points *)s->contact;
    int i, c, k;
    for (i = 0; i < s->nbody; i++) {
        double R[9];
        quat_to_mat(s->q0 + 4 * i, R);
        for (c = 0; c < 3; c++) {
            B->b.x[3 * i + c][l] = s->x0[3 * i + c];
            B->b.v[3 * i + c][l] = 0; B->b.w[3 * i + c][l] = 0; B->b.ww[3 * i + c][l] = 0;
            B->b.fext_prev[3 * i + c][l] = 0; B->b.fdamp_prev[3 * i + c][l] = 0;
            B->b.tdamp_prev[3 * i + c][l] = 0;
        }
        for (c = 0; c < 4; c++) B->b.q[4 * i + c][l] = s->q0[4 * i + c];
        for (c = 0; c < 9; c++) B->b.R[9 * i + c][l] = R[c];
    }
    for (k = 0; k < pts->np; k++) {
        B->fsx[k * CF_BW + l] = 0; B->fsy[k * CF_BW + l] = 0; B->pst[k * CF_BW + l] = 0;
        B->pen0[k * CF_BW + l] = 0; B->hint[k * CF_BW + l] = 0;
        CF_BN(hint_edges)(B, k, l);
    }
    for (k = 0; k < s->nj * CF_SLEEP_ND; k++) B->sleep[(size_t)k * CF_BW + l] = 0.0;
}

/* The lane's view for the monitor: positions and rotations of every body (all) or of the
 * top block's body only; with hist, quaternions and joint forces too. */
static void CF_BN(lane_view)(const cf_solver *s, CF_BN(batch) *B, int l, int all, int hist)
{
    cf_solver *v = &B->view[l];
    int i, c, i0 = all ? 0 : s->blk_body[s->nblk - 1], i1 = all ? s->nbody : i0 + 1;
    for (i = i0; i < i1; i++) {
        for (c = 0; c < 3; c++) v->x[3 * i + c] = B->b.x[3 * i + c][l];
        for (c = 0; c < 9; c++) v->R[9 * i + c] = B->b.R[9 * i + c][l];
    }
    if (hist) {
        for (i = 0; i < 4 * s->nbody; i++) v->q[i] = B->b.q[i][l];
        for (i = 0; i < s->nj; i++) v->jfn[i] = B->jfn[i][l];
    }
}

/* Lane l takes the next job that passes cf_solver_run's checks (a job that fails them
 * gets cf_solver_run's status, message and result at once); idle when none is left. */
static void CF_BN(lane_fill)(const cf_solver *s, CF_BN(batch) *B, int l, int *next, int n_jobs, const int *order,
                             const cf_solver_batch_job *jobs, cf_solver_batch_out *out)
{
    cf_solver *v = &B->view[l];
    CF_BN(lane_reset)(s, B, l);
    B->job[l] = -1;
    while (*next < n_jobs) {
        int j = order[(*next)++], st;
        const cf_solver_batch_job *jb = &jobs[j];
        v->msg[0] = 0;
        batch_job_history(v, jb);
        st = cf_solver_run_check(v, &B->r[l], jb->acc_x, jb->acc_y, jb->acc_z, jb->n, jb->dt_rec);
        if (!st) {
            CF_BN(lane_view)(s, B, l, 1, 0);
            if (v->conn) cf_solver_connectors_reset(v->conn);
            st = cf_solver_run_begin(v, &B->r[l]);
        }
        if (st) {
            cf_solver_result_none(&out[j].result);
            out[j].status = st;
            memcpy(out[j].message, v->msg, CF_MSG_LEN);
            continue;
        }
        B->job[l] = j;
        return;
    }
}

/* |x| per lane: the sign bit cleared (fabs's bits) */
static inline VD CF_BN(sleep_abs)(VD x)
{
    return (VD)((VM)x & ~(VM)CF_BN(splat)(-0.0));
}

/* The sleeping joint j in the lanes (solver_sleep.h, as solver_points.c's joint_sleeping): the linear law
 * of CF_SLEEP_SIDE on whole lane vectors (every lane the single run's operations); returns the running
 * lanes whose joint stays asleep (their sums in sm, vs, fn, their U advanced); those whose joint wakes
 * get their points' shear from the linear map. */
static VM CF_BN(sleeping)(const cf_solver *s, CF_BN(batch) *B, const cf_joint_chunk *C, int j, const int *has,
                          VD (*sm)[6], VD *vs, VD *fn, int need)
{
    const cf_points *pts = (const cf_points *)s->contact;
    const cf_points_joint *PJ = &pts->jt[j];
    const cf_joint *J = &s->jt[j];
    const VD zero = {0};
    double *base = B->sleep + (size_t)j * CF_SLEEP_ND * CF_BW;
    VD u[2][6];
    VM asl = CF_BN(ld)(base) != 0.0, stay;
    int l, side, i;
    *vs = zero; *fn = zero;
    for (side = 0; side < 2; side++)
        for (i = 0; i < 6; i++) sm[side][i] = zero;
    for (l = 0; l < CF_BW; l++)
        if (B->job[l] < 0) asl[l] = 0;
    if (!CF_BW_BITS(asl)) return asl;
    stay = asl;
    for (side = 0; side < 2; side++) {
        VD sd[CF_SL_SIDE], g[9];
        VM ok;
        const double sgn = side == 0 ? -1.0 : 1.0;
        if (!has[side]) continue;
        for (i = 0; i < CF_SL_SIDE; i++) sd[i] = CF_BN(ld)(base + (size_t)(CF_SL_S0 + side * CF_SL_SIDE + i) * CF_BW);
        /* cf_sleep_g of cf_face_pass_lane's map: side 0 in the lower face's frame (M0), side 1 in the upper's (M0^T) */
        g[0] = CF_BN(ld)(C->M0[0]); g[1] = CF_BN(ld)(C->M0[side == 0 ? 1 : 3]);
        g[3] = CF_BN(ld)(C->M0[side == 0 ? 3 : 1]); g[4] = CF_BN(ld)(C->M0[4]);
        g[6] = CF_BN(ld)(C->M0[side == 0 ? 6 : 2]); g[7] = CF_BN(ld)(C->M0[side == 0 ? 7 : 5]);
        for (i = 0; i < 3; i++) g[3 * i + 2] = CF_BN(ld)(C->mz[side][i]) + CF_BN(ld)(C->t[side][i]);
        CF_SLEEP_SIDE(VD, zero, CF_BN(sleep_abs), sd, PJ->sq[side], PJ->sqs[side], PJ->srho[side], J->kn, J->ks, J->mu,
                      sgn, g, CF_BN(ld)(C->A[side][0]), CF_BN(ld)(C->A[side][1]), CF_BN(ld)(C->W[side][0]),
                      CF_BN(ld)(C->W[side][1]), CF_BN(ld)(C->W[side][2]), u[side], sm[side], *vs, *fn, need, ok);
        stay = stay & ok;
    }
    for (side = 0; side < 2; side++) {
        if (!has[side]) continue;
        for (i = 0; i < 6; i++) {
            double *p = base + (size_t)(CF_SL_S0 + side * CF_SL_SIDE + CF_SL_UX + i) * CF_BW;
            CF_BN(st)(p, CF_BW_SEL(stay, u[side][i], CF_BN(ld)(p)));
        }
    }
    for (l = 0; l < CF_BW; l++)
        if (asl[l] && !stay[l]) cf_sleep_wake(pts, PJ, base + l, CF_BW, B->fsx + l, B->fsy + l, CF_BW);
    return stay;
}

/* After the full law's step of joint j: the running lanes in try (a bit per lane: their ledger steps)
 * whose joint is awake try to fall asleep (as solver_points.c's joint_points). */
static void CF_BN(try_sleep)(const cf_solver *s, CF_BN(batch) *B, const cf_joint_chunk *C, int j, const int *has,
                             int try)
{
    const cf_points *pts = (const cf_points *)s->contact;
    int l, side;
    for (l = 0; l < CF_BW; l++) {
        double *sl = B->sleep + (size_t)j * CF_SLEEP_ND * CF_BW + l;
        cf_face_pass P[2];
        if (!(try & (1 << l)) || B->job[l] < 0 || sl[0] != 0.0) continue;
        for (side = 0; side < 2; side++) {
            cf_face_pass_set(pts, &s->jt[j], side, &P[side]);
            cf_face_pass_lane(C, side, l, &P[side]);
        }
        cf_sleep_try(pts, &pts->jt[j], &s->jt[j], P, has, pts->sleep_margin, sl, CF_BW, B->fsx + l, B->fsy + l,
                     B->pst + l, CF_BW);
    }
}

/* 2. contacts of every joint, in joint order, for all lanes (solver_points.c's order); the spring
 * energy and the joints' normal forces only where need (a constant: two instances) */
static inline __attribute__((always_inline)) void CF_BN(contacts_body)(const cf_solver *s, CF_BN(batch) *B,
                                                                      cf_joint_chunk *C, cf_chunk_before_fn before,
                                                                      cf_chunk_after_fn after, VD *e_vs, VD *e_dslip,
                                                                      VD *e_dswitch, const int need, int try)
{
    const VD zero = {0};
    const cf_points *pts = (const cf_points *)s->contact;
    int i, j, l, nb = s->nbody;
    CF_BN(state) *b = &B->b;
    for (i = 0; i < 3 * nb; i++) { b->F[i] = zero; b->T[i] = zero; }
    *e_vs = zero; *e_dslip = zero; *e_dswitch = zero;
    for (j = 0; j < s->nj; j++) {
        const cf_joint *J = &s->jt[j];
        const cf_points_joint *PJ = &pts->jt[j];
        int bl = J->bl, bu = J->bu, side, end = PJ->p0 + PJ->np, has[2] = {PJ->n0 > 0, PJ->np > PJ->n0}, skip = 0;
        VD s6 = zero, s7 = zero, dslip = zero, dswitch = zero;
        /* sleeping joints (solver_sleep.h): their lanes' sums, and the lanes that sleep (slm); the points
         * are skipped when every running lane sleeps (idle lanes then get zero forces) */
        VD slsm[2][6], slvs, slfn;
        VM slm = (VM)zero;
        for (i = 0; i < 9; i++) { CF_BN(st)(C->RL[i], b->R[9 * bl + i]); CF_BN(st)(C->RU[i], b->R[9 * bu + i]); }
        for (i = 0; i < 3; i++) {
            CF_BN(st)(C->xl[i], b->x[3 * bl + i]); CF_BN(st)(C->xu[i], b->x[3 * bu + i]);
            CF_BN(st)(C->vl[i], b->v[3 * bl + i]); CF_BN(st)(C->vu[i], b->v[3 * bu + i]);
            CF_BN(st)(C->wl[i], b->ww[3 * bl + i]); CF_BN(st)(C->wu[i], b->ww[3 * bu + i]);
            CF_BN(st)(C->fcl[i], CF_BN(splat)(J->fl.c[i])); CF_BN(st)(C->fcu[i], CF_BN(splat)(J->fu.c[i]));
        }
        /* whole vectors (the lane functions load them as such: no store forwarding from doubles) */
        CF_BN(st)(C->lz[0], CF_BN(splat)(PJ->lz[0])); CF_BN(st)(C->lz[1], CF_BN(splat)(PJ->lz[1]));
        CF_BN(st)(C->gl, CF_BN(splat)(bl != 0 ? 1.0 : 0.0));
        before(C, CF_BW, s->dt);
        if (pts->sleep) {
            int idle = 0;
            for (l = 0; l < CF_BW; l++) idle |= B->job[l] < 0 ? 1 << l : 0;
            slm = CF_BN(sleeping)(s, B, C, j, has, slsm, &slvs, &slfn, need);
            skip = (CF_BW_BITS(slm) | idle) == (1 << CF_BW) - 1;
        }
        for (side = 0; side < 2; side++) {
            int k0 = side == 0 ? PJ->p0 : PJ->p0 + PJ->n0, k1 = side == 0 ? PJ->p0 + PJ->n0 : end, k, built = 0;
            cf_face_pass P, PL[CF_BW];
            VD Mx0, Mx1, My0, My1, Mz0, Mz1, z0, z1, z2, t0, t1, t2, A0, A1, W0, W1, W2;
            VD s0 = zero, s1 = zero, s2 = zero, s3 = zero, s4 = zero, s5 = zero;
            const cf_face *ff;
            double apo2, apotol;
            CF_BN(st)(C->has[side], CF_BN(splat)(k1 > k0 ? 1.0 : 0.0));
            if (k1 <= k0 || skip) {
                for (i = 0; i < 6; i++) CF_BN(st)(C->sm[side][i], zero);
                continue;
            }
            cf_face_pass_set(pts, J, side, &P);
            ff = P.ff;
            apo2 = ff->apoc * ff->apoc; apotol = ff->apo + P.tol;
            /* the frame map: side 0 in the lower face's frame (M0), side 1 in the upper's (M0^T) */
            Mx0 = CF_BN(ld)(C->M0[0]); Mx1 = CF_BN(ld)(C->M0[side == 0 ? 1 : 3]);
            My0 = CF_BN(ld)(C->M0[side == 0 ? 3 : 1]); My1 = CF_BN(ld)(C->M0[4]);
            Mz0 = CF_BN(ld)(C->M0[side == 0 ? 6 : 2]); Mz1 = CF_BN(ld)(C->M0[side == 0 ? 7 : 5]);
            z0 = CF_BN(ld)(C->mz[side][0]); z1 = CF_BN(ld)(C->mz[side][1]); z2 = CF_BN(ld)(C->mz[side][2]);
            t0 = CF_BN(ld)(C->t[side][0]); t1 = CF_BN(ld)(C->t[side][1]); t2 = CF_BN(ld)(C->t[side][2]);
            A0 = CF_BN(ld)(C->A[side][0]); A1 = CF_BN(ld)(C->A[side][1]);
            W0 = CF_BN(ld)(C->W[side][0]); W1 = CF_BN(ld)(C->W[side][1]); W2 = CF_BN(ld)(C->W[side][2]);
            for (k = k0; k < k1; k++) {
                const double lx = pts->lx[k], ly = pts->ly[k];
                double *pfsx = B->fsx + (size_t)k * CF_BW, *pfsy = B->fsy + (size_t)k * CF_BW;
                double *pst = B->pst + (size_t)k * CF_BW;
                /* the point in the face frame, as cf_point_law_at */
                VD X, Y, Z;
                CF_POINT_AT(Mx0, Mx1, My0, My1, Mz0, Mz1, z0, z1, z2, t0, t1, t2, lx, ly, X, Y, Z);
                VD pen = P.sgn * Z, st = CF_BN(ld)(pst), fsx0, fsy0, f, lim, fx, fy, m2, mx, my, mz, vs, dux, duy;
                VM pos = pen > 0.0, act, in, out, st0, st1, ok, open, lift, slip, nz;
                const double ksw = pts->ksw[k], ihkw = pts->ihkw[k];
                int bits, fb;
                st0 = cf_point_state_is(st, CF_POINT_OPEN);
                open = (~pos & st0) | slm;   /* a sleeping lane: nothing to do */
                /* open before and now, not overlapping the plane: nothing to do */
                if (CF_BW_BITS(open) == (1 << CF_BW) - 1) continue;
                act = pos & ~(pen > P.pmax);
                st1 = cf_point_state_is(st, CF_POINT_CONTACT);
                out = (VM)zero;
                if (P.unbounded) in = ~(VM)zero;
                else {
                    VD dhx = X - pts->hx[k], dhy = Y - pts->hy[k];
                    in = CF_LANES_QUICK_IN(dhx, dhy, pts->fast[k], X, Y, apo2);
                    if (CF_BW_BITS(act & ~in)) {
                        /* the polygon test where the lane's hint edge is still its most distant
                         * edge (cf_face_inside_hint would stay there and leave the hint): inside
                         * or outside; where the walk would move, cf_point_law_at decides */
                        size_t o = (size_t)k * CF_BW;
                        VD best;
                        VM stay;
                        CF_LANES_HINT_EDGE(X, Y, CF_BN(ld)(B->he[0] + o), CF_BN(ld)(B->he[1] + o),
                                           CF_BN(ld)(B->he[2] + o), CF_BN(ld)(B->he[3] + o),
                                           CF_BN(ld)(B->he[4] + o), CF_BN(ld)(B->he[5] + o), best, stay);
                        stay = ~in & stay;
                        out = stay & ~(best <= apotol);
                        in = in | (stay & (best <= apotol));
                    }
                }
                CF_POINT_DU(A0, A1, W0, W1, W2, X, Y, Z, dux, duy);
                fsx0 = CF_BN(ld)(pfsx); fsy0 = CF_BN(ld)(pfsy);
                CF_LAW_TRIAL(CF_LAW_SADD, CF_LAW_SSUB, CF_LAW_SMUL, pen, dux, duy, pts->knw[k], ksw, P.mu,
                             fsx0, fsy0, f, lim, fx, fy, m2);
                /* in contact (from state 1, or taking contact from state 0): the law of
                 * cf_law_update, sticking or slipping; the point is in state 1 after it */
                ok = act & in & (st0 | st1) & ~slm;
                slip = ok & (m2 > CF_LAW_CAP2(CF_LAW_SMUL, lim));
                if (CF_BW_BITS(slip)) {
                    VD sc, fxs, fys, diss;
                    CF_LAW_SLIP(CF_BW_SQRT, lim, m2, fx, fy, fsx0, fsy0, dux, duy, ksw, sc, fxs, fys, diss);
                    dslip = dslip + CF_BN(mask)(diss, slip);
                    fx = CF_PH_SEL(slip, fxs, fx); fy = CF_PH_SEL(slip, fys, fy);
                    m2 = fx * fx + fy * fy;
                }
                CF_LAW_TERMS(CF_LAW_SADD, CF_LAW_SSUB, CF_LAW_SMUL, 0.5, X, Y, Z, pen, f, fx, fy, m2, ihkw,
                             mx, my, mz, vs);
                /* leaving contact from state 1 (not overlapping the plane any more): the release
                 * of cf_law_release -- its stored shear energy dissipated, the shear reset --
                 * and state 0 */
                lift = ~pos & st1 & ~slm;
                nz = (fsx0 != 0.0) | (fsy0 != 0.0);
                dslip = dslip + CF_BN(mask)(CF_LAW_SHEAR_ENERGY(fsx0, fsy0, ihkw), lift & nz);
                CF_BN(st)(pfsx, CF_PH_SEL(ok, fx, CF_PH_SEL(lift & nz, zero, fsx0)));
                CF_BN(st)(pfsy, CF_PH_SEL(ok, fy, CF_PH_SEL(lift & nz, zero, fsy0)));
                CF_BN(st)(pst, CF_PH_SEL(ok, zero + CF_POINT_CONTACT, CF_PH_SEL(lift, zero + CF_POINT_OPEN, st)));
                s0 = s0 + CF_BN(mask)(fx, ok); s1 = s1 + CF_BN(mask)(fy, ok); s2 = s2 + CF_BN(mask)(f, ok);
                s3 = s3 + CF_BN(mask)(mx, ok); s4 = s4 + CF_BN(mask)(my, ok); s5 = s5 + CF_BN(mask)(mz, ok);
                if (need) { s6 = s6 + CF_BN(mask)(vs, ok); s7 = s7 + CF_BN(mask)(f, ok); }
                /* off the face polygon before and now (state 2, no shear): nothing changes */
                open = open | lift | (act & out & cf_point_state_is(st, CF_POINT_OFF_FACE));
                bits = CF_BW_BITS(ok | open);
                fb = ~bits & ((1 << CF_BW) - 1);
                /* the other lanes: the full law on the lane's own state, one lane at a time, its
                 * terms added to the lane's sums (through memory, so that the sums stay in
                 * registers on the vector path) */
                if (fb) {
                    double sa[8][CF_BW], dsl[CF_BW], dsw[CF_BW];
                    CF_BN(st)(sa[0], s0); CF_BN(st)(sa[1], s1); CF_BN(st)(sa[2], s2); CF_BN(st)(sa[3], s3);
                    CF_BN(st)(sa[4], s4); CF_BN(st)(sa[5], s5); CF_BN(st)(sa[6], s6); CF_BN(st)(sa[7], s7);
                    CF_BN(st)(dsl, dslip); CF_BN(st)(dsw, dswitch);
                    for (l = 0; fb; l++, fb >>= 1) {
                        cf_face_sums S;
                        double t[8];
                        if (!(fb & 1)) continue;
                        if (!(built & (1 << l))) {
                            PL[l] = P;
                            cf_face_pass_lane(C, side, l, &PL[l]);
                            built |= 1 << l;
                        }
                        S.dslip = dsl[l]; S.dswitch = dsw[l];
                        if (cf_point_law_at(pts, &PL[l], k, pfsx + l, pfsy + l, pst + l,
                                            B->pen0 + (size_t)k * CF_BW + l, B->hint + (size_t)k * CF_BW + l, &S, t))
                            for (i = 0; i < 8; i++) sa[i][l] += t[i];
                        dsl[l] = S.dslip; dsw[l] = S.dswitch;
                        CF_BN(hint_edges)(B, k, l);
                    }
                    s0 = CF_BN(ld)(sa[0]); s1 = CF_BN(ld)(sa[1]); s2 = CF_BN(ld)(sa[2]); s3 = CF_BN(ld)(sa[3]);
                    s4 = CF_BN(ld)(sa[4]); s5 = CF_BN(ld)(sa[5]); s6 = CF_BN(ld)(sa[6]); s7 = CF_BN(ld)(sa[7]);
                    dslip = CF_BN(ld)(dsl); dswitch = CF_BN(ld)(dsw);
                }
            }
            CF_BN(st)(C->sm[side][0], s0); CF_BN(st)(C->sm[side][1], s1); CF_BN(st)(C->sm[side][2], s2);
            CF_BN(st)(C->sm[side][3], s3); CF_BN(st)(C->sm[side][4], s4); CF_BN(st)(C->sm[side][5], s5);
        }
        if (CF_BW_BITS(slm)) {
            for (side = 0; side < 2; side++)
                for (i = 0; i < 6; i++) CF_BN(st)(C->sm[side][i], CF_BW_SEL(slm, slsm[side][i], CF_BN(ld)(C->sm[side][i])));
            s6 = CF_BW_SEL(slm, slvs, s6); s7 = CF_BW_SEL(slm, slfn, s7);
        }
        if (need) {
            *e_vs = *e_vs + s6;
            B->jfn[j] = s7;
        }
        if (pts->sleep && try) CF_BN(try_sleep)(s, B, C, j, has, try);
        *e_dslip = *e_dslip + dslip;
        *e_dswitch = *e_dswitch + dswitch;
        after(C, CF_BW);
        /* apply, as solver_points.c: force at the face centre with its moment on the upper
         * body, the opposite on the lower body */
        for (side = 0; side < 2; side++) {
            for (i = 0; i < 3; i++) {
                b->F[3 * bu + i] = b->F[3 * bu + i] + CF_BN(ld)(C->Fw[side][i]);
            }
            for (i = 0; i < 3; i++) b->T[3 * bu + i] = b->T[3 * bu + i] + CF_BN(ld)(C->Tu[side][i]);
            if (bl != 0) {
                for (i = 0; i < 3; i++) b->F[3 * bl + i] = b->F[3 * bl + i] - CF_BN(ld)(C->Fw[side][i]);
                for (i = 0; i < 3; i++) b->T[3 * bl + i] = b->T[3 * bl + i] - CF_BN(ld)(C->Tl[side][i]);
            }
        }
    }
}

/* 2b. the connectors after the contacts, as cf_solver_step_contacts, connector by connector: the
 * displacement of its ends and its force on the bodies on lane vectors with the operations of
 * cf_solver_connectors_step (solver_math_internal.h's helpers: every lane the single run's bits), its
 * law per running lane by the single run's text (cf_solver_connectors_law_step on the lane's own
 * connectors); a lane whose connector carries nothing adds nothing (a select, as the single run skips
 * it). The connectors' fixed data (definitions, ends, rest offsets) are every lane's: s's. */
static void CF_BN(connectors)(const cf_solver *s, CF_BN(batch) *B, cf_step_energy *e)
{
    const cf_connectors *c0 = s->conn;
    CF_BN(state) *b = &B->b;
    const VD zero = {0};
    double t[CF_BW];
    int i, k, l;
    for (l = 0; l < CF_BW; l++) t[l] = B->job[l] >= 0 ? (double)B->conn[l]->steps * s->dt : 0.0;
    for (i = 0; i < c0->n; i++) {
        const cf_joint *J = &s->jt[c0->d[i].joint];
        int bl = J->bl, bu = J->bu, any = 0;
        VD pu[3], pl[3], w[3], d[3], f[3], F[3], r[3], q[3];
        VM on = (VM)zero;
        /* relative(): the upper end relative to the lower one, in the lower face's frame */
        CF_MAT_VEC(VD, b->R + 9 * bu, c0->au + 3 * i, pu);
        CF_MAT_VEC(VD, b->R + 9 * bl, c0->al + 3 * i, pl);
        for (k = 0; k < 3; k++) {
            pu[k] = pu[k] + b->x[3 * bu + k];
            pl[k] = pl[k] + b->x[3 * bl + k];
            w[k] = pu[k] - pl[k];
        }
        CF_MAT_TVEC(VD, b->R + 9 * bl, w, d);
        for (k = 0; k < 3; k++) { d[k] = d[k] - c0->rest[3 * i + k]; f[k] = zero; }
        for (l = 0; l < CF_BW; l++) {
            double u[3];
            if (B->job[l] < 0) continue;
            u[0] = d[0][l]; u[1] = d[1][l]; u[2] = d[2][l];
            if (cf_solver_connectors_law_step(B->conn[l], i, u, t[l], &e[l])) {
                const double *fl = B->conn[l]->st[i].f;
                f[0][l] = fl[0]; f[1][l] = fl[1]; f[2][l] = fl[2];
                on[l] = -1;
                any = 1;
            }
        }
        if (!any) continue;
        CF_MAT_VEC(VD, b->R + 9 * bl, f, F);
        for (k = 0; k < 3; k++) r[k] = pu[k] - b->x[3 * bu + k];
        CF_V3_CROSS(VD, r, F, q);
        for (k = 0; k < 3; k++) {
            b->F[3 * bu + k] = CF_BW_SEL(on, b->F[3 * bu + k] + F[k], b->F[3 * bu + k]);
            b->T[3 * bu + k] = CF_BW_SEL(on, b->T[3 * bu + k] + q[k], b->T[3 * bu + k]);
        }
        if (bl != 0) {
            for (k = 0; k < 3; k++) r[k] = pu[k] - b->x[3 * bl + k];
            CF_V3_CROSS(VD, r, F, q);
            for (k = 0; k < 3; k++) {
                b->F[3 * bl + k] = CF_BW_SEL(on, b->F[3 * bl + k] - F[k], b->F[3 * bl + k]);
                b->T[3 * bl + k] = CF_BW_SEL(on, b->T[3 * bl + k] - q[k], b->T[3 * bl + k]);
            }
        }
    }
    for (l = 0; l < CF_BW; l++)
        if (B->job[l] >= 0) B->conn[l]->steps++;
}

static void CF_BN(contacts)(const cf_solver *s, CF_BN(batch) *B, cf_joint_chunk *C, cf_chunk_before_fn before,
                            cf_chunk_after_fn after, VD *e_vs, VD *e_dslip, VD *e_dswitch, int need, int try)
{
    if (need) CF_BN(contacts_body)(s, B, C, before, after, e_vs, e_dslip, e_dswitch, 1, try);
    else CF_BN(contacts_body)(s, B, C, before, after, e_vs, e_dslip, e_dswitch, 0, try);
}

/* Where the batch keeps its arrays, in one block: the lanes' vectors first (the block is aligned
 * for VD and every vector array is whole VDs), then the points' doubles, their faces and their
 * hints. Sets B's pointers into base when base is given; returns the bytes either way, so that
 * the size and the carving are one list. */
static size_t CF_BN(layout)(CF_BN(batch) *B, unsigned char *base, int nb, int nj, int np)
{
    size_t off = 0, npw = (size_t)np * CF_BW;
    int i;
#define TAKE(ptr, type, n) \
    do { if (base) (ptr) = (type *)(void *)(base + off); off += (size_t)(n) * sizeof(type); } while (0)
    TAKE(B->b.x, VD, 3 * nb); TAKE(B->b.v, VD, 3 * nb); TAKE(B->b.q, VD, 4 * nb); TAKE(B->b.w, VD, 3 * nb);
    TAKE(B->b.R, VD, 9 * nb); TAKE(B->b.F, VD, 3 * nb); TAKE(B->b.T, VD, 3 * nb); TAKE(B->b.ww, VD, 3 * nb);
    TAKE(B->b.vold, VD, 3 * nb); TAKE(B->b.wold, VD, 3 * nb); TAKE(B->b.fext_prev, VD, 3 * nb);
    TAKE(B->b.fdamp_prev, VD, 3 * nb); TAKE(B->b.tdamp_prev, VD, 3 * nb); TAKE(B->jfn, VD, nj);
    TAKE(B->fsx, double, npw); TAKE(B->fsy, double, npw); TAKE(B->pst, double, npw); TAKE(B->pen0, double, npw);
    for (i = 0; i < 6; i++) TAKE(B->he[i], double, npw);
    TAKE(B->sleep, double, (size_t)nj * CF_BW * CF_SLEEP_ND);
    TAKE(B->pface, const cf_face *, np);
    TAKE(B->hint, int, npw);
#undef TAKE
    return off;
}

/* A lane's view's own arrays in base (when given: x, R, q, jfn); returns their count of doubles. */
static size_t CF_BN(view_layout)(cf_solver *v, double *base, int nb, int nj)
{
    if (base) { v->x = base; v->R = v->x + 3 * nb; v->q = v->R + 9 * nb; v->jfn = v->q + 4 * nb; }
    return (size_t)16 * nb + (size_t)nj;
}

/* Frees what CF_BN(open) allocated (any of it may be NULL). */
static void CF_BN(close)(CF_BN(batch) *B, cf_joint_chunk *C, unsigned char *raw, int *order)
{
    int l;
    if (B) for (l = 0; l < CF_BW; l++) { free(B->lane_mem[l]); cf_solver_connectors_free(B->conn[l]); }
    free(B); free(C); free(raw); free(order);
}

/* The batch's memory (the lanes' vectors in one block aligned for VD, layout), its faces and lane views,
 * every lane idle; the jobs' order, longest record first (batch_order). CF_ENOMEM leaves nothing behind. */
static int CF_BN(open)(cf_solver *s, int n_jobs, const cf_solver_batch_job *jobs, CF_BN(batch) **Bp,
                       cf_joint_chunk **Cp, unsigned char **rawp, int **orderp)
{
    const cf_points *pts = (const cf_points *)s->contact;
    int nb = s->nbody, np = pts->np, nj = s->nj, l, j, nomem = 0;
    size_t bytes = CF_BN(layout)(NULL, NULL, nb, nj, np) + 64, nview = CF_BN(view_layout)(NULL, NULL, nb, nj);
    int *order = batch_order(n_jobs, jobs);   /* longest record first */
    CF_BN(batch) *B = (CF_BN(batch) *)calloc(1, sizeof *B);
    cf_joint_chunk *C = (cf_joint_chunk *)calloc(1, sizeof *C);
    unsigned char *raw = (unsigned char *)calloc(1, bytes);
    if (B)
        for (l = 0; l < CF_BW; l++) {
            B->lane_mem[l] = (double *)calloc(nview, sizeof(double));
            nomem |= !B->lane_mem[l];
            if (s->conn) {
                B->conn[l] = cf_solver_connectors_clone(s->conn);
                nomem |= !B->conn[l];
            }
        }
    if (!B || !C || !raw || !order || nomem) {
        CF_BN(close)(B, C, raw, order);
        return cf_solver_fail(s, CF_ENOMEM, "out of memory");
    }
    CF_BN(layout)(B, raw + (64 - (uintptr_t)raw % 64) % 64, nb, nj, np);
    for (j = 0; j < nj; j++) {
        const cf_joint *J = &s->jt[j];
        const cf_points_joint *PJ = &pts->jt[j];
        int k;
        for (k = PJ->p0; k < PJ->p0 + PJ->np; k++) B->pface[k] = k < PJ->p0 + PJ->n0 ? &J->fl : &J->fu;
    }
    for (l = 0; l < CF_BW; l++) {
        cf_solver *v = &B->view[l];
        *v = *s;
        CF_BN(view_layout)(v, B->lane_mem[l], nb, nj);
        v->conn = B->conn[l];
        B->job[l] = -1;
        CF_BN(lane_reset)(s, B, l);
    }
    *Bp = B; *Cp = C; *rawp = raw; *orderp = order;
    return CF_OK;
}

/* The caller's check said stop: every running lane ends with CF_EINTR, the jobs not started say so. */
static void CF_BN(stop)(CF_BN(batch) *B, const cf_solver_batch_job *jobs, cf_solver_batch_out *out, int next,
                        int n_jobs, const int *order)
{
    int l;
    for (l = 0; l < CF_BW; l++) {
        int j = B->job[l];
        cf_run *r = &B->r[l];
        if (j < 0) continue;
        cf_solver_run_stopped(&B->view[l], r);
        cf_solver_run_finish(&B->view[l], r, jobs[j].residual_dislocation, &out[j].result);
        out[j].status = r->st;
        memcpy(out[j].message, B->view[l].msg, CF_MSG_LEN);
    }
    batch_not_started(next, n_jobs, order, out);
}

/* The batch: lanes filled with jobs longest record first (batch_order), stepped together,
 * each refilled at the next multiple of CF_LEDGER_STEPS after its run ends. */
static int CF_BN(run)(cf_solver *s, int n_jobs, const cf_solver_batch_job *jobs, cf_solver_batch_out *out)
{
    CF_BN(batch) *B = NULL;   /* set by open (GCC cannot see it through the inlined call) */
    cf_joint_chunk *C = NULL;
    unsigned char *raw = NULL;
    int *order = NULL;
    cf_chunk_before_fn before;
    cf_chunk_after_fn after;
    int l, next = 0, active;
    long steps = 0;
    const VD zero = {0};
    int st = CF_BN(open)(s, n_jobs, jobs, &B, &C, &raw, &order);
    if (st != CF_OK)
        return st;
    cf_solver_points_chunk_fns(CF_BW, &before, &after);
    for (;; steps++) {
        VD ag[3], ke, vg, Wl, Dd, e_vs, e_dslip, e_dswitch;
        VM damp = (VM)zero;
        cf_step_energy e[CF_BW];
        int end[CF_BW], need = 0, try = 0;
        /* the caller's check (cf_solver_set_check) after every CF_SOLVER_CHECK_STEPS steps of the batch
         * (idle ones included), as cf_solver_run does */
        if (s->check && steps > 0 && steps % CF_SOLVER_CHECK_STEPS == 0 && s->check(s->check_user)) {
            CF_BN(stop)(B, jobs, out, next, n_jobs, order);
            break;
        }
        /* runs start at the batch's multiples of CF_LEDGER_STEPS (a lane idles up to three steps),
         * so that every lane's ledger steps are the batch's: the spring energies are summed at a
         * quarter of the steps */
        if (steps % CF_LEDGER_STEPS == 0)
            for (l = 0; l < CF_BW && next < n_jobs; l++)
                if (B->job[l] < 0) CF_BN(lane_fill)(s, B, l, &next, n_jobs, order, jobs, out);
        ag[0] = ag[1] = ag[2] = Wl = Dd = zero;
        active = 0;
        for (l = 0; l < CF_BW; l++) {
            double a[3] = {0, 0, 0};
            if (B->job[l] >= 0) {
                cf_run *r = &B->r[l];
                active++;
                cf_solver_run_pre(&B->view[l], r, &e[l], a);
                need |= e[l].need;
                try |= e[l].ledger ? 1 << l : 0;
                if (s->def.damping_alpha > 0.0 && r->t >= s->def.damping_start_s) damp[l] = -1;
                Wl[l] = r->m.W; Dd[l] = r->m.Ddamp;
            }
            ag[0][l] = a[0]; ag[1][l] = a[1]; ag[2][l] = a[2];
        }
        if (!active) {
            if (next >= n_jobs) break;
            continue;   /* every lane waits for the next start */
        }
        CF_BN(phase_rotations)(s, &B->b);
        CF_BN(contacts)(s, B, C, before, after, &e_vs, &e_dslip, &e_dswitch, need, try);
        if (s->conn) CF_BN(connectors)(s, B, e);
        CF_BN(phase_velocities)(s, &B->b, ag, damp, &Wl, &Dd, &ke, &vg);
        for (l = 0; l < CF_BW; l++) {
            cf_run *r = &B->r[l];
            end[l] = 0;
            if (B->job[l] < 0) continue;
            r->m.W = Wl[l]; r->m.Ddamp = Dd[l];
            e[l].vs = e_vs[l]; e[l].dslip = e_dslip[l]; e[l].dswitch = e_dswitch[l];
            CF_BN(lane_view)(s, B, l, s->scene || cf_solver_run_reads_all(r), r->hist_now);
            end[l] = cf_solver_run_post(&B->view[l], r, &e[l], ke[l], vg[l]);
        }
        CF_BN(phase_positions)(s, &B->b);
        for (l = 0; l < CF_BW; l++) {
            if (B->job[l] < 0) continue;
            if (end[l]) {
                int j = B->job[l];
                cf_solver_run_finish(&B->view[l], &B->r[l], jobs[j].residual_dislocation, &out[j].result);
                out[j].status = B->r[l].st;
                memcpy(out[j].message, B->view[l].msg, CF_MSG_LEN);
                B->job[l] = -1;
                CF_BN(lane_reset)(s, B, l);   /* a defined, finite state while it waits (lane_fill resets again) */
            } else B->r[l].n++;
        }
    }
    CF_BN(close)(B, C, raw, order);
    return CF_OK;
}

#undef CF_PH_SEL
#endif
