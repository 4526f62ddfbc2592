"""The plan's drive rows (``PlanCheck.drive_rows``): where the a_lat guard's drive limit would cut a drive force, the
plan does not plan it (``drive_rows.drive_rows``, ``reactions.understeer_excess``)."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest
from one_opponent import window_road

from fcgen.dsl import ProblemError
from fcgen.ocp import build_ocp
from fcgen.presets import preset
from fcgen.reactions import DRIVE_SLACK, G, understeer_drive_limit, understeer_excess
from fcgen.reference import RtiSolver

PROFILE = preset("car_lifted_ellipse_ipm_safe")
SAFE = PROFILE.with_(plan_check=replace(PROFILE.plan_check, drive_rows=True))
NO_DRIVE_LIMIT = SAFE.with_(plan_check=replace(SAFE.plan_check, drive_limit=False, drive_rise=0.0, drive_rows=False))
E, PC = SAFE.ego, SAFE.plan_check


def _excess(a_lat: float, v: float, f_d: float) -> float:
    """The safe car's understeer excess at the formula's ``a_lat``, speed ``v`` and drive force ``f_d``."""
    over = max(abs(a_lat) - DRIVE_SLACK, 0.0)
    return understeer_excess(over, v, f_d / E.m, PC.tyre_stiffness, E.l_f, E.l_r, PC.h_cg)


def test_understeer_excess_by_hand():
    # a_x h v^2 a_over / (c g^2 l_f l_r) with a_x = 1, h = 1, v = 10, a_over = 1, c = 10, l_f = l_r = 1
    assert understeer_excess(1.0, 10.0, 1.0, 10.0, 1.0, 1.0, 1.0) == pytest.approx(100.0 / (10.0 * G * G), rel=1e-12)
    assert _excess(0.25, 20.0, 1e4) == 0.0  # within the slack: none at any force
    assert _excess(-4.0, 20.0, -5000.0) < 0.0  # braking: never limited


@pytest.mark.parametrize("a_lat, v", [(1.0, 10.0), (3.0, 15.0), (-4.95, 20.0), (4.5, 30.0)])
def test_at_the_guards_drive_limit_the_excess_is_the_slack(a_lat, v):
    """The row's boundary is the guard's cap: ``understeer_drive_limit`` inverted."""
    k = 1.0 / (E.l * PC.tyre_stiffness)
    cap = understeer_drive_limit(abs(a_lat), v, k, E.l_f, E.l_r, PC.h_cg, DRIVE_SLACK, math.inf, E.m)
    assert _excess(a_lat, v, cap) == pytest.approx(DRIVE_SLACK, rel=1e-12)


def _rows(pb, stage: str) -> tuple[str, ...]:
    return tuple(r for r in getattr(build_ocp(pb), stage).row_names if r == "drive")


def _with_rows(name: str):
    pb = preset(name)
    return pb.with_(plan_check=replace(pb.plan_check, drive_rows=True))


def test_stages_0_to_n_minus_1_carry_the_drive_row_where_asked_for():
    assert _rows(SAFE, "first") == _rows(SAFE, "middle") == ("drive",)
    assert _rows(SAFE, "last") == ()  # no control at N
    assert _rows(_with_rows("car_direct_elimination_circles_ipm_safe"), "middle") == ("drive",)
    assert _rows(PROFILE, "middle") == _rows(PROFILE, "first") == ()  # off in the safe profile
    assert _rows(preset("car_lifted_ellipse_ipm"), "middle") == ()  # and in the paper's presets
    conventional = preset("car_conventional_ellipse_ipm_safe")  # no a_lat guard there: no rows
    assert _rows(conventional.with_(plan_check=replace(conventional.plan_check, drive_rows=True)), "middle") == ()
    assert _rows(NO_DRIVE_LIMIT, "middle") == ()


@pytest.mark.parametrize("bad", [1, "yes", None])
def test_drive_rows_is_a_bool(bad):
    with pytest.raises(ProblemError, match=r"plan_check.drive_rows = .* is invalid: allowed True or False"):
        replace(PROFILE.plan_check, drive_rows=bad)


def test_drive_rows_need_the_drive_limit():
    with pytest.raises(ProblemError, match=r"plan_check.drive_rows = True is invalid: allowed False without"):
        replace(PROFILE.plan_check, drive_limit=False, drive_rise=0.0, drive_rows=True)


@pytest.mark.parametrize("stage", ["first", "middle"])
def test_the_drive_row_is_the_understeer_excess(stage):
    """Hard at stage 0, on the a_lat slack at 1..N-1; a drive force the guard would cut is beyond the bound."""
    ocp = build_ocp(SAFE)
    st = getattr(ocp, stage)
    i, names = st.row_names.index("drive"), list(st.var_names)
    v, delta = 20.0, -0.03  # turning right: a_lat = -3.53 m/s^2
    a = v * v * math.tan(delta) / E.l
    for f_d, sigma in ((3000.0, 0.0), (3000.0, 0.1), (-5000.0, 0.0)):
        w = np.zeros(st.nw)
        w[names.index("v")], w[names.index("delta")], w[names.index("F_d")] = v, delta, f_d
        if stage == "middle":
            w[names.index("sigma0")] = sigma
        g = float(np.array(st.fun(w, np.zeros(ocp.nx), np.zeros(ocp.np_stage))[0]).ravel()[i])
        want = (_excess(a, v, f_d) - (sigma if stage == "middle" else 0.0)) / SAFE.bounds.a_lat_max
        assert g == pytest.approx(want, rel=1e-9, abs=1e-12)
        assert st.U[i] == pytest.approx(DRIVE_SLACK / SAFE.bounds.a_lat_max)
        assert (_excess(a, v, f_d) > DRIVE_SLACK) == (f_d > 0)  # 3000 N would be cut; braking never is


def _plan_excess(pb) -> np.ndarray:
    """The understeer excess of the converged plan's stages 0..N-1 beyond the a_lat slack (stage 0: none) from a hard
    turn at 14 m/s on a straight road (a_lat 4.5 m/s^2 now; the plan straightens and accelerates towards v_ref)."""
    sv = RtiSolver(build_ocp(pb))
    sv.set_road(window_road(pb))
    opp = np.zeros((pb.horizon.N + 1, pb.opponents.count, 3))
    opp[..., 0], opp[..., 1] = -1000.0, 500.0
    sv.set_opponents(opp)
    v = 14.0
    sv.solve_converged(np.array([0.0, 0.0, 0.0, v, math.atan(4.5 * E.l / v**2)]), max_sqp=30, tol=1e-7)
    xs, us, slack = sv.states(), sv.controls(), np.r_[0.0, sv.slacks()[:, 0]]
    a = xs[:, 3] ** 2 * np.tan(xs[:, 4]) / E.l
    return np.array([_excess(a[k], xs[k, 3], us[k, 0]) - slack[k] for k in range(pb.horizon.N)])


def test_the_plan_drives_as_the_guard_lets_it():
    """With the rows the converged plan's drive forces stay where the guard keeps them (beyond it only by what the
    plan pays as a_lat slack); without, the same plan drives beyond it (it accelerates out of the turn at the drive
    force's bound)."""
    assert _plan_excess(SAFE).max() <= DRIVE_SLACK + 1e-4
    assert _plan_excess(NO_DRIVE_LIMIT).max() > 2 * DRIVE_SLACK
