/* fs_scenario.c -- reading the scenario data file (fs_scenario.h): whitespace-separated tokens, keys in order. */
#include "fs_scenario.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

fs_scenario_t fs_sc;
FS_HARNESS_MEM double fs_kappa[FS_MAX_ROAD], fs_phi[FS_MAX_ROAD], fs_gx[FS_MAX_ROAD], fs_gy[FS_MAX_ROAD];
FS_HARNESS_MEM double fs_opp_cart[(FS_MAX_SAMPLES + 1) * NOPP * 3 + 1];
FS_HARNESS_MEM double fs_opp_fr[(FS_MAX_SAMPLES + 1) * NOPP * 3 + 1];
FS_HARNESS_MEM real_t fs_opp_params[OPP_BLOCK + 1];
double fs_meas_err[5];
double fs_plant_in[8];

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

static void read_dims(const char *key, fs_dims_t *d) {
  double v[5];
  read_doubles(key, v, 5);
  d->l_f = v[0];
  d->l_r = v[1];
  d->l_r_ch = v[2];
  d->l_f_ch = v[3];
  d->w_ch = v[4];
}

int fs_scenario_open(const char *path) {
  g_in_name = path;
  g_in = fopen(path, "r");
  if (!g_in) {
    fprintf(stderr, "closed_loop: cannot open %s\n", path);
    return 2;
  }
  return 0;
}

/* the format line, the run's names, its 'version' lines (up to 'seed') */
static void read_names(void) {
  if (strcmp(next_token(), SCENARIO_FORMAT) != 0) fail_data("not a scenario file of format " SCENARIO_FORMAT);
  expect_key("problem");
  read_word(fs_sc.problem);
  expect_key("formulation");
  read_word(fs_sc.formulation);
  expect_key("obstacle_model");
  read_word(fs_sc.obstacle_model);
  expect_key("scenario");
  read_word(fs_sc.scenario);
  expect_key("controller");
  read_word(fs_sc.controller);
  for (;;) {
    next_token();
    if (strcmp(g_tok, "seed") == 0) break;
    if (strcmp(g_tok, "version") != 0) fail_data("expected 'version' or 'seed'");
    if (fs_sc.n_versions >= FS_MAX_VERSIONS) fail_data("too many 'version' lines");
    read_word(fs_sc.version_key[fs_sc.n_versions]);
    read_word(fs_sc.version_val[fs_sc.n_versions]);
    ++fs_sc.n_versions;
  }
}

/* seed .. n_bound: the sizes, checked against the compiled solver */
static void read_sizes(void) {
  char msg[300];
  fs_sc.seed = read_long();
  expect_key("N");
  check_size("N", read_long(), N);
  expect_key("dt");
  fs_sc.dt = read_double();
  expect_key("samples");
  fs_sc.samples = (int)read_long();
  if (fs_sc.samples < 1 || fs_sc.samples > FS_MAX_SAMPLES) {
    snprintf(msg, sizeof msg, "samples = %d is invalid: allowed 1 .. %d (FS_MAX_SAMPLES)", fs_sc.samples,
             FS_MAX_SAMPLES);
    fail_data(msg);
  }
  expect_key("nopp");
  check_size("nopp", read_long(), NOPP);
  expect_key("nopp_par");
  check_size("nopp_par", read_long(), NOPP_PAR);
  expect_key("road_window");
  fs_sc.road_window = (int)read_long();
  if (fs_sc.road_window < 2 || fs_sc.road_window > ROAD_MAX) {
    fail_data("road_window is outside 2 .. ROAD_MAX of the solver");
  }
  expect_key("plant_window");
  check_size("plant_window", read_long(), PLANT_WINDOW);
  expect_key("window_behind");
  fs_sc.window_behind = read_double();
  expect_key("n_bound");
  fs_sc.n_bound = read_double();
}

/* The optional perturbation lines "latency D", "steer_lag TAU", "noise STD x 5", "prediction WORD",
 * "plant KIND PARAMS" (docs/scenario_file.md), then "ego_l". */
static void read_perturbations(void) {
  int i;
  fs_sc.latency = 0;
  fs_sc.steer_lag = 0.0;
  fs_sc.noisy = 0;
  for (i = 0; i < 5; ++i) fs_sc.noise[i] = 0.0;
  next_token();
  if (strcmp(g_tok, "latency") == 0) {
    fs_sc.latency = (int)read_long();
    if (fs_sc.latency < 0 || fs_sc.latency > FS_MAX_LATENCY) fail_data("latency is outside 0 .. FS_MAX_LATENCY");
    next_token();
  }
  if (strcmp(g_tok, "steer_lag") == 0) {
    fs_sc.steer_lag = read_double();
    if (!(fs_sc.steer_lag > 0.0 && fs_sc.steer_lag <= FS_MAX_STEER_LAG)) fail_data("steer_lag is outside (0, 2] s");
    next_token();
  }
  if (strcmp(g_tok, "noise") == 0) {
    for (i = 0; i < 5; ++i) {
      fs_sc.noise[i] = read_double();
      if (!(fs_sc.noise[i] >= 0.0)) fail_data("noise: a std is negative or not a number");
    }
    fs_sc.noisy = 1;
    next_token();
  }
  strcpy(fs_sc.prediction, "oracle");
  if (strcmp(g_tok, "prediction") == 0) {
    read_word(fs_sc.prediction);
    next_token();
  }
  strcpy(fs_sc.plant, "model");
  strcpy(fs_sc.plant_params, "paper");
  if (strcmp(g_tok, "plant") == 0) {
    read_word(fs_sc.plant);
    read_word(fs_sc.plant_params);
    next_token();
  }
  if (strcmp(g_tok, "ego_l") != 0)
    fail_data("expected 'latency', 'steer_lag', 'noise', 'prediction', 'plant' or 'ego_l'");
  fs_sc.external = strcmp(fs_sc.plant, "model") != 0;
  fs_sc.perturbed = fs_sc.latency > 0 || fs_sc.steer_lag > 0.0 || fs_sc.noisy ||
                    strcmp(fs_sc.prediction, "oracle") != 0 || fs_sc.external;
}

void fs_read_header(void) {
  int i;
  read_names();
  read_sizes();
  read_perturbations();
  fs_sc.ego_l = read_double();
  read_dims("ego_dims", &fs_sc.ego_dims);
  for (i = 0; i < NOPP; ++i) read_dims("opp_dims", &fs_sc.opp_dims[i]);
  read_doubles("x0", fs_sc.x0, 5);
  expect_key("road");
  fs_sc.road_size = (int)read_long();
  if (fs_sc.road_size < 2 || fs_sc.road_size > FS_MAX_ROAD) fail_data("road size is outside 2 .. FS_MAX_ROAD");
  fs_sc.road_s0 = read_double();
  fs_sc.road_ds = read_double();
  if (!(fs_sc.road_ds > 0.0)) fail_data("road ds must be > 0");
  read_doubles("kappa", fs_kappa, fs_sc.road_size);
  read_doubles("phi_gamma", fs_phi, fs_sc.road_size);
  read_doubles("gamma_x", fs_gx, fs_sc.road_size);
  read_doubles("gamma_y", fs_gy, fs_sc.road_size);
}

void fs_read_sample(int j) {
  expect_key("sample");
  if (read_long() != j) fail_data("samples out of order");
  read_doubles("opp_cartesian", &fs_opp_cart[(size_t)j * NOPP * 3], NOPP * 3);
  read_doubles("opp_frenet", &fs_opp_fr[(size_t)j * NOPP * 3], NOPP * 3);
  if (j > 0 && fs_sc.external) read_doubles("plant_state", fs_plant_in, 7);
  if (j < fs_sc.samples) read_reals("opp_params", fs_opp_params, OPP_BLOCK);
  if (j < fs_sc.samples && fs_sc.noisy) read_doubles("measurement_error", fs_meas_err, 5);
  if (j == fs_sc.samples && fs_sc.external) read_doubles("plant_a_lat", &fs_plant_in[7], 1);
}

void fs_read_end(void) {
  expect_key("end");
}

void fs_scenario_close(void) {
  fclose(g_in);
}
