/*
 * fuzz_api.c -- seeded random call sequences against the C API of a generated fcgen solver (tests/test_fuzz.py).
 *
 *   fuzz_api SEED EPISODES
 *
 * First the good sequence (K_GOOD RTI samples on a straight road, one opponent ahead in the lane, fixed inputs
 * that do not depend on the solver's output) runs on the fresh, zero-initialised solver: the reference. Then each
 * episode is
 *   1. garbage: GARBAGE random calls (every API function; NaN/Inf/huge/denormal inputs, NULL pointers, opponents
 *      on the ego, roads that do not cover the horizon, wrong call order, prepare twice, reset/init);
 *   2. a restart, init() or reset();
 *   3. the good sequence again with rejected calls interleaved ("noise"), compared bitwise (memcmp of u0 and of the
 *      states, and the return codes) with the reference.
 * Checks, every call: no crash (and, built with -fsanitize=address,undefined, no sanitizer report); every invalid
 * call rejected with its code (and get_status's exit_code equal to it); only documented codes; an OK feedback gives
 * a finite u0. Contract checks (compile with -DFUZZ_CONTRACT; without it they are measured and printed as "gap_*"
 * lines, not failed): an OK feedback has a usable QP status and u0 inside the input box; a failed prepare and a
 * second prepare leave the solver as before (noise mode B); reset() gives what a fresh solver gives.
 * Without -DFUZZ_CONTRACT the strict bitwise checks are init() + noise mode A (rejected setters, feedback before
 * prepare, getters).
 *
 * Prints "key value" counts and exits 1 on any violation (0 otherwise; 2: usage).
 * Build: -DSOLVER=<name> -DSOLVER_UPPER=<NAME> -DFUZZ_F_D_MAX=<F_d_max> -DFUZZ_R_MAX=<r_max> -DFUZZ_DS=<road ds>
 *        -I<solver folder>, linked with lib<name>.a lib<name>_osqp.a -lm (see tests/c/Makefile).
 */
#include <float.h>
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#if !defined(SOLVER) || !defined(SOLVER_UPPER) || !defined(FUZZ_F_D_MAX) || !defined(FUZZ_R_MAX) || !defined(FUZZ_DS)
#error "compile with -DSOLVER=<name> -DSOLVER_UPPER=<NAME> -DFUZZ_F_D_MAX=.. -DFUZZ_R_MAX=.. -DFUZZ_DS=.."
#endif

#define FZ_CAT_(a, b) a##b
#define FZ_CAT(a, b) FZ_CAT_(a, b)
#define FZ_STR_(x) #x
#define FZ_STR(x) FZ_STR_(x)
#define S_(x) FZ_CAT(SOLVER, x)
#define U_(x) FZ_CAT(SOLVER_UPPER, x)

#include FZ_STR(S_(_solver).h)

typedef S_(_real_t) real_t;
typedef S_(_status_t) status_t;

#define NX U_(_NX)
#define NU U_(_NU)
#define N U_(_N)
#define NOPP U_(_NOPP)
#define NOPP_PAR U_(_NOPP_PAR)
#define ROAD_MAX U_(_ROAD_MAX)
#define ROAD_WINDOW U_(_ROAD_WINDOW)
#define OPP_BLOCK ((N + 1) * NOPP * NOPP_PAR)
#define NSTATES ((N + 1) * NX)

#if NOPP_PAR != 3
#error "fuzz_api.c places opponents as Cartesian poses (x, y, phi): use a lifted or direct-elimination solver"
#endif

#define K_GOOD 8    /* samples of the good sequence */
#define GARBAGE 40  /* random calls per episode before the restart */
#define G_S0 (-20.0)

/* ------------------------------------------------------------------------------------------------ random */
static uint64_t rng_state;
static uint64_t rnd(void) { /* splitmix64 */
  uint64_t z = (rng_state += 0x9E3779B97F4A7C15ull);
  z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
  z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
  return z ^ (z >> 31);
}
static int pick(int n) { return (int)(rnd() % (uint64_t)n); }
static double unif(double a, double b) { return a + (b - a) * ((double)(rnd() >> 11) / 9007199254740992.0); }
static double nonfinite(void) {
  static const double v[3] = {NAN, INFINITY, -INFINITY};
  return v[pick(3)];
}
static double extreme(void) {
  static const double v[10] = {1e15, -1e15, 1e300, -1e300, DBL_MAX, 4.9e-324, -4.9e-324, 1e-310, -0.0, 1e30};
  return v[pick(10)];
}

/* ------------------------------------------------------------------------------------------------ counts */
#define MAX_CODE 64
static long n_calls, n_invalid, n_rejected_ok, n_rc[MAX_CODE], n_unknown_code;
static long n_fb_ok, n_fb_err, n_checked, n_equal, n_episodes;
static long violations, gaps;
static long v_wrong_code, v_status, v_nonfinite_u, v_mismatch, v_good_rejected;
static long g_ok_unusable, g_u_out_of_box, g_mismatch_reset, g_mismatch_modeb;
static double g_max_du;

static void violation(long *counter, const char *what, double a, double b) {
  ++*counter;
  if (++violations <= 10) fprintf(stderr, "violation: %s (%.17g, %.17g)\n", what, a, b);
}

#ifdef FUZZ_CONTRACT
#define CONTRACT 1
#else
#define CONTRACT 0
#endif

/* a contract check: a violation with -DFUZZ_CONTRACT, a measured gap otherwise */
static void contract(long *gap_counter, const char *what, double a, double b) {
  if (CONTRACT) {
    violation(gap_counter, what, a, b);
  } else {
    ++*gap_counter;
    ++gaps;
  }
}

static const char *code_name(int rc) {
  switch (rc) {
    case U_(_OK): return "OK";
    case U_(_ERR_NOT_PREPARED): return "ERR_NOT_PREPARED";
    case U_(_ERR_NO_STATE): return "ERR_NO_STATE";
    case U_(_ERR_NONFINITE_STATE): return "ERR_NONFINITE_STATE";
    case U_(_ERR_NONFINITE_OPPONENTS): return "ERR_NONFINITE_OPPONENTS";
    case U_(_ERR_NONFINITE_ROAD): return "ERR_NONFINITE_ROAD";
    case U_(_ERR_ROAD_WINDOW): return "ERR_ROAD_WINDOW";
    case U_(_ERR_ROAD_SIZE): return "ERR_ROAD_SIZE";
    case U_(_ERR_QP): return "ERR_QP";
    default: return NULL;
  }
}

/* every call that returns a code goes through here; want < 0: any documented code */
static int called(int rc, int want) {
  status_t st;
  ++n_calls;
  if (rc >= 0 && rc < MAX_CODE) ++n_rc[rc];
  if (!code_name(rc)) {
    ++n_unknown_code;
    violation(&v_wrong_code, "undocumented exit code", rc, want);
    return rc;
  }
  if (want >= 0) {
    if (want != U_(_OK)) ++n_invalid;
    if (rc != want) {
      violation(&v_wrong_code, "wrong exit code (got, expected)", rc, want);
    } else if (want != U_(_OK)) {
      ++n_rejected_ok;
    }
  }
  if (rc != U_(_OK)) {
    S_(_get_status)(&st);
    if (st.exit_code != rc) violation(&v_status, "status.exit_code differs from the returned code", st.exit_code, rc);
  }
  return rc;
}

/* ------------------------------------------------------------------------------------------------ inputs */
static real_t g_kappa[ROAD_MAX], g_phi[ROAD_MAX], g_gx[ROAD_MAX], g_gy[ROAD_MAX];
static real_t g_x[K_GOOD][5];
static real_t g_opp[K_GOOD][OPP_BLOCK + 1];
static real_t r_kappa[ROAD_MAX + 1], r_phi[ROAD_MAX + 1], r_gx[ROAD_MAX + 1], r_gy[ROAD_MAX + 1];
static real_t r_opp[OPP_BLOCK + 1];
static real_t last_x0[5] = {0.0, 0.0, 0.0, 10.0, 0.0};

static void make_good(void) {
  int i, k, j, o;
  for (i = 0; i < ROAD_MAX; ++i) {
    g_kappa[i] = 0.0;
    g_phi[i] = 0.0;
    g_gx[i] = (real_t)(G_S0 + FUZZ_DS * i);
    g_gy[i] = 0.0;
  }
  for (k = 0; k < K_GOOD; ++k) {
    real_t x[5] = {(real_t)(1.5 * k), (real_t)(1.0 - 0.05 * k), 0.0, 15.0, 0.0};
    memcpy(g_x[k], x, sizeof x);
    for (j = 0; j <= N; ++j)
      for (o = 0; o < NOPP; ++o) {
        real_t *p = g_opp[k] + (j * NOPP + o) * NOPP_PAR;
        p[0] = o == 0 ? (real_t)(35.0 + 1.0 * (k + j)) : -1000.0; /* opponent 0: in the lane, 10 m/s */
        p[1] = o == 0 ? 1.0 : 500.0;
        p[2] = 0.0;
      }
  }
}

static int set_good_road(void) {
  return S_(_set_road)((real_t)G_S0, (real_t)FUZZ_DS, ROAD_MAX, g_kappa, g_phi, g_gx, g_gy);
}

static int all_finite(const real_t *v, int n) {
  int i;
  for (i = 0; i < n; ++i)
    if (!isfinite(v[i])) return 0;
  return 1;
}

/* ------------------------------------------------------------------------------------------------ random calls */
/* what the harness knows for sure about the solver (for exact expectations) */
static int state_since_init; /* a set_state was accepted since init (or since the start) */
static int road_since_init;  /* 0: none accepted since init, 1: the last accepted one is shorter than a window, 2: other */
static int prep;             /* 0: certainly not prepared, 1: certainly prepared, 2: unknown */

static void restarted(void) { prep = 0; }
static void after_good(void) { /* the good sequence set a state and the good road; its last call was a feedback */
  state_since_init = 1;
  road_since_init = 2;
  prep = 0;
}
static void inited(void) {
  state_since_init = 0;
  road_since_init = 0;
  prep = 0;
}

static int r_set_state(void) {
  real_t x[5];
  int i, kind = pick(4), want;
  for (i = 0; i < 5; ++i) x[i] = last_x0[i];
  if (kind == 0) { /* plausible */
    x[0] = (real_t)unif(-10.0, 200.0);
    x[1] = (real_t)unif(-12.0, 12.0);
    x[2] = (real_t)unif(-1.0, 1.0);
    x[3] = (real_t)unif(-5.0, 45.0);
    x[4] = (real_t)unif(-0.5, 0.5);
  } else if (kind == 1) {
    x[pick(5)] = (real_t)extreme();
  } else if (kind == 2) {
    x[pick(5)] = (real_t)nonfinite();
  }
  if (kind == 3 && pick(2)) return called(S_(_set_state)(NULL), U_(_ERR_NO_STATE));
  want = all_finite(x, 5) ? U_(_OK) : U_(_ERR_NONFINITE_STATE);
  if (called(S_(_set_state)(x), want) == U_(_OK)) {
    memcpy(last_x0, x, sizeof x);
    state_since_init = 1;
  }
  return 0;
}

static int r_set_road(void) {
  int i, n = ROAD_MAX, kind = pick(9), want;
  double s0 = G_S0, ds = FUZZ_DS;
  const real_t *k = r_kappa, *p = r_phi, *x = r_gx, *y = r_gy;
  for (i = 0; i <= ROAD_MAX; ++i) {
    r_kappa[i] = g_kappa[i < ROAD_MAX ? i : 0];
    r_phi[i] = 0.0;
    r_gx[i] = (real_t)(G_S0 + FUZZ_DS * i);
    r_gy[i] = 0.0;
  }
  switch (kind) {
    case 0: s0 += unif(-300.0, 300.0); break;                             /* shifted: may not cover the ego */
    case 1: n = 2 + pick(ROAD_WINDOW - 2 > 0 ? ROAD_WINDOW - 2 : 1); break; /* shorter than one window */
    case 2: for (i = 0; i < n; ++i) r_kappa[i] = (real_t)unif(-1.0, 1.0); break;
    case 3: { static const int bad[5] = {0, 1, -3, ROAD_MAX + 1, 2147483647}; n = bad[pick(5)]; } break;
    case 4: if (pick(2)) k = NULL; else y = NULL; break;
    case 5: r_gy[pick(n)] = (real_t)nonfinite(); break;
    case 6: if (pick(2)) s0 = nonfinite(); else ds = nonfinite(); break;
    case 7: { static const double bad[5] = {0.0, -0.0, -2.0, 4.9e-324, 1e300}; ds = bad[pick(5)]; } break;
    default: r_kappa[pick(n)] = (real_t)extreme(); break;
  }
  if (n < 2 || n > ROAD_MAX || !k || !y) {
    want = U_(_ERR_ROAD_SIZE);
  } else if (!isfinite((real_t)s0) || !isfinite((real_t)ds) || !all_finite(k, n) || !all_finite(p, n) ||
             !all_finite(x, n) || !all_finite(y, n)) {
    want = U_(_ERR_NONFINITE_ROAD);
  } else if (!((real_t)ds > 0)) {
    want = U_(_ERR_ROAD_SIZE);
  } else {
    want = U_(_OK);
  }
  if (called(S_(_set_road)((real_t)s0, (real_t)ds, n, k, p, x, y), want) == U_(_OK))
    road_since_init = n < ROAD_WINDOW ? 1 : 2;
  return 0;
}

static int r_set_opponents(void) {
  int i, j, kind = pick(5), want;
  memcpy(r_opp, g_opp[pick(K_GOOD)], sizeof r_opp);
  if (kind == 0) { /* every opponent on the ego, at every stage */
    for (j = 0; j < (N + 1) * NOPP; ++j) {
      r_opp[j * NOPP_PAR] = last_x0[0];
      r_opp[j * NOPP_PAR + 1] = last_x0[1];
      r_opp[j * NOPP_PAR + 2] = last_x0[2];
    }
  } else if (kind == 1) {
    for (i = 0; i < 1 + pick(4); ++i) r_opp[pick(OPP_BLOCK > 0 ? OPP_BLOCK : 1)] = (real_t)extreme();
  } else if (kind == 2) {
    r_opp[pick(OPP_BLOCK > 0 ? OPP_BLOCK : 1)] = (real_t)nonfinite();
  }
  if (kind == 3 && pick(2)) return called(S_(_set_opponents)(NULL), NOPP ? U_(_ERR_NONFINITE_OPPONENTS) : U_(_OK));
  want = (NOPP == 0 || all_finite(r_opp, OPP_BLOCK)) ? U_(_OK) : U_(_ERR_NONFINITE_OPPONENTS);
  return called(S_(_set_opponents)(r_opp), want);
}

static int check_feedback_ok(void) {
  real_t u[NU];
  status_t st;
  S_(_get_u0)(u);
  S_(_get_status)(&st);
  if (!all_finite(u, NU)) violation(&v_nonfinite_u, "OK feedback with a non-finite u0", 0, 0);
  if (st.qp_status != U_(_QP_SOLVED) && st.qp_status != U_(_QP_SOLVED_INACCURATE) && st.qp_status != U_(_QP_MAX_ITER))
    contract(&g_ok_unusable, "OK feedback with an unusable QP status", st.qp_status, st.qp_raw_status);
  if (!(fabs((double)u[0]) <= FUZZ_F_D_MAX) || !(fabs((double)u[1]) <= FUZZ_R_MAX))
    contract(&g_u_out_of_box, "OK feedback with u0 outside the input box", (double)u[0], (double)u[1]);
  return 0;
}

static int r_prepare(void) {
  int want = -1, rc;
  /* exact only when certainly not prepared (a prepare while prepared is a no-op under the contract) */
  if (prep == 0 && !S_(_has_guess)() && !state_since_init) want = U_(_ERR_NO_STATE);
  else if (prep == 0 && road_since_init < 2) want = U_(_ERR_ROAD_WINDOW);
  rc = called(S_(_prepare)(), want);
  if (rc == U_(_OK)) prep = 1;
  else if (prep == 1) prep = 2; /* failed: today unprepared, transactional: as before */
  return rc;
}

static int r_feedback(void) {
  int rc = called(S_(_feedback)(), prep == 0 ? U_(_ERR_NOT_PREPARED) : -1);
  if (rc == U_(_OK)) {
    ++n_fb_ok;
    check_feedback_ok();
    prep = 0;
  } else if (rc == U_(_ERR_NOT_PREPARED)) {
    prep = 0;
  } else {
    ++n_fb_err;
    prep = 2;
  }
  return rc;
}

static void r_getters(void) {
  real_t u[NU], x[NSTATES], uu[N * NU];
  const real_t *q, *l, *uq, *ax, *px, *z, *y;
  status_t st;
  volatile real_t sink;
  S_(_get_u0)(u);
  S_(_get_states)(x);
  S_(_get_controls)(uu);
  S_(_get_status)(&st);
  S_(_get_status)(NULL);
  S_(_get_qp)(&q, &l, &uq, &ax, &px, &z, &y);
  S_(_get_qp)(NULL, NULL, NULL, NULL, NULL, NULL, NULL);
  sink = S_(_max_slack)() + (real_t)S_(_has_guess)() + q[0] + l[0] + uq[0] + ax[0] + px[0] + (z ? z[0] : 0) + y[0];
  (void)sink;
  n_calls += 10;
}

static void garbage_call(void) {
  switch (pick(12)) {
    case 0: case 1: r_set_state(); break;
    case 2: case 3: r_set_road(); break;
    case 4: r_set_opponents(); break;
    case 5: case 6: r_prepare(); break;
    case 7: case 8: r_feedback(); break;
    case 9: S_(_reset)(); ++n_calls; restarted(); break;
    case 10: if (pick(4) == 0) { called(S_(_init)(), U_(_OK)); inited(); } else r_getters(); break;
    default: called(set_good_road(), U_(_OK)); road_since_init = 2; break;
  }
}

/* ------------------------------------------------------------------------------------------------ good sequence */
static real_t ref_u[K_GOOD][NU], ref_x[K_GOOD][NSTATES];
static int ref_rc[K_GOOD][2];

/* a call the solver must reject without any effect but status.exit_code (noise mode A); unprepared: the solver is
 * certainly not prepared (then feedback is one of them) */
static void reject_one(int unprepared) {
  real_t x[5];
  int i;
  switch (pick(unprepared ? 7 : 6)) {
    case 0:
      memcpy(x, last_x0, sizeof x);
      x[pick(5)] = (real_t)nonfinite();
      called(S_(_set_state)(x), U_(_ERR_NONFINITE_STATE));
      break;
    case 1: called(S_(_set_state)(NULL), U_(_ERR_NO_STATE)); break;
    case 2: called(S_(_set_road)((real_t)G_S0, (real_t)FUZZ_DS, pick(2) ? 1 : ROAD_MAX + 1, g_kappa, g_phi, g_gx, g_gy),
                   U_(_ERR_ROAD_SIZE)); break;
    case 3:
      for (i = 0; i < ROAD_MAX; ++i) r_gy[i] = g_gy[i];
      r_gy[pick(ROAD_MAX)] = (real_t)nonfinite();
      called(S_(_set_road)((real_t)G_S0, (real_t)FUZZ_DS, ROAD_MAX, g_kappa, g_phi, g_gx, r_gy), U_(_ERR_NONFINITE_ROAD));
      break;
    case 4:
      if (NOPP == 0) break;
      memcpy(r_opp, g_opp[0], sizeof r_opp);
      r_opp[pick(OPP_BLOCK > 0 ? OPP_BLOCK : 1)] = (real_t)nonfinite();
      called(S_(_set_opponents)(pick(2) ? r_opp : NULL), U_(_ERR_NONFINITE_OPPONENTS));
      break;
    case 5: r_getters(); break;
    default: called(S_(_feedback)(), U_(_ERR_NOT_PREPARED)); break; /* wrong order: feedback before prepare */
  }
}

/* noise mode B adds calls that fail (or repeat) inside the solver: a prepare on a road that does not cover the
 * horizon (then the good road again) before the sample's prepare, and a second prepare after it. The contract: the
 * solver is as before such a call (a second prepare is an error or a no-op).
 * where: 0 before set_opponents, 1 before prepare (the state is set), 2 after a successful prepare; unprepared:
 * the solver is certainly not prepared. */
static void noise(int mode, int where, int unprepared) {
  int i, count = pick(3);
  for (i = 0; i < count; ++i) {
    if (mode == 1 && where > 0 && pick(3) == 0) {
      if (where == 2) {
        called(S_(_prepare)(), -1); /* prepare twice: an error or a no-op */
      } else {
        called(S_(_set_road)((real_t)G_S0, (real_t)FUZZ_DS, ROAD_WINDOW - 1, g_kappa, g_phi, g_gx, g_gy), U_(_OK));
        called(S_(_prepare)(), U_(_ERR_ROAD_WINDOW));
        called(set_good_road(), U_(_OK));
      }
    } else {
      reject_one(unprepared);
    }
  }
}

/* the good sequence; record: store as the reference, else compare. Returns the number of differing samples. */
static int run_good(int mode, int record, int strict, long *gap_counter) {
  int k, rc_p, rc_f, bad = 0, prev_ok = 1;
  real_t u[NU], x[NSTATES];
  for (k = 0; k < K_GOOD; ++k) {
    if (called(set_good_road(), U_(_OK)) != U_(_OK)) violation(&v_good_rejected, "good road rejected", k, 0);
    if (mode >= 0) noise(mode, 0, prev_ok);
    if (called(S_(_set_opponents)(g_opp[k]), U_(_OK))) violation(&v_good_rejected, "good opponents rejected", k, 0);
    if (!S_(_has_guess)() && called(S_(_set_state)(g_x[k]), U_(_OK)))
      violation(&v_good_rejected, "good state rejected", k, 0);
    if (mode >= 0) noise(mode, 1, prev_ok);
    rc_p = called(S_(_prepare)(), -1);
    if (mode >= 0 && rc_p == U_(_OK)) noise(mode, 2, 0);
    if (called(S_(_set_state)(g_x[k]), U_(_OK))) violation(&v_good_rejected, "good state rejected", k, 1);
    rc_f = called(S_(_feedback)(), -1);
    if (rc_f == U_(_OK)) {
      ++n_fb_ok;
      check_feedback_ok();
    }
    prev_ok = rc_f == U_(_OK);
    S_(_get_u0)(u);
    S_(_get_states)(x);
    if (record) {
      memcpy(ref_u[k], u, sizeof u);
      memcpy(ref_x[k], x, sizeof x);
      ref_rc[k][0] = rc_p;
      ref_rc[k][1] = rc_f;
      if (rc_p || rc_f) violation(&v_good_rejected, "the good sequence fails on the fresh solver", rc_p, rc_f);
      continue;
    }
    ++n_checked;
    if (memcmp(u, ref_u[k], sizeof u) || memcmp(x, ref_x[k], sizeof x) || rc_p != ref_rc[k][0] ||
        rc_f != ref_rc[k][1]) {
      double du = fabs((double)u[0] - (double)ref_u[k][0]);
      if (du > g_max_du || du != du) g_max_du = du;
      ++bad;
      if (strict) violation(&v_mismatch, "good sequence differs from the fresh solver's (sample, restart)", k, mode);
      else contract(gap_counter, "good sequence differs from the fresh solver's", k, mode);
    } else {
      ++n_equal;
    }
  }
  return bad;
}

/* ------------------------------------------------------------------------------------------------ main */
int main(int argc, char **argv) {
  unsigned long long seed;
  long e, episodes;
  int c;
  if (argc != 3 || sscanf(argv[1], "%llu", &seed) != 1 || sscanf(argv[2], "%ld", &episodes) != 1 || episodes < 0) {
    fprintf(stderr, "usage: %s SEED EPISODES\n", argv[0]);
    return 2;
  }
  rng_state = (uint64_t)seed;
  make_good();
  run_good(-1, 1, 1, NULL); /* the reference: the fresh (zero-initialised) solver */
  called(S_(_init)(), U_(_OK));
  inited();
  run_good(-1, 0, 1, NULL); /* init() == fresh, no noise */
  after_good();
  for (e = 0; e < episodes; ++e) {
    int restart = pick(2), mode = pick(2);
    ++n_episodes;
    for (c = 0; c < GARBAGE; ++c) garbage_call();
    if (restart == 0) {
      called(S_(_init)(), U_(_OK));
      inited();
    } else {
      S_(_reset)();
      ++n_calls;
      restarted();
    }
    run_good(mode, 0, restart == 0 && mode == 0, restart ? &g_mismatch_reset : &g_mismatch_modeb);
    after_good();
  }
  printf("seed %llu\nepisodes %ld\ncontract_checks %s\n", seed, n_episodes, CONTRACT ? "on" : "measured");
  printf("calls %ld\ninvalid_calls %ld\nrejected_with_expected_code %ld\n", n_calls, n_invalid, n_rejected_ok);
  for (c = 0; c < MAX_CODE; ++c)
    if (n_rc[c]) printf("rc %s %ld\n", code_name(c) ? code_name(c) : "unknown", n_rc[c]);
  printf("feedback_ok %ld\nfeedback_failed %ld\n", n_fb_ok, n_fb_err);
  printf("bitwise_checked %ld\nbitwise_equal %ld\n", n_checked, n_equal);
  printf("violation_wrong_code %ld\nviolation_status %ld\nviolation_nonfinite_u %ld\nviolation_mismatch %ld\n"
         "violation_good_rejected %ld\n", v_wrong_code, v_status, v_nonfinite_u, v_mismatch, v_good_rejected);
  printf("%s_ok_unusable_qp %ld\n%s_u_outside_box %ld\n%s_reset_not_fresh %ld\n%s_failed_call_not_transactional %ld\n",
         CONTRACT ? "violation" : "gap", g_ok_unusable, CONTRACT ? "violation" : "gap", g_u_out_of_box,
         CONTRACT ? "violation" : "gap", g_mismatch_reset, CONTRACT ? "violation" : "gap", g_mismatch_modeb);
  printf("max_abs_du0_of_differing_samples %.6g\n", g_max_du);
  printf("gaps %ld\nviolations %ld\n", gaps, violations);
  return violations ? 1 : 0;
}
