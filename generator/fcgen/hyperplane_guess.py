"""The separating hyperplanes' cold-start guess: per opponent the plane through the midpoint of the ego's and the
opponent's centres, normal to the line between them. A CasADi function of a stage's state and parameters, used by the
reference's initial guess (``RtiSolver.initial_guess``) and emitted as the generated C's ``<name>_theta_init``.
"""

from __future__ import annotations

import casadi as ca

from . import obstacles as obs
from .dsl import Conventional, SeparatingHyperplane
from .ocp import Ocp
from .road import casadi_to_cartesian


def theta_init(ocp: Ocp) -> ca.Function:
    """Initial separating hyperplanes: normal from the ego centre to the opponent centre, through the midpoint."""
    x = ca.SX.sym("x", ocp.nx)
    p = ca.SX.sym("p", ocp.np_stage)
    pb = ocp.problem
    if not isinstance(pb.obstacles, SeparatingHyperplane):
        return ca.Function("theta_init", [x, p], [ca.SX(0, 1)])
    rp = ocp.road_params
    out = []
    for j in range(pb.opponents.count):
        pj = p[ocp.p_opp][j * ocp.n_opp_stage : (j + 1) * ocp.n_opp_stage]
        if isinstance(pb.formulation, Conventional):
            ego = obs.frenet_ego_shape(x[0], x[1], x[2], 1.0, pb.ego)
            opp = obs.Shape(pj[0], pj[1], pj[2], pj[3], pj[4])
        else:
            px, py, phi = (
                (x[5], x[6], x[7])
                if ocp.state_kind == "lifted"
                else casadi_to_cartesian(x[0], x[1], x[2], p[ocp.p_road], rp.samples)
            )
            ego = obs.chassis_shape(px, py, phi, pb.ego)
            opp = obs.shape_of(pj[0], pj[1], pj[2], pj[3:])
        out += obs.midpoint_plane(ego, opp)
    return ca.Function("theta_init", [x, p], [ca.vertcat(*out)])
