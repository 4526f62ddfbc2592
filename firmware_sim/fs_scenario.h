/* fs_scenario.h -- the scenario data file (format fcgen-scenario/1, docs/scenario_file.md, written by
 * fcgen.sim.export.export_scenario): its header, the road, and the per-sample opponent records, read like sensor data.
 * A bad file, or one that does not match the compiled solver, ends the program with exit code 2 and one line naming
 * what is wrong. */
#ifndef FS_SCENARIO_H
#define FS_SCENARIO_H

#include "fs_solver.h"

#define SCENARIO_FORMAT "fcgen-scenario/1"
#define FS_MAX_LATENCY 8 /* the largest "latency" (Problem.delay's range) */
#define FS_MAX_STEER_LAG 2.0 /* s, the largest "steer_lag" (fcgen.sim.plants.spec.MAX_STEER_LAG) */

/* a vehicle's dimensions (sim/collision.py's chassis) */
typedef struct {
  double l_f, l_r, l_r_ch, l_f_ch, w_ch;
} fs_dims_t;

/* the file's header: the run's metadata, the ego, the opponents' dimensions, x0 and the road's grid */
typedef struct {
  char problem[FS_MAX_WORD], formulation[FS_MAX_WORD], obstacle_model[FS_MAX_WORD];
  char scenario[FS_MAX_WORD], controller[FS_MAX_WORD];
  char version_key[FS_MAX_VERSIONS][FS_MAX_WORD], version_val[FS_MAX_VERSIONS][FS_MAX_WORD];
  int n_versions;
  long seed;
  int samples, road_window, road_size;
  /* the perturbations between solver and plant (the optional lines; fcgen.sim.plants.actuation): */
  int latency; /* samples between a control's computation and its actuation ("latency"; 0) */
  double steer_lag; /* s, a first-order steering actuator's time constant ("steer_lag"; 0: none) */
  int noisy; /* 1: each sample's record ends in the measured state's error ("noise": the stds) */
  double noise[5];
  char prediction[FS_MAX_WORD]; /* the opponents' futures in opp_params ("prediction"; oracle: the truth) */
  char plant[FS_MAX_WORD], plant_params[FS_MAX_WORD]; /* "plant KIND PARAMS"; model: fcgen's, <name>_plant */
  int external; /* 1: the host steps the plant; each sample's record brings its state ("plant_state") */
  int perturbed; /* any of these: the run log gets the perturbed run's fields (docs/plants.md) */
  double dt, window_behind, n_bound, ego_l;
  fs_dims_t ego_dims, opp_dims[NOPP + 1];
  double x0[5];
  double road_s0, road_ds;
} fs_scenario_t;

extern fs_scenario_t fs_sc;
/* the road's samples (fs_sc.road_size of them; FS_HARNESS_MEM: the board's external RAM on the bare-metal image) */
extern double fs_kappa[FS_MAX_ROAD], fs_phi[FS_MAX_ROAD], fs_gx[FS_MAX_ROAD], fs_gy[FS_MAX_ROAD];
/* the opponents' poses at t_0 .. t_K (NOPP x 3 a sample), for the run log */
extern double fs_opp_cart[(FS_MAX_SAMPLES + 1) * NOPP * 3 + 1];
extern double fs_opp_fr[(FS_MAX_SAMPLES + 1) * NOPP * 3 + 1];
/* the current sample's opponent block for the solver's set_opponents */
extern real_t fs_opp_params[OPP_BLOCK + 1];
/* the current sample's measurement error (the noise's draw; zeros without noise), added to the state the solver gets */
extern double fs_meas_err[5];
/* with an external plant: the current sample's plant state x_j (5), the plant's a_lat and input-limit cut flags of
 * sample j - 1 ("plant_state", j >= 1), and at j = K the plant's a_lat at x_K ("plant_a_lat") */
extern double fs_plant_in[8];

/* Open the file (0; else 2 after one line on stderr). */
int fs_scenario_open(const char *path);
/* Read the header into fs_sc and the road, checking it against the compiled solver. */
void fs_read_header(void);
/* Read the record of sample j (j = 0 .. K): the opponents' poses and, for j < K, the solver's opponent block. */
void fs_read_sample(int j);
/* Read the closing "end" line. */
void fs_read_end(void);
/* Close the file. */
void fs_scenario_close(void);

#endif /* FS_SCENARIO_H */
