/* fs_plant.h -- the discrete plant: the generated <name>_plant (the RK4 Frenet step of <name>_model.c, the same
 * CasADi function the Python closed loop calls) on the local road window around the state. */
#ifndef FS_PLANT_H
#define FS_PLANT_H

/* x_{j+1} = plant(x_j, u_j) on the road window starting one sample behind s_j: 0, or 3 (the window is outside the
 * road, or the evaluation failed) after one line on stderr naming sample j. */
int fs_plant_step(int j, const double x[5], const double u[2], double xn[5]);

#endif /* FS_PLANT_H */
