/* fs_geometry.h -- what the run log derives from the states after the loop, as run_closed_loop does: the ego's
 * Cartesian pose on the whole road, the collision flags (the exact separating-axis rectangle test of
 * fcgen.sim.collision: interiors must intersect, touching is no collision), the lateral acceleration. */
#ifndef FS_GEOMETRY_H
#define FS_GEOMETRY_H

#include "fs_scenario.h"

/* Road.to_cartesian on the scenario's whole road: (s, n, alpha) -> rear-axle (x, y, phi) */
void fs_to_cartesian(double s, double n, double alpha, double out[3]);

/* 1 if the chassis of the ego at pose ego[3] overlaps that of any opponent at its pose in opp (NOPP x 3) */
int fs_collides(const double ego[3], const double *opp);

/* a_lat = v^2 tan(delta) / l of a state [s, n, alpha, v, delta] */
double fs_a_lat(const double x[5]);

#endif /* FS_GEOMETRY_H */
