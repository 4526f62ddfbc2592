/*
 * closed_loop.c -- closed-loop simulation of a generated fcgen solver in C, the way an ECU runs it.
 *
 *   closed_loop SCENARIO_FILE RUN_LOG_JSON
 *
 * Reads a scenario data file (format fcgen-scenario/1, docs/scenario_file.md, written by
 * fcgen.sim.export.export_scenario), runs the SQP-RTI solver sample by sample against the discrete plant model
 * <name>_plant (the same RK4 Frenet step the Python closed loop uses), and writes the run log (format
 * fcgen-runlog/1, docs/runlog.md) with the same fields, layout and number formatting as the Python writer.
 *
 * It replicates generator/fcgen/sim/closedloop.py run_closed_loop with the controller calls of
 * generator/fcgen/build.py CSolver.step:
 *   per sample j:  road window [floor((s - window_behind - s0) / ds), + road_window samples)
 *                  set_road, set_opponents, set_state (only without a guess), prepare, set_state, feedback
 *                  x_{j+1} = plant(x_j, u_j, local road window starting one sample behind s_j)
 * then, as Python does after the loop: ego Cartesian poses by the inverse Frenet transform on the whole road,
 * collision flags by the exact separating-axis rectangle test, a_lat = v^2 tan(delta) / l.
 * With the scenario's perturbations (fcgen.sim.perturbed.run_perturbed): the solver gets x_j plus the sample's
 * measurement_error, the plant the control of sample j - latency through the steering actuator's lag; with a plant on
 * the host ("plant KIND PARAMS", fcgen.sim.cosim) the harness writes each applied control to stdout ("u J F_D R")
 * and the next sample's record brings the plant's state.
 *
 * This file is the closed-loop driver (and the timing probe of `fcgen wcet`); the jobs it calls live apart:
 *   fs_solver.h    the solver it is compiled for (macros) and the fixed maxima;
 *   fs_scenario.c  reading the scenario file (header, road, the per-sample opponent records);
 *   fs_plant.c     the discrete plant on its local road window;
 *   fs_geometry.c  Cartesian poses, collision flags and a_lat of the run log;
 *   fs_log.c       the run log's JSON writer.
 *
 * Compile with -DSOLVER=<name> -DSOLVER_UPPER=<NAME> -I<generated folder> (see the Makefile). Static memory only;
 * the platform (fs_platform.h) gives the clock (integer ticks, FS_TICKS_PER_SECOND of them a second; the run log
 * keeps seconds): fs_host.c (the solver folder's POSIX clock, nanoseconds) on a host,
 * fs_baremetal.c (startup, SysTick, semihosting command line) on a Cortex-M; stdio is the C library's (newlib's over
 * semihosting on the bare-metal image), so the same loop runs on both;
 * the per-sample loop reads the sample's inputs (opponent parameters) from the file stream, like sensor data.
 * Exit codes: 0 run completed (whatever the solver returned), 1 usage, 2 bad scenario file, 3 run aborted
 * (road window outside the road), 4 cannot write the log.
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "fs_geometry.h"
#include "fs_log.h"
#include "fs_plant.h"
#include "fs_scenario.h"

/* ------------------------------------------------------------------------------------------------ run results */
/* FS_HARNESS_MEM (fs_platform.h): the large buffers, in the board's external RAM on the bare-metal image */
FS_HARNESS_MEM static double g_t[FS_MAX_SAMPLES + 1];
FS_HARNESS_MEM static double g_xs[(FS_MAX_SAMPLES + 1) * 5];
FS_HARNESS_MEM static double g_ego_cart[(FS_MAX_SAMPLES + 1) * 3];
FS_HARNESS_MEM static int g_collision[FS_MAX_SAMPLES + 1];
FS_HARNESS_MEM static double g_a_lat[FS_MAX_SAMPLES + 1]; /* the plant's (an external plant's own) */
FS_HARNESS_MEM static double g_a_lat_model[FS_MAX_SAMPLES + 1]; /* the model's formula on the same states */
FS_HARNESS_MEM static int g_cut[FS_MAX_SAMPLES]; /* an external plant's input-limit cut flags */
FS_HARNESS_MEM static double g_us[FS_MAX_SAMPLES * 2];
FS_HARNESS_MEM static double g_ua[FS_MAX_SAMPLES * 2]; /* the controls the plant got (latency, steering lag) */
FS_HARNESS_MEM static double g_tp[FS_MAX_SAMPLES], g_tf[FS_MAX_SAMPLES], g_slack[FS_MAX_SAMPLES];
FS_HARNESS_MEM static int g_qi[FS_MAX_SAMPLES], g_qs[FS_MAX_SAMPLES];
static int g_exit_nonzero;

/* ------------------------------------------------------------------------------------------------ loop buffers */
FS_HARNESS_MEM static real_t g_win_kappa[ROAD_MAX], g_win_phi[ROAD_MAX], g_win_gx[ROAD_MAX], g_win_gy[ROAD_MAX];

/* ------------------------------------------------------------------------------------------------ timing probe */
/* -DFS_PROBE (bare metal; `fcgen wcet`, with a solver built with -D<NAME>_PROBE): every sample's events with the
 * raw tick count (fs_ticks) at each: the harness's around prepare (10, 11) and feedback (12, 13), the solver's
 * QPB_PROBE events (<name>_probe: 0 QP start, 1 check, 2 step, 3 QP end, 4 fit scan start, 5 fit scan step), into
 * the side file RUN_LOG.probe: a line "fcgen-probe/1 TICKS_PER_SECOND RESET_EVERY", then per sample
 * "s J RESET N EVENT TICKS ...". -DFS_PROBE_RESET=R: reset() before every R-th sample (cold starts, the longest
 * QPs). */
#ifdef FS_PROBE
#ifndef FS_BAREMETAL
#error "FS_PROBE needs the bare-metal platform (fs_ticks: SysTick under qemu -icount)"
#endif
#ifndef FS_PROBE_MAX
#define FS_PROBE_MAX 16384 /* events per sample */
#endif
#ifndef FS_PROBE_RESET
#define FS_PROBE_RESET 0
#endif
FS_HARNESS_MEM static unsigned char g_pev[FS_PROBE_MAX];
FS_HARNESS_MEM static uint32_t g_pt[FS_PROBE_MAX];
static long g_pn;
static int g_preset;
static FILE *g_pf;

static void fs_mark(int event) {
  const uint32_t t = fs_ticks();
  if (g_pn < FS_PROBE_MAX) {
    g_pev[g_pn] = (unsigned char)event;
    g_pt[g_pn] = t;
  }
  ++g_pn;
}

void S_(_probe)(int event);
void S_(_probe)(int event) {
  fs_mark(event);
}

static void fs_probe_open(const char *log) {
  char path[600];
  snprintf(path, sizeof path, "%s.probe", log);
  g_pf = fopen(path, "w");
  if (!g_pf) {
    fprintf(stderr, "closed_loop: cannot write %s\n", path);
    exit(4);
  }
  fprintf(g_pf, "fcgen-probe/1 %ld %d\n", (long)FS_SYSTICK_HZ, FS_PROBE_RESET);
}

static void fs_probe_begin(int j) {
  g_pn = 0;
  g_preset = (FS_PROBE_RESET > 0) && (j > 0) && (j % FS_PROBE_RESET == 0);
  if (g_preset) S_(_reset)();
}

static void fs_probe_end(int j) {
  long i;
  if (g_pn > FS_PROBE_MAX) {
    fprintf(stderr, "closed_loop: sample %d: %ld probe events, more than FS_PROBE_MAX = %d\n", j, g_pn, FS_PROBE_MAX);
    exit(3);
  }
  fprintf(g_pf, "s %d %d %ld", j, g_preset, g_pn);
  for (i = 0; i < g_pn; ++i) fprintf(g_pf, " %u %lu", (unsigned)g_pev[i], (unsigned long)g_pt[i]);
  fputc('\n', g_pf);
}

static void fs_probe_close(void) {
  if (fclose(g_pf) != 0) {
    fprintf(stderr, "closed_loop: cannot write the probe file\n");
    exit(4);
  }
}
#define FS_MARK(event) fs_mark(event)
#define FS_PROBE_OPEN(log) fs_probe_open(log)
#define FS_PROBE_BEGIN(j) fs_probe_begin(j)
#define FS_PROBE_END(j) fs_probe_end(j)
#define FS_PROBE_CLOSE() fs_probe_close()
#else
#define FS_MARK(event) ((void)0)
#define FS_PROBE_OPEN(log) ((void)0)
#define FS_PROBE_BEGIN(j) ((void)0)
#define FS_PROBE_END(j) ((void)0)
#define FS_PROBE_CLOSE() ((void)0)
#endif

/* ------------------------------------------------------------------------------------------------ the loop */
/* one controller sample: the calls and their order of CSolver.step (generator/fcgen/build.py) */
static int controller_step(const double x[5], int w0) {
  real_t xr[5], s0 = (real_t)(fs_sc.road_s0 + (double)w0 * fs_sc.road_ds), ds = (real_t)fs_sc.road_ds;
  int i, rc;
  for (i = 0; i < 5; ++i) xr[i] = (real_t)x[i];
  for (i = 0; i < fs_sc.road_window; ++i) {
    g_win_kappa[i] = (real_t)fs_kappa[w0 + i];
    g_win_phi[i] = (real_t)fs_phi[w0 + i];
    g_win_gx[i] = (real_t)fs_gx[w0 + i];
    g_win_gy[i] = (real_t)fs_gy[w0 + i];
  }
  rc = S_(_set_road)(s0, ds, fs_sc.road_window, g_win_kappa, g_win_phi, g_win_gx, g_win_gy);
  if (!rc) rc = S_(_set_opponents)(fs_opp_params);
  if (!rc && !S_(_has_guess)()) rc = S_(_set_state)(xr);
  if (!rc) {
    FS_MARK(10);
    rc = S_(_prepare)();
    FS_MARK(11);
  }
  if (!rc) rc = S_(_set_state)(xr);
  if (!rc) {
    FS_MARK(12);
    rc = S_(_feedback)();
    FS_MARK(13);
  }
  return rc;
}

/* The steering actuator's lag (fcgen.sim.plants.actuation.Actuation._lagged_rate): the commanded angle integrates
 * the rate r, the actual angle delta follows it with time constant tau; returns the constant rate that ends the
 * sample at the first-order response's exact angle. */
static double lagged_rate(int j, double r, double delta) {
  static double cmd; /* the commanded angle, from the plant's angle at the first sample */
  const double tau = fs_sc.steer_lag, h = fs_sc.dt;
  double e0, e1;
  if (j == 0) cmd = delta;
  e0 = cmd - delta; /* commanded minus actual */
  e1 = r * tau + (e0 - r * tau) * exp(-h / tau); /* e' = r - e / tau over the sample */
  cmd += r * h;
  return (cmd - e1 - delta) / h;
}

/* The control the plant applies in sample j: the one computed fs_sc.latency samples earlier (zeros before the first;
 * the same queue as fcgen.sim.plants.actuation), its steering rate through the actuator's lag; delta: the plant's
 * steering angle. */
static void actuate(int j, const double u[2], double delta, double ua[2]) {
  static double queue[FS_MAX_LATENCY][2];
  const int d = fs_sc.latency;
  if (d == 0) {
    ua[0] = u[0];
    ua[1] = u[1];
  } else {
    if (j == 0) (void)memset(queue, 0, sizeof queue);
    ua[0] = queue[j % d][0];
    ua[1] = queue[j % d][1];
    queue[j % d][0] = u[0];
    queue[j % d][1] = u[1];
  }
  if (fs_sc.steer_lag > 0.0) ua[1] = lagged_rate(j, ua[1], delta);
}

/* An external plant (the host steps it, fcgen.sim.cosim): the record of sample j brought x_j and the plant's a_lat
 * and cut flags of sample j - 1 (at j = K also its a_lat at x_K). */
static void take_plant_state(int j) {
  int i;
  if (!fs_sc.external || j == 0) return;
  for (i = 0; i < 5; ++i) g_xs[(size_t)j * 5 + (size_t)i] = fs_plant_in[i];
  g_a_lat[j - 1] = fs_plant_in[5];
  g_cut[j - 1] = (int)fs_plant_in[6];
  if (j == fs_sc.samples) g_a_lat[j] = fs_plant_in[7];
}

/* The applied control to the host's plant: one line "u J F_D R" on stdout, flushed (the host answers with the next
 * sample's record). */
static int send_control(int j, const double ua[2]) {
  printf("u %d %.17g %.17g\n", j, ua[0], ua[1]);
  return fflush(stdout) == 0 ? 0 : 3;
}

/* sample j: its record, the controller on the measured state, the control and status into the run, the plant's
 * step; 0, or 3 (aborted) */
static int run_sample(int j) {
  const double *x = &g_xs[(size_t)j * 5];
  double *u = &g_us[(size_t)j * 2];
  double fw, s_start;
  double xm[5];
  int rc, i;
  status_t st;
  real_t ur[2];
  fs_read_sample(j);
  take_plant_state(j);
  for (i = 0; i < 5; ++i) xm[i] = fs_sc.noisy ? x[i] + fs_meas_err[i] : x[i]; /* Actuation.measure */
  /* road.window(x[0] - WINDOW_BEHIND, road_window); a perturbed loop starts it at the road's start at the latest */
  s_start = xm[0] - fs_sc.window_behind;
  if (fs_sc.perturbed && s_start < fs_sc.road_s0) s_start = fs_sc.road_s0;
  fw = floor((s_start - fs_sc.road_s0) / fs_sc.road_ds);
  if (!(fw >= 0.0) || fw + (double)fs_sc.road_window > (double)fs_sc.road_size) {
    fprintf(stderr, "closed_loop: sample %d: road window at s = %.1f is outside the road [%.1f, %.1f]\n", j, s_start,
            fs_sc.road_s0, fs_sc.road_s0 + fs_sc.road_ds * (double)(fs_sc.road_size - 1));
    return 3;
  }
  FS_PROBE_BEGIN(j);
  rc = controller_step(xm, (int)fw);
  FS_PROBE_END(j);
  S_(_get_status)(&st);
  /* get_u0 is always the control to apply: after an unusable QP the solver's fallback, after a rejected call the
   * last control; both inside the input box */
  S_(_get_u0)(ur);
  u[0] = (double)ur[0];
  u[1] = (double)ur[1];
  if (rc) {
    g_slack[j] = NAN;
    ++g_exit_nonzero;
  } else {
    g_slack[j] = (double)S_(_max_slack)();
  }
  g_tp[j] = (double)st.ticks_prepare / (double)FS_TICKS_PER_SECOND; /* the run log keeps seconds */
  g_tf[j] = (double)st.ticks_feedback / (double)FS_TICKS_PER_SECOND;
  g_qi[j] = st.qp_iter;
  g_qs[j] = st.qp_status;
  actuate(j, u, x[4], &g_ua[(size_t)j * 2]);
  if (fs_sc.external) return send_control(j, &g_ua[(size_t)j * 2]);
  return fs_plant_step(j, x, &g_ua[(size_t)j * 2], &g_xs[(size_t)(j + 1) * 5]);
}

/* after the loop, as run_closed_loop: time, Cartesian poses, collisions, lateral acceleration */
static void evaluate_run(int K) {
  int j;
  for (j = 0; j <= K; ++j) {
    const double *x = &g_xs[(size_t)j * 5];
    g_t[j] = (double)j * fs_sc.dt;
    fs_to_cartesian(x[0], x[1], x[2], &g_ego_cart[(size_t)j * 3]);
    g_collision[j] = fs_collides(&g_ego_cart[(size_t)j * 3], &fs_opp_cart[(size_t)j * NOPP * 3]);
    g_a_lat_model[j] = fs_a_lat(x);
    if (!fs_sc.external) g_a_lat[j] = g_a_lat_model[j];
  }
}

static int write_run_log(const char *path, int K) {
  fs_run_t run;
  run.samples = K;
  run.exit_nonzero = g_exit_nonzero;
  run.t = g_t;
  run.ego_frenet = g_xs;
  run.ego_cartesian = g_ego_cart;
  run.collision = g_collision;
  run.a_lat = g_a_lat;
  run.control = g_us;
  run.control_applied = fs_sc.perturbed ? g_ua : NULL;
  run.a_lat_model = g_a_lat_model;
  run.plant_cut = g_cut;
  run.max_slack = g_slack;
  run.time_prepare = g_tp;
  run.time_feedback = g_tf;
  run.qp_iter = g_qi;
  run.qp_status = g_qs;
  if (fs_write_log(path, &run)) {
    fprintf(stderr, "closed_loop: cannot write %s\n", path);
    return 4;
  }
  return 0;
}

int main(int argc, char **argv) {
  int K, j, i, rc;
  if (argc != 3) {
    fprintf(stderr, "usage: %s SCENARIO_FILE RUN_LOG_JSON\n", argv[0]);
    return 1;
  }
  rc = fs_scenario_open(argv[1]);
  if (rc) return rc;
  fs_read_header();
  K = fs_sc.samples;
  FS_PROBE_OPEN(argv[2]);

  S_(_init)();
  S_(_set_clock)(fs_clock);
  for (i = 0; i < 5; ++i) g_xs[i] = fs_sc.x0[i];
  for (j = 0; j < K; ++j) {
    rc = run_sample(j);
    if (rc) return rc;
  }
  fs_read_sample(K);
  take_plant_state(K);
  fs_read_end();
  FS_PROBE_CLOSE();
  fs_scenario_close();

  evaluate_run(K);
  rc = write_run_log(argv[2], K);
  if (rc) return rc;
  printf("%s: %d samples, s %.2f -> %.2f m, %d solver errors, run log written to %s\n", fs_sc.problem, K, g_xs[0],
         g_xs[(size_t)K * 5], g_exit_nonzero, argv[2]);
  return 0;
}
