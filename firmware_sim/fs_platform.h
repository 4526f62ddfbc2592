/* fs_platform.h -- what closed_loop.c needs from the platform it runs on (one implementation per platform):
 *   fs_host.c       a host: the solver folder's POSIX clock (<name>_host_clock);
 *   fs_baremetal.c  a Cortex-M image under QEMU: vector table, startup, SysTick clock, argv from semihosting. */
#ifndef FS_PLATFORM_H
#define FS_PLATFORM_H

/* Where the harness's large buffers go (scenario, run log). The bare-metal image (-DFS_BAREMETAL) puts them in a
 * section of their own, linked into the board's external RAM, so that the on-chip RAM region holds only what an ECU
 * holds: the solver's data, the C library's, the heap of stdio and the stack. */
#ifdef FS_BAREMETAL
#define FS_HARNESS_MEM __attribute__((section(".bss.fs_harness")))
#else
#define FS_HARNESS_MEM
#endif

/* The solver's timing hook (<name>_set_clock): monotonic time in seconds. */
double fs_clock(void);

/* The raw tick counter for the timing probe of `fcgen wcet` (closed_loop.c with -DFS_PROBE): on the bare-metal
 * platform the SysTick count the clock hook accumulates (FS_SYSTICK_HZ ticks a second; modulo 2^32). */
#include <stdint.h>
uint32_t fs_ticks(void);

#endif /* FS_PLATFORM_H */
