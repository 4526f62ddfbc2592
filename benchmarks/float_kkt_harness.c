/* Diagnosis harness for benchmarks/float_kkt_diagnosis.py (not part of any generated solver).
 *
 * Compiled together with a generated folder's OSQP workspace and library (float or double, symbols prefixed):
 * loads one QP into OSQP's embedded workspace the way the generated solver does, solves it from a given warm start,
 * and exposes one KKT solve (optionally with iterative refinement in working precision) and the LDL' pivots.
 * Build: -DWS_HEADER='"<name>_workspace.h"' -DSOLVER=<name>_solver -DRESET=<name>_workspace_reset.
 */
#include "osqp.h"
#include "types.h"
#include "algebra_impl.h"
#include "qdldl_interface.h"
#include "qdldl.h"
#include WS_HEADER

#define SV (&SOLVER)
#define MAXN 8192

static int inited = 0;
static OSQPFloat rb[MAXN], rs[MAXN], rr[MAXN];

static void ensure(void) {
  if (!inited) {
    RESET();
    inited = 1;
  }
}

/* the QP's data, in the generated solver's order (q first: OSQP scales with the q it holds) */
int h_load(const OSQPFloat *Px, const OSQPFloat *Ax, const OSQPFloat *q, const OSQPFloat *l, const OSQPFloat *u, int n,
           int nnzA) {
  ensure();
  if (osqp_update_data_vec(SV, q, OSQP_NULL, OSQP_NULL)) return 1;
  if (osqp_update_data_mat(SV, Px, OSQP_NULL, n, Ax, OSQP_NULL, nnzA)) return 2;
  return (int)osqp_update_data_vec(SV, q, l, u);
}

/* iteration cap, termination check interval (0: none) and tolerances */
int h_settings(int max_iter, int check, double eps_abs, double eps_rel) {
  OSQPSettings s;
  ensure();
  s = *SV->settings;
  s.max_iter = max_iter;
  s.check_termination = check;
  s.eps_abs = (OSQPFloat)eps_abs;
  s.eps_rel = (OSQPFloat)eps_rel;
  return (int)osqp_update_settings(SV, &s);
}

/* solve from the warm start (x0, y0); returns OSQP's status_val (negative: osqp_solve's error) */
int h_solve(const OSQPFloat *x0, const OSQPFloat *y0, OSQPFloat *x, OSQPFloat *y, int *iter) {
  OSQPInt i;
  int rc;
  (void)osqp_warm_start(SV, x0, y0);
  rc = (int)osqp_solve(SV);
  for (i = 0; i < SV->work->data->n; ++i) x[i] = SV->solution->x[i];
  for (i = 0; i < SV->work->data->m; ++i) y[i] = SV->solution->y[i];
  *iter = (int)SV->info->iter;
  return (rc != 0) ? -rc : (int)SV->info->status_val;
}

/* warm start at (x0, y0), then the ADMM right-hand side of the KKT solve (n + m), as OSQP's compute_rhs forms it,
 * and the scaled x of that warm start */
int h_rhs(const OSQPFloat *x0, const OSQPFloat *y0, OSQPFloat *b, OSQPFloat *x_scaled) {
  OSQPWorkspace *w = SV->work;
  OSQPInt i;
  (void)osqp_warm_start(SV, x0, y0);
  for (i = 0; i < w->data->n; ++i) {
    b[i] = SV->settings->sigma * w->x->values[i] - w->data->q->values[i];
    x_scaled[i] = w->x->values[i];
  }
  for (i = 0; i < w->data->m; ++i) b[w->data->n + i] = w->z->values[i] - w->rho_inv_vec->values[i] * w->y->values[i];
  return 0;
}

/* solve K s = b in place with OSQP's factorization (permuted QDLDL factor), then nref steps of iterative
 * refinement with the residual in working precision; b becomes s = [x_tilde; nu] */
int h_kkt(OSQPFloat *b, int nref) {
  qdldl_solver *q = (qdldl_solver *)SV->work->linsys_solver;
  const OSQPCscMatrix *K = q->KKT;
  OSQPInt N = K->n, j, p, r;
  if (N > MAXN) return -1;
  for (j = 0; j < N; ++j) {
    rb[j] = b[q->P[j]];
    rs[j] = rb[j];
  }
  QDLDL_solve(N, q->L->p, q->L->i, q->L->x, q->Dinv, rs);
  for (r = 0; r < nref; ++r) {
    for (j = 0; j < N; ++j) rr[j] = rb[j];
    for (j = 0; j < N; ++j) {
      for (p = K->p[j]; p < K->p[j + 1]; ++p) { /* K: upper triangle of the symmetric permuted KKT matrix */
        OSQPInt i = K->i[p];
        rr[i] -= K->x[p] * rs[j];
        if (i != j) rr[j] -= K->x[p] * rs[i];
      }
    }
    QDLDL_solve(N, q->L->p, q->L->i, q->L->x, q->Dinv, rr);
    for (j = 0; j < N; ++j) rs[j] += rr[j];
  }
  for (j = 0; j < N; ++j) b[q->P[j]] = rs[j];
  return (int)N;
}

/* the pivots d of the LDL' factorization (n + m) */
int h_pivots(OSQPFloat *d) {
  qdldl_solver *q = (qdldl_solver *)SV->work->linsys_solver;
  OSQPInt j;
  for (j = 0; j < q->L->n; ++j) d[j] = q->D[j];
  return (int)q->L->n;
}
