"""The plan's drive rows: where the a_lat guard's drive limit would cut a drive force, the plan does not plan it
(``ocp._drive_rows``, ``reactions.understeer_excess``)."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest
from one_opponent import window_road

from fcgen.ocp import build_ocp
from fcgen.presets import preset
from fcgen.reactions import DRIVE_SLACK, G, understeer_drive_limit, understeer_excess
from fcgen.reference import RtiSolver

SAFE = preset("car_lifted_ellipse_ipm_safe")
NO_DRIVE_LIMIT = SAFE.with_(plan_check=replace(SAFE.plan_check, drive_limit=False, drive_rise=0.0))
E = SAFE.ego


def test_understeer_excess_by_hand():
    # a_x h v^2 (a_lat - 0.25) / (c g^2 l_f l_r) with a_x = 1, h = 1, v = 10, a_lat = 1.25, c = 10, l_f = l_r = 1
    assert understeer_excess(1.25, 10.0, 1.0, 10.0, 1.0, 1.0, 1.0) == pytest.approx(100.0 / (10.0 * G * G), rel=1e-12)
    assert understeer_excess(0.25, 10.0, 1.0, 10.0, 1.0, 1.0, 1.0) == 0.0  # within the slack: no excess at any force


@pytest.mark.parametrize("a_lat, v", [(1.0, 10.0), (3.0, 15.0), (4.95, 20.0), (4.5, 30.0)])
def test_at_the_guards_drive_limit_the_excess_is_the_slack(a_lat, v):
    """The row's boundary is the guard's cap: ``understeer_drive_limit`` inverted."""
    c, pc = SAFE.plan_check.tyre_stiffness, SAFE.plan_check
    k = 1.0 / (E.l * c)
    cap = understeer_drive_limit(a_lat, v, k, E.l_f, E.l_r, pc.h_cg, DRIVE_SLACK, math.inf, E.m)
    assert understeer_excess(a_lat, v, cap / E.m, c, E.l_f, E.l_r, pc.h_cg) == pytest.approx(DRIVE_SLACK, rel=1e-12)


def _rows(pb, stage: str) -> tuple[str, ...]:
    return tuple(r for r in getattr(build_ocp(pb), stage).row_names if r == "drive")


def test_the_middle_stages_carry_the_drive_rows_with_the_drive_limit_only():
    assert _rows(SAFE, "middle") == ("drive",)
    assert _rows(SAFE, "first") == () and _rows(SAFE, "last") == ()  # no control to limit at N; u_0: the guard's
    for name in ("car_lifted_ellipse_ipm", "car_direct_elimination_circles_ipm_safe"):
        assert _rows(preset(name), "middle") == (() if name.endswith("_ipm") else ("drive",))
    assert _rows(preset("car_conventional_ellipse_ipm_safe"), "middle") == ()  # no a_lat guard there
    assert _rows(NO_DRIVE_LIMIT, "middle") == ()


def test_the_drive_row_is_the_understeer_excess_of_a_drive_force_and_nothing_when_braking():
    ocp = build_ocp(SAFE)
    st = ocp.middle
    i = st.row_names.index("drive")
    v, delta = 20.0, -0.03  # turning right: a_lat < 0, the lo row's
    a = v * v * math.tan(delta) / E.l
    for f_d, sigma in ((3000.0, 0.0), (3000.0, 0.1), (-5000.0, 0.0)):
        w = np.zeros(st.nw)
        names = list(st.var_names)
        w[names.index("v")], w[names.index("delta")], w[names.index("F_d")] = v, delta, f_d
        w[names.index("sigma0")] = sigma
        g = np.array(st.fun(w, np.zeros(ocp.nx), np.zeros(ocp.np_stage))[0]).ravel()
        pc = SAFE.plan_check
        ex = [
            understeer_excess(s * a, v, max(f_d, 0.0) / E.m, pc.tyre_stiffness, E.l_f, E.l_r, pc.h_cg) for s in (1, -1)
        ]
        want = (max(ex) - sigma) / SAFE.bounds.a_lat_max  # |a_lat|: the larger of the two sides
        assert g[i] == pytest.approx(want, rel=1e-9, abs=1e-12)
        assert (ex[1] > DRIVE_SLACK) == (f_d > 0)  # this drive force would be cut; braking never is


def _plan_excess(pb) -> np.ndarray:
    """The understeer excess of the converged plan's stages 2..N-1 from a hard turn at 14 m/s on a straight road
    (a_lat 4.5 m/s^2 now; the plan straightens and accelerates towards v_ref)."""
    sv = RtiSolver(build_ocp(pb))
    sv.set_road(window_road(pb))
    opp = np.zeros((pb.horizon.N + 1, pb.opponents.count, 3))
    opp[..., 0], opp[..., 1] = -1000.0, 500.0
    sv.set_opponents(opp)
    v = 14.0
    sv.solve_converged(np.array([0.0, 0.0, 0.0, v, math.atan(4.5 * E.l / v**2)]), max_sqp=30, tol=1e-7)
    xs, us, pc = sv.states(), sv.controls(), pb.plan_check
    a = xs[:, 3] ** 2 * np.tan(xs[:, 4]) / E.l
    return np.array(
        [
            understeer_excess(abs(a[k]), xs[k, 3], max(us[k, 0], 0.0) / E.m, pc.tyre_stiffness, E.l_f, E.l_r, pc.h_cg)
            for k in range(2, pb.horizon.N)
        ]
    )


def test_the_plan_drives_as_the_guard_lets_it():
    """With the rows the converged plan's drive forces stay where the guard keeps them; without, the same plan drives
    beyond it (the plan accelerates out of the turn at the drive force's bound)."""
    assert _plan_excess(SAFE).max() <= DRIVE_SLACK + 1e-4
    assert _plan_excess(NO_DRIVE_LIMIT).max() > 2 * DRIVE_SLACK
