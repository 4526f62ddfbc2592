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
 *   3. the good sequence again with calls interleaved that must leave the solver as it was ("noise": rejected
 *      setters, feedback before prepare, getters; in mode B also a prepare on a road that does not cover the horizon
 *      and a second prepare), compared bitwise (memcmp of get_u0, get_states and the return codes) with the
 *      reference: reset() and init() give what a fresh solver gives, a rejected call changes nothing.
 * Checks on every call (the safety contract of <name>_solver.h): no crash (and, built with
 * -fsanitize=address,undefined, no sanitizer report); every invalid call rejected with its code, get_status's
 * exit_code equal to it, only documented codes; a rejected call leaves get_u0, the plan and the status (apart from
 * exit_code) as they were; prepare while prepared is a no-op returning OK; a feedback that consumes the sample
 * returns the code of its QP status (OK only for a usable one); get_u0 is always inside the input box and equal to
 * the plan's u0 projected on it, with u_projected/u_violation saying so; after an unusable QP the plan is the
 * shifted previous plan (zeros on a cold start, also the cold restart after COLD_RESTART_AFTER unusable QPs in a
 * row, which happens exactly then), so get_u0 is the fallback.
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

#if !defined(FUZZ_F_D_MAX) || !defined(FUZZ_R_MAX) || !defined(FUZZ_DS)
#error "compile with -DSOLVER=<name> -DSOLVER_UPPER=<NAME> -DFUZZ_F_D_MAX=.. -DFUZZ_R_MAX=.. -DFUZZ_DS=.."
#endif

#include "fuzz_common.h" /* the solver's names and sizes, rnd, pick, unif, nonfinite, qp_outcome */

#define ROAD_WINDOW U_(_ROAD_WINDOW)
#define NSTATES ((N + 1) * NX)

#if NOPP_PAR != 3
#error "fuzz_api.c places opponents as Cartesian poses (x, y, phi): use a lifted or direct-elimination solver"
#endif

#define K_GOOD 8 /* samples of the good sequence */
#define GARBAGE 40 /* random calls per episode before the restart */
#define G_S0 (-20.0)

/* ------------------------------------------------------------------------------------------------ random */
static double extreme(void) {
  static const double v[10] = {1e15, -1e15, 1e300, -1e300, DBL_MAX, 4.9e-324, -4.9e-324, 1e-310, -0.0, 1e30};
  return v[pick(10)];
}

/* ------------------------------------------------------------------------------------------------ counts */
static long n_calls, n_invalid, n_rejected_ok, n_rc[MAX_CODE], n_qs[MAX_CODE];
static long n_fb_ok, n_fb_unusable, n_fb_input_bounds, n_projected, n_fallback_checked, n_checked, n_equal, n_episodes,
    n_cold_restarts;
static long violations;
static long v_wrong_code, v_status, v_changed, v_box, v_qp_code, v_fallback, v_mismatch, v_good_rejected;
static double max_u_violation, max_du_mismatch;

static void violation(long *counter, const char *what, double a, double b) {
  ++*counter;
  if (++violations <= 10) fprintf(stderr, "violation: %s (%.17g, %.17g)\n", what, a, b);
}

static const char *code_name(int rc) {
  switch (rc) {
  case U_(_OK):
    return "OK";
  case U_(_ERR_NOT_PREPARED):
    return "ERR_NOT_PREPARED";
  case U_(_ERR_NO_STATE):
    return "ERR_NO_STATE";
  case U_(_ERR_NONFINITE_STATE):
    return "ERR_NONFINITE_STATE";
  case U_(_ERR_NONFINITE_OPPONENTS):
    return "ERR_NONFINITE_OPPONENTS";
  case U_(_ERR_NONFINITE_ROAD):
    return "ERR_NONFINITE_ROAD";
  case U_(_ERR_ROAD_WINDOW):
    return "ERR_ROAD_WINDOW";
  case U_(_ERR_ROAD_SIZE):
    return "ERR_ROAD_SIZE";
  case U_(_ERR_QP):
    return "ERR_QP";
  case U_(_ERR_QP_INFEASIBLE):
    return "ERR_QP_INFEASIBLE";
  case U_(_ERR_QP_DUAL_INFEASIBLE):
    return "ERR_QP_DUAL_INFEASIBLE";
  case U_(_ERR_QP_NONCONVEX):
    return "ERR_QP_NONCONVEX";
  case U_(_ERR_QP_NONFINITE):
    return "ERR_QP_NONFINITE";
  case U_(_ERR_QP_NUMERICAL):
    return "ERR_QP_NUMERICAL";
  case U_(_ERR_OPP_FRENET):
    return "ERR_OPP_FRENET";
  case U_(_ERR_QP_INPUT_BOUNDS):
    return "ERR_QP_INPUT_BOUNDS";
  default:
    return NULL;
  }
}

static const char *qp_status_name(int qs) {
  switch (qs) {
  case 0:
    return "QP_NONE";
  case U_(_QP_SOLVED):
    return "QP_SOLVED";
  case U_(_QP_SOLVED_INACCURATE):
    return "QP_SOLVED_INACCURATE";
  case U_(_QP_MAX_ITER):
    return "QP_MAX_ITER";
  case U_(_QP_PRIMAL_INFEASIBLE):
    return "QP_PRIMAL_INFEASIBLE";
  case U_(_QP_DUAL_INFEASIBLE):
    return "QP_DUAL_INFEASIBLE";
  case U_(_QP_NONCONVEX):
    return "QP_NONCONVEX";
  case U_(_QP_NONFINITE):
    return "QP_NONFINITE";
  case U_(_QP_NUMERICAL):
    return "QP_NUMERICAL";
  case U_(_QP_OTHER):
    return "QP_OTHER";
  default:
    return NULL;
  }
}

/* the QP outcome contract: the code a feedback that solved a QP returns for its status (a usable status may also
 * give ERR_QP_INPUT_BOUNDS: its step's u0 was beyond the input box by more than MAX_INPUT_VIOLATION) */
static int qp_exit(int qs) {
  switch (qs) {
  case U_(_QP_SOLVED):
  case U_(_QP_SOLVED_INACCURATE):
  case U_(_QP_MAX_ITER):
    return U_(_OK);
  case U_(_QP_PRIMAL_INFEASIBLE):
    return U_(_ERR_QP_INFEASIBLE);
  case U_(_QP_DUAL_INFEASIBLE):
    return U_(_ERR_QP_DUAL_INFEASIBLE);
  case U_(_QP_NONCONVEX):
    return U_(_ERR_QP_NONCONVEX);
  case U_(_QP_NONFINITE):
    return U_(_ERR_QP_NONFINITE);
  case U_(_QP_NUMERICAL):
    return U_(_ERR_QP_NUMERICAL);
  default:
    return U_(_ERR_QP);
  }
}

/* what a rejected call must not change */
typedef struct {
  real_t u0[NU], x[NSTATES], u[N * NU];
  status_t st;
} snap_t;

static void take(snap_t *sn) {
  memset(sn, 0, sizeof *sn); /* padding of the status struct too, for memcmp */
  S_(_get_u0)(sn->u0);
  S_(_get_states)(sn->x);
  S_(_get_controls)(sn->u);
  S_(_get_status)(&sn->st);
}

static void unchanged(const snap_t *before, const char *what) {
  snap_t now;
  take(&now);
  now.st.exit_code = before->st.exit_code;
  if (memcmp(before->u0, now.u0, sizeof now.u0) || memcmp(before->x, now.x, sizeof now.x) ||
      memcmp(before->u, now.u, sizeof now.u))
    violation(&v_changed, what, 0, 0);
  if (before->st.qp_status != now.st.qp_status || before->st.qp_raw_status != now.st.qp_raw_status ||
      before->st.qp_iter != now.st.qp_iter || before->st.u_projected != now.st.u_projected ||
      memcmp(&before->st.u_violation, &now.st.u_violation, sizeof now.st.u_violation))
    violation(&v_changed, "a rejected call changed the status", before->st.qp_status, now.st.qp_status);
}

static const real_t U_LIMIT[2] = {(real_t)FUZZ_F_D_MAX, (real_t)FUZZ_R_MAX};

/* get_u0 is the plan's u0 projected on the box, inside it, and the status reports the projection (same arithmetic) */
static void check_applied(void) {
  real_t u0[NU], plan[N * NU], v, lo, hi, want, excess, worst = 0.0;
  status_t st;
  int i;
  S_(_get_u0)(u0);
  S_(_get_controls)(plan);
  S_(_get_status)(&st);
  for (i = 0; i < NU; ++i) {
    if (!(fabs((double)u0[i]) <= (double)U_LIMIT[i])) violation(&v_box, "get_u0 outside the input box", i, u0[i]);
    v = plan[i];
    lo = -U_LIMIT[i];
    hi = U_LIMIT[i];
    want = v < lo ? lo : (v > hi ? hi : v);
    excess = v < lo ? (lo - v) / U_LIMIT[i] : (v > hi ? (v - hi) / U_LIMIT[i] : 0.0);
    if (excess > worst) worst = excess;
    if (memcmp(&want, &u0[i], sizeof want)) violation(&v_box, "get_u0 is not the plan's u0 projected", v, u0[i]);
  }
  if (st.u_projected != (worst > 0.0) || !((double)st.u_violation == (double)worst))
    violation(&v_box, "u_projected/u_violation do not describe the projection", st.u_violation, worst);
}

/* the plan the last real prepare shifted (or none: cold start), for the fallback check */
static real_t prev_x[NSTATES], prev_u[N * NU];
static int prev_cold, prev_known;

/* after a feedback that solved a QP: its code is the contract's for its status; an unusable QP leaves the
 * shifted previous plan (the initial guess's zero controls on a cold start) */
static void check_qp_outcome(int rc) {
  real_t x[NSTATES], u[N * NU];
  status_t st;
  int i;
  S_(_get_status)(&st);
  if (st.qp_status >= 0 && st.qp_status < MAX_CODE) ++n_qs[st.qp_status];
  if (!qp_status_name(st.qp_status)) violation(&v_qp_code, "undocumented QP status", st.qp_status, rc);
  if (rc == U_(_ERR_QP_INPUT_BOUNDS) ? qp_exit(st.qp_status) != U_(_OK) : rc != qp_exit(st.qp_status))
    violation(&v_qp_code, "exit code is not the QP status's (code, status)", rc, st.qp_status);
  check_applied();
  if (st.u_projected) ++n_projected;
  if ((double)st.u_violation > max_u_violation) max_u_violation = (double)st.u_violation;
  if (rc == U_(_OK)) {
    ++n_fb_ok;
    if (!((double)st.u_violation <= U_(_MAX_INPUT_VIOLATION)))
      violation(&v_box, "OK with u0 beyond the input box by more than MAX_INPUT_VIOLATION", st.u_violation,
                U_(_MAX_INPUT_VIOLATION));
    return;
  }
  ++n_fb_unusable;
  if (rc == U_(_ERR_QP_INPUT_BOUNDS)) ++n_fb_input_bounds;
  if (!prev_known) return;
  ++n_fallback_checked;
  S_(_get_states)(x);
  S_(_get_controls)(u);
  if (prev_cold) {
    for (i = 0; i < N * NU; ++i)
      if (u[i] != 0.0) violation(&v_fallback, "cold-start fallback plan has a non-zero control", i, u[i]);
  } else if (memcmp(u, prev_u + NU, sizeof(real_t) * (N - 1) * NU) || memcmp(x, prev_x + NX, sizeof(real_t) * N * NX)) {
    violation(&v_fallback, "plan after an unusable QP is not the shifted previous plan", rc, st.qp_status);
  }
}

/* every call that returns a code goes through here; want < 0: any documented code */
static int called(int rc, int want) {
  status_t st;
  ++n_calls;
  if (rc >= 0 && rc < MAX_CODE) ++n_rc[rc];
  if (!code_name(rc)) {
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

/* ------------------------------------------------------------------------------------------------ calls */
/* what the harness knows about the solver (the contract makes it exact) */
static int state_since_init; /* a set_state was accepted since init (or since the start) */
static int
    road_since_init; /* 0: none accepted since init, 1: the last accepted one is shorter than a window, 2: other */
static int prep; /* 1: a preparation is pending (prepared, no feedback since) */
static snap_t before;

static void restarted(void) {
  prep = 0;
  prev_known = 0;
}
static void inited(void) {
  restarted();
  state_since_init = 0;
  road_since_init = 0;
}
static void after_good(void) { /* the good sequence set a state and the good road; its last call was a feedback */
  state_since_init = 1;
  road_since_init = 2;
  prep = 0;
}

/* a setter (or any call whose error is a rejection): a rejected call changes nothing but exit_code */
static int setter(int rc, int want) {
  called(rc, want);
  if (rc != U_(_OK)) unchanged(&before, "a rejected call changed the solver");
  check_applied();
  return rc;
}
#define SET(expr, want) (take(&before), setter((expr), (want)))

static int do_prepare(int want) {
  int rc, had_guess = S_(_has_guess)();
  take(&before);
  rc = called(S_(_prepare)(), want);
  if (rc != U_(_OK)) {
    unchanged(&before, "a failed prepare changed the plan or the status");
  } else if (prep) {
    unchanged(&before, "prepare while prepared is not a no-op");
  } else {
    status_t st;
    int due = had_guess && U_(_COLD_RESTART_AFTER) > 0 && before.st.qp_unusable_run >= U_(_COLD_RESTART_AFTER);
    S_(_get_status)(&st);
    if (st.cold_restarts != before.st.cold_restarts + due || (due && st.qp_unusable_run != 0))
      violation(&v_fallback, "cold restart not after COLD_RESTART_AFTER unusable QPs in a row",
                before.st.qp_unusable_run, st.cold_restarts);
    memcpy(prev_x, before.x, sizeof prev_x); /* the plan this preparation shifted */
    memcpy(prev_u, before.u, sizeof prev_u);
    prev_cold = !had_guess || due; /* a cold start: no plan, or the cold restart */
    n_cold_restarts += due;
    prev_known = 1;
    prep = 1;
  }
  check_applied();
  return rc;
}

static int do_feedback(int want) {
  int rc;
  take(&before);
  rc = called(S_(_feedback)(), want);
  if (qp_outcome(rc)) {
    if (!prep) violation(&v_wrong_code, "a QP outcome without a pending preparation", rc, 0);
    check_qp_outcome(rc);
    prep = 0;
  } else {
    unchanged(&before, "a rejected feedback changed the solver");
    if (prep && rc == U_(_ERR_NOT_PREPARED)) violation(&v_wrong_code, "ERR_NOT_PREPARED while prepared", rc, 0);
    check_applied();
  }
  return rc;
}

static void do_reset(int init) {
  if (init) {
    called(S_(_init)(), U_(_OK));
    inited();
  } else {
    S_(_reset)();
    ++n_calls;
    restarted();
  }
  check_applied();
}

/* ------------------------------------------------------------------------------------------------ random calls */
static void r_set_state(void) {
  real_t x[5];
  int i, kind = pick(4);
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
  if (kind == 3 && pick(2)) {
    SET(S_(_set_state)(NULL), U_(_ERR_NO_STATE));
  } else if (SET(S_(_set_state)(x), all_finite(x, 5) ? U_(_OK) : U_(_ERR_NONFINITE_STATE)) == U_(_OK)) {
    memcpy(last_x0, x, sizeof x);
    state_since_init = 1;
  }
}

static void r_set_road(void) {
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
  case 0:
    s0 += unif(-300.0, 300.0);
    break; /* shifted: may not cover the ego */
  case 1:
    n = 2 + pick(ROAD_WINDOW - 2 > 0 ? ROAD_WINDOW - 2 : 1);
    break; /* shorter than one window */
  case 2:
    for (i = 0; i < n; ++i) r_kappa[i] = (real_t)unif(-1.0, 1.0);
    break;
  case 3: {
    static const int bad[5] = {0, 1, -3, ROAD_MAX + 1, 2147483647};
    n = bad[pick(5)];
  } break;
  case 4:
    if (pick(2))
      k = NULL;
    else
      y = NULL;
    break;
  case 5:
    r_gy[pick(n)] = (real_t)nonfinite();
    break;
  case 6:
    if (pick(2))
      s0 = nonfinite();
    else
      ds = nonfinite();
    break;
  case 7: {
    static const double bad[5] = {0.0, -0.0, -2.0, 4.9e-324, 1e300};
    ds = bad[pick(5)];
  } break;
  default:
    r_kappa[pick(n)] = (real_t)extreme();
    break;
  }
  if (n < 2 || n > ROAD_MAX || !k || !y) {
    want = U_(_ERR_ROAD_SIZE);
  } else if (!isfinite((real_t)s0) || !isfinite((real_t)ds) || !all_finite(k, n) || !all_finite(p, n) ||
             !all_finite(x, n) || !all_finite(y, n)) {
    want = U_(_ERR_NONFINITE_ROAD);
  } else if (!((real_t)ds >= (real_t)1e-3 && (real_t)ds <= (real_t)100.0)) { /* fcgen.contract.INPUT_RANGES */
    want = U_(_ERR_ROAD_SIZE);
  } else {
    want = U_(_OK);
  }
  if (SET(S_(_set_road)((real_t)s0, (real_t)ds, n, k, p, x, y), want) == U_(_OK))
    road_since_init = n < ROAD_WINDOW ? 1 : 2;
}

static void r_set_opponents(void) {
  int i, j, kind = pick(5);
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
  if (kind == 3 && pick(2))
    SET(S_(_set_opponents)(NULL), NOPP ? U_(_ERR_NONFINITE_OPPONENTS) : U_(_OK));
  else
    SET(S_(_set_opponents)(r_opp),
        (NOPP == 0 || all_finite(r_opp, OPP_BLOCK)) ? U_(_OK) : U_(_ERR_NONFINITE_OPPONENTS));
}

static void r_prepare(void) {
  int want = -1;
  if (prep)
    want = U_(_OK); /* a no-op */
  else if (!S_(_has_guess)() && !state_since_init)
    want = U_(_ERR_NO_STATE);
  else if (road_since_init < 2)
    want = U_(_ERR_ROAD_WINDOW);
  do_prepare(want);
}

static void r_getters(void) {
  real_t u[NU], x[NSTATES], uu[N * NU];
  const real_t *q, *l, *uq, *ax, *px, *z, *y;
  status_t st;
  volatile real_t sink;
  take(&before);
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
  unchanged(&before, "a getter changed the solver");
}

static void garbage_call(void) {
  switch (pick(12)) {
  case 0:
  case 1:
    r_set_state();
    break;
  case 2:
  case 3:
    r_set_road();
    break;
  case 4:
    r_set_opponents();
    break;
  case 5:
  case 6:
    r_prepare();
    break;
  case 7:
  case 8:
    do_feedback(prep ? -1 : U_(_ERR_NOT_PREPARED));
    break;
  case 9:
    do_reset(0);
    break;
  case 10:
    if (pick(4) == 0)
      do_reset(1);
    else
      r_getters();
    break;
  default:
    SET(set_good_road(), U_(_OK));
    road_since_init = 2;
    break;
  }
}

/* ------------------------------------------------------------------------------------------------ good sequence */
static real_t ref_u[K_GOOD][NU], ref_x[K_GOOD][NSTATES];
static int ref_rc[K_GOOD][2];

/* a call the solver must reject without any effect but status.exit_code; unprepared: feedback is one of them */
static void reject_one(int unprepared) {
  real_t x[5];
  int i;
  switch (pick(unprepared ? 7 : 6)) {
  case 0:
    memcpy(x, last_x0, sizeof x);
    x[pick(5)] = (real_t)nonfinite();
    SET(S_(_set_state)(x), U_(_ERR_NONFINITE_STATE));
    break;
  case 1:
    SET(S_(_set_state)(NULL), U_(_ERR_NO_STATE));
    break;
  case 2:
    SET(S_(_set_road)((real_t)G_S0, (real_t)FUZZ_DS, pick(2) ? 1 : ROAD_MAX + 1, g_kappa, g_phi, g_gx, g_gy),
        U_(_ERR_ROAD_SIZE));
    break;
  case 3:
    for (i = 0; i < ROAD_MAX; ++i) r_gy[i] = g_gy[i];
    r_gy[pick(ROAD_MAX)] = (real_t)nonfinite();
    SET(S_(_set_road)((real_t)G_S0, (real_t)FUZZ_DS, ROAD_MAX, g_kappa, g_phi, g_gx, r_gy), U_(_ERR_NONFINITE_ROAD));
    break;
  case 4:
    if (NOPP == 0) break;
    memcpy(r_opp, g_opp[0], sizeof r_opp);
    r_opp[pick(OPP_BLOCK > 0 ? OPP_BLOCK : 1)] = (real_t)nonfinite();
    SET(S_(_set_opponents)(pick(2) ? r_opp : NULL), U_(_ERR_NONFINITE_OPPONENTS));
    break;
  case 5:
    r_getters();
    break;
  default:
    do_feedback(U_(_ERR_NOT_PREPARED));
    break; /* wrong order: feedback before prepare */
  }
}

/* noise mode B adds calls that fail or repeat inside the solver: a prepare on a road that does not cover the horizon
 * (then the good road again) before the sample's prepare, and a second prepare (a no-op) after it.
 * where: 0 before set_opponents, 1 before prepare (the state is set), 2 after the sample's prepare. */
static void noise(int mode, int where) {
  int i, count = pick(3);
  for (i = 0; i < count; ++i) {
    if (mode == 1 && where > 0 && pick(3) == 0) {
      if (where == 2) {
        do_prepare(U_(_OK));
      } else {
        SET(S_(_set_road)((real_t)G_S0, (real_t)FUZZ_DS, ROAD_WINDOW - 1, g_kappa, g_phi, g_gx, g_gy), U_(_OK));
        do_prepare(U_(_ERR_ROAD_WINDOW));
        SET(set_good_road(), U_(_OK));
      }
    } else {
      reject_one(where < 2);
    }
  }
}

/* the good sequence (mode -1: without noise); record: store as the reference, else compare bitwise with it */
static void run_good(int mode, int record) {
  int k, rc_p, rc_f;
  real_t u[NU], x[NSTATES];
  for (k = 0; k < K_GOOD; ++k) {
    if (SET(set_good_road(), U_(_OK)) != U_(_OK)) violation(&v_good_rejected, "good road rejected", k, 0);
    if (mode >= 0) noise(mode, 0);
    if (SET(S_(_set_opponents)(g_opp[k]), U_(_OK))) violation(&v_good_rejected, "good opponents rejected", k, 0);
    if (!S_(_has_guess)() && SET(S_(_set_state)(g_x[k]), U_(_OK)))
      violation(&v_good_rejected, "good state rejected", k, 0);
    if (mode >= 0) noise(mode, 1);
    rc_p = do_prepare(-1);
    if (mode >= 0 && rc_p == U_(_OK)) noise(mode, 2);
    if (SET(S_(_set_state)(g_x[k]), U_(_OK))) violation(&v_good_rejected, "good state rejected", k, 1);
    rc_f = do_feedback(-1);
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
      if (du > max_du_mismatch || du != du) max_du_mismatch = du;
      violation(&v_mismatch, "good sequence differs from the fresh solver's (sample, noise mode)", k, mode);
    } else {
      ++n_equal;
    }
  }
}

/* ------------------------------------------------------------------------------------------------ main */
int main(int argc, char **argv) {
  unsigned long long seed;
  long e, episodes, n_reset = 0, n_init = 0;
  int c;
  if (argc != 3 || sscanf(argv[1], "%llu", &seed) != 1 || sscanf(argv[2], "%ld", &episodes) != 1 || episodes < 0) {
    fprintf(stderr, "usage: %s SEED EPISODES\n", argv[0]);
    return 2;
  }
  fz_rng = (uint64_t)seed;
  make_good();
  run_good(-1, 1); /* the reference: the fresh (zero-initialised) solver */
  after_good();
  do_reset(1);
  run_good(-1, 0); /* init() == fresh, no noise */
  after_good();
  for (e = 0; e < episodes; ++e) {
    int restart_init = pick(2);
    ++n_episodes;
    for (c = 0; c < GARBAGE; ++c) garbage_call();
    do_reset(restart_init);
    if (restart_init)
      ++n_init;
    else
      ++n_reset;
    run_good(pick(2), 0);
    after_good();
  }
  printf("seed %llu\nepisodes %ld\nrestarts_init %ld\nrestarts_reset %ld\n", seed, n_episodes, n_init, n_reset);
  printf("calls %ld\ninvalid_calls %ld\nrejected_with_expected_code %ld\n", n_calls, n_invalid, n_rejected_ok);
  for (c = 0; c < MAX_CODE; ++c)
    if (n_rc[c]) printf("rc %s %ld\n", code_name(c) ? code_name(c) : "unknown", n_rc[c]);
  for (c = 0; c < MAX_CODE; ++c)
    if (n_qs[c]) printf("qp %s %ld\n", qp_status_name(c) ? qp_status_name(c) : "unknown", n_qs[c]);
  printf("feedback_ok %ld\nfeedback_unusable_qp %ld\nfeedback_input_bounds %ld\nfallbacks_checked "
         "%ld\nfeedback_u_projected %ld\nmax_u_violation %.6g\n",
         n_fb_ok, n_fb_unusable, n_fb_input_bounds, n_fallback_checked, n_projected, max_u_violation);
  printf("bitwise_checked %ld\nbitwise_equal %ld\ncold_restarts %ld\n", n_checked, n_equal, n_cold_restarts);
  printf("violation_wrong_code %ld\nviolation_status %ld\nviolation_rejected_call_changed %ld\n"
         "violation_u_outside_box %ld\nviolation_qp_code %ld\nviolation_fallback %ld\nviolation_mismatch %ld\n"
         "violation_good_rejected %ld\n",
         v_wrong_code, v_status, v_changed, v_box, v_qp_code, v_fallback, v_mismatch, v_good_rejected);
  printf("max_abs_du0_of_differing_samples %.6g\nviolations %ld\n", max_du_mismatch, violations);
  return violations ? 1 : 0;
}
