"""The target-lane rule (``fcgen.commonroad.lanes``) on scenarios the tests write with commonroad-io: a lane that
ends, a goal in the left lane, a slower vehicle ahead, a gap that closes; a closed loop where the ego's lane ends."""

from __future__ import annotations

import numpy as np
import pytest
from crscenes import LANE, write_scenario

from fcgen.campaign.commonroad import load_for
from fcgen.commonroad.lanes import T_CLOSE, T_GAP, Traffic, gap_free, lanes_at, road_lanes, target_lane
from fcgen.presets import preset

pytestmark = [
    pytest.mark.filterwarnings("ignore::UserWarning"),
    pytest.mark.filterwarnings("ignore::DeprecationWarning"),
]
PB = preset("car_lifted_ellipse_ipm")
L = PB.ego.l_ch
NONE = Traffic(np.zeros(0), np.zeros(0), np.zeros(0))


def _s(sc, x: float) -> float:
    """The road's s of the point (x, 0) on the straight test road."""
    return float(sc.road.to_frenet(np.array([x]), np.array([0.0]), np.array([0.0]))[0][0])


def _traffic(sc, *cars) -> Traffic:
    """Vehicles (x, lane offset n, speed) on the straight road."""
    a = np.array(cars, dtype=float).reshape(-1, 3)
    return Traffic(np.array([_s(sc, x) for x in a[:, 0]]), a[:, 1], a[:, 2])


def test_the_lanes_along_the_road(tmp_path):
    """Three lanes of 3.5 m, the ego on the middle one: lane centres -3.5, 0, 3.5; where the right lane ends (x = 150)
    two are left."""
    sc = load_for(PB, write_scenario(tmp_path / "l.xml", end_lane=(0, 150.0)))
    lanes = road_lanes(sc.scenario.lanelet_network, sc.road)
    np.testing.assert_allclose(lanes_at(lanes, _s(sc, 100.0)), [-LANE, 0.0, LANE], atol=1e-6)
    np.testing.assert_allclose(lanes_at(lanes, _s(sc, 160.0)), [0.0, LANE], atol=1e-6)


def test_a_lane_that_ends(tmp_path):
    """Two lanes, the ego (20 m/s) on the right one, which ends at x = 150. At x = 50 the end is beyond the look-ahead
    (4 s x 20 m/s = 80 m): the target stays; at x = 100 it is within: the left lane, when its gap is free; a car
    beside the ego in the left lane keeps the target (the NMPC brakes for the lane's end)."""
    sc = load_for(PB, write_scenario(tmp_path / "e.xml", lanes=2, ego_lane=0, end_lane=(0, 150.0)))
    tl = target_lane(sc, L, None, 0.0)
    assert tl.update(_s(sc, 50.0), 0.0, 20.0, NONE) == (pytest.approx(0.0, abs=1e-6), "start")
    n, why = tl.update(_s(sc, 100.0), 0.0, 20.0, NONE)
    assert (n, why) == (pytest.approx(LANE, abs=1e-6), "the lane ends")
    tl = target_lane(sc, L, None, 0.0)
    n, _ = tl.update(_s(sc, 100.0), 0.0, 20.0, _traffic(sc, (101.0, LANE, 20.0)))
    assert n == pytest.approx(0.0, abs=1e-6)


def test_a_goal_in_the_left_lane(tmp_path):
    """The goal's lane is the left one: the reference is the goal's centre (n = 3.5) as soon as the left lane has room
    beside the ego; a car overlapping the ego there keeps it in its lane until it has passed."""
    sc = load_for(PB, write_scenario(tmp_path / "g.xml", goal={"lane": 2, "s": 170.0}, goal_steps=(50, 70)))
    goal_n = sc.goal_sn[1]
    tl = target_lane(sc, L, goal_n, 0.0)
    beside = _traffic(sc, (52.0, LANE, 20.0))
    assert tl.update(_s(sc, 50.0), 0.0, 20.0, beside)[0] == pytest.approx(0.0, abs=1e-6)
    n, why = tl.update(_s(sc, 50.0), 0.0, 20.0, _traffic(sc, (50.0 + L + 1.0, LANE, 20.0)))
    assert (n, why) == (pytest.approx(goal_n, abs=1e-9), "the goal's lane")


def test_the_goals_lane_counts_the_gap_a_vehicle_opens(tmp_path):
    """The goal's lane to the left, the ego at 20 m/s (chassis L = 4 m): a car there 2.5 m behind the ego's centre
    asks L = 4 m without the credit; at 17 m/s it drops back 3 m/s x T_OPEN_GOAL (1 s), so 4 - 3 = 1 m is enough: the
    change starts; at 20 m/s (no opening) or 22 m/s (closing: 4 + 1 s x 2 m/s = 6 m) it is not. Ahead by 2.5 m, one at
    23 m/s pulls away (4 - 3 = 1 m): the change starts; one at 20 m/s does not."""
    from fcgen.commonroad.lanes import T_CLOSE_GOAL, T_OPEN_GOAL

    assert (T_OPEN_GOAL, T_CLOSE_GOAL) == (1.0, 1.0) and pytest.approx(4.0) == L
    sc = load_for(PB, write_scenario(tmp_path / "o.xml", goal={"lane": 2, "s": 170.0}, goal_steps=(50, 70)))
    goal_n = sc.goal_sn[1]
    for dx, v_car, changes in ((-2.5, 17.0, True), (-2.5, 20.0, False), (-2.5, 22.0, False), (2.5, 23.0, True)):
        n, _ = target_lane(sc, L, goal_n, 0.0).update(_s(sc, 50.0), 0.0, 20.0, _traffic(sc, (50.0 + dx, LANE, v_car)))
        assert n == pytest.approx(goal_n if changes else 0.0, abs=1e-6), (dx, v_car)
    n, _ = target_lane(sc, L, goal_n, 0.0).update(_s(sc, 50.0), 0.0, 20.0, _traffic(sc, (52.5, LANE, 20.0)))
    assert n == pytest.approx(0.0, abs=1e-6)
    assert not gap_free(_traffic(sc, (47.5, LANE, 17.0)), LANE, _s(sc, 50.0), 20.0, L, 0.0, T_CLOSE_GOAL)


def test_an_ego_off_its_lanes_centre_is_not_changing_lanes(tmp_path):
    """The ego starts 0.7 m left of its lane's centre (more than SETTLED = 0.5 m) at 20 m/s, with the safe profile's gap
    and a car 15 m ahead at 15 m/s in its lane (short of L + 1 s x 20 + 3 s x 5 = 39 m): the ego's own lane is not a
    gap that closed; the goal's lane to the left is empty: the target is the goal's lane."""
    from fcgen.commonroad.lanes import SETTLED

    assert SETTLED == 0.5
    sc = load_for(PB, write_scenario(tmp_path / "u.xml", goal={"lane": 2, "s": 170.0}, goal_steps=(50, 70)))
    goal_n = sc.goal_sn[1]
    ahead = _traffic(sc, (65.0, 0.0, 15.0))
    assert not gap_free(ahead, 0.0, _s(sc, 50.0), 20.0, L, t_close_ahead=T_CLOSE)
    n, why = target_lane(sc, L, goal_n, 0.7, close_ahead=True).update(_s(sc, 50.0), 0.7, 20.0, ahead)
    assert (n, why) == (pytest.approx(goal_n, abs=1e-9), "the goal's lane")


def test_a_slower_vehicle_ahead(tmp_path):
    """Three lanes, the ego settled in the middle at 20 m/s (v_ref 20): a car 30 m ahead at 10 m/s (more than 2 m/s
    slower) sends it to the left lane when that lane's gap is free; with a slower car nearer ahead on the left, to the
    right; a car ahead only 1 m/s slower keeps it."""
    sc = load_for(PB, write_scenario(tmp_path / "s.xml"))
    slow = (80.0, 0.0, 10.0)
    n, why = target_lane(sc, L, None, 0.0).update(_s(sc, 50.0), 0.0, 20.0, _traffic(sc, slow))
    assert (n, why) == (pytest.approx(LANE, abs=1e-6), "a slower vehicle ahead")
    left_slow = _traffic(sc, slow, (70.0, LANE, 8.0))
    n, _ = target_lane(sc, L, None, 0.0).update(_s(sc, 50.0), 0.0, 20.0, left_slow)
    assert n == pytest.approx(-LANE, abs=1e-6)
    n, _ = target_lane(sc, L, None, 0.0).update(_s(sc, 50.0), 0.0, 20.0, _traffic(sc, (80.0, 0.0, 19.0)))
    assert n == pytest.approx(0.0, abs=1e-6)


def test_a_gap_that_closes(tmp_path):
    """The ego has begun a change to the left lane (n = 1.0, not settled) when a car 20 m behind closes in at 30 m/s:
    the gap it needs is L + 1 s x 30 + 3 s x 10 = 64 m: the target goes back to the ego's lane."""
    sc = load_for(PB, write_scenario(tmp_path / "c.xml"))
    s = _s(sc, 50.0)
    tl = target_lane(sc, L, None, 0.0)
    assert tl.update(s, 0.0, 20.0, _traffic(sc, (80.0, 0.0, 10.0)))[0] == pytest.approx(LANE, abs=1e-6)
    closing = _traffic(sc, (80.0, 0.0, 10.0), (30.0, LANE, 30.0))
    assert not gap_free(closing, LANE, s, 20.0, L)
    assert (T_GAP, T_CLOSE) == (1.0, 3.0)  # the gap of the docstring's figure
    assert tl.update(s, 1.0, 20.0, closing) == (pytest.approx(0.0, abs=1e-6), "the gap closed")
    far = _traffic(sc, (80.0, 0.0, 10.0), (50.0 - L - 30.0 - 30.0 - 1.0, LANE, 30.0))
    assert gap_free(far, LANE, s, 20.0, L)


def test_the_ego_leaves_a_lane_that_ends(tmp_path):
    """Closed loop (Python reference): two lanes, the ego's ends at x = 200: it changes to the left lane, stays on the
    road (the drivability checker) and collides with nothing."""
    from fcgen.sim.commonroad_run import run_commonroad

    sc = load_for(
        PB, write_scenario(tmp_path / "r.xml", lanes=2, ego_lane=0, end_lane=(0, 200.0), goal_steps=(90, 100))
    )
    run = run_commonroad(PB, sc)
    cr = run.log.meta["extra"]["commonroad"]
    assert [why for _, _, why in cr["lane_changes"]] == ["start", "the lane ends"]
    assert not run.checker["road_departure"] and not run.checker["collision"]
    assert abs(np.asarray(run.log.ego_frenet)[-1, 1] - LANE) < 0.3


def test_the_relevance_rule_in_a_closed_loop_sees_a_slower_vehicle_ahead(tmp_path):
    """Ego at x = 50 (centre), 20 m/s along x. A car 20 m ahead at 10 m/s closes to 0 within 2 s; cars beside (3.5 m
    left and right, level with the ego) and one 6 m behind, all at 20 m/s, stay nearer now. By the distance now the
    car ahead is not among three slots; by the closest approach over the 4 s horizon it is the first (0 m), before the
    cars beside (3.5 m, ties by id) and the one behind (6 m)."""
    from fcgen.commonroad import select_opponents

    cars = [
        (11, 1, 70.0, 10.0, 60, 4.5, 1.8),
        (12, 2, 50.0, 20.0, 60, 4.5, 1.8),
        (13, 0, 50.0, 20.0, 60, 4.5, 1.8),
        (14, 1, 44.0, 20.0, 60, 4.5, 1.8),
    ]
    sc = load_for(PB, write_scenario(tmp_path / "v.xml", obstacles=cars))
    ids = [o.id for o in sc.obstacles]
    now = select_opponents(sc.obstacles, 0, (50.0, 0.0), 3)
    assert [ids[i] for i in now] == [12, 13, 14]
    ahead = select_opponents(sc.obstacles, 0, (50.0, 0.0), 3, (20.0, 0.0), None, PB.horizon.N)  # 20 m/s, heading 0
    assert [ids[i] for i in ahead] == [11, 12, 13]


def test_a_standing_ego_sees_the_standing_vehicle_ahead_before_those_passing_beside(tmp_path):
    """Ego standing at x = 50 (centre), heading 0; vehicle 21 standing 10 m ahead in its lane; 22-24 passing in the
    left lane (3.5 m) at 15 m/s from x = 35, 20, 5; 25 closing from behind in the ego's lane at 10 m/s from x = 30.
    The ego at its own speed 0 (the rule without the reference speed): 25 reaches it at 2 s (0 m), 22-24 come level
    at 1, 2, 3 s (3.5 m), 21 stays at 10 m and gets no slot. The ego at the reference speed of 10 m/s: it reaches 21
    at 1 s (0 m); 25 stays 20 m behind; 15 - 10 = 5 m/s relative: 22 comes level at 3 s (3.5 m), 23 ends 10 m behind
    at 4 s (hypot(10, 3.5) = 10.595 m), 24 25 m behind (25.244 m). The nearer of the two: 21 and 25 at 0, then 22."""
    from fcgen.commonroad import select_opponents
    from fcgen.commonroad.traffic import _approach

    cars = [
        (21, 1, 60.0, 0.0, 60, 4.5, 1.8),
        (22, 2, 35.0, 15.0, 60, 4.5, 1.8),
        (23, 2, 20.0, 15.0, 60, 4.5, 1.8),
        (24, 2, 5.0, 15.0, 60, 4.5, 1.8),
        (25, 1, 30.0, 10.0, 60, 4.5, 1.8),
    ]
    sc = load_for(PB, write_scenario(tmp_path / "s.xml", obstacles=cars))  # (its ego start is not used here)
    ids, N, ego = [o.id for o in sc.obstacles], PB.horizon.N, (0.0, 0.0)  # the standing ego: (speed, heading)

    def approach(v: float) -> list[float]:
        d = {o.id: _approach(o, 0, (50.0, 0.0), (v, 0.0), None, N) for o in sc.obstacles}
        return [d[i] for i in (21, 22, 23, 24, 25)]

    np.testing.assert_allclose(approach(0.0), [10.0, 3.5, 3.5, 3.5, 0.0], atol=1e-6)
    np.testing.assert_allclose(approach(10.0), [0.0, 3.5, 10.595, 25.244, 20.0], atol=2e-3)
    own = select_opponents(sc.obstacles, 0, (50.0, 0.0), 3, ego, None, N, v_ref=0.0)
    assert [ids[i] for i in own] == [25, 22, 23]
    ref = select_opponents(sc.obstacles, 0, (50.0, 0.0), 3, ego, None, N, v_ref=10.0)
    assert [ids[i] for i in ref] == [21, 25, 22]
    slow = select_opponents(sc.obstacles, 0, (50.0, 0.0), 3, (10.0, 0.0), None, N, v_ref=5.0)  # its own 10 m/s
    assert [ids[i] for i in slow] == [21, 22, 23]


def test_a_lane_change_profile_by_hand():
    """n_ref per node of a change from 0 to 3.5 m over 3 s: 0 before it, 3.5 after it, h(u) = 3 u^2 - 2 u^3 between
    (at u = 1/2: 1.75 m; 1 s in: 3.5 (3/9 - 2/27) = 0.9074 m); planned 1 s ago the profile is shifted by 1 s."""
    from fcgen.commonroad.lanes import lane_change_profile

    t = np.array([0.0, 1.0, 1.5, 3.0, 4.0])
    np.testing.assert_allclose(lane_change_profile(0.0, 3.5, 0.0, t), [0.0, 3.5 * 7 / 27, 1.75, 3.5, 3.5], atol=1e-12)
    np.testing.assert_allclose(lane_change_profile(0.0, 3.5, 1.0, t[:2]), [3.5 * 7 / 27, 3.5 * 20 / 27], atol=1e-12)
    back = lane_change_profile(3.5, 0.0, 0.0, t)  # back to the lane it came from: the mirror image
    np.testing.assert_allclose(back, 3.5 - lane_change_profile(0.0, 3.5, 0.0, t), atol=1e-12)


def test_a_planned_lane_change_gets_n_ref_per_stage(tmp_path):
    """The lane that ends, closed loop: with the per-stage n_ref (the default CHANGE_TIME) the solver's reference moves
    along the horizon from the ego's lane to the target's; the ego reaches the target lane on the road without a
    collision, as with the target's centre at once (change_time = 0), and no later than 1 s after it."""
    from fcgen.commonroad.lanes import CHANGE_TIME
    from fcgen.ocp import build_ocp
    from fcgen.sim.closedloop import ReferenceController
    from fcgen.sim.commonroad_run import run_commonroad

    sc = load_for(
        PB, write_scenario(tmp_path / "r.xml", lanes=2, ego_lane=0, end_lane=(0, 200.0), goal_steps=(90, 100))
    )
    seen: list[np.ndarray] = []

    class Spy(ReferenceController):
        def set_reference_stages(self, v_ref, n_ref) -> int:
            seen.append(np.array(n_ref))
            return super().set_reference_stages(v_ref, n_ref)

    runs = {}
    for change in (CHANGE_TIME, 0.0):
        runs[change] = run_commonroad(PB, sc, controller=Spy(build_ocp(PB)), change_time=change)
        n = np.asarray(runs[change].log.ego_frenet)[:, 1]
        assert not runs[change].checker["road_departure"] and not runs[change].checker["collision"]
        assert abs(n[-1] - LANE) < 0.3
    assert len(seen) == round(
        CHANGE_TIME / PB.horizon.dt
    )  # one per sample of the change (the sample it is planned on first)
    first = seen[0]
    assert first[0] == pytest.approx(0.0, abs=0.3) and first[-1] == pytest.approx(LANE, abs=0.3)
    assert np.all(np.diff(first) >= -1e-12)  # moving towards the target along the horizon
    t_in = {c: int(np.argmax(np.abs(np.asarray(r.log.ego_frenet)[:, 1] - LANE) < 0.3)) for c, r in runs.items()}
    assert t_in[CHANGE_TIME] <= t_in[0.0] + round(1.0 / PB.horizon.dt)


def test_a_faster_vehicle_closing_in_from_behind_sets_the_reference_speed():
    """The ego's centre at s = 20 in the lane at n = 0, chassis 4 m: the vehicle behind at s = 10 (20 m/s) is within
    4 + T_BEHIND (1.5 s) x 20 = 34 m and faster than a 15 m/s reference: its 20 m/s; not faster than 22 m/s: None; at
    s = -40 (60 m behind): None; one a lane over (n = 3.5) never counts."""
    from fcgen.commonroad.lanes import T_BEHIND, keep_ahead

    assert T_BEHIND == 1.5
    tr = Traffic(np.array([10.0, 30.0, 15.0]), np.array([0.0, 0.0, 3.5]), np.array([20.0, 15.0, 30.0]))
    assert keep_ahead(tr, 0.0, 20.0, 15.0, 4.0) == 20.0
    assert keep_ahead(tr, 0.0, 20.0, 22.0, 4.0) is None
    far = Traffic(np.array([-40.0, 15.0]), np.array([0.0, 3.5]), np.array([20.0, 30.0]))
    assert keep_ahead(far, 0.0, 20.0, 15.0, 4.0) is None
    assert keep_ahead(NONE, 0.0, 20.0, 15.0, 4.0) is None


def test_recorded_traffic_behind_is_not_made_to_run_into_the_ego(tmp_path):
    """The ego at 15 m/s in lane 1, a goal 100 m ahead within steps 95-105 (its window asks 100 / 10.25 ... 100 / 9.75
    = 9.8-10.3 m/s), and a recorded car 10 m behind at a constant 15 m/s (it does not brake). With the car within
    4 + 1.5 s x 15 m/s of the ego, the reference speed is the car's 15 m/s, not the goal's 10.3, at every sample
    while it stays there; no collision."""
    from fcgen.sim.commonroad_run import run_commonroad

    follower = (9, 1, 40.0, 15.0, 120, 4.5, 1.8)
    path = write_scenario(
        tmp_path / "f.xml", ego_v=15.0, goal={"lane": 1, "s": 150.0}, goal_steps=(95, 105), obstacles=[follower]
    )
    sc = load_for(PB, path)
    assert sc.v_ref_source == "goal time window" and sc.v_ref == pytest.approx(100.0 / 9.75, rel=0.01)
    run = run_commonroad(PB, sc, criticality=False)
    np.testing.assert_allclose(run.log.meta["extra"]["commonroad"]["v_ref_samples"][:30], 15.0, rtol=1e-9)
    assert not run.fcgen["collision"] and not run.checker["collision"]
    assert float(np.min(run.log.ego_frenet[:, 3])) > 14.0


def test_a_lane_beyond_a_median_is_not_beside_the_ego():
    """Lanes at n = 0 (the ego's) and n = 19 m (a road beyond a median, as 19 m left of USA_Peach-3_1's start): a car
    30 m ahead at 5 m/s in the ego's lane does not send the ego 19 m to the left (more than ``ADJACENT`` = 5 m); with
    the other lane at 3.5 m it does."""
    from fcgen.commonroad.lanes import ADJACENT, Lane, TargetLane

    s = np.linspace(0.0, 500.0, 51)
    slow = Traffic(np.array([130.0]), np.array([0.0]), np.array([5.0]))
    assert ADJACENT == 5.0
    for other, expected in ((19.0, 0.0), (LANE, LANE)):
        lanes = [Lane(1, s, np.zeros_like(s)), Lane(2, s, np.full_like(s, other))]
        n, _ = TargetLane(lanes, None, L, 20.0, 0.0).update(100.0, 0.0, 20.0, slow)
        assert n == pytest.approx(expected, abs=1e-9)


def test_a_lane_that_pauses_at_a_junction_keeps_the_target():
    """Three lanes (n = 0, 3.5, 7; the ego's the right one) end 0.1 m apart before a junction (s = 100.0, 100.1,
    100.2) and go on past it (from s = 108): as the ego's centre passes the ends, the target stays at 0 (the old rule
    took the nearest lane still present: 3.5, then 7); a lane that ends for good is still left for the next one."""
    from fcgen.commonroad.lanes import Lane, TargetLane

    before, after = np.linspace(0.0, 100.0, 11), np.linspace(108.0, 300.0, 11)
    lanes = []
    for i, n in enumerate((0.0, LANE, 2 * LANE)):
        s_end = before.copy()
        s_end[-1] += 0.1 * i
        lanes += [Lane(2 * i, s_end, np.full(11, n)), Lane(2 * i + 1, after, np.full(11, n))]
    tl = TargetLane(lanes, None, L, 10.0, 0.0)
    for s in (99.9, 100.05, 100.15, 100.25, 104.0, 110.0):
        n, why = tl.update(s, 0.0, 5.0, NONE)
        assert (n, why) == (0.0, "start"), s
    ends = [Lane(0, before, np.zeros(11)), Lane(1, np.linspace(0.0, 300.0, 31), np.full(31, LANE))]
    n, why = TargetLane(ends, None, L, 10.0, 0.0).update(100.5, 0.0, 5.0, NONE)
    assert (n, why) == (LANE, "start")


def test_the_lane_on_the_way_to_the_goals_lane_needs_the_goals_room():
    """Lanes at n = 0 (the ego's, 20 m/s), 3.5 and 7 (the goal's, two lanes left). A car in the middle lane 12 m behind
    the ego's centre at 15 m/s: the goal's room (L = 4 m behind, no time gap) is free, the strict gap (L + 1 s x
    15 m/s = 19 m) is not. The change towards the goal starts into the middle lane (the old rule asked the strict gap
    there and never started in dense traffic: USA_US101-24_1, 25_1); a car level with the ego there still holds it."""
    from fcgen.commonroad.lanes import GOAL_LANE, Lane, TargetLane

    s = np.linspace(0.0, 500.0, 51)
    lanes = [Lane(i, s, np.full_like(s, n)) for i, n in enumerate((0.0, LANE, 2 * LANE))]
    behind = Traffic(np.array([88.0]), np.array([LANE]), np.array([15.0]))
    assert not gap_free(behind, LANE, 100.0, 20.0, L) and L < 100.0 - 88.0
    n, why = TargetLane(lanes, 2 * LANE, L, 20.0, 0.0, close_ahead=True).update(100.0, 0.0, 20.0, behind)
    assert (n, why) == (LANE, GOAL_LANE)
    tl = TargetLane(lanes, 2 * LANE, L, 20.0, 0.0, close_ahead=True)
    level = Traffic(np.array([101.0]), np.array([LANE]), np.array([20.0]))
    assert tl.update(100.0, 0.0, 20.0, level) == (0.0, "start")
    tl.update(100.0, 0.0, 20.0, behind)  # the change starts; under way, the strict gap would call it off
    held = Traffic(
        np.array([88.0, 101.0]), np.array([LANE, 2 * LANE]), np.array([15.0, 20.0])
    )  # the goal's lane: taken
    assert tl.update(100.0, 1.0, 20.0, held) == (LANE, GOAL_LANE)


def test_the_goals_lane_rule_does_not_go_back_and_forth():
    """Two cases that sent the target back at every sample (USA_US101-23_1). (1) A goal held within the band at
    n = 2.04 m between lanes at 0 and 3.92 m (2.04 and 1.88 m from it, both beyond SAME_LANE): the ego steps to the
    nearer lane, 3.92, and stays. (2) The goal in the left lane at s = 130 m, a lane that ends at s = 150 m, the ego at
    s = 100 m and 20 m/s (look-ahead 80 m): the lane goes on to the goal, so it is not a lane that ends."""
    from fcgen.commonroad.lanes import GOAL_LANE, Lane, TargetLane

    s = np.linspace(0.0, 500.0, 51)
    lanes = [Lane(0, s, np.zeros_like(s)), Lane(1, s, np.full_like(s, 3.92))]
    tl = TargetLane(lanes, 2.04, L, 20.0, 0.0)
    assert [tl.update(100.0 + k, 0.0, 20.0, NONE)[0] for k in range(3)] == [3.92, 3.92, 3.92]
    short = np.linspace(0.0, 150.0, 16)
    lanes = [Lane(0, s, np.zeros_like(s)), Lane(1, short, np.full_like(short, LANE))]
    tl = TargetLane(lanes, LANE, L, 20.0, 0.0, goal_s=130.0)
    got = [tl.update(100.0 + k, 0.0, 20.0, NONE) for k in range(3)]
    assert got == [(LANE, GOAL_LANE)] * 3


def test_a_lane_beyond_the_problems_band_is_never_the_target():
    """Lanes at n = 0 (the ego's), 3.5 and 7 (the goal's), the problem's band n <= 5 m: the change towards the goal
    stops at 3.5 (the solver refuses a reference beyond its band: USA_US101-26_2 targeted a lane at 13.85 m)."""
    from fcgen.commonroad.lanes import GOAL_LANE, Lane, TargetLane

    s = np.linspace(0.0, 500.0, 51)
    lanes = [Lane(i, s, np.full_like(s, n)) for i, n in enumerate((0.0, LANE, 2 * LANE))]
    tl = TargetLane(lanes, 2 * LANE, L, 20.0, 0.0, n_bounds=(-5.0, 5.0))
    got = [tl.update(100.0 + k, 0.0, 20.0, NONE) for k in range(3)]
    assert got == [(LANE, GOAL_LANE)] * 3
    free = TargetLane(lanes, 2 * LANE, L, 20.0, 0.0)
    assert [free.update(100.0 + k, 0.0, 20.0, NONE)[0] for k in range(2)] == [LANE, 2 * LANE]


def _oncoming(oid: int, n_of_step, x0: float = 150.0, v: float = 15.0, heading: float = np.pi):
    """A car (4.5 m x 1.8 m) from x0 against the road (heading pi) at v, its centre n_of_step(k) left of the road's
    centre line at step k, recorded for 60 steps."""
    from fcgen.commonroad.traffic import CrObstacle

    k = np.arange(60)
    d = np.cos(heading)
    centres = np.c_[x0 + d * v * 0.1 * k, [n_of_step(i) for i in k], np.full(60, heading)]
    return CrObstacle(oid, False, 4.5, 1.8, 0, 59, centres, v, 0.1)


def test_oncoming_traffic_beside_the_band_gets_no_slot_with_the_corners_band(tmp_path):
    """One lane of 3.5 m (band -1.75..1.75). A car against the road in the lane beside (n = 3.5: its rectangle 2.6..4.4)
    stays beside the band over the 4 s horizon: separated, so with the corners' band it gets no slot. Not separated:
    the same car at n = 2.5 (its rectangle from 1.6, inside the band), one that turns into the ego's lane at step 20
    (n = 0 from there), one driving with the road beside it."""
    from fcgen.commonroad.traffic import select_opponents, separated_oncoming

    sc = load_for(PB, write_scenario(tmp_path / "o.xml", lanes=1, ego_lane=0))
    road, N = sc.road, PB.horizon.N
    np.testing.assert_allclose([road.n_min[0], road.n_max[0]], [-LANE / 2, LANE / 2], atol=1e-6)
    beside = _oncoming(1, lambda k: LANE)
    inside = _oncoming(2, lambda k: 2.5)
    turning = _oncoming(3, lambda k: LANE if k < 20 else 0.0)
    along = _oncoming(4, lambda k: LANE, x0=40.0, heading=0.0)
    assert separated_oncoming(beside, road, 0, None, N)
    assert not separated_oncoming(inside, road, 0, None, N)
    assert not separated_oncoming(turning, road, 0, None, N)  # within the horizon at step 0 ...
    assert separated_oncoming(turning, road, 25, None, N) is False  # ... and in the lane after it
    assert separated_oncoming(turning, road, 0, None, 10)  # beyond a 1 s horizon it turns: beside over that one
    assert not separated_oncoming(along, road, 0, None, N)
    obs = (beside, inside, along)  # from (50, 0): 100.06, 100.03 and 10.6 m away
    assert select_opponents(obs, 0, (50.0, 0.0), 3) == (2, 1, 0)
    assert select_opponents(obs, 0, (50.0, 0.0), 3, band_road=road) == (2, 1, None)
