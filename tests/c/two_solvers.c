/* two_solvers.c -- two generated solvers in one image: a few RTI samples of each on a straight road, opponents far
 * away; prints every u0 with 17 digits. Compile with -DSOLVER_A=<name> -DSOLVER_A_UP=<NAME> (and/or the same for
 * SOLVER_B) and link lib<name>.a + lib<name>_osqp.a of each; with one of them only, the same program gives that
 * solver's figures alone. Both solvers need the Cartesian opponent pose (NOPP_PAR = 3) and road.ds = DS. */
#include <stdio.h>

#define STR(x) #x
#define XSTR(x) STR(x)
#define CAT(a, b) a##b
#define XCAT(a, b) CAT(a, b)
#define HEADER(n) XSTR(XCAT(n, _solver.h))

#ifndef DS
#define DS 2.0
#endif
#define S0 (-20.0)
#define SAMPLES 3

/* the run of the solver with prefix P (upper case: PU) */
#define DEFINE_RUN(P, PU)                                                                                              \
  static int XCAT(run_, P)(void) {                                                                                     \
    static XCAT(P, _real_t) kappa[XCAT(PU, _ROAD_MAX)], phi[XCAT(PU, _ROAD_MAX)];                                      \
    static XCAT(P, _real_t) gx[XCAT(PU, _ROAD_MAX)], gy[XCAT(PU, _ROAD_MAX)];                                          \
    static XCAT(P, _real_t) opp[(XCAT(PU, _N) + 1) * XCAT(PU, _NOPP) * 3 + 1];                                         \
    XCAT(P, _real_t) x0[5] = {0.0, 1.0, 0.0, 15.0, 0.0}, u[2];                                                         \
    int i, k, rc;                                                                                                      \
    (void)sizeof(char[(XCAT(PU, _NOPP_PAR) == 3) ? 1 : -1]); /* Cartesian opponent pose */                             \
    for (i = 0; i < XCAT(PU, _ROAD_MAX); ++i) {                                                                        \
      kappa[i] = 0;                                                                                                    \
      phi[i] = 0;                                                                                                      \
      gx[i] = (XCAT(P, _real_t))(S0 + DS * i);                                                                         \
      gy[i] = 0;                                                                                                       \
    }                                                                                                                  \
    for (i = 0; i < (XCAT(PU, _N) + 1) * XCAT(PU, _NOPP); ++i) {                                                       \
      opp[3 * i] = -1000;                                                                                              \
      opp[3 * i + 1] = 500;                                                                                            \
      opp[3 * i + 2] = 0;                                                                                              \
    }                                                                                                                  \
    rc = XCAT(P, _init)();                                                                                             \
    if (!rc)                                                                                                           \
      rc = XCAT(P, _set_road)((XCAT(P, _real_t))S0, (XCAT(P, _real_t))DS, XCAT(PU, _ROAD_MAX), kappa, phi, gx, gy);    \
    if (!rc) rc = XCAT(P, _set_opponents)(opp);                                                                        \
    for (k = 0; k < SAMPLES && !rc; ++k) {                                                                             \
      rc = XCAT(P, _set_state)(x0);                                                                                    \
      if (!rc) rc = XCAT(P, _prepare)();                                                                               \
      if (!rc) rc = XCAT(P, _feedback)();                                                                              \
      XCAT(P, _get_u0)(u);                                                                                             \
      printf("%s %d %d %.17g %.17g\n", XSTR(P), k, rc, (double)u[0], (double)u[1]);                                    \
      x0[0] += (XCAT(P, _real_t))1.5; /* the ego moved on */                                                           \
    }                                                                                                                  \
    return rc;                                                                                                         \
  }

#ifdef SOLVER_A
#include HEADER(SOLVER_A)
DEFINE_RUN(SOLVER_A, SOLVER_A_UP)
#endif
#ifdef SOLVER_B
#include HEADER(SOLVER_B)
DEFINE_RUN(SOLVER_B, SOLVER_B_UP)
#endif

int main(void) {
  int rc = 0;
#ifdef SOLVER_A
  rc |= XCAT(run_, SOLVER_A)();
#endif
#ifdef SOLVER_B
  rc |= XCAT(run_, SOLVER_B)();
#endif
  return rc;
}
