/* fs_log.h -- the run log (format fcgen-runlog/1, docs/runlog.md), written with the same fields, key order, layout
 * and number formatting (Python's repr of a double) as the Python writer, so C and Python runs compare with
 * fcgen.sim.runlog.compare. The run's metadata, road and opponents come from the scenario (fs_scenario.h). */
#ifndef FS_LOG_H
#define FS_LOG_H

#define RUNLOG_FORMAT "fcgen-runlog/1"

/* what the closed loop recorded: K = samples controls, K + 1 states (row-major arrays) */
typedef struct {
  int samples; /* K */
  int exit_nonzero; /* samples whose solver call returned an error (meta.extra.exit_codes_nonzero) */
  const double *t; /* K + 1 */
  const double *ego_frenet; /* (K + 1) x 5 */
  const double *ego_cartesian; /* (K + 1) x 3 */
  const int *collision; /* K + 1 */
  const double *a_lat; /* K + 1, the plant's */
  const double *a_lat_model; /* K + 1, the model's formula on the same states (a perturbed run's field) */
  const int *plant_cut; /* K, the plant's input-limit cut flags (1 steering rate, 2 angle, 4 acceleration) */
  const double *control; /* K x 2 */
  const double *control_applied; /* K x 2, the controls the plant got; NULL: an unperturbed run (fs_sc.perturbed) */
  const double *max_slack; /* K */
  const double *time_prepare; /* K, seconds */
  const double *time_feedback; /* K, seconds */
  const int *qp_iter; /* K */
  const int *qp_status; /* K */
} fs_run_t;

/* Write the run log to path: 0, or 1 if it cannot be written. */
int fs_write_log(const char *path, const fs_run_t *run);

#endif /* FS_LOG_H */
