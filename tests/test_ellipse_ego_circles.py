"""The ellipse with the ego covered by ``n_ego`` circles (``Ellipse(n_ego)``): the circles and their radius by hand,
the opponent's ellipse grown by the smaller radius, the rows against a second method (shapely), n_ego = 1 as the
one-disk rows, bad values refused."""

from __future__ import annotations

import functools
import math

import numpy as np
import pytest
from shapely.geometry import Polygon

from fcgen import obstacles as obs
from fcgen.campaign.grid import Config, paper_grid
from fcgen.dsl import Ellipse, ProblemError
from fcgen.presets import CAR

SQ2 = math.sqrt(2.0)


@functools.cache
def _axes(L: float, W: float, r: float) -> tuple[float, float]:
    return obs.containing_ellipse_axes(L, W, r)


def _rows(model: Ellipse, ego: obs.Shape, opp: obs.Shape, r_axes: float | None = None) -> np.ndarray:
    """The model's rows of one opponent, its ellipse grown by the model's ego radius (as ``opponent_shape`` gives
    it) or by ``r_axes``."""
    r = obs.ego_radius(model, CAR) if r_axes is None else r_axes
    rows, eq = obs.constraint_rows(model, ego, opp, None, cover=False, length=CAR.l_ch, axes=_axes(opp.L, opp.W, r))
    assert eq == []
    return np.array([float(h) for h in rows])


def test_the_cars_two_and_three_circles_by_hand():
    # the car's chassis: 4.0 x 1.9 m (L = 2.0, W = 0.95), its centre l / 2 = 1.7 m ahead of the rear axle
    assert (CAR.l_ch, CAR.w_ch, CAR.l) == (4.0, 1.9, 3.4)
    # one circle: the half diagonal; two: centres +-(L - W) = +-1.05 m, radius sqrt(W^2 + (L - W)^2) (the middle of a
    # side is the farthest point); three: spacing 0.525 m < W, so the corners decide: radius sqrt(2) W
    assert obs.ego_radius(Ellipse(), CAR) == pytest.approx(math.sqrt(4.0 + 0.9025), abs=1e-15)
    assert obs.ego_radius(Ellipse(n_ego=2), CAR) == pytest.approx(math.sqrt(0.9025 + 1.1025), abs=1e-15)
    assert obs.ego_radius(Ellipse(n_ego=3), CAR) == pytest.approx(0.95 * SQ2, abs=1e-15)
    assert obs.rows_per_opponent(Ellipse(n_ego=2)) == 2 and obs.rows_per_opponent(Ellipse(n_ego=5)) == 5
    # rear axle at (1, 2) heading +y: chassis centre (1, 3.7), circles at (1, 2.65) and (1, 4.75); an opponent on the
    # same axis 10 m ahead of the chassis centre: each row is the circle's distance along the axis / a - 1
    ego = obs.chassis_shape(1.0, 2.0, math.pi / 2, CAR)
    opp = obs.Shape(1.0, 13.7, math.pi / 2, 2.5, 0.75)
    a, _ = obs.containing_ellipse_axes(2.5, 0.75, math.sqrt(2.005))
    np.testing.assert_allclose(_rows(Ellipse(n_ego=2), ego, opp), [(10 + 1.05) / a - 1, (10 - 1.05) / a - 1], atol=1e-9)


def test_the_containing_ellipse_of_a_square_is_the_circle_through_its_grown_corners():
    # the smallest-area ellipse of a set symmetric under a quarter turn is a circle (it is unique): for a square of
    # half side L grown by a disk r its radius is sqrt(2) L + r; the ego's two circles shrink it by r1 - r2 = 0.80 m
    half = 0.75
    for n, r in ((1, math.sqrt(4.9025)), (2, math.sqrt(2.005))):
        a, b = obs.containing_ellipse_axes(half, half, obs.ego_radius(Ellipse(n_ego=n), CAR))
        assert a == pytest.approx(SQ2 * half + r, rel=2e-5) and b == pytest.approx(SQ2 * half + r, rel=2e-5)
    # the paper's semi-axes by hand: sqrt(2) W + r
    for n, r in ((1, math.sqrt(4.9025)), (2, math.sqrt(2.005))):
        _, b = obs.paper_ellipse_axes(2.5, half, obs.ego_radius(Ellipse(shape="paper", n_ego=n), CAR))
        assert b == pytest.approx(SQ2 * half + r, abs=1e-12)


def test_two_circles_allow_a_vehicle_level_in_the_next_lane():
    # a 4.9 x 2.0 m car level with the ego, 3.3 m to its left (US-101's lanes lie 3.3-3.5 m apart): its ellipse grown
    # by the one disk (at least W + r1 = 3.21 m across) is 3.93 m across, so the one-disk row is negative; the two
    # circles (r2 = 1.42 m) leave it outside, and the chassis are 1.35 m apart
    ego = obs.chassis_shape(0.0, 0.0, 0.0, CAR)
    opp = obs.Shape(ego.cx, 3.3, 0.0, 2.45, 1.0)
    _, b1 = obs.containing_ellipse_axes(2.45, 1.0, math.sqrt(4.9025))
    assert b1 >= 1.0 + math.sqrt(4.9025) and b1 == pytest.approx(3.93, abs=0.005)
    assert _rows(Ellipse(), ego, opp)[0] == pytest.approx(3.3 / b1 - 1, abs=1e-9) and 3.3 / b1 - 1 < 0
    assert (_rows(Ellipse(n_ego=2), ego, opp) > 0.05).all()


@pytest.mark.parametrize("n_ego", [2, 3])
def test_every_pose_the_rows_admit_keeps_the_chassis_apart(n_ego):
    """Second method: shapely's polygons of the two chassis at random poses near the opponent; wherever every row is
    >= 0 they do not overlap. The same sampling with the ellipse not grown by the ego's radius finds overlaps."""
    rng = np.random.default_rng(7)
    model = Ellipse(n_ego=n_ego)
    opp = obs.Shape(0.0, 0.0, 0.3, 2.6, 1.1)  # a 5.2 x 2.2 m car, turned by 0.3 rad
    opp_poly = Polygon(obs.vertices(opp))
    admitted = overlapping_admitted = ungrown_overlaps = 0
    for _ in range(4000):
        x, y = rng.uniform(-9.0, 9.0), rng.uniform(-6.0, 6.0)
        ego = obs.chassis_shape(x, y, rng.uniform(-math.pi, math.pi), CAR)
        ego_poly = Polygon(obs.vertices(ego))
        overlap = ego_poly.intersection(opp_poly).area > 1e-9
        if (_rows(model, ego, opp) >= 0).all():
            admitted += 1
            overlapping_admitted += overlap
        if (_rows(model, ego, opp, r_axes=0.0) >= 0).all() and overlap:
            ungrown_overlaps += 1
    assert admitted > 1000 and overlapping_admitted == 0
    assert ungrown_overlaps > 50  # the check can fail: an ellipse that is not grown lets the chassis overlap


def test_sat_clearance_agrees_where_the_rows_hold():
    """The campaign's judge (``sat_clearance``) on the poses of the last test's kind: >= 0 wherever the rows hold."""
    import casadi as ca

    a, b = ca.SX.sym("a", 5), ca.SX.sym("b", 5)
    clear = ca.Function(
        "c", [a, b], [obs.sat_clearance(obs.Shape(*(a[i] for i in range(5))), obs.Shape(*(b[i] for i in range(5))))]
    )
    rng = np.random.default_rng(3)
    opp = obs.Shape(0.0, 0.0, -0.2, 3.05, 1.2)
    held = 0
    for _ in range(1500):
        ego = obs.chassis_shape(rng.uniform(-9, 9), rng.uniform(-6, 6), rng.uniform(-math.pi, math.pi), CAR)
        if (_rows(Ellipse(n_ego=2), ego, opp) >= 0).all():
            held += 1
            assert float(clear([ego.cx, ego.cy, ego.angle, ego.L, ego.W], [0.0, 0.0, -0.2, 3.05, 1.2])) >= 0.0
    assert held > 300


def test_one_ego_circle_is_the_one_disk_row_bit_for_bit():
    rng = np.random.default_rng(11)
    r1 = math.hypot(CAR.l_ch / 2, CAR.w_ch / 2)
    for shape, axes_of in (("minkowski", obs.containing_ellipse_axes), ("paper", obs.paper_ellipse_axes)):
        for _ in range(20):
            ego = obs.chassis_shape(*rng.uniform(-8, 8, 2), rng.uniform(-3, 3), CAR)
            opp = obs.Shape(*rng.uniform(-2, 2, 2), rng.uniform(-3, 3), 2.5, 0.9)
            rows, _ = obs.constraint_rows(Ellipse(shape=shape), ego, opp, None, cover=False, length=4.0)
            assert len(rows) == 1 and rows[0] == obs.ellipse_h(ego.cx, ego.cy, opp, *axes_of(opp.L, opp.W, r1))
    assert Ellipse() == Ellipse(n_ego=1) and obs.ego_radius(Ellipse(), CAR) == r1


def test_the_shape_check_takes_the_models_radius():
    # semi-axes computed for two ego circles are too small for the one-disk model: refused naming b and its floor
    vals = obs.opponent_shape(Ellipse(n_ego=2), CAR, 4.9, 2.0, 0.0)
    obs.check_opponent_shape(Ellipse(n_ego=2), CAR, vals)
    with pytest.raises(ValueError, match=r"opponent shape a = .* allowed in \[4\.66"):
        obs.check_opponent_shape(Ellipse(), CAR, vals)


@pytest.mark.parametrize("bad", [0, 6, -1, 2.0, True, "2", None])
def test_bad_n_ego_is_refused_naming_the_field(bad):
    with pytest.raises(ProblemError, match=r"obstacles\.n_ego = .* is invalid: allowed an integer in \[1, 5\]"):
        Ellipse(n_ego=bad)


def test_campaign_config_ego_circles():
    base = Config("car", "lifted", "ellipse", 0, "c", "ipm", "safe", road_bound="corners")
    two = Config("car", "lifted", "ellipse", 0, "c", "ipm", "safe", road_bound="corners", ego_circles=2)
    assert base.key == "car/lifted/EL/c/ipm/safe/corners" and "ego_circles" not in base.as_dict()
    assert two.key == base.key + "/ego2" and two.as_dict()["ego_circles"] == 2
    pb = two.problem()
    assert pb.obstacles == Ellipse(n_ego=2) and pb.name == base.problem().name + "_e2"
    with pytest.raises(ProblemError, match=r"ego_circles = 2 is invalid: allowed 1 unless obstacles = 'ellipse'"):
        Config("car", "lifted", "hyperplane", 0, ego_circles=2)
    with pytest.raises(ProblemError, match=r"ego_circles = 6 is invalid: allowed an integer in \[1, 5\]"):
        Config("car", "lifted", "ellipse", 0, ego_circles=6)
    # the grid: the ellipse's configurations take the circles, the others keep one; a grid without the ellipse refuses
    grid = paper_grid(["car"], ["lifted"], ["ellipse", "hyperplane"], road_bound="corners", ego_circles=3)
    assert [(c.obstacles, c.ego_circles) for c in grid] == [("ellipse", 3), ("hyperplane", 1)]
    with pytest.raises(ProblemError, match=r"ego_circles = 2 is invalid: allowed 1 unless the grid has the ellipse"):
        paper_grid(["car"], ["lifted"], ["hyperplane"], ego_circles=2)
