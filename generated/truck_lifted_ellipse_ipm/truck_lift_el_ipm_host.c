/* truck_lift_el_ipm_host.c -- host clock for "truck_lift_el_ipm" (POSIX); linked into the example and the shared library only. */
#define _POSIX_C_SOURCE 199309L
#include <time.h>

#include "truck_lift_el_ipm_host.h"

double truck_lift_el_ipm_host_clock(void) {
  struct timespec ts;
  if (clock_gettime(CLOCK_MONOTONIC, &ts) != 0) return 0.0;
  return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

double truck_lift_el_ipm_host_cpu_clock(void) {
  struct timespec ts;
  if (clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts) != 0) return 0.0;
  return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}
