/* fs_host.c -- the host platform of closed_loop.c: the solver folder's POSIX clock (nanoseconds). */
#include "fs_platform.h"

uint32_t fs_clock(void) {
  return FS_CAT(SOLVER, _host_clock)();
}
