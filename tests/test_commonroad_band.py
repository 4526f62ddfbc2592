"""The solver's lateral band on CommonRoad scenarios (``fcgen.commonroad.band``): the lanes in use, their band, the way
back for an ego off it, on scenarios the tests write with commonroad-io (lanes of 3.5 m, the car: chassis 4.0 x 1.9 m,
wheelbase 3.4 m, so the rear axle's band is the lanes' shrunk by 0.95 + 0.25 = 1.2 m)."""

from __future__ import annotations

import numpy as np
import pytest
from crscenes import LANE, write_scenario

from fcgen.campaign.commonroad import load_for
from fcgen.commonroad.band import BACK_MARGIN, BACK_ROOM, SolverBand, lane_band, lanes_in_use, way_back
from fcgen.commonroad.lanes import road_lanes
from fcgen.presets import preset
from fcgen.sim.closedloop import solver_window
from fcgen.sim.commonroad_run import run_commonroad, scenario_road, solver_band

pytestmark = [
    pytest.mark.filterwarnings("ignore::UserWarning"),
    pytest.mark.filterwarnings("ignore::DeprecationWarning"),
]
PB = preset("car_lifted_ellipse_ipm_safe")
INSET = PB.ego.w_ch / 2 + 0.25
HALF = LANE / 2


def _s(sc, x: float) -> float:
    return float(sc.road.to_frenet(np.array([x]), np.array([0.0]), np.array([0.0]))[0][0])


def test_the_lanes_in_use(tmp_path):
    """Three lanes, the chassis' lateral extent [lo, hi]: within the middle lane, the middle one; across the marking
    at n = 1.75 by 0.75 m, the middle and the left one; 0.05 m over it (less than OVERLAP), the middle one alone; the
    target lane always."""
    sc = load_for(PB, write_scenario(tmp_path / "l.xml", end_lane=(0, 150.0)))
    lanes = road_lanes(sc.scenario.lanelet_network, sc.road)
    s = _s(sc, 100.0)
    assert lanes_in_use(lanes, s, -0.95, 0.95, 0.0) == pytest.approx((0.0, 0.0), abs=1e-6)
    assert lanes_in_use(lanes, s, 0.6, 2.5, 0.0) == pytest.approx((0.0, LANE), abs=1e-6)
    assert lanes_in_use(lanes, s, 0.85, 1.8, 0.0) == pytest.approx((0.0, 0.0), abs=1e-6)
    assert lanes_in_use(lanes, s, -0.95, 0.95, LANE) == pytest.approx((0.0, LANE), abs=1e-6)
    # past the right lane's end (x = 150) a chassis there overlaps no lane: the target's alone
    assert lanes_in_use(lanes, _s(sc, 160.0), -4.5, -2.6, 0.0) == pytest.approx((0.0, 0.0), abs=1e-6)


def test_the_band_of_the_lanes(tmp_path):
    """The lanes' edges by hand: the middle lane [-1.75, 1.75]; the middle and the left [-1.75, 5.25]; the right and
    the middle [-5.25, 1.75] before the right lane ends (x = 150), [-1.75, 1.75] after it."""
    sc = load_for(PB, write_scenario(tmp_path / "b.xml", end_lane=(0, 150.0)))
    lanes = road_lanes(sc.scenario.lanelet_network, sc.road)
    s = np.array([_s(sc, x) for x in (60.0, 100.0, 140.0, 160.0, 300.0)])
    wide = np.full(len(s), 20.0)
    lo, hi = lane_band(lanes, s, (0.0, 0.0), -wide, wide)
    np.testing.assert_allclose(lo, -HALF, atol=1e-6)
    np.testing.assert_allclose(hi, HALF, atol=1e-6)
    lo, hi = lane_band(lanes, s, (0.0, LANE), -wide, wide)
    np.testing.assert_allclose(lo, -HALF, atol=1e-6)
    np.testing.assert_allclose(hi, LANE + HALF, atol=1e-6)
    lo, hi = lane_band(lanes, s, (-LANE, 0.0), -wide, wide)
    np.testing.assert_allclose(lo, [-LANE - HALF] * 3 + [-HALF] * 2, atol=1e-6)
    np.testing.assert_allclose(hi, HALF, atol=1e-6)
    # within the road's band: a narrower road band wins
    lo, hi = lane_band(lanes, s, (0.0, LANE), -wide, np.full(len(s), 1.0))
    np.testing.assert_allclose(hi, 1.0)


def test_the_way_back_by_hand():
    """Band [-1, 1]; the rear axle at n = -2 (s = 100, 10 m/s, heading 0): the lower edge is -2.02 (BACK_ROOM beyond
    it) at s <= 100 and returns to -1 over max(10, 3 s x 10 m/s) = 30 m as 3u^2 - 2u^3: -2.02 + 1.02 x 0.5 = -1.51 at
    s = 115, -1 from s = 130 on; the upper edge stays. An ego 0.5 m inside the band moves nothing; one 0.05 m inside an
    edge (less than BACK_MARGIN) gets the edge BACK_ROOM beyond it where the band is narrower than that."""
    s = np.arange(80.0, 161.0, 5.0)
    lo, hi = np.full(len(s), -1.0), np.full(len(s), 1.0)
    lo2, hi2, moved = way_back(s, lo, hi, 100.0, -2.0, 0.0, 10.0)
    assert moved
    at = dict(zip(s.tolist(), lo2.tolist(), strict=True))
    assert at[80.0] == at[100.0] == pytest.approx(-2.0 - BACK_ROOM)
    assert at[115.0] == pytest.approx(-2.02 + 1.02 * 0.5)
    assert at[130.0] == at[160.0] == pytest.approx(-1.0)
    np.testing.assert_array_equal(hi2, hi)
    assert np.all(np.diff(lo2[s >= 100.0]) >= 0.0)  # back monotonically
    _, _, moved = way_back(s, lo, hi, 100.0, 0.5, 0.0, 10.0)
    assert not moved
    assert BACK_MARGIN == 0.1
    _, hi3, moved = way_back(s, lo, np.where(s <= 100.0, 0.96, hi), 100.0, 0.95, 0.0, 10.0)
    assert moved and hi3[0] == pytest.approx(0.95 + BACK_ROOM)
    assert not way_back(s, lo, hi, 100.0, 0.95, 0.0, 10.0)[2]  # 0.97 is inside the band: nothing to move


def test_the_way_back_for_a_heading_towards_the_edge():
    """Band [-1, 1], the rear axle at n = 0.5 (s = 100, 10 m/s) heading 0.1 rad to the left, after a sample without a
    solution: at that heading it would be at 0.5 + 10 tan(0.1) = 1.503 after BACK_TURN = 1 s (10 m): the upper edge
    moves to that path plus BACK_ROOM, returning over 30 m: at s = 105 (u = 1/6) e + (1 - e) h(1/6) with
    e = 0.52 + 5 tan(0.1), at s = 110 (u = 1/3) with e = 0.52 + 10 tan(0.1), h(u) = 3u^2 - 2u^3. Heading 0.1 rad to
    the right, it moves nothing; without the failure (the path over BACK_STEP = 0.2 s, 2 m: 0.72 m) neither."""
    s = np.arange(80.0, 161.0, 5.0)
    lo, hi = np.full(len(s), -1.0), np.full(len(s), 1.0)
    _, hi2, moved = way_back(s, lo, hi, 100.0, 0.5, 0.1, 10.0)
    assert moved
    at = dict(zip(s.tolist(), hi2.tolist(), strict=True))

    def h(u):
        return 3 * u * u - 2 * u**3

    for x, u in ((105.0, 1 / 6), (110.0, 1 / 3)):
        edge = 0.5 + BACK_ROOM + np.tan(0.1) * min(x - 100.0, 10.0)
        assert at[x] == pytest.approx(edge + (1.0 - edge) * h(u))
    assert at[100.0] == at[80.0] == 1.0 and at[130.0] == 1.0
    assert not way_back(s, lo, hi, 100.0, 0.5, -0.1, 10.0)[2]
    assert not way_back(s, lo, hi, 100.0, 0.5, 0.1, 10.0, heading=False)[2]


def test_the_solver_band_of_a_lane_and_of_a_lane_change(tmp_path):
    """The rear axle's band in the solver's window: settled in the middle lane [-1.75 + 1.2, 1.75 - 1.2] =
    [-0.55, 0.55]; changing to the left lane [-0.55, 5.25 - 1.2 = 4.05]; with the road's band (rule ``road``) the
    three lanes' [-5.25 + 1.2, 4.05] as before."""
    sc = load_for(PB, write_scenario(tmp_path / "w.xml"))
    lanes = road_lanes(sc.scenario.lanelet_network, sc.road)
    road, _ = scenario_road(PB, sc)
    x = np.array([_s(sc, 100.0) - PB.ego.l / 2, 0.0, 0.0, 20.0, 0.0])
    inner = None
    for target, rule, want in (
        (0.0, "lanes", (-HALF + INSET, HALF - INSET)),
        (LANE, "lanes", (-HALF + INSET, LANE + HALF - INSET)),
        (0.0, "road", (-LANE - HALF + INSET, LANE + HALF - INSET)),
    ):
        win = solver_window(PB, road, x)
        inner = (win.s > _s(sc, 60.0)) & (win.s < _s(sc, 390.0))
        assert not solver_band(PB, sc, lanes, rule).set(win, x, target)
        np.testing.assert_allclose(win.n_min[inner], want[0], atol=1e-6)
        np.testing.assert_allclose(win.n_max[inner], want[1], atol=1e-6)
    assert inner is not None and inner.sum() > 50
    with pytest.raises(ValueError, match="not a band rule: allowed road, road_back, lanes"):
        SolverBand("lane", [], sc.road, 1.2, (-8.5, 8.5), 2.0, 0.95, 1.7)


def test_an_ego_that_starts_over_the_edge_drives_back(tmp_path):
    """Closed loop (Python reference), three lanes, the ego starting in the right lane 1.3 m right of its centre: the
    chassis 0.5 m over the road's right edge, the rear axle 0.75 m below its band's lower edge (the road's frame is
    the right lane's centre: -1.75 + 1.2 = -0.55; the ego at -1.3). With the road's band as a hard bound the QP has
    no solution at the start; with the way back every QP is solved and the rear axle is inside its band within 3 s,
    from then on the chassis' corners on the road (the drivability checker's first departure is the start's)."""
    path = write_scenario(tmp_path / "o.xml", ego_lane=0, ego_n=-1.3, goal_steps=(60, 60))
    sc = load_for(PB, path)
    assert sc.x0[1] == pytest.approx(-1.3, abs=1e-6)  # the reference path is the right lane's centre
    old = run_commonroad(PB, sc, band="road")
    assert old.log.meta["extra"]["commonroad"]["unsolved"]["samples"] > 0
    run = run_commonroad(PB, sc, band="lanes")
    cr = run.log.meta["extra"]["commonroad"]
    assert cr["unsolved"]["samples"] == 0
    assert cr["band"]["way_back_samples"][0] == 0
    n = np.asarray(run.log.ego_frenet)[:, 1]
    inside = np.flatnonzero(n >= -HALF + INSET - 1e-3)
    assert inside.size and inside[0] * sc.dt <= 3.0
    assert np.all(n[inside[0] :] >= -HALF + INSET - 0.05)
    # the chassis' corners on the straight road: n + a sin(alpha) + b cos(alpha), a from the rear axle along the car
    # (-0.3 and 3.7 m), b across it (+-0.95 m); inside the road's right edge (-5.25 + 3.5 = -1.75 on this frame)
    f = np.asarray(run.log.ego_frenet)[inside[0] :]
    a = PB.ego.l / 2 + np.array([-1.0, 1.0]) * PB.ego.l_ch / 2
    corners = [f[:, 1] + ai * np.sin(f[:, 2]) + b * np.cos(f[:, 2]) for ai in a for b in (-0.95, 0.95)]
    assert np.min(corners) >= -HALF
    assert run.checker["road_departure"] and run.checker["departure_step"] == 0
    assert not run.checker["collision"]


def test_the_checker_sees_an_ego_back_on_the_road_and_off_it_again(tmp_path):
    """Three lanes of 3.5 m (the road's edges at y = -5.25 and 5.25), the chassis 4.0 x 1.9 m along x: centred at
    y = -5.0 it crosses the right edge (to -5.95), at y = 0 it is clear, at y = 4.8 it crosses the left edge (to
    5.75). Off, off, on, on, off, on: the departure at 0, back at 2, off again at 4; starting on the road, the
    departure at 2 and no return asked."""
    from fcgen.commonroad.judge import drivability_verdict

    sc = load_for(PB, write_scenario(tmp_path / "j.xml"))
    ys = [-5.0, -5.0, 0.0, 0.0, 4.8, 0.0]
    centres = np.array([[50.0 + 2.0 * j, y, 0.0] for j, y in enumerate(ys)])
    v = drivability_verdict(sc, centres, PB.ego.l_ch, PB.ego.w_ch)
    assert (v["departure_step"], v["back_on_road_step"], v["departure_again_step"]) == (0, 2, 4)
    v = drivability_verdict(sc, centres[2:], PB.ego.l_ch, PB.ego.w_ch)
    assert (v["departure_step"], v["back_on_road_step"], v["departure_again_step"]) == (2, None, None)


def test_a_lanelet_whose_borders_cross_still_gives_the_band():
    """A lanelet whose borders cross (its polygon a bow-tie, as DEU_A9-1_1's self-touching border): the band is
    measured on the repaired polygon, 1.75 m to each side away from the crossing, not a GEOS TopologyException."""
    from commonroad.scenario.lanelet import Lanelet, LaneletNetwork

    from fcgen.commonroad.reference_path import drivable_band
    from fcgen.road import straight_road

    x = np.array([0.0, 100.0, 101.0, 300.0])
    left = np.stack([x, np.array([1.75, 1.75, -1.75, -1.75])], axis=1)
    right = np.stack([x, np.array([-1.75, -1.75, 1.75, 1.75])], axis=1)
    net = LaneletNetwork.create_from_lanelet_list([Lanelet(left, (left + right) / 2, right, 1)])
    road = straight_road(300.0)
    assert not net.find_lanelet_by_id(1).polygon.shapely_object.is_valid
    lo, hi = drivable_band(net, road)
    away = (road.s > 10.0) & (road.s < 90.0)
    assert np.allclose(lo[away], -1.75, atol=1e-6) and np.allclose(hi[away], 1.75, atol=1e-6)
