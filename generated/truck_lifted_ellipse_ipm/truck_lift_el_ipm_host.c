/* truck_lift_el_ipm_host.c -- host clock for "truck_lift_el_ipm" (POSIX); linked into the example and the shared library only. */
#define _POSIX_C_SOURCE 199309L
#include <time.h>

#include "truck_lift_el_ipm_host.h"

/* nanoseconds of clock `id` modulo 2^32 (0 if it cannot be read) */
static uint32_t ns_ticks(clockid_t id) {
  struct timespec ts;
  if (clock_gettime(id, &ts) != 0) return 0u;
  return (uint32_t)((uint32_t)ts.tv_sec * 1000000000u + (uint32_t)ts.tv_nsec);
}

uint32_t truck_lift_el_ipm_host_clock(void) { return ns_ticks(CLOCK_MONOTONIC); }

uint32_t truck_lift_el_ipm_host_cpu_clock(void) { return ns_ticks(CLOCK_THREAD_CPUTIME_ID); }
