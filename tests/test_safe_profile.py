"""The safe profile: obstacle shapes that contain what they stand for, the presets' profiles, exact penalties."""

from __future__ import annotations

import math
from dataclasses import replace

import casadi as ca
import numpy as np
import pytest

from fcgen import obstacles as obs
from fcgen.collision import chassis_corners, sat_overlap
from fcgen.dsl import CoveringCircles, Ellipse, Horizon, PlanCheck, Problem, ProblemError, SeparatingHyperplane
from fcgen.ocp import build_ocp
from fcgen.presets import CAR, PAPER_SOFT, SAFE_PLAN_CHECK, SAFE_SOFT_CONVENTIONAL, TRUCK, preset, preset_names
from fcgen.reference import RtiSolver
from fcgen.road import straight_road


def polygon_distance(a: np.ndarray, b: np.ndarray) -> float:
    """Smallest distance from a vertex of polygon ``a`` to an edge of ``b`` (with the converse: the distance of two
    disjoint convex polygons)."""
    best = math.inf
    for i in range(len(b)):
        p0, p1 = b[i], b[(i + 1) % len(b)]
        d = p1 - p0
        t = np.clip(((a - p0) @ d) / (d @ d), 0.0, 1.0)
        best = min(best, float(np.min(np.linalg.norm(a - (p0 + t[:, None] * d), axis=1))))
    return best


def grown_rectangle_boundary(L: float, W: float, r: float, n: int = 4000) -> np.ndarray:
    """Points on the boundary of the half-L x half-W rectangle grown by a disk of radius r (a stadium-cornered box):
    four straight sides pushed out by r and four quarter circles around the corners."""
    t = np.linspace(0.0, 0.5 * math.pi, n)
    pts = []
    for sx, sy in ((1, 1), (-1, 1), (-1, -1), (1, -1)):
        pts.append(np.stack([sx * (L + r * np.cos(t)), sy * (W + r * np.sin(t))], axis=1))
    u = np.linspace(-1.0, 1.0, n)
    pts += [
        np.stack([L * u, np.full(n, W + r)], 1),
        np.stack([L * u, np.full(n, -W - r)], 1),
        np.stack([np.full(n, L + r), W * u], 1),
        np.stack([np.full(n, -L - r), W * u], 1),
    ]
    return np.concatenate(pts)


@pytest.mark.parametrize("opp, ego", [(TRUCK, CAR), (CAR, CAR), (CAR, TRUCK)], ids=["truck", "car", "car-by-truck"])
def test_the_safe_ellipse_contains_the_rectangle_grown_by_the_ego_circle(opp, ego):
    L, W, r = opp.l_ch / 2, opp.w_ch / 2, ego.r_cover
    sh = obs.Shape(0.0, 0.0, 0.0, L, W)
    P = grown_rectangle_boundary(L, W, r)
    a, b = obs.containing_ellipse_axes(L, W, r)
    h = obs.ellipse_h(P[:, 0], P[:, 1], sh, a, b)
    assert h.max() <= 0.0  # every boundary point inside (or on) the ellipse
    assert h.max() > -1e-3  # and it touches: no larger than it needs to be
    # the paper's ellipse does not contain it (a second method: collision_kind.ellipse_shortfall's 0.3 m for a truck)
    assert obs.paper_ellipse_h(P[:, 0], P[:, 1], sh, r).max() > 0.0
    # the smallest area: a 1 % smaller ellipse in either axis leaves a point out
    assert obs.ellipse_h(P[:, 0], P[:, 1], sh, 0.99 * a, b).max() > 0.0
    assert obs.ellipse_h(P[:, 0], P[:, 1], sh, a, 0.99 * b).max() > 0.0
    # the closed form for shapes sized at run time (CasADi) contains it too
    Ls, Ws, rs = ca.SX.sym("L"), ca.SX.sym("W"), ca.SX.sym("r")
    f = ca.Function("ab", [Ls, Ws, rs], list(obs.containing_ellipse_axes(Ls, Ws, rs)))
    ac, bc = (float(v) for v in f(L, W, r))
    assert obs.ellipse_h(P[:, 0], P[:, 1], sh, ac, bc).max() <= 0.0
    assert ac * bc >= a * b  # and is no smaller than the optimum


def test_the_safe_circles_cover_the_chassis_where_the_papers_do_not():
    # a truck with 5 circles: spacing (26 - 4) / 4 = 5.5 m > w = 4 m, the paper's radius w / sqrt(2) leaves gaps
    sh = obs.chassis_shape(0.0, 0.0, 0.3, TRUCK)
    P = chassis_corners(0.0, 0.0, 0.3, TRUCK.l, TRUCK.l_r_ch, TRUCK.l_f_ch, TRUCK.w_ch)
    edge = np.concatenate([P[i] + np.linspace(0, 1, 400)[:, None] * (P[(i + 1) % 4] - P[i]) for i in range(4)])

    def covered(cover: bool) -> bool:
        rad = obs.circle_radius(sh.L, sh.W, 5, cover)
        C = np.array(obs.circle_centres(sh, 5))
        d = np.linalg.norm(edge[:, None, :] - C[None], axis=2).min(axis=1)
        return bool(d.max() <= rad + 1e-12)

    assert covered(True) and not covered(False)
    rows_safe, _ = obs.constraint_rows(CoveringCircles(5), sh, sh, None, cover=False, length=4.0)
    rows_paper, _ = obs.constraint_rows(CoveringCircles(5, radius="paper"), sh, sh, None, cover=False, length=4.0)
    assert min(rows_safe) < min(rows_paper)  # larger circles: deeper inside for the same pose


def test_hyperplane_rows_that_hold_separate_the_true_rectangles_by_the_margin():
    """If every ego vertex is >= margin on one side of a unit-normal plane and every opponent vertex on the other,
    the rectangles are apart by at least the margin (convexity); the SAT judge agrees on random poses."""
    rng = np.random.default_rng(3)
    model = SeparatingHyperplane(margin=0.2)
    held = 0
    for _ in range(3000):
        ex, ey, ephi, ox, oy, ophi = rng.uniform([-30, -8, -1, -5, -3, -0.5], [30, 8, 1, 5, 3, 0.5])
        ego, opp = obs.chassis_shape(ex, ey, ephi, CAR), obs.chassis_shape(ox, oy, ophi, TRUCK)
        ang = rng.uniform(-math.pi, math.pi)
        theta = (math.cos(ang), math.sin(ang), rng.uniform(-20, 20))
        rows, (eq,) = obs.constraint_rows(model, ego, opp, theta, cover=False, length=CAR.l_ch)
        assert abs(eq) < 1e-12
        if min(rows) >= 0.0:
            held += 1
            ce = chassis_corners(ex, ey, ephi, CAR.l, CAR.l_r_ch, CAR.l_f_ch, CAR.w_ch)
            co = chassis_corners(ox, oy, ophi, TRUCK.l, TRUCK.l_r_ch, TRUCK.l_f_ch, TRUCK.w_ch)
            assert sat_overlap(ce, co) < 0.0  # the judge: apart
            assert min(polygon_distance(ce, co), polygon_distance(co, ce)) >= 0.2 - 1e-9
    assert held > 50


def test_profiles_of_the_presets():
    paper, safe = preset("truck_lifted_hyperplane_ipm"), preset("truck_lifted_hyperplane_ipm_safe")
    assert safe.name == "truck_lift_hp_ipm_safe" and safe.qp.backend == "ipm"
    # the same scenario, formulation, horizon, weights, backend: only the profile's fields differ
    for f in ("formulation", "ego", "opponents", "wind", "horizon", "weights", "road"):
        assert getattr(paper, f) == getattr(safe, f), f
    # of the reference only the curve speed (the paper asks v_ref everywhere)
    assert replace(paper.reference, curve_a_lat=safe.reference.curve_a_lat) == safe.reference
    assert paper.reference.curve_a_lat == 0.0 < safe.reference.curve_a_lat == Problem("x").reference.curve_a_lat
    # of the bounds only the planning margin inside the a_lat bound (the paper plans up to it)
    assert replace(paper.bounds, a_lat_margin=safe.bounds.a_lat_margin) == safe.bounds
    assert paper.bounds.a_lat_margin == 0.0 < safe.bounds.a_lat_margin == Problem("x").bounds.a_lat_margin
    # of the QP options only the IPM's start (the safe profile's and the DSL's default: scaled)
    assert replace(paper.qp, ipm_scaled_start=True) == safe.qp and not paper.qp.ipm_scaled_start
    assert Problem("x").qp.ipm_scaled_start
    # the safe weights' order: where the hard problem is infeasible, a_lat gives way before an obstacle row
    assert safe.soft.obstacle_l1 > safe.soft.a_lat_l1 > PAPER_SOFT.a_lat_l1
    assert paper.soft == PAPER_SOFT and paper.plan_check.react_stages == 0 and paper.obstacles.anchor == 0.0
    assert not paper.plan_check.a_lat_guard and safe.plan_check.a_lat_guard  # the paper applies its plan's u0
    assert safe.soft == Problem("x").soft and safe.plan_check == SAFE_PLAN_CHECK and safe.obstacles.anchor > 0
    # Problem()'s defaults are the safe profile
    d = Problem("x")
    assert d.obstacles == Ellipse() and d.obstacles.shape == "minkowski" and d.plan_check.react_stages > 0
    assert d.soft.a_lat_l1 > PAPER_SOFT.a_lat_l1 and d.soft.obstacle_l1 > PAPER_SOFT.obstacle_l1
    for name in preset_names():
        # the DSL's weights, but for the conventional formulation's (obstacle 1e8: its QPs' conditioning; its boxes
        # give way before a_lat, 3e8)
        conventional = "_conventional_" in name
        assert preset(name + "_safe").soft == (SAFE_SOFT_CONVENTIONAL if conventional else d.soft)
        assert replace(d.soft, obstacle_l1=1e8, a_lat_l1=3e8) == SAFE_SOFT_CONVENTIONAL
        assert preset(name + "_safe").bounds.a_lat_margin == d.bounds.a_lat_margin
        assert preset(name).bounds.a_lat_margin == 0.0
        # the DSL's reference, but the conventional formulation's curve speed has no traffic rule and is taken at the
        # plan's start only (verify's 1e-7)
        assert preset(name + "_safe").reference == (
            replace(d.reference, curve_traffic_clearance=0.0, curve_along_horizon=False)
            if conventional
            else d.reference
        )
        assert preset(name).reference.curve_a_lat == 0.0
        # the DSL's plan check with the guard's memory of the last force (SAFE_PLAN_CHECK), but the conventional
        # formulation's has no a_lat guard (its a_lat rows hold the bound)
        assert preset(name + "_safe").plan_check == (
            replace(d.plan_check, a_lat_guard=False) if conventional else SAFE_PLAN_CHECK
        )
        assert replace(d.plan_check, brake_memory=True, drive_rise=SAFE_PLAN_CHECK.drive_rise) == SAFE_PLAN_CHECK
        assert not preset(name).plan_check.a_lat_guard
        assert preset(name + "_ipm_safe").qp.backend == "ipm"
    with pytest.raises(ProblemError, match="unknown"):
        preset("truck_lifted_ellipse_safe_ipm")  # the profile comes last
    with pytest.raises(ProblemError, match="unknown"):
        preset("truck_lifted_ellipse_safe_safe")


@pytest.mark.parametrize("bad, field", [(dict(shape="round"), "obstacles.shape")])
def test_bad_profile_fields_are_named(bad, field):
    with pytest.raises(ProblemError, match=field):
        Ellipse(**bad)
    with pytest.raises(ProblemError, match=r"obstacles.radius"):
        CoveringCircles(3, radius="tight")
    with pytest.raises(ProblemError, match=r"obstacles.anchor.*\[0, 1\]"):
        SeparatingHyperplane(anchor=-1e-3)
    with pytest.raises(ProblemError, match=r"plan_check.react_stages.*\[0, 500\]"):
        PlanCheck(react_stages=-1)


def test_sat_clearance_is_minus_the_judges_overlap():
    """The plan check's CasADi geometry against the campaign's judge (numpy, edges from corners), random poses."""
    import casadi as ca

    a_s, b_s = ca.SX.sym("a", 3), ca.SX.sym("b", 3)
    f = ca.Function(
        "c",
        [a_s, b_s],
        [
            obs.sat_clearance(
                obs.chassis_shape(a_s[0], a_s[1], a_s[2], CAR), obs.chassis_shape(b_s[0], b_s[1], b_s[2], TRUCK)
            )
        ],
    )
    rng = np.random.default_rng(7)
    n_overlap = 0
    for _ in range(2000):
        a = rng.uniform([-20, -6, -math.pi], [20, 6, math.pi])
        b = rng.uniform([-10, -3, -math.pi], [10, 3, math.pi])
        judge = sat_overlap(
            chassis_corners(*a, CAR.l, CAR.l_r_ch, CAR.l_f_ch, CAR.w_ch),
            chassis_corners(*b, TRUCK.l, TRUCK.l_r_ch, TRUCK.l_f_ch, TRUCK.w_ch),
        )
        assert float(f(a, b)) == pytest.approx(-judge, abs=1e-9)
        n_overlap += judge > 0
    assert 100 < n_overlap < 1900  # both signs exercised


def test_responsibility_rule_on_hand_made_contacts():
    from fcgen.sim.collision_kind import behind_rear, responsible

    kept = np.full(11, 2.0)  # a Frenet n over the last second: the lane kept
    moved = np.linspace(0.0, 2.0, 11)  # changed its lane by 2 m
    ego_c, east = np.array([0.0, 0.0]), 0.0
    v_ego = np.array([20.0, 0.0])

    def who(opp_c, opp_v, ego_n, opp_n=kept):
        rear = behind_rear(ego_c, opp_c, math.atan2(opp_v[1], opp_v[0]), 2.0)  # a car: 4 m long
        return responsible(ego_c, east, v_ego, opp_c, opp_v, ego_n, opp_n_before=opp_n, rear=rear)

    # a faster opponent behind the ego: it ran into the ego's rear, whatever the ego's lane
    assert who(np.array([-4.0, 0.5]), np.array([25.0, 0.0]), moved) == "opponent_from_behind"
    # a slower opponent ahead in its lane, the ego's front at its rear: the ego ran into it, lane kept or not
    assert who(np.array([4.0, 0.0]), np.array([15.0, 0.0]), moved) == "ego_into_opponent"
    assert who(np.array([4.0, 0.0]), np.array([15.0, 0.0]), kept) == "ego_into_opponent"
    # the same contact with the opponent cutting in (its n moved) and the ego in its lane: the opponent's
    assert who(np.array([4.0, 0.0]), np.array([15.0, 0.0]), kept, moved) == "opponent_from_side"
    # beside the ego (the ego's centre ahead of its rear edge), the ego kept its lane: the opponent came into it
    assert who(np.array([1.0, 2.5]), np.array([15.0, -1.0]), kept) == "opponent_from_side"
    # the same contact after the ego changed lanes: the ego's
    assert who(np.array([1.0, 2.5]), np.array([15.0, -1.0]), moved) == "ego_into_opponent"


def _converged_slacks(pb, gap: float, offset: float):
    """Full SQP (to a 1e-7 step) of ``pb`` with the ego at 20 m/s on a straight road and a car standing ``gap`` m
    ahead, ``offset`` m to the left: the largest obstacle slack, the largest a_lat slack (m/s^2)."""
    road = straight_road(length=(pb.road.samples - 1) * pb.road.ds, ds=pb.road.ds, s0=-20.0)
    opp = np.zeros((pb.horizon.N + 1, pb.opponents.count, 3))
    opp[..., 0], opp[..., 1] = -1000.0, 500.0  # the others far away
    opp[:, 0, 0], opp[:, 0, 1] = 20.0 + gap, offset  # the ego's s = 0 is x = 20
    sv = RtiSolver(build_ocp(pb))
    sv.set_road(road)
    sv.set_opponents(opp)
    assert sv.solve_converged(np.array([0.0, 0.0, 0.0, 20.0, 0.0]), max_sqp=60, tol=1e-7) < 60
    sl = sv.slacks()
    return float(sl[:, 1:].max()), float(sl[:, 0].max())


def test_where_the_hard_problem_has_no_solution_the_a_lat_row_gives_way_not_the_obstacle_row():
    """A car standing 15 m ahead, 1 m to the left of the ego's line, the ego at 20 m/s: it cannot stop short of it
    (20^2 / (2 F_d_max / m) = 23 m) and with |a_lat| held at its bound (a_lat L1 1e11) the converged plan keeps an
    obstacle slack: the hard problem has no solution. With the safe weights the plan keeps the obstacle row exactly
    and exceeds the a_lat bound instead; at obstacle / a_lat = 100 (1e8 / 1e6, the weights before commit 70450cc) the
    row's slack is cheaper than the swerve that removes it (as in truck lifted HP seed 417's contact): it is kept,
    0.04 here."""
    base = preset("car_lifted_ellipse_ipm_safe").with_(horizon=Horizon(N=20))
    assert 20.0**2 / (2 * base.bounds.F_d_max / base.ego.m) > 15.0 + base.ego.l_ch
    obstacle, a_lat = _converged_slacks(base.with_(soft=replace(base.soft, a_lat_l1=1e11)), 15.0, 1.0)
    assert obstacle > 0.1 and a_lat < 1e-6  # a_lat held: the obstacle row must give
    obstacle, a_lat = _converged_slacks(base, 15.0, 1.0)
    assert obstacle < 1e-6 and a_lat > 1.0  # the safe weights: the obstacle row holds
    obstacle, a_lat = _converged_slacks(base.with_(soft=replace(base.soft, obstacle_l1=1e8)), 15.0, 1.0)
    assert obstacle > 0.01 and a_lat > 1.0  # ratio 100: the obstacle row gives a little
