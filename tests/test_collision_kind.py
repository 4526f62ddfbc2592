"""sim.collision_kind: the depth and kind of a run's first contact, and the paper's ellipse's shortfall, against
hand-derived geometry (a straight road, a circular bend) and a second method (a grid of ego-circle centres)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from fcgen.obstacles import Shape, paper_ellipse_h
from fcgen.presets import CAR, TRUCK
from fcgen.road import Road
from fcgen.sim.closedloop import dims
from fcgen.sim.collision_kind import classify, ellipse_shortfall, first_collision


def rear_axle(centre, phi, veh):
    """The rear-axle pose of a vehicle whose chassis centre is ``centre`` (the centre is l/2 ahead of the axle)."""
    return np.array([centre[0] - 0.5 * veh.l * math.cos(phi), centre[1] - 0.5 * veh.l * math.sin(phi), phi])


def test_kinds_by_corner_and_sweep():
    assert classify(0, 5.0) == classify(3, 0.0) == "rear_corner"  # rear-right, rear-left
    assert classify(1, 1.5) == classify(2, 8.0) == "swept_front"
    assert classify(2, 0.2) == "front_corner"


def test_no_collision_gives_none():
    road = Road.from_curvature(np.zeros(100), 2.0)
    ego = np.array([[0.0, 0.0, 0.0]])
    opp = np.array([[[50.0, 0.0, 0.0]]])
    assert first_collision(road, ego, dims(CAR), opp, opp, [dims(CAR)]) is None


def test_clipping_a_rear_corner_on_a_straight_road():
    road = Road.from_curvature(np.zeros(100), 2.0)
    opp_c = np.array([20.0 + 0.5 * CAR.l, 1.0])  # opponent chassis centre, lane n = 1
    # the ego's centre 3.5 m behind and 1.5 m right of the opponent's: it overlaps the rear-right corner by
    # 4 - 3.5 = 0.5 m along and 1.9 - 1.5 = 0.4 m across: SAT depth 0.4 m
    ego = rear_axle(opp_c + np.array([-3.5, -1.5]), 0.0, CAR)[None]
    opp = np.array([[[20.0, 1.0, 0.0]]])
    info = first_collision(road, ego, dims(CAR), opp, opp, [dims(CAR)])
    assert info.depth == pytest.approx(0.4) and info.sample == 0 and info.opponent == 0
    assert info.corner == 0 and info.kind == "rear_corner"
    assert info.sweep == pytest.approx(0.0, abs=1e-9)  # the corner is on its lane's edge: n = 1 - 0.95


def test_a_truck_front_swept_by_a_bend():
    R, s_opp = 25.0, 100.0
    road = Road.from_curvature(np.full(200, 1.0 / R), 2.0)
    pose = road.to_cartesian(np.array([s_opp]), np.array([0.0]), np.array([0.0]))
    x, y, phi = (float(np.ravel(v)[0]) for v in pose)
    t, nrm = np.array([math.cos(phi), math.sin(phi)]), np.array([-math.sin(phi), math.cos(phi)])
    corner = np.array([x, y]) + 23.0 * t + 2.0 * nrm  # front-left: 10 + 13 ahead, 2 to the left
    # the ego (heading the truck's way) centred 0.5 m ahead of that corner on the truck's left edge line:
    # overlap 2 - 0.5 = 1.5 m along and 0.95 m across: depth 0.95 m
    ego = rear_axle(corner + 0.5 * t, phi, CAR)[None]
    opp_c = np.array([[[x, y, phi]]])
    opp_f = np.array([[[s_opp, 0.0, 0.0]]])
    info = first_collision(road, ego, dims(CAR), opp_c, opp_f, [dims(TRUCK)])
    assert info.depth == pytest.approx(0.95) and info.corner == 2 and info.kind == "swept_front"
    # on a circle of radius R (centre on the left), the corner 23 m along the tangent and 2 m in has
    # n = R - sqrt(23^2 + (R - 2)^2): 7.53 m to the right of the lane, 5.53 m beyond the half width
    n_hand = R - math.hypot(23.0, R - 2.0)
    assert info.sweep == pytest.approx(abs(n_hand) - 2.0, abs=0.02)


def test_a_square_is_covered_by_its_enlarged_circle():
    # semi-axes sqrt(2) L + r both: the circle through the square's corners grown by r contains square + disc
    assert ellipse_shortfall(1.0, 1.0, 0.7) == pytest.approx(0.0, abs=1e-12)


def test_the_truck_ellipse_shortfall_matches_a_grid_of_ego_circles():
    L, W, r = 0.5 * TRUCK.l_ch, 0.5 * TRUCK.w_ch, math.hypot(0.5 * CAR.l_ch, 0.5 * CAR.w_ch)
    gap = ellipse_shortfall(L, W, r)
    # second method: every ego-circle centre p on a grid that the ellipse constraint (obstacles.paper_ellipse_h) lets
    # through overlaps the rectangle by r - dist(p, rectangle); the worst of them is the shortfall
    xs, ys = np.meshgrid(np.linspace(0.0, 24.0, 1201), np.linspace(0.0, 8.0, 401))
    h = paper_ellipse_h(xs, ys, Shape(0.0, 0.0, 0.0, L, W), r)
    dist = np.hypot(np.maximum(xs - L, 0.0), np.maximum(ys - W, 0.0))
    worst = float(np.max(np.where(h >= 0.0, r - dist, -np.inf)))
    assert 0.3 < gap < 0.4 and worst == pytest.approx(gap, abs=0.02)
    # the car opponent is (nearly) covered
    assert ellipse_shortfall(0.5 * CAR.l_ch, 0.5 * CAR.w_ch, r) < 0.1


# responsibility (collision_kind.responsible) of hand-built runs: 1 s at 0.1 s, the first contact at the last
# sample (asserted), chassis centres given; on the straight road s = x, n = y
DT, T = 0.1, np.linspace(0.0, 1.0, 11)
STRAIGHT = Road.from_curvature(np.zeros(200), 2.0)


def straight_run(ego_c, ego_phi, opp_c, opp_phi):
    """``first_collision`` of a car ego and a car opponent given by their chassis centres (11, 2) and headings."""
    ego = np.array([rear_axle(c, p, CAR) for c, p in zip(ego_c, ego_phi)])
    opp = np.array([rear_axle(c, p, CAR) for c, p in zip(opp_c, opp_phi)])[:, None]
    return first_collision(STRAIGHT, ego, dims(CAR), opp, opp.copy(), [dims(CAR)], ego[:, 1], DT)


def test_a_lane_kept_rear_end_of_a_slower_car_is_the_egos():
    # both in lane n = 0, the ego at 20 m/s, the car ahead at 15: the ego's front (20 t + 2) passes the car's rear
    # (8.7 + 15 t - 2) at t = 0.94: 0.2 m apart at t = 0.9, 0.3 m deep at t = 1
    info = straight_run(np.c_[20 * T, 0 * T], 0 * T, np.c_[8.7 + 15 * T, 0 * T], 0 * T)
    assert info.sample == 10 and info.depth == pytest.approx(0.3)
    assert info.responsibility == "ego_into_opponent"  # both kept their lanes: the ego closed in on its rear


def test_a_car_cutting_in_ahead_is_from_the_side():
    # the ego keeps n = 0 at 20 m/s; the car ahead, at 15 m/s, moves from n = 3.0 to 1.2 in the second (heading
    # atan(-1.8 / 15)): its rear-right corner (x - 2.10, 0.50) at t = 1 is 0.3 m behind the ego's front (x = 22)
    b = math.atan2(-1.8, 15.0)
    info = straight_run(np.c_[20 * T, 0 * T], 0 * T, np.c_[8.8 + 15 * T, 3.0 - 1.8 * T], 0 * T + b)
    assert info.sample == 10 and info.kind == "rear_corner"  # the ego touches its rear, faster ...
    assert info.responsibility == "opponent_from_side"  # ... but the car did not keep its lane, the ego did


def test_an_opponent_from_behind():
    # the ego at 15 m/s, a car behind in its lane at 20: its front reaches 0.3 m into the ego's rear at t = 1
    info = straight_run(np.c_[15 * T, 0 * T], 0 * T, np.c_[-8.7 + 20 * T, 0 * T], 0 * T)
    assert info.sample == 10 and info.depth == pytest.approx(0.3)
    assert info.responsibility == "opponent_from_behind"


def test_a_lane_change_into_a_car_beside_is_the_egos():
    # the ego at 20 m/s moves from n = -3.9 to -1.9 (heading atan(2 / 20)) into a car in lane n = 0 beside it, 1 m
    # ahead, at 20 m/s: a contact on the car's side (the ego's centre ahead of its rear edge), the ego's lane changed
    a = math.atan2(2.0, 20.0)
    info = straight_run(np.c_[20 * T, -3.9 + 2.0 * T], 0 * T + a, np.c_[1.0 + 20 * T, 0 * T], 0 * T)
    assert info.sample == 10
    assert info.responsibility == "ego_into_opponent"


def test_a_truck_front_swept_into_the_egos_lane_is_from_the_side():
    # a 25 m radius bend (centre on the left); the truck's rear axle in lane n = 0 at 15 m/s, its heading turning
    # from 0.3 rad left of the lane to along it over the second (it enters the bend): its front-right corner (23 m
    # ahead of the axle, 2 m right) sweeps out to n = R - hypot(23, R + 2) = -10.36 m. The ego keeps n = -11.31
    # (its left side 0.3 m inside that corner's last n), its centre level with the corner, at the truck's s rate
    R, s_opp = 25.0, 100.0
    road = Road.from_curvature(np.full(200, 1.0 / R), 2.0)
    x, y, phi = (float(np.ravel(v)[0]) for v in road.to_cartesian(np.array([s_opp]), np.zeros(1), np.zeros(1)))
    corner = (
        np.array([x, y])
        + 23.0 * np.array([math.cos(phi), math.sin(phi)])
        - 2.0 * np.array([-math.sin(phi), math.cos(phi)])
    )
    n_e = R - math.hypot(23.0, R + 2.0) - 0.5 * CAR.w_ch + 0.3
    s_e = float(road.project(corner[:1], corner[1:])[0]) - 0.5 * CAR.l + 15.0 * (T - 1.0)
    s_t, alpha_t = s_opp + 15.0 * (T - 1.0), 0.3 * (1.0 - T)
    opp = np.stack(road.to_cartesian(s_t, 0 * T, alpha_t), axis=1)[:, None]
    ego = np.stack(road.to_cartesian(s_e, n_e + 0 * T, 0 * T), axis=1)
    opp_f = np.stack([s_t, 0 * T, alpha_t], axis=1)[:, None]
    info = first_collision(road, ego, dims(CAR), opp, opp_f, [dims(TRUCK)], n_e + 0 * T, DT)
    assert info.sample == 10 and info.corner == 1 and info.kind == "swept_front"
    assert info.responsibility == "opponent_from_side"
