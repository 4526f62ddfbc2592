/* ---- the residuals of an iterate and the stopping tests (ipm_check: one pass over the data, which also takes the
 * last step and prepares the next step's weights and the predictor's right-hand side) ---- */

/* ipm_check's work on side j (sign sg) of a row whose A z is az: its r_p and 1 / t, into the row's sums row (its y,
 * its weight W = sum lam / t, the predictor's g: both sides of a row add to the same three, from 0) and the stopping
 * test's acc (the sum of t lam, the largest residual or product, the largest multiplier) */
static inline void ipm_check_side(int j, ipm_real_t sg, ipm_real_t az, ipm_real_t *row, ipm_real_t *acc) {
  const ipm_real_t t = IPM_W.t[j];
  const ipm_real_t lam = IPM_W.lam[j];
  const ipm_real_t it = IPM_ONE / t;
  const ipm_real_t rp = ((sg * az) - IPM_W.bs[j]) - t;
  row[0] -= sg * lam;
  row[1] += lam * it;
  row[2] += (sg * ((t * lam) + (lam * rp))) * it;
  IPM_W.r_p[j] = rp;
  IPM_W.it[j] = it;
  if (IPM_FABS(rp) > acc[1]) {
    acc[1] = IPM_FABS(rp);
  }
  acc[0] += t * lam;
  if ((t * lam) > acc[1]) {
    acc[1] = t * lam;
  }
  if (lam > acc[2]) {
    acc[2] = lam;
  }
}

/* the last step (IPM_W.aff[3]: its length, 0 for none) taken on the sides' t, lam and on z; then h = P z + q */
static void ipm_take_step(const ipm_real_t *q) {
  int j;
  const ipm_real_t alpha = IPM_W.aff[3];
  for (j = 0; j < IPM_NSIDE; ++j) {
    IPM_W.t[j] += alpha * IPM_W.dt[j];
    IPM_W.lam[j] += alpha * IPM_W.dlam[j];
  }
  for (j = 0; j < IPM_NV; ++j) { /* every variable: the soft rows' slacks' entries (dz = 0) are not read */
    IPM_W.z[j] += alpha * IPM_W.dz[j];
    IPM_W.h[j] = (IPM_W.Pd[j] * IPM_W.z[j]) + q[j];
  }
}

/* per inequality row, over its sides (A z in IPM_W.wr): its y (as ipm_compose_y), each side's r_p, t lam, lam; and
 * for the step ipm_step may take, 1 / t, the row's weight W = sum lam / t (in IPM_W.wr, over its A z once read) and
 * its predictor's right-hand side g (ipm_side_g of ipm_rc(0): the pass ipm_ineq_ATx would make, fused here). A row's
 * two sides are a lower and an upper one (IPM_IN_TWO): their signs are constants, the row's sums stay in registers.
 * Into acc: the sum of t lam, the largest residual or product, the largest multiplier */
static void ipm_ineq_rows(ipm_real_t *acc) {
  int i;
  int j = 0;
  for (i = 0; i < IPM_NIN; ++i) {
    const int r = IPM_IN_ROW[i];
    const ipm_real_t az = IPM_W.wr[r];
    ipm_real_t row[3] = {REAL_0, REAL_0, REAL_0};
    if (IPM_IN_TWO[i] != 0) {
      ipm_check_side(j, IPM_SG_P, az, row, acc);
      ipm_check_side(j + 1, IPM_SG_M, az, row, acc);
      j += 2;
    } else {
      ipm_check_side(j, IPM_SIDE_SG[j], az, row, acc);
      ++j;
    }
    IPM_W.y[r] = row[0];
    IPM_W.wr[r] = row[1];
    IPM_W.ar[r] = row[2];
  }
}

/* the equality rows' residuals A z - l in IPM_W.wr, A z of the init and the dynamics rows formed here (the stage
 * equality rows' by ipm_Ax); returns their largest magnitude, from 0 (the init rows, the dynamics rows by stage, the
 * stage equality rows: every equality row once). The dynamics rows' residuals become c_k = -r_eq / E (ipm_stage_c)
 * in the same pass */
static ipm_real_t ipm_eq_residuals(const ipm_real_t *z, const ipm_real_t *l) {
  int i;
  int k;
  ipm_real_t rmax = REAL_0;
  for (i = 0; i < IPM_NX; ++i) {
    const int r = IPM_INIT_ROWS[i];
    const ipm_real_t v = (IPM_W.einit[i] * z[IPM_VMAP_XU[i]]) - l[r];
    IPM_W.wr[r] = v;
    if (IPM_FABS(v) > rmax) {
      rmax = IPM_FABS(v);
    }
  }
  for (k = 0; k < IPM_N; ++k) { /* row i of stage k: E_i (x_{k+1}[i] - ([F G] v_k)[i]) */
    ipm_real_t v[IPM_NXU];
    ipm_real_t f[IPM_NX] = {0};
    ipm_gather_xu(k, z, v);
    ipm_fg_axpy(IPM_W.fgb[k], v, f);
    if (IPM_XU_LO[k + 1] == 0) { /* x_{k+1} on consecutive variables, the stage's dynamics rows consecutive */
      const ipm_real_t *xn = &z[IPM_XU_V[k + 1]];
      const ipm_idx_t *en = &IPM_DYN_NEXT[k * IPM_NX];
      const int r0 = IPM_DYN_ROWS[k * IPM_NX];
      ipm_real_t *o = &IPM_W.wr[r0];
      const ipm_real_t *lo = &l[r0];
      for (i = 0; i < IPM_NX; ++i) {
        const ipm_real_t d = (IPM_W.Ax[en[i]] * (xn[i] - f[i])) - lo[i];
        if (IPM_FABS(d) > rmax) {
          rmax = IPM_FABS(d);
        }
        o[i] = d * (-IPM_W.Einv[k][i]);
      }
    } else {
      for (i = 0; i < IPM_NX; ++i) {
        const int q = (k * IPM_NX) + i;
        const int r = IPM_DYN_ROWS[q];
        const ipm_real_t d = (IPM_W.Ax[IPM_DYN_NEXT[q]] * (z[IPM_VMAP_XU[((k + 1) * IPM_NXU) + i]] - f[i])) - l[r];
        if (IPM_FABS(d) > rmax) {
          rmax = IPM_FABS(d);
        }
        IPM_W.wr[r] = d * (-IPM_W.Einv[k][i]);
      }
    }
  }
#if IPM_NE > 0
  for (i = 0; i < ((IPM_N + 1) * IPM_NE1); ++i) {
    const int r = IPM_EQ_ROW[i];
    if (r >= 0) {
      const ipm_real_t v = IPM_W.wr[r] - l[r];
      IPM_W.wr[r] = v;
      if (IPM_FABS(v) > rmax) {
        rmax = IPM_FABS(v);
      }
    }
  }
#endif
  return rmax;
}

/* the stationarity residuals' largest magnitude, at least rmax0; NaN once one is not finite: 0 times each summed
 * (two chains of each, the even and the odd entries: their maxima and sums overlap) */
static ipm_real_t ipm_stationarity_max(ipm_real_t rmax0) {
  int i;
  ipm_real_t rmax = rmax0;
  ipm_real_t nf0 = REAL_0;
  ipm_real_t nf1 = REAL_0;
  ipm_real_t rm1 = REAL_0;
  for (i = 0; i < IPM_NGV; i += 2) {
    const ipm_real_t r0 = IPM_W.r_d[IPM_GV[i]];
    const ipm_real_t r1 = ((i + 1) < IPM_NGV) ? IPM_W.r_d[IPM_GV[i + 1]] : REAL_0;
    nf0 += r0 * REAL_0;
    nf1 += r1 * REAL_0;
    rmax = ipm_max(IPM_FABS(r0), rmax);
    rm1 = ipm_max(IPM_FABS(r1), rm1);
  }
  rmax = ipm_max(rm1, rmax);
  nf0 += nf1;
  if (isfinite(nf0) == 0) {
    rmax = nf0;
  }
  return rmax;
}

/* residuals and the stopping tests of the current iterate: IPM_GOING, or the raw status it stops with; mu */
static int ipm_check(const ipm_real_t *q, const ipm_real_t *l, ipm_real_t *mu_out) {
  int j;
  int raw = IPM_GOING;
  ipm_real_t mu;
  ipm_real_t rmax;
  ipm_real_t req;
  ipm_real_t m[2];
  ipm_real_t acc[3] = {REAL_0, REAL_0, REAL_0};
  ipm_take_step(q);
  ipm_Ax(IPM_W.z, IPM_W.wr); /* A z: the weights on the inequality rows, residuals on the others */
  req = ipm_eq_residuals(IPM_W.z, l);
  ipm_ineq_rows(acc);
  for (j = 0; j < IPM_NFREE; ++j) {
    const int v = IPM_FREE[j];
    IPM_W.h[v] = ((IPM_W.Pd[v] + IPM_PROX) * IPM_W.z[v]) + q[v];
  }
  ipm_ATx(IPM_W.h, IPM_W.y, IPM_W.r_d);
  m[0] = acc[1]; /* the largest residual or product, the largest multiplier: the soft rows' too */
  m[1] = acc[2];
  mu = acc[0] + ipm_sr_check(m);
  rmax = (req > m[0]) ? req : m[0]; /* the max of both (NaN if m[0] is) */
  mu /= (ipm_real_t)IPM_NCOMP;
  rmax = ipm_stationarity_max(rmax);
  if ((isfinite(rmax) == 0) || (isfinite(mu) == 0)) {
    raw = IPM_RAW_QP_NONFINITE;
  } else if (rmax <= IPM_TOL) {
    raw = IPM_RAW_QP_SOLVED;
  } else if (m[1] > IPM_LAM_MAX) {
    raw = IPM_RAW_QP_PRIMAL_INFEASIBLE;
  } else {
    /* not converged */
  }
  *mu_out = mu;
  return raw;
}
