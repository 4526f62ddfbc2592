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

#ifndef SOLVER
#error "compile with -DSOLVER=<solver name> -DSOLVER_UPPER=<SOLVER NAME IN UPPER CASE>"
#endif
#ifndef SOLVER_UPPER
#error "compile with -DSOLVER_UPPER=<SOLVER NAME IN UPPER CASE>"
#endif

#include "fs_platform.h" /* FS_CAT, FS_STR, the clock */

#define S_(x) FS_CAT(SOLVER, x)       /* S_(_init) -> <name>_init */
#define U_(x) FS_CAT(SOLVER_UPPER, x) /* U_(_N) -> <NAME>_N */

#include FS_STR(S_(_solver).h)
#include FS_STR(S_(_model).h)

typedef S_(_real_t) real_t;
typedef S_(_status_t) status_t;

#define NX U_(_NX)
#define NU U_(_NU)
#define N U_(_N)
#define NOPP U_(_NOPP)
#define NOPP_PAR U_(_NOPP_PAR)
#define ROAD_MAX U_(_ROAD_MAX)
#define PLANT_WINDOW U_(_ROAD_WINDOW)
#define OPP_BLOCK ((N + 1) * NOPP * NOPP_PAR)

#define PLANT_SZ_ARG S_(_plant_SZ_ARG)
#define PLANT_SZ_RES S_(_plant_SZ_RES)
#define PLANT_SZ_IW S_(_plant_SZ_IW)
#define PLANT_SZ_W S_(_plant_SZ_W)
#define PLANT_NP (2 + 4 * PLANT_WINDOW)

/* fixed maximum sizes of the scenario (override with -D) */
#ifndef FS_MAX_ROAD
#define FS_MAX_ROAD 20000
#endif
#ifndef FS_MAX_SAMPLES
#define FS_MAX_SAMPLES 20000
#endif
#define FS_MAX_WORD 128
#define FS_MAX_VERSIONS 8

#define SCENARIO_FORMAT "fcgen-scenario/1"
#define RUNLOG_FORMAT "fcgen-runlog/1"

/* ------------------------------------------------------------------------------------------------ scenario data */
/* FS_HARNESS_MEM (fs_platform.h): the large buffers, in the board's external RAM on the bare-metal image */
typedef struct {
  double l_f, l_r, l_r_ch, l_f_ch, w_ch;
} dims_t;

static char g_problem[FS_MAX_WORD], g_formulation[FS_MAX_WORD], g_obstacle_model[FS_MAX_WORD];
static char g_scenario[FS_MAX_WORD], g_controller[FS_MAX_WORD];
static char g_version_key[FS_MAX_VERSIONS][FS_MAX_WORD], g_version_val[FS_MAX_VERSIONS][FS_MAX_WORD];
static int g_n_versions;
static long g_seed;
static int g_samples, g_road_window, g_road_size;
static double g_dt, g_window_behind, g_n_bound, g_ego_l;
static dims_t g_ego_dims, g_opp_dims[NOPP + 1];
static double g_x0[5];
static double g_road_s0, g_road_ds;
FS_HARNESS_MEM static double g_kappa[FS_MAX_ROAD], g_phi[FS_MAX_ROAD], g_gx[FS_MAX_ROAD], g_gy[FS_MAX_ROAD];

/* ------------------------------------------------------------------------------------------------ run results */
FS_HARNESS_MEM static double g_t[FS_MAX_SAMPLES + 1];
FS_HARNESS_MEM static double g_xs[(FS_MAX_SAMPLES + 1) * 5];
FS_HARNESS_MEM static double g_ego_cart[(FS_MAX_SAMPLES + 1) * 3];
FS_HARNESS_MEM static double g_opp_cart[(FS_MAX_SAMPLES + 1) * NOPP * 3 + 1];
FS_HARNESS_MEM static double g_opp_fr[(FS_MAX_SAMPLES + 1) * NOPP * 3 + 1];
FS_HARNESS_MEM static int g_collision[FS_MAX_SAMPLES + 1];
FS_HARNESS_MEM static double g_a_lat[FS_MAX_SAMPLES + 1];
FS_HARNESS_MEM static double g_us[FS_MAX_SAMPLES * 2];
FS_HARNESS_MEM static double g_tp[FS_MAX_SAMPLES], g_tf[FS_MAX_SAMPLES], g_slack[FS_MAX_SAMPLES];
FS_HARNESS_MEM static int g_qi[FS_MAX_SAMPLES], g_qs[FS_MAX_SAMPLES], g_exit[FS_MAX_SAMPLES];

/* ------------------------------------------------------------------------------------------------ loop buffers */
FS_HARNESS_MEM static real_t g_opp_params[OPP_BLOCK + 1];
FS_HARNESS_MEM static real_t g_win_kappa[ROAD_MAX], g_win_phi[ROAD_MAX], g_win_gx[ROAD_MAX], g_win_gy[ROAD_MAX];
static casadi_real g_plant_p[PLANT_NP];
static const casadi_real *g_plant_arg[PLANT_SZ_ARG + 1];
static casadi_real *g_plant_res[PLANT_SZ_RES + 1];
static casadi_int g_plant_iw[PLANT_SZ_IW + 1];
static casadi_real g_plant_w[PLANT_SZ_W + 1];

/* ------------------------------------------------------------------------------------------------ reader */
static FILE *g_in;
static const char *g_in_name;
static char g_tok[256];

static void fail_data(const char *what) {
  fprintf(stderr, "closed_loop: %s: %s\n", g_in_name, what);
  exit(2);
}

static const char *next_token(void) {
  if (fscanf(g_in, "%255s", g_tok) != 1) fail_data("unexpected end of file");
  return g_tok;
}

static void expect_key(const char *key) {
  char msg[400];
  if (strcmp(next_token(), key) != 0) {
    snprintf(msg, sizeof msg, "expected '%s', found '%.200s'", key, g_tok);
    fail_data(msg);
  }
}

static double read_double(void) {
  char *end;
  double v;
  char msg[400];
  next_token();
  v = strtod(g_tok, &end);
  if (end == g_tok || *end != '\0') {
    snprintf(msg, sizeof msg, "expected a number, found '%.200s'", g_tok);
    fail_data(msg);
  }
  return v;
}

static long read_long(void) {
  char *end;
  long v;
  char msg[400];
  next_token();
  v = strtol(g_tok, &end, 10);
  if (end == g_tok || *end != '\0') {
    snprintf(msg, sizeof msg, "expected an integer, found '%.200s'", g_tok);
    fail_data(msg);
  }
  return v;
}

static void read_word(char *dst) {
  next_token();
  if (strlen(g_tok) >= FS_MAX_WORD) fail_data("word too long");
  strcpy(dst, g_tok);
}

static void read_doubles(const char *key, double *dst, int n) {
  int i;
  expect_key(key);
  for (i = 0; i < n; ++i) dst[i] = read_double();
}

static void read_reals(const char *key, real_t *dst, int n) {
  int i;
  expect_key(key);
  for (i = 0; i < n; ++i) dst[i] = (real_t)read_double();
}

static void check_size(const char *what, long got, long want) {
  char msg[300];
  if (got != want) {
    snprintf(msg, sizeof msg, "%s = %ld, but the solver " FS_STR(SOLVER) " was generated for %ld", what, got, want);
    fail_data(msg);
  }
}

static void read_dims(const char *key, dims_t *d) {
  double v[5];
  read_doubles(key, v, 5);
  d->l_f = v[0];
  d->l_r = v[1];
  d->l_r_ch = v[2];
  d->l_f_ch = v[3];
  d->w_ch = v[4];
}

static void read_header(void) {
  int i;
  char msg[300];
  if (strcmp(next_token(), SCENARIO_FORMAT) != 0) fail_data("not a scenario file of format " SCENARIO_FORMAT);
  expect_key("problem");
  read_word(g_problem);
  expect_key("formulation");
  read_word(g_formulation);
  expect_key("obstacle_model");
  read_word(g_obstacle_model);
  expect_key("scenario");
  read_word(g_scenario);
  expect_key("controller");
  read_word(g_controller);
  for (;;) {
    next_token();
    if (strcmp(g_tok, "seed") == 0) break;
    if (strcmp(g_tok, "version") != 0) fail_data("expected 'version' or 'seed'");
    if (g_n_versions >= FS_MAX_VERSIONS) fail_data("too many 'version' lines");
    read_word(g_version_key[g_n_versions]);
    read_word(g_version_val[g_n_versions]);
    ++g_n_versions;
  }
  g_seed = read_long();
  expect_key("N");
  check_size("N", read_long(), N);
  expect_key("dt");
  g_dt = read_double();
  expect_key("samples");
  g_samples = (int)read_long();
  if (g_samples < 1 || g_samples > FS_MAX_SAMPLES) {
    snprintf(msg, sizeof msg, "samples = %d is invalid: allowed 1 .. %d (FS_MAX_SAMPLES)", g_samples, FS_MAX_SAMPLES);
    fail_data(msg);
  }
  expect_key("nopp");
  check_size("nopp", read_long(), NOPP);
  expect_key("nopp_par");
  check_size("nopp_par", read_long(), NOPP_PAR);
  expect_key("road_window");
  g_road_window = (int)read_long();
  if (g_road_window < 2 || g_road_window > ROAD_MAX) fail_data("road_window is outside 2 .. ROAD_MAX of the solver");
  expect_key("plant_window");
  check_size("plant_window", read_long(), PLANT_WINDOW);
  expect_key("window_behind");
  g_window_behind = read_double();
  expect_key("n_bound");
  g_n_bound = read_double();
  expect_key("ego_l");
  g_ego_l = read_double();
  read_dims("ego_dims", &g_ego_dims);
  for (i = 0; i < NOPP; ++i) read_dims("opp_dims", &g_opp_dims[i]);
  read_doubles("x0", g_x0, 5);
  expect_key("road");
  g_road_size = (int)read_long();
  if (g_road_size < 2 || g_road_size > FS_MAX_ROAD) fail_data("road size is outside 2 .. FS_MAX_ROAD");
  g_road_s0 = read_double();
  g_road_ds = read_double();
  if (!(g_road_ds > 0.0)) fail_data("road ds must be > 0");
  read_doubles("kappa", g_kappa, g_road_size);
  read_doubles("phi_gamma", g_phi, g_road_size);
  read_doubles("gamma_x", g_gx, g_road_size);
  read_doubles("gamma_y", g_gy, g_road_size);
}

/* the per-sample record: opponents' poses at t_j (for the log) and, for j < K, the solver's opponent block */
static void read_sample(int j) {
  expect_key("sample");
  if (read_long() != j) fail_data("samples out of order");
  read_doubles("opp_cartesian", &g_opp_cart[(size_t)j * NOPP * 3], NOPP * 3);
  read_doubles("opp_frenet", &g_opp_fr[(size_t)j * NOPP * 3], NOPP * 3);
  if (j < g_samples) read_reals("opp_params", g_opp_params, OPP_BLOCK);
}

/* ------------------------------------------------------------------------------------------------ road geometry */
/* cubic Hermite value on a segment (generator/fcgen/road.py _hermite, same operation order) */
static double hermite(double tau, double h, double y0, double y1, double m0, double m1) {
  double t2 = tau * tau;
  double t3 = t2 * tau;
  return (2.0 * t3 - 3.0 * t2 + 1.0) * y0 + (t3 - 2.0 * t2 + tau) * h * m0 + (-2.0 * t3 + 3.0 * t2) * y1 +
         (t3 - t2) * h * m1;
}

/* Road.to_cartesian on the whole road: (s, n, alpha) -> rear-axle (x, y, phi) */
static void to_cartesian(double s, double n, double alpha, double out[3]) {
  double t = (s - g_road_s0) / g_road_ds;
  double fi = floor(t), tau, phi_g, gx, gy;
  int i;
  if (fi < 0.0) fi = 0.0;
  if (fi > (double)(g_road_size - 2)) fi = (double)(g_road_size - 2);
  i = (int)fi;
  tau = t - (double)i;
  phi_g = hermite(tau, g_road_ds, g_phi[i], g_phi[i + 1], g_kappa[i], g_kappa[i + 1]);
  gx = hermite(tau, g_road_ds, g_gx[i], g_gx[i + 1], cos(g_phi[i]), cos(g_phi[i + 1]));
  gy = hermite(tau, g_road_ds, g_gy[i], g_gy[i + 1], sin(g_phi[i]), sin(g_phi[i + 1]));
  out[0] = gx - n * sin(phi_g);
  out[1] = gy + n * cos(phi_g);
  out[2] = phi_g + alpha;
}

/* ------------------------------------------------------------------------------------------------ collision */
/* chassis corners (generator/fcgen/sim/collision.py chassis_corners): rear-right, front-right, front-left, rear-left */
static void chassis_corners(const double pose[3], const dims_t *d, double px[4], double py[4]) {
  static const double A[4] = {-1.0, 1.0, 1.0, -1.0}, B[4] = {-1.0, -1.0, 1.0, 1.0};
  double c = cos(pose[2]), s = sin(pose[2]);
  double half_l = 0.5 * (d->l_r_ch + d->l_f_ch), half_w = 0.5 * d->w_ch, l = d->l_f + d->l_r;
  double cx = pose[0] + 0.5 * l * c, cy = pose[1] + 0.5 * l * s;
  int k;
  for (k = 0; k < 4; ++k) {
    double a = A[k] * half_l, b = B[k] * half_w;
    px[k] = cx + a * c - b * s;
    py[k] = cy + a * s + b * c;
  }
}

/* smallest projection overlap over the 4 SAT axes (sat_overlap); > 0: the interiors intersect */
static double sat_overlap(const double x1[4], const double y1[4], const double x2[4], const double y2[4]) {
  double ex[4], ey[4], best = HUGE_VAL;
  int a, k;
  ex[0] = x1[1] - x1[0];
  ey[0] = y1[1] - y1[0];
  ex[1] = x1[2] - x1[1];
  ey[1] = y1[2] - y1[1];
  ex[2] = x2[1] - x2[0];
  ey[2] = y2[1] - y2[0];
  ex[3] = x2[2] - x2[1];
  ey[3] = y2[2] - y2[1];
  for (a = 0; a < 4; ++a) {
    double nrm = sqrt(ex[a] * ex[a] + ey[a] * ey[a]), ax, ay, lo1, hi1, lo2, hi2, ov;
    if (nrm == 0.0) return -HUGE_VAL; /* degenerate rectangle (Python raises); never for valid dimensions */
    ax = ex[a] / nrm;
    ay = ey[a] / nrm;
    lo1 = hi1 = ax * x1[0] + ay * y1[0];
    lo2 = hi2 = ax * x2[0] + ay * y2[0];
    for (k = 1; k < 4; ++k) {
      double p1 = ax * x1[k] + ay * y1[k], p2 = ax * x2[k] + ay * y2[k];
      if (p1 < lo1) lo1 = p1;
      if (p1 > hi1) hi1 = p1;
      if (p2 < lo2) lo2 = p2;
      if (p2 > hi2) hi2 = p2;
    }
    ov = (hi1 < hi2 ? hi1 : hi2) - (lo1 > lo2 ? lo1 : lo2);
    if (ov < best) best = ov;
  }
  return best;
}

/* ------------------------------------------------------------------------------------------------ JSON writer */
/* Python repr of a finite double: shortest round-tripping digits; fixed notation for -4 < decpt <= 16 */
static void repr_double(double v, char *out, size_t size) {
  char tmp[64], digits[32];
  int p, nd = 0, e, decpt, i;
  const char *q;
  char *w = out;
  for (p = 1; p <= 17; ++p) {
    snprintf(tmp, sizeof tmp, "%.*e", p - 1, v);
    if (strtod(tmp, NULL) == v) break;
  }
  q = tmp;
  if (*q == '-') {
    *w++ = '-';
    ++q;
  }
  for (; *q && *q != 'e'; ++q)
    if (*q != '.') digits[nd++] = *q;
  e = atoi(q + 1);
  while (nd > 1 && digits[nd - 1] == '0') --nd;
  digits[nd] = '\0';
  decpt = e + 1;
  if (decpt > -4 && decpt <= 16) {
    if (decpt <= 0) {
      *w++ = '0';
      *w++ = '.';
      for (i = 0; i < -decpt; ++i) *w++ = '0';
      memcpy(w, digits, (size_t)nd);
      w += nd;
    } else if (decpt >= nd) {
      memcpy(w, digits, (size_t)nd);
      w += nd;
      for (i = nd; i < decpt; ++i) *w++ = '0';
      *w++ = '.';
      *w++ = '0';
    } else {
      memcpy(w, digits, (size_t)decpt);
      w += decpt;
      *w++ = '.';
      memcpy(w, digits + decpt, (size_t)(nd - decpt));
      w += nd - decpt;
    }
    *w = '\0';
  } else {
    *w++ = digits[0];
    if (nd > 1) {
      *w++ = '.';
      memcpy(w, digits + 1, (size_t)(nd - 1));
      w += nd - 1;
    }
    snprintf(w, size - (size_t)(w - out), "e%c%02d", decpt - 1 < 0 ? '-' : '+', abs(decpt - 1));
  }
}

static FILE *g_out;

static void put_str(const char *s) { /* JSON string (the writer only sees printable ASCII words) */
  fputc('"', g_out);
  for (; *s; ++s) {
    if (*s == '"' || *s == '\\') fputc('\\', g_out);
    if ((unsigned char)*s < 0x20)
      fprintf(g_out, "\\u%04x", (unsigned)(unsigned char)*s);
    else
      fputc(*s, g_out);
  }
  fputc('"', g_out);
}

static void put_num(double v) { /* array element: non-finite as the strings "NaN", "Infinity", "-Infinity" */
  char buf[64];
  if (isnan(v))
    fputs("\"NaN\"", g_out);
  else if (isinf(v))
    fputs(v > 0 ? "\"Infinity\"" : "\"-Infinity\"", g_out);
  else {
    repr_double(v, buf, sizeof buf);
    fputs(buf, g_out);
  }
}

static void pad(int level) {
  int i;
  for (i = 0; i < level; ++i) fputs("  ", g_out);
}

/* key of an object member at indentation level; first member opens nothing (the caller writes "{\n") */
static void key(int level, const char *k, int first) {
  if (!first) fputs(",\n", g_out);
  pad(level);
  put_str(k);
  fputs(": ", g_out);
}

static void row_d(const double *v, int n) {
  int i;
  fputc('[', g_out);
  for (i = 0; i < n; ++i) {
    if (i) fputs(", ", g_out);
    put_num(v[i]);
  }
  fputc(']', g_out);
}

static void row_i(const int *v, int n, int as_bool) {
  int i;
  fputc('[', g_out);
  for (i = 0; i < n; ++i) {
    if (i) fputs(", ", g_out);
    if (as_bool)
      fputs(v[i] ? "true" : "false", g_out);
    else
      fprintf(g_out, "%d", v[i]);
  }
  fputc(']', g_out);
}

/* rows x cols matrix at indentation level (one row per line), as the Python emitter writes a list of lists */
static void mat_d(const double *v, int rows, int cols, int level) {
  int r;
  if (rows == 0) {
    fputs("[]", g_out);
    return;
  }
  if (cols == 0) { /* a list of empty lists */
    fputs("[\n", g_out);
    for (r = 0; r < rows; ++r) {
      if (r) fputs(",\n", g_out);
      pad(level + 1);
      fputs("[]", g_out);
    }
    fputc('\n', g_out);
    pad(level);
    fputc(']', g_out);
    return;
  }
  fputs("[\n", g_out);
  for (r = 0; r < rows; ++r) {
    if (r) fputs(",\n", g_out);
    pad(level + 1);
    row_d(v + (size_t)r * cols, cols);
  }
  fputc('\n', g_out);
  pad(level);
  fputc(']', g_out);
}

/* rows x O x 3 */
static void cube_d(const double *v, int rows, int n_opp, int level) {
  int r;
  fputs("[\n", g_out);
  for (r = 0; r < rows; ++r) {
    if (r) fputs(",\n", g_out);
    pad(level + 1);
    mat_d(v + (size_t)r * n_opp * 3, n_opp, 3, level + 1);
  }
  fputc('\n', g_out);
  pad(level);
  fputc(']', g_out);
}

static void dims_obj(const dims_t *d, int level) { /* sorted keys */
  char buf[64];
  const char *names[5] = {"l_f", "l_f_ch", "l_r", "l_r_ch", "w_ch"};
  double vals[5];
  int i;
  vals[0] = d->l_f;
  vals[1] = d->l_f_ch;
  vals[2] = d->l_r;
  vals[3] = d->l_r_ch;
  vals[4] = d->w_ch;
  fputs("{\n", g_out);
  for (i = 0; i < 5; ++i) {
    key(level + 1, names[i], i == 0);
    repr_double(vals[i], buf, sizeof buf);
    fputs(buf, g_out);
  }
  fputc('\n', g_out);
  pad(level);
  fputc('}', g_out);
}

FS_HARNESS_MEM static double g_road_s[FS_MAX_ROAD];

static int write_log(const char *path, int exit_nonzero) {
  char buf[64];
  int K = g_samples, i, j, k;
  g_out = fopen(path, "w");
  if (!g_out) return 1;
  fputs("{\n", g_out);
  key(1, "ego", 1);
  dims_obj(&g_ego_dims, 1);
  key(1, "format", 0);
  put_str(RUNLOG_FORMAT);
  /* meta, keys sorted as Python sorts them ("N" first) */
  key(1, "meta", 0);
  fputs("{\n", g_out);
  key(2, "N", 1);
  fprintf(g_out, "%d", N);
  key(2, "controller", 0);
  put_str(g_controller);
  key(2, "dt", 0);
  repr_double(g_dt, buf, sizeof buf);
  fputs(buf, g_out);
  key(2, "extra", 0);
  fputs("{\n", g_out);
  key(3, "exit_codes_nonzero", 1);
  fprintf(g_out, "%d", exit_nonzero);
  key(3, "harness", 0);
  put_str("c-firmware_sim");
  fputc('\n', g_out);
  pad(2);
  fputc('}', g_out);
  key(2, "formulation", 0);
  put_str(g_formulation);
  key(2, "n_bound", 0);
  repr_double(g_n_bound, buf, sizeof buf);
  fputs(buf, g_out);
  key(2, "obstacle_model", 0);
  put_str(g_obstacle_model);
  key(2, "problem", 0);
  put_str(g_problem);
  key(2, "scenario", 0);
  put_str(g_scenario);
  key(2, "seed", 0);
  fprintf(g_out, "%ld", g_seed);
  key(2, "versions", 0);
  if (g_n_versions == 0) {
    fputs("{}", g_out);
  } else { /* the exporter writes them sorted by key */
    fputs("{\n", g_out);
    for (i = 0; i < g_n_versions; ++i) {
      key(3, g_version_key[i], i == 0);
      put_str(g_version_val[i]);
    }
    fputc('\n', g_out);
    pad(2);
    fputc('}', g_out);
  }
  fputc('\n', g_out);
  pad(1);
  fputc('}', g_out);
  /* opponents */
  key(1, "opponents", 0);
  if (NOPP == 0) {
    fputs("[]", g_out);
  } else {
    fputs("[\n", g_out);
    for (i = 0; i < NOPP; ++i) {
      if (i) fputs(",\n", g_out);
      pad(2);
      dims_obj(&g_opp_dims[i], 2);
    }
    fputc('\n', g_out);
    pad(1);
    fputc(']', g_out);
  }
  /* road */
  for (i = 0; i < g_road_size; ++i) g_road_s[i] = g_road_s0 + g_road_ds * (double)i;
  key(1, "road", 0);
  fputs("{\n", g_out);
  key(2, "ds", 1);
  repr_double(g_road_ds, buf, sizeof buf);
  fputs(buf, g_out);
  key(2, "gamma_x", 0);
  row_d(g_gx, g_road_size);
  key(2, "gamma_y", 0);
  row_d(g_gy, g_road_size);
  key(2, "kappa", 0);
  row_d(g_kappa, g_road_size);
  key(2, "phi_gamma", 0);
  row_d(g_phi, g_road_size);
  key(2, "s", 0);
  row_d(g_road_s, g_road_size);
  fputc('\n', g_out);
  pad(1);
  fputc('}', g_out);
  /* samples, sorted */
  key(1, "samples", 0);
  fputs("{\n", g_out);
  key(2, "a_lat", 1);
  row_d(g_a_lat, K + 1);
  key(2, "collision", 0);
  row_i(g_collision, K + 1, 1);
  key(2, "control", 0);
  mat_d(g_us, K, 2, 2);
  key(2, "ego_cartesian", 0);
  mat_d(g_ego_cart, K + 1, 3, 2);
  key(2, "ego_frenet", 0);
  mat_d(g_xs, K + 1, 5, 2);
  key(2, "max_slack", 0);
  row_d(g_slack, K);
  key(2, "opp_cartesian", 0);
  cube_d(g_opp_cart, K + 1, NOPP, 2);
  key(2, "opp_frenet", 0);
  cube_d(g_opp_fr, K + 1, NOPP, 2);
  key(2, "qp_iter", 0);
  row_i(g_qi, K, 0);
  key(2, "qp_status", 0);
  row_i(g_qs, K, 0);
  key(2, "t", 0);
  row_d(g_t, K + 1);
  key(2, "time_feedback", 0);
  row_d(g_tf, K);
  key(2, "time_prepare", 0);
  row_d(g_tp, K);
  for (j = 0; j < K; ++j) g_tp[j] += g_tf[j]; /* time_total = time_prepare + time_feedback (written last) */
  key(2, "time_total", 0);
  row_d(g_tp, K);
  fputc('\n', g_out);
  pad(1);
  fputs("}\n}\n", g_out);
  k = ferror(g_out);
  if (fclose(g_out) != 0) k = 1;
  return k != 0;
}

/* ------------------------------------------------------------------------------------------------ timing probe */
/* -DFS_PROBE (bare metal; `fcgen wcet`, with a solver built with -D<NAME>_PROBE): every sample's events with the
 * raw tick count (fs_ticks) at each: the harness's around prepare (10, 11) and feedback (12, 13), the solver's
 * QPB_PROBE events (<name>_probe: 0 QP start, 1 check, 2 step, 3 QP end, 4 fit scan start, 5 fit scan step), into
 * the side file RUN_LOG.probe: a line "fcgen-probe/1 TICKS_PER_SECOND RESET_EVERY", then per sample
 * "s J RESET N EVENT TICKS ...". -DFS_PROBE_RESET=R: reset() before every R-th sample (cold starts, the longest QPs). */
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
void S_(_probe)(int event) { fs_mark(event); }

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
  real_t xr[5], s0 = (real_t)(g_road_s0 + (double)w0 * g_road_ds), ds = (real_t)g_road_ds;
  int i, rc;
  for (i = 0; i < 5; ++i) xr[i] = (real_t)x[i];
  for (i = 0; i < g_road_window; ++i) {
    g_win_kappa[i] = (real_t)g_kappa[w0 + i];
    g_win_phi[i] = (real_t)g_phi[w0 + i];
    g_win_gx[i] = (real_t)g_gx[w0 + i];
    g_win_gy[i] = (real_t)g_gy[w0 + i];
  }
  rc = S_(_set_road)(s0, ds, g_road_window, g_win_kappa, g_win_phi, g_win_gx, g_win_gy);
  if (!rc) rc = S_(_set_opponents)(g_opp_params);
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

int main(int argc, char **argv) {
  int K, j, i;
  int exit_nonzero = 0;
  if (argc != 3) {
    fprintf(stderr, "usage: %s SCENARIO_FILE RUN_LOG_JSON\n", argv[0]);
    return 1;
  }
  g_in_name = argv[1];
  g_in = fopen(argv[1], "r");
  if (!g_in) {
    fprintf(stderr, "closed_loop: cannot open %s\n", argv[1]);
    return 2;
  }
  read_header();
  K = g_samples;
  FS_PROBE_OPEN(argv[2]);

  S_(_init)();
  S_(_set_clock)(fs_clock);
  for (i = 0; i < 5; ++i) g_xs[i] = g_x0[i];

  for (j = 0; j < K; ++j) {
    const double *x = &g_xs[(size_t)j * 5];
    double *xn = &g_xs[(size_t)(j + 1) * 5];
    double *u = &g_us[(size_t)j * 2];
    double fw;
    int w0, p0, rc;
    status_t st;
    real_t ur[2];
    read_sample(j);
    /* road.window(x[0] - WINDOW_BEHIND, road_window) */
    fw = floor(((x[0] - g_window_behind) - g_road_s0) / g_road_ds);
    if (!(fw >= 0.0) || fw + (double)g_road_window > (double)g_road_size) {
      fprintf(stderr, "closed_loop: sample %d: road window at s = %.1f is outside the road [%.1f, %.1f]\n", j,
              x[0] - g_window_behind, g_road_s0, g_road_s0 + g_road_ds * (double)(g_road_size - 1));
      return 3;
    }
    w0 = (int)fw;
    FS_PROBE_BEGIN(j);
    rc = controller_step(x, w0);
    FS_PROBE_END(j);
    S_(_get_status)(&st);
    /* get_u0 is always the control to apply: after an unusable QP the solver's fallback, after a rejected call the
     * last control; both inside the input box */
    S_(_get_u0)(ur);
    u[0] = (double)ur[0];
    u[1] = (double)ur[1];
    if (rc) {
      g_slack[j] = NAN;
      ++exit_nonzero;
    } else {
      g_slack[j] = (double)S_(_max_slack)();
    }
    g_exit[j] = rc;
    g_tp[j] = (double)st.ticks_prepare / (double)FS_TICKS_PER_SECOND; /* the run log keeps seconds */
    g_tf[j] = (double)st.ticks_feedback / (double)FS_TICKS_PER_SECOND;
    g_qi[j] = st.qp_iter;
    g_qs[j] = st.qp_status;
    /* plant: i0 = floor((s - s0) / ds) - 1, p = [s0 + i0 ds, ds, kappa, phi, gx, gy] over the local window */
    fw = floor((x[0] - g_road_s0) / g_road_ds) - 1.0;
    if (!(fw >= 0.0) || fw + (double)PLANT_WINDOW > (double)g_road_size) {
      fprintf(stderr, "closed_loop: sample %d: plant road window at s = %.1f is outside the road\n", j, x[0]);
      return 3;
    }
    p0 = (int)fw;
    g_plant_p[0] = (casadi_real)(g_road_s0 + (double)p0 * g_road_ds);
    g_plant_p[1] = (casadi_real)g_road_ds;
    for (i = 0; i < PLANT_WINDOW; ++i) {
      g_plant_p[2 + i] = (casadi_real)g_kappa[p0 + i];
      g_plant_p[2 + PLANT_WINDOW + i] = (casadi_real)g_phi[p0 + i];
      g_plant_p[2 + 2 * PLANT_WINDOW + i] = (casadi_real)g_gx[p0 + i];
      g_plant_p[2 + 3 * PLANT_WINDOW + i] = (casadi_real)g_gy[p0 + i];
    }
    {
      casadi_real xc[5], uc[2], xo[5];
      for (i = 0; i < 5; ++i) xc[i] = (casadi_real)x[i];
      uc[0] = (casadi_real)u[0];
      uc[1] = (casadi_real)u[1];
      g_plant_arg[0] = xc;
      g_plant_arg[1] = uc;
      g_plant_arg[2] = g_plant_p;
      g_plant_res[0] = xo;
      if (S_(_plant)(g_plant_arg, g_plant_res, g_plant_iw, g_plant_w, 0) != 0) {
        fprintf(stderr, "closed_loop: sample %d: plant evaluation failed\n", j);
        return 3;
      }
      for (i = 0; i < 5; ++i) xn[i] = (double)xo[i];
    }
  }
  read_sample(K);
  expect_key("end");
  FS_PROBE_CLOSE();
  fclose(g_in);

  /* after the loop, as run_closed_loop: time, Cartesian poses, collisions, lateral acceleration */
  for (j = 0; j <= K; ++j) {
    const double *x = &g_xs[(size_t)j * 5];
    double ex[4], ey[4], ox[4], oy[4];
    int o, hit = 0;
    g_t[j] = (double)j * g_dt;
    to_cartesian(x[0], x[1], x[2], &g_ego_cart[(size_t)j * 3]);
    chassis_corners(&g_ego_cart[(size_t)j * 3], &g_ego_dims, ex, ey);
    for (o = 0; o < NOPP; ++o) {
      chassis_corners(&g_opp_cart[((size_t)j * NOPP + o) * 3], &g_opp_dims[o], ox, oy);
      if (sat_overlap(ex, ey, ox, oy) > 0.0) hit = 1;
    }
    g_collision[j] = hit;
    g_a_lat[j] = x[3] * x[3] * tan(x[4]) / g_ego_l;
  }
  if (write_log(argv[2], exit_nonzero)) {
    fprintf(stderr, "closed_loop: cannot write %s\n", argv[2]);
    return 4;
  }
  printf("%s: %d samples, s %.2f -> %.2f m, %d solver errors, run log written to %s\n", g_problem, K, g_xs[0],
         g_xs[(size_t)K * 5], exit_nonzero, argv[2]);
  return 0;
}
