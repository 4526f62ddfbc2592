/* fs_platform.h -- what closed_loop.c needs from the platform it runs on (one implementation per platform):
 *   fs_host.c       a host: the solver folder's POSIX clock (<name>_host_clock);
 *   fs_baremetal.c  a Cortex-M image under QEMU: vector table, startup, SysTick clock, argv from semihosting. */
#ifndef FS_PLATFORM_H
#define FS_PLATFORM_H

/* The solver's timing hook (<name>_set_clock): monotonic time in seconds. */
double fs_clock(void);

#endif /* FS_PLATFORM_H */
