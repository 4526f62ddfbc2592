/* ---- the general rows of a stage (IPM_GEN_*): the generic loops over the stage view's tables, and the one switch to
 * the kernels the problem header writes out for the stages of the commonest pattern (IPM_GEN_PAT, gen_kernels) -------
 * A general row is an inequality row on a stage's (x, u) and at most one slack; a slack's rows (its group) are
 * eliminated with it. Each *_any function here is the generic loops of one operation on stage k's rows; its
 * written-out counterpart ipm_gen_* does the same operations in the same order at the pattern's fixed offsets. */

/* The one switch between a stage's general rows written out and the generic loops: the written-out call at a stage
 * IPM_GEN_PAT flags, else the generic one. Without a stage written out (IPM_GEN_WRITTEN 0: the problem header has no
 * ipm_gen_* and no IPM_GEN_PAT) the generic call alone. */
#if IPM_GEN_WRITTEN
#define IPM_GEN_ROWS(k, written, generic) ((IPM_GEN_PAT[(k)] != 0) ? (written) : (generic))
#else
#define IPM_GEN_ROWS(k, written, generic) (generic)
#endif

/* slack s of stage k: its rows' general slots IPM_SG_G[p], p = IPM_SG_BEG[k][s] .. IPM_SG_END[k][s] - 1 */
#define IPM_SG0(k, s) IPM_SG_BEG[k][s]
#define IPM_SG1(k, s) IPM_SG_END[k][s]
#define IPM_GSLOT(k, g) (((k) * IPM_NG) + (g))

/* a'x on stage k's general rows, into out by row: the generic loops */
static void ipm_rows_ax_any(int k, const ipm_real_t *x, ipm_real_t *out) {
  int g;
  int a;
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

/* IPM_W.h += A' g over stage k's general rows, g in IPM_W.ar: the generic loops */
static void ipm_rows_atx_any(int k) {
  int g;
  int a;
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

/* stage k's slacks' part of its reduced right-hand side, the generic loops: hs, and the slacks eliminated from ht */
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
