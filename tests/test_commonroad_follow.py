"""The safe profile's speed reference behind a vehicle ahead (``fcgen.commonroad.follow``) and its lane rule's gap
ahead (``lanes.gap_free(t_close_ahead=...)``): by hand, on scenarios the tests write with commonroad-io, and in a
closed loop behind a slower car."""

from __future__ import annotations

import numpy as np
import pytest
from crscenes import LANE, write_scenario

from fcgen.campaign.commonroad import load_for
from fcgen.commonroad.follow import Following, LeadRows, follow_speed, profile_following, vehicle_ahead
from fcgen.commonroad.lanes import T_CLOSE, T_GAP, Traffic, gap_free, target_lane
from fcgen.presets import preset

pytestmark = [
    pytest.mark.filterwarnings("ignore::UserWarning"),
    pytest.mark.filterwarnings("ignore::DeprecationWarning"),
]
SAFE = preset("car_lifted_ellipse_ipm_safe")
PAPER = preset("car_lifted_ellipse_ipm")
L = SAFE.ego.l_ch


def _s(sc, x: float) -> float:
    """The road's s of the point (x, 0) on the straight test road."""
    return float(sc.road.to_frenet(np.array([x]), np.array([0.0]), np.array([0.0]))[0][0])


def _traffic(sc, *cars) -> Traffic:
    """Vehicles (x, lane offset n, speed, length) on the straight road."""
    a = np.array(cars, dtype=float).reshape(-1, 4)
    return Traffic(np.array([_s(sc, x) for x in a[:, 0]]), a[:, 1], a[:, 2], a[:, 3])


def test_the_follow_speed_by_hand():
    """t_gap 1 s, s0 2 m, t_close 2 s; a car ahead at 10 m/s: beyond 2 + 1 x 10 = 12 m the ego may close in, at 30 m
    at 10 + 18 / 2 = 19 m/s; at 12 m and within it, the car's 10 m/s (no closing in, no opening); behind a standing car
    0."""
    f = Following()
    assert (f.t_gap, f.s0, f.t_close) == (1.0, 2.0, 2.0)
    assert f.speed(30.0, 10.0) == pytest.approx(19.0, abs=1e-12)
    assert f.speed(12.0, 10.0) == pytest.approx(10.0, abs=1e-12)
    assert f.speed(5.0, 10.0) == pytest.approx(10.0, abs=1e-12)
    assert f.speed(1.0, 0.0) == 0.0


def test_the_follow_speed_never_asks_for_a_time_to_collision_below_t_close():
    """At the reference speed the time to collision gap / (v_ref - v_lead) is gap t_close / (gap - s0 - t_gap v_lead)
    >= t_close, on a grid of gaps and leader speeds (infinite where the reference does not close in)."""
    f = Following()
    for v_lead in np.linspace(0.0, 35.0, 36):
        for gap in np.linspace(0.0, 200.0, 401):
            dv = f.speed(gap, v_lead) - v_lead
            if dv > 0.0:
                assert gap / dv == pytest.approx(gap * f.t_close / (gap - f.s0 - f.t_gap * v_lead), rel=1e-9)
                assert gap / dv >= f.t_close - 1e-9


def test_bad_parameters_are_refused():
    bad = ({"t_gap": 0.0}, {"s0": -1.0}, {"t_close": float("nan")}, {"t_row": -1.0}, {"row_step": 0.0})
    for kw in (*bad, {"b_release": float("inf")}):
        with pytest.raises(ValueError, match=f"Following.{next(iter(kw))}"):
            Following(**kw)


def test_the_profiles():
    """The safe profile follows (its curve speed on), the paper's does not (its reference as given)."""
    assert profile_following(SAFE) == Following()
    assert profile_following(PAPER) is None


def test_the_vehicle_ahead_in_the_corridor(tmp_path):
    """The ego's centre at x = 50 in the middle lane (n = 0): a 4 m car at x = 80 in its lane is 30 - (4 + L) / 2
    ahead bumper to bumper; a 5 m car at x = 60 in the left lane counts only for a corridor that holds the left lane
    (the run's corridor is the ego's centre's half lane); a car behind (x = 40) never; with nothing ahead, no cap."""
    sc = load_for(SAFE, write_scenario(tmp_path / "a.xml"))
    tr = _traffic(sc, (80.0, 0.0, 10.0, 4.0), (60.0, LANE, 15.0, 5.0), (40.0, 0.0, 30.0, 4.0))
    s = _s(sc, 50.0)
    gap, v, i = vehicle_ahead(tr, s, (0.0,), L)
    assert (gap, v, i) == (pytest.approx(30.0 - (4.0 + L) / 2, abs=1e-6), 10.0, 0)
    gap, v, i = vehicle_ahead(tr, s, (0.0, LANE), L)
    assert (gap, v, i) == (pytest.approx(10.0 - (5.0 + L) / 2, abs=1e-6), 15.0, 1)
    assert follow_speed(Following(), tr, s, (0.0,), L) == pytest.approx(Following().speed(30.0 - (4.0 + L) / 2, 10.0))
    assert vehicle_ahead(tr, _s(sc, 90.0), (0.0,), L) is None


def test_the_leader_s_lengthening_by_hand():
    """t_row 1.5 s, rounded up to 0.5 m: closing at 5 m/s 7.5 m; at 3.1 m/s 4.65 -> 5 m; not closing in, none, or
    what is held; at most the gap less 1 m rounded down (9.9 m: 8.5 m)."""
    f = Following()
    assert (f.t_row, f.row_step, f.b_release, f.row_gap) == (1.5, 0.5, 2.0, 1.0)
    assert f.extension(20.0, 15.0, 30.0) == pytest.approx(7.5, abs=1e-12)
    assert f.extension(20.0, 16.9, 30.0) == pytest.approx(5.0, abs=1e-12)
    assert f.extension(10.0, 10.0, 30.0) == 0.0
    assert f.extension(10.0, 12.0, 30.0) == 0.0
    assert f.extension(10.0, 12.0, 30.0, held=6.1) == pytest.approx(6.5, abs=1e-12)
    assert f.extension(20.0, 10.0, 9.9) == pytest.approx(8.5, abs=1e-12)
    assert f.extension(20.0, 10.0, 0.5) == 0.0


def test_the_leader_s_rectangle_lengthened_backwards(tmp_path):
    """The ego's centre at x = 50 in the middle lane at 20 m/s; in the slots a 5 m car in the left lane at x = 60, a
    4 m car ahead in the ego's lane at x = 80 (both 10 m/s, 26 m ahead bumper to bumper): the second slot's rectangle
    1.5 x 10 = 15 m longer, its centre 7.5 m back (the front where it is); the left lane's car as it is. Then at 12 m/s
    the lengthening shrinks by 1.5 x 2 x 0.1 = 0.3 m a sample (15 -> 14.7 -> 14.4 ..., rounded up to 0.5 m) down to
    1.5 x 2 = 3 m; at the car's speed it is gone at once; without the car ahead in the slots, nothing is held."""
    cars = [(11, 1, 80.0, 10.0, 20, 4.0, 1.8), (12, 2, 60.0, 10.0, 20, 5.0, 1.8)]
    sc = load_for(SAFE, write_scenario(tmp_path / "l.xml", obstacles=cars))
    shapes = np.array([(5.0, 1.8, 0.0), (4.0, 1.8, 0.0), (1.0, 1.0, 0.0)])
    x = np.array([_s(sc, 50.0) - SAFE.ego.l / 2, 0.0, 0.0, 20.0, 0.0])  # the rear axle's state: the centre at 50
    rows = LeadRows(Following(), sc.dt)
    out = rows.shapes(sc, 0, (12, 11, None), shapes, SAFE.ego, x)
    assert out[1] == pytest.approx([4.0 + 15.0, 1.8, -7.5], abs=1e-9)
    assert out[0] == pytest.approx(shapes[0]) and out[2] == pytest.approx(shapes[2])
    assert shapes[1] == pytest.approx([4.0, 1.8, 0.0])  # the caller's array untouched
    x[3] = 12.0
    lengths = [rows.shapes(sc, 0, (12, 11, None), shapes, SAFE.ego, x)[1, 0] - 4.0 for _ in range(50)]
    assert lengths[:4] == pytest.approx([15.0, 14.5, 14.5, 14.0], abs=1e-9)
    assert np.all(np.diff(lengths) <= 0.0) and lengths[-1] == pytest.approx(3.0, abs=1e-9)
    x[3] = 10.0
    assert rows.shapes(sc, 0, (12, 11, None), shapes, SAFE.ego, x) is shapes and rows.samples == 51
    rows = LeadRows(Following(), sc.dt)
    x[3] = 20.0
    rows.shapes(sc, 0, (12, 11, None), shapes, SAFE.ego, x)
    assert rows.shapes(sc, 0, (12, None, None), shapes, SAFE.ego, x) is shapes
    x[3] = 12.0
    out = rows.shapes(sc, 0, (12, 11, None), shapes, SAFE.ego, x)  # the lead changed: nothing held
    assert out[1, 0] == pytest.approx(4.0 + 3.0, abs=1e-9)


def test_the_safe_lane_rule_asks_for_room_ahead_of_a_slower_car(tmp_path):
    """Ego 20 m/s; a car in the left lane 35 m ahead at 10 m/s. The gap rule asks L + 1 s x 20 = 24.5 m ahead (free);
    the safe profile's also T_CLOSE x 10 = 30 m more, 54.5 m (not free); at 60 m ahead both are free."""
    sc = load_for(SAFE, write_scenario(tmp_path / "g.xml"))
    s = _s(sc, 50.0)
    near = _traffic(sc, (85.0, LANE, 10.0, 4.0))
    assert (T_GAP, T_CLOSE) == (1.0, 3.0)
    assert gap_free(near, LANE, s, 20.0, L)
    assert not gap_free(near, LANE, s, 20.0, L, t_close_ahead=T_CLOSE)
    far = _traffic(sc, (50.0 + L + 20.0 + 30.0 + 1.0, LANE, 10.0, 4.0))
    assert gap_free(far, LANE, s, 20.0, L, t_close_ahead=T_CLOSE)
    # a slower car ahead in the ego's lane (5 m/s, 20 m ahead): the paper's rule changes to the left lane, behind the
    # 10 m/s car (farther and faster); the safe profile's does not, and goes right, where the gap is free
    tr = _traffic(sc, (70.0, 0.0, 5.0, 4.0), (85.0, LANE, 10.0, 4.0), (200.0, -LANE, 25.0, 4.0))
    assert target_lane(sc, L, None, 0.0).update(s, 0.0, 20.0, tr)[0] == pytest.approx(LANE, abs=1e-6)
    safe = target_lane(sc, L, None, 0.0, close_ahead=True).update(s, 0.0, 20.0, tr)
    assert safe == (pytest.approx(-LANE, abs=1e-6), "a slower vehicle ahead")


def test_the_safe_profile_follows_a_slower_car_in_a_closed_loop(tmp_path):
    """One lane, the ego at 20 m/s (its reference) 36 m (centres) behind a 4.5 m car at 10 m/s, for 10 s (Python
    reference). Safe profile: the reference falls to the follow speed at once (10 + (31.5 - 12) / 2 = 19.75 m/s) and
    the gap settles at 2 + 1 x 10 = 12 m (within 2 m after 10 s: the reference's gap error decays as exp(-t / 2 s),
    the NMPC's tracking lags it by about a metre; measured 10.5 m), the
    time to collision (bumper gap over closing speed) never below 1.5 s (2 s at the reference, less the tracking's
    lag), no collision; the paper profile has no follow rule and closes in at its 20 m/s reference (TTC below
    1 s)."""
    from fcgen.sim.commonroad_run import run_commonroad

    car = [(11, 0, 86.0, 10.0, 110, 4.5, 1.8)]
    sc = load_for(SAFE, write_scenario(tmp_path / "f.xml", lanes=1, ego_lane=0, obstacles=car, goal_steps=(99, 100)))
    runs = {name: run_commonroad(pb, sc, criticality=False) for name, pb in (("safe", SAFE), ("paper", PAPER))}
    out = {}
    for name, run in runs.items():
        xs = np.asarray(run.log.ego_frenet)
        t = np.arange(len(xs)) * sc.dt
        centre = xs[:, 0] + SAFE.ego.l / 2
        lead = _s(sc, 86.0) + 10.0 * t
        gap = lead - centre - (4.5 + L) / 2
        closing = xs[:, 3] - 10.0
        ttc = np.where((closing > 0.0) & (gap > 0.0), gap / np.maximum(closing, 1e-9), np.inf)
        out[name] = (gap, ttc, run.log.meta["extra"]["commonroad"]["follow"], run.checker["collision"])
    gap, ttc, follow, hit = out["safe"]
    assert not hit
    assert follow["samples"] > 0 and follow["t_close"] == 2.0
    assert follow["lead"] > 0  # closing in from 20 m/s: the car's rectangle lengthened
    assert gap[-1] == pytest.approx(12.0, abs=2.0)
    assert ttc.min() >= 1.5
    gap, ttc, follow, _ = out["paper"]
    assert follow is None
    assert ttc.min() < 1.0
