/* ---- the backend interface, the IPM's driver: qpb_reset, the prepare phase qpb_set_matrices, and
 * qpb_solve, which starts from z = 0 and the warm duals and alternates ipm_check and ipm_step ---- */
/* the workspace zeroed: the state of program start */
static void qpb_reset(void) {
  (void)memset(&IPM_W, 0, sizeof IPM_W);
}

/* prepare phase: the dynamics blocks of this sample */
static int qpb_set_matrices(const ipm_real_t *P_x, const ipm_real_t *A_x, const ipm_real_t *q) {
  int k;
  int i;
  (void)q;
  IPM_W.Pd = P_x;
  IPM_W.Ax = A_x;
  for (k = 0; k < IPM_N; ++k) { /* [F G] = -A / E, packed by bands (the pattern is fixed: entries of a band outside
                                 * it are never written, so they stay 0 from qpb_reset) */
    int e;
    for (i = 0; i < IPM_NX; ++i) {
      IPM_W.Einv[k][i] = IPM_ONE / A_x[IPM_DYN_NEXT[(k * IPM_NX) + i]];
    }
    for (e = IPM_DYN_PTR[k]; e < IPM_DYN_PTR[k + 1]; ++e) { /* a band's other entries: 0 since qpb_reset */
      IPM_W.fgb[k][IPM_DYN_B[e]] = (-A_x[IPM_DYN_A[e]]) * IPM_W.Einv[k][IPM_DYN_I[e]];
    }
  }
  for (i = 0; i < IPM_NX; ++i) {
    IPM_W.einit[i] = A_x[IPM_INIT_A[i]];
  }
  for (i = 0; i < IPM_NGA; ++i) { /* the inequality rows' coefficients in the order the feedback loops read them */
    IPM_W.gax[i] = A_x[IPM_GEN_A[i]];
  }
  for (i = 0; i < ((IPM_N + 1) * IPM_NG); ++i) {
    IPM_W.gex[i] = (IPM_GEN_E[i] >= 0) ? A_x[IPM_GEN_E[i]] : REAL_0;
  }
  for (i = 0; i < IPM_NBOX; ++i) {
    IPM_W.bax[i] = A_x[IPM_BOX_A[i]];
  }
  for (i = 0; i < IPM_NSRP; ++i) { /* times the sides' signs: both sides of a soft row are lower sides */
    const ipm_real_t sg = (ipm_real_t)IPM_SR_SIGN[i];
    int p;
    for (p = 0; p < IPM_NA; ++p) {
      const int da = IPM_SR_A[i][p];
      IPM_SR.a[p][i] = (da >= 0) ? (sg * A_x[da]) : REAL_0;
    }
    if (IPM_SR_ROW[i] < 0) { /* a padding row: no data, P_s = 1 */
      IPM_SR.e[i] = REAL_0;
      IPM_SR.ps[i] = IPM_ONE;
      IPM_SR.bb[i] = REAL_0;
      IPM_SR.w[i] = REAL_0;
    } else {
      IPM_SR.e[i] = sg * A_x[IPM_SR_E[i]];
      IPM_SR.ps[i] = P_x[IPM_SR_SVAR[i]];
      IPM_SR.bb[i] = ((ipm_real_t)IPM_SR_BSIGN[i]) * A_x[IPM_SR_BA[i]];
      IPM_SR.w[i] = IPM_ONE;
    }
  }
  return 0;
}

/* y: equality rows nu, inequality rows lam_upper - lam_lower */
static void ipm_compose_y(void) {
  int i;
  int j;
  for (i = 0; i < IPM_NIN; ++i) { /* equality rows: their multipliers, all along */
    ipm_real_t v = REAL_0;
    for (j = IPM_IN_PTR[i]; j < IPM_IN_PTR[i + 1]; ++j) {
      v -= IPM_SIDE_SG[j] * IPM_W.lam[j];
    }
    IPM_W.y[IPM_IN_ROW[i]] = v;
  }
  for (i = 0; i < IPM_NSRP; ++i) {
    if (IPM_SR_ROW[i] < 0) {
      continue; /* a padding row */
    }
    IPM_W.z[IPM_SR_SVAR[i]] = IPM_SR.zs[i];
    IPM_W.y[IPM_SR_ROW[i]] = -(((ipm_real_t)IPM_SR_SIGN[i]) * IPM_SR.l1[i]);
    IPM_W.y[IPM_SR_BROW[i]] = -(((ipm_real_t)IPM_SR_BSIGN[i]) * IPM_SR.l2[i]);
  }
}

/* side j: sign a'z - b >= 0 with b = l (lower side) or -u (upper side) */
static ipm_real_t ipm_side_b(const ipm_real_t *l, const ipm_real_t *u, int j) {
  return (IPM_SIDE_SIGN[j] > 0) ? l[IPM_SIDE_ROW[j]] : (-u[IPM_SIDE_ROW[j]]);
}

/* a soft row's slack bound's initial t given its initial lam: max(-b, IPM_T_MIN / max(1, lam)) with
 * IPM_SCALED_START (no initial t lam above IPM_T_MIN: the bound carries a multiplier near the row's L1 weight), else
 * max(-b, IPM_T_MIN) as every other side */
static inline ipm_real_t ipm_t2_start(ipm_real_t b, ipm_real_t lam) {
#if IPM_SCALED_START
  const ipm_real_t f = IPM_T_MIN / ((IPM_ONE > lam) ? IPM_ONE : lam);
#else
  const ipm_real_t f = IPM_T_MIN;
  (void)lam;
#endif
  return ((-b) > f) ? (-b) : f;
}

/* a side's initial lam from its warm multiplier lw and its b (the slack at z = 0 is -b): max(lw, IPM_LAM_MIN /
 * max(1, -b)) with IPM_SCALED_START (a side far from its bound starts with t lam at most IPM_LAM_MIN, not
 * IPM_LAM_MIN (-b), which would set mu0 and, through the centring, every multiplier), else max(lw, IPM_LAM_MIN) */
static inline ipm_real_t ipm_lam_start(ipm_real_t b, ipm_real_t lw) {
#if IPM_SCALED_START
  const ipm_real_t f = IPM_LAM_MIN / (((-b) > IPM_ONE) ? (-b) : IPM_ONE);
#else
  const ipm_real_t f = IPM_LAM_MIN;
  (void)b;
#endif
  return (lw > f) ? lw : f;
}

/* the sides' b and initial t, lam (lam from the warm duals, ipm_lam_start; t at least IPM_T_MIN), no step */
static void ipm_start_sides(const ipm_real_t *l, const ipm_real_t *u, const ipm_real_t *y_warm) {
  int j;
  for (j = 0; j < IPM_NSIDE; ++j) {
    const int r = IPM_SIDE_ROW[j];
    const ipm_real_t lw = (IPM_WARM != 0) ? ((-IPM_SIDE_SIGN[j]) * y_warm[r]) : REAL_0;
    const ipm_real_t b = ipm_side_b(l, u, j);
    IPM_W.bs[j] = b;
    IPM_W.dt[j] = REAL_0; /* no step taken yet (IPM_W.aff[3] = 0): ipm_check takes the last step */
    IPM_W.dlam[j] = REAL_0;
    IPM_W.t[j] = ((-b) > IPM_T_MIN) ? (-b) : IPM_T_MIN;
    IPM_W.lam[j] = ipm_lam_start(b, lw);
  }
}

/* with IPM_SCALED_START, a slack's bound without a warm lam (0: a cold start) starts at the slack's cost over the
 * bound's coefficient, q_s / c: the multiplier the bound carries while the slack's row is inactive (the slack's
 * stationarity P_s s + q_s - c lam = 0 at s = 0, the row's lam 0), not at the floor, from which an L1 weight's
 * multiplier takes the IPM many steps to climb; its t as a soft row's slack bound's (ipm_t2_start) */
static void ipm_start_slack_bounds(const ipm_real_t *q, const ipm_real_t *y_warm) {
#if IPM_SCALED_START
  int i;
  for (i = 0; i < IPM_NSB; ++i) {
    const int j = IPM_SB_SIDE[i];
    const ipm_real_t lw = (IPM_WARM != 0) ? ((-IPM_SIDE_SIGN[j]) * y_warm[IPM_SIDE_ROW[j]]) : REAL_0;
    const ipm_real_t c = IPM_SIDE_SG[j] * IPM_W.Ax[IPM_SB_A[i]];
    if ((lw == REAL_0) && (c > REAL_0)) {
      IPM_W.lam[j] = ipm_lam_start(IPM_W.bs[j], q[IPM_SB_VAR[i]] / c);
      IPM_W.t[j] = ipm_t2_start(IPM_W.bs[j], IPM_W.lam[j]);
    }
  }
#else
  (void)q;
  (void)y_warm;
#endif
}

/* the soft rows' b and initial iterates (as the sides'; the slack z_s = 0; a slack bound without a warm lam as in
 * ipm_start_slack_bounds), no step */
static void ipm_start_soft_rows(const ipm_real_t *q, const ipm_real_t *l, const ipm_real_t *u,
                                const ipm_real_t *y_warm) {
  int j;
  for (j = 0; j < IPM_NSRP; ++j) {
    const int r = IPM_SR_ROW[j];
    const int rb = IPM_SR_BROW[j];
    IPM_SR.zs[j] = REAL_0;
    IPM_SR.dzs[j] = REAL_0; /* no step taken yet (IPM_W.aff[3] = 0) */
    IPM_SR.dt1[j] = REAL_0;
    IPM_SR.dl1[j] = REAL_0;
    IPM_SR.dt2[j] = REAL_0;
    IPM_SR.dl2[j] = REAL_0;
    if (r < 0) { /* a padding row: b = -1 and t = 1 on both sides, lam = 0, no cost: every step keeps t, z_s */
      IPM_SR.b1[j] = -IPM_ONE;
      IPM_SR.b2[j] = -IPM_ONE;
      IPM_SR.t1[j] = IPM_ONE;
      IPM_SR.t2[j] = IPM_ONE;
      IPM_SR.l1[j] = REAL_0;
      IPM_SR.l2[j] = REAL_0;
      IPM_SR.qs[j] = REAL_0;
    } else {
      const ipm_real_t lw1 = (IPM_WARM != 0) ? ((-IPM_SR_SIGN[j]) * y_warm[r]) : REAL_0;
      ipm_real_t lw2 = (IPM_WARM != 0) ? ((-IPM_SR_BSIGN[j]) * y_warm[rb]) : REAL_0;
#if IPM_SCALED_START
      if ((lw2 == REAL_0) && (IPM_SR.bb[j] > REAL_0)) { /* no warm lam (a cold start): see ipm_start_slack_bounds */
        lw2 = q[IPM_SR_SVAR[j]] / IPM_SR.bb[j];
      }
#endif
      IPM_SR.b1[j] = (IPM_SR_SIGN[j] > 0) ? l[r] : (-u[r]);
      IPM_SR.b2[j] = (IPM_SR_BSIGN[j] > 0) ? l[rb] : (-u[rb]);
      IPM_SR.t1[j] = ((-IPM_SR.b1[j]) > IPM_T_MIN) ? (-IPM_SR.b1[j]) : IPM_T_MIN;
      IPM_SR.l1[j] = ipm_lam_start(IPM_SR.b1[j], lw1);
      IPM_SR.l2[j] = ipm_lam_start(IPM_SR.b2[j], lw2);
      IPM_SR.t2[j] = ipm_t2_start(IPM_SR.b2[j], IPM_SR.l2[j]);
      IPM_SR.qs[j] = q[IPM_SR_SVAR[j]];
    }
  }
}

/* a centred start: every lam at least IPM_LAM_CENTER mean(t lam) / t */
static void ipm_centre(void) {
  int j;
  ipm_real_t c = REAL_0;
  for (j = 0; j < IPM_NSIDE; ++j) {
    c += IPM_W.t[j] * IPM_W.lam[j];
  }
  for (j = 0; j < IPM_NSRP; ++j) {
    c += (IPM_SR.t1[j] * IPM_SR.l1[j]) + (IPM_SR.t2[j] * IPM_SR.l2[j]); /* a padding row: lam = 0 here */
  }
  c = IPM_LAM_CENTER * (c / (ipm_real_t)IPM_NCOMP);
  for (j = 0; j < IPM_NSIDE; ++j) {
    const ipm_real_t lc = c / IPM_W.t[j];
    IPM_W.lam[j] = (lc > IPM_W.lam[j]) ? lc : IPM_W.lam[j];
  }
  for (j = 0; j < IPM_NSRP; ++j) {
    if (IPM_SR_ROW[j] >= 0) { /* a padding row keeps lam = 0 */
      const ipm_real_t lc1 = c / IPM_SR.t1[j];
      const ipm_real_t lc2 = c / IPM_SR.t2[j];
      IPM_SR.l1[j] = (lc1 > IPM_SR.l1[j]) ? lc1 : IPM_SR.l1[j];
      IPM_SR.l2[j] = (lc2 > IPM_SR.l2[j]) ? lc2 : IPM_SR.l2[j];
    }
  }
}

/* the QP of this sample (q, bounds l <= A z <= u) from z = 0 and the warm duals y_warm, at most max_iter steps */
static int qpb_solve(const ipm_real_t *q, const ipm_real_t *l, const ipm_real_t *u, const ipm_real_t *y_warm,
                     int max_iter, qpb_result_t *res) {
  int j;
  int it = 0;
  int raw = IPM_GOING;
  ipm_start_sides(l, u, y_warm);
  ipm_start_slack_bounds(q, y_warm);
  ipm_start_soft_rows(q, l, u, y_warm);
  IPM_W.aff[3] = REAL_0;
  ipm_centre();
  for (j = 0; j < IPM_NEQ; ++j) {
    IPM_W.y[IPM_EQ_ALL[j]] = (IPM_WARM != 0) ? y_warm[IPM_EQ_ALL[j]] : REAL_0;
  }
  for (j = 0; j < IPM_NGV; ++j) {
    IPM_W.z[IPM_GV[j]] = REAL_0;
    IPM_W.dz[IPM_GV[j]] = REAL_0; /* the soft rows' slacks' entries stay 0 */
  }
  QPB_PROBE(QPB_PROBE_START);
  while (raw == IPM_GOING) {
    ipm_real_t mu;
    raw = ipm_check(q, l, &mu);
    QPB_PROBE(QPB_PROBE_CHECK);
    if ((raw == IPM_GOING) && (it >= max_iter)) {
      raw = IPM_RAW_QP_MAX_ITER;
    }
    if (raw == IPM_GOING) {
      raw = ipm_step(mu);
      QPB_PROBE(QPB_PROBE_STEP);
      if (raw == IPM_GOING) {
        ++it;
      }
    }
  }
  ipm_compose_y();
  QPB_PROBE(QPB_PROBE_END);
  res->raw_status = raw;
  res->status = IPM_STATUS[raw];
  res->iter = it;
  res->z = (raw == IPM_RAW_QP_NONFINITE) ? NULL : IPM_W.z;
  res->y = (raw == IPM_RAW_QP_NONFINITE) ? NULL : IPM_W.y;
  return 0;
}
