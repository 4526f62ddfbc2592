"""Tests of the obstacle constraints (fcgen.obstacles, SPEC section 4).

Rows are h >= 0 outside, h < 0 inside. Expected values and signs are derived by hand from the geometry;
coverage is checked by dense sampling of the true rectangles.
"""

from __future__ import annotations

import math
import re

import numpy as np
import pytest

from fcgen import obstacles as obs
from fcgen.dsl import CoveringCircles, Ellipse, SeparatingHyperplane
from fcgen.ocp import build_ocp
from fcgen.presets import CAR, TRUCK, paper_problem
from fcgen.road import Road, random_road

SQ2 = math.sqrt(2.0)


def rect_points(sh: obs.Shape, per_m: float = 50.0, interior: int = 25) -> np.ndarray:
    """Dense points on the boundary (per_m per metre, corners included) and a grid in the interior."""
    corners = [np.array(c, dtype=float) for c in obs.vertices(sh)]
    pts = []
    for i in range(4):
        p0, p1 = corners[i], corners[(i + 1) % 4]
        m = max(2, int(np.linalg.norm(p1 - p0) * per_m))
        t = np.linspace(0, 1, m, endpoint=False)[:, None]
        pts.append(p0 + t * (p1 - p0))
    c, s = math.cos(sh.angle), math.sin(sh.angle)
    a = np.linspace(-1, 1, 4 * interior)[:, None]
    b = np.linspace(-1, 1, interior)[None, :]
    px = sh.cx + a * sh.L * c - b * sh.W * s
    py = sh.cy + a * sh.L * s + b * sh.W * c
    pts.append(np.stack([px.ravel(), py.ravel()], axis=1))
    return np.concatenate(pts)


def box_excess(px, py, box: obs.Shape) -> np.ndarray:
    """max(|e1| - L, |e2| - W) in the box's frame: <= 0 inside the box."""
    c, s = math.cos(box.angle), math.sin(box.angle)
    dx, dy = px - box.cx, py - box.cy
    return np.maximum(np.abs(c * dx + s * dy) - box.L, np.abs(-s * dx + c * dy) - box.W)


# --- shapes by hand ----------------------------------------------------------------------------------


def test_chassis_shape_and_vertices_by_hand():
    # truck: rear axle at (1, 2) heading +y; wheelbase 20, chassis 13 + 13 by 4
    sh = obs.chassis_shape(1.0, 2.0, math.pi / 2, TRUCK)
    assert (sh.cx, sh.cy) == pytest.approx((1.0, 12.0), abs=1e-12)
    assert (sh.L, sh.W) == (13.0, 2.0)
    v = np.array(obs.vertices(sh))
    # front-left, front-right, rear-right, rear-left (heading +y: left is -x)
    np.testing.assert_allclose(v, [[-1, 25], [3, 25], [3, -1], [-1, -1]], atol=1e-12)
    # the car: rear overhang l_r,ch - l_r = 0.3 m behind the rear axle
    car = obs.chassis_shape(0.0, 0.0, 0.0, CAR)
    assert (car.cx, car.L, car.W) == pytest.approx((1.7, 2.0, 0.95))
    assert min(p[0] for p in obs.vertices(car)) == pytest.approx(-0.3)


def test_circle_centres_and_radius_by_hand():
    sh = obs.Shape(0.0, 0.0, 0.0, 13.0, 2.0)
    c = np.array(obs.circle_centres(sh, 7))
    # from -(L - W) = -11 to +11 in 6 equal gaps
    np.testing.assert_allclose(c[:, 0], np.linspace(-11, 11, 7), atol=1e-12)
    np.testing.assert_allclose(c[:, 1], 0.0, atol=1e-12)
    assert obs.circle_radius(13.0, 2.0, 7, cover=False) == pytest.approx(2.0 * SQ2)  # w / sqrt(2)
    assert obs.circle_radius(13.0, 2.0, 1, cover=False) == pytest.approx(math.hypot(13.0, 2.0))
    assert obs.circle_centres(sh, 1) == [(0.0, 0.0)]


# --- ellipse -----------------------------------------------------------------------------------------

OPP = obs.chassis_shape(3.0, -2.0, 0.6, TRUCK)  # a truck chassis at an arbitrary pose


def test_ellipse_corners_on_the_ellipse_and_rectangle_inside():
    # semi-axes sqrt(2) L, sqrt(2) W: a corner (L, W) gives (1/2 + 1/2) = 1 -> on the boundary
    for px, py in obs.vertices(OPP):
        assert abs(obs.paper_ellipse_h(px, py, OPP, 0.0)) < 1e-9
        assert obs.paper_ellipse_h(px, py, OPP, 0.5) < 0  # strictly inside once enlarged
    P = rect_points(OPP)
    assert np.max(obs.paper_ellipse_h(P[:, 0], P[:, 1], OPP, 0.0)) <= 1e-9


@pytest.mark.parametrize("r", [0.0, CAR.r_cover])
def test_ellipse_sign_along_the_axes(r):
    a, b = SQ2 * OPP.L + r, SQ2 * OPP.W + r
    c, s = math.cos(OPP.angle), math.sin(OPP.angle)
    for sign in (1, -1):
        for dist, expected in ((a + 0.01, 0.01 / a), (a - 0.01, -0.01 / a)):  # along the major axis
            h = obs.paper_ellipse_h(OPP.cx + sign * dist * c, OPP.cy + sign * dist * s, OPP, r)
            assert h == pytest.approx(expected, abs=1e-9)
        for dist, expected in ((b + 0.01, 0.01 / b), (b - 0.01, -0.01 / b)):  # along the minor axis
            h = obs.paper_ellipse_h(OPP.cx - sign * dist * s, OPP.cy + sign * dist * c, OPP, r)
            assert h == pytest.approx(expected, abs=1e-9)
    assert obs.paper_ellipse_h(OPP.cx, OPP.cy, OPP, r) == pytest.approx(-1.0, abs=1e-5)


def test_ellipse_constraint_row_uses_the_ego_covering_circle():
    ego = obs.chassis_shape(-40.0, 7.0, 0.2, CAR)
    rows, eqs = obs.constraint_rows(Ellipse(shape="paper"), ego, OPP, None, cover=False, length=4.0)
    assert eqs == []
    assert rows[0] == pytest.approx(obs.paper_ellipse_h(ego.cx, ego.cy, OPP, math.hypot(2.0, 0.95)), abs=1e-15)


# --- covering circles ---------------------------------------------------------------------------------


def uncovered(P, sh, n, radius):
    centres = np.array(obs.circle_centres(sh, n))
    d = np.min(np.hypot(P[:, None, 0] - centres[None, :, 0], P[:, None, 1] - centres[None, :, 1]), axis=1)
    return d - radius  # > 0: outside every circle


@pytest.mark.parametrize("n", [7, 8, 10])
def test_enough_circles_cover_the_truck(n):
    P = rect_points(OPP)
    assert np.max(uncovered(P, OPP, n, obs.circle_radius(OPP.L, OPP.W, n, cover=False))) <= 1e-9
    # the same through the constraint rows with a zero-size ego: some row is negative everywhere
    ego = obs.Shape(P[:, 0], P[:, 1], 0.0, 0.0, 0.0)
    rows = np.array(obs.circles_h(ego, 1, OPP, n, cover=False))
    assert np.max(np.min(rows, axis=0)) <= 1e-9


@pytest.mark.parametrize("n", [5, 6])
def test_too_few_circles_leave_points_uncovered(n):
    P = rect_points(OPP)
    gap = uncovered(P, OPP, n, obs.circle_radius(OPP.L, OPP.W, n, cover=False))
    assert np.max(gap) > 0.01
    # where: on the long edges midway between two centres (n = 5: spacing 5.5 > w = 4)
    # cover=True enlarges the radius (conventional formulation) so that n = 5 covers again
    assert np.max(uncovered(P, OPP, n, obs.circle_radius(OPP.L, OPP.W, n, cover=True))) <= 1e-9


def test_circle_rows_by_hand():
    ego = obs.Shape(30.0, 0.0, 0.0, 2.0, 0.95)
    opp = obs.Shape(0.0, 0.0, 0.0, 13.0, 2.0)
    # one circle each: radii hypot(2, 0.95) and hypot(13, 2)
    rows = obs.circles_h(ego, 1, opp, 1, cover=False)
    assert rows == [pytest.approx(30.0 / (math.hypot(2, 0.95) + math.hypot(13, 2)) - 1, abs=1e-12)]
    # three ego circles x seven opponent circles, radius w/sqrt(2) each
    rows = obs.circles_h(ego, 3, opp, 7, cover=False)
    assert len(rows) == 21
    r = 0.95 * SQ2 + 2.0 * SQ2
    # ego circle centres at 30 - 1.05, 30, 30 + 1.05; opponent centres at -11 .. 11
    expected = [abs(e - o) / r - 1 for e in (28.95, 30.0, 31.05) for o in np.linspace(-11, 11, 7)]
    np.testing.assert_allclose(rows, expected, atol=1e-9)
    assert min(rows) > 0
    # overlapping: ego right next to the truck's side
    rows = obs.circles_h(obs.Shape(0.0, 3.0, 0.0, 2.0, 0.95), 3, opp, 7, cover=False)
    assert min(rows) < 0


# --- separating hyperplane ---------------------------------------------------------------------------


def test_separating_hyperplane_rows_by_hand():
    ego = obs.Shape(30.0, 0.0, 0.0, 2.0, 0.95)  # ego x in [28, 32]
    opp = obs.Shape(0.0, 0.0, 0.0, 13.0, 2.0)  # opponent x in [-13, 13]
    # plane x = 16 with the normal pointing to the opponent: theta . [p - c_opp, 1] = -x + 16
    rows, eq = obs.hyperplane_h(ego, opp, [-1.0, 0.0, 16.0], length=4.0)
    assert len(rows) == 8 and eq == pytest.approx(0.0)
    np.testing.assert_allclose(rows[:4], [(32 - 16) / 4, (32 - 16) / 4, (28 - 16) / 4, (28 - 16) / 4])
    np.testing.assert_allclose(rows[4:], [3 / 4, 3 / 4, 29 / 4, 29 / 4])
    assert min(rows) >= 0
    # a plane through the opponent does not separate: negative rows
    rows, _ = obs.hyperplane_h(ego, opp, [-1.0, 0.0, 0.0], length=4.0)
    assert min(rows) < 0
    # a plane through the ego does not separate either
    rows, _ = obs.hyperplane_h(ego, opp, [-1.0, 0.0, 30.0], length=4.0)
    assert min(rows) < 0
    # normalization row
    _, eq = obs.hyperplane_h(ego, opp, [0.6, 0.6, 0.0], length=4.0)
    assert eq == pytest.approx(0.72 - 1)
    # a margin keeps the ego's vertices that far from the plane: ego rows shift by margin / length, opponent rows not
    rows_m, _ = obs.hyperplane_h(ego, opp, [-1.0, 0.0, 16.0], length=4.0, margin=0.2)
    np.testing.assert_allclose(rows_m[:4], [(32 - 16.2) / 4, (32 - 16.2) / 4, (28 - 16.2) / 4, (28 - 16.2) / 4])
    np.testing.assert_allclose(rows_m[4:], [3 / 4, 3 / 4, 29 / 4, 29 / 4])
    # an ego vertex 0.1 m from the plane satisfies the exact form but violates a 0.2 m margin
    near = obs.Shape(18.1, 0.0, 0.0, 2.0, 0.95)  # ego x in [16.1, 20.1]
    assert min(obs.hyperplane_h(near, opp, [-1.0, 0.0, 16.0], length=4.0)[0]) >= 0
    assert min(obs.hyperplane_h(near, opp, [-1.0, 0.0, 16.0], length=4.0, margin=0.2)[0]) < 0


@pytest.mark.parametrize("margin", [-0.1, 2.5, float("nan")])
def test_separating_hyperplane_margin_validated(margin):
    from fcgen.dsl import ProblemError

    with pytest.raises(ProblemError, match=r"obstacles\.margin"):
        SeparatingHyperplane(margin=margin)


def test_separating_hyperplane_rotated_random():
    rng = np.random.default_rng(0)
    for _ in range(50):
        ang = rng.uniform(-math.pi, math.pi)
        u = np.array([math.cos(ang), math.sin(ang)])
        opp = obs.chassis_shape(*rng.uniform(-20, 20, 2), rng.uniform(-3, 3), TRUCK)
        # an ego far away in direction u from the opponent centre: theta = -u, through a point between them
        dist = 40.0
        ego = obs.chassis_shape(opp.cx + dist * u[0], opp.cy + dist * u[1], rng.uniform(-3, 3), CAR)
        # the ego centre is l/2 ahead of its rear axle: project both shapes on u
        ego_min = min(np.dot(np.array(v) - [opp.cx, opp.cy], u) for v in obs.vertices(ego))
        opp_max = max(np.dot(np.array(v) - [opp.cx, opp.cy], u) for v in obs.vertices(opp))
        assert ego_min > opp_max
        t3 = 0.5 * (ego_min + opp_max)
        rows, eq = obs.hyperplane_h(ego, opp, [-u[0], -u[1], t3], length=4.0)
        assert min(rows) > 0 and abs(eq) < 1e-12
        rows, _ = obs.hyperplane_h(ego, opp, [u[0], u[1], -t3], length=4.0)  # flipped: wrong side
        assert max(rows) < 0


# --- rows per opponent ---------------------------------------------------------------------------------


def test_rows_per_opponent_and_ocp_slack_count():
    assert obs.rows_per_opponent(Ellipse()) == 1
    assert obs.rows_per_opponent(CoveringCircles(7)) == 49
    assert obs.rows_per_opponent(CoveringCircles(5, n_ego=2)) == 10
    assert obs.rows_per_opponent(SeparatingHyperplane()) == 8
    assert obs.thetas_per_opponent(SeparatingHyperplane()) == 3
    assert obs.thetas_per_opponent(Ellipse()) == 0 and obs.thetas_per_opponent(CoveringCircles(3)) == 0
    for ob, rows in (("ellipse", 1), ("circles", 49), ("hyperplane", 8)):
        ocp = build_ocp(paper_problem("truck", "lifted", ob))
        assert ocp.n_sigma == 1 + 3 * rows  # a_lat slack + one per obstacle row
        names = ocp.middle.row_names
        assert sum(re.fullmatch(r"opp\d+_h\d+", nm) is not None for nm in names) == 3 * rows
        assert sum(nm.endswith("hp_norm") for nm in names) == (3 if ob == "hyperplane" else 0)
        assert ocp.n_theta == (9 if ob == "hyperplane" else 0)


# --- conventional formulation: the Frenet over-approximation -------------------------------------------

KAPPA = 0.05
ROAD = Road.from_curvature(np.full(81, KAPPA), 2.0, s0=-60.0)  # a circle of radius 20 m (left turn)


def true_rectangle_in_frenet(s, n):
    """Dense points of the opponent truck's true chassis (rear axle on the lane (s, n), alpha = 0) in (s, n)."""
    x, y, phi = ROAD.to_cartesian(s, n, 0.0)
    sh = obs.chassis_shape(x, y, phi, TRUCK)
    P = rect_points(sh)
    guess = s + (P - [x, y]) @ np.array([math.cos(phi), math.sin(phi)])
    ps, pn, _ = ROAD.to_frenet(P[:, 0], P[:, 1], 0.0 * P[:, 0], s_guess=guess)
    # the mapping is right: back-transforming reproduces the Cartesian points
    bx, by, _ = ROAD.to_cartesian(ps, pn, 0.0)
    assert np.max(np.hypot(bx - P[:, 0], by - P[:, 1])) < 1e-9
    return (x, y, phi), ps, pn


def fitted(s, n):
    pose, ps, pn = true_rectangle_in_frenet(s, n)
    shape = obs.fit_frenet_shape(ROAD, pose, TRUCK, CAR, 0.0, s_guess=s)
    return obs.Shape(*shape[:5]), ps, pn, shape[5]


def test_truck_is_far_from_straight_in_frenet():
    # SPEC: on |kappa| = 0.05 a 26 m truck following the lane deviates by metres in (s, n)
    _, _ps, pn = true_rectangle_in_frenet(20.0, 5.0)
    # by hand: the rear axle is on the circle of radius 15; the front corners 23 m ahead along the tangent are at
    # radius sqrt((15 -+ 2)^2 + 23^2) -> n = 20 - 26.4 = -6.4 (inner) and 20 - 28.6 = -8.6 (outer);
    # the road is the Hermite interpolant of the circle: position error <= h^4/384 kappa^3 = 5e-6 m
    assert np.min(pn) == pytest.approx(20 - math.hypot(17, 23), abs=2e-5)
    # the inner long edge (radius 13 at the rear axle's abscissa, where the tangent touches) is closest to the centre
    assert np.max(pn) == pytest.approx(20 - 13, abs=2e-5)


@pytest.mark.parametrize("n", [5.0, -5.0])
def test_conventional_ellipse_covers_true_rectangle(n):
    box, ps, pn, _ = fitted(20.0, n)
    h = obs.paper_ellipse_h(ps, pn, box, 0.0)  # zero-size ego
    assert np.max(h) < 0, np.max(h)


@pytest.mark.parametrize("n", [5.0, -5.0])
def test_conventional_circles_cover_true_rectangle(n):
    box, ps, pn, _ = fitted(20.0, n)
    ego = obs.Shape(ps, pn, 0.0, 0.0, 0.0)  # zero-size ego: one circle of radius 0
    rows = np.array(obs.constraint_rows(CoveringCircles(7, n_ego=1), ego, box, None, cover=True, length=4.0)[0])
    assert np.max(np.min(rows, axis=0)) < 0


@pytest.mark.parametrize("n", [5.0, -5.0])
def test_conventional_box_covers_true_rectangle(n):
    # the box whose vertices the separating hyperplane uses: every point of the true rectangle is inside it
    box, ps, pn, _ = fitted(20.0, n)
    excess = box_excess(ps, pn, box)
    assert np.max(excess) <= 0.0, f"true rectangle sticks out of the fitted box by {np.max(excess):.2e} m"


@pytest.mark.parametrize("n", [5.0, -5.0])
def test_naive_shape_does_not_cover_true_rectangle(n):
    _pose, ps, pn = true_rectangle_in_frenet(20.0, n)
    naive = obs.Shape(*obs.naive_frenet_shape((20.0, n, 0.0), TRUCK)[:5])
    assert naive.angle == 0.0 and naive.cx == pytest.approx(30.0) and naive.cy == pytest.approx(n)
    h = obs.paper_ellipse_h(ps, pn, naive, 0.0)
    assert np.mean(h > 0) > 0.1 and np.max(h) > 1.0  # metres of the truck stick out of the naive ellipse
    assert np.max(box_excess(ps, pn, naive)) > 2.0


def test_conventional_fit_on_straight_road_is_the_rectangle():
    road = Road.from_curvature(np.zeros(200), 2.0, s0=-100.0)
    x, y, phi = road.to_cartesian(20.0, 3.0, 0.0)
    c_s, c_n, angle, L, W, f = obs.fit_frenet_shape(road, (x, y, phi), TRUCK, CAR, 0.25, s_guess=20.0)
    assert (c_s, c_n, angle) == pytest.approx((30.0, 3.0, 0.0), abs=1e-9)
    assert (L, W, f) == pytest.approx((13.25, 2.25, 1.0), abs=1e-9)  # plus the margin; no stretch


def _edge_pieces_in_frenet(road: Road, s: float, n: float, alpha: float, ppm: float = 1.0, dense: int = 60):
    """The fitted points' edge pieces of a truck at (s, n, alpha): per piece its two mapped ends and ``dense`` mapped
    points in between (an independent projection, Newton to 1e-12)."""
    x, y, phi = road.to_cartesian(s, n, alpha)
    corners = [np.array(c) for c in obs.vertices(obs.chassis_shape(x, y, phi, TRUCK))]
    ends, inner = [], []
    for i in range(4):
        p0, p1 = corners[i], corners[(i + 1) % 4]
        m = max(2, math.ceil((TRUCK.w_ch if i % 2 == 0 else TRUCK.l_ch) * ppm))
        for k in range(m):
            a, b = p0 + (k / m) * (p1 - p0), p0 + ((k + 1) / m) * (p1 - p0)
            t = np.linspace(0.0, 1.0, dense + 2)[:, None]
            P = a + t * (b - a)
            guess = s + (P - [x, y]) @ np.array([math.cos(phi), math.sin(phi)])
            ps, pn, _ = road.to_frenet(P[:, 0], P[:, 1], 0 * P[:, 0], s_guess=guess)
            ends.append(((ps[0], pn[0]), (ps[-1], pn[-1])))
            inner.append(np.stack([ps, pn], axis=1))
    return ends, inner


@pytest.mark.parametrize(
    "road_name, s, n, alpha",
    [("circle", 20.0, 5.0, 0.0), ("circle", 20.0, -5.0, 0.3), ("wavy", 60.0, 4.0, -0.2), ("wavy", 150.0, -4.5, 0.25)],
)
def test_chord_sag_bound_covers_the_mapped_edges(road_name, s, n, alpha):
    """obstacles.chord_sag_bound against the true distance of every mapped edge piece from its chord (dense points,
    independent projection), on the |kappa| = 0.05 circle and a road whose curvature changes (kappa' != 0)."""
    road = ROAD if road_name == "circle" else random_road(5, length=400.0, s0=-50.0)
    ends, inner = _edge_pieces_in_frenet(road, s, n, alpha)
    dev = 0.0
    for (a, b), pts in zip(ends, inner):
        a, b = np.array(a), np.array(b)
        u = (b - a) / np.linalg.norm(b - a)
        off = pts - a
        t = np.clip(off @ u, 0.0, np.linalg.norm(b - a))
        dev = max(dev, float(np.max(np.linalg.norm(off - t[:, None] * u, axis=1))))
    e = np.array([p for ab in ends for p in ab])
    reach = CAR.l + CAR.l_ch + CAR.w_ch
    sel = (road.s >= e[:, 0].min() - reach - road.ds) & (road.s <= e[:, 0].max() + reach + road.ds)
    bound = obs.chord_sag_bound(
        obs.edge_spacing(TRUCK, 1.0), float(e[:, 1].min()), float(e[:, 1].max()), road.kappa[sel], road.ds, reach
    )
    assert 0.0 < dev <= bound, (dev, bound)
    assert bound < 8.0 * dev  # a bound, not a blanket: within a small factor of the true sag


def test_chord_sag_bound_by_hand_and_its_limit():
    # straight road: no sag; circle kappa = 0.05 next to n in [-1, 1], h = 1: q = 1 - 1.5 * 0.05 = 0.925,
    # (|s''| + |n''|) <= 0.05 / q^2 + 0.05 / q, h^2 / 8 of it
    assert obs.chord_sag_bound(1.0, -1.0, 1.0, np.zeros(5), 2.0, 9.3) == 0.0
    q = 1.0 - 1.5 * 0.05
    assert obs.chord_sag_bound(1.0, -1.0, 1.0, np.full(5, 0.05), 2.0, 9.3) == pytest.approx(
        (0.05 / q**2 + 0.05 / q) / 8.0, rel=1e-12
    )
    # curvature slope: kappa 0 -> 0.02 over one 2 m sample, |n| <= 1.5: + 1.5 * 0.01 / q'^3
    qs = 1.0 - 1.5 * 0.02
    assert obs.chord_sag_bound(1.0, -1.0, 1.0, np.array([0.0, 0.02]), 2.0, 9.3) == pytest.approx(
        ((0.02 + 1.5 * 0.01 / qs) / qs**2 + 0.02 / qs) / 8.0, rel=1e-12
    )
    # the piece can leave the curvature samples (h / (2 q) > reach + ds): no bound
    assert obs.chord_sag_bound(4.0, 15.0, 17.0, np.full(5, 0.05), 2.0, 1.0) is None
    # edge spacing: the longest of the edges' spacings (truck: 4 m width in 4, 26 m length in 26 points)
    assert obs.edge_spacing(TRUCK, 1.0) == 1.0
    assert obs.edge_spacing(TRUCK, 0.25) == pytest.approx(26.0 / 7.0)


def test_frenet_ego_shape_inflation_about_the_rear_axle():
    sh = obs.frenet_ego_shape(10.0, 1.0, 0.0, 1.0, CAR)
    assert (sh.cx, sh.cy, sh.L, sh.W) == pytest.approx((11.7, 1.0, 2.0, 0.95))
    f = 1.5
    sh = obs.frenet_ego_shape(10.0, 1.0, 0.0, f, CAR)
    # front edge at f * (l/2 + l_ch/2) = 1.5 * 3.7 ahead of the rear axle, width scaled by f
    assert sh.cx + sh.L == pytest.approx(10.0 + f * 3.7)
    assert pytest.approx(f * 0.95) == sh.W


def test_conventional_fit_along_a_truck_scenario():
    """Seed 0 of the truck scenario through the solver path: the reference's prepare phase fits the opponents of every
    stage from their Cartesian poses and the closed loop's road window (as the generated C does), and each fitted
    ellipse and box covers its opponent's true rectangle (dense points, mapped by an independent projection)."""
    from fcgen.reference import RtiSolver
    from fcgen.sim.closedloop import WINDOW_BEHIND
    from fcgen.sim.scenario import OpponentParams, make_scenario

    pb = paper_problem("truck", "conventional", "ellipse")
    ocp = build_ocp(pb)
    sv = RtiSolver(ocp)
    sc = make_scenario("truck", 0)
    op = OpponentParams(pb, sc)
    fitted = 0
    for j in range(0, 200, 25):
        s_ego = 15.0 * j * sc.dt  # where the ego roughly is
        sv.set_road(sc.road.window(s_ego - WINDOW_BEHIND, pb.road.samples))
        sv.set_opponents(op.horizon(j))
        sv._fit_opponents()  # prepare's first step
        par = sv.opp_stage.reshape(pb.horizon.N + 1, 3, 6)
        assert np.all(par[..., 5] >= 1.0)
        for k in range(0, pb.horizon.N + 1, 8):
            fr, cart = sc.opp_frenet((j + k) * sc.dt), sc.opp_cartesian((j + k) * sc.dt)
            for i in range(3):
                if par[k, i, 0] < sv.road.s0:  # left out: the road window does not cover it
                    assert fr[i, 0] + 23.0 + 9.3 > sv.road.s_end - 2.0 or fr[i, 0] - 3.0 - 9.3 < sv.road.s0 + 2.0
                    continue
                fitted += 1
                sh = obs.chassis_shape(*cart[i], TRUCK)
                P = rect_points(sh, per_m=10, interior=10)
                guess = fr[i, 0] + (P - cart[i, :2]) @ np.array([math.cos(cart[i, 2]), math.sin(cart[i, 2])])
                ps, pn, _ = sc.road.to_frenet(P[:, 0], P[:, 1], 0 * P[:, 0], s_guess=guess)
                box = obs.Shape(*par[k, i, :5])
                assert np.max(obs.paper_ellipse_h(ps, pn, box, 0.0)) < 0
                assert np.max(box_excess(ps, pn, box)) <= 0.0
    assert fitted > 100
