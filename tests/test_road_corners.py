"""The road band on the chassis' corners (``Bounds(road_bound="corners")``): the corners' offsets by hand and by the
chassis rectangle, the rows' Jacobians by finite differences, the rows taking the road's band, and a closed loop in
which the rear axle's bound lets the front corner cross the edge and the corners' bound does not."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from fcgen import obstacles as obs
from fcgen.commonroad.band import SolverBand
from fcgen.dsl import Bounds, DirectElimination, Lifted, ProblemError, Vehicle
from fcgen.models import CORNERS, corner_n
from fcgen.ocp import build_ocp
from fcgen.presets import preset
from fcgen.qp import build_layout
from fcgen.reference import RtiSolver
from fcgen.road import Road
from fcgen.road_rows import BAND_SCALE, CORNER_ROWS
from fcgen.sim.closedloop import Plant

CAR = Vehicle()  # wheelbase 3.4 m, chassis 2.0 + 2.0 m about its centre (1.7 m ahead of the rear axle), 1.9 m wide


def _corners(pb):
    return pb.with_(bounds=dataclasses.replace(pb.bounds, road_bound="corners"))


def test_the_option_is_checked():
    with pytest.raises(ProblemError, match=r"bounds.road_bound = 'front' is invalid: allowed 'rear_axle' or 'corners'"):
        Bounds(road_bound="front")
    assert Bounds().road_bound == "rear_axle"
    assert preset("car_lifted_ellipse").bounds.road_bound == "rear_axle"


def test_the_front_left_corner_by_hand():
    """Straight road, rear axle at n = 0.4, heading 10 degrees: the front of the chassis is 1.7 + 2.0 = 3.7 m ahead
    of the rear axle, its rear 1.7 - 2.0 = -0.3 m; front left n = 0.4 + 3.7 sin 10 + 0.95 cos 10 = 1.978065."""
    a = math.radians(10.0)
    c = dict(zip(CORNERS, [float(v) for v in corner_n(0.4, a, CAR)], strict=True))
    assert c["front_left"] == pytest.approx(0.4 + 0.642498 + 0.935567, abs=1e-6)
    assert c["front_right"] == pytest.approx(0.4 + 0.642498 - 0.935567, abs=1e-6)
    assert c["rear_left"] == pytest.approx(0.4 - 0.052094 + 0.935567, abs=1e-6)
    assert c["rear_right"] == pytest.approx(0.4 - 0.052094 - 0.935567, abs=1e-6)


@pytest.mark.parametrize("alpha", [-0.3, -0.05, 0.0, 0.12, 0.4])
def test_the_corners_are_the_chassis_rectangles(alpha):
    """On a straight road along x, n is y: the four offsets are the y of the chassis rectangle's corners
    (``obstacles.chassis_shape``, a second construction)."""
    sh = obs.chassis_shape(0.0, 0.7, alpha, CAR)
    ys = sorted(sh.cy + sx * sh.L * math.sin(alpha) + sy * sh.W * math.cos(alpha) for sx in (-1, 1) for sy in (-1, 1))
    assert sorted(float(v) for v in corner_n(0.7, alpha, CAR)) == pytest.approx(ys, abs=1e-12)


def _projected_corners(road: Road, s0: float, n0: float, alpha: float) -> list[float]:
    """The n of the chassis rectangle's corners (``CORNERS``' order) for a rear axle at (s0, n0, alpha), projected
    onto ``road`` (``Road.to_frenet``): the second construction the corners' offsets are checked against."""
    x, y, phi = road.to_cartesian(np.array([s0]), np.array([n0]), np.array([alpha]))
    sh = obs.chassis_shape(float(x[0]), float(y[0]), float(phi[0]), CAR)
    c, sn = math.cos(sh.angle), math.sin(sh.angle)
    got = []
    for sx, sy in ((1, 1), (-1, 1), (1, -1), (-1, -1)):
        px, py = sh.cx + sx * sh.L * c - sy * sh.W * sn, sh.cy + sx * sh.L * sn + sy * sh.W * c
        got.append(float(road.to_frenet(np.array([px]), np.array([py]), np.array([0.0]), np.array([s0]))[1][0]))
    return got


@pytest.mark.parametrize("kappa", [-0.02, 0.01])
@pytest.mark.parametrize("alpha", [-0.25, 0.1])
def test_the_corners_on_a_bend(kappa, alpha):
    """On a circular road (radius 50 or 100 m) the offsets match the corners of the chassis rectangle projected onto
    the road (``Road.to_frenet``) within what the second-order distance leaves (0.5 mm)."""
    road = Road.from_curvature(np.full(201, kappa), 1.0)
    s0, n0 = 60.0, 0.8
    got = _projected_corners(road, s0, n0, alpha)
    want = [float(v) for v in corner_n(n0, alpha, CAR, kappa)]
    np.testing.assert_allclose(want, got, atol=5e-4)
    flat = [float(v) for v in corner_n(n0, alpha, CAR)]
    assert max(abs(a - b) for a, b in zip(flat, got, strict=True)) > 0.02  # the curvature term matters here


@pytest.mark.parametrize("s0, n0, alpha", [(45.0, 0.8, 0.1), (50.0, -0.5, -0.2), (38.0, 0.3, 0.2)])
def test_the_corners_on_a_clothoid(s0, n0, alpha):
    """A clothoid (curvature -0.002 (s - 40) per metre: a left bend turning into a right one at s = 40 m): with the
    curvature ahead (``kappa_at``, Simpson's over each corner's half length) the offsets match the chassis
    rectangle's corners projected onto the road within 1.5 mm; the curvature at the rear axle alone leaves 1.5 cm
    and more."""
    s = np.arange(0.0, 201.0)
    road = Road.from_curvature(-0.002 * (s - 40.0), 1.0)
    got = _projected_corners(road, s0, n0, alpha)
    k0 = float(road.eval(s0)[0])
    ahead = [float(v) for v in corner_n(n0, alpha, CAR, k0, lambda d: float(road.eval(s0 + d)[0]))]
    np.testing.assert_allclose(ahead, got, atol=1.5e-3)
    at_rear = [float(v) for v in corner_n(n0, alpha, CAR, k0)]
    assert max(abs(a - b) for a, b in zip(at_rear, got, strict=True)) > 0.015


@pytest.mark.parametrize(
    "name", ["car_lifted_ellipse_ipm_safe", "car_direct_elimination_ellipse", "car_conventional_ellipse"]
)
def test_the_rows_and_their_jacobian(name):
    """Every formulation: the middle stage has the four corner rows (and no box row on n), their values are the
    corners' n / BAND_SCALE on a bend of radius 50 m, their Jacobian columns (scaled variables) match central
    differences."""
    pb = _corners(preset(name))
    ocp = build_ocp(pb)
    st = ocp.middle
    assert "bound_n" not in st.row_names and "bound_n" in build_ocp(preset(name)).middle.row_names
    rows = [st.row_names.index(r) for r in CORNER_ROWS]
    rng = np.random.default_rng(3)
    w = rng.normal(size=st.nw) * 0.1
    w[0], w[1], w[2], w[3] = 30.0, 0.8, 0.15, 12.0
    xn = np.zeros(ocp.nx)
    road = Road.from_curvature(np.full(200, -0.02), pb.road.ds)
    p = np.zeros(ocp.np_stage)
    p[ocp.p_road] = ocp.road_params.pack(road, int(30.0 / pb.road.ds) - 1)
    g, J, _ = (np.array(v) for v in st.fun(w, xn, p))
    want = [float(v) for v in corner_n(w[1], w[2], pb.ego, -0.02)]
    np.testing.assert_allclose(g.ravel()[rows], np.array(want) / BAND_SCALE, atol=1e-12)
    D = np.r_[st.D, np.ones(ocp.nx)]
    h = 1e-6
    for i in range(st.nw):
        e = np.zeros(st.nw)
        e[i] = h * st.D[i]
        gp = np.array(st.fun(w + e, xn, p)[0]).ravel()
        gm = np.array(st.fun(w - e, xn, p)[0]).ravel()
        np.testing.assert_allclose(J[rows, i], (gp[rows] - gm[rows]) / (2 * h), atol=1e-7, err_msg=f"column {i}")
    assert D.shape[0] == J.shape[1]


def test_the_corner_rows_take_the_band():
    """The layout: per stage 1..N the left corners take the band's upper edge, the right ones its lower edge; the
    reference's bounds are then band / BAND_SCALE - g, the corner's n within the road's edges."""
    pb = _corners(preset("car_lifted_ellipse_ipm_safe"))
    lay = build_layout(build_ocp(pb))
    names = [lay.row_names[r] for r, _, _ in lay.band_rows]
    sides = {nm.split("[")[0]: int(sd) for nm, (_, _, sd) in zip(names, lay.band_rows, strict=True)}
    assert sides == {"road_front_left": 1, "road_rear_left": 1, "road_front_right": 0, "road_rear_right": 0}
    assert len(lay.band_rows) == 4 * pb.horizon.N
    ahead = {nm.split("[")[0]: float(d) for nm, d in zip(names, lay.band_ds, strict=True)}
    assert ahead == pytest.approx(
        {"road_front_left": 3.7, "road_rear_left": -0.3, "road_front_right": 3.7, "road_rear_right": -0.3}
    )  # the chassis' front and rear ahead of the rear axle


def test_each_corner_takes_the_band_at_its_own_s(tmp_path):
    """A band narrowing along the road (upper edge 4 - s / 100, lower edge its negative): each corner row's upper or
    lower bound in the reference's QP is the band at the stage's s plus the corner's position ahead of the rear axle
    (3.7 m for the front, -0.3 m for the rear), so the front corners meet the narrower band; the C builds the same
    bounds (its BAND_DS table)."""
    from fcgen.build import build
    from fcgen.codegen.generate import generate
    from fcgen.csolver import CSolver

    pb = _corners(preset("car_lifted_ellipse_ipm_safe"))
    ocp = build_ocp(pb)
    lay = build_layout(ocp)
    base = Road.from_curvature(np.zeros(150), pb.road.ds)  # 300 m
    edge = 4.0 - base.s / 100.0
    road = Road(base.s0, base.ds, base.kappa, base.phi, base.gx, base.gy, -edge, edge).window(10.0, pb.road.samples)
    far = np.tile([-5000.0, -5000.0, 0.0], (ocp.N + 1, pb.opponents.count, 1))
    x0 = np.array([20.0, 0.0, 0.0, 10.0, 0.0])
    sv = RtiSolver(ocp)
    sv.set_road(road)
    sv.set_opponents(far)
    sv.set_state(x0)
    sv.prepare()
    for (row, k, side), d in zip(lay.band_rows, lay.band_ds, strict=True):
        s_k = float(sv.w_prep[lay.s_vars[k]])
        want = (4.0 - (s_k + d) / 100.0) * (1 if side == 1 else -1)
        got = (sv.u if side == 1 else sv.l)[row] + sv.g[row]
        assert got * BAND_SCALE == pytest.approx(want, abs=1e-12), lay.row_names[row]
    cs = CSolver(build(generate(pb.with_(name="corners"), tmp_path / "g").out_dir))
    assert cs.init() == 0 and cs.set_road(road) == 0 and cs.set_opponents(far) == 0
    assert cs.set_state(x0) == 0 and cs.prepare() == 0
    qp = cs.get_qp()
    np.testing.assert_allclose(qp["l"], sv.l, rtol=0, atol=1e-12)
    np.testing.assert_allclose(qp["u"], sv.u, rtol=0, atol=1e-12)


def _drive_left(pb, edge: float, rear_inset: float, samples: int = 50) -> np.ndarray:
    """Closed loop (Python reference, fcgen's plant) from s = 20 m at 10 m/s, the road straight to s = 30 m, then a
    right bend of radius 40 m for 60 m: its left edge (the outer one) at ``edge``, the rear axle's band
    ``rear_inset`` inside it, the lateral reference 4 m beyond it. Per sample the front left corner's n on the road
    (``Road.to_frenet`` of the chassis rectangle's corner)."""
    ocp = build_ocp(pb)
    ds = pb.road.ds
    s = np.arange(0.0, 1600.0 + ds, ds)
    base = Road.from_curvature(np.where((s > 30.0) & (s < 90.0), -1.0 / 40.0, 0.0), ds)
    hi = np.full(base.size, edge - rear_inset)
    road = Road(base.s0, base.ds, base.kappa, base.phi, base.gx, base.gy, -hi, hi)
    sv = RtiSolver(ocp)
    sv.set_reference(10.0, edge + 4.0)
    far = np.tile([-5000.0, -5000.0, 0.0], (ocp.N + 1, pb.opponents.count, 1))
    plant = Plant(pb, pb.road.samples)
    x = np.array([20.0, 0.0, 0.0, 10.0, 0.0])
    front_left = []
    for _ in range(samples):
        sv.set_road(road.window(x[0] - 10.0, pb.road.samples))
        sv.set_opponents(far)
        if sv.w is None:
            sv.set_state(x)
        sv.prepare()
        sv.set_state(x)
        x = plant.step(x, sv.feedback(), road)
        px, py, phi = (float(v[0]) for v in road.to_cartesian(np.array([x[0]]), np.array([x[1]]), np.array([x[2]])))
        sh = obs.chassis_shape(px, py, phi, pb.ego)
        cx = sh.cx + sh.L * math.cos(phi) - sh.W * math.sin(phi)
        cy = sh.cy + sh.L * math.sin(phi) + sh.W * math.cos(phi)
        front_left.append(
            float(road.to_frenet(np.array([cx]), np.array([cy]), np.array([0.0]), np.array([x[0]]))[1][0])
        )
    return np.array(front_left)


@pytest.mark.parametrize("form", [Lifted(), DirectElimination()])
def test_the_corners_stay_on_the_road_where_the_rear_axle_bound_lets_them_cross(form):
    """Left edge at n = 2.5 on a right bend of radius 40 m, the reference beyond it: the rear axle bounded at
    2.5 - 0.95 (half the width: the chassis straight on a straight road) lets the front left corner cross the edge
    (by about kappa 3.7^2 / 2 = 0.17 m along the bend); the corners bounded at 2.5 keep it on the road (within 1 cm:
    the rows are linearised at the previous plan)."""
    pb = preset("car_lifted_ellipse_ipm_safe").with_(formulation=form)
    rear = _drive_left(pb, 2.5, CAR.w_ch / 2)
    corners = _drive_left(_corners(pb), 2.5, 0.0)
    assert rear.max() > 2.5 + 0.1
    assert corners.max() <= 2.5 + 0.01
    assert corners.max() > 2.5 - 0.1  # it does drive to the edge


@pytest.mark.parametrize("name", ["car_lifted_ellipse_ipm_safe", "car_conventional_ellipse_safe"])
def test_the_c_computes_the_corner_rows_as_the_reference(tmp_path, name):
    """``fcgen verify`` on a corners problem (the IPM and OSQP): the C's rows, Jacobians, QP and closed loop are the
    reference's within verify's tolerances."""
    from fcgen.codegen.generate import generate
    from fcgen.verify import verify

    pb = _corners(preset(name))
    generate(pb.with_(name="corners"), tmp_path / "g")
    rep = verify(tmp_path / "g", samples=40)
    assert rep.passed, rep.format()
    assert any(nm.startswith("road_front_left") for nm in build_layout(build_ocp(pb)).row_names)


def test_simulate_refuses_a_solver_folder_of_the_other_road_bound():
    """``simulate --road-bound corners`` with a solver folder generated for the rear axle: one line naming both."""
    from pathlib import Path

    from click.testing import CliRunner

    from fcgen.cli import main

    d = Path(__file__).resolve().parents[1] / "generated" / "truck_lifted_ellipse_ipm"
    args = ["simulate", "--controller", "c", "--solver-dir", str(d), "--problem", str(d / "problem.py")]
    res = CliRunner().invoke(main, [*args, "--road-bound", "corners", "--samples", "2"])
    assert res.exit_code == 1, res.output
    assert "road_bound = 'rear_axle'" in res.output and "'corners'" in res.output


def test_the_corners_way_back_by_hand():
    """Band [-1, 1] on s = 80..160 m (0.5 m), the upper corner at 0.98 moving out 0.1 m per metre at 10 m/s: over
    CORNER_STEP = 0.1 s (1 m) it would reach 1.08, so the upper edge moves to that path without BACK_ROOM: 1.08 at
    s = 101, returning to 1 over max(10, 3 x 10) = 30 m as 3u^2 - 2u^3 (1.08 - 0.08 h(1/30) at s = 101); at and
    behind s0 the band, which holds the corner, stays. At 0.5 (its path 0.6) nothing moves; a corner 0.05 beyond the
    edge and not moving gets the edge where it is (1.05 at s0). After a sample without a solution, the rear axle's
    rule (BACK_ROOM beyond the path at the heading)."""
    from fcgen.commonroad.band import BACK_ROOM, CORNER_STEP, way_back

    assert CORNER_STEP == 0.1
    s = np.arange(80.0, 160.5, 0.5)
    lo, hi = np.full(len(s), -1.0), np.full(len(s), 1.0)
    _, hi2, moved = way_back(s, lo, hi, 100.0, (-0.5, 0.98), 0.0, 10.0, False, (0.0, 0.1))
    assert moved
    at = dict(zip(s.tolist(), hi2.tolist(), strict=True))
    u = 1.0 / 30.0
    assert at[101.0] == pytest.approx(1.08 - 0.08 * (3 * u * u - 2 * u**3))
    assert at[100.0] == at[80.0] == 1.0 and at[130.0] == 1.0
    assert not way_back(s, lo, hi, 100.0, (-0.5, 0.5), 0.0, 10.0, False, (0.0, 0.1))[2]
    _, hi3, moved = way_back(s, lo, hi, 100.0, (-0.5, 1.05), 0.0, 10.0, False, (0.0, 0.0))
    assert moved and hi3[s == 100.0][0] == pytest.approx(1.05)
    _, hi4, _ = way_back(s, lo, hi, 100.0, (-0.5, 1.05), 0.0, 10.0, True, (0.0, 0.0))
    assert hi4[s == 100.0][0] == pytest.approx(1.05 + BACK_ROOM)


def test_the_corners_way_back_holds_the_front_corner():
    """Band [-1, 1] on a straight road, the rear axle at s = 100 m, n = 0.2, straight: the left corners at
    0.2 + 0.95 = 1.15 lie beyond the upper edge, so the edge moves out to them up to the front corner's s
    (100 + 3.7 m, where its row takes the band) and returns to the band beyond it."""
    road = Road.from_curvature(np.zeros(301), 1.0)
    band = SolverBand("road_back", [], road, 0.15, (-10.0, 10.0), 2.0, 0.95, 1.7, True)
    win = road.window(80.0, 120)
    win = Road(win.s0, win.ds, win.kappa, win.phi, win.gx, win.gy, np.full(120, -1.0), np.full(120, 1.0))
    assert band.set(win, np.array([100.0, 0.2, 0.0, 10.0, 0.0]), 0.0)
    hi = dict(zip(win.s.tolist(), win.n_max.tolist(), strict=True))
    assert hi[100.0] == hi[103.0] == pytest.approx(1.15)
    assert 1.0 < hi[110.0] < 1.15 and hi[150.0] == 1.0


def test_the_corners_motion_on_a_straight_road():
    """Heading 0.1 rad, steering angle 0, 10 m/s on a straight road: the heading does not change, so the outermost
    corner on either side moves sin(0.1) towards +n per metre along the road (the signed change of n: towards the
    upper edge, away from the lower one)."""
    road = Road.from_curvature(np.zeros(301), 1.0)
    band = SolverBand("lanes", [], road, 0.15, (-10.0, 10.0), 2.0, 0.95, 1.7, True)
    (n_lo, n_hi), (d_lo, d_hi) = band.corner_motion(np.array([50.0, 0.4, 0.1, 10.0, 0.0]))
    c = [float(v) for v in corner_n(0.4, 0.1, CAR)]
    assert (n_lo, n_hi) == pytest.approx((min(c[2:]), max(c[:2])))
    assert d_hi == pytest.approx(math.sin(0.1), rel=1e-9)
    assert d_lo == pytest.approx(math.sin(0.1), rel=1e-9)
