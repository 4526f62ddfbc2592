/* ---- the core of an interior-point step: the sides' complementarity targets and right-hand sides, their steps and
 * the step to the boundary, one Newton direction, and Mehrotra's predictor-corrector step with its centring ---- */
/* the sides j of inequality row i (IPM_IN_ROW[i]) are IPM_IN_PTR[i] .. IPM_IN_PTR[i + 1] - 1 (lower side first).
 * ipm_check's pass runs over the rows in order, hence over the sides in order, the row's sums in registers: two sides
 * (IPM_IN_TWO) are a lower and an upper one, whose signs are constants (the generator checks); one side has its sign
 * from IPM_SIDE_SG. The other passes run flat over the sides (IPM_SIDE_ROW; a per-row sum: the row's first side
 * sets it, a second (IPM_SIDE_2ND) adds): measured, that is cheaper for them on the Cortex-M7 and no dearer on x86 */
/* complementarity target of side j: t lam (predictor) or t lam + dt dlam - sm (corrector, with the predictor's step
 * still in IPM_W.dt, IPM_W.dlam) */
static ipm_real_t ipm_rc(int corr, ipm_real_t sm, int j) {
  return (corr != 0) ? (((IPM_W.t[j] * IPM_W.lam[j]) + (IPM_W.dt[j] * IPM_W.dlam[j])) - sm)
                     : (IPM_W.t[j] * IPM_W.lam[j]);
}

/* side j's (sign sg) share of its row's right-hand side g: sign (rc + lam r_p) / t */
static inline ipm_real_t ipm_side_g(int j, ipm_real_t sg, ipm_real_t rc) {
  return (sg * (rc + (IPM_W.lam[j] * IPM_W.r_p[j]))) * IPM_W.it[j];
}

/* h = r_d + A_in' g, g the inequality rows' right-hand sides: per row (IPM_W.ar), the sum over its sides of
 * sign (rc + lam r_p) / t; then scattered over the rows' entries (general slots, then box rows). The predictor's g
 * is ipm_check's (its pass over the sides leaves it in IPM_W.ar); the corrector's, a pass over the sides here */
static void ipm_ineq_ATx(int corr, ipm_real_t sm) {
  int k;
  int a;
  (void)memcpy(IPM_W.h, IPM_W.r_d, sizeof IPM_W.h); /* the soft rows' slacks' entries are not read */
  if (corr != 0) { /* flat over the sides (measured: cheaper on the Cortex-M7 than by rows); the corrector's target
                    * kept in IPM_W.dlam (the predictor's dlam is read here for the last time) for ipm_ineq_sides */
    int j;
    for (j = 0; j < IPM_NSIDE; ++j) {
      const int r = IPM_SIDE_ROW[j];
      const ipm_real_t rc = ipm_rc(1, sm, j);
      IPM_W.dlam[j] = rc;
      IPM_W.ar[r] = ((IPM_SIDE_2ND[j] != 0) ? IPM_W.ar[r] : REAL_0) + ipm_side_g(j, IPM_SIDE_SG[j], rc);
    }
  }
  for (k = 0; k <= IPM_N; ++k) {
    IPM_GEN_ROWS(k, ipm_gen_atx(k), ipm_rows_atx_any(k));
  }
  for (a = 0; a < IPM_NBOX; ++a) {
    IPM_W.h[IPM_BOX_VAR[a]] += IPM_W.bax[a] * IPM_W.ar[IPM_BOX_ROW[a]];
  }
}

/* side j's (sign sg) step dt, dlam from its row's a'dz (ad) and target rc; returns amax cut to its boundary */
static inline ipm_real_t ipm_side_step(int j, ipm_real_t sg, ipm_real_t ad, ipm_real_t rc, ipm_real_t amax) {
  ipm_real_t am = amax;
  const ipm_real_t dt = (sg * ad) + IPM_W.r_p[j];
  const ipm_real_t dl = (-(rc + (IPM_W.lam[j] * dt))) * IPM_W.it[j];
  /* t + a dt < 0 only if dt < 0 (t, a > 0): a branch that is rarely taken, so well predicted */
  if ((IPM_W.t[j] + (am * dt)) < REAL_0) {
    am = (-IPM_W.t[j]) / dt;
  }
  if ((IPM_W.lam[j] + (am * dl)) < REAL_0) {
    am = (-IPM_W.lam[j]) / dl;
  }
  IPM_W.dt[j] = dt;
  IPM_W.dlam[j] = dl;
  return am;
}

/* the sides' steps dt, dlam from A dz on the inequality rows (per row in IPM_W.ar: general, then box rows; then one
 * pass over the sides, written once per target: the corrector's, ipm_ineq_ATx left in IPM_W.dlam); returns the
 * largest step to the boundary (at most amax0) */
static ipm_real_t ipm_ineq_sides(int corr, ipm_real_t amax0) {
  int j;
  ipm_real_t amax = amax0;
  ipm_ineq_Ax(IPM_W.dz, IPM_W.ar);
  if (corr != 0) { /* flat over the sides (measured: cheaper here than by rows) */
    for (j = 0; j < IPM_NSIDE; ++j) {
      amax = ipm_side_step(j, IPM_SIDE_SG[j], IPM_W.ar[IPM_SIDE_ROW[j]], IPM_W.dlam[j], amax);
    }
  } else { /* the predictor also sums t lam, t dlam + lam dt, dt dlam into IPM_W.aff (mu_aff for any step length) */
    ipm_real_t s0 = REAL_0;
    ipm_real_t s1 = REAL_0;
    ipm_real_t s2 = REAL_0;
    for (j = 0; j < IPM_NSIDE; ++j) {
      const ipm_real_t rc = ipm_rc(0, REAL_0, j);
      amax = ipm_side_step(j, IPM_SIDE_SG[j], IPM_W.ar[IPM_SIDE_ROW[j]], rc, amax);
      s0 += rc;
      s1 += (IPM_W.t[j] * IPM_W.dlam[j]) + (IPM_W.lam[j] * IPM_W.dt[j]);
      s2 += IPM_W.dt[j] * IPM_W.dlam[j];
    }
    IPM_W.aff[0] += s0;
    IPM_W.aff[1] += s1;
    IPM_W.aff[2] += s2;
  }
  return amax;
}

/* direction for the complementarity target ipm_rc -> IPM_W.dz, IPM_W.dt, IPM_W.dlam (and the equality duals' step
 * in IPM_W.gd); with factor, the Newton matrix is factored in the same backward sweep. The largest step to the
 * boundary (at most 1) in *amax; 1 if a pivot is not positive */
static int ipm_direction(int corr, ipm_real_t sm, int factor, ipm_real_t *amax) {
  ipm_ineq_ATx(corr, sm);
  if (ipm_backward(corr, sm, factor) != 0) {
    return 1;
  }
  *amax = ipm_ineq_sides(corr, ipm_forward(corr, sm));
  return 0;
}

/* one predictor-corrector step from the iterate ipm_check left (mu: its complementarity): IPM_GOING, or the raw
 * status it stops with */
static int ipm_step(ipm_real_t mu) {
  int j;
  ipm_real_t nf;
  ipm_real_t a_aff = REAL_0;
  ipm_real_t mu_aff = REAL_0;
  ipm_real_t ratio;
  ipm_real_t sigma;
  ipm_real_t alpha = REAL_0;
  /* IPM_W.wr: W = sum lam / t on the inequality rows (ipm_check), r_eq on the others */
  ipm_hd();
  /* predictor (affine scaling; the Newton matrix factored in its backward sweep), then Mehrotra's corrector with
   * the centring sigma = (mu_aff / mu)^3 */
  if (ipm_direction(0, REAL_0, 1, &a_aff) != 0) {
    return IPM_RAW_QP_NUMERICAL;
  }
  /* the sum of (t + a dt) (lam + a dlam) over the sides and the soft rows, from the predictor's sums */
  mu_aff = IPM_W.aff[0] + (a_aff * (IPM_W.aff[1] + (a_aff * IPM_W.aff[2])));
  mu_aff /= (ipm_real_t)IPM_NCOMP;
  ratio = mu_aff / mu;
  sigma = (ratio * ratio) * ratio;
  (void)ipm_direction(1, sigma * mu, 0, &alpha);
  alpha *= IPM_TAU;
  if (alpha > IPM_ONE) {
    alpha = IPM_ONE;
  }
  nf = ipm_dz_nonfinite(); /* NaN once an entry of the step is not finite (the soft rows' slacks': 0) */
  if (isfinite(nf) == 0) {
    return IPM_RAW_QP_NONFINITE;
  }
  if (alpha < IPM_ALPHA_MIN) {
    return IPM_RAW_QP_NUMERICAL;
  }
  for (j = 0; j < IPM_NEQ; ++j) {
    IPM_W.y[IPM_EQ_ALL[j]] += alpha * IPM_W.gd[IPM_EQ_ALL[j]];
  }
  IPM_W.aff[3] = alpha; /* z, the sides' t, lam and the soft rows take this step in the next ipm_check's passes */
  return IPM_GOING;
}
