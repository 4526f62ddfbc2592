/* truck_lift_el_ipm_host.h -- host-side helpers for "truck_lift_el_ipm" (example, Python binding); not part of the solver. */
#ifndef TRUCK_LIFT_EL_IPM_HOST_H
#define TRUCK_LIFT_EL_IPM_HOST_H

#ifdef __cplusplus
extern "C" {
#endif

/* Monotonic clock in seconds (POSIX clock_gettime); pass it to truck_lift_el_ipm_set_clock on a host. */
double truck_lift_el_ipm_host_clock(void);
/* CPU time of the calling thread in seconds (CLOCK_THREAD_CPUTIME_ID): timings without preemption by other loads. */
double truck_lift_el_ipm_host_cpu_clock(void);

#ifdef __cplusplus
}
#endif

#endif /* TRUCK_LIFT_EL_IPM_HOST_H */
