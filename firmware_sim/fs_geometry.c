/* fs_geometry.c -- road geometry, collision and lateral acceleration of the run log (fs_geometry.h). */
#include "fs_geometry.h"

#include <math.h>
#include <stddef.h>

/* cubic Hermite value on a segment (generator/fcgen/road.py _hermite, same operation order) */
static double hermite(double tau, double h, double y0, double y1, double m0, double m1) {
  double t2 = tau * tau;
  double t3 = t2 * tau;
  return (2.0 * t3 - 3.0 * t2 + 1.0) * y0 + (t3 - 2.0 * t2 + tau) * h * m0 + (-2.0 * t3 + 3.0 * t2) * y1 +
         (t3 - t2) * h * m1;
}

void fs_to_cartesian(double s, double n, double alpha, double out[3]) {
  double t = (s - fs_sc.road_s0) / fs_sc.road_ds;
  double fi = floor(t), tau, phi_g, gx, gy;
  int i;
  if (fi < 0.0) fi = 0.0;
  if (fi > (double)(fs_sc.road_size - 2)) fi = (double)(fs_sc.road_size - 2);
  i = (int)fi;
  tau = t - (double)i;
  phi_g = hermite(tau, fs_sc.road_ds, fs_phi[i], fs_phi[i + 1], fs_kappa[i], fs_kappa[i + 1]);
  gx = hermite(tau, fs_sc.road_ds, fs_gx[i], fs_gx[i + 1], cos(fs_phi[i]), cos(fs_phi[i + 1]));
  gy = hermite(tau, fs_sc.road_ds, fs_gy[i], fs_gy[i + 1], sin(fs_phi[i]), sin(fs_phi[i + 1]));
  out[0] = gx - n * sin(phi_g);
  out[1] = gy + n * cos(phi_g);
  out[2] = phi_g + alpha;
}

/* chassis corners (generator/fcgen/sim/collision.py chassis_corners): rear-right, front-right, front-left, rear-left */
static void chassis_corners(const double pose[3], const fs_dims_t *d, double px[4], double py[4]) {
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

int fs_collides(const double ego[3], const double *opp) {
  double ex[4], ey[4], ox[4], oy[4];
  int o, hit = 0;
  chassis_corners(ego, &fs_sc.ego_dims, ex, ey);
  for (o = 0; o < NOPP; ++o) {
    chassis_corners(&opp[(size_t)o * 3], &fs_sc.opp_dims[o], ox, oy);
    if (sat_overlap(ex, ey, ox, oy) > 0.0) hit = 1;
  }
  return hit;
}

double fs_a_lat(const double x[5]) {
  return x[3] * x[3] * tan(x[4]) / fs_sc.ego_l;
}
