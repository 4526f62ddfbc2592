/* ---- the Newton (KKT) system, stage by stage: its factorization (box weights on the diagonal, each slack eliminated
 * with its rows, the stage equalities by a Schur complement of their own, a Riccati recursion k = N..0) and its
 * solve (the backward sweep's p_k, kk_k; the forward sweep's step) ---- */
/* stage k's Newton block's diagonal += hd of the slot's variable (hs: the first's), 1 for a slot without one */
static void ipm_stage_diag_any(int k, const ipm_real_t *hs) {
  int a;
  for (a = 0; a < IPM_XU_LO[k]; ++a) {
    IPM_W.H[a][a] += IPM_ONE;
  }
  for (; a < IPM_XU_HI[k]; ++a) {
    IPM_W.H[a][a] += hs[a - IPM_XU_LO[k]];
  }
  for (; a < IPM_NXU; ++a) {
    IPM_W.H[a][a] += IPM_ONE;
  }
}

/* stage k's Hessian block IPM_W.H over (x_k, u_k), on and above the diagonal (the factorization reads no other
 * entry): its rows' weights, P + box weights (IPM_W.h), slack couplings (the rows' parts written out at a stage
 * IPM_GEN_PAT flags) */
static void ipm_stage_hessian(int k) {
  if (k < IPM_N) { /* the cost-to-go through the stage's dynamics sets the upper triangle; the rows add to it */
    ipm_fg_ctg(IPM_W.fgb[k], IPM_W.P[k + 1], IPM_W.H);
  } else {
    (void)memset(IPM_W.H, 0, sizeof IPM_W.H);
  }
  IPM_GEN_ROWS(k, ipm_gen_rows_h(k), ipm_rows_h_any(k));
  ipm_sr_hessian(k);
  { /* the diagonal: hd of the slot's variable, 1 for a slot without one */
    const ipm_real_t *hs = &IPM_W.hd[IPM_XU_V[k]];
    if ((IPM_XU_LO[k] == 0) && (IPM_XU_HI[k] == IPM_NXU)) { /* every slot has a variable (most stages) */
      int a;
      for (a = 0; a < IPM_NXU; ++a) {
        IPM_W.H[a][a] += hs[a];
      }
    } else {
      ipm_stage_diag_any(k, hs);
    }
  }
  IPM_GEN_ROWS(k, ipm_gen_couple_h(k), ipm_couple_h_any(k));
}

#if IPM_NE > 0

/* stage k's equalities D u = d: UD = L^-1 D', M = UD' UD (+1 on padded rows), W2 = LM^-1 UD' W1; P_k += W2' W2 */
static int ipm_stage_equalities(int k) {
  int i;
  int j;
  int a;
  int e;
  (void)memset(IPM_W.D, 0, sizeof IPM_W.D);
  for (e = 0; e < IPM_NE; ++e) {
    for (a = IPM_EQ_PTR[(k * IPM_NE) + e]; a < IPM_EQ_PTR[(k * IPM_NE) + e + 1]; ++a) {
      IPM_W.D[e][IPM_EQ_J[a]] = IPM_W.Ax[IPM_EQ_A[a]];
    }
  }
  for (i = 0; i < IPM_NU; ++i) {
    for (e = 0; e < IPM_NE1; ++e) {
      IPM_W.UD[k][i][e] = IPM_W.D[e][i];
    }
  }
  ipm_fwd_u(k, &IPM_W.L[k][0][0], &IPM_W.UD[k][0][0], IPM_NE1, IPM_NE1);
  for (i = 0; i < IPM_NE1; ++i) {
    for (j = 0; j < IPM_NE1; ++j) {
      ipm_real_t v = REAL_0;
      for (a = 0; a < IPM_NU; ++a) {
        v += IPM_W.UD[k][a][i] * IPM_W.UD[k][a][j];
      }
      IPM_W.M[i][j] = v;
    }
    IPM_W.M[i][i] += (IPM_EQ_ROW[(k * IPM_NE1) + i] < 0) ? IPM_ONE : REAL_0;
  }
  if (ipm_chol(&IPM_W.M[0][0], &IPM_W.LM[k][0][0], IPM_NE1, IPM_NE1) != 0) {
    return 1;
  }
  for (i = 0; i < IPM_NE1; ++i) {
    for (j = 0; j < IPM_NX; ++j) {
      ipm_real_t v = REAL_0;
      for (a = 0; a < IPM_NU; ++a) {
        v += IPM_W.UD[k][a][i] * IPM_W.W1[k][a][j];
      }
      IPM_W.W2[i][j] = v;
    }
  }
  ipm_fwd(&IPM_W.LM[k][0][0], IPM_NE1, &IPM_W.W2[0][0], IPM_NE1, IPM_NX, IPM_NX);
  for (i = 0; i < IPM_NX; ++i) { /* on and below the diagonal, as ipm_factor_stage keeps P_k */
    for (j = 0; j <= i; ++j) {
      ipm_real_t v = REAL_0;
      for (a = 0; a < IPM_NE1; ++a) {
        v += IPM_W.W2[a][i] * IPM_W.W2[a][j];
      }
      IPM_W.P[k][i][j] += v;
    }
  }
  return 0;
}

/* tv -= UD M^-1 (UD' tv + base): the stage equalities' part of a step (base: NULL for 0) -> M^-1 (..) in nh */
static void ipm_eq_project(int k, const ipm_real_t *base, ipm_real_t *tv, ipm_real_t *nh) {
  int i;
  int a;
  int e;
  for (e = 0; e < IPM_NE1; ++e) {
    ipm_real_t v = REAL_0;
    for (a = 0; a < IPM_NU; ++a) {
      v += IPM_W.UD[k][a][e] * tv[a];
    }
    nh[e] = (base != NULL) ? (v + base[e]) : v;
  }
  ipm_fwd(&IPM_W.LM[k][0][0], IPM_NE1, nh, IPM_NE1, 1, 1);
  ipm_bwd(&IPM_W.LM[k][0][0], IPM_NE1, nh, IPM_NE1, 1, 1);
  for (i = 0; i < IPM_NU; ++i) {
    ipm_real_t v = REAL_0;
    for (e = 0; e < IPM_NE1; ++e) {
      v += IPM_W.UD[k][i][e] * nh[e];
    }
    tv[i] -= v;
  }
}
#endif

/* the Newton matrix's diagonal hd = P (+ the proximal weight) + the box rows' weights */
static void ipm_hd(void) {
  int i;
  (void)memcpy(IPM_W.hd, IPM_W.Pd, sizeof IPM_W.hd); /* every variable's (the soft rows' slacks' are not read) */
  for (i = 0; i < IPM_NFREE; ++i) {
    IPM_W.hd[IPM_FREE[i]] = IPM_W.Pd[IPM_FREE[i]] + IPM_PROX;
  }
  for (i = 0; i < IPM_NBOX; ++i) {
    const ipm_real_t av = IPM_W.bax[i];
    IPM_W.hd[IPM_BOX_VAR[i]] += IPM_W.wr[IPM_BOX_ROW[i]] * (av * av);
  }
}

/* stage k of the factorization (the Riccati recursion's step from P_{k+1}); 1 if a pivot is not positive */
static int ipm_factor_stage(int k) {
  int i;
  int j;
  IPM_GEN_ROWS(k, ipm_gen_weights(k), ipm_stage_weights_any(k)); /* the rows' weights, the slack pivots */
  ipm_stage_hessian(k);
  /* Q = H[x][x], S = H[u][x], R = H[u][u] (with the cost-to-go through the dynamics) */
  for (i = 0; i < IPM_NU; ++i) { /* R (both triangles: the Cholesky factorization reads the lower one) */
    for (j = i; j < IPM_NU; ++j) {
      IPM_W.R[i][j] = IPM_W.H[IPM_NX + i][IPM_NX + j];
      IPM_W.R[j][i] = IPM_W.R[i][j];
    }
    IPM_W.R[i][i] += IPM_REG;
  }
  if (ipm_chol_u(k, &IPM_W.R[0][0], &IPM_W.L[k][0][0]) != 0) {
    return 1;
  }
  for (i = 0; i < IPM_NU; ++i) {
    for (j = 0; j < IPM_NX; ++j) {
      IPM_W.W1[k][i][j] = IPM_W.H[j][IPM_NX + i];
    }
  }
  ipm_fwd_u(k, &IPM_W.L[k][0][0], &IPM_W.W1[k][0][0], IPM_NX, IPM_NX);
  ipm_pk(IPM_W.H, IPM_W.W1[k], IPM_W.P[k]); /* P_k = H[x][x] - W1' W1: on and below the diagonal (all that is kept
                                              * of it: its readers, ipm_fg_ctg and ipm_mv, read the lower triangle) */
#if IPM_NE > 0
  if (ipm_stage_equalities(k) != 0) {
    return 1;
  }
#endif
  /* every entry of P_k finite? (its lower triangle: the upper one is never written, 0 since qpb_reset) */
  return (isfinite(ipm_pk_nonfinite(IPM_W.P[k])) == 0) ? 1 : 0;
}

/* ---- one Newton direction for the right-hand side IPM_W.h and the equality residuals (ipm_check leaves them in
 * IPM_W.wr) -> IPM_W.dz and, with duals, the equality multipliers' step IPM_W.gd (the predictor needs dz only) ---- */
/* stage k's reduced right-hand side ht (slacks eliminated) and slack right-hand side hs, from IPM_W.h */
static void ipm_stage_rhs(int k, ipm_real_t *ht, ipm_real_t *hs) {
  ipm_gather_xu(k, IPM_W.h, ht);
  IPM_GEN_ROWS(k, ipm_gen_rhs(k, ht, hs), ipm_slacks_rhs_any(k, ht, hs));
}

/* stage k < N's dynamics right-hand side c_k = -r_eq / E: ipm_check leaves it in IPM_W.wr on the stage's dynamics
 * rows (consecutive rows: fg_bands' caller checks) */
static const ipm_real_t *ipm_stage_c(int k) {
  return &IPM_W.wr[IPM_DYN_ROWS[((k < IPM_N) ? k : 0) * IPM_NX]];
}

/* stage k's equality right-hand sides on its stage equality rows: -r_eq */
static void ipm_stage_eq(int k, ipm_real_t *deq) {
#if IPM_NE > 0
  int i;
  for (i = 0; i < IPM_NE1; ++i) {
    const int r = IPM_EQ_ROW[(k * IPM_NE1) + i];
    deq[i] = (r >= 0) ? (-IPM_W.wr[r]) : REAL_0;
  }
#else
  (void)k; /* no stage equalities */
  (void)deq;
#endif
}

/* the backward sweep: p_k, kk_k (and lr_k) for the right-hand side (the soft rows' part for the target ipm_rc);
 * with factor, each stage is factored first (one sweep: the rows' data is read once); 1 if a pivot is not positive */
static int ipm_backward(int corr, ipm_real_t sm, int factor) {
  int k;
  int i;
#if !IPM_U_FUSED
  ipm_real_t tv[IPM_NU];
#endif
  ipm_real_t ht[IPM_NXU];
  ipm_real_t hs[IPM_NS];
  ipm_real_t deq[IPM_NE1];
#if IPM_NE > 0
  ipm_real_t nh[IPM_NE1];
#endif
  for (k = IPM_N; k >= 0; --k) {
    const ipm_real_t *cdyn = ipm_stage_c(k);
    if ((factor != 0) && (ipm_factor_stage(k) != 0)) {
      return 1;
    }
    ipm_stage_rhs(k, ht, hs);
    ipm_sr_rhs(k, corr, sm, ht);
    ipm_stage_eq(k, deq);
    if (k < IPM_N) { /* plus [F G]' (P_{k+1} c_k + p_{k+1}) */
      ipm_real_t pc[IPM_NX];
      /* P_{k+1} c_k is the same for both targets: the factoring sweep keeps it in IPM_W.gd on the stage's dynamics
       * rows (free until the corrector's forward sweep writes the multipliers' step there), the other reads it */
      ipm_real_t *pcs = &IPM_W.gd[IPM_DYN_ROWS[k * IPM_NX]];
      if (factor != 0) {
        ipm_mv_add(IPM_W.P[k + 1], cdyn, IPM_W.p[k + 1], pcs, pc);
      } else {
        for (i = 0; i < IPM_NX; ++i) {
          pc[i] = pcs[i] + IPM_W.p[k + 1][i];
        }
      }
      ipm_fg_tdot(IPM_W.fgb[k], pc, ht);
    }
#if IPM_U_FUSED
    ipm_u_rhs(&IPM_W.L[k][0][0], IPM_W.W1[k], ht, IPM_W.p[k], IPM_W.kk[k]); /* the steps below in one kernel */
#else
    for (i = 0; i < IPM_NU; ++i) {
      IPM_W.lr[k][i] = ht[IPM_NX + i];
    }
    ipm_fwd_u(k, &IPM_W.L[k][0][0], IPM_W.lr[k], 1, 1);
    for (i = 0; i < IPM_NU; ++i) {
      tv[i] = IPM_W.lr[k][i];
    }
#if IPM_NE > 0
    ipm_eq_project(k, deq, tv, nh);
#endif
    ipm_q_wtx(IPM_W.W1[k], tv, ht, IPM_W.p[k]); /* p_k = q_bar - W1' tv (ht's first NX entries: q_bar) */
    ipm_bwd_u_sub(k, &IPM_W.L[k][0][0], tv, NULL, IPM_W.kk[k]); /* kk_k = -L^-T tv */
#endif
  }
  return 0;
}

/* stage k's primal step dv = (dx, du) (dz of its slacks and variables) and, with duals, its equality rows' duals */
static void ipm_forward_stage(int k, int duals, const ipm_real_t *dx, const ipm_real_t *deq, ipm_real_t *dv) {
  int i;
  int s;
#if !IPM_U_FUSED
  ipm_real_t tv[IPM_NU];
#endif
  ipm_real_t hs[IPM_NS];
#if IPM_NE > 0
  ipm_real_t nh[IPM_NE1];
#else
  (void)deq; /* no stage equalities */
#endif
  for (s = 0; s < IPM_NS; ++s) {
    const int v = IPM_VMAP_S[k][s];
    hs[s] = (v >= 0) ? IPM_W.h[v] : REAL_0;
  }
  /* du = K dx + kk with K = -L^-T (W1 - UD M^-1 UD' W1) */
  for (i = 0; i < IPM_NX; ++i) {
    dv[i] = dx[i];
  }
#if IPM_U_FUSED
  ipm_u_du(&IPM_W.L[k][0][0], IPM_W.W1[k], dx, IPM_W.kk[k], &dv[IPM_NX]);
#else
  ipm_wx(IPM_W.W1[k], dx, tv);
#if IPM_NE > 0
  ipm_eq_project(k, NULL, tv, nh);
#endif
  ipm_bwd_u_sub(k, &IPM_W.L[k][0][0], tv, IPM_W.kk[k], &dv[IPM_NX]); /* du = kk_k - L^-T tv */
#endif
  if (duals != 0) { /* the equality rows' multiplier step: -(P_k dx + p_k), scaled */
    ipm_real_t pd[IPM_NX];
    ipm_mv(IPM_W.P[k], dx, pd);
    if (k == 0) {
      for (i = 0; i < IPM_NX; ++i) {
        IPM_W.gd[IPM_INIT_ROWS[i]] = (-(pd[i] + IPM_W.p[k][i])) / IPM_W.einit[i];
      }
    } else { /* the stage's dynamics rows are consecutive (ipm_stage_c) */
      ipm_real_t *gd = &IPM_W.gd[IPM_DYN_ROWS[(k - 1) * IPM_NX]];
      for (i = 0; i < IPM_NX; ++i) {
        gd[i] = (-(pd[i] + IPM_W.p[k][i])) * IPM_W.Einv[k - 1][i];
      }
    }
#if IPM_NE > 0
    { /* and the stage equality rows' */
      int e;
      ipm_real_t wl[IPM_NU];
      ipm_wx(IPM_W.W1[k], dx, wl);
      for (i = 0; i < IPM_NU; ++i) {
        wl[i] += IPM_W.lr[k][i];
      }
      ipm_eq_project(k, deq, wl, nh);
      for (e = 0; e < IPM_NE1; ++e) {
        const int r = IPM_EQ_ROW[(k * IPM_NE1) + e];
        if (r >= 0) {
          IPM_W.gd[r] = -nh[e];
        }
      }
    }
#endif
  }
  IPM_GEN_ROWS(k, ipm_gen_dz(k, dv, hs), ipm_slacks_dz_any(k, dv, hs));
  ipm_set_xu(k, dv, IPM_W.dz);
}

/* the forward sweep of the Newton step for the target ipm_rc (corr, sm), after ipm_backward: dz, the soft rows'
 * dt, dlam (and the sums of IPM_W.aff); with the corrector (corr) the equality multipliers' step too; returns the
 * soft rows' largest step to the boundary (at most 1) */
static ipm_real_t ipm_forward(int corr, ipm_real_t sm) {
  int k;
  int i;
  ipm_real_t amax = IPM_ONE;
  ipm_real_t dx[IPM_NX];
  ipm_real_t dv[IPM_NXU];
  ipm_real_t deq[IPM_NE1];
  IPM_W.aff[0] = REAL_0;
  IPM_W.aff[1] = REAL_0;
  IPM_W.aff[2] = REAL_0;
  for (i = 0; i < IPM_NX; ++i) {
    dx[i] = (-IPM_W.wr[IPM_INIT_ROWS[i]]) / IPM_W.einit[i];
  }
  for (k = 0; k <= IPM_N; ++k) {
    const ipm_real_t *cdyn = ipm_stage_c(k);
    ipm_stage_eq(k, deq);
    ipm_forward_stage(k, corr, dx, deq, dv);
    amax = ipm_sr_forward(k, corr, sm, dv, amax);
    if (k < IPM_N) { /* dx_{k+1} = [F G] dv + c */
      for (i = 0; i < IPM_NX; ++i) {
        dx[i] = cdyn[i];
      }
      ipm_fg_axpy(IPM_W.fgb[k], dv, dx);
    }
  }
  return amax;
}
