/* The IPM's algorithm (csrc/ipm/ipm_core.c and its parts) compiled on its own, with a problem header rendered by fcgen
 * (ipm_problem.h: sizes, tables, workspace), the way HPIPM's library is separate from the interfaces that size it.
 * tests/test_ipm_core.py renders the header, writes the QPs a Python closed loop solved and compares the results.
 *
 * Input (binary, native doubles), argv: n m nnzA events_file results_file. The events file is a sequence of
 *   'R'                               qpb_reset()
 *   'M' P_x[n] A_x[nnzA] q[n]         qpb_set_matrices
 *   'S' q[n] l[m] u[m] y_warm[m] it   qpb_solve (it: the iteration cap, as a double)
 * For every 'S' the results file gets: status raw iter, the probe's counts of its four events (as doubles), z[n],
 * y[m]. */
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

typedef double tipm_real_t;
enum {
  TIPM_QP_SOLVED = 1,
  TIPM_QP_SOLVED_INACCURATE,
  TIPM_QP_MAX_ITER,
  TIPM_QP_PRIMAL_INFEASIBLE,
  TIPM_QP_DUAL_INFEASIBLE,
  TIPM_QP_NONCONVEX,
  TIPM_QP_NONFINITE,
  TIPM_QP_NUMERICAL,
  TIPM_QP_OTHER
};
#define REAL_0 ((tipm_real_t)0.0)
typedef struct {
  int status;
  int raw_status;
  int iter;
  const tipm_real_t *z;
  const tipm_real_t *y;
} qpb_result_t;
/* the QP phases' timing probe (the solver's QPB_PROBE): counted, so a test sees each phase once per iteration */
static long g_probe[4];
#define QPB_PROBE_START 0
#define QPB_PROBE_CHECK 1
#define QPB_PROBE_STEP 2
#define QPB_PROBE_END 3
#define QPB_PROBE(event) (++g_probe[(event)])

#include "ipm_problem.h"
#include "ipm_core.c"

static int read_all(FILE *f, double *x, long n) {
  return fread(x, sizeof(double), (size_t)n, f) == (size_t)n;
}

int main(int argc, char **argv) {
  if (argc != 6) {
    fprintf(stderr, "usage: %s n m nnzA events results\n", argv[0]);
    return 2;
  }
  const long n = atol(argv[1]), m = atol(argv[2]), nnz = atol(argv[3]);
  FILE *ev = fopen(argv[4], "rb");
  FILE *out = fopen(argv[5], "wb");
  if (!ev || !out) return 2;
  /* set_matrices keeps pointers to P_x and A_x: one buffer each, alive for the whole run */
  double *P = malloc(sizeof(double) * (size_t)n), *A = malloc(sizeof(double) * (size_t)(nnz ? nnz : 1));
  double *q = malloc(sizeof(double) * (size_t)n), *l = malloc(sizeof(double) * (size_t)m);
  double *u = malloc(sizeof(double) * (size_t)m), *yw = malloc(sizeof(double) * (size_t)m);
  int c;
  while ((c = fgetc(ev)) != EOF) {
    if (c == 'R') {
      qpb_reset();
    } else if (c == 'M') {
      if (!read_all(ev, P, n) || !read_all(ev, A, nnz) || !read_all(ev, q, n)) return 3;
      if (qpb_set_matrices(P, A, q) != 0) return 4;
    } else if (c == 'S') {
      double it;
      qpb_result_t res;
      if (!read_all(ev, q, n) || !read_all(ev, l, m) || !read_all(ev, u, m) || !read_all(ev, yw, m) ||
          !read_all(ev, &it, 1))
        return 3;
      (void)memset(g_probe, 0, sizeof g_probe);
      (void)qpb_solve(q, l, u, yw, (int)it, &res);
      double head[7] = {res.status, res.raw_status, res.iter, g_probe[0], g_probe[1], g_probe[2], g_probe[3]};
      fwrite(head, sizeof(double), 7, out);
      fwrite(res.z, sizeof(double), (size_t)n, out);
      fwrite(res.y, sizeof(double), (size_t)m, out);
    } else {
      return 3;
    }
  }
  fclose(out);
  fclose(ev);
  return 0;
}
