"""The plan's drive rows (``PlanCheck.drive_rows``): the a_lat guard's drive limit outside its steering as rows of the
OCP, so that the plan does not plan a drive force the guard will cut.

A row is ``(name, g, lower, upper)`` as in ``ocp``; ``g`` is in units of ``bounds.a_lat_max``, as the a_lat rows.
"""

from __future__ import annotations

import casadi as ca

from .dsl import Problem
from .reactions import DRIVE_SLACK, understeer_excess

INF = 1e30  # OSQP_INFTY (as ocp.INF)


def drive_rows(pb: Problem, xs: ca.SX, us: ca.SX, sigma: ca.SX, a: ca.SX) -> dict[str, list[tuple]]:
    """The rows of stage 0 (``"first"``: hard, a bound on u_0 from the measured state, as the guard's) and of stages
    1..N-1 (``"middle"``: soft on the a_lat slack ``sigma``): ``reactions.understeer_excess`` of the stage's state
    ``xs``, control ``us`` and formula's a_lat ``a`` within ``reactions.DRIVE_SLACK``; braking gives a negative
    excess, never limited. None without ``drive_rows``, the a_lat guard or tyres."""
    pc, e, bnd = pb.plan_check, pb.ego, pb.bounds
    if not (pc.a_lat_guard and pc.drive_rows and pc.tyre_stiffness > 0):
        return {"first": [], "middle": []}
    over = ca.fmax(ca.fabs(a) - DRIVE_SLACK, 0.0)
    excess = understeer_excess(over, xs[3], us[0] / e.m, pc.tyre_stiffness, e.l_f, e.l_r, pc.h_cg)
    hi = DRIVE_SLACK / bnd.a_lat_max
    return {
        "first": [("drive", excess / bnd.a_lat_max, -INF, hi)],
        "middle": [("drive", (excess - sigma) / bnd.a_lat_max, -INF, hi)],
    }
