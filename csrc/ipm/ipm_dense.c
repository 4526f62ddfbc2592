/* ---- the IPM's small dense kernels (row-major, fixed sizes; plain C99) -------------------------------------------
 * A finiteness test, NaN-aware max/min, Cholesky factor and triangular solves, and the solves with a stage's R_bar
 * over its input blocks (or written out for all inputs: IPM_U_DENSE, u_kernels in the problem header). */

/* 0 times each entry of the step IPM_W.dz, summed in four independent chains: NaN once one is not finite (a
 * finiteness test whose adds overlap instead of waiting on each other; P_k's own test is ipm_pk_nonfinite) */
static ipm_real_t ipm_dz_nonfinite(void) {
  const ipm_real_t *v = IPM_W.dz;
  ipm_real_t s0 = REAL_0;
  ipm_real_t s1 = REAL_0;
  ipm_real_t s2 = REAL_0;
  ipm_real_t s3 = REAL_0;
  int i;
  for (i = 0; (i + 3) < IPM_NV; i += 4) {
    s0 += v[i] * REAL_0;
    s1 += v[i + 1] * REAL_0;
    s2 += v[i + 2] * REAL_0;
    s3 += v[i + 3] * REAL_0;
  }
#if (IPM_NV % 4) != 0 /* the last entries (a loop that never runs would be flagged by gcc once inlined) */
  for (i = IPM_NV - (IPM_NV % 4); i < IPM_NV; ++i) {
    s0 += v[i] * REAL_0;
  }
#endif
  return (s0 + s1) + (s2 + s3);
}

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

/* Cholesky factor and triangular solves (row-major, fixed sizes): for the input blocks (where not written out:
 * IPM_U_DENSE) and the stage equalities */
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
