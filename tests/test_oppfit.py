"""The conventional solver's own opponent fit (fcgen.oppfit): Python reference and generated C against the
independent fit of fcgen.obstacles (Newton from a heading guess to 1e-12 on the whole road, numpy), and its
behaviour off the road."""

from __future__ import annotations

import math
import shutil

import numpy as np
import pytest

from fcgen import obstacles as obs
from fcgen.dsl import Conventional, Horizon, Opponents, ProblemError
from fcgen.ocp import build_ocp
from fcgen.oppfit import OppFitter, build_oppfit, neutral
from fcgen.presets import CAR, TRUCK, paper_problem
from fcgen.reference import RtiSolver, SolverError
from fcgen.road import Road, random_road

CIRCLE = Road.from_curvature(np.full(56, 0.05), 2.0, s0=-30.0)  # radius 20 m, left turn; 110 m: not a lap
WAVY = random_road(5, length=400.0, s0=-50.0)  # |kappa| <= 0.05, changing sign
STRAIGHT = Road.from_curvature(np.zeros(141), 2.0, s0=-60.0)


def problem(n_opp=2, N=10, **conv):
    return paper_problem("truck", "conventional", "ellipse", horizon=Horizon(N=N)).with_(
        opponents=Opponents(n_opp, TRUCK), formulation=Conventional(**conv)
    )


def poses_on(road: Road, frenet) -> np.ndarray:
    """Rear-axle Cartesian poses of (s, n, alpha) triples: shape (..., 3)."""
    f = np.asarray(frenet, dtype=float)
    x, y, phi = road.to_cartesian(f[..., 0], f[..., 1], f[..., 2])
    return np.stack([x, y, phi], axis=-1)


def independent_fit(road: Road, frenet, pb) -> np.ndarray:
    """obstacles.fit_frenet_shape with the scenario's exact s as its guess."""
    pose = poses_on(road, frenet)
    return obs.fit_frenet_shape(
        road,
        pose,
        pb.opponents.vehicle,
        pb.ego,
        pb.formulation.margin,
        s_guess=float(frenet[0]),
        points_per_metre=pb.formulation.points_per_metre,
    )


CASES = [
    (CIRCLE, (20.0, 5.0, 0.0)),
    (CIRCLE, (20.0, -5.0, 0.0)),
    (CIRCLE, (40.0, 0.0, 0.3)),
    (WAVY, (30.0, 4.0, 0.0)),
    (WAVY, (95.0, -3.0, -0.2)),
    (WAVY, (160.0, 0.5, 0.1)),
    (STRAIGHT, (10.0, 3.0, 0.0)),
]


@pytest.mark.parametrize("ppm, margin", [(4.0, 0.0), (1.0, 0.25)])
def test_python_fit_equals_the_independent_fit(ppm, margin):
    pb = problem(n_opp=1, points_per_metre=ppm, margin=margin)
    fitter = OppFitter(build_oppfit(pb), len(CASES), 1)
    for road in (CIRCLE, WAVY, STRAIGHT):
        sel = [c for c in CASES if c[0] is road]
        fr = np.array([c[1] for c in sel] + [sel[0][1]] * (len(CASES) - len(sel)))
        out, outside, singular = fitter(road, poses_on(road, fr)[:, None, :])
        assert outside == 0 and singular == []
        for k, (_, f) in enumerate(sel):
            np.testing.assert_allclose(out[k], independent_fit(road, f, pb), rtol=0, atol=1e-9)
    # on the straight road the box is the rectangle plus the margin (by hand: 13 + m by 2 + m about the centre)
    assert out[0][:5] == pytest.approx([20.0, 3.0, 0.0, 13.0 + margin, 2.0 + margin], abs=1e-9)
    assert out[0][5] == 1.0


def test_points_per_metre_is_validated():
    with pytest.raises(ProblemError, match=r"formulation.points_per_metre = 0.1 is invalid: allowed \[0.25, 20\]"):
        Conventional(points_per_metre=0.1)


def test_left_out_when_the_road_does_not_cover_it():
    pb = problem(n_opp=1)
    fitter = OppFitter(build_oppfit(pb), 4, 1)
    road = STRAIGHT.window(-60.0, 100)  # s in [-60, 138]
    fr = np.array(
        [
            [20.0, 3.0, 0.0],  # covered
            [125.0, 0.0, 0.0],  # its front (s = 148) is beyond the road's end
            [20.0, 35.0, 0.0],  # beside the band [-10, 10] plus the ego's reach (9.3 m)
            [-55.0, 0.0, 0.0],
        ]
    )  # the ego's reach behind it is before the road's start
    out, outside, singular = fitter(road, poses_on(road, fr)[:, None, :])
    assert outside == 3 and singular == []
    assert out[0][:5] == pytest.approx([30.0, 3.0, 0.0, 13.0, 2.0], abs=1e-9)
    for k in (1, 2, 3):
        np.testing.assert_array_equal(out[k], neutral(road.s0))
    assert neutral(road.s0)[0] == road.s0 - 1000.0


BEND60 = Road.from_curvature(np.full(56, 1.0 / 60.0), 2.0, s0=-30.0)  # 110 m of a 60 m radius left bend


def _inside_bend60(off: float) -> np.ndarray:
    """A truck's rear-axle pose `off` m from BEND60's centre of curvature towards its middle sample, heading at it."""
    mid = BEND60.size // 2
    nx, ny = -math.sin(BEND60.phi[mid]), math.cos(BEND60.phi[mid])  # the left normal: to the centre
    cx, cy = BEND60.gx[mid] + 60.0 * nx, BEND60.gy[mid] + 60.0 * ny
    return np.array([cx - off * nx, cy - off * ny, math.atan2(-ny, -nx)])


def test_left_out_when_far_from_the_road_beside_a_bend():
    """An opponent deep inside a bend, far from the road window: its reference point's nearest sample is an inner
    one, but no point of it can come within the band plus the ego's reach, so it is left out, not mapped (its
    points' searches would land on the wrong part of the road: ERR_OPP_FRENET before). One nearer is still mapped
    or refused, never left out."""
    pb = problem(n_opp=1)
    fit = build_oppfit(pb)
    assert fit.far == pytest.approx(10.0 + pb.ego.l + pb.ego.l_ch + pb.ego.w_ch + math.hypot(13.0, 2.0))
    fitter = OppFitter(fit, 1, 1)
    P = np.array(fitter._points(_inside_bend60(10.0), fit.shape0)[0])  # (2, npt): the mapped points
    gap = np.min(np.hypot(BEND60.gx[None, :] - P[0][:, None], BEND60.gy[None, :] - P[1][:, None]))
    assert gap > 10.0 + fit.reach  # independent: out of the ego's reach
    for off in (5.0, 10.0, 15.0):  # centre 40-55 m from the road
        out, outside, singular = fitter(BEND60, _inside_bend60(off)[None, None, :])
        assert (outside, singular) == (1, [])
        np.testing.assert_array_equal(out[0], neutral(BEND60.s0))
    # the chassis centre 30 m from the road (its front 17 m): within `far`, so not left out
    _, outside, _ = fitter(BEND60, _inside_bend60(20.0)[None, None, :])
    assert outside == 0


def test_singular_frenet_frame_fails_the_prepare_phase():
    # a car next to the inside of a 12.5 m bend: the ego beside it would be stretched by 1 / (1 - n kappa) with
    # n kappa = (4 + 0.95 + 9.3) * 0.08 > 0.9
    pb = paper_problem("car", "conventional", "ellipse", horizon=Horizon(N=10)).with_(opponents=Opponents(1, CAR))
    road = Road.from_curvature(np.full(34, 0.08), 2.0, s0=-10.0)  # 66 m of a 78.5 m circle
    sv = RtiSolver(build_ocp(pb))
    sv.set_road(road)
    sv.set_opponents(np.tile(poses_on(road, (25.0, 4.0, 0.0)), (11, 1, 1)))
    sv.set_state(np.array([0.0, 0.0, 0.0, 15.0, 0.0]))
    with pytest.raises(SolverError, match="ERR_OPP_FRENET: opponent 0 at stage 0 cannot be mapped"):
        sv.prepare()
    sv.set_opponents(np.tile(poses_on(road, (25.0, -4.0, 0.0)), (11, 1, 1)))  # outside of the bend: fine
    sv.prepare()
    assert sv.status.opp_outside == 0


needs_cc = pytest.mark.skipif(any(shutil.which(t) is None for t in ("gcc", "make")), reason="needs gcc and make")


@pytest.fixture(scope="module")
def c_solver(tmp_path_factory):
    from fcgen.build import build
    from fcgen.codegen.generate import generate
    from fcgen.csolver import CSolver

    pb = problem(n_opp=2, N=10).with_(name="conv_fit")
    out = tmp_path_factory.mktemp("oppfit") / "conv_fit"
    generate(pb, out)
    return pb, CSolver(build(out, verify=True))


@needs_cc
@pytest.mark.parametrize("road", [CIRCLE, WAVY], ids=["circle", "wavy"])
def test_c_fit_equals_python_and_the_independent_fit(c_solver, road):
    pb, cs = c_solver
    ocp = build_ocp(pb)
    N = pb.horizon.N
    # two opponents per stage moving along the road, one turning; the last stage of the second is off the road
    fr = np.zeros((N + 1, 2, 3))
    for k in range(N + 1):
        fr[k, 0] = (20.0 + 1.5 * k, 4.0 - 0.8 * k, 0.0)
        fr[k, 1] = (30.0 + 1.0 * k, -2.0, 0.25 * math.sin(k))
    win = road.window(-30.0, min(road.size, pb.road.samples))
    fr[N, 1] = (win.s_end - 10.0, 0.0, 0.0)
    poses = poses_on(win, fr)
    x0 = np.array([0.0, 0.0, 0.0, 15.0, 0.0])
    sv = RtiSolver(ocp)
    sv.set_road(win)
    sv.set_opponents(poses)
    sv.set_state(x0)
    sv.prepare()
    assert cs.init() == 0
    assert cs.set_road(win) == 0 and cs.set_opponents(poses) == 0 and cs.set_state(x0) == 0
    assert cs.prepare() == 0
    c_par, py_par = cs.get_opp_params(), sv.P[:, ocp.p_opp]
    np.testing.assert_array_equal(c_par, py_par)  # bit for bit, every fitted parameter
    assert cs.status().opp_outside == sv.status.opp_outside == 1
    opp = c_par.reshape(N + 1, 2, 6)
    for k in range(N + 1):
        for j in range(2):
            if (k, j) == (N, 1):
                np.testing.assert_array_equal(opp[k, j], neutral(win.s0))
                continue
            np.testing.assert_allclose(opp[k, j], independent_fit(win, fr[k, j], pb), rtol=0, atol=1e-9)


def _c_and_python(c_solver, road, fr):
    """The C fit's and the Python reference's parameters (N+1, 2 * 6) and left-out counts at Frenet poses fr."""
    return _c_and_python_poses(c_solver, road, fr, {})


def _c_and_python_poses(c_solver, road, fr, cartesian):
    """As _c_and_python; opponent j's pose at every stage replaced by the Cartesian pose cartesian[j]."""
    pb, cs = c_solver
    ocp = build_ocp(pb)
    poses = poses_on(road, fr)
    for j, pose in cartesian.items():
        poses[:, j] = pose
    x0 = np.array([0.0, 0.0, 0.0, 15.0, 0.0])
    sv = RtiSolver(ocp)
    sv.set_road(road)
    sv.set_opponents(poses)
    sv.set_state(x0)
    sv.prepare()
    assert cs.init() == 0
    assert cs.set_road(road) == 0 and cs.set_opponents(poses) == 0 and cs.set_state(x0) == 0
    assert cs.prepare() == 0
    return cs.get_opp_params(), sv.P[:, ocp.p_opp], cs.status().opp_outside, sv.status.opp_outside


@needs_cc
def test_c_fit_breaks_distance_ties_as_numpy(c_solver):
    """Points halfway between two road samples (the straight road's samples at even x, the truck's edge points at
    integers): the C's walk down a point's window takes the first of the two nearest samples, as numpy's argmin."""
    pb, _ = c_solver
    N = pb.horizon.N
    fr = np.zeros((N + 1, 2, 3))
    fr[:, 0] = (20.0, 3.0, 0.0)
    fr[:, 1] = (45.0, -4.0, 0.0)
    win = STRAIGHT.window(-60.0, pb.road.samples)
    fit = build_oppfit(pb)
    P, _ = OppFitter(fit, 1, 2)._points(poses_on(win, fr[0]).T, np.tile(np.reshape(fit.shape0, (3, 1)), (1, 2)))
    px = np.array(P)[0]
    assert np.count_nonzero((px - win.s0) % (2 * win.ds) == win.ds) > 20  # exactly halfway: ties
    c_par, py_par, c_out, py_out = _c_and_python(c_solver, win, fr)
    np.testing.assert_array_equal(c_par, py_par)
    assert c_out == py_out == 0


@needs_cc
def test_c_fit_on_a_tight_bend_equals_python(c_solver, monkeypatch):
    """A bend of radius 14 m: road evaluations whose phi_gamma is more than ROT_MAX from their segment's first sample
    (libm's cos and sin instead of the rotation) and points too far out for fit_window's unimodality test (the full
    scan of the window); the C equals the Python reference bit for bit."""
    from fcgen import oppfit

    pb, _ = c_solver
    N = pb.horizon.N
    road = Road.from_curvature(np.concatenate([np.zeros(20), np.full(12, 0.07), np.zeros(40)]), 2.0, s0=-30.0)
    far = []
    rot = oppfit.rot_cos_sin

    def counting(phi0, dl, c0, s0):
        far.append(int(np.count_nonzero(np.abs(dl) > oppfit.ROT_MAX)))
        return rot(phi0, dl, c0, s0)

    monkeypatch.setattr(oppfit, "rot_cos_sin", counting)
    fr = np.zeros((N + 1, 2, 3))
    for k in range(N + 1):
        fr[k, 0] = (5.0 + 1.5 * k, -4.0, 0.0)  # the outside of the (left) bend
        fr[k, 1] = (20.0 + 1.0 * k, -7.0, 0.1)
    c_par, py_par, c_out, py_out = _c_and_python(c_solver, road, fr)
    np.testing.assert_array_equal(c_par, py_par)
    assert c_out == py_out == 0
    assert sum(far) > 0


@needs_cc
def test_c_leaves_out_an_opponent_far_beside_a_bend_as_python(c_solver):
    """Opponent 0 deep inside BEND60 at every stage (left out), opponent 1 on the road (fitted): the C prepares
    (no ERR_OPP_FRENET) and equals the Python reference bit for bit."""
    pb, _ = c_solver
    N = pb.horizon.N
    fr = np.zeros((N + 1, 2, 3))
    fr[:, 1] = (30.0, -3.0, 0.0)
    c_par, py_par, c_out, py_out = _c_and_python_poses(c_solver, BEND60, fr, {0: _inside_bend60(10.0)})
    np.testing.assert_array_equal(c_par, py_par)
    assert c_out == py_out == N + 1
    for k in range(N + 1):
        np.testing.assert_array_equal(c_par[k, :6], neutral(BEND60.s0))


@needs_cc
def test_c_singular_and_unset_road_codes(c_solver):
    from fcgen.contract import EXIT_CODES

    pb, cs = c_solver
    N = pb.horizon.N
    assert cs.init() == 0
    x0 = np.array([0.0, 0.0, 0.0, 15.0, 0.0])
    poses = np.tile(poses_on(STRAIGHT, (20.0, 3.0, 0.0)), (N + 1, 2, 1))
    assert cs.set_opponents(poses) == 0 and cs.set_state(x0) == 0
    assert cs.prepare() == EXIT_CODES.index("ERR_ROAD_WINDOW")  # no road yet
    # one good sample first: one opponent fitted, the other beyond the road's end
    good = np.tile(poses_on(STRAIGHT, (20.0, 3.0, 0.0)), (N + 1, 2, 1))
    good[:, 1] = poses_on(STRAIGHT, (200.0, 0.0, 0.0))
    assert cs.set_road(STRAIGHT) == 0 and cs.set_opponents(good) == 0 and cs.prepare() == 0 and cs.feedback() == 0
    tight = Road.from_curvature(np.full(40, 0.07), 2.0, s0=-30.0)  # (4 + 2 + 9.3) * 0.07 > 0.9 inside
    assert cs.set_road(tight) == 0
    assert cs.status().opp_outside == N + 1
    u = cs.u0()
    assert cs.set_opponents(np.tile(poses_on(tight, (10.0, 4.0, 0.0)), (N + 1, 2, 1))) == 0
    assert cs.prepare() == EXIT_CODES.index("ERR_OPP_FRENET")
    st = cs.status()  # a failed prepare changes nothing else
    assert st.exit_code == EXIT_CODES.index("ERR_OPP_FRENET") and st.opp_outside == N + 1
    assert cs.has_guess() and np.array_equal(cs.u0(), u)
    assert cs.feedback() == EXIT_CODES.index("ERR_NOT_PREPARED")
    sv = RtiSolver(build_ocp(pb))
    sv.set_road(tight)
    sv.set_opponents(np.tile(poses_on(tight, (10.0, 4.0, 0.0)), (N + 1, 2, 1)))
    sv.set_state(x0)
    with pytest.raises(SolverError, match="ERR_OPP_FRENET"):
        sv.prepare()


def test_naive_option_uses_the_projected_rear_axle():
    # overapprox="none": the Cartesian rectangle unchanged at the rear axle's Frenet pose, which the solver projects
    pb = problem(n_opp=1, overapprox="none")
    fit = build_oppfit(pb)
    assert fit.npt == 1
    fitter = OppFitter(fit, 3, 1)
    fr = np.array([(30.0, 4.0, 0.0), (95.0, -3.0, -0.2), (160.0, 0.5, 0.1)])
    out, outside, singular = fitter(WAVY, poses_on(WAVY, fr)[:, None, :])
    assert outside == 0 and singular == []
    for k in range(3):
        np.testing.assert_allclose(out[k], obs.naive_frenet_shape(fr[k], TRUCK), rtol=0, atol=1e-9)


def _dense_rectangle_in_frenet(road: Road, frenet, per_m: float = 10.0):
    """Dense points on the truck's true rectangle (boundary and interior) at the Frenet pose, mapped by the
    independent projection (Newton to 1e-12 from a heading guess)."""
    x, y, phi = (float(v) for v in poses_on(road, frenet))
    sh = obs.chassis_shape(x, y, phi, TRUCK)
    c, s = math.cos(phi), math.sin(phi)
    a = np.linspace(-1.0, 1.0, int(2 * sh.L * per_m) + 1)[:, None]
    b = np.linspace(-1.0, 1.0, int(2 * sh.W * per_m) + 1)[None, :]
    px = (sh.cx + a * sh.L * c - b * sh.W * s).ravel()
    py = (sh.cy + a * sh.L * s + b * sh.W * c).ravel()
    guess = frenet[0] + (px - x) * c + (py - y) * s
    ps, pn, _ = road.to_frenet(px, py, 0 * px, s_guess=guess)
    return ps, pn


@pytest.mark.parametrize("frenet", [(20.0, 5.0, 0.0), (20.0, -5.0, 0.0), (25.0, 2.0, 0.3), (15.0, -3.0, -0.3)])
def test_fitted_box_covers_the_true_rectangle_at_one_point_per_metre(frenet):
    """The solver's fit (the preset's 1 point per metre; the C equals it bit for bit) on the |kappa| = 0.05 circle:
    no point of the true rectangle sticks out of the fitted box (nor of the ellipse around it)."""
    pb = problem(n_opp=1)
    assert pb.formulation.points_per_metre == 1.0
    fitter = OppFitter(build_oppfit(pb), 1, 1)
    out, outside, singular = fitter(CIRCLE, poses_on(CIRCLE, np.array([frenet]))[:, None, :])
    assert outside == 0 and singular == []
    box = obs.Shape(*out[0][:5])
    ps, pn = _dense_rectangle_in_frenet(CIRCLE, frenet)
    cb, sb = math.cos(box.angle), math.sin(box.angle)
    e1, e2 = cb * (ps - box.cx) + sb * (pn - box.cy), -sb * (ps - box.cx) + cb * (pn - box.cy)
    excess = np.maximum(np.abs(e1) - box.L, np.abs(e2) - box.W)
    assert np.max(excess) <= 0.0, f"the true rectangle sticks out of the box by {np.max(excess):.2e} m"
    assert np.max(obs.paper_ellipse_h(ps, pn, box, 0.0)) < 0.0


@pytest.mark.parametrize("road", [CIRCLE, WAVY], ids=["circle", "wavy"])
def test_foot_points_reach_the_converged_projection(road):
    """oppfit.map_points (a Halley step from the nearest sample, one road evaluation, Taylor for n) against the
    independent projection (Newton to 1e-12) of the same points: s and n within 2e-11 m."""
    from fcgen.oppfit import SEARCH, map_points

    fit = build_oppfit(problem(n_opp=1))
    lo, hi = road.s0 + 40.0, road.s_end - 40.0
    rng = np.random.default_rng(3)
    fr = np.stack([rng.uniform(lo, hi, 25), rng.uniform(-5, 5, 25), rng.uniform(-0.3, 0.3, 25)], axis=1)
    fitter = OppFitter(fit, len(fr), 1)
    P, d = fitter._points(poses_on(road, fr).T, fit.shape0)
    P = np.array(P).reshape(2, len(fr), fit.npt)
    d = np.array(d).T
    ref = np.argmin(
        (road.gx[None, :] - P[0, :, fit.ref_point, None]) ** 2 + (road.gy[None, :] - P[1, :, fit.ref_point, None]) ** 2,
        axis=1,
    )
    cand = np.clip(
        ref[:, None, None] + np.floor(d / road.ds + 0.5).astype(int)[:, :, None] + np.arange(-SEARCH, SEARCH + 1),
        0,
        road.size - 1,
    )
    dd = (road.gx[cand] - P[0][:, :, None]) ** 2 + (road.gy[cand] - P[1][:, :, None]) ** 2
    ist = np.take_along_axis(cand, np.argmin(dd, axis=2)[:, :, None], axis=2)[:, :, 0]
    fs, fn, _, w0 = map_points(fit, road, P, ist)
    assert np.all((fs >= w0) & (fs <= w0 + 2 * road.ds))
    sp = road.project(P[0].ravel(), P[1].ravel(), fs.ravel()).reshape(fs.shape)
    _, phg, gx, gy, _, _ = road.eval(sp)
    n = -(P[0] - gx) * np.sin(phg) + (P[1] - gy) * np.cos(phg)
    assert np.max(np.abs(fs - sp)) < 2e-11 and np.max(np.abs(fn - n)) < 2e-11
