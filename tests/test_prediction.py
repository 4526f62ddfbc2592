"""Predicted traffic (docs/plants.md, "Predicted traffic"): each predictor against the motion it assumes (hand-derived:
it must be exact there), the seeded observation noise, and the closed loop (the solver sees the prediction, the
collision check the truth; oracle is today's loop)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from fcgen.dsl import ProblemError
from fcgen.road import Road
from fcgen.sim.plants import PREDICTIONS, PlantSpec
from fcgen.sim.prediction import SPAN, PredictedOpponents

DT = 0.1
OFFSETS = np.arange(21)


def _line(s_of_t, heading=0.3, start=(4.0, -2.0)):
    """Two opponents on straight lines with progress s(t): poses [x, y, phi] at sample j."""

    def truth(j: int) -> np.ndarray:
        s = s_of_t(j * DT)
        return np.array(
            [
                [start[0] + s * math.cos(heading), start[1] + s * math.sin(heading), heading],
                [start[0] + 3 + 0.5 * s * math.cos(-heading), start[1] + 0.5 * s * math.sin(-heading), -heading],
            ]
        )

    return truth


def _true_horizon(truth, i):
    return np.stack([truth(i + int(k)) for k in OFFSETS])


@pytest.mark.parametrize("delay", [0, 2])
def test_constant_velocity_is_exact_for_a_constant_velocity_opponent(delay):
    truth = _line(lambda t: 12.0 * t)
    pred = PredictedOpponents("constant-velocity", truth, OFFSETS, DT, delay=delay)
    for i in (0, 7, 30):
        assert np.allclose(pred.horizon(i), _true_horizon(truth, i), atol=1e-9)


def test_constant_acceleration_is_exact_for_constant_acceleration_and_cv_is_not():
    truth = _line(lambda t: 10.0 * t + 0.5 * 1.5 * t**2)
    ca = PredictedOpponents("constant-acceleration", truth, OFFSETS, DT, delay=1)
    cv = PredictedOpponents("constant-velocity", truth, OFFSETS, DT, delay=1)
    for i in (3, 40):
        assert np.allclose(ca.horizon(i), _true_horizon(truth, i), atol=1e-9)
    # CV: speed of the last span's middle, held: behind by a (SPAN dt / 2 * tau + tau^2 / 2) at the horizon's end
    tau = (OFFSETS[-1] + 1) * DT
    lag = 1.5 * (SPAN * DT / 2 * tau + tau**2 / 2)
    err = np.hypot(*(cv.horizon(40)[-1, 0, :2] - _true_horizon(truth, 40)[-1, 0, :2]))
    assert err == pytest.approx(lag, rel=1e-9)


def test_constant_acceleration_stops_a_braking_opponent():
    v0, a = 8.0, -4.0  # stops after 2 s, 8 m

    def s(t):
        t = min(t, -v0 / a)
        return v0 * t + 0.5 * a * t**2

    truth = _line(s)
    pred = PredictedOpponents("constant-acceleration", truth, OFFSETS, DT)
    assert np.allclose(pred.horizon(12), _true_horizon(truth, 12), atol=1e-9)  # observed until 1.2 s, stops at 2 s


def test_lane_following_on_a_circle_arc_keeps_the_offset():
    R, n_off, sdot = 50.0, 1.5, 12.0
    road = Road.from_curvature(np.full(200, 1.0 / R), 1.0, s0=-50.0)  # less than one turn

    def truth(j: int) -> np.ndarray:
        s = np.array([20.0, 60.0]) + sdot * j * DT
        x, y, phi = road.to_cartesian(s, np.array([n_off, -n_off]), np.zeros(2))
        return np.stack([x, y, phi], axis=-1)

    lane = PredictedOpponents("lane-following", truth, OFFSETS, DT, road=road, delay=1)
    cv = PredictedOpponents("constant-velocity", truth, OFFSETS, DT, road=road, delay=1)
    got = lane.horizon(10)
    assert np.allclose(got, _true_horizon(truth, 10), atol=1e-7)
    _, n, _ = road.to_frenet(got[..., 0].ravel(), got[..., 1].ravel(), got[..., 2].ravel())
    assert np.allclose(n.reshape(got.shape[:2]), [n_off, -n_off], atol=1e-7)
    # a straight line leaves the circle: at 2.1 s (25.2 m of arc) the tangent is ~ arc^2 / (2 R) outside it
    assert np.hypot(*(cv.horizon(10)[-1, 0, :2] - got[-1, 0, :2])) > 3.0


def test_observation_noise_is_seeded_and_the_same_each_time_asked():
    truth = _line(lambda t: 12.0 * t)
    a = PredictedOpponents("constant-velocity", truth, OFFSETS, DT, noise=(0.05, 0.05, 0.005), seed=4)
    b = PredictedOpponents("constant-velocity", truth, OFFSETS, DT, noise=(0.05, 0.05, 0.005), seed=4)
    c = PredictedOpponents("constant-velocity", truth, OFFSETS, DT, noise=(0.05, 0.05, 0.005), seed=5)
    first = a.horizon(9).copy()
    assert np.array_equal(first, a.horizon(9)) and np.array_equal(first, b.horizon(9))
    assert not np.array_equal(first, c.horizon(9))
    d = a.observed(9) - truth(9)
    assert 0 < np.max(np.abs(d[:, :2])) < 0.5 and np.max(np.abs(d[:, 2])) < 0.05


def test_bad_prediction_names_the_field():
    with pytest.raises(ProblemError, match="prediction"):
        PlantSpec(prediction="kalman")
    with pytest.raises(ValueError, match="lane-following"):
        PredictedOpponents("lane-following", _line(lambda t: t), OFFSETS, DT)
    assert PlantSpec().is_default and PlantSpec().prediction == "oracle" == PREDICTIONS[0]
    assert PlantSpec(prediction="constant-velocity", latency=1).label() == "model+lat1+cv"


def test_closed_loop_solver_sees_the_prediction_collision_check_the_truth():
    from fcgen.presets import paper_problem
    from fcgen.sim.closedloop import run_closed_loop
    from fcgen.sim.plants import plant_of
    from fcgen.sim.runlog import RunLog
    from fcgen.sim.scenario import make_scenario

    pb = paper_problem("car", "lifted", "ellipse", profile="safe")
    sc = make_scenario("car", 1, n_opp=pb.opponents.count, samples=15, dt=pb.horizon.dt)
    oracle = run_closed_loop(pb, sc)
    # the paper's opponents follow their lane at constant ds/dt: lane-following predicts them (to rounding)
    lane = run_closed_loop(pb, sc, plant=PlantSpec(prediction="lane-following"))
    assert np.allclose(lane.ego_frenet, oracle.ego_frenet, atol=1e-6)
    cv = run_closed_loop(pb, sc, plant=PlantSpec(prediction="constant-velocity"))
    assert not np.allclose(cv.control, oracle.control, atol=1e-6)  # the solver sees another future
    assert np.array_equal(cv.opp_cartesian, oracle.opp_cartesian)  # logged and checked: the true motion
    back = RunLog.from_json_string(cv.to_json_string())
    assert plant_of(back) == PlantSpec(prediction="constant-velocity")


def test_verify_passes_with_predicted_traffic(tmp_path):
    """The C solver (its API unchanged: the predicted poses are set per stage as the true ones) equals the reference
    on the same predictions, with delay compensation, the st plant and noisy observations."""
    from fcgen.codegen.generate import generate
    from fcgen.presets import preset
    from fcgen.sim.plants import DEFAULT_NOISE
    from fcgen.verify import verify

    name = "truck_lifted_ellipse_ipm_safe"
    generate(preset(name).with_(delay=1), tmp_path / name)
    spec = PlantSpec(kind="st", latency=1, noise=DEFAULT_NOISE, prediction="constant-velocity")
    rep = verify(tmp_path / name, seed=2, samples=40, plant=spec)
    assert rep.passed, rep.format()


def test_the_margin_rule_by_hand():
    """MARGIN_RULE without noise: a constant-velocity opponent gives 0 at every stage; constant acceleration a gives
    e = a SPAN dt (the two spans' mean speeds differ by that), m_k = c tau_k e with tau_k = (delay + k) dt, capped at
    10 m."""
    from fcgen.contract import INPUT_RANGES

    cv = PredictedOpponents("constant-velocity", _line(lambda t: 12.0 * t), OFFSETS, DT, delay=1)
    assert np.max(cv.margins(30, 1.0)) < 1e-12  # rounding of the two speeds only
    acc = PredictedOpponents("constant-velocity", _line(lambda t: 10.0 * t + 0.5 * 1.5 * t**2), OFFSETS, DT, delay=1)
    e = 1.5 * SPAN * DT
    np.testing.assert_allclose(acc.margins(30, 2.0), 2.0 * (1 + OFFSETS) * DT * e, rtol=1e-9)
    assert np.max(acc.margins(30, 1000.0)) == INPUT_RANGES.margin_max


def test_the_margin_rule_covers_the_turn_a_straight_line_misses():
    """An opponent on a circle arc (radius R, speed v) at constant speed: e = 0, and the straight-line predictions miss
    its turn: t = v1 omega with v1 = 2 R sin(omega SPAN dt / 2) / (SPAN dt) (the chord's speed) and omega = v / R,
    m_k = c tau_k^2 t / 2 (by hand); the true pose at stage k is m_k from the prediction to 1 % at c = 1 (the error the
    margin is for); lane-following, which follows the arc, takes no turn term."""
    R, v, c = 50.0, 15.0, 1.0
    omega = v / R

    def truth(j: int) -> np.ndarray:
        th = omega * j * DT
        return np.array([[R * math.sin(th), R * (1 - math.cos(th)), th]])

    pred = PredictedOpponents("constant-velocity", truth, OFFSETS, DT)
    tau = OFFSETS * DT
    v1 = 2 * R * math.sin(omega * SPAN * DT / 2) / (SPAN * DT)
    m = pred.margins(30, c)
    np.testing.assert_allclose(m, c * 0.5 * v1 * omega * tau**2, rtol=1e-9, atol=1e-9)
    dist = np.hypot(*(pred.horizon(30)[:, 0, :2] - _true_horizon(truth, 30)[:, 0, :2]).T)
    assert np.all(dist <= 1.01 * m) and np.all(dist[1:] > 0.95 * m[1:])  # the error, to 1 % (the chord's speed)
    lane = PredictedOpponents("lane-following", truth, OFFSETS, DT, road=Road.from_curvature(np.full(200, 1 / R), 1.0))
    assert np.max(lane.margins(30, c)) < 1e-9


def test_a_prediction_margin_needs_a_prediction():
    with pytest.raises(ProblemError, match="prediction_margin"):
        PlantSpec(prediction_margin=1.0)
    with pytest.raises(ProblemError, match="prediction_margin"):
        PlantSpec(prediction="constant-velocity", prediction_margin=-1.0)
    spec = PlantSpec(prediction="constant-velocity", prediction_margin=1.0)
    assert spec.label() == "model+cv+pm1" and spec.as_meta()["prediction_margin"] == 1.0
    assert "prediction_margin" not in PlantSpec(prediction="constant-velocity").as_meta()  # logs as before


def test_the_closed_loop_sets_the_margins_of_the_rule(tmp_path):
    """The loop gives the solver the rule's margins before each solve (the reference's margins after the last sample
    are that sample's), and the C equals the reference with them (fcgen verify: the lockstep sets both)."""
    from fcgen.codegen.generate import generate
    from fcgen.ocp import build_ocp
    from fcgen.presets import preset
    from fcgen.sim.closedloop import ReferenceController, opponent_params, run_closed_loop
    from fcgen.sim.plants import DEFAULT_NOISE
    from fcgen.sim.prediction import PredictedOpponents as PO
    from fcgen.sim.scenario import make_scenario
    from fcgen.verify import verify

    name = "car_lifted_ellipse_ipm_safe"
    pb = preset(name)
    spec = PlantSpec(prediction="constant-velocity", noise=DEFAULT_NOISE, prediction_margin=1.0)
    sc = make_scenario("car", 2, n_opp=pb.opponents.count, samples=12, dt=pb.horizon.dt)
    ctl = ReferenceController(build_ocp(pb))
    run_closed_loop(pb, sc, controller=ctl, plant=spec)
    opp = opponent_params(pb, sc)
    pred = PO("constant-velocity", opp.at_index, pb.horizon.offsets, sc.dt, noise=DEFAULT_NOISE[:3], seed=sc.seed)
    want = pred.margins(sc.samples - 1, 1.0)
    np.testing.assert_array_equal(ctl.solver.margins, want)
    assert want[-1] > want[1] > 0.0
    generate(pb, tmp_path / name)
    rep = verify(tmp_path / name, seed=2, samples=30, plant=spec, closed_loop=False)
    assert rep.passed, rep.format()
