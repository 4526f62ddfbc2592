/* fs_solver.h -- the generated solver the harness is compiled for, and the harness's fixed maxima.
 *
 * Compile with -DSOLVER=<name> -DSOLVER_UPPER=<NAME> -I<generated folder> (see the Makefile): token pasting gives
 * <name>_prepare, <NAME>_N, ... and the headers <name>_solver.h and <name>_model.h. */
#ifndef FS_SOLVER_H
#define FS_SOLVER_H

#ifndef SOLVER
#error "compile with -DSOLVER=<solver name> -DSOLVER_UPPER=<SOLVER NAME IN UPPER CASE>"
#endif
#ifndef SOLVER_UPPER
#error "compile with -DSOLVER_UPPER=<SOLVER NAME IN UPPER CASE>"
#endif

#include "fs_platform.h" /* FS_CAT, FS_STR, the clock, FS_HARNESS_MEM */

#define S_(x) FS_CAT(SOLVER, x) /* S_(_init) -> <name>_init */
#define U_(x) FS_CAT(SOLVER_UPPER, x) /* U_(_N) -> <NAME>_N */

#include FS_STR(S_(_solver).h)
#include FS_STR(S_(_model).h)

typedef S_(_real_t) real_t;
typedef S_(_status_t) status_t;

#define NX U_(_NX)
#define NU U_(_NU)
#define N U_(_N)
#define NOPP U_(_NOPP)
#define NOPP_PAR U_(_NOPP_PAR)
#define ROAD_MAX U_(_ROAD_MAX)
#define PLANT_WINDOW U_(_ROAD_WINDOW)
#define OPP_BLOCK ((N + 1) * NOPP * NOPP_PAR)

/* fixed maximum sizes of the scenario (override with -D) */
#ifndef FS_MAX_ROAD
#define FS_MAX_ROAD 20000
#endif
#ifndef FS_MAX_SAMPLES
#define FS_MAX_SAMPLES 20000
#endif
#define FS_MAX_WORD 128
#define FS_MAX_VERSIONS 8

#endif /* FS_SOLVER_H */
