/*
 * fuzz_contract.c -- random calls on every public entry of a generated fcgen solver, checked against a twin
 * (tests/test_fuzz_contract.py; the long run and the libFuzzer entry: docs/verification.md).
 *
 *   fuzz_contract SEED TRIALS [CALLS [WEIGHTS]]
 *
 * A trial is CALLS random calls (default 200) after init(): set_state, set_road, set_road_bounds, set_opponents,
 * set_opponent_shapes, set_reference (and its per-stage forms), set_clock, prepare, feedback, reset, init and every
 * getter, with valid, extreme (1e30, 1e-30, 0, negative, the type's largest and denormal values), NaN/inf and NULL
 * inputs. After each
 * call the solver's observable state (every getter's output, bit for bit) is hashed. Then the twin: init() again
 * and only the calls the fuzzed run accepted, replayed with the same inputs (a reset() replayed as init() plus the
 * inputs set since the last init, in their order: reset equals a fresh solver given the same inputs; where reset keeps
 * the actuator's memory, -DFUZZ_KEEPS=1 (a delay line, the drive force handed out last, the steering lag: what the
 * vehicle still has), replayed as reset()). Checks:
 *   - twin: after each call of the fuzzed run, its state equals the twin's after the accepted calls so far (a
 *     refused call leaves the solver bit for bit as it was; after a prepare refused with ERR_QP_NONFINITE only
 *     get_qp's u and A_x may differ, as the header says) and the twin's calls return the same codes;
 *   - status: status.exit_code is the code of the last call that can change the solver (getters leave it);
 *   - codes: every code is documented; a getter given NULL returns ERR_NULL_POINTER and changes nothing;
 *   - outputs: after a feedback that consumed its sample, get_u0 is finite and inside the input box; with opponents
 *     the plan check reports a stage (it checked every stage: never plan_clearance_stage = -1).
 * Built with -fsanitize=address,undefined (clang: also float-cast-overflow) -fno-sanitize-recover=all, a sanitizer
 * report aborts the run. WEIGHTS: how often kinds are drawn, "kind=w,..." with the names of the counts (the others keep
 * theirs: set_state 14, set_road 5, set_road_bounds 5, set_opponents 10, set_opponent_shapes 5, set_reference 5,
 * set_clock 2, prepare 16, feedback 16, reset 2, init 1, getter 12). Prints "key value" counts (per kind: calls, returned codes),
 * on stderr every 10 s "progress ..." and at the end the processor seconds per kind and the slowest call; exit 1 on
 * any violation, 2: usage.
 * -DFUZZ_LIBFUZZER: LLVMFuzzerTestOneInput instead of main (the input bytes drive the choices of one trial).
 * Build: -DSOLVER=<name> -DSOLVER_UPPER=<NAME> -DFUZZ_F_D_MAX= -DFUZZ_R_MAX= -DFUZZ_DS= -DFUZZ_N_MIN= -DFUZZ_N_MAX=
 *        [-DFUZZ_DELAY=<Problem.delay>] [-DFUZZ_KEEPS=1] -I<solver folder>, linked with lib<name>.a lib<name>_osqp.a -lm
 *        (tests/c/Makefile, target fuzz_contract).
 */
#include <float.h>
#include <math.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#if !defined(FUZZ_F_D_MAX) || !defined(FUZZ_R_MAX) || !defined(FUZZ_DS) || !defined(FUZZ_N_MIN) || !defined(FUZZ_N_MAX)
#error                                                                                                                 \
    "compile with -DSOLVER=<name> -DSOLVER_UPPER=<NAME> -DFUZZ_F_D_MAX= -DFUZZ_R_MAX= -DFUZZ_DS= -DFUZZ_N_MIN= -DFUZZ_N_MAX="
#endif

#include "fuzz_common.h" /* the solver's names and sizes, rnd, pick, unif, nonfinite, qp_outcome */

#define NOPP_STAGE U_(_NOPP_STAGE)
#define NOPP_SHAPE U_(_NOPP_SHAPE)
#define QP_N U_(_QP_N)
#define QP_M U_(_QP_M)
#define NNZ_A U_(_QP_NNZ_A)
#define SHAPE_BLOCK (NOPP * NOPP_SHAPE)
#ifndef FUZZ_DELAY
#define FUZZ_DELAY 0 /* Problem.delay of the solver */
#endif
#ifndef FUZZ_KEEPS
#define FUZZ_KEEPS (FUZZ_DELAY > 0) /* reset keeps the actuator's memory (fuzzbuild.defines) */
#endif
#if FUZZ_DELAY > 0
typedef char fz_delay_is_the_solvers[(U_(_DELAY) == FUZZ_DELAY) ? 1 : -1];
#endif
#define MAX_CALLS 1000
#define OK U_(_OK)
#ifdef FUZZ_VOID_GETTERS /* a solver of fcgen 0.20.0 (getters without a code): no NULL given to them */
#define ERR_NULL 19
#define GETRC(e) ((e), 0)
#define CODE_LAST ERR_NULL
#else
#define ERR_NULL U_(_ERR_NULL_POINTER)
#define GETRC(e) (e)
#define CODE_LAST U_(_ERR_MARGIN) /* the last documented code */
#endif

/* ---------------------------------------------------------------------------------------------- random */
/* an extreme value of the real type (no conversion out of its range) */
static real_t extreme(void) {
  static const double d[12] = {1e30, -1e30, 1e-30, -1e-30, 0.0, -0.0, -1.0, 1e300, -1e300, DBL_MAX, 4.9e-324, 1e-310};
  static const double f[10] = {1e30, -1e30, 1e-30, -1e-30, 0.0, -0.0, -1.0, 3.4e38, 1.4e-45, 1e-40};
  return (sizeof(real_t) == sizeof(double)) ? (real_t)d[pick(12)] : (real_t)f[pick(10)];
}
/* a valid value mostly, else an extreme or non-finite one or the valid one negated */
static real_t val(double valid) {
  const int m = pick(100);
  if (m < 85) return (real_t)valid;
  if (m < 93) return extreme();
  if (m < 97) return (real_t)nonfinite();
  return (real_t)-valid;
}
/* one entry of an array corrupted now and then */
static void corrupt(real_t *a, int n) {
  const int m = pick(100);
  if (n <= 0 || m >= 12) return;
  a[pick(n)] = (m < 8) ? extreme() : (real_t)nonfinite();
}

/* ---------------------------------------------------------------------------------------------- clocks */
static uint32_t clock_t0;
static uint32_t clock_a(void) {
  return clock_t0 += 0x9E3779B9u;
} /* wraps modulo 2^32 */
static uint32_t clock_b(void) {
  return clock_t0 += 7u;
}

/* ---------------------------------------------------------------------------------------------- calls */
enum {
  C_STATE,
  C_ROAD,
  C_BOUNDS,
  C_OPP,
  C_SHAPES,
  C_REF,
  C_CLOCK,
  C_PREPARE,
  C_FEEDBACK,
  C_RESET,
  C_INIT,
  C_GET,
  C_KINDS
};
/* how often each kind is drawn (relative); the command line may give others (a mix with fewer feedbacks) */
static int weight[C_KINDS] = {14, 5, 5, 10, 5, 5, 2, 16, 16, 2, 1, 12};
static const char *const KIND_NAME[C_KINDS] = {
    "set_state",     "set_road",  "set_road_bounds", "set_opponents", "set_opponent_shapes",
    "set_reference", "set_clock", "prepare",         "feedback",      "reset",
    "init",          "getter"};
static int is_input(int kind) {
  return kind <= C_REF;
}

static real_t a_kappa[ROAD_MAX], a_phi[ROAD_MAX], a_gx[ROAD_MAX], a_gy[ROAD_MAX], a_lo[ROAD_MAX], a_hi[ROAD_MAX];
static real_t a_opp[OPP_BLOCK + 1], a_shape[SHAPE_BLOCK + 1], a_x[5];
static status_t fz_st;
static real_t o_x[(N + 1) * NX], o_u[N * NU], o_p[(N + 1) * NOPP * NOPP_STAGE + 1], o_u0[NU];

static double base_s(int idx) {
  return 0.05 * idx;
} /* the ego drifts along the road during a trial */

static int call_road(int idx) {
  const int full = pick(100) < 75;
  const int n = full ? ROAD_MAX : 2 + pick(ROAD_MAX - 1);
  const double kap = (pick(100) < 60) ? 0.0 : unif(-0.01, 0.01);
  const double s0 = full ? -20.0 : base_s(idx) + unif(-30.0, 10.0);
  double ds = FUZZ_DS, phi = 0.0, x = s0, y = 0.0;
  int i;
  for (i = 0; i < n; ++i) {
    a_kappa[i] = (real_t)kap;
    a_phi[i] = (real_t)phi;
    a_gx[i] = (real_t)x;
    a_gy[i] = (real_t)y;
    x += ds * cos(phi + 0.5 * ds * kap);
    y += ds * sin(phi + 0.5 * ds * kap);
    phi += ds * kap;
  }
  corrupt(a_kappa, n);
  corrupt(a_phi, n);
  corrupt(a_gx, n);
  corrupt(a_gy, n);
  if (pick(100) < 10) ds = (double)extreme();
  if (pick(100) < 5) {
    const real_t *none = NULL;
    const int which = pick(4);
    return S_(_set_road)(val(s0), (real_t)ds, n, which == 0 ? none : a_kappa, which == 1 ? none : a_phi,
                         which == 2 ? none : a_gx, which == 3 ? none : a_gy);
  }
  return S_(_set_road)(val(s0), (real_t)ds, (pick(100) < 4) ? (pick(2) ? -1 : ROAD_MAX + 1) : n, a_kappa, a_phi, a_gx,
                       a_gy);
}

static int call_bounds(void) {
  const double w = FUZZ_N_MAX - FUZZ_N_MIN;
  int i;
  for (i = 0; i < ROAD_MAX; ++i) {
    a_lo[i] = (real_t)(FUZZ_N_MIN + unif(0.0, 0.45) * w);
    a_hi[i] = (real_t)(FUZZ_N_MAX - unif(0.0, 0.45) * w);
  }
  corrupt(a_lo, ROAD_MAX);
  corrupt(a_hi, ROAD_MAX);
  if (pick(100) < 5) return S_(_set_road_bounds)(pick(2) ? NULL : a_lo, a_hi);
  if (pick(100) < 5) return S_(_set_road_bounds)(a_hi, a_lo); /* swapped: lower > upper */
  return S_(_set_road_bounds)(a_lo, a_hi);
}

static int call_opp(int idx) {
  int k, j;
  for (j = 0; j < NOPP; ++j) {
    const double s = base_s(idx) + unif(-10.0, 60.0), n = unif(-3.0, 3.0), v = unif(0.0, 15.0);
    for (k = 0; k <= N; ++k) {
      real_t *p = &a_opp[(k * NOPP + j) * NOPP_PAR];
      p[0] = (real_t)(s + 0.1 * k * v);
      p[1] = (real_t)n;
      p[2] = (real_t)unif(-0.1, 0.1);
    }
  }
  corrupt(a_opp, OPP_BLOCK);
  if (pick(100) < 3) a_opp[pick(OPP_BLOCK)] = extreme();
  return S_(_set_opponents)(pick(100) < 4 ? NULL : a_opp);
}

static int call_shapes(void) {
  int j;
  for (j = 0; j < NOPP; ++j) {
    real_t *v = &a_shape[j * NOPP_SHAPE];
    const double l = unif(3.0, 18.0), w = unif(1.5, 2.6);
    v[0] = val(l);
    v[1] = val(w);
    v[2] = val(unif(-0.5, 0.5) * l);
#if NOPP_SHAPE > 3
    v[3] = val(0.5 * l + 4.0);
    v[4] = val(0.5 * w + 4.0);
#endif
  }
  return S_(_set_opponent_shapes)(pick(100) < 4 ? NULL : a_shape);
}

static int call_state(int idx) {
  a_x[0] = val(base_s(idx) + unif(-1.0, 1.0));
  a_x[1] = val(unif(-1.5, 1.5));
  a_x[2] = val(unif(-0.05, 0.05));
  a_x[3] = val(unif(3.0, 20.0));
  a_x[4] = val(unif(-0.02, 0.02));
  return S_(_set_state)(pick(100) < 4 ? NULL : a_x);
}

/* a getter with valid or NULL outputs: its return code (0 for those without one) */
static int call_get(void) {
#ifdef FUZZ_VOID_GETTERS
  const int null = 0;
#else
  const int null = pick(100) < 30;
#endif
  const real_t *q, *l, *u, *ax, *px, *z, *y;
  switch (pick(9)) {
  case 0:
    return GETRC(S_(_get_u0)(null ? NULL : o_u0));
  case 1:
    return GETRC(S_(_get_states)(null ? NULL : o_x));
  case 2:
    return GETRC(S_(_get_controls)(null ? NULL : o_u));
  case 3:
    return GETRC(S_(_get_opp_params)(null ? NULL : o_p));
  case 4:
    return GETRC(S_(_get_status)(null ? NULL : &fz_st));
  case 5:
    return GETRC(S_(_get_qp)(null ? NULL : &q, null ? NULL : &l, &u, &ax, null ? NULL : &px, &z, &y));
  case 6:
    return S_(_has_guess)() * 0;
  case 7:
    return (S_(_max_slack)() != (real_t)0) * 0;
  default:
    return GETRC(S_(_get_qp)(NULL, NULL, NULL, NULL, NULL, NULL, NULL));
  }
}

/* set_reference, or set_reference_stages / set_obstacle_margins (solvers that have them): per-stage values that
 * differ across stages, now and then one entry extreme, non-finite or out of range (a negative margin, n_ref beyond
 * the band), or NULL */
static real_t a_vref[N + 1], a_nref[N + 1], a_margin[N + 1];
static int call_reference(void) {
#ifndef FUZZ_VOID_GETTERS
  const int which = pick(3);
  const int null = pick(100) < 4 ? 1 + pick(2) : 0;
  int k;
  if (which == 1) {
    const double v0 = unif(0.0, 30.0), v1 = unif(0.0, 30.0), n0 = unif(-2.0, 2.0), n1 = unif(-2.0, 2.0);
    for (k = 0; k <= N; ++k) {
      a_vref[k] = (real_t)(v0 + (v1 - v0) * k / N);
      a_nref[k] = (real_t)(n0 + (n1 - n0) * k / N);
    }
    corrupt(a_vref, N + 1);
    corrupt(a_nref, N + 1);
    if (pick(100) < 3) a_nref[pick(N + 1)] = (real_t)(FUZZ_N_MAX + 0.5);
    return S_(_set_reference_stages)(null == 1 ? NULL : a_vref, null == 2 ? NULL : a_nref);
  }
  if (which == 2) {
    const double m0 = unif(0.0, 0.5), slope = unif(0.0, 0.1);
    for (k = 0; k <= N; ++k) a_margin[k] = (real_t)(m0 + slope * k);
    corrupt(a_margin, N + 1);
    if (pick(100) < 3) a_margin[pick(N + 1)] = (real_t)(pick(2) ? -0.1 : 1e3);
    return S_(_set_obstacle_margins)(null != 0 ? NULL : a_margin);
  }
#endif
  return S_(_set_reference)(val(unif(0.0, 30.0)), val(unif(-2.0, 2.0)));
}

/* the call of kind with inputs drawn from seed; idx: its place in the trial */
static int do_call(int kind, uint64_t seed, int idx) {
  const uint64_t keep = fz_rng;
  const size_t left = fz_stream_left;
  int rc = OK;
  fz_rng = seed;
  fz_stream_left = 0u; /* inputs from the seed only (the twin draws them again) */
  switch (kind) {
  case C_STATE:
    rc = call_state(idx);
    break;
  case C_ROAD:
    rc = call_road(idx);
    break;
  case C_BOUNDS:
    rc = call_bounds();
    break;
  case C_OPP:
    rc = call_opp(idx);
    break;
  case C_SHAPES:
    rc = call_shapes();
    break;
  case C_REF:
    rc = call_reference();
    break;
  case C_CLOCK: {
    const int c = pick(3);
    S_(_set_clock)(c == 0 ? NULL : (c == 1 ? clock_a : clock_b));
    break;
  }
  case C_PREPARE:
    rc = S_(_prepare)();
    break;
  case C_FEEDBACK:
    rc = S_(_feedback)();
    break;
  case C_RESET:
    S_(_reset)();
    break;
  case C_INIT:
    rc = S_(_init)();
    break;
  default:
    rc = call_get();
    break;
  }
  fz_rng = keep;
  fz_stream_left = left;
  return rc;
}

/* ---------------------------------------------------------------------------------------------- state */
/* a 64-bit hash of n bytes, 8 at a time (FNV-1a's step on words; any changed bit changes it but with
 * probability 2^-64) */
static uint64_t fnv(uint64_t h, const void *p, size_t n) {
  const unsigned char *b = (const unsigned char *)p;
  uint64_t w;
  size_t i;
  for (i = 0; i + 8u <= n; i += 8u) {
    memcpy(&w, b + i, 8u);
    h = (h ^ w) * 0x100000001B3ull;
    h ^= h >> 29;
  }
  for (; i < n; ++i) h = (h ^ b[i]) * 0x100000001B3ull;
  return h;
}

/* the observable state: every getter's output except status.exit_code (main) and get_qp's u, A_x (qp) */
static void observe(uint64_t *main_h, uint64_t *qp_h, int *exit_code) {
  status_t st;
  const real_t *q, *l, *u, *ax, *px, *z, *y;
  real_t slack;
  int g;
  uint64_t h = 0xCBF29CE484222325ull;
  memset(&st, 0, sizeof st);
  S_(_get_u0)(o_u0);
  S_(_get_states)(o_x);
  S_(_get_controls)(o_u);
  S_(_get_opp_params)(o_p);
  S_(_get_status)(&st);
  S_(_get_qp)(&q, &l, &u, &ax, &px, &z, &y);
  slack = S_(_max_slack)();
  g = S_(_has_guess)();
  *exit_code = st.exit_code;
  st.exit_code = 0;
  h = fnv(h, o_u0, sizeof o_u0);
  h = fnv(h, o_x, sizeof o_x);
  h = fnv(h, o_u, sizeof o_u);
  h = fnv(h, o_p, sizeof(real_t) * (N + 1) * NOPP * NOPP_STAGE);
  h = fnv(h, &st, sizeof st);
  h = fnv(h, q, sizeof(real_t) * QP_N);
  h = fnv(h, l, sizeof(real_t) * QP_M);
  h = fnv(h, px, sizeof(real_t) * QP_N);
  h = fnv(h, z, sizeof(real_t) * QP_N);
  h = fnv(h, y, sizeof(real_t) * QP_M);
  h = fnv(h, &slack, sizeof slack);
  *main_h = fnv(h, &g, sizeof g);
  *qp_h = fnv(fnv(0xCBF29CE484222325ull, u, sizeof(real_t) * QP_M), ax, sizeof(real_t) * NNZ_A);
}

/* ---------------------------------------------------------------------------------------------- checks */
static long n_calls, n_trials, n_refused, n_replayed, n_rc[MAX_CODE], n_kind[C_KINDS], n_fb_consumed, n_fb_ok, n_react,
    n_null_get, n_compared, n_qp_iter, max_qp_iter;
/* where the time goes (processor seconds, clock()): per kind in the fuzzed run, the twin's replay, the slowest call */
static double t_kind[C_KINDS], t_twin, t_slowest;
static int slowest_kind, slowest_idx;
static long slowest_trial;
static double seconds(clock_t a, clock_t b) {
  return (double)(b - a) / (double)CLOCKS_PER_SEC;
}

static long violations, v_code, v_status, v_twin, v_twin_rc, v_output, v_plan_check, v_null;

static void violation(long *counter, const char *what, int idx, double a, double b) {
  ++*counter;
  if (++violations <= 20) fprintf(stderr, "violation: %s (call %d: %.17g, %.17g)\n", what, idx, a, b);
}

/* the calls the header says change nothing but status.exit_code */
static int refused(int kind, int rc) {
  if (kind == C_FEEDBACK) return !qp_outcome(rc);
  if (kind == C_PREPARE) return rc != OK && rc != U_(_ERR_QP_NUMERICAL);
  if (kind == C_GET) return 1; /* a getter changes nothing at all */
  return rc != OK;
}

static void check_outputs(int idx, int rc) {
  real_t u0[NU];
  status_t st;
  const double lim[2] = {FUZZ_F_D_MAX, FUZZ_R_MAX};
  int i;
  ++n_fb_consumed;
  n_fb_ok += rc == OK;
  S_(_get_u0)(u0);
  S_(_get_status)(&st);
  for (i = 0; i < NU; ++i)
    if (!(fabs((double)u0[i]) <= lim[i])) violation(&v_output, "get_u0 not finite or outside the box", idx, i, u0[i]);
  if (NOPP > 0 && !(st.plan_clearance_stage >= 0 && st.plan_clearance_stage <= N))
    violation(&v_plan_check, "the plan check skipped stages (no stage reported)", idx, st.plan_clearance_stage,
              (double)st.plan_clearance);
  n_react += st.plan_reaction != 0;
  n_qp_iter += st.qp_iter;
  if (st.qp_iter > max_qp_iter) max_qp_iter = st.qp_iter;
}

typedef struct {
  int kind, rc, refused, exit_code, taint;
  uint64_t seed, h_main, h_qp;
} rec_t;
static rec_t recs[MAX_CALLS];

static void run_trial(int calls) {
  int i, total = 0, last_rc = OK, taint = 0, inputs[MAX_CALLS], n_inputs = 0;
  clock_t c0;
  double dt;
  for (i = 0; i < C_KINDS; ++i) total += weight[i];
  clock_t0 = 0u;
  S_(_set_clock)(NULL);
  (void)S_(_init)();
  for (i = 0; i < calls; ++i) { /* the fuzzed run */
    rec_t *r = &recs[i];
    int w = pick(total), kind = 0;
    while (w >= weight[kind]) w -= weight[kind++];
    r->kind = kind;
    r->seed = rnd();
    c0 = clock();
    r->rc = do_call(kind, r->seed, i);
    dt = seconds(c0, clock());
    t_kind[kind] += dt;
    if (dt > t_slowest) {
      t_slowest = dt;
      slowest_kind = kind;
      slowest_idx = i;
      slowest_trial = n_trials;
    }
    r->refused = refused(kind, r->rc);
    ++n_calls;
    ++n_kind[kind];
    n_refused += r->refused && kind != C_GET;
    if (r->rc >= 0 && r->rc < MAX_CODE) ++n_rc[r->rc];
    if (r->rc < 0 || r->rc > CODE_LAST) violation(&v_code, "undocumented code", i, kind, r->rc);
    if (kind == C_PREPARE && r->rc == U_(_ERR_QP_NONFINITE)) taint = 1;
    if ((kind == C_PREPARE && r->rc == OK) || kind == C_INIT) taint = 0;
    r->taint = taint;
    if (kind == C_GET) {
      if (r->rc != OK && r->rc != ERR_NULL) violation(&v_null, "a getter's code", i, r->rc, ERR_NULL);
      n_null_get += r->rc == ERR_NULL;
    } else {
      last_rc = r->rc;
    }
    observe(&r->h_main, &r->h_qp, &r->exit_code);
    if (r->exit_code != last_rc)
      violation(&v_status, "status.exit_code is not the last call's code", i, r->exit_code, last_rc);
    if (kind == C_FEEDBACK && qp_outcome(r->rc)) check_outputs(i, r->rc);
  }
  c0 = clock();
  clock_t0 = 0u; /* the twin: the accepted calls only, from init() */
  S_(_set_clock)(NULL);
  (void)S_(_init)();
  for (i = 0; i < calls; ++i) {
    const rec_t *r = &recs[i];
    uint64_t hm, hq;
    int ec, j;
    if (!r->refused) {
      if (r->kind == C_RESET && !FUZZ_KEEPS) { /* a fresh solver given the same inputs */
        (void)S_(_init)();
        for (j = 0; j < n_inputs; ++j) (void)do_call(recs[inputs[j]].kind, recs[inputs[j]].seed, inputs[j]);
      } else {
        const int rc = do_call(r->kind, r->seed, i);
        if (rc != r->rc) violation(&v_twin_rc, "the twin's code differs", i, r->rc, rc);
      }
      ++n_replayed;
      if (r->kind == C_INIT) n_inputs = 0;
      if (is_input(r->kind)) inputs[n_inputs++] = i;
    }
    observe(&hm, &hq, &ec);
    ++n_compared;
    if (hm != r->h_main || (!r->taint && hq != r->h_qp))
      violation(&v_twin, r->refused ? "a refused call changed the solver" : "the state differs from the twin's", i,
                r->kind, r->rc);
  }
  t_twin += seconds(c0, clock());
  ++n_trials;
}

static void report(void) {
  int i;
  printf("trials %ld\ncalls %ld\nrefused %ld\nreplayed %ld\ncompared %ld\n", n_trials, n_calls, n_refused, n_replayed,
         n_compared);
  printf("feedback_consumed %ld\nfeedback_ok %ld\nplan_reactions %ld\nnull_getters %ld\n", n_fb_consumed, n_fb_ok,
         n_react, n_null_get);
  printf("qp_iterations %ld\nqp_iterations_max %ld\n", n_qp_iter, max_qp_iter);
  for (i = 0; i < C_KINDS; ++i) printf("kind %s %ld\n", KIND_NAME[i], n_kind[i]);
  for (i = 0; i < MAX_CODE; ++i)
    if (n_rc[i]) printf("rc %d %ld\n", i, n_rc[i]);
  for (i = 0; i < C_KINDS; ++i) printf("weight %s %d\n", KIND_NAME[i], weight[i]);
  /* the timings on stderr: stdout is a function of the seed */
  for (i = 0; i < C_KINDS; ++i) fprintf(stderr, "seconds %s %.3f\n", KIND_NAME[i], t_kind[i]);
  fprintf(stderr, "seconds twin %.3f\nslowest_call_seconds %.6f\nslowest_call %s trial %ld call %d\n", t_twin,
          t_slowest, KIND_NAME[slowest_kind], slowest_trial, slowest_idx);
  printf("violation_code %ld\nviolation_status %ld\nviolation_twin %ld\nviolation_twin_rc %ld\n", v_code, v_status,
         v_twin, v_twin_rc);
  printf("violation_output %ld\nviolation_plan_check %ld\nviolation_null %ld\nviolations %ld\n", v_output, v_plan_check,
         v_null, violations);
}

#ifdef FUZZ_LIBFUZZER
int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);
int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size) {
  const int calls = (int)((size / 16u) < 8u ? 8u : ((size / 16u) > 300u ? 300u : size / 16u));
  fz_stream = data;
  fz_stream_left = size;
  fz_rng = 0x1234u;
  run_trial(calls);
  fz_stream_left = 0u;
  if (violations != 0) {
    report();
    abort();
  }
  return 0;
}
#else
/* "kind=w,...": the weights of the kinds named (KIND_NAME), the others keep theirs; 0 if malformed */
static int parse_weights(const char *text) {
  int i, total = 0;
  while (*text != '\0') {
    const char *eq = strchr(text, '=');
    char *end;
    long w;
    for (i = 0; i < C_KINDS; ++i)
      if (eq != NULL && strlen(KIND_NAME[i]) == (size_t)(eq - text) &&
          !strncmp(text, KIND_NAME[i], (size_t)(eq - text)))
        break;
    if (i == C_KINDS) return 0;
    w = strtol(eq + 1, &end, 10);
    if (end == eq + 1 || w < 0 || w > 1000 || (*end != ',' && *end != '\0')) return 0;
    weight[i] = (int)w;
    text = (*end == ',') ? end + 1 : end;
  }
  for (i = 0; i < C_KINDS; ++i) total += weight[i];
  return total > 0;
}

#define PROGRESS_SECONDS 10
int main(int argc, char **argv) {
  const clock_t start = clock();
  time_t last = time(NULL);
  long t, trials;
  int calls = 200;
  if (argc < 3) {
    fprintf(stderr, "usage: %s SEED TRIALS [CALLS [WEIGHTS]]\n", argv[0]);
    return 2;
  }
  fz_rng = strtoull(argv[1], NULL, 10) * 0x2545F4914F6CDD1Dull;
  trials = strtol(argv[2], NULL, 10);
  if (argc > 3) calls = atoi(argv[3]);
  if (calls < 1 || calls > MAX_CALLS || trials < 1 || (argc > 4 && !parse_weights(argv[4]))) {
    fprintf(stderr, "usage: %s SEED TRIALS [CALLS (1..%d) [WEIGHTS: kind=w,... w in 0..1000, e.g. feedback=8]]\n",
            argv[0], MAX_CALLS);
    return 2;
  }
  for (t = 0; t < trials; ++t) {
    run_trial(calls);
    if (time(NULL) - last >= PROGRESS_SECONDS || t + 1 == trials) { /* a long run says how far it is */
      const double cpu = seconds(start, clock());
      last = time(NULL);
      fprintf(stderr, "progress trials %ld calls %ld cpu_seconds %.0f calls_per_s %.0f violations %ld\n", n_trials,
              n_calls, cpu, cpu > 0.0 ? (double)n_calls / cpu : 0.0, violations);
      fflush(stderr);
    }
  }
  report();
  return violations != 0;
}
#endif
