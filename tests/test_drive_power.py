"""The drive's power (``Bounds.P_d_max``): a row ``F_d v <= P_d_max`` per stage 0..N-1, so that the plan keeps the
acceleration a vehicle model with CommonRoad's ``a_max v_switch / v`` limit allows (``drive_rows.power_rows``,
``commonroad.solution.drive_power``)."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest
from one_opponent import window_road

from fcgen.campaign.grid import Config, default_drive_power, grid_extras
from fcgen.dsl import ProblemError
from fcgen.ocp import build_ocp
from fcgen.presets import preset
from fcgen.reference import RtiSolver

SAFE = preset("car_lifted_ellipse_ipm_safe")
A_MAX, V_SWITCH = 11.5, 7.319  # the BMW 320i's longitudinal a_max (m/s^2) and v_switch (m/s), CommonRoad's vehicle 2
POWER = SAFE.ego.m * A_MAX * V_SWITCH  # 97.6 kW for 1160 kg


def _powered(pb, p: float | None = POWER):
    return pb.with_(bounds=replace(pb.bounds, P_d_max=p))


def _rows(pb, stage: str) -> tuple[str, ...]:
    return tuple(r for r in getattr(build_ocp(pb), stage).row_names if r == "power")


def test_the_solution_vehicles_power_by_hand():
    pytest.importorskip("vehiclemodels")
    from fcgen.commonroad.solution import drive_power

    assert drive_power(1160.0) == pytest.approx(1160.0 * 11.5 * 7.319, rel=1e-12)
    assert default_drive_power(True, "safe") == pytest.approx(POWER, rel=1e-12)
    assert default_drive_power(True, "paper") == default_drive_power(False, "safe") == 0.0
    assert grid_extras(None, 0, None, 1, True, "safe")[2:] == ("corners", 1, pytest.approx(POWER))  # a campaign's
    assert grid_extras(None, 0, "rear_axle", 1, False, "safe")[2:] == ("rear_axle", 1, 0.0)


def test_stages_0_to_n_minus_1_carry_the_power_row_where_asked_for():
    pb = _powered(SAFE)
    assert _rows(pb, "first") == _rows(pb, "middle") == ("power",)
    assert _rows(pb, "last") == ()  # no control at N
    assert _rows(SAFE, "middle") == _rows(preset("car_lifted_ellipse_ipm"), "first") == ()  # the presets: none
    assert _rows(_powered(preset("car_direct_elimination_circles_ipm_safe")), "middle") == ("power",)


@pytest.mark.parametrize("stage", ["first", "middle"])
def test_the_power_row_is_force_times_speed(stage):
    ocp = build_ocp(_powered(SAFE))
    st = getattr(ocp, stage)
    i, names = st.row_names.index("power"), list(st.var_names)
    for v, f_d in ((22.0, 7000.0), (5.0, 1e4), (30.0, -8000.0)):
        w = np.zeros(st.nw)
        w[names.index("v")], w[names.index("F_d")] = v, f_d
        g = float(np.array(st.fun(w, np.zeros(ocp.nx), np.zeros(ocp.np_stage))[0]).ravel()[i])
        assert g == pytest.approx(f_d * v / POWER, rel=1e-12)
        assert st.U[i] == 1.0 and st.L[i] < -1e29  # braking never limited


@pytest.mark.parametrize("bad", [0.0, -1.0, math.nan, math.inf, "97 kW"])
def test_p_d_max_is_none_or_positive(bad):
    allowed = r"None \(no power row\) or > 0 W" if bad in (0.0, -1.0) else "a finite real number"
    with pytest.raises(ProblemError, match=rf"bounds.P_d_max = .* is invalid: allowed {allowed}"):
        replace(SAFE.bounds, P_d_max=bad)


def _plan(pb, v0: float) -> tuple[np.ndarray, np.ndarray]:
    """The converged plan's speeds and drive forces from ``v0`` on a straight road, far below the reference speed
    (the plan accelerates as hard as it may)."""
    sv = RtiSolver(build_ocp(pb))
    sv.set_road(window_road(pb))
    opp = np.zeros((pb.horizon.N + 1, pb.opponents.count, 3))
    opp[..., 0], opp[..., 1] = -1000.0, 500.0
    sv.set_opponents(opp)
    sv.set_reference(35.0, 0.0)
    sv.solve_converged(np.array([0.0, 0.0, 0.0, v0, 0.0]), max_sqp=30, tol=1e-7)
    return sv.states()[:-1, 3], sv.controls()[:, 0]


def test_the_plan_accelerates_within_the_power():
    """From 22 m/s towards 35 m/s: with the row every stage's acceleration stays within CommonRoad's
    ``a_max v_switch / v`` (F_d v <= P), at the row's bound at stage 0; without it the plan drives at the force's
    bound, 2x beyond."""
    pb = replace(SAFE.bounds, v_max=40.0)
    v, f = _plan(_powered(SAFE.with_(bounds=pb)), 22.0)
    assert np.all(f * v <= POWER * (1 + 1e-6))
    assert f[0] * v[0] == pytest.approx(POWER, rel=1e-4)
    assert np.all(f / SAFE.ego.m <= A_MAX * V_SWITCH / v * (1 + 1e-6))
    v_free, f_free = _plan(SAFE.with_(bounds=pb), 22.0)
    assert f_free[0] == pytest.approx(SAFE.bounds.F_d_max, rel=1e-3)
    assert f_free[0] * v_free[0] > 2 * POWER


def test_the_checkers_ks_model_reaches_what_the_power_allows():
    """CommonRoad's feasibility check (KS, BMW 320i) on a straight line at 22 m/s: the speed the power's acceleration
    reaches in 0.1 s passes; the drive force's bound (8.6 m/s^2) does not."""
    pytest.importorskip("commonroad_dc")
    from commonroad.common.solution import VehicleModel, VehicleType
    from commonroad.scenario.state import KSState
    from commonroad.scenario.trajectory import Trajectory
    from commonroad_dc.feasibility import feasibility_checker as fc
    from commonroad_dc.feasibility.vehicle_dynamics import VehicleDynamics

    vd = VehicleDynamics.from_model(VehicleModel.KS, VehicleType.BMW_320i)
    dt, v0 = 0.1, 22.0

    def feasible(a: float) -> bool:
        v1 = v0 + a * dt
        states = [
            KSState(time_step=k, position=np.array([x, 0.0]), orientation=0.0, velocity=v, steering_angle=0.0)
            for k, (x, v) in enumerate(((0.0, v0), (dt * (v0 + v1) / 2, v1)))
        ]
        return bool(fc.trajectory_feasibility(Trajectory(0, states), vd, dt)[0])

    at_power = POWER / (SAFE.ego.m * v0)  # 3.83 m/s^2
    assert feasible(0.98 * at_power)
    assert not feasible(SAFE.bounds.F_d_max / SAFE.ego.m)


def test_a_campaigns_drive_power_names_its_problem_and_key():
    cfg = Config("car", "lifted", "ellipse", backend="ipm", profile="safe", road_bound="corners", drive_power=POWER)
    pb = cfg.problem()
    assert pb.bounds.P_d_max == POWER and pb.name.endswith("_cbp")
    assert cfg.key.endswith("/corners/power97.6kW") and cfg.as_dict()["drive_power"] == POWER
    plain = replace(cfg, drive_power=0.0)
    assert plain.problem().bounds.P_d_max is None and "drive_power" not in plain.as_dict()
    with pytest.raises(ProblemError, match=r"drive_power = -1.0 is invalid: allowed a finite float >= 0 W"):
        replace(cfg, drive_power=-1.0)


def test_simulates_drive_power_option():
    """``fcgen simulate --drive-power``: 'vehicle' or watts into ``Bounds.P_d_max``; anything else refused naming the
    option and what it allows; a solver folder without the row refused for a problem with it."""
    import click
    from click.testing import CliRunner

    from fcgen.cli import main
    from fcgen.cli.options import same_bounds, with_chassis_options

    pytest.importorskip("vehiclemodels")
    assert with_chassis_options(SAFE, None, None, "vehicle").bounds.P_d_max == pytest.approx(POWER, rel=1e-12)
    assert with_chassis_options(SAFE, None, None, 5e4).bounds.P_d_max == 5e4
    assert with_chassis_options(SAFE, None, None).bounds.P_d_max is None  # the problem's own
    for bad in ("0", "-3", "inf", "fast"):
        res = CliRunner().invoke(main, ["simulate", "--drive-power", bad])
        assert res.exit_code == 2 and "'vehicle' or a power > 0 W" in res.output, res.output
    with pytest.raises(click.ClickException, match=r"--solver-dir d has P_d_max = None where the problem .* has 97635"):
        same_bounds(SAFE, _powered(SAFE), "d")
    same_bounds(_powered(SAFE), _powered(SAFE), "d")  # the same row: accepted
