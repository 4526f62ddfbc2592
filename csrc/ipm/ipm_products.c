/* ---- products with the QP's A but its soft rows, by stage: the dynamics and init rows (the [F G] kernels: a
 * dynamics row of stage k is E_i (x_{k+1}[i] - ([F G] v_k)[i]), E_i its x_{k+1}[i] coefficient), the box and general
 * rows, the others with the layout's sparse pattern; and a stage's (x, u) gathered from and scattered into a vector
 * of variables ---- */
/* stage k's (x, u) slots with a variable are IPM_XU_LO[k] .. IPM_XU_HI[k] - 1, on consecutive variables from
 * IPM_XU_V[k] (codegen_context checks): its (x, u) from a vector of variables (0 for a slot without a variable) */
static inline void ipm_gather_xu(int k, const ipm_real_t *x, ipm_real_t *v) {
  int a;
  const int lo = IPM_XU_LO[k];
  const int hi = IPM_XU_HI[k];
  const ipm_real_t *xs = &x[IPM_XU_V[k]];
  if ((lo == 0) && (hi == IPM_NXU)) { /* every slot has a variable (most stages): a copy of a constant length */
    for (a = 0; a < IPM_NXU; ++a) {
      v[a] = xs[a];
    }
    return;
  }
  for (a = 0; a < lo; ++a) {
    v[a] = REAL_0;
  }
  for (; a < hi; ++a) {
    v[a] = xs[a - lo];
  }
  for (; a < IPM_NXU; ++a) {
    v[a] = REAL_0;
  }
}

/* x[variable of slot a] += v[a] (sub: -= v[a]) over stage k's slots with a variable */
static inline void ipm_add_xu(int k, const ipm_real_t *v, ipm_real_t *x, int sub) {
  const int lo = IPM_XU_LO[k];
  const int n = IPM_XU_HI[k] - lo;
  const ipm_real_t *vs = &v[lo];
  ipm_real_t *xs = &x[IPM_XU_V[k]];
  int a;
  if (n == IPM_NXU) { /* every slot has a variable (most stages): a constant length */
    for (a = 0; a < IPM_NXU; ++a) {
      xs[a] = (sub != 0) ? (xs[a] - vs[a]) : (xs[a] + vs[a]);
    }
    return;
  }
  for (a = 0; a < n; ++a) {
    xs[a] = (sub != 0) ? (xs[a] - vs[a]) : (xs[a] + vs[a]);
  }
}

/* x[variable of slot a] = v[a] over stage k's slots with a variable */
static inline void ipm_set_xu(int k, const ipm_real_t *v, ipm_real_t *x) {
  const int lo = IPM_XU_LO[k];
  const int n = IPM_XU_HI[k] - lo;
  const ipm_real_t *vs = &v[lo];
  ipm_real_t *xs = &x[IPM_XU_V[k]];
  int a;
  if (n == IPM_NXU) { /* every slot has a variable (most stages): a constant length */
    for (a = 0; a < IPM_NXU; ++a) {
      xs[a] = vs[a];
    }
    return;
  }
  for (a = 0; a < n; ++a) {
    xs[a] = vs[a];
  }
}

/* a'x on the box and general inequality rows, into out by row (their entries are the generic A's, in its CSR
 * order: codegen_context checks, so each sum is the CSR loop's) */
static void ipm_ineq_Ax(const ipm_real_t *x, ipm_real_t *out) {
  int k;
  int a;
  for (a = 0; a < IPM_NBOX; ++a) {
    out[IPM_BOX_ROW[a]] = IPM_W.bax[a] * x[IPM_BOX_VAR[a]];
  }
  for (k = 0; k <= IPM_N; ++k) {
    IPM_GEN_ROWS(k, ipm_gen_ax(k, x, out), ipm_rows_ax_any(k, x, out));
  }
}

/* A z on the rows but the soft rows, the init and the dynamics rows (their residuals: ipm_eq_residuals) */
static void ipm_Ax(const ipm_real_t *x, ipm_real_t *out) {
  int k;
  int p;
  ipm_ineq_Ax(x, out); /* the generic A's box and general rows; then its others (stage equalities) */
  for (k = 0; k < IPM_NAR_OTHER; ++k) {
    const int r = IPM_AR_OTHER[k];
    ipm_real_t s = REAL_0;
    for (p = IPM_AR_P[r]; p < IPM_AR_P[r + 1]; ++p) {
      s += IPM_W.Ax[IPM_AR_K[p]] * x[IPM_AR_J[p]];
    }
    out[IPM_AR_ROW[r]] = s;
  }
}

/* out = base + A' v over the rows but the soft rows (they add theirs in ipm_sr_check), on the generic variables */
static void ipm_ATx(const ipm_real_t *base, const ipm_real_t *v, ipm_real_t *out) {
  int k;
  int i;
  /* the generic variables by their entries' count (no inner loop for none or one; the sums are the CSC loop's) */
  for (i = 0; i < IPM_NCOL0; ++i) {
    const int j = IPM_A_COL0[i];
    out[j] = base[j] + REAL_0;
  }
  for (i = 0; i < IPM_NCOL1; ++i) {
    const int j = IPM_A_COL1[i];
    out[j] = base[j] + (REAL_0 + (IPM_W.Ax[IPM_A_COL1_K[i]] * v[IPM_A_COL1_I[i]]));
  }
  for (i = 0; i < IPM_NCOLM; ++i) {
    const int j = IPM_A_COLM[i];
    ipm_real_t s = REAL_0;
    for (k = IPM_A_P[j]; k < IPM_A_P[j + 1]; ++k) {
      s += IPM_W.Ax[IPM_A_K[k]] * v[IPM_A_I[k]];
    }
    out[j] = base[j] + s;
  }
  for (i = 0; i < IPM_NX; ++i) {
    out[IPM_VMAP_XU[i]] += IPM_W.einit[i] * v[IPM_INIT_ROWS[i]];
  }
  for (k = 0; k < IPM_N; ++k) { /* E_i v_i on x_{k+1}[i], -[F G]' (E v) on (x_k, u_k) */
    ipm_real_t w[IPM_NX];
    ipm_real_t g[IPM_NXU] = {0};
    if (IPM_XU_LO[k + 1] == 0) { /* as in ipm_Ax: x_{k+1}'s variables and the dynamics rows consecutive */
      ipm_real_t *xn = &out[IPM_XU_V[k + 1]];
      const ipm_idx_t *en = &IPM_DYN_NEXT[k * IPM_NX];
      const ipm_real_t *vr = &v[IPM_DYN_ROWS[k * IPM_NX]];
      for (i = 0; i < IPM_NX; ++i) {
        w[i] = IPM_W.Ax[en[i]] * vr[i];
        xn[i] += w[i];
      }
    } else {
      for (i = 0; i < IPM_NX; ++i) {
        const int r = (k * IPM_NX) + i;
        w[i] = IPM_W.Ax[IPM_DYN_NEXT[r]] * v[IPM_DYN_ROWS[r]];
        out[IPM_VMAP_XU[((k + 1) * IPM_NXU) + i]] += w[i];
      }
    }
    ipm_fg_tdot(IPM_W.fgb[k], w, g);
    ipm_add_xu(k, g, out, 1); /* x - g: the x + (-g) of a negation pass, exactly */
  }
}
