/* fs_platform.h -- what closed_loop.c needs from the platform it runs on (one implementation per platform):
 *   fs_host.c       a host: the solver folder's POSIX clock (<name>_host_clock, nanoseconds);
 *   fs_baremetal.c  a Cortex-M image under QEMU: vector table, startup, SysTick clock, argv from semihosting. */
#ifndef FS_PLATFORM_H
#define FS_PLATFORM_H

#include <stdint.h>

#define FS_CAT_(a, b) a##b
#define FS_CAT(a, b) FS_CAT_(a, b)
#define FS_STR_(x) #x
#define FS_STR(x) FS_STR_(x)

/* Where the harness's large buffers go (scenario, run log). The bare-metal image (-DFS_BAREMETAL) puts them in a
 * section of their own, linked into the board's external RAM, so that the on-chip RAM region holds only what an ECU
 * holds: the solver's data, the C library's, the heap of stdio and the stack.
 * FS_TICKS_PER_SECOND: the rate of fs_clock (the harness converts the solver's tick counts to seconds with it). */
#ifdef FS_BAREMETAL
#ifndef FS_SYSTICK_HZ
#error "compile with -DFS_SYSTICK_HZ=<SysTick clock in Hz> (fcgen's target table)"
#endif
#define FS_HARNESS_MEM __attribute__((section(".bss.fs_harness")))
#define FS_TICKS_PER_SECOND FS_SYSTICK_HZ
#else
#include FS_STR(FS_CAT(SOLVER, _host).h)
#define FS_HARNESS_MEM
#define FS_TICKS_PER_SECOND FS_CAT(SOLVER_UPPER, _HOST_TICKS_PER_SECOND)
#endif

/* The solver's timing hook (<name>_set_clock): a free-running tick counter (modulo 2^32). */
uint32_t fs_clock(void);

/* The raw tick counter for the timing probe of `fcgen wcet` (closed_loop.c with -DFS_PROBE): on the bare-metal
 * platform the SysTick count the clock hook accumulates (FS_SYSTICK_HZ ticks a second; modulo 2^32). */
#include <stdint.h>
uint32_t fs_ticks(void);

#endif /* FS_PLATFORM_H */
