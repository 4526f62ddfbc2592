"""Predicted traffic on CommonRoad scenarios (``fcgen.sim.cr_prediction``, ``--prediction`` with ``--commonroad``):
each rule against poses derived by hand on scenarios written with commonroad-io (a straight lane; a lanelet whose
successor turns; a fork; a bend), the solver seeing the prediction while the judge sees the recording, and the
command lines."""

from __future__ import annotations

import math

import numpy as np
import pytest
from click.testing import CliRunner
from crscenes import LANE, write_scenario

from fcgen.campaign.commonroad import load_for
from fcgen.cli import main
from fcgen.commonroad.traffic import CrObstacle
from fcgen.ocp import build_ocp
from fcgen.presets import preset
from fcgen.sim.closedloop import ReferenceController
from fcgen.sim.commonroad_run import run_commonroad
from fcgen.sim.cr_prediction import LanePath, ScenarioPrediction
from fcgen.sim.plants import PlantSpec

pytestmark = [
    pytest.mark.filterwarnings("ignore::UserWarning"),
    pytest.mark.filterwarnings("ignore::DeprecationWarning"),
]
PB = preset("car_lifted_ellipse_ipm_safe")
DT = 0.1


def _obstacle(xy_phi: np.ndarray, speeds=None, first: int = 0) -> CrObstacle:
    c = np.asarray(xy_phi, dtype=float)
    return CrObstacle(7, False, 4.5, 1.8, first, first + len(c) - 1, c, 0.0, DT, speeds)


def _network(tmp_path, lanelets):
    """The lanelets (id, centre vertices, successors) with 3.5 m width, written to a scenario file with commonroad-io
    and read back: the network as a loaded scenario has it."""
    from commonroad.common.file_reader import CommonRoadFileReader
    from commonroad.common.file_writer import CommonRoadFileWriter, OverwriteExistingFile
    from commonroad.planning.planning_problem import PlanningProblemSet
    from commonroad.scenario.lanelet import Lanelet, LaneletNetwork
    from commonroad.scenario.scenario import Scenario, ScenarioID

    lls = []
    for lid, centre, succ in lanelets:
        c = np.asarray(centre, dtype=float)
        d = np.gradient(c, axis=0)
        nrm = np.column_stack([-d[:, 1], d[:, 0]]) / np.hypot(d[:, 0], d[:, 1])[:, None]
        lls.append(Lanelet(c + LANE / 2 * nrm, c, c - LANE / 2 * nrm, lid, successor=list(succ)))
    sc = Scenario(DT, scenario_id=ScenarioID(country_id="ZAM", map_name="Pred", map_id=1))
    sc.add_objects(LaneletNetwork.create_from_lanelet_list(lls))
    path = tmp_path / "net.xml"
    CommonRoadFileWriter(sc, PlanningProblemSet([]), "fcgen tests", "fcgen", "", set()).write_to_file(
        str(path), OverwriteExistingFile.ALWAYS
    )
    return CommonRoadFileReader(str(path)).open()[0].lanelet_network


def test_straight_lane_every_rule_by_hand(tmp_path):
    """A vehicle braking at b = 2 m/s^2 from 15 m/s along y = 0: constant velocity goes on at the mean speed of the
    last 5 samples, constant acceleration finds -2 exactly and stops where v^2 / (2 b) says, lane-following goes on
    the lane's centre at the same mean speed; seen once, the recorded speed."""
    net = _network(tmp_path, [(1, [[x, 0.0] for x in range(0, 401, 10)], [])])
    t = np.arange(60) * DT
    x = 50.0 + 15.0 * t - t**2  # v = 15 - 2 t
    ob = _obstacle(np.column_stack([x, np.zeros_like(x), np.zeros_like(x)]), speeds=15.0 - 2.0 * t)
    now, tau = 20, np.array([0.5, 1.0, 3.0])
    v_mean = (x[now] - x[now - 5]) / (5 * DT)  # the speed at the span's middle: 15 - 2 (1.75) = 11.5
    assert v_mean == pytest.approx(11.5)
    cv = ScenarioPrediction("constant-velocity", None, DT).predict(ob, now, tau)
    np.testing.assert_allclose(cv[:, 0], x[now] + 11.5 * tau, atol=1e-9)
    np.testing.assert_allclose(cv[:, 1:], 0.0, atol=1e-12)
    ca = ScenarioPrediction("constant-acceleration", None, DT).predict(ob, now, np.array([0.5, 1.0, 10.0]))
    v_now = 15.0 - 2.0 * 2.0  # 11 m/s at t = 2 s; stops after 5.5 s, 30.25 m on
    np.testing.assert_allclose(ca[:, 0], x[now] + np.array([11 * 0.5 - 0.25, 11 - 1, 11**2 / 4]), atol=1e-9)
    assert v_now == 11.0
    lf = ScenarioPrediction("lane-following", net, DT).predict(ob, now, tau)
    np.testing.assert_allclose(lf, cv, atol=1e-9)  # the lane's centre is the line it drives
    first = ScenarioPrediction("constant-velocity", None, DT).predict(ob, 0, tau)
    np.testing.assert_allclose(first[:, 0], 50.0 + 15.0 * tau, atol=1e-9)  # seen once: its recorded 15 m/s
    lone = _obstacle(np.zeros((1, 3)))  # seen once, no speed recorded: standing
    np.testing.assert_allclose(ScenarioPrediction("constant-velocity", None, DT).predict(lone, 0, tau), 0.0)
    off = ScenarioPrediction("lane-following", net, DT).predict(_obstacle([[0.0, 30.0, 0.0]] * 8), 7, tau)
    np.testing.assert_allclose(off[:, :2], [[0.0, 30.0]] * 3)  # off every lanelet: constant velocity (here 0)


def test_lane_following_takes_the_successor_and_keeps_the_offset(tmp_path):
    """Lanelet 1 along x to (20, 0), its successor 2 turning left up to (20, 30): a vehicle 0.5 m left of the centre
    at x = 10, 10 m/s, is 15 m on after 1.5 s: 5 m up lanelet 2, still 0.5 m left of it (x = 19.5), heading pi/2;
    after 5 s 50 m on: 10 m past lanelet 2's end, straight on. At a fork the successor that turns least."""
    up = (2, [[20.0, y] for y in range(0, 31, 5)], [])
    net = _network(tmp_path, [(1, [[x, 0.0] for x in range(0, 21, 5)], [2]), up])
    hist = np.array([[10.0 - 10.0 * DT * k, 0.5, 0.0] for k in range(10, -1, -1)])
    ob = _obstacle(hist)
    p = ScenarioPrediction("lane-following", net, DT).predict(ob, 10, np.array([0.5, 1.5, 5.0]))
    np.testing.assert_allclose(p, [[15.0, 0.5, 0.0], [19.5, 5.0, math.pi / 2], [19.5, 40.0, math.pi / 2]], atol=1e-9)
    ahead = (3, [[x, 0.0] for x in range(20, 61, 5)], [])
    fork = _network(tmp_path, [(1, [[x, 0.0] for x in range(0, 21, 5)], [2, 3]), up, ahead])
    p = ScenarioPrediction("lane-following", fork, DT).predict(ob, 10, np.array([1.5]))
    np.testing.assert_allclose(p, [[25.0, 0.5, 0.0]], atol=1e-9)
    path = LanePath.of([[0.0, 0.0], [20.0, 0.0], [20.0, 0.0], [20.0, 30.0]])  # a repeated joint vertex once
    assert path.s.tolist() == [0.0, 20.0, 50.0]
    assert path.project(25.0, 10.0) == (pytest.approx(30.0), pytest.approx(-5.0))  # right of the upward leg


def test_noise_and_bad_kind():
    ob = _obstacle([[float(k), 0.0, 0.0] for k in range(12)])
    pred = ScenarioPrediction("constant-velocity", None, DT, noise=(0.05, 0.05, 0.005), seed=3)
    a, b = pred.observed(ob, 11), pred.observed(ob, 11)
    np.testing.assert_array_equal(a, b)  # the same draw each time it is asked for
    assert 0 < np.max(np.abs(a - [11.0, 0.0, 0.0])) < 0.3
    with pytest.raises(ValueError, match="prediction = 'oracle' is invalid"):
        ScenarioPrediction("oracle", None, DT)
    with pytest.raises(ValueError, match="lanelet network"):
        ScenarioPrediction("lane-following", None, DT)


class _Spy(ReferenceController):
    """The reference controller, keeping the opponents' poses it is given at each sample."""

    def __init__(self, ocp):
        super().__init__(ocp)
        self.seen: list[np.ndarray] = []

    def step(self, x, win, poses):
        self.seen.append(np.array(poses, copy=True))
        return super().step(x, win, poses)


@pytest.fixture(scope="module")
def bend(tmp_path_factory):
    """A left bend of radius 150 m, a car 30 m ahead of the ego in its lane, both at 15 m/s, 12 samples."""
    path = tmp_path_factory.mktemp("bend") / "bend.xml"
    return write_scenario(
        path, radius=150.0, ego_v=15.0, obstacles=[(7, 1, 80.0, 15.0, 80, 4.5, 1.8)], goal_steps=(12, 12)
    )


@pytest.mark.parametrize("kind", ["lane-following", "constant-velocity"])
def test_the_solver_sees_the_prediction_the_judge_the_recording(bend, kind):
    """In a bend lane-following predicts the car's arc (within 5 cm over the horizon) and constant velocity its
    tangent (hand-derived: the chord's mean speed along the heading seen); the run's log and verdicts keep the
    recording."""
    sc = load_for(PB, bend)
    spy = _Spy(build_ocp(PB))
    run = run_commonroad(PB, sc, controller=spy, plant=PlantSpec(prediction=kind), criticality=False)
    ob, offs = sc.obstacles[0], np.asarray(PB.horizon.offsets)
    r = 150.0  # the car's lane is the ego's, whose centre is the reference line
    for j, poses in enumerate(spy.seen):
        truth = np.array([ob.pose(sc.first_step + j + int(k)) for k in offs])
        if kind == "lane-following":
            np.testing.assert_allclose(poses[:, 0, :2], truth[:, :2], atol=0.05)
            continue
        span = min(5, j)
        v = 15.0 if span == 0 else 2 * r * math.sin(15.0 * span * DT / (2 * r)) / (span * DT)  # chord / time
        p0, tau = truth[0], offs * DT
        expect = p0[:2] + np.outer(v * tau, [math.cos(p0[2]), math.sin(p0[2])])
        np.testing.assert_allclose(poses[:, 0, :2], expect, atol=2e-3)  # the file keeps 4 decimals of a position
        assert np.hypot(*(poses[-1, 0, :2] - truth[-1, :2])) > 1.0  # the tangent leaves the arc
    steps = sc.first_step + np.arange(len(run.log.opp_cartesian))
    np.testing.assert_allclose(run.log.opp_cartesian[:, 0], [ob.pose(int(t)) for t in steps], atol=1e-9)
    assert run.log.meta["extra"]["plant"]["prediction"] == kind and not run.fcgen["collision"]


def test_commands_take_the_prediction_and_key_campaign_rows_by_it(bend, tmp_path):
    args = ["simulate", "--commonroad", str(bend), "--problem", "car_lifted_ellipse_ipm_safe", "--samples", "3"]
    r = CliRunner().invoke(main, [*args, "--prediction", "lane-following"])
    assert r.exit_code == 0, r.output
    assert "plant model+lane |" in r.output
    r = CliRunner().invoke(main, [*args, "--prediction", "constant-velocity", "--prediction-margin", "1"])
    assert r.exit_code == 1 and "--prediction-margin is not for --commonroad" in r.output
    r = CliRunner().invoke(main, [*args, "--prediction", "sideways"])
    assert r.exit_code == 2 and "--prediction" in r.output and "lane-following" in r.output
    folder = tmp_path / "sc"
    folder.mkdir()
    (folder / "bend.xml").write_bytes(bend.read_bytes())
    camp = ["campaign", "--commonroad", str(folder), "--scenarios", "car", "--formulations", "lifted"]
    camp += ["--obstacles", "ellipse", "--controller", "python", "--profile", "safe", "--jobs", "1"]
    camp += ["--no-criticality", "--out", str(tmp_path / "res"), "--cache", str(tmp_path / "cache")]
    for pred in ("oracle", "constant-velocity", "constant-velocity"):  # the third: resumed, nothing run
        r = CliRunner().invoke(main, [*camp, "--prediction", pred])
        assert r.exit_code == 0, r.output
    assert "1 runs, 1 already in" in r.output
    import pandas as pd

    df = pd.read_parquet(tmp_path / "res" / "commonroad.parquet")
    assert sorted(df.prediction) == ["constant-velocity", "oracle"] and (df.status == "ran").all()
    r = CliRunner().invoke(main, [*camp, "--prediction", "oracle", "--latency", "1"])
    assert r.exit_code == 1 and "no --plant, --latency, --steer-lag, --noise" in r.output
