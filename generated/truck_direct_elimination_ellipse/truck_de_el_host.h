/* truck_de_el_host.h -- host-side helpers for "truck_de_el" (example, Python binding); not part of the solver. */
#ifndef TRUCK_DE_EL_HOST_H
#define TRUCK_DE_EL_HOST_H

#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

/* Ticks per second of the host clocks below: they count nanoseconds (modulo 2^32, a wrap every 4.29 s). */
#define TRUCK_DE_EL_HOST_TICKS_PER_SECOND 1000000000u

/* Monotonic clock (POSIX clock_gettime) in ticks; pass it to truck_de_el_set_clock on a host. */
uint32_t truck_de_el_host_clock(void);
/* CPU time of the calling thread in ticks (CLOCK_THREAD_CPUTIME_ID): timings without preemption by other loads. */
uint32_t truck_de_el_host_cpu_clock(void);

#ifdef __cplusplus
}
#endif

#endif /* TRUCK_DE_EL_HOST_H */
