/*
 * fuzz_common.h -- what the C API fuzzers (fuzz_api.c, fuzz_contract.c) share: the solver's names from
 * -DSOLVER=<name> -DSOLVER_UPPER=<NAME>, its sizes, the seeded random numbers (splitmix64; libFuzzer's input bytes
 * first where fz_stream is set) and the QP outcome codes of feedback. Included once per program (static functions).
 */
#ifndef FCGEN_FUZZ_COMMON_H
#define FCGEN_FUZZ_COMMON_H

#include <math.h>
#include <stddef.h>
#include <stdint.h>
#include <string.h>

#if !defined(SOLVER) || !defined(SOLVER_UPPER)
#error "compile with -DSOLVER=<name> -DSOLVER_UPPER=<NAME> -I<solver folder>"
#endif

#define FZ_CAT_(a, b) a##b
#define FZ_CAT(a, b) FZ_CAT_(a, b)
#define FZ_STR_(x) #x
#define FZ_STR(x) FZ_STR_(x)
#define S_(x) FZ_CAT(SOLVER, x) /* the solver's function or type x: S_(_prepare) */
#define U_(x) FZ_CAT(SOLVER_UPPER, x) /* its constant x: U_(_OK) */

#include FZ_STR(S_(_solver).h)

typedef S_(_real_t) real_t;
typedef S_(_status_t) status_t;

#define NX U_(_NX)
#define NU U_(_NU)
#define N U_(_N)
#define NOPP U_(_NOPP)
#define NOPP_PAR U_(_NOPP_PAR)
#define ROAD_MAX U_(_ROAD_MAX)
#define OPP_BLOCK ((N + 1) * NOPP * NOPP_PAR)
#define MAX_CODE 64

/* ---------------------------------------------------------------------------------------------- random */
static uint64_t fz_rng; /* splitmix64's state: the seed */
static const uint8_t *fz_stream; /* libFuzzer: the input's bytes, used before the generator */
static size_t fz_stream_left;

static uint64_t rnd(void) {
  uint64_t z;
  if (fz_stream_left >= 8u) {
    memcpy(&z, fz_stream, 8u);
    fz_stream += 8;
    fz_stream_left -= 8u;
    return z;
  }
  z = (fz_rng += 0x9E3779B97F4A7C15ull);
  z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
  z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
  return z ^ (z >> 31);
}
static int pick(int n) {
  return (int)(rnd() % (uint64_t)n);
}
static double unif(double a, double b) {
  return a + (b - a) * ((double)(rnd() >> 11) / 9007199254740992.0);
}
static double nonfinite(void) {
  static const double v[3] = {NAN, INFINITY, -INFINITY};
  return v[pick(3)];
}

/* ---------------------------------------------------------------------------------------------- codes */
/* a feedback code that means "the sample was consumed by a QP" (OK or a QP outcome), not a refused call */
static int qp_outcome(int rc) {
  return rc == U_(_OK) || rc == U_(_ERR_QP) || rc == U_(_ERR_QP_INFEASIBLE) || rc == U_(_ERR_QP_DUAL_INFEASIBLE) ||
         rc == U_(_ERR_QP_NONCONVEX) || rc == U_(_ERR_QP_NONFINITE) || rc == U_(_ERR_QP_NUMERICAL) ||
         rc == U_(_ERR_QP_INPUT_BOUNDS);
}

#endif
