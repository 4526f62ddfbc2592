"""Closed-loop tests (fcgen.sim, SPEC section 7): a quick 30-sample run, and (slow) the paper's truck campaign."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from fcgen.backends import QP_USABLE
from fcgen.ocp import road_window_samples
from fcgen.presets import paper_problem
from fcgen.road import FrenetSingular, LeftRoad, Road
from fcgen.sim.closedloop import WINDOW_BEHIND, Plant, opponent_params, run_closed_loop
from fcgen.sim.plants import PlantSpec
from fcgen.sim.runlog import RunLog, compare, summary
from fcgen.sim.scenario import OPP_SPEED, OpponentParams, make_scenario


@pytest.fixture(scope="module")
def quick_run():
    pb = paper_problem("truck", "lifted", "ellipse")
    sc = make_scenario("truck", 0, samples=30)
    return pb, sc, run_closed_loop(pb, sc)


def test_quick_run_is_safe_and_sane(quick_run):
    _pb, sc, log = quick_run
    s = summary(log)
    assert s["n_states"] == 31 and s["n_controls"] == 30
    assert s["n_collision_samples"] == 0 and not log.collision.any()
    # progress: positive, and at most what 40 m/s would give in 3 s
    assert 0 < s["progress"] <= 40.0 * 3.0
    assert s["progress"] == pytest.approx(log.ego_frenet[-1, 0] - sc.x0[0])
    v = log.ego_frenet[:, 3]
    assert np.all(v >= 0.0) and np.all(v <= 40.0)
    assert np.all(np.abs(log.ego_frenet[:, 1]) <= 10.0 + 1e-6)  # truck scenario road bounds
    # input bounds, up to the QP tolerance: eps_abs = eps_rel = 1e-3 on rows u / u_max (the cold-started first QP
    # gets QpOptions.max_iter_cold iterations; capped at 60 it gave |r| = 0.3933)
    assert np.all(np.abs(log.control[:, 0]) <= 1e4 * (1 + 3e-3))
    assert np.all(np.abs(log.control[:, 1]) <= 0.39 * (1 + 3e-3))
    # every QP solved, or stopped by the iteration cap (solved_inaccurate / max_iter): none failed
    assert np.all(np.isin(log.qp_status, QP_USABLE))
    assert log.meta["extra"]["exit_codes_nonzero"] == 0
    np.testing.assert_array_equal(log.ego_frenet[0], sc.x0)


def test_quick_run_follows_the_plant_model(quick_run):
    """The logged trajectory is the Frenet ODE (SPEC section 2, written here in numpy on the road's interpolants)
    under the logged piecewise-constant controls, up to RK4's error."""
    pb, sc, log = quick_run
    road, veh, wind = sc.road, pb.ego, pb.wind

    def rhs(t, x, u):
        s, n, alpha, v, delta = x
        kappa, phi_g = (float(a) for a in road.eval(s)[:2])
        sdot = v * math.cos(alpha) / (1 - n * kappa)
        v_rel = v + wind.v * math.cos(phi_g + alpha - wind.phi)
        return [
            sdot,
            v * math.sin(alpha),
            v * math.tan(delta) / veh.l - kappa * sdot,
            (u[0] - veh.c_air * v_rel * abs(v_rel) - veh.c_roll) / veh.m,
            u[1],
        ]

    for j in range(30):
        x_next = solve_ivp(rhs, (0, 0.1), log.ego_frenet[j], args=(log.control[j],), rtol=1e-11, atol=1e-11).y[:, -1]
        np.testing.assert_allclose(log.ego_frenet[j + 1], x_next, atol=2e-4)
    # Cartesian log = F^-1 of the Frenet log; opponents drive at 15 m/s along their lane
    x, y, phi = road.to_cartesian(*log.ego_frenet[:, :3].T)
    np.testing.assert_allclose(log.ego_cartesian, np.stack([x, y, phi], axis=1), atol=1e-12)
    np.testing.assert_allclose(np.diff(log.opp_frenet[:, :, 0], axis=0), OPP_SPEED * 0.1, atol=1e-12)
    np.testing.assert_allclose(log.opp_frenet[:, :, 1], np.broadcast_to(sc.opp_n, (31, 3)))


def test_plant_road_stepper_is_step(quick_run):
    """Plant.road_stepper (the closed loop's plant: window parameters from a table) gives Plant.step's states bit
    for bit, and its error off the road."""
    pb, sc, log = quick_run
    plant = Plant(pb, road_window_samples(pb))
    step = plant.road_stepper(sc.road)
    for x, u in zip(log.ego_frenet[:-1], log.control):
        assert step(x, u).tobytes() == plant.step(x, u, sc.road).tobytes()
    off = log.ego_frenet[0].copy()
    off[0] = sc.road.s_end
    with pytest.raises(LeftRoad, match="outside the road"):
        step(off, log.control[0])
    off[0] = sc.road.s0  # the plant's window starts one sample behind the state's segment: before the road
    with pytest.raises(LeftRoad, match="outside the road"):
        plant.step(off, log.control[0], sc.road)
    # near the road's centre of curvature (1 - n kappa = 0.05 <= FRENET_MIN = 0.1, kappa at the state's segment
    # start) the Frenet state is near its singularity: the closed loop's plant refuses to step it; at 0.2 it steps
    i = int(np.argmax(np.abs(sc.road.kappa[10:-10]))) + 10
    near = log.ego_frenet[0].copy()
    near[0] = sc.road.s0 + (i + 0.5) * sc.road.ds
    near[1] = 0.95 / sc.road.kappa[i]
    with pytest.raises(FrenetSingular, match="centre of curvature"):
        step(near, log.control[0])
    near[1] = 0.8 / sc.road.kappa[i]
    assert np.all(np.isfinite(step(near, log.control[0])))


@pytest.mark.parametrize("spec", [None, PlantSpec(latency=1)], ids=["model", "latency"])
def test_a_run_that_leaves_the_road_ends_there(spec):
    """A 500 m road (s from -50 to 450 m) and a car at 15 m/s: the solver's window of 141 samples of 2 m from 50 m
    behind the ego leaves the road once s > 220 m, about 15 s in. The run ends at that sample instead of raising:
    the log keeps the samples before it (states up to that one, whose window is the first outside), says so in
    ``meta.extra.ended_early``, and its figures are those of the shorter run."""
    pb = paper_problem("car", "lifted", "ellipse")
    sc = make_scenario("car", 0, samples=200, road_length=500.0)
    reach = sc.road.s_end - (pb.road.samples - 1) * pb.road.ds + WINDOW_BEHIND  # 450 - 280 + 50 = 220 m
    log = run_closed_loop(pb, sc, plant=spec)
    ended = log.meta["extra"]["ended_early"]
    K = log.n_controls
    assert 100 < K < 200 and ended["sample"] == K and len(log.ego_frenet) == K + 1
    s = log.ego_frenet[:, 0]
    assert s[K] > reach >= s[K - 1]  # the first state whose window leaves the road is the last one logged
    assert f"s = {s[K]:.2f} m left the road [-50.0, 450.0] m" in ended["reason"]
    assert summary(log)["progress"] == pytest.approx(s[K] - s[0])
    assert np.all(np.isfinite(log.ego_frenet)) and not log.collision.any()


def test_opponent_tables_are_kept_per_scenario_on_a_read_only_road(quick_run):
    """opponent_params shares one table between the runs of one scenario (a seed's road, kept per process) and gives
    OpponentParams' values; a road that can change gets a table of its own every time."""
    pb, sc, _ = quick_run
    again = make_scenario("truck", 0, samples=30)
    op = opponent_params(pb, sc)
    assert opponent_params(pb, again) is op
    fresh = OpponentParams(pb, again)
    for j in (0, 5, 29):
        assert op.horizon(j).tobytes() == fresh.horizon(j).tobytes()
    assert opponent_params(pb, make_scenario("truck", 1, samples=30)) is not op
    own = dataclasses.replace(
        sc,
        road=Road(sc.road.s0, sc.road.ds, *(np.array(a) for a in (sc.road.kappa, sc.road.phi, sc.road.gx, sc.road.gy))),
    )
    assert opponent_params(pb, own) is not opponent_params(pb, own)


def test_quick_run_log_round_trips_through_json(quick_run, tmp_path):
    _, _, log = quick_run
    path = log.to_json(tmp_path / "run.json")
    back = RunLog.from_json(path)
    assert all(v == 0.0 for v in compare(log, back).values())
    assert back.meta == log.meta
    assert back.meta["formulation"] == "lifted" and back.meta["obstacle_model"] == "ellipse"
    assert back.to_json_string() == log.to_json_string()
    assert summary(back) == summary(log)


def test_runs_are_reproducible(quick_run):
    pb, _, log = quick_run
    again = run_closed_loop(pb, make_scenario("truck", 0, samples=30))
    d = compare(log, again)
    for name, val in d.items():
        if not name.startswith("time_"):
            assert val == 0.0, name


def test_truck_campaign_paper_finding(tmp_path):
    """20 seeds of the truck scenario, ellipse model, on the compiled C solvers (the campaign's process pool): no
    collisions by the true-rectangle check in any formulation, and both Cartesian-obstacle formulations (direct
    elimination, lifted) progress further on average than the conventional one (paper Sec. V)."""
    from fcgen.campaign.grid import make_tasks, paper_grid
    from fcgen.campaign.runner import run_campaign
    from fcgen.campaign.store import ResultStore

    configs = paper_grid(scenarios=("truck",), obstacles=("ellipse",))
    tasks = make_tasks(configs, range(20), 200, str(tmp_path / "cache"))
    res = run_campaign(tasks, tmp_path / "res", jobs=2)
    assert res.computed == 60 and not res.failed
    rows = ResultStore(tmp_path / "res").read()
    by = {f: rows[rows["formulation"] == f] for f in ("conventional", "direct_elimination", "lifted")}
    for form, r in by.items():
        assert len(r) == 20 and not r["collision"].any(), (form, list(r["n_collision_samples"]))
    conv = by["conventional"]["progress"].mean()
    assert by["lifted"]["progress"].mean() > conv
    assert by["direct_elimination"]["progress"].mean() > conv
