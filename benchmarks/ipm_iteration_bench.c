/* The IPM's QP solve alone, timed per QP iteration on recorded QPs (benchmarks/ipm_iteration_bench.py).
 *
 * Built once per solver folder with -DSOLVER_C='"<folder>/<name>_solver.c"': the solver's own translation unit is
 * included, so its static backend (qpb_reset, qpb_set_matrices, qpb_solve) is called as feedback calls it.
 *
 *   harness QPS_FILE REPEATS MAX_ITER   ->   one line per repeat: "<seconds> <iterations>" of all QPs
 *
 * QPS_FILE: int32 count, then per QP the float64 arrays q[QP_N], l[QP_M], u[QP_M], A_x[QP_NNZ_A], y_warm[QP_M]. */
#define _POSIX_C_SOURCE 199309L
#include <stdio.h>
#include <stdlib.h>
#include <time.h>

#include SOLVER_C

#ifndef QPH_PREFIX
#error "QPH_PREFIX (the solver's upper-case name) must be defined"
#endif
#define QPH_CAT2(a, b) a##b
#define QPH_CAT(a, b) QPH_CAT2(a, b)
#define QPH_N QPH_CAT(QPH_PREFIX, _QP_N)
#define QPH_M QPH_CAT(QPH_PREFIX, _QP_M)
#define QPH_NNZ QPH_CAT(QPH_PREFIX, _QP_NNZ_A)
#define QPH_REC (QPH_N + (3 * QPH_M) + QPH_NNZ)

static double seconds(void) {
  struct timespec ts;
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts); /* CPU time: a descheduled moment does not count */
  return (double)ts.tv_sec + (1e-9 * (double)ts.tv_nsec);
}

int main(int argc, char **argv) {
  FILE *f;
  int count = 0;
  int reps;
  int max_iter;
  int r;
  double *data;
  if (argc != 4) {
    fprintf(stderr, "usage: %s QPS_FILE REPEATS MAX_ITER\n", argv[0]);
    return 2;
  }
  reps = atoi(argv[2]);
  max_iter = atoi(argv[3]);
  f = fopen(argv[1], "rb");
  if (f == NULL || fread(&count, sizeof count, 1, f) != 1 || count <= 0) {
    fprintf(stderr, "cannot read %s\n", argv[1]);
    return 2;
  }
  data = malloc(sizeof(double) * (size_t)count * QPH_REC);
  if (data == NULL || fread(data, sizeof(double) * QPH_REC, (size_t)count, f) != (size_t)count) {
    fprintf(stderr, "%s: short file\n", argv[1]);
    return 2;
  }
  fclose(f);
  qpb_reset();
  for (r = 0; r < reps; ++r) {
    long iters = 0;
    int k;
    const double t0 = seconds();
    for (k = 0; k < count; ++k) {
      const double *q = &data[(size_t)k * QPH_REC];
      const double *l = q + QPH_N;
      const double *u = l + QPH_M;
      const double *a = u + QPH_M;
      const double *y = a + QPH_NNZ;
      qpb_result_t res;
      (void)qpb_set_matrices(P_DIAG, a, q);
      (void)qpb_solve(q, l, u, y, max_iter, &res);
      iters += res.iter;
    }
    printf("%.9f %ld\n", seconds() - t0, iters);
  }
  free(data);
  return 0;
}
