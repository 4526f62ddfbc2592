/* fs_log.c -- the run log's JSON writer (fs_log.h): the layout of Python's json.dump(indent=2, sort_keys=True) with
 * each innermost list of numbers on one line, as fcgen.sim.runlog writes it. */
#include "fs_log.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "fs_scenario.h"

static FILE *g_out;
FS_HARNESS_MEM static double g_road_s[FS_MAX_ROAD];

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

static void put_double(double v) { /* a finite double as a JSON number */
  char buf[64];
  repr_double(v, buf, sizeof buf);
  fputs(buf, g_out);
}

static void put_num(double v) { /* array element: non-finite as the strings "NaN", "Infinity", "-Infinity" */
  if (isnan(v))
    fputs("\"NaN\"", g_out);
  else if (isinf(v))
    fputs(v > 0 ? "\"Infinity\"" : "\"-Infinity\"", g_out);
  else
    put_double(v);
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

/* the end of an object or list whose members are at level + 1 */
static void close_at(int level, char bracket) {
  fputc('\n', g_out);
  pad(level);
  fputc(bracket, g_out);
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

static void row_sum_d(const double *a, const double *b, int n) { /* the row a + b */
  int i;
  fputc('[', g_out);
  for (i = 0; i < n; ++i) {
    if (i) fputs(", ", g_out);
    put_num(a[i] + b[i]);
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
  fputs("[\n", g_out);
  for (r = 0; r < rows; ++r) {
    if (r) fputs(",\n", g_out);
    pad(level + 1);
    if (cols == 0) /* a list of empty lists */
      fputs("[]", g_out);
    else
      row_d(v + (size_t)r * cols, cols);
  }
  close_at(level, ']');
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
  close_at(level, ']');
}

static void dims_obj(const fs_dims_t *d, int level) { /* sorted keys */
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
    put_double(vals[i]);
  }
  close_at(level, '}');
}

/* meta.versions: the exporter writes them sorted by key */
static void write_versions(void) {
  int i;
  if (fs_sc.n_versions == 0) {
    fputs("{}", g_out);
    return;
  }
  fputs("{\n", g_out);
  for (i = 0; i < fs_sc.n_versions; ++i) {
    key(3, fs_sc.version_key[i], i == 0);
    put_str(fs_sc.version_val[i]);
  }
  close_at(2, '}');
}

/* a perturbed run's meta.extra entries after "harness" (fcgen.sim.perturbed.perturbed_meta): the plant and the
 * perturbations, the samples the plant's input limits cut, the largest |a_lat| of the model's formula */
static void write_plant_meta(const fs_run_t *run) {
  int j, cut[4] = {0, 0, 0, 0}; /* any, steering rate, steering angle, acceleration */
  double amax = 0.0;
  for (j = 0; j <= run->samples; ++j) amax = fabs(run->a_lat_model[j]) > amax ? fabs(run->a_lat_model[j]) : amax;
  for (j = 0; j < run->samples; ++j) {
    cut[0] += run->plant_cut[j] != 0;
    cut[1] += (run->plant_cut[j] & 1) != 0;
    cut[2] += (run->plant_cut[j] & 2) != 0;
    cut[3] += (run->plant_cut[j] & 4) != 0;
  }
  key(3, "max_abs_a_lat_model", 0);
  put_double(amax);
  key(3, "plant", 0);
  fputs("{\n", g_out);
  key(4, "kind", 1);
  put_str(fs_sc.plant);
  key(4, "latency", 0);
  fprintf(g_out, "%d", fs_sc.latency);
  key(4, "noise", 0);
  row_d(fs_sc.noise, 5);
  key(4, "params", 0);
  put_str(fs_sc.plant_params);
  key(4, "prediction", 0);
  put_str(fs_sc.prediction);
  key(4, "steer_lag", 0);
  put_double(fs_sc.steer_lag);
  close_at(3, '}');
  key(3, "plant_cut_accel", 0);
  fprintf(g_out, "%d", cut[3]);
  key(3, "plant_cut_samples", 0);
  fprintf(g_out, "%d", cut[0]);
  key(3, "plant_cut_steer_angle", 0);
  fprintf(g_out, "%d", cut[2]);
  key(3, "plant_cut_steer_rate", 0);
  fprintf(g_out, "%d", cut[1]);
}

/* meta, keys sorted as Python sorts them ("N" first) */
static void write_meta(const fs_run_t *run) {
  key(1, "meta", 0);
  fputs("{\n", g_out);
  key(2, "N", 1);
  fprintf(g_out, "%d", N);
  key(2, "controller", 0);
  put_str(fs_sc.controller);
  key(2, "dt", 0);
  put_double(fs_sc.dt);
  key(2, "extra", 0);
  fputs("{\n", g_out);
  key(3, "exit_codes_nonzero", 1);
  fprintf(g_out, "%d", run->exit_nonzero);
  key(3, "harness", 0);
  put_str("c-firmware_sim");
  if (run->control_applied) write_plant_meta(run);
  close_at(2, '}');
  key(2, "formulation", 0);
  put_str(fs_sc.formulation);
  key(2, "n_bound", 0);
  put_double(fs_sc.n_bound);
  key(2, "obstacle_model", 0);
  put_str(fs_sc.obstacle_model);
  key(2, "problem", 0);
  put_str(fs_sc.problem);
  key(2, "scenario", 0);
  put_str(fs_sc.scenario);
  key(2, "seed", 0);
  fprintf(g_out, "%ld", fs_sc.seed);
  key(2, "versions", 0);
  write_versions();
  close_at(1, '}');
}

static void write_opponents(void) {
  int i;
  key(1, "opponents", 0);
  if (NOPP == 0) {
    fputs("[]", g_out);
    return;
  }
  fputs("[\n", g_out);
  for (i = 0; i < NOPP; ++i) {
    if (i) fputs(",\n", g_out);
    pad(2);
    dims_obj(&fs_sc.opp_dims[i], 2);
  }
  close_at(1, ']');
}

static void write_road(void) {
  int i;
  for (i = 0; i < fs_sc.road_size; ++i) g_road_s[i] = fs_sc.road_s0 + fs_sc.road_ds * (double)i;
  key(1, "road", 0);
  fputs("{\n", g_out);
  key(2, "ds", 1);
  put_double(fs_sc.road_ds);
  key(2, "gamma_x", 0);
  row_d(fs_gx, fs_sc.road_size);
  key(2, "gamma_y", 0);
  row_d(fs_gy, fs_sc.road_size);
  key(2, "kappa", 0);
  row_d(fs_kappa, fs_sc.road_size);
  key(2, "phi_gamma", 0);
  row_d(fs_phi, fs_sc.road_size);
  key(2, "s", 0);
  row_d(g_road_s, fs_sc.road_size);
  close_at(1, '}');
}

/* samples, sorted; time_total = time_prepare + time_feedback */
static void write_samples(const fs_run_t *run) {
  const int K = run->samples;
  key(1, "samples", 0);
  fputs("{\n", g_out);
  key(2, "a_lat", 1);
  row_d(run->a_lat, K + 1);
  if (run->control_applied) {
    key(2, "a_lat_model", 0);
    row_d(run->a_lat_model, K + 1);
  }
  key(2, "collision", 0);
  row_i(run->collision, K + 1, 1);
  key(2, "control", 0);
  mat_d(run->control, K, 2, 2);
  if (run->control_applied) {
    key(2, "control_applied", 0);
    mat_d(run->control_applied, K, 2, 2);
  }
  key(2, "ego_cartesian", 0);
  mat_d(run->ego_cartesian, K + 1, 3, 2);
  key(2, "ego_frenet", 0);
  mat_d(run->ego_frenet, K + 1, 5, 2);
  key(2, "max_slack", 0);
  row_d(run->max_slack, K);
  key(2, "opp_cartesian", 0);
  cube_d(fs_opp_cart, K + 1, NOPP, 2);
  key(2, "opp_frenet", 0);
  cube_d(fs_opp_fr, K + 1, NOPP, 2);
  if (run->control_applied) {
    key(2, "plant_cut", 0);
    row_i(run->plant_cut, K, 0);
  }
  key(2, "qp_iter", 0);
  row_i(run->qp_iter, K, 0);
  key(2, "qp_status", 0);
  row_i(run->qp_status, K, 0);
  key(2, "t", 0);
  row_d(run->t, K + 1);
  key(2, "time_feedback", 0);
  row_d(run->time_feedback, K);
  key(2, "time_prepare", 0);
  row_d(run->time_prepare, K);
  key(2, "time_total", 0);
  row_sum_d(run->time_prepare, run->time_feedback, K);
  close_at(1, '}');
}

int fs_write_log(const char *path, const fs_run_t *run) {
  int k;
  g_out = fopen(path, "w");
  if (!g_out) return 1;
  fputs("{\n", g_out);
  key(1, "ego", 1);
  dims_obj(&fs_sc.ego_dims, 1);
  key(1, "format", 0);
  put_str(RUNLOG_FORMAT);
  write_meta(run);
  write_opponents();
  write_road();
  write_samples(run);
  fputs("\n}\n", g_out);
  k = ferror(g_out);
  if (fclose(g_out) != 0) k = 1;
  return k != 0;
}
