/* ---- fcgen's Riccati interior-point QP backend: the algorithm (plain C99, the same for every problem) ------------
 * Mehrotra predictor-corrector on the layout's QP; the Newton system is solved stage by stage: box rows on the
 * diagonal, each slack eliminated with its rows, a Riccati recursion over (x_k, u_k). The Python reference is
 * fcgen/backends/ipm.py (same algorithm, same order of operations).
 *
 * Hand-written, not a template: what varies per problem (every size as a macro IPM_*, the index tables of the stage
 * view, the workspace struct IPM_W, the real type ipm_real_t, IPM_SQRT / IPM_FABS / IPM_FMIN of that type, the
 * raw-to-generic status map IPM_STATUS, the kernels written out at the problem's sizes) comes from the problem header
 * fcgen renders (templates/backends/ipm_problem.h.j2), included before this file. It also needs from its includer
 * <string.h>, <math.h>, REAL_0 (zero of the real type), qpb_result_t (the RTI core's view of a solve: status,
 * raw_status, iter, z, y) and QPB_PROBE(event) (a timing probe, nothing in a normal build). It defines the backend
 * interface qpb_reset, qpb_set_matrices and qpb_solve; every function is static.
 *
 * One translation unit of the parts below, in this order (each uses only what comes before it). The generated
 * <name>_solver.c contains the problem header and the parts in this order (fcgen reads this list);
 * tests/c/ipm_core_test.c compiles this file on its own with a rendered header. */
#include "ipm_dense.c" /* small dense kernels: finiteness test, max/min, Cholesky factor and solves */
#include "ipm_gen_rows.c" /* a stage's general rows: the generic loops and the one switch to the written-out ones */
#include "ipm_products.c" /* products with A, by stage */
#include "ipm_soft_rows.c" /* the soft rows' fused passes */
#include "ipm_res.c" /* residuals and stopping tests */
#include "ipm_kkt.c" /* the Newton system: factorization, backward and forward sweeps */
#include "ipm_step.c" /* the sides' steps, one Newton direction, the predictor-corrector step */
#include "ipm_solve.c" /* the backend interface: reset, prepare, solve */
