"""The criticality measures (fcgen.commonroad.criticality, commonroad-crime) against hand-computed values on a
constructed scenario: the ego at a constant 20 m/s between a slower vehicle ahead and a faster one behind in its
lane, all at constant speeds, so TTC = gap / closing speed and THW = gap / follower's speed (to the next step)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from crscenes import write_scenario

from fcgen.campaign.commonroad import load_for
from fcgen.commonroad.criticality import criticality
from fcgen.presets import preset

pytestmark = [
    pytest.mark.filterwarnings("ignore::UserWarning"),
    pytest.mark.filterwarnings("ignore::DeprecationWarning"),
]
PB = preset("car_lifted_ellipse_ipm")
CAR = PB.ego
K = 30  # samples
AHEAD = (1, 1, 90.0, 15.0, 60, 4.0, 1.8)  # id, lane (the ego's), centre s at step 0, speed, steps, length, width
BEHIND = (2, 1, 10.0, 25.0, 60, 5.0, 1.8)
BESIDE = (3, 2, 56.0, 10.0, 60, 4.0, 1.8)  # the lane to the left, closing fast: not in the ego's lane


@pytest.fixture(scope="module")
def run(tmp_path_factory):
    path = write_scenario(tmp_path_factory.mktemp("crit") / "three.xml", obstacles=[AHEAD, BEHIND, BESIDE])
    sc = load_for(PB, path)
    j = np.arange(K + 1)
    centres = np.stack([50.0 + 20.0 * sc.dt * j, np.zeros(K + 1), np.zeros(K + 1)], axis=1)
    return sc, criticality(sc, centres, np.full(K + 1, 20.0), CAR.l_ch, CAR.w_ch)


def test_ttc_is_the_gap_over_the_closing_speed(run):
    _, c = run
    assert c["error"] == ""
    gap_ahead = 90.0 - 50.0 - (4.0 + CAR.l_ch) / 2  # bumper to bumper at step 0, closing at 5 m/s
    gap_behind = 50.0 - 10.0 - (5.0 + CAR.l_ch) / 2  # the follower closes at 5 m/s
    for j in range(K + 1):
        assert c["series"]["ttc_ahead"][j] == pytest.approx((gap_ahead - 0.5 * j) / 5.0, abs=0.006)
        assert c["series"]["ttc_behind"][j] == pytest.approx((gap_behind - 0.5 * j) / 5.0, abs=0.006)
    assert c["ttc_ahead"] == {"min": pytest.approx((gap_ahead - 0.5 * K) / 5.0, abs=0.006), "obstacle": 1, "sample": K}
    assert c["ttc_behind"]["obstacle"] == 2 and c["ttc_behind"]["sample"] == K


def test_thw_is_the_gap_over_the_followers_speed_to_the_next_step(run):
    sc, c = run
    gap_ahead = 90.0 - 50.0 - (4.0 + CAR.l_ch) / 2
    gap_behind = 50.0 - 10.0 - (5.0 + CAR.l_ch) / 2
    # the first step at which the follower's front has passed where the leader's rear is at the sample
    assert c["series"]["thw_ahead"][0] == pytest.approx(math.floor(gap_ahead / (20.0 * sc.dt) + 1) * sc.dt)
    assert c["series"]["thw_behind"][0] == pytest.approx(math.floor(gap_behind / (25.0 * sc.dt) + 1) * sc.dt)
    assert c["thw_ahead"]["obstacle"] == 1 and c["thw_behind"]["obstacle"] == 2


def test_the_measures_do_not_depend_on_the_road_s_heading(tmp_path):
    """The same scenario turned by 45 degrees about the origin (CriMe's headway shifts positions by half a length on
    x and y alike: fcgen hands it the scenario turned back to the ego's heading) gives the same TTC and THW."""
    from commonroad.common.file_reader import CommonRoadFileReader
    from commonroad.common.file_writer import CommonRoadFileWriter, OverwriteExistingFile

    path = write_scenario(tmp_path / "three.xml", obstacles=[AHEAD, BEHIND, BESIDE])
    scenario, pps = CommonRoadFileReader(str(path)).open()
    turn = math.pi / 4
    scenario.translate_rotate(np.zeros(2), turn)
    pps.translate_rotate(np.zeros(2), turn)
    CommonRoadFileWriter(scenario, pps).write_to_file(str(tmp_path / "turned.xml"), OverwriteExistingFile.ALWAYS)
    sc = load_for(PB, tmp_path / "turned.xml")
    j = np.arange(K + 1)
    x, y = 50.0 + 20.0 * sc.dt * j, np.zeros(K + 1)
    c, s = math.cos(turn), math.sin(turn)
    centres = np.stack([c * x - s * y, s * x + c * y, np.full(K + 1, turn)], axis=1)
    turned = criticality(sc, centres, np.full(K + 1, 20.0), CAR.l_ch, CAR.w_ch)
    gap_ahead = 90.0 - 50.0 - (4.0 + CAR.l_ch) / 2
    assert turned["error"] == ""
    for j in range(K + 1):
        assert turned["series"]["ttc_ahead"][j] == pytest.approx((gap_ahead - 0.5 * j) / 5.0, abs=0.006)
    # THW's resolution is one step: the turned coordinates' rounding may move the crossing by one
    assert turned["series"]["thw_ahead"][0] == pytest.approx(gap_ahead / 20.0, abs=sc.dt + 1e-9)


def test_a_vehicle_ahead_at_a_constant_gap_reads_no_closing_where_the_lane_s_orientation_crosses_0(tmp_path):
    """A left bend (radius 2000 m) turned so that its lanes head along x at s = 200 m (orientation -0.1 .. +0.1 rad):
    the ego (its initial heading 1 degree left of its lane's) and a vehicle 30 m ahead in its lane at 5 m/s each, a
    constant gap. By hand the TTC is infinite; CriMe's cosines of the lane's orientations at the two (0.015 rad apart on
    the bend) make a closing of a few mm/s: a TTC of thousands of seconds. Turned so that the ego's initial heading is
    along x, the lane's orientation crossed CriMe's wrap at 0 where the vehicle ahead drove: 4.0 s (docstring)."""
    from commonroad.common.file_reader import CommonRoadFileReader
    from commonroad.common.file_writer import CommonRoadFileWriter, OverwriteExistingFile

    radius, s_ego, v, turn = 2000.0, 150.0, 5.0, -200.0 / 2000.0
    ahead = (1, 1, s_ego + 30.0, v, 60, 4.0, 1.8)
    path = write_scenario(tmp_path / "bend.xml", radius=radius, ego_x=s_ego, ego_v=v, obstacles=[ahead])
    scenario, pps = CommonRoadFileReader(str(path)).open()
    scenario.translate_rotate(np.zeros(2), turn)
    pps.translate_rotate(np.zeros(2), turn)
    CommonRoadFileWriter(scenario, pps).write_to_file(str(tmp_path / "turned.xml"), OverwriteExistingFile.ALWAYS)
    sc = load_for(PB, tmp_path / "turned.xml")
    th = (s_ego + v * sc.dt * np.arange(K + 1)) / radius
    x, y = radius * np.sin(th), radius * (1.0 - np.cos(th))
    c, s = math.cos(turn), math.sin(turn)
    centres = np.stack([c * x - s * y, s * x + c * y, th + turn], axis=1)
    centres[0, 2] += math.radians(1.0)
    out = criticality(sc, centres, np.full(K + 1, v), CAR.l_ch, CAR.w_ch)
    assert out["error"] == ""
    ttc = out["series"]["ttc_ahead"]
    assert all(t is not None and t > 100.0 for t in ttc), ttc  # measured at every sample, no closing


def _lanelet(lid: int, road, s, n):
    """A stand-in lanelet (id, centre vertices) whose centre runs through the road-frame points (``s``, ``n``)."""
    from types import SimpleNamespace

    x, y, _ = road.to_cartesian(np.asarray(s, dtype=float), np.asarray(n, dtype=float), np.zeros(len(s)))
    return SimpleNamespace(lanelet_id=lid, center_vertices=np.stack([x, y], axis=1))


def test_the_lanelets_that_turn_off_the_ego_s_road_are_left_out(tmp_path):
    """On a straight three-lane road: a lanelet along the ego's lane, one merging at 0.1 rad and a crossing street 30 m
    to the side stay; a right turn of radius 15 m from the ego's lane (heading 0.25 rad away after 3.75 m of arc,
    0.47 m to the side, on the road) and an oncoming lane (heading pi) are left out."""
    from types import SimpleNamespace

    from fcgen.commonroad.criticality import OFF_ROUTE, off_route

    sc = load_for(PB, write_scenario(tmp_path / "road.xml"))
    road = sc.road
    th = np.linspace(0.0, math.pi / 2, 20)
    ramp = np.linspace(0.0, 40.0, 21)
    lanelets = [
        _lanelet(1, road, np.linspace(60.0, 120.0, 31), np.zeros(31)),  # straight on
        _lanelet(2, road, 100.0 + 15.0 * np.sin(th), -15.0 * (1.0 - np.cos(th))),  # a right turn
        _lanelet(3, road, np.linspace(120.0, 60.0, 31), np.full(31, 3.5)),  # oncoming
        _lanelet(4, road, 60.0 + ramp, -9.0 + math.tan(0.1) * ramp),  # merging at 0.1 rad
        _lanelet(5, road, np.full(11, 100.0), np.linspace(30.0, 60.0, 11)),  # a street crossing 30 m to the side
    ]
    assert 15.0 * (1.0 - math.cos(OFF_ROUTE)) < 0.5  # the turn is still on the road where it heads 0.25 rad away
    assert off_route(SimpleNamespace(lanelets=lanelets), road) == [2, 3]


def test_a_turning_lanelet_is_kept_back_only_under_a_pose_on_no_other():
    """CriMe needs a lanelet under each of the ego's poses: a left-out lanelet is kept back where a pose lies on it
    alone (an on-ramp the ego starts on), not where the pose also lies on a lanelet along the road (a turn forking
    from the ego's lane, DEU_Muc-17)."""
    from fcgen.commonroad.criticality import kept_back

    assert kept_back([2, 3], [[1, 2], [1], [1, 4]]) == set()  # the fork: the turn stays out
    assert kept_back([2, 3], [[2], [1, 2], [1]]) == {2}  # the ego starts on the turn alone
    assert kept_back([2, 3], [[], [2, 3], [1]]) == {2, 3}  # a pose on left-out lanelets only: both back


def test_crime_orientations_hold_the_centre_s_own_vertices():
    """CriMe takes a lanelet's centre vertices as they are where a smoothing fails: their orientations are among the
    ones the turn puts above 0 (a kink of -0.5 m over 10 m: atan2(-0.5, 10) = -0.04996 rad)."""
    from commonroad.scenario.lanelet import Lanelet

    from fcgen.commonroad.criticality import crime_orientations

    centre = np.array([[0.0, 0.0], [10.0, 0.0], [20.0, -0.5], [30.0, -0.5], [40.0, -0.5]])
    side = np.array([0.0, 1.75])
    la = Lanelet(centre + side, centre, centre - side, 7)
    assert float(np.min(crime_orientations(la))) == pytest.approx(math.atan2(-0.5, 10.0), abs=1e-9)
