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
