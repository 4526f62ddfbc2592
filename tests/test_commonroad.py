"""CommonRoad scenarios in, CommonRoad solutions out: on small scenarios the tests write with commonroad-io (a straight
and a curved three-lane road, a lane that ends, a truck and cars with given trajectories), the road, its band, the
opponents, the refusals and the two collision checks against hand-derived values; a closed loop with the C = Python."""

from __future__ import annotations

import math
import shutil
import warnings

import numpy as np
import pytest
from click.testing import CliRunner
from crscenes import LANE, write_scenario

from fcgen.campaign.commonroad import load_for
from fcgen.commonroad import (
    ScenarioRefused,
    drivability_verdict,
    fcgen_collisions,
    opponent_horizon,
    select_opponents,
    write_solution,
)
from fcgen.dsl import Horizon
from fcgen.presets import preset

pytestmark = [
    pytest.mark.filterwarnings("ignore::UserWarning"),
    pytest.mark.filterwarnings("ignore::DeprecationWarning"),
]
PB = preset("car_lifted_ellipse_ipm")
CAR = PB.ego
# obstacles: (id, lane, s0, speed, recorded steps, length, width[, first step])
STANDING = (1, 1, 150.0, 0.0, 120, 4.5, 1.8)
TRUCK = (2, 0, 40.0, 15.0, 30, 12.0, 2.5)
LATE = (3, 2, 80.0, 25.0, 20, 4.5, 1.8, 10)


@pytest.fixture(scope="module")
def straight(tmp_path_factory):
    path = write_scenario(tmp_path_factory.mktemp("cr") / "straight.xml", obstacles=[STANDING, TRUCK, LATE])
    return load_for(PB, path)


def test_a_straight_three_lane_road(straight):
    """Lanes of 3.5 m, the ego on the middle one: the band is [-5.25, 5.25] at every sample (the lanelets' edges
    along the normals, exact), the curvature 0; the ego's Frenet start is its rear axle, half the wheelbase behind
    its centre (50, 0)."""
    sc = straight
    assert np.all(np.abs(sc.road.kappa) < 1e-9)
    np.testing.assert_allclose(sc.road.n_min, -1.5 * LANE, atol=1e-6)
    np.testing.assert_allclose(sc.road.n_max, 1.5 * LANE, atol=1e-6)
    x, y, phi = sc.road.to_cartesian(sc.x0[0], sc.x0[1], sc.x0[2])
    assert (float(x), float(y), float(phi)) == pytest.approx((50.0 - CAR.l / 2, 0.0, 0.0), abs=1e-9)
    assert sc.x0[3] == 20.0 and sc.x0[4] == 0.0
    assert (sc.v_ref, sc.v_ref_source) == (20.0, "initial speed")
    assert (sc.samples, sc.samples_source) == (40, "goal time")
    assert sc.road_info["max_deviation_m"] < 1e-6
    # the road reaches the window behind the ego and what the run can reach ahead at v_max, plus the solver's window
    assert sc.road.s0 <= sc.x0[0] - 50.0
    assert sc.road.s_end >= sc.x0[0] + sc.samples * sc.dt * PB.bounds.v_max + (PB.road.samples - 1) * PB.road.ds


def test_a_start_heading_given_with_whole_turns_is_the_same_pose(tmp_path):
    """CommonRoad allows any real orientation (DEU_Muc-2: -3.351 on a lane heading 2.932; DEU_Muc-17: -4.7 on 1.583).
    The ego on the straight road's middle lane given 0 - 2 pi (-6.2831) starts at alpha 8.5e-5, not -2 pi (which no
    step at the yaw rate bound brings inside |alpha| <= alpha_max at stage 1: every QP infeasible, the run on the
    fallback); every QP of the run is solved, the ego stays in its lane heading along it, and the solution starts at
    the problem's -6.2831."""
    from fcgen.sim.commonroad_run import run_commonroad

    safe = preset("car_lifted_ellipse_ipm_safe")  # (the campaign's profile: every QP infeasible before)
    sc = load_for(safe, write_scenario(tmp_path / "turn.xml", ego_turns=-1, goal_steps=(10, 12)))
    assert float(sc.planning_problem.initial_state.orientation) == -6.2831  # (the writer keeps 4 decimals)
    assert sc.x0[2] == pytest.approx(2.0 * math.pi - 6.2831, abs=1e-9)
    run = run_commonroad(safe, sc, criticality=False)
    assert run.log.meta["extra"]["commonroad"]["goal"]["step"] == 10  # (the goal's time steps 10-12, no position)
    assert run.log.exit_code is not None and len(run.log.exit_code) == 10
    assert np.all(run.log.exit_code == 0)
    fr = np.asarray(run.log.ego_frenet)
    assert np.all(np.abs(fr[:, 1]) < 0.5) and np.all(np.abs(fr[:, 2]) < 0.05)
    sol = run.log.meta["extra"]["commonroad"]["solution"]
    assert sol["starts_at_initial_state"] and sol["feasible"] and not sol["road_departure"]
    assert not run.checker["road_departure"]


def test_a_bend_of_constant_radius(tmp_path):
    """A left bend of radius 200 m: the curvature 1/200 on the lanelets (within 1.5 %: the smoothing spline through
    the 2 m polyline), the band still +-5.25 m along the normals, the centre line reproduced within 5 cm."""
    sc = load_for(PB, write_scenario(tmp_path / "bend.xml", radius=200.0, length=500.0, goal_steps=(20, 30)))
    on = slice(30, 200)  # samples on the lanelets, away from their ends
    np.testing.assert_allclose(sc.road.kappa[on], 1 / 200.0, rtol=0.015)
    np.testing.assert_allclose(sc.road.n_min[on], -1.5 * LANE, atol=0.03)
    np.testing.assert_allclose(sc.road.n_max[on], 1.5 * LANE, atol=0.03)
    assert sc.road_info["max_deviation_m"] < 0.05


def test_a_lane_that_ends_narrows_the_band(tmp_path):
    """The left lane ends 150 m along the road: left of the centre line 5.25 m before, 1.75 m after it."""
    sc = load_for(PB, write_scenario(tmp_path / "merge.xml", end_lane=(2, 150.0), goal_steps=(20, 30)))
    s_xy = sc.road.gx  # the road runs along x from x = 0
    before, after = (s_xy > 10.0) & (s_xy < 140.0), (s_xy > 160.0) & (s_xy < 390.0)
    np.testing.assert_allclose(sc.road.n_max[before], 1.5 * LANE, atol=0.021)
    np.testing.assert_allclose(sc.road.n_max[after], 0.5 * LANE, atol=0.021)
    np.testing.assert_allclose(sc.road.n_min[before | after], -1.5 * LANE, atol=0.021)


def test_a_crack_between_lanelets_not_adjacent_ends_the_band(tmp_path):
    """An on-ramp (lane 0) 5 mm right of the ego's lane at x = 0, the crack closing linearly to none at x = 100 (2.5 mm
    at x = 50, 0.25 mm at x = 95). Not adjacent in the map: the drivability checker's road boundary runs along the
    crack (a car across it at x = 60 touches it, at x = 150 not), and the band ends at the ego's lane's right edge,
    -1.75 m, up to x = 100, -5.25 m beyond. Adjacent in the map: the checker's hull spans the crack, the band runs to
    lane 0's right edge, -5.25 m less the gap."""
    from commonroad_dc.boundary.boundary import create_road_boundary_obstacle
    from commonroad_dc.pycrcc import RectOBB

    for adjacent in (False, True):
        path = write_scenario(tmp_path / f"ramp{adjacent}.xml", crack=(0.005, 100.0, adjacent), goal_steps=(20, 30))
        sc = load_for(PB, path)
        _, boundary = create_road_boundary_obstacle(sc.scenario, method="obb_rectangles")
        across = [boundary.collide(RectOBB(2.0, 0.95, 0.0, x, -0.5 * LANE)) for x in (60.0, 150.0)]
        x = sc.road.gx  # the road runs along x from x = 0
        crack, after = (x > 4.0) & (x < 98.0), (x > 102.0) & (x < 390.0)
        assert across == [not adjacent, False]
        ramp = -1.5 * LANE - 0.005 * (1.0 - x[crack] / 100.0)  # lane 0's right edge
        np.testing.assert_allclose(sc.road.n_min[crack], ramp if adjacent else -0.5 * LANE, atol=1e-6)
        np.testing.assert_allclose(sc.road.n_min[after], -1.5 * LANE, atol=1e-6)
        np.testing.assert_allclose(sc.road.n_max[crack | after], 1.5 * LANE, atol=1e-6)


def test_past_the_lanelets_the_road_keeps_its_last_curvature_then_runs_straight(tmp_path):
    """A bend of radius 200 m whose lanelets end 200 m on: the road continues with curvature 1/200 for the horizon
    (4 s at 20 m/s: 80 m), then straight; the band past the end is the last one on the lanelets."""
    sc = load_for(PB, write_scenario(tmp_path / "end.xml", radius=200.0, length=200.0, goal_steps=(20, 30)))
    end = int(np.argmin(np.hypot(sc.road.gx - 200.0 * math.sin(1.0), sc.road.gy - 200.0 * (1 - math.cos(1.0)))))
    held = sc.road.kappa[end : end + 30]  # the spline's last 8 m are extended over too
    assert np.all(held == held[0]) and held[0] == pytest.approx(1 / 200.0, rel=0.03)  # the spline end effect
    assert np.all(sc.road.kappa[end + 40 :] == 0.0) and sc.road.size > end + 60
    np.testing.assert_array_equal(sc.road.n_max[end + 5 :], sc.road.n_max[end + 5])


def test_a_parked_car_and_a_speed_limit(tmp_path):
    """A static obstacle stands at its pose at every step and is always present; a MAX_SPEED sign on the ego's lane
    caps the reference speed (25 m/s leaves the ego's 20 m/s, 15 m/s sets it)."""
    sc = load_for(PB, write_scenario(tmp_path / "park.xml", statics=[(9, 0, 120.0, 4.4, 1.8)], speed_limit=25.0))
    assert (sc.v_ref, sc.v_ref_source) == (20.0, "initial speed")
    sc = load_for(PB, write_scenario(tmp_path / "park.xml", statics=[(9, 0, 120.0, 4.4, 1.8)], speed_limit=15.0))
    car = next(o for o in sc.obstacles if o.id == 9)
    assert car.static and car.present(0) and car.present(500)
    np.testing.assert_allclose(car.pose(300), [120.0, -LANE, 0.0], atol=1e-9)
    assert (sc.v_ref, sc.v_ref_source) == (15.0, "speed limit")


def test_obstacles_shapes_recordings_and_extrapolation(straight):
    """The truck (12 x 2.5 m, lane 0: y = -3.5, 15 m/s from x = 40, recorded steps 0..29): at step 5 x = 47.5; past
    its end (step 39) at constant velocity x = 40 + 15 x 3.9; the late car is not there before step 10."""
    sc = straight
    truck = next(o for o in sc.obstacles if o.id == 2)
    late = next(o for o in sc.obstacles if o.id == 3)
    assert (truck.length, truck.width, truck.first_step, truck.last_step) == (12.0, 2.5, 0, 29)
    np.testing.assert_allclose(truck.pose(5), [47.5, -LANE, 0.0], atol=1e-9)
    np.testing.assert_allclose(truck.pose(39), [40.0 + 15.0 * 3.9, -LANE, 0.0], atol=1e-9)
    assert truck.present(29) and not truck.present(30)
    assert late.pose(9) is None and not late.present(9) and late.present(10)
    np.testing.assert_allclose(late.pose(10), [80.0, LANE, 0.0], atol=1e-9)


def test_the_relevance_rule_and_empty_slots(straight):
    """Nearest first among the present obstacles: at step 0 from (50, 0) the truck (10.6 m), the standing car
    (100 m), the late car not yet there (an empty slot); at step 12 the late car (85, 3.5) comes before the standing
    car. An empty slot holds a small box far beyond the road."""
    sc = straight
    ids = [o.id for o in sc.obstacles]
    assert [ids[i] if i is not None else None for i in select_opponents(sc.obstacles, 0, (50.0, 0.0), 3)] == [
        2,
        1,
        None,
    ]
    assert [ids[i] for i in select_opponents(sc.obstacles, 12, (50.0, 0.0), 3)] == [2, 3, 1]
    poses, shapes, slot_ids = opponent_horizon(sc, 0, (50.0, 0.0), 3, PB.horizon.N)
    assert slot_ids == (2, 1, None)
    np.testing.assert_array_equal(shapes[0], [12.0, 2.5, 0.0])
    np.testing.assert_allclose(poses[10, 0], [40.0 + 15.0, -LANE, 0.0], atol=1e-9)  # 1 s later
    assert poses[0, 2, 0] < float(np.min(sc.road.gx)) - 999.0
    # a grid of coarse intervals: stage k at the node's step (10 one-step intervals, then steps of three)
    offsets = Horizon(N=20, stride=3, fine=10).offsets
    grid, _, _ = opponent_horizon(sc, 0, (50.0, 0.0), 3, 20, offsets)
    np.testing.assert_array_equal(grid[:11], poses[:11])
    np.testing.assert_allclose(grid[12, 0], [40.0 + 1.5 * 16, -LANE, 0.0], atol=1e-9)  # offsets[12] = 16 steps


def test_unusable_scenarios_are_refused_with_one_line(tmp_path):
    cases = [
        (dict(ego_x=50.0, ego_lane=5, lanes=3), "no lanelet at the ego's start"),
        (dict(length=80.0, ego_x=40.0), "shorter than the horizon"),
        (dict(obstacles=[(7, 0, 60.0, 0.0, 5, 4.0, 2.0)], shape="circle"), "obstacle 7: its shape is a Circle"),
        # a 6 m goal centred 40 m behind the ego's centre: its front end 37 m behind
        (dict(ego_x=100.0, goal={"lane": 1, "s": 60.0}), "goal unreachable: the goal's position lies 37.0 m"),
    ]
    for i, (kw, reason) in enumerate(cases):
        path = write_scenario(tmp_path / f"bad{i}.xml", **kw)
        with pytest.raises(ScenarioRefused, match=reason) as e:
            load_for(PB, path)
        assert "\n" not in str(e.value)
    with pytest.raises(ScenarioRefused, match="no planning problem 9"):
        load_for(PB, write_scenario(tmp_path / "ok.xml"), 9)


def _line(y: float, x0: float = 100.0, steps: int = 60) -> np.ndarray:
    return np.stack([x0 + np.arange(steps), np.full(steps, y), np.zeros(steps)], axis=1)


def test_the_drivability_checker_and_fcgen_agree_with_the_hand_derived_contact(straight):
    """The ego (4 x 1.9 m, centre) drives along y = 0 at 1 m a step from x = 100 into the standing car (4.5 m long,
    centred at x = 150): their rectangles meet when 100 + j + 2 > 147.75, first at step 46; along y = -3.5 it passes
    (1.65 m apart); at y = 4.5 its left side (5.45 m) is beyond the road's edge (5.25 m) from step 0."""
    sc = straight
    hit = _line(0.0)
    for verdict in (drivability_verdict(sc, hit, CAR.l_ch, CAR.w_ch), fcgen_collisions(sc, hit, CAR.l_ch, CAR.w_ch)):
        assert verdict["collision"] and verdict["collision_step"] == 46
    assert fcgen_collisions(sc, hit, CAR.l_ch, CAR.w_ch)["obstacle_id"] == 1
    past = _line(-LANE)  # the right lane: the truck (behind, recorded to step 29) does not reach it
    ck = drivability_verdict(sc, past, CAR.l_ch, CAR.w_ch)
    assert not ck["collision"] and not fcgen_collisions(sc, past, CAR.l_ch, CAR.w_ch)["collision"]
    assert not ck["road_departure"]
    off = drivability_verdict(sc, _line(4.5), CAR.l_ch, CAR.w_ch)
    assert off["road_departure"] and off["departure_step"] == 0


def test_the_solution_file_reads_back(straight, tmp_path):
    from commonroad.common.solution import CommonRoadSolutionReader, VehicleModel

    states = np.column_stack([_line(0.0, steps=5), np.full(5, 20.0), np.zeros(5)])
    write_solution(straight, states, tmp_path / "sol.xml")
    sol = CommonRoadSolutionReader.open(str(tmp_path / "sol.xml"))
    pps = sol.planning_problem_solutions[0]
    assert pps.vehicle_model == VehicleModel.KS and pps.planning_problem_id == 1
    st = pps.trajectory.state_list
    assert len(st) == 5 and st[-1].time_step == 4
    np.testing.assert_allclose(st[3].position, [103.0, 0.0])
    assert st[3].velocity == 20.0


@pytest.fixture(scope="module")
def solver_dir(tmp_path_factory):
    from fcgen.codegen.generate import generate

    if shutil.which("gcc") is None:
        pytest.skip("needs gcc")
    return generate(PB, tmp_path_factory.mktemp("crs") / "s").out_dir


def test_a_closed_loop_on_the_scenario_c_equals_python(straight, solver_dir, tmp_path):
    """The ego passes the standing car (the plan moves it left of the car): no collision by either check, inside the
    band, the C's run equal to the reference's; the picture and the run log are written."""
    from fcgen.build import build
    from fcgen.csolver import CSolver
    from fcgen.sim.commonroad_run import run_commonroad
    from fcgen.sim.runlog import RunLog

    sc = straight
    py = run_commonroad(PB, sc)
    cs = CSolver(build(solver_dir))
    c = run_commonroad(PB, sc, controller=cs)
    np.testing.assert_allclose(c.log.ego_frenet, py.log.ego_frenet, rtol=0, atol=1e-8)
    for run in (py, c):
        assert run.agree and not run.fcgen["collision"] and not run.checker["road_departure"]
    n = np.asarray(py.log.ego_frenet)[:, 1]
    assert np.all(n >= -1.5 * LANE + CAR.w_ch / 2 - 0.05) and np.all(n <= 1.5 * LANE)
    assert c.log.meta["extra"]["commonroad"]["slots"][0] == [2, 1, -1]
    c.log.to_json(tmp_path / "run.json")
    back = RunLog.from_json(tmp_path / "run.json")
    assert back.meta["extra"]["commonroad"]["agree"] is True
    assert len(back.opponents) == len(sc.obstacles)


def test_simulate_and_campaign_commands(straight, tmp_path):
    """``fcgen simulate --commonroad`` prints both verdicts and writes the log, the solution and the picture; a
    scenario it cannot drive is one line, exit 1; ``campaign --commonroad`` runs a folder (one refused) into rows, each
    naming its profile, and a summary."""
    from fcgen.cli import main

    folder = tmp_path / "scenarios"
    folder.mkdir()
    good = write_scenario(folder / "a_straight.xml", obstacles=[STANDING, TRUCK], goal_steps=(8, 10))
    bad = write_scenario(folder / "b_short.xml", length=80.0, ego_x=40.0)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        r = CliRunner().invoke(
            main,
            [
                "simulate",
                "--commonroad",
                str(good),
                "--problem",
                "car_lifted_ellipse_ipm",
                "--out",
                str(tmp_path / "log.json"),
                "--solution",
                str(tmp_path / "sol.xml"),
                "--plot",
                str(tmp_path / "run.png"),
                "--animate",
                str(tmp_path / "run.gif"),
            ],
        )
        assert r.exit_code == 0, r.output
        assert "collision: fcgen none, drivability checker none" in r.output
        assert "traffic: recorded; criticality (minimum): TTC ahead " in r.output
        assert all((tmp_path / f).is_file() for f in ("log.json", "sol.xml", "run.png", "run.gif"))
        r = CliRunner().invoke(main, ["simulate", "--commonroad", str(bad), "--problem", "car_lifted_ellipse_ipm"])
        assert r.exit_code == 1 and r.output.count("\n") == 1 and "refused:" in r.output and "horizon" in r.output
        out = tmp_path / "res"
        r = CliRunner().invoke(
            main,
            [
                "campaign",
                "--commonroad",
                str(folder),
                "--scenarios",
                "car",
                "--formulations",
                "lifted",
                "--obstacles",
                "ellipse",
                "--controller",
                "python",
                "--jobs",
                "1",
                "--out",
                str(out),
                "--cache",
                str(tmp_path / "cache"),
            ],
        )
    assert r.exit_code == 0, r.output
    import pandas as pd

    df = pd.read_parquet(out / "commonroad.parquet")
    assert sorted(df.status) == ["ran", "refused"]
    assert list(df.profile) == ["paper", "paper"]  # each row names its profile (the report's planner column)
    assert "horizon" in df[df.status == "refused"].reason.iloc[0]
    assert bool(df[df.status == "ran"].agree.iloc[0])
    assert "Agreement: 1 of 1 runs" in (out / "commonroad.md").read_text()
    assert math.isfinite(float(df[df.status == "ran"].progress_m.iloc[0]))


def test_record_and_regress_a_commonroad_suite(solver_dir, tmp_path):
    """``fcgen record --commonroad`` keeps the run log and a copy of the scenario; ``fcgen regress`` replays it (and
    runs it again in closed loop) within the same-build tolerances; a changed scenario file is unusable input (2)."""
    from fcgen.cli import main

    xml = write_scenario(tmp_path / "rec.xml", obstacles=[STANDING, TRUCK], goal_steps=(15, 20))
    suite = tmp_path / "suite"
    r = CliRunner().invoke(
        main, ["record", str(solver_dir), "-o", str(suite), "--commonroad", str(xml), "--verify", "--plan", "controls"]
    )
    assert r.exit_code == 0, r.output
    assert (suite / "rec.xml").read_bytes() == xml.read_bytes()
    for extra in ([], ["--mode", "closed-loop"]):
        r = CliRunner().invoke(main, ["regress", str(solver_dir), str(suite), *extra])
        assert r.exit_code == 0 and "PASS" in r.output, r.output
    (suite / "rec.xml").write_bytes(xml.read_bytes() + b"<!-- changed -->\n")
    r = CliRunner().invoke(main, ["regress", str(solver_dir), str(suite)])
    assert r.exit_code == 2 and "rec.xml" in r.output, r.output


def test_record_and_regress_in_reactive_traffic(solver_dir, tmp_path):
    """``record --traffic reactive``: a faster vehicle behind the ego in its lane reacts to the ego (the log names it,
    its leader the ego) and keeps its distance; ``regress`` replays and re-runs the suite in the golden log's traffic
    mode within the same-build tolerances."""
    from fcgen.cli import main
    from fcgen.suite import load_log

    fast = (4, 1, 0.0, 28.0, 60, 4.5, 1.8)  # 50 m behind the ego's centre, 8 m/s faster
    xml = write_scenario(tmp_path / "react.xml", obstacles=[STANDING, fast], goal_steps=(25, 30))
    suite = tmp_path / "suite"
    r = CliRunner().invoke(
        main,
        ["record", str(solver_dir), "-o", str(suite), "--commonroad", str(xml), "--traffic", "reactive", "--verify"],
    )
    assert r.exit_code == 0, r.output
    log = load_log(next(suite.glob("cr_*.json.xz")))
    cr = log.meta["extra"]["commonroad"]
    assert cr["traffic"]["mode"] == "reactive"
    assert [(rx[0], rx[3]) for rx in cr["traffic"]["reactions"]] == [(4, "ego")]
    assert not cr["fcgen"]["collision"]
    k = cr["obstacle_ids"].index(4)
    recorded_s = 0.0 + 28.0 * 0.1 * np.arange(len(log.t))
    driven_s = np.asarray(log.opp_cartesian)[:, k, 0]
    assert np.all(driven_s <= recorded_s + 1e-9) and driven_s[-1] < recorded_s[-1] - 1.0  # it braked
    assert cr["criticality"]["error"] == ""
    for extra in ([], ["--mode", "closed-loop"]):
        r = CliRunner().invoke(main, ["regress", str(solver_dir), str(suite), *extra])
        assert r.exit_code == 0 and "PASS" in r.output, r.output
