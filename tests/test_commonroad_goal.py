"""The planning problem's goal: whether and when the ego reached it (CommonRoad's ``GoalRegion.is_reached``), the
reference speed and lane it drives for it, the run ending there, and the drivability checker's verdict on the
solution file, on scenarios the tests write with commonroad-io (docs/commonroad.md)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from crscenes import LANE, write_scenario

from fcgen.campaign.commonroad import load_for
from fcgen.commonroad import solution_verdict
from fcgen.commonroad.goal import WINDOW_MARGIN, first_reached, goal_speed, reached
from fcgen.presets import preset

pytestmark = [
    pytest.mark.filterwarnings("ignore::UserWarning"),
    pytest.mark.filterwarnings("ignore::DeprecationWarning"),
]
PB = preset("car_lifted_ellipse_ipm")
CAR = PB.ego


def _window(d: float, steps: tuple[int, int], dt: float = 0.1) -> tuple[float, float]:
    """The speeds that arrive at distance ``d`` within the middle of the time window (hand-derived bounds)."""
    a, b = steps[0] * dt, steps[1] * dt
    a, b = a + WINDOW_MARGIN * (b - a), b - WINDOW_MARGIN * (b - a)
    return d / b, d / a


def test_the_reference_speed_drives_for_the_goal(tmp_path):
    """Ego at 20 m/s, goal centre 200 m ahead (centre to centre, along the straight path). A window of steps 80-120
    (8-12 s: 18.2-22.2 m/s in its middle half) keeps the traffic's 20 m/s; 40-60 (4-6 s) asks 36.4 m/s; the goal's
    speed interval (near the goal), the lane's speed limit and v_max cap it, in that order."""
    goal = {"lane": 2, "s": 250.0}
    sc = load_for(PB, write_scenario(tmp_path / "a.xml", goal=goal, goal_steps=(80, 120), length=600.0))
    assert (sc.v_ref, sc.v_ref_source) == (20.0, "initial speed")
    s_centre = sc.x0[0] + CAR.l / 2  # the ego's centre on the road
    assert (sc.goal_sn[0] - s_centre, sc.goal_sn[1]) == pytest.approx((200.0, LANE), abs=0.05)
    lo, hi = _window(200.0, (40, 60))
    assert hi > lo
    sc = load_for(PB, write_scenario(tmp_path / "b.xml", goal=goal, goal_steps=(40, 60), length=600.0))
    assert lo > 20.0 and (sc.v_ref, sc.v_ref_source) == (pytest.approx(lo, rel=1e-3), "goal time window")
    sc = load_for(
        PB,
        write_scenario(tmp_path / "c.xml", goal={**goal, "velocity": (0.0, 30.0)}, goal_steps=(40, 60), length=600.0),
    )
    # the speed interval is the speed at the goal: it applies once the goal is within the horizon's reach, aimed
    # SPEED_MARGIN (0.5 m/s) inside its upper end 30 m/s
    assert (sc.v_ref, sc.v_ref_source) == (pytest.approx(lo, rel=1e-3), "goal time window")
    assert (sc.v_goal, sc.v_goal_source) == (29.5, "goal velocity")
    sc = load_for(
        PB,
        write_scenario(tmp_path / "d.xml", goal=goal, goal_steps=(40, 60), length=600.0, speed_limit=25.0),
    )
    assert (sc.v_ref, sc.v_ref_source) == (25.0, "speed limit")
    # a goal with no position: the traffic's speed into the goal's speed interval
    pp = sc.planning_problem
    assert goal_speed(pp, 20.0, 0.1, None, None, 40.0) == (20.0, "initial speed")
    assert goal_speed(pp, 50.0, 0.1, None, None, 40.0) == (40.0, "v_max")


def test_reached_is_commonroads_goal_region(tmp_path):
    """Goal: lane 2 at s = 100, a 6 x 3 m rectangle, steps 10-20, speed 15-25, heading within +-0.2 rad. A centre
    inside at step 15, 20 m/s, heading 0 is in; outside the time, the speed, the heading or the rectangle is not; a
    heading one turn around (2 pi) is the same heading."""
    g = {"lane": 2, "s": 100.0, "velocity": (15.0, 25.0), "orientation": (-0.2, 0.2)}
    sc = load_for(PB, write_scenario(tmp_path / "g.xml", goal=g, goal_steps=(10, 20)))
    pp, inside = sc.planning_problem, (101.0, LANE)
    assert reached(pp, 15, inside, 0.0, 20.0)
    assert reached(pp, 15, inside, 2 * math.pi + 0.1, 20.0)
    assert not reached(pp, 9, inside, 0.0, 20.0) and not reached(pp, 21, inside, 0.0, 20.0)
    assert not reached(pp, 15, inside, 0.0, 26.0) and not reached(pp, 15, inside, 0.3, 20.0)
    assert not reached(pp, 15, (104.0, LANE), 0.0, 20.0) and not reached(pp, 15, (101.0, LANE - 1.6), 0.0, 20.0)
    # a pass through the rectangle at 20 m/s from x = 70 at step 0: inside (97 .. 103) at steps 14 and 15
    xs = 70.0 + 2.0 * np.arange(20)
    centres = np.column_stack([xs, np.full(20, LANE), np.zeros(20)])
    assert first_reached(pp, 0, centres, np.full(20, 20.0)) == 14
    assert first_reached(pp, 0, centres, np.full(20, 30.0)) is None  # too fast for the goal


@pytest.fixture(scope="module")
def left_goal(tmp_path_factory):
    """Goal 120 m ahead in the left lane, steps 50-70 (the traffic's 20 m/s arrives at 6 s), nothing in the way."""
    path = write_scenario(
        tmp_path_factory.mktemp("goal") / "left.xml", goal={"lane": 2, "s": 170.0}, goal_steps=(50, 70)
    )
    return load_for(PB, path)


def test_a_goal_in_the_left_lane_is_driven_to_and_the_run_ends_there(left_goal):
    """The lateral reference is the goal's lane (n = 3.5 m left); the ego changes lane, reaches the goal within its
    window and the run ends at that sample; the solution starts at the initial state, is feasible for the KS model it
    names and valid as a whole."""
    from fcgen.sim.commonroad_run import run_commonroad

    sc = left_goal
    run = run_commonroad(PB, sc)
    cr = run.log.meta["extra"]["commonroad"]
    g = cr["goal"]
    assert cr["n_ref"] == pytest.approx(LANE, abs=0.05) and g["n_ref_source"] == "goal position"
    assert g["reached"] and 50 <= g["step"] <= 70
    assert run.log.n_states == g["sample"] + 1 and run.log.n_controls == g["sample"]
    c = run.ego_centres[-1]
    assert abs(c[0] - 170.0) <= 3.0 and abs(c[1] - LANE) <= 1.5  # inside the 6 x 3 m rectangle
    sol = cr["solution"]
    assert sol["starts_at_initial_state"] and sol["feasible"] and sol["goal_reached"] and sol["valid"]
    assert cr["unsolved"]["samples"] == 0
    np.testing.assert_allclose(run.ego_states[0, :2], [50.0, 0.0], atol=1e-9)  # the problem's initial position


def test_the_solution_verdict_finds_a_wrong_start_and_an_infeasible_jump(left_goal):
    """Driving straight on at 20 m/s is feasible but misses the goal; the same shifted 1 m sideways does not start at
    the initial state; a 5 m jump sideways between two samples is infeasible from that sample on."""
    sc = left_goal
    k = 10
    v = solution_verdict(
        sc, np.column_stack([50.0 + 2.0 * np.arange(k), np.zeros((k, 2)), np.full(k, 20.0), np.zeros(k)])
    )
    assert v["starts_at_initial_state"] and v["feasible"] and not v["goal_reached"] and not v["valid"]
    assert v["valid_but_goal"]
    moved = np.column_stack([50.0 + 2.0 * np.arange(k), np.ones(k), np.zeros(k), np.full(k, 20.0), np.zeros(k)])
    assert not solution_verdict(sc, moved)["starts_at_initial_state"]
    jump = np.column_stack([50.0 + 2.0 * np.arange(k), np.zeros((k, 2)), np.full(k, 20.0), np.zeros(k)])
    jump[5:, 1] = 5.0
    v = solution_verdict(sc, jump)
    assert not v["feasible"] and v["infeasible_step"] == 5 and not v["valid_but_goal"]


def test_an_obstacle_with_a_set_based_prediction_is_refused():
    """A set-based prediction (occupancy sets, CommonRoad's S scenarios) is not a recorded trajectory: refused, naming
    the obstacle."""
    from commonroad.geometry.shape import Rectangle
    from commonroad.prediction.prediction import Occupancy, SetBasedPrediction
    from commonroad.scenario.obstacle import DynamicObstacle, ObstacleType
    from commonroad.scenario.state import InitialState

    from fcgen.commonroad import ScenarioRefused
    from fcgen.commonroad.traffic import obstacle_from

    box = Rectangle(4.0, 2.0)
    init = InitialState(position=np.zeros(2), orientation=0.0, velocity=10.0, time_step=0, yaw_rate=0.0, slip_angle=0.0)
    ob = DynamicObstacle(7, ObstacleType.CAR, box, init, SetBasedPrediction(1, [Occupancy(1, Rectangle(6.0, 3.0))]))
    with pytest.raises(ScenarioRefused, match="obstacle 7: a SetBasedPrediction"):
        obstacle_from(ob, 0.1)


def test_the_speed_reference_makes_up_lost_time_from_what_is_left():
    """A 2 m goal 100-102 m ahead, its window 7-8 s, the traffic's 12 m/s (hand-derived): the middle halves are
    100.5-101.5 m and 7.25-7.75 s, so at the start the ego needs 100.5 / 7.75 = 12.97 m/s at least. Having lost time
    (60 m driven at 5 s) it asks 40.5 / 2.75 = 14.73 m/s; ahead of time (95 m at 5 s) at most 6.5 / 2.25 = 2.89 m/s;
    late (95 m at 7.5 s) the distance in MIN_TIME = 1 s: 5.5 m/s at least, so the traffic's 12 m/s stays; just before
    the window's middle half no upper bound to speak of; past the goal, nothing to time."""
    from fcgen.commonroad.goal import MIN_TIME, SPAN_MARGIN, GoalTiming, arrival_band, speed_now

    g = GoalTiming((100.0, 102.0), (7.0, 8.0), None, 12.0, None, 40.0)
    assert arrival_band(g, 0.0, 0.0) == pytest.approx((100.5 / 7.75, 101.5 / 7.25))
    assert speed_now(g, 0.0, 0.0, False) == (pytest.approx(100.5 / 7.75), "goal time window")
    assert speed_now(g, 5.0, 60.0, False) == (pytest.approx(40.5 / 2.75), "goal time window")
    assert speed_now(g, 5.0, 95.0, False) == (pytest.approx(6.5 / 2.25), "goal time window")
    assert MIN_TIME == 1.0 and arrival_band(g, 7.5, 95.0) == (pytest.approx(5.5), math.inf)
    # 0.05 s before the window's middle half, 6.5 m ahead of its far end: up to 6.5 / 0.05 = 130 m/s is not early
    assert arrival_band(g, 7.2, 95.0) == (pytest.approx(5.5 / 1.0), pytest.approx(6.5 / 0.05))
    assert speed_now(g, 7.5, 95.0, False) == (12.0, "initial speed")
    assert arrival_band(g, 7.5, 101.6) is None and speed_now(g, 7.5, 101.6, True) == (12.0, "initial speed")
    # a goal lanelet 80 m long (100-180 m), steps 30-31: all but SPAN_MARGIN = 2 m at either end, 102-178 m, within
    # 3.025-3.075 s: from 50 m at 16 m/s, 52 / 3.075 = 16.91 m/s at least
    lane = GoalTiming((100.0, 180.0), (3.0, 3.1), None, 16.0, None, 40.0)
    assert SPAN_MARGIN == 2.0 and arrival_band(lane, 0.0, 50.0) == pytest.approx((52.0 / 3.075, 128.0 / 3.025))
    with pytest.raises(ValueError, match=r"GoalTiming.window .* allowed a finite interval"):
        GoalTiming((100.0, 102.0), (8.0, 7.0), None, 12.0, None, 40.0)


def test_the_goal_speed_interval_is_aimed_inside_its_ends():
    """Near the goal its speed interval applies SPEED_MARGIN = 0.5 m/s inside its ends (at most a quarter of its
    width): 18.24-24.24 m/s takes the traffic's 16.8 m/s to 18.74 (the tracking settled 0.2 m/s below a reference at
    the interval's lower end, outside it); 0-1 m/s takes 3 m/s to 0.75; before the goal is near, the interval does
    not apply; the lane's limit and v_max cap it."""
    from fcgen.commonroad.goal import SPEED_MARGIN, GoalTiming, speed_now

    assert SPEED_MARGIN == 0.5
    g = GoalTiming((500.0, 502.0), None, (18.24, 24.24), 16.8, None, 40.0)
    assert speed_now(g, 0.0, 0.0, True) == (pytest.approx(18.74), "goal velocity")
    assert speed_now(g, 0.0, 0.0, False) == (16.8, "initial speed")
    slow = GoalTiming((500.0, 502.0), None, (0.0, 1.0), 3.0, None, 40.0)
    assert speed_now(slow, 0.0, 0.0, True) == (pytest.approx(0.75), "goal velocity")
    capped = GoalTiming(None, None, (30.0, 40.0), 20.0, 25.0, 40.0)
    assert speed_now(capped, 0.0, 0.0, False) == (25.0, "speed limit")


def test_a_lane_change_for_the_goal_is_planned_within_the_time_left():
    """A change towards the goal's lane planned 1.2 s before the goal window's start (3 s) takes MIN_CHANGE = 2 s,
    one planned at 0 s the usual 3 s, one without a window the usual 3 s."""
    from fcgen.commonroad.goal import MIN_CHANGE, GoalTiming, change_time

    g = GoalTiming(None, (3.0, 3.1), None, 16.0, None, 40.0)
    assert MIN_CHANGE == 2.0
    assert change_time(g, 1.8, 3.0) == 2.0 and change_time(g, 0.5, 3.0) == 2.5 and change_time(g, 0.0, 3.0) == 3.0
    assert change_time(GoalTiming(None, None, None, 16.0, None, 40.0), 1.8, 3.0) == 3.0
    assert change_time(None, 1.8, 3.0) == 3.0


def test_a_goal_at_the_speed_intervals_end_and_a_tight_window_is_reached(tmp_path):
    """The ego at 16.8 m/s, a 2.2 x 1.7 m goal 140 m ahead (centre to centre) in its lane, steps 70-80 and 18.24-24.24
    m/s (the recorded driver's ~21 m/s): the window asks 140 / 7.75 = 18.06 m/s at least, and the speed at the goal at
    least 18.24. The ego arrives within the window at a speed inside the interval and the run ends there."""
    from fcgen.sim.commonroad_run import run_commonroad

    goal = {"lane": 1, "s": 50.0 + 140.0, "length": 2.2, "width": 1.7, "velocity": (18.24, 24.24)}
    sc = load_for(PB, write_scenario(tmp_path / "t.xml", goal=goal, goal_steps=(70, 80), ego_v=16.8, length=600.0))
    s_g = sc.goal_sn[0]  # the goal's extent along the straight road: its 2.2 m length about its centre
    assert sc.goal_timing.span == pytest.approx((s_g - 1.1, s_g + 1.1), abs=0.02)
    assert sc.goal_timing.window == pytest.approx((7.0, 8.0)) and sc.goal_timing.speeds == (18.24, 24.24)
    run = run_commonroad(PB, sc, criticality=False)
    g = run.log.meta["extra"]["commonroad"]["goal"]
    assert g["reached"] and 70 <= g["step"] <= 80
    v_end = float(run.log.ego_frenet[-1, 3])
    assert 18.24 <= v_end <= 24.24
