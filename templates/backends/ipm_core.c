/* ---- fcgen's Riccati interior-point QP backend: the algorithm (plain C99, the same for every problem) ------------
 * Mehrotra predictor-corrector on the layout's QP; the Newton system is solved stage by stage: box rows on the
 * diagonal, each slack eliminated with its rows, a Riccati recursion over (x_k, u_k). The Python reference is
 * fcgen/backends/ipm.py (same algorithm, same order of operations).
 *
 * Not a template: what varies per problem (every size as a macro IPM_*, the index tables of the stage view, the
 * workspace struct IPM_W, the real type ipm_real_t, IPM_SQRT / IPM_FABS of that type, the raw-to-generic status
 * map IPM_STATUS) comes from the problem header fcgen renders (templates/backends/ipm_problem.h.j2), included
 * before this file. It also needs from its includer <string.h>, <math.h>, REAL_0 (zero of the real type) and
 * qpb_result_t (the RTI core's view of a solve: status, raw_status, iter, z, y) and QPB_PROBE(event) (a timing probe,
 * nothing in a normal build). The generated <name>_solver.c
 * contains the problem header and this file, in that order; tests/c/ipm_core_test.c compiles it on its own with a
 * rendered header.
 * It defines the backend interface qpb_reset, qpb_set_matrices and qpb_solve (static). */

/* 0 times each of v[0 .. n - 1], summed in four independent chains: NaN once one is not finite (a finiteness test
 * whose adds overlap instead of waiting on each other) */
static ipm_real_t ipm_nonfinite(const ipm_real_t *v, int n) {
  ipm_real_t s0 = REAL_0;
  ipm_real_t s1 = REAL_0;
  ipm_real_t s2 = REAL_0;
  ipm_real_t s3 = REAL_0;
  int i;
  for (i = 0; (i + 3) < n; i += 4) {
    s0 += v[i] * REAL_0;
    s1 += v[i + 1] * REAL_0;
    s2 += v[i + 2] * REAL_0;
    s3 += v[i + 3] * REAL_0;
  }
  for (; i < n; ++i) {
    s0 += v[i] * REAL_0;
  }
  return (s0 + s1) + (s2 + s3);
}

/* ---- small dense kernels (row-major, fixed sizes): for the input blocks (where not written out: IPM_U_DENSE) and
 * the stage equalities ---- */
#if (IPM_U_DENSE == 0) || (IPM_NE > 0)
/* lower Cholesky factor of the n x n matrix A (stride ld) into Lo; 1 if a pivot is not positive */
static int ipm_chol(const ipm_real_t *A, ipm_real_t *Lo, int n, int ld) {
  int i;
  int j;
  int k;
  for (j = 0; j < n; ++j) {
    ipm_real_t s = A[(j * ld) + j];
    for (k = 0; k < j; ++k) {
      s -= Lo[(j * ld) + k] * Lo[(j * ld) + k];
    }
    if (!(s > REAL_0)) {
      return 1;
    }
    s = IPM_SQRT(s);
    Lo[(j * ld) + j] = s;
    for (i = j + 1; i < n; ++i) {
      ipm_real_t v = A[(i * ld) + j];
      for (k = 0; k < j; ++k) {
        v -= Lo[(i * ld) + k] * Lo[(j * ld) + k];
      }
      Lo[(i * ld) + j] = v / s;
    }
    for (i = 0; i < j; ++i) {
      Lo[(i * ld) + j] = REAL_0;
    }
  }
  return 0;
}

/* X := Lo^-1 X (n x m, strides ldl, ldx): row i of X less Lo[i][j] times row j (j < i), over X's contiguous rows */
static void ipm_fwd(const ipm_real_t *Lo, int ldl, ipm_real_t *X, int n, int m, int ldx) {
  int i;
  int j;
  int c;
  for (i = 0; i < n; ++i) {
    const ipm_real_t d = IPM_ONE / Lo[(i * ldl) + i];
    for (j = 0; j < i; ++j) {
      const ipm_real_t lij = Lo[(i * ldl) + j];
      for (c = 0; c < m; ++c) {
        X[(i * ldx) + c] -= lij * X[(j * ldx) + c];
      }
    }
    for (c = 0; c < m; ++c) {
      X[(i * ldx) + c] *= d;
    }
  }
}

/* X := Lo^-T X */
static void ipm_bwd(const ipm_real_t *Lo, int ldl, ipm_real_t *X, int n, int m, int ldx) {
  int i;
  int j;
  int c;
  for (i = n - 1; i >= 0; --i) {
    for (c = 0; c < m; ++c) {
      ipm_real_t s = REAL_0;
      for (j = i + 1; j < n; ++j) {
        s += Lo[(j * ldl) + i] * X[(j * ldx) + c];
      }
      X[(i * ldx) + c] = (X[(i * ldx) + c] - s) / Lo[(i * ldl) + i];
    }
  }
}
#endif

/* ---- stage k's R_bar is block diagonal over its input blocks IPM_UB[k] (inputs IPM_UB[k][b] .. IPM_UB[k][b + 1] - 1:
 * e.g. the controls, then each opponent's hyperplane variables): its factor L, every solve with it, block by block */
static int ipm_chol_u(int k, const ipm_real_t *A, ipm_real_t *Lo) {
#if IPM_U_DENSE
  (void)k; /* all inputs at once, written out in the problem header (IPM_UB's blocks come out exactly) */
  return ipm_chol_nu(A, Lo);
#else
  int b;
  for (b = 0; b < IPM_NUB; ++b) {
    const int o = IPM_UB[k][b];
    if (ipm_chol(&A[(o * IPM_NU) + o], &Lo[(o * IPM_NU) + o], IPM_UB[k][b + 1] - o, IPM_NU) != 0) {
      return 1;
    }
  }
  return 0;
#endif
}

/* X := L_k^-1 X (NU x m, stride ldx) */
static void ipm_fwd_u(int k, const ipm_real_t *Lo, ipm_real_t *X, int m, int ldx) {
#if IPM_U_DENSE
  (void)k;
  ipm_fwd_nu(Lo, X, m, ldx);
#else
  int b;
  for (b = 0; b < IPM_NUB; ++b) {
    const int o = IPM_UB[k][b];
    ipm_fwd(&Lo[(o * IPM_NU) + o], IPM_NU, &X[o * ldx], IPM_UB[k][b + 1] - o, m, ldx);
  }
#endif
}

#if !IPM_U_FUSED
/* out := base - L_k^-T x, or -L_k^-T x without base (NULL); x may be overwritten. Written out (IPM_U_DENSE), the
 * result goes from registers to out: a loop over a copy would read back values just stored */
static void ipm_bwd_u_sub(int k, const ipm_real_t *Lo, ipm_real_t *x, const ipm_real_t *base, ipm_real_t *out) {
#if IPM_U_DENSE
  (void)k;
  ipm_bwd_nu_sub(Lo, x, base, out);
#else
  int b;
  int i;
  for (b = 0; b < IPM_NUB; ++b) {
    const int o = IPM_UB[k][b];
    ipm_bwd(&Lo[(o * IPM_NU) + o], IPM_NU, &x[o], IPM_UB[k][b + 1] - o, 1, 1);
  }
  for (i = 0; i < IPM_NU; ++i) {
    out[i] = (base != NULL) ? (base[i] - x[i]) : (-x[i]);
  }
#endif
}
#endif

/* ---- products with A but its soft rows: the dynamics and init rows by stage (the [F G] kernels: a dynamics row of
 * stage k is E_i (x_{k+1}[i] - ([F G] v_k)[i]), E_i its x_{k+1}[i] coefficient), the others with the layout's
 * sparse pattern ---- */
/* stage k's (x, u) slots with a variable are IPM_XU_LO[k] .. IPM_XU_HI[k] - 1, on consecutive variables from
 * IPM_XU_V[k] (codegen_context checks): its (x, u) from a vector of variables (0 for a slot without a variable) */
static inline void ipm_gather_xu(int k, const ipm_real_t *x, ipm_real_t *v) {
  int a;
  const int lo = IPM_XU_LO[k];
  const int hi = IPM_XU_HI[k];
  const ipm_real_t *xs = &x[IPM_XU_V[k]];
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
  for (a = 0; a < n; ++a) {
    xs[a] = vs[a];
  }
}

/* a'x on the box and general inequality rows, into out by row (their entries are the generic A's, in its CSR
 * order: codegen_context checks, so each sum is the CSR loop's) */
static void ipm_ineq_Ax(const ipm_real_t *x, ipm_real_t *out) {
  int k;
  int g;
  int a;
  for (a = 0; a < IPM_NBOX; ++a) {
    out[IPM_BOX_ROW[a]] = IPM_W.bax[a] * x[IPM_BOX_VAR[a]];
  }
  for (k = 0; k <= IPM_N; ++k) {
#if IPM_GEN_WRITTEN
    if (IPM_GEN_PAT[k] != 0) { /* the stage's rows written out */
      ipm_gen_ax(k, x, out);
      continue;
    }
#endif
    for (g = 0; g < IPM_NG; ++g) {
      const int gs = (k * IPM_NG) + g;
      ipm_real_t s = REAL_0;
      if (IPM_GEN_ROW[gs] < 0) {
        continue;
      }
      for (a = IPM_GEN_PTR[gs]; a < IPM_GEN_PTR[gs + 1]; ++a) {
        s += IPM_W.gax[a] * x[IPM_GEN_VAR[a]];
      }
      if (IPM_GEN_E[gs] >= 0) {
        s += IPM_W.gex[gs] * x[IPM_GEN_SVAR[gs]];
      }
      out[IPM_GEN_ROW[gs]] = s;
    }
  }
}

/* A z on the rows but the soft rows */
static void ipm_Ax(const ipm_real_t *x, ipm_real_t *out) {
  int i;
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
  for (i = 0; i < IPM_NX; ++i) {
    out[IPM_INIT_ROWS[i]] = IPM_W.einit[i] * x[IPM_VMAP_XU[i]];
  }
  for (k = 0; k < IPM_N; ++k) {
    ipm_real_t v[IPM_NXU];
    ipm_real_t f[IPM_NX] = {0};
    ipm_gather_xu(k, x, v);
    ipm_fg_axpy(IPM_W.fgb[k], v, f);
    for (i = 0; i < IPM_NX; ++i) {
      const int r = (k * IPM_NX) + i;
      out[IPM_DYN_ROWS[r]] = IPM_W.Ax[IPM_DYN_NEXT[r]] * (x[IPM_VMAP_XU[((k + 1) * IPM_NXU) + i]] - f[i]);
    }
  }
}

/* out = base + A' v over the rows of ipm_Ax (the soft rows add theirs in ipm_sr_check), on the generic variables */
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
    for (i = 0; i < IPM_NX; ++i) {
      const int r = (k * IPM_NX) + i;
      w[i] = IPM_W.Ax[IPM_DYN_NEXT[r]] * v[IPM_DYN_ROWS[r]];
      out[IPM_VMAP_XU[((k + 1) * IPM_NXU) + i]] += w[i];
    }
    ipm_fg_tdot(IPM_W.fgb[k], w, g);
    ipm_add_xu(k, g, out, 1); /* x - g: the x + (-g) of a negation pass, exactly */
  }
}

/* ---- the soft rows (IPM_SR_*): soft row j's side t1 = a'v + e s - b1 and its slack's bound t2 = bb s - b2 (the
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

/* the larger of v and m (m if v is NaN: a NaN never replaces a maximum) */
static inline ipm_real_t ipm_max(ipm_real_t v, ipm_real_t m) {
  return (v > m) ? v : m;
}

/* the smaller of v and m (m if v is NaN). Where the FPU has VMINNM (FPv5, the Cortex-M7's: ARMv7E-M with a double
 * FPU) fmin is that one instruction instead of a compare and a conditional move. They differ only where m is a NaN:
 * in the soft rows' step limits (the only use) a NaN comes from a non-finite t, lam or step, which the next check
 * finds either way (its sum of t lam is not finite) */
#if defined(__ARM_ARCH_7EM__) && defined(__ARM_FP)
#if ((__ARM_FP & 8) != 0)
#define IPM_MINNM 1
#endif
#endif
static inline ipm_real_t ipm_min(ipm_real_t v, ipm_real_t m) {
#if defined(IPM_MINNM)
  return IPM_FMIN(v, m);
#else
  return (v < m) ? v : m;
#endif
}

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
    const ipm_real_t least = ipm_min(ipm_min(t1 + (am * dt1), l1 + (am * dl1)), ipm_min(t2 + (am * dt2), l2 + (am * dl2)));
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
  int g;
  int a;
  (void)memcpy(IPM_W.h, IPM_W.r_d, sizeof IPM_W.h); /* the soft rows' slacks' entries are not read */
  if (corr != 0) { /* flat over the sides (measured: cheaper on the Cortex-M7 than by rows) */
    int j;
    for (j = 0; j < IPM_NSIDE; ++j) {
      const int r = IPM_SIDE_ROW[j];
      IPM_W.ar[r] = ((IPM_SIDE_2ND[j] != 0) ? IPM_W.ar[r] : REAL_0) + ipm_side_g(j, IPM_SIDE_SG[j], ipm_rc(1, sm, j));
    }
  }
  for (k = 0; k <= IPM_N; ++k) {
#if IPM_GEN_WRITTEN
    if (IPM_GEN_PAT[k] != 0) { /* the stage's rows written out */
      ipm_gen_atx(k);
      continue;
    }
#endif
    for (g = 0; g < IPM_NG; ++g) {
      const int gs = (k * IPM_NG) + g;
      ipm_real_t gv;
      if (IPM_GEN_ROW[gs] < 0) {
        continue;
      }
      gv = IPM_W.ar[IPM_GEN_ROW[gs]];
      for (a = IPM_GEN_PTR[gs]; a < IPM_GEN_PTR[gs + 1]; ++a) {
        IPM_W.h[IPM_GEN_VAR[a]] += IPM_W.gax[a] * gv;
      }
      if (IPM_GEN_E[gs] >= 0) {
        IPM_W.h[IPM_GEN_SVAR[gs]] += IPM_W.gex[gs] * gv;
      }
    }
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
 * pass over the sides, written once per target); returns the largest step to the boundary (at most amax0) */
static ipm_real_t ipm_ineq_sides(int corr, ipm_real_t sm, ipm_real_t amax0) {
  int j;
  ipm_real_t amax = amax0;
  ipm_ineq_Ax(IPM_W.dz, IPM_W.ar);
  if (corr != 0) { /* flat over the sides (measured: cheaper here than by rows) */
    for (j = 0; j < IPM_NSIDE; ++j) {
      amax = ipm_side_step(j, IPM_SIDE_SG[j], IPM_W.ar[IPM_SIDE_ROW[j]], ipm_rc(1, sm, j), amax);
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

/* slack s of stage k: its rows' general slots IPM_SG_G[p], p = IPM_SG_BEG[k][s] .. IPM_SG_END[k][s] - 1 */
#define IPM_SG0(k, s) IPM_SG_BEG[k][s]
#define IPM_SG1(k, s) IPM_SG_END[k][s]
#define IPM_GSLOT(k, g) (((k) * IPM_NG) + (g))

/* stage k's row weights: W e of its general slots (IPM_W.wg, 0 without a slack), the effective weights IPM_W.Weff
 * (a slack's rows weigh W_i (hd_s + sum_{j != i} W_j e_j^2) / d_s) and the slack pivots IPM_W.d[k]; the generic
 * loops (a stage IPM_GEN_PAT flags: ipm_gen_weights, written out) */
static void ipm_stage_weights_any(int k) {
  int g;
  int s;
  int p;
  int q;
  int c = IPM_SE_BEG[k][0]; /* the next entry of IPM_W.wc */
  for (g = 0; g < IPM_NG; ++g) {
    const int gs = IPM_GSLOT(k, g);
    const int r = IPM_GEN_ROW[gs];
    IPM_W.Weff[g] = (r >= 0) ? IPM_W.wr[r] : REAL_0;
    IPM_W.wg[gs] = (IPM_GEN_E[gs] >= 0) ? (IPM_W.wr[r] * IPM_W.gex[gs]) : REAL_0;
  }
  for (s = 0; s < IPM_NS; ++s) {
    const int vs = IPM_VMAP_S[k][s];
    const ipm_real_t hs = (vs >= 0) ? IPM_W.hd[vs] : IPM_ONE;
    ipm_real_t dd = hs;
    for (p = IPM_SG0(k, s); p < IPM_SG1(k, s); ++p) {
      const int gs = IPM_GSLOT(k, IPM_SG_G[p]);
      dd += IPM_W.wg[gs] * IPM_W.gex[gs];
    }
    IPM_W.d[k][s] = dd;
    if ((IPM_SG1(k, s) - IPM_SG0(k, s)) == 1) { /* one row (the common case): it weighs W hd_s / d_s */
      const int gs = IPM_GSLOT(k, IPM_SG_G[IPM_SG0(k, s)]);
      int a;
      for (a = IPM_GEN_PTR[gs]; a < IPM_GEN_PTR[gs + 1]; ++a) {
        IPM_W.wc[c] = IPM_W.wg[gs] * IPM_W.gax[a];
        ++c;
      }
      IPM_W.Weff[IPM_SG_G[IPM_SG0(k, s)]] = (IPM_W.wr[IPM_GEN_ROW[gs]] * hs) / dd;
      continue;
    }
    for (p = IPM_SG0(k, s); p < IPM_SG1(k, s); ++p) { /* W e a of the rows' entries, in IPM_SE order */
      const int gs = IPM_GSLOT(k, IPM_SG_G[p]);
      int a;
      for (a = IPM_GEN_PTR[gs]; a < IPM_GEN_PTR[gs + 1]; ++a) {
        IPM_W.wc[c] = IPM_W.wg[gs] * IPM_W.gax[a];
        ++c;
      }
    }
    for (p = IPM_SG0(k, s); p < IPM_SG1(k, s); ++p) {
      ipm_real_t others = hs;
      for (q = IPM_SG0(k, s); q < IPM_SG1(k, s); ++q) {
        if (q != p) {
          const int gq = IPM_GSLOT(k, IPM_SG_G[q]);
          others += IPM_W.wg[gq] * IPM_W.gex[gq];
        }
      }
      IPM_W.Weff[IPM_SG_G[p]] = (IPM_W.wr[IPM_GEN_ROW[IPM_GSLOT(k, IPM_SG_G[p])]] * others) / dd;
    }
  }
}

static void ipm_stage_weights(int k) {
#if IPM_GEN_WRITTEN
  if (IPM_GEN_PAT[k] != 0) {
    ipm_gen_weights(k);
  } else {
    ipm_stage_weights_any(k);
  }
#else
  ipm_stage_weights_any(k);
#endif
}

/* stage k's rows' W c c' into IPM_W.H (a row's slots ascend): the generic loops */
static void ipm_rows_h_any(int k) {
  int g;
  int a;
  int b;
  for (g = 0; g < IPM_NG; ++g) {
    const int gs = IPM_GSLOT(k, g);
    for (a = IPM_GEN_PTR[gs]; a < IPM_GEN_PTR[gs + 1]; ++a) {
      const ipm_real_t ca = IPM_W.Weff[g] * IPM_W.gax[a];
      for (b = a; b < IPM_GEN_PTR[gs + 1]; ++b) {
        IPM_W.H[IPM_GEN_V[a]][IPM_GEN_V[b]] += ca * IPM_W.gax[b];
      }
    }
  }
}

/* two rows of one slack couple by -W_i e_i W_j e_j / d_s (m c_i c_j' + its transpose): the generic loops */
static void ipm_couple_h_any(int k) {
  int s;
  int p;
  int q;
  for (s = 0; s < IPM_NS; ++s) {
    if ((IPM_SG1(k, s) - IPM_SG0(k, s)) < 2) {
      continue; /* one row or none: no coupling */
    }
    for (p = IPM_SG0(k, s); p < IPM_SG1(k, s); ++p) {
      for (q = p + 1; q < IPM_SG1(k, s); ++q) {
        const int gi = IPM_GSLOT(k, IPM_SG_G[p]);
        const int gj = IPM_GSLOT(k, IPM_SG_G[q]);
        const ipm_real_t mij = ((-IPM_W.wg[gi]) * IPM_W.wg[gj]) / IPM_W.d[k][s];
        int x;
        int y;
        for (x = IPM_GEN_PTR[gi]; x < IPM_GEN_PTR[gi + 1]; ++x) {
          const ipm_real_t cx = mij * IPM_W.gax[x];
          for (y = IPM_GEN_PTR[gj]; y < IPM_GEN_PTR[gj + 1]; ++y) {
            const int vx = IPM_GEN_V[x];
            const int vy = IPM_GEN_V[y];
            const int lo = (vx < vy) ? vx : vy;
            const int hi = (vx < vy) ? vy : vx;
            const ipm_real_t v = cx * IPM_W.gax[y];
            IPM_W.H[lo][hi] += v;
            if (lo == hi) {
              IPM_W.H[lo][hi] += v; /* the transpose's term on the diagonal */
            }
          }
        }
      }
    }
  }
}

/* stage k's Hessian block IPM_W.H over (x_k, u_k), on and above the diagonal (the factorization reads no other
 * entry): its rows' weights, P + box weights (IPM_W.h), slack couplings (the rows' parts written out at a stage
 * IPM_GEN_PAT flags) */
static void ipm_stage_hessian(int k) {
  int a;
  if (k < IPM_N) { /* the cost-to-go through the stage's dynamics sets the upper triangle; the rows add to it */
    ipm_fg_ctg(IPM_W.fgb[k], IPM_W.P[k + 1], IPM_W.H);
  } else {
    (void)memset(IPM_W.H, 0, sizeof IPM_W.H);
  }
#if IPM_GEN_WRITTEN
  if (IPM_GEN_PAT[k] != 0) {
    ipm_gen_rows_h(k);
  } else {
    ipm_rows_h_any(k);
  }
#else
  ipm_rows_h_any(k);
#endif
  ipm_sr_hessian(k);
  { /* the diagonal: hd of the slot's variable, 1 for a slot without one */
    const ipm_real_t *hs = &IPM_W.hd[IPM_XU_V[k]];
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
#if IPM_GEN_WRITTEN
  if (IPM_GEN_PAT[k] != 0) {
    ipm_gen_couple_h(k);
  } else {
    ipm_couple_h_any(k);
  }
#else
  ipm_couple_h_any(k);
#endif
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

/* ---- the Newton matrix: box weights, slack groups, Riccati recursion (k = N..0) ---- */
/* its diagonal hd = P (+ the proximal weight) + the box rows' weights */
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
  ipm_stage_weights(k);
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
  /* every entry of P_k finite? (its upper triangle is never written: 0 since qpb_reset) */
  return (isfinite(ipm_nonfinite(&IPM_W.P[k][0][0], IPM_NX * IPM_NX)) == 0) ? 1 : 0;
}

/* ---- one Newton direction for the right-hand side IPM_W.h and the equality residuals IPM_W.r_eq -> IPM_W.dz and,
 * with duals, the equality multipliers' step IPM_W.dnu (the predictor needs dz only) ---- */
/* stage k's reduced right-hand side ht (slacks eliminated) and slack right-hand side hs, from IPM_W.h */
/* its slacks' part, the generic loops: hs, and the slacks eliminated from ht */
static void ipm_slacks_rhs_any(int k, ipm_real_t *ht, ipm_real_t *hs) {
  int s;
  int p;
  for (s = 0; s < IPM_NS; ++s) {
    const int v = IPM_VMAP_S[k][s];
    ipm_real_t f;
    hs[s] = (v >= 0) ? IPM_W.h[v] : REAL_0;
    f = hs[s] / IPM_W.d[k][s];
    for (p = IPM_SE_BEG[k][s]; p < IPM_SE_END[k][s]; ++p) {
      ht[IPM_SE_V[p]] -= IPM_W.wc[p] * f;
    }
  }
}

static void ipm_stage_rhs(int k, ipm_real_t *ht, ipm_real_t *hs) {
  ipm_gather_xu(k, IPM_W.h, ht);
#if IPM_GEN_WRITTEN
  if (IPM_GEN_PAT[k] != 0) {
    ipm_gen_rhs(k, ht, hs);
  } else {
    ipm_slacks_rhs_any(k, ht, hs);
  }
#else
  ipm_slacks_rhs_any(k, ht, hs);
#endif
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

/* stage k's slacks' step from its (x, u) step dv and slack right-hand sides hs, the generic loops */
static void ipm_slacks_dz_any(int k, const ipm_real_t *dv, const ipm_real_t *hs) {
  int s;
  int p;
  for (s = 0; s < IPM_NS; ++s) {
    const int v = IPM_VMAP_S[k][s];
    ipm_real_t acc = REAL_0;
    for (p = IPM_SE_BEG[k][s]; p < IPM_SE_END[k][s]; ++p) {
      acc += IPM_W.wc[p] * dv[IPM_SE_V[p]];
    }
    if (v >= 0) {
      IPM_W.dz[v] = (-(acc + hs[s])) / IPM_W.d[k][s];
    }
  }
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
    for (i = 0; i < IPM_NX; ++i) {
      const ipm_real_t v = pd[i] + IPM_W.p[k][i];
      if (k == 0) {
        IPM_W.gd[IPM_INIT_ROWS[i]] = (-v) / IPM_W.einit[i];
      } else {
        IPM_W.gd[IPM_DYN_ROWS[((k - 1) * IPM_NX) + i]] = (-v) * IPM_W.Einv[k - 1][i];
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
#if IPM_GEN_WRITTEN
  if (IPM_GEN_PAT[k] != 0) {
    ipm_gen_dz(k, dv, hs);
  } else {
    ipm_slacks_dz_any(k, dv, hs);
  }
#else
  ipm_slacks_dz_any(k, dv, hs);
#endif
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

/* direction for the complementarity target ipm_rc -> IPM_W.dz, IPM_W.dt, IPM_W.dlam (and the equality duals' step
 * in IPM_W.gd); with factor, the Newton matrix is factored in the same backward sweep. The largest step to the
 * boundary (at most 1) in *amax; 1 if a pivot is not positive */
static int ipm_direction(int corr, ipm_real_t sm, int factor, ipm_real_t *amax) {
  ipm_ineq_ATx(corr, sm);
  if (ipm_backward(corr, sm, factor) != 0) {
    return 1;
  }
  *amax = ipm_ineq_sides(corr, sm, ipm_forward(corr, sm));
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

/* residuals and the stopping tests of the current iterate: IPM_GOING, or the raw status it stops with; mu */
static int ipm_check(const ipm_real_t *q, const ipm_real_t *l, ipm_real_t *mu_out) {
  int i;
  int j;
  int k;
  int raw = IPM_GOING;
  ipm_real_t mu;
  ipm_real_t rmax;
  ipm_real_t lmax;
  ipm_real_t acc[3] = {REAL_0, REAL_0, REAL_0};
  const ipm_real_t alpha = IPM_W.aff[3]; /* the last step's length (0: none), taken here */
  for (j = 0; j < IPM_NSIDE; ++j) {
    IPM_W.t[j] += alpha * IPM_W.dt[j];
    IPM_W.lam[j] += alpha * IPM_W.dlam[j];
  }
  for (j = 0; j < IPM_NV; ++j) { /* every variable: the soft rows' slacks' entries (dz = 0) are not read */
    IPM_W.z[j] += alpha * IPM_W.dz[j];
    IPM_W.h[j] = (IPM_W.Pd[j] * IPM_W.z[j]) + q[j];
  }
  ipm_Ax(IPM_W.z, IPM_W.wr); /* A z: residuals on the equality rows, then the weights on the others */
  /* per inequality row, over its sides: its y (as ipm_compose_y), each side's r_p, t lam, lam; and for the step
   * ipm_step may take, 1 / t, the row's weight W = sum lam / t (in IPM_W.wr, over its A z once read) and its
   * predictor's right-hand side g (ipm_side_g of ipm_rc(0): the pass ipm_ineq_ATx would make, fused here). A row's
   * two sides are a lower and an upper one (IPM_IN_TWO): their signs are constants, the row's sums stay in registers */
  j = 0;
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
  mu = acc[0];
  rmax = acc[1];
  lmax = acc[2];
  for (j = 0; j < IPM_NFREE; ++j) {
    const int v = IPM_FREE[j];
    IPM_W.h[v] = ((IPM_W.Pd[v] + IPM_PROX) * IPM_W.z[v]) + q[v];
  }
  ipm_ATx(IPM_W.h, IPM_W.y, IPM_W.r_d);
  {
    ipm_real_t m[2];
    m[0] = rmax;
    m[1] = lmax;
    mu += ipm_sr_check(m);
    rmax = m[0];
    lmax = m[1];
  }
  for (j = 0; j < IPM_NEQ; ++j) {
    const int r = IPM_EQ_ALL[j];
    IPM_W.wr[r] = IPM_W.wr[r] - l[r];
    if (IPM_FABS(IPM_W.wr[r]) > rmax) {
      rmax = IPM_FABS(IPM_W.wr[r]);
    }
  }
  for (k = 0; k < IPM_N; ++k) { /* the dynamics rows' residuals become c_k = -r_eq / E (ipm_stage_c) */
    for (i = 0; i < IPM_NX; ++i) {
      IPM_W.wr[IPM_DYN_ROWS[(k * IPM_NX) + i]] *= -IPM_W.Einv[k][i];
    }
  }
  mu /= (ipm_real_t)IPM_NCOMP;
  { /* the stationarity residuals: their largest magnitude; 0 times each sums to NaN once one is not finite (two
     * chains of each, the even and the odd entries: their maxima and sums overlap) */
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
  }
  if ((isfinite(rmax) == 0) || (isfinite(mu) == 0)) {
    raw = IPM_RAW_QP_NONFINITE;
  } else if (rmax <= IPM_TOL) {
    raw = IPM_RAW_QP_SOLVED;
  } else if (lmax > IPM_LAM_MAX) {
    raw = IPM_RAW_QP_PRIMAL_INFEASIBLE;
  } else {
    /* not converged */
  }
  *mu_out = mu;
  return raw;
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
  nf = ipm_nonfinite(IPM_W.dz, IPM_NV); /* NaN once an entry of the step is not finite (the soft rows' slacks': 0) */
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

static int qpb_solve(const ipm_real_t *q, const ipm_real_t *l, const ipm_real_t *u,
                     const ipm_real_t *y_warm, int max_iter, qpb_result_t *res) {
  int j;
  int it = 0;
  int raw = IPM_GOING;
  for (j = 0; j < IPM_NSIDE; ++j) {
    const int r = IPM_SIDE_ROW[j];
    const ipm_real_t lw = (IPM_WARM != 0) ? ((-IPM_SIDE_SIGN[j]) * y_warm[r]) : REAL_0;
    const ipm_real_t b = ipm_side_b(l, u, j);
    IPM_W.bs[j] = b;
    IPM_W.dt[j] = REAL_0; /* no step taken yet (IPM_W.aff[3] = 0): ipm_check takes the last step */
    IPM_W.dlam[j] = REAL_0;
    IPM_W.t[j] = ((-b) > IPM_T_MIN) ? (-b) : IPM_T_MIN;
    IPM_W.lam[j] = (lw > IPM_LAM_MIN) ? lw : IPM_LAM_MIN;
  }
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
      const ipm_real_t lw2 = (IPM_WARM != 0) ? ((-IPM_SR_BSIGN[j]) * y_warm[rb]) : REAL_0;
      IPM_SR.b1[j] = (IPM_SR_SIGN[j] > 0) ? l[r] : (-u[r]);
      IPM_SR.b2[j] = (IPM_SR_BSIGN[j] > 0) ? l[rb] : (-u[rb]);
      IPM_SR.t1[j] = ((-IPM_SR.b1[j]) > IPM_T_MIN) ? (-IPM_SR.b1[j]) : IPM_T_MIN;
      IPM_SR.l1[j] = (lw1 > IPM_LAM_MIN) ? lw1 : IPM_LAM_MIN;
      IPM_SR.l2[j] = (lw2 > IPM_LAM_MIN) ? lw2 : IPM_LAM_MIN;
      IPM_SR.t2[j] = ipm_t2_start(IPM_SR.b2[j], IPM_SR.l2[j]);
      IPM_SR.qs[j] = q[IPM_SR_SVAR[j]];
    }
  }
  IPM_W.aff[3] = REAL_0;
  { /* a centred start: every lam at least IPM_LAM_CENTER mean(t lam) / t */
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
