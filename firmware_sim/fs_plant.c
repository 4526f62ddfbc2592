/* fs_plant.c -- the discrete plant (fs_plant.h). */
#include "fs_plant.h"

#include <math.h>
#include <stdio.h>

#include "fs_scenario.h"

#define PLANT_SZ_ARG S_(_plant_SZ_ARG)
#define PLANT_SZ_RES S_(_plant_SZ_RES)
#define PLANT_SZ_IW S_(_plant_SZ_IW)
#define PLANT_SZ_W S_(_plant_SZ_W)
#define PLANT_NP (2 + 4 * PLANT_WINDOW)

static casadi_real g_plant_p[PLANT_NP];
static const casadi_real *g_plant_arg[PLANT_SZ_ARG + 1];
static casadi_real *g_plant_res[PLANT_SZ_RES + 1];
static casadi_int g_plant_iw[PLANT_SZ_IW + 1];
static casadi_real g_plant_w[PLANT_SZ_W + 1];

int fs_plant_step(int j, const double x[5], const double u[2], double xn[5]) {
  casadi_real xc[5], uc[2], xo[5];
  double fw;
  int i, p0;
  /* i0 = floor((s - s0) / ds) - 1, p = [s0 + i0 ds, ds, kappa, phi, gx, gy] over the local window */
  fw = floor((x[0] - fs_sc.road_s0) / fs_sc.road_ds) - 1.0;
  if (!(fw >= 0.0) || fw + (double)PLANT_WINDOW > (double)fs_sc.road_size) {
    fprintf(stderr, "closed_loop: sample %d: plant road window at s = %.1f is outside the road\n", j, x[0]);
    return 3;
  }
  p0 = (int)fw;
  g_plant_p[0] = (casadi_real)(fs_sc.road_s0 + (double)p0 * fs_sc.road_ds);
  g_plant_p[1] = (casadi_real)fs_sc.road_ds;
  for (i = 0; i < PLANT_WINDOW; ++i) {
    g_plant_p[2 + i] = (casadi_real)fs_kappa[p0 + i];
    g_plant_p[2 + PLANT_WINDOW + i] = (casadi_real)fs_phi[p0 + i];
    g_plant_p[2 + 2 * PLANT_WINDOW + i] = (casadi_real)fs_gx[p0 + i];
    g_plant_p[2 + 3 * PLANT_WINDOW + i] = (casadi_real)fs_gy[p0 + i];
  }
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
  return 0;
}
