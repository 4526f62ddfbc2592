/* ---- the soft rows (IPM_SR_*), their fused passes: soft row j's side t1 = a'v + e s - b1 and its slack's bound t2 = bb s - b2 (the
 * coefficients multiplied by the sides' signs in the prepare phase, so both are lower sides here); the slack is
 * eliminated with its two sides (pivot d = hd_s + W1 e^2, hd_s = P_s + W2 bb^2), so a soft row adds W1 hd_s / d a a'
 * to its stage's Newton block: the generic rows' algebra. A stage's soft rows come in runs of rows on the same (x, u)
 * slots (IPM_SR_RUN_*), and an iteration reads every row three times, not six (the rows are most of the data):
 * ipm_sr_check takes the step, tests, and sums per run the Newton block's terms (IPM_W.srh) and the predictor's
 * right-hand side (IPM_W.srr[0]); ipm_sr_forward's predictor pass steps the rows and sums the corrector's right-hand
 * side, which is affine in sigma mu (IPM_W.srr[1] - sigma mu IPM_W.srr[2]); the corrector's forward pass steps them
 * again. A run is read IPM_LANES rows at a time, row j0 + i on lane i % IPM_LANES (its storage is padded to whole
 * groups of lanes with rows of no data: a = e = bb = 0, t = 1, so their steps keep t and their lam stays finite, and
 * IPM_SR.w = 0 masks their t lam, lam and step limit), and every sum over its rows keeps one partial sum per lane
 * (added at the run's end): the lanes are independent, so a compiler maps them onto SIMD registers (plain C99, no
 * pragma, no intrinsics) ---- */
#define IPM_SR IPM_W.sr
#define IPM_SR_NACC (4 + IPM_SR_NT + (3 * IPM_NA)) /* ipm_sr_check's sums per lane (see ipm_sr_check_row) */
/* ipm_sr_check's rows j .. j + IPM_LANES - 1 (row j + l on lane l): the last step (alpha) taken; both sides'
 * residuals and 1 / t; the slack's stationarity residual; the slack's elimination (1 / d, c = W1 e) and the
 * predictor's slack right-hand side. Into the lanes of acc: [0] t lam (sum), [1] residuals and products (max), [2]
 * multipliers (max), [3] 0 times the stationarity residual (sum: NaN once one is not finite), [4 + p] the stage
 * variables' stationarity -a l1, then the upper triangle of W1 hd_s / d a a', then a times the predictor's f and a
 * times the corrector's sigma mu coefficient. Every loop over the lanes is innermost (whole SIMD registers) */
static void ipm_sr_check_rows(int j, ipm_real_t alpha, const ipm_real_t *zr, ipm_real_t (*acc)[IPM_LANES]) {
  int l;
  ipm_real_t az[IPM_LANES];
  ipm_real_t l1v[IPM_LANES];
  ipm_real_t weff[IPM_LANES];
  ipm_real_t f[IPM_LANES];
  ipm_real_t fb[IPM_LANES];
  ipm_sr_av(j, zr, az);
  for (l = 0; l < IPM_LANES; ++l) {
    const int i = j + l;
    const ipm_real_t zs = IPM_SR.zs[i] + (alpha * IPM_SR.dzs[i]);
    const ipm_real_t t1 = IPM_SR.t1[i] + (alpha * IPM_SR.dt1[i]);
    const ipm_real_t l1 = IPM_SR.l1[i] + (alpha * IPM_SR.dl1[i]);
    const ipm_real_t t2 = IPM_SR.t2[i] + (alpha * IPM_SR.dt2[i]);
    const ipm_real_t l2 = IPM_SR.l2[i] + (alpha * IPM_SR.dl2[i]);
    const ipm_real_t e = IPM_SR.e[i];
    const ipm_real_t bb = IPM_SR.bb[i];
    const ipm_real_t w = IPM_SR_W(i);
    const ipm_real_t tl1 = t1 * l1;
    const ipm_real_t tl2 = t2 * l2;
    const ipm_real_t it1 = IPM_ONE / t1;
    const ipm_real_t it2 = IPM_ONE / t2;
    const ipm_real_t w1 = l1 * it1;
    const ipm_real_t hds = IPM_SR.ps[i] + ((l2 * it2) * (bb * bb));
    const ipm_real_t c = w1 * e;
    const ipm_real_t id = IPM_ONE / (hds + (c * e));
    const ipm_real_t rp1 = ((az[l] + (e * zs)) - IPM_SR.b1[i]) - t1;
    const ipm_real_t rp2 = ((bb * zs) - IPM_SR.b2[i]) - t2;
    const ipm_real_t rds = ((IPM_SR.ps[i] * zs) + IPM_SR.qs[i]) - ((e * l1) + (bb * l2));
    const ipm_real_t g1 = (tl1 + (l1 * rp1)) * it1;
    const ipm_real_t g2 = (tl2 + (l2 * rp2)) * it2;
    const ipm_real_t hv = (rds + (e * g1)) + (bb * g2);
    weff[l] = (w1 * hds) * id;
    f[l] = g1 - ((c * hv) * id);
    fb[l] = it1 - ((c * ((e * it1) + (bb * it2))) * id);
    l1v[l] = l1;
    IPM_SR.zs[i] = zs;
    IPM_SR.rds[i] = rds;
    IPM_SR.t1[i] = t1;
    IPM_SR.l1[i] = l1;
    IPM_SR.t2[i] = t2;
    IPM_SR.l2[i] = l2;
    IPM_SR.rp1[i] = rp1;
    IPM_SR.rp2[i] = rp2;
    IPM_SR.it1[i] = it1;
    IPM_SR.it2[i] = it2;
    IPM_SR.c[i] = c;
    IPM_SR.id[i] = id;
    IPM_SR.hs[i] = hv;
    acc[0][l] += w * (tl1 + tl2);
    acc[1][l] = ipm_max(ipm_max(ipm_max(IPM_FABS(rp1), IPM_FABS(rp2)), ipm_max(w * ipm_max(tl1, tl2), IPM_FABS(rds))),
                        acc[1][l]);
    acc[2][l] = ipm_max(w * ipm_max(l1, l2), acc[2][l]);
    acc[3][l] += rds * REAL_0;
  }
  ipm_sr_check_sums(j, weff, l1v, f, fb, acc); /* written out at IPM_NA (the problem header) */
}

/* ipm_check's part: the last step's t, lam (IPM_W.aff[3]: its length, 0 for none); both sides' residuals and 1 / t;
 * the slack's and the stage variables' stationarity (r_d holds P z + q + the other rows' A' y); the maxima of the
 * stopping test (in m[0]: residuals and products, m[1]: multipliers) and the sum of t lam (returned); per run, the
 * Newton block's terms (IPM_W.srh), the predictor's right-hand side (IPM_W.srr[0]) and the corrector's sigma mu
 * coefficient (IPM_W.srr[2]) */
static ipm_real_t ipm_sr_check(ipm_real_t *m) {
  int k;
  int r;
  int j;
  int l;
  int p;
  int q;
  ipm_real_t mu = REAL_0;
  ipm_real_t rmax = m[0];
  ipm_real_t lmax = m[1];
  ipm_real_t nf = REAL_0;
  const ipm_real_t alpha = IPM_W.aff[3];
  ipm_real_t acc[IPM_SR_NACC][IPM_LANES];
  ipm_real_t zl[IPM_NXU];
  ipm_real_t rl[IPM_NXU];
  for (p = 0; p < 4; ++p) {
    for (l = 0; l < IPM_LANES; ++l) {
      acc[p][l] = REAL_0;
    }
  }
  for (k = 0; k <= IPM_N; ++k) {
    ipm_gather_xu(k, IPM_W.z, zl);
    for (p = 0; p < IPM_NXU; ++p) {
      rl[p] = REAL_0;
    }
    for (r = IPM_SR_RPTR[k]; r < IPM_SR_RPTR[k + 1]; ++r) {
      const int j1 = IPM_SR_RUN_PTR[r + 1];
      ipm_real_t zr[IPM_NA];
      for (p = 0; p < IPM_NA; ++p) {
        zr[p] = zl[IPM_SR_RUN_V[r][p]];
      }
      for (p = 4; p < IPM_SR_NACC; ++p) {
        for (l = 0; l < IPM_LANES; ++l) {
          acc[p][l] = REAL_0;
        }
      }
      for (j = IPM_SR_RUN_PTR[r]; j < j1; j += IPM_LANES) {
        ipm_sr_check_rows(j, alpha, zr, acc);
      }
      for (p = 0; p < IPM_NA; ++p) {
        ipm_real_t s0 = REAL_0;
        ipm_real_t s1 = REAL_0;
        ipm_real_t s2 = REAL_0;
        for (l = 0; l < IPM_LANES; ++l) {
          s0 += acc[4 + p][l];
          s1 += acc[4 + IPM_NA + IPM_SR_NT + p][l];
          s2 += acc[4 + (2 * IPM_NA) + IPM_SR_NT + p][l];
        }
        rl[IPM_SR_RUN_V[r][p]] += s0;
        IPM_W.srr[0][r][p] = s1;
        IPM_W.srr[2][r][p] = s2;
      }
      for (q = 0; q < IPM_SR_NT; ++q) {
        ipm_real_t s = REAL_0;
        for (l = 0; l < IPM_LANES; ++l) {
          s += acc[4 + IPM_NA + q][l];
        }
        IPM_W.srh[r][q] = s;
      }
    }
    ipm_add_xu(k, rl, IPM_W.r_d, 0);
  }
  for (l = 0; l < IPM_LANES; ++l) {
    mu += acc[0][l];
    rmax = ipm_max(acc[1][l], rmax);
    lmax = ipm_max(acc[2][l], lmax);
    nf += acc[3][l];
  }
  if (isfinite(nf) == 0) { /* as the generic stationarity test: a non-finite residual stops the QP */
    rmax = nf;
  }
  m[0] = rmax;
  m[1] = lmax;
  return mu;
}

/* the factorization's part (stage k): its runs' W1 hd_s / d a a' (ipm_sr_check's sums) into the upper triangle of
 * IPM_W.H */
static void ipm_sr_hessian(int k) {
  int r;
  int q;
  for (r = IPM_SR_RPTR[k]; r < IPM_SR_RPTR[k + 1]; ++r) {
    for (q = 0; q < IPM_SR_NT; ++q) { /* on and above the diagonal (a padding entry: slot 0, a term 0) */
      IPM_W.H[IPM_SR_HLO[r][q]][IPM_SR_HHI[r][q]] += IPM_W.srh[r][q];
    }
  }
}

/* the backward sweep's part (stage k): the soft rows' slacks eliminated from the right-hand side ht, from the sums
 * per run of the predictor (ipm_sr_check) or of the corrector (ipm_sr_forward's predictor pass, sm = sigma mu) */
static void ipm_sr_rhs(int k, int corr, ipm_real_t sm, ipm_real_t *ht) {
  int r;
  int p;
  for (r = IPM_SR_RPTR[k]; r < IPM_SR_RPTR[k + 1]; ++r) {
    for (p = 0; p < IPM_NA; ++p) {
      ht[IPM_SR_RUN_V[r][p]] += (corr != 0) ? (IPM_W.srr[1][r][p] - (sm * IPM_W.srr[2][r][p])) : IPM_W.srr[0][r][p];
    }
  }
}

/* ipm_sr_forward's rows j .. j + IPM_LANES - 1 (row j + l on lane l; the run's step to the boundary so far: am): the
 * slack's step, both sides' dt, dlam; the least of t + am dt, lam + am dlam into the lanes of mn (negative: the run
 * cuts am). The predictor's pass (corr 0) also sums into the lanes of acc t lam, t dlam + lam dt, dt dlam, and a times
 * the corrector's f but its sigma mu term, and keeps the corrector's slack right-hand side but that term in
 * IPM_SR.hs; the corrector's pass (corr 1) adds it (-sm (e / t1 + bb / t2)) */
static void ipm_sr_forward_rows(int j, int corr, ipm_real_t sm, ipm_real_t am, const ipm_real_t *vr,
                                ipm_real_t (*acc)[IPM_LANES], ipm_real_t *mn) {
  int l;
  ipm_real_t adv[IPM_LANES];
  ipm_real_t f[IPM_LANES];
  ipm_sr_av(j, vr, adv);
  for (l = 0; l < IPM_LANES; ++l) {
    f[l] = REAL_0;
  }
  for (l = 0; l < IPM_LANES; ++l) {
    const int i = j + l;
    const ipm_real_t t1 = IPM_SR.t1[i];
    const ipm_real_t l1 = IPM_SR.l1[i];
    const ipm_real_t t2 = IPM_SR.t2[i];
    const ipm_real_t l2 = IPM_SR.l2[i];
    const ipm_real_t it1 = IPM_SR.it1[i];
    const ipm_real_t it2 = IPM_SR.it2[i];
    const ipm_real_t e = IPM_SR.e[i];
    const ipm_real_t bb = IPM_SR.bb[i];
    const ipm_real_t rp1 = IPM_SR.rp1[i];
    const ipm_real_t rp2 = IPM_SR.rp2[i];
    const ipm_real_t c = IPM_SR.c[i];
    const ipm_real_t id = IPM_SR.id[i];
    const ipm_real_t w = IPM_SR_W(i);
    const ipm_real_t rc1 = (corr != 0) ? (((t1 * l1) + (IPM_SR.dt1[i] * IPM_SR.dl1[i])) - sm) : (t1 * l1);
    const ipm_real_t rc2 = (corr != 0) ? (((t2 * l2) + (IPM_SR.dt2[i] * IPM_SR.dl2[i])) - sm) : (t2 * l2);
    const ipm_real_t hs = (corr != 0) ? (IPM_SR.hs[i] - (sm * ((e * it1) + (bb * it2)))) : IPM_SR.hs[i];
    const ipm_real_t ds = (-((c * adv[l]) + hs)) * id;
    const ipm_real_t dt1 = (adv[l] + (e * ds)) + rp1;
    const ipm_real_t dl1 = (-(rc1 + (l1 * dt1))) * it1;
    const ipm_real_t dt2 = (bb * ds) + rp2;
    const ipm_real_t dl2 = (-(rc2 + (l2 * dt2))) * it2;
    const ipm_real_t least =
        ipm_min(ipm_min(t1 + (am * dt1), l1 + (am * dl1)), ipm_min(t2 + (am * dt2), l2 + (am * dl2)));
    IPM_SR.dzs[i] = ds;
    IPM_SR.dt1[i] = dt1;
    IPM_SR.dl1[i] = dl1;
    IPM_SR.dt2[i] = dt2;
    IPM_SR.dl2[i] = dl2;
    mn[l] = ipm_min((w > REAL_0) ? least : IPM_ONE, mn[l]);
    if (corr == 0) {
      const ipm_real_t g1 = (((t1 * l1) + (dt1 * dl1)) + (l1 * rp1)) * it1;
      const ipm_real_t g2 = (((t2 * l2) + (dt2 * dl2)) + (l2 * rp2)) * it2;
      const ipm_real_t hv = (IPM_SR.rds[i] + (e * g1)) + (bb * g2);
      f[l] = g1 - ((c * hv) * id);
      IPM_SR.hs[i] = hv;
      acc[0][l] += w * ((t1 * l1) + (t2 * l2));
      acc[1][l] += w * (((t1 * dl1) + (l1 * dt1)) + ((t2 * dl2) + (l2 * dt2)));
      acc[2][l] += w * ((dt1 * dl1) + (dt2 * dl2));
    }
  }
  if (corr == 0) {
    ipm_sr_forward_sums(j, f, acc); /* written out at IPM_NA (the problem header) */
  }
}

/* the forward sweep's part (stage k, its step dv): the slack's step, both sides' dt, dlam; for the predictor, adds to
 * IPM_W.aff the sums of t lam, t dlam + lam dt and dt dlam (mu_aff for any step length) and sums per run the
 * corrector's right-hand side (IPM_W.srr[1]); returns amax cut to the boundary of their t and lam */
static ipm_real_t ipm_sr_forward(int k, int corr, ipm_real_t sm, const ipm_real_t *dv, ipm_real_t amax) {
  int r;
  int j;
  int l;
  int p;
  ipm_real_t am = amax;
  ipm_real_t acc[3 + IPM_NA][IPM_LANES];
  for (p = 0; p < 3; ++p) {
    for (l = 0; l < IPM_LANES; ++l) {
      acc[p][l] = REAL_0;
    }
  }
  for (r = IPM_SR_RPTR[k]; r < IPM_SR_RPTR[k + 1]; ++r) {
    const int j0 = IPM_SR_RUN_PTR[r];
    const int j1 = IPM_SR_RUN_PTR[r + 1];
    ipm_real_t vr[IPM_NA];
    ipm_real_t mn[IPM_LANES];
    ipm_real_t least = IPM_ONE;
    for (p = 0; p < IPM_NA; ++p) {
      vr[p] = dv[IPM_SR_RUN_V[r][p]];
      for (l = 0; l < IPM_LANES; ++l) {
        acc[3 + p][l] = REAL_0;
      }
    }
    for (l = 0; l < IPM_LANES; ++l) {
      mn[l] = IPM_ONE;
    }
    for (j = j0; j < j1; j += IPM_LANES) {
      ipm_sr_forward_rows(j, corr, sm, am, vr, acc, mn);
    }
    for (p = 0; (p < IPM_NA) && (corr == 0); ++p) {
      ipm_real_t s = REAL_0;
      for (l = 0; l < IPM_LANES; ++l) {
        s += acc[3 + p][l];
      }
      IPM_W.srr[1][r][p] = s;
    }
    for (l = 0; l < IPM_LANES; ++l) {
      least = ipm_min(mn[l], least);
    }
    if (least < REAL_0) { /* rare: the run cuts am; row by row, as one sequential pass would, a division per cut */
      for (j = j0; j < j1; ++j) {
        if (IPM_SR_ROW[j] < 0) {
          continue; /* a padding row */
        }
        if ((IPM_SR.t1[j] + (am * IPM_SR.dt1[j])) < REAL_0) {
          am = (-IPM_SR.t1[j]) / IPM_SR.dt1[j];
        }
        if ((IPM_SR.l1[j] + (am * IPM_SR.dl1[j])) < REAL_0) {
          am = (-IPM_SR.l1[j]) / IPM_SR.dl1[j];
        }
        if ((IPM_SR.t2[j] + (am * IPM_SR.dt2[j])) < REAL_0) {
          am = (-IPM_SR.t2[j]) / IPM_SR.dt2[j];
        }
        if ((IPM_SR.l2[j] + (am * IPM_SR.dl2[j])) < REAL_0) {
          am = (-IPM_SR.l2[j]) / IPM_SR.dl2[j];
        }
      }
    }
  }
  for (l = 0; l < IPM_LANES; ++l) {
    IPM_W.aff[0] += acc[0][l];
    IPM_W.aff[1] += acc[1][l];
    IPM_W.aff[2] += acc[2][l];
  }
  return am;
}
