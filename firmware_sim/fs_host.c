/* fs_host.c -- the host platform of closed_loop.c: the solver folder's POSIX clock. */
#include "fs_platform.h"

#define FS_CAT_(a, b) a##b
#define FS_CAT(a, b) FS_CAT_(a, b)
#define FS_STR_(x) #x
#define FS_STR(x) FS_STR_(x)

#include FS_STR(FS_CAT(SOLVER, _host).h)

double fs_clock(void) { return FS_CAT(SOLVER, _host_clock)(); }
