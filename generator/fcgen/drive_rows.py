"""The plan's drive rows: the a_lat guard's drive limit outside its steering (``PlanCheck.drive_rows``), so that the
plan does not plan a drive force the guard will cut; and the drive's power (``Bounds.P_d_max``).

A row is ``(name, g, lower, upper)`` as in ``ocp``; the guard's ``g`` is in units of ``bounds.a_lat_max``, as the a_lat
rows, the power's in units of ``P_d_max``.
"""

from __future__ import annotations

import casadi as ca

from .dsl import Problem
from .reactions import DRIVE_SLACK, understeer_excess

INF = 1e30  # OSQP_INFTY (as ocp.INF)


def power_rows(pb: Problem, xs: ca.SX, us: ca.SX) -> list[tuple]:
    """``F_d v <= P_d_max`` (hard; braking, ``F_d < 0``, never limited); at stage 0 a bound on u_0 from the measured
    speed. None without ``Bounds.P_d_max``."""
    p_max = pb.bounds.P_d_max
    return [] if p_max is None else [("power", us[0] * xs[3] / p_max, -INF, 1.0)]


def drive_rows(pb: Problem, xs: ca.SX, us: ca.SX, sigma: ca.SX, a: ca.SX) -> dict[str, list[tuple]]:
    """The rows of stage 0 (``"first"``: hard, a bound on u_0 from the measured state, as the guard's) and of stages
    1..N-1 (``"middle"``: soft on the a_lat slack ``sigma``): ``reactions.understeer_excess`` of the stage's state
    ``xs``, control ``us`` and formula's a_lat ``a`` within ``reactions.DRIVE_SLACK``; braking gives a negative
    excess, never limited (none without ``drive_rows``, the a_lat guard or tyres); then ``power_rows``."""
    pc, e, bnd = pb.plan_check, pb.ego, pb.bounds
    power = power_rows(pb, xs, us)
    if not (pc.a_lat_guard and pc.drive_rows and pc.tyre_stiffness > 0):
        return {"first": power, "middle": power}
    over = ca.fmax(ca.fabs(a) - DRIVE_SLACK, 0.0)
    excess = understeer_excess(over, xs[3], us[0] / e.m, pc.tyre_stiffness, e.l_f, e.l_r, pc.h_cg)
    hi = DRIVE_SLACK / bnd.a_lat_max
    return {
        "first": [("drive", excess / bnd.a_lat_max, -INF, hi), *power],
        "middle": [("drive", (excess - sigma) / bnd.a_lat_max, -INF, hi), *power],
    }
