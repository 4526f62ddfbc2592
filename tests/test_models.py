"""Tests of the vehicle models (fcgen.models, SPEC section 2).

Independent references: the SPEC's equations re-written here in numpy, central finite differences for the
Jacobians, scipy's solve_ivp (rtol 1e-12) for the RK4 step, and the road's own numpy F^-1 for the lifted model.
"""

from __future__ import annotations

import math

import casadi as ca
import numpy as np
import pytest
from scipy.integrate import solve_ivp

from fcgen import models
from fcgen.dsl import Horizon, Vehicle, Wind
from fcgen.ocp import build_ocp
from fcgen.presets import paper_problem
from fcgen.reference import RtiSolver
from fcgen.road import casadi_road, random_road

VEH = Vehicle()
WIND = Wind()


# --- closed-form roads: s -> (kappa, phi_gamma) with phi_gamma' = kappa ----------------------------


def road_const(k0=0.03):
    return (lambda s: (k0 + 0 * s, k0 * s)), (lambda s: (k0, k0 * s))


def road_sine(a=0.04, b=0.02):
    # kappa = a sin(b s), phi_gamma = (a / b) (1 - cos(b s))
    cas = lambda s: (a * ca.sin(b * s), a / b * (1 - ca.cos(b * s)))
    num = lambda s: (a * math.sin(b * s), a / b * (1 - math.cos(b * s)))
    return cas, num


# --- the SPEC's equations in numpy -----------------------------------------------------------------


def vdot_ref(v, phi, F_d, veh=VEH, wind=WIND):
    v_rel = v + wind.v * math.cos(phi - wind.phi)
    return (F_d - veh.c_air * v_rel * abs(v_rel) - veh.c_roll) / veh.m


def cart_ref(x, u, veh=VEH, wind=WIND):
    _, _, phi, v, delta = x
    return np.array(
        [v * math.cos(phi), v * math.sin(phi), v * math.tan(delta) / veh.l, vdot_ref(v, phi, u[0], veh, wind), u[1]]
    )


def frenet_ref(x, u, road, veh=VEH, wind=WIND):
    s, n, alpha, v, delta = x
    kappa, phi_g = road(s)
    sdot = v * math.cos(alpha) / (1 - n * kappa)
    return np.array(
        [
            sdot,
            v * math.sin(alpha),
            v * math.tan(delta) / veh.l - kappa * sdot,
            vdot_ref(v, phi_g + alpha, u[0], veh, wind),
            u[1],
        ]
    )


def lifted_ref(x, u, road, veh=VEH, wind=WIND):
    s, n, alpha, v, delta, _px, _py, phi = x
    kappa, _ = road(s)
    sdot = v * math.cos(alpha) / (1 - n * kappa)
    w = v * math.tan(delta) / veh.l
    return np.array(
        [
            sdot,
            v * math.sin(alpha),
            w - kappa * sdot,
            vdot_ref(v, phi, u[0], veh, wind),
            u[1],
            v * math.cos(phi),
            v * math.sin(phi),
            w,
        ]
    )


def casadi_fun(kind, road, veh=VEH, wind=WIND):
    nx = models.NX[kind]
    x, u = ca.SX.sym("x", nx), ca.SX.sym("u", 2)
    f = models.ode(kind, road, veh, wind)(x, u)
    z = ca.vertcat(x, u)
    return ca.Function("f", [x, u], [f, ca.jacobian(f, z)])


def random_point(kind, rng):
    s = rng.uniform(0, 200)
    n = rng.uniform(-8, 8)
    alpha = rng.uniform(-0.7, 0.7)
    v = rng.uniform(1, 38)
    delta = rng.uniform(-0.28, 0.28)
    phi = rng.uniform(-math.pi, math.pi)
    if kind == "cartesian":
        x = [rng.uniform(-100, 100), rng.uniform(-100, 100), phi, v, delta]
    elif kind == "frenet":
        x = [s, n, alpha, v, delta]
    else:
        x = [s, n, alpha, v, delta, rng.uniform(-100, 100), rng.uniform(-100, 100), phi]
    return np.array(x), np.array([rng.uniform(-1e4, 1e4), rng.uniform(-0.39, 0.39)])


REFS = {"cartesian": lambda x, u, road: cart_ref(x, u), "frenet": frenet_ref, "lifted": lifted_ref}


@pytest.mark.parametrize("road_maker", [road_const, road_sine], ids=["const_kappa", "sine_kappa"])
@pytest.mark.parametrize("kind", ["cartesian", "frenet", "lifted"])
def test_ode_values_match_spec_equations(kind, road_maker):
    cas, num = road_maker()
    f = casadi_fun(kind, cas)
    rng = np.random.default_rng(1)
    for _ in range(30):
        x, u = random_point(kind, rng)
        val = np.array(f(x, u)[0]).ravel()
        np.testing.assert_allclose(val, REFS[kind](x, u, num), rtol=1e-12, atol=1e-12)


@pytest.mark.parametrize("road_maker", [road_const, road_sine], ids=["const_kappa", "sine_kappa"])
@pytest.mark.parametrize("kind", ["cartesian", "frenet", "lifted"])
def test_ode_jacobian_matches_central_differences(kind, road_maker):
    cas, _ = road_maker()
    f = casadi_fun(kind, cas)
    rng = np.random.default_rng(2)
    nx = models.NX[kind]
    for _ in range(10):
        x, u = random_point(kind, rng)
        J = np.array(f(x, u)[1])
        z = np.r_[x, u]
        Jfd = np.zeros_like(J)
        for j in range(len(z)):
            h = 1e-6 * max(1.0, abs(z[j]))
            zp, zm = z.copy(), z.copy()
            zp[j] += h
            zm[j] -= h
            fp = np.array(f(zp[:nx], zp[nx:])[0]).ravel()
            fm = np.array(f(zm[:nx], zm[nx:])[0]).ravel()
            Jfd[:, j] = (fp - fm) / (2 * h)
        np.testing.assert_allclose(J, Jfd, rtol=1e-6, atol=1e-7 * np.abs(J).max())


# --- wind ------------------------------------------------------------------------------------------


def vdot(phi, v, F_d, wind, veh=VEH):
    f = casadi_fun("cartesian", None, veh, wind)
    return float(f([0, 0, phi, v, 0.1], [F_d, 0.0])[0][3])


def test_no_wind_drag_is_c_air_v_squared():
    v, F = 25.0, 3000.0
    expected = (F - 0.5 * 0.29 * 2.07 * 1.29 * v**2 - 0.015 * 1160 * 9.81) / 1160
    for phi in (0.0, 1.0, -2.5):
        assert vdot(phi, v, F, Wind(v=0.0)) == pytest.approx(expected, rel=1e-13)


def test_crosswind_has_no_effect():
    v, F = 25.0, 3000.0
    no_wind = vdot(0.3, v, F, Wind(v=0.0))
    for phi_w in (0.0, 1.2, -2.0):
        for sign in (1, -1):
            assert vdot(phi_w + sign * math.pi / 2, v, F, Wind(v=20.0, phi=phi_w)) == pytest.approx(no_wind, abs=1e-12)


def test_head_and_tail_wind_by_hand():
    c_air, c_roll, m = 0.5 * 0.29 * 2.07 * 1.29, 0.015 * 1160 * 9.81, 1160.0
    # phi_wind is where the wind comes from: driving towards it (phi = phi_wind) the relative air speed is
    # v + v_wind: 10 + 20 = 30 m/s -> F_air = 900 c_air.
    assert vdot(0.7, 10.0, 0.0, Wind(20.0, 0.7)) == pytest.approx((-900 * c_air - c_roll) / m, rel=1e-13)
    # driving away from it (tail wind faster than the car): v_rel = 10 - 20 = -10 -> the wind pushes,
    # F_air = -100 c_air.
    assert vdot(0.7 + math.pi, 10.0, 0.0, Wind(20.0, 0.7)) == pytest.approx((100 * c_air - c_roll) / m, rel=1e-12)
    # tail wind as fast as the car: no drag at all
    assert vdot(math.pi, 20.0, 500.0, Wind(20.0, 0.0)) == pytest.approx((500 - c_roll) / m, abs=1e-12)
    # 60 degrees off the head wind: v_rel = v + v_w / 2
    assert vdot(math.pi / 3, 10.0, 0.0, Wind(20.0, 0.0)) == pytest.approx((-400 * c_air - c_roll) / m, rel=1e-12)


def test_frenet_wind_uses_road_heading_plus_alpha_and_lifted_uses_cartesian_phi():
    cas, num = road_sine()
    s, alpha = 40.0, 0.1
    phi_hat = num(s)[1] + alpha
    wind = Wind(20.0, phi_hat)  # a pure head wind for the Frenet heading
    c_air, c_roll, m = VEH.c_air, VEH.c_roll, VEH.m
    ff = casadi_fun("frenet", cas, wind=wind)
    vd = float(ff([s, 1.0, alpha, 10.0, 0.0], [0.0, 0.0])[0][3])
    assert vd == pytest.approx((-900 * c_air - c_roll) / m, rel=1e-12)
    fl = casadi_fun("lifted", cas, wind=wind)
    # the lifted model ignores phi_gamma + alpha and uses its own phi: crosswind -> drag c_air v^2
    vd = float(fl([s, 1.0, alpha, 10.0, 0.0, 0.0, 0.0, phi_hat + math.pi / 2], [0.0, 0.0])[0][3])
    assert vd == pytest.approx((-100 * c_air - c_roll) / m, rel=1e-12)


# --- lateral acceleration --------------------------------------------------------------------------


def test_lateral_acceleration_by_hand():
    v, delta = 20.0, 0.1
    # tan(0.1) = 0.10033467208545055; 400 * 0.10033467 / 3.4 = 11.80408...
    assert float(models.a_lat(v, delta, VEH)) == pytest.approx(400 * 0.10033467208545055 / 3.4, rel=1e-14)
    assert float(models.a_lat(v, delta, VEH)) == pytest.approx(11.80408, abs=1e-5)
    # a_lat = v * yaw rate of the Cartesian model (circular motion)
    f = casadi_fun("cartesian", None)
    rng = np.random.default_rng(3)
    for _ in range(10):
        x, u = random_point("cartesian", rng)
        yaw = float(f(x, u)[0][2])
        assert float(models.a_lat(x[3], x[4], VEH)) == pytest.approx(x[3] * yaw, rel=1e-13)
    ocp = build_ocp(paper_problem("truck", "lifted", "ellipse"))
    xl = np.array([1.0, 2.0, 0.1, v, delta, 0, 0, 0])
    assert float(ocp.a_lat(xl)) == pytest.approx(400 * math.tan(0.1) / 3.4, rel=1e-14)


# --- RK4 -------------------------------------------------------------------------------------------


def rk4_fun(kind, road, dt):
    nx = models.NX[kind]
    x, u = ca.SX.sym("x", nx), ca.SX.sym("u", 2)
    return ca.Function("phi", [x, u], [models.rk4(models.ode(kind, road, VEH, WIND), x, u, dt)])


def exact_step(kind, num_road, x0, u, dt):
    rhs = {
        "cartesian": lambda t, x: cart_ref(x, u),
        "frenet": lambda t, x: frenet_ref(x, u, num_road),
        "lifted": lambda t, x: lifted_ref(x, u, num_road),
    }[kind]
    sol = solve_ivp(rhs, (0.0, dt), x0, method="DOP853", rtol=1e-12, atol=1e-13)
    return sol.y[:, -1]


# a typical cornering state: 15 m/s, delta = 0.1 (yaw rate 0.44 rad/s), steering further at 0.1 rad/s, in wind
CASES = {
    "cartesian": np.array([3.0, -2.0, 0.4, 15.0, 0.1]),
    "frenet": np.array([20.0, 2.5, 0.2, 15.0, 0.1]),
    "lifted": np.array([20.0, 2.5, 0.2, 15.0, 0.1, 3.0, -2.0, 0.4]),
}


@pytest.mark.parametrize("kind", ["cartesian", "frenet", "lifted"])
def test_rk4_one_step_error_is_fifth_order(kind):
    cas, num = road_sine(0.05, 0.05)
    x0, u = CASES[kind], np.array([2500.0, 0.1])
    errs = []
    for dt in (0.1, 0.05):
        step = np.array(rk4_fun(kind, cas, dt)(x0, u)).ravel()
        errs.append(np.max(np.abs(step - exact_step(kind, num, x0, u, dt))))
    assert errs[0] < 1e-6
    assert errs[1] > 1e-12  # well above the reference's own accuracy
    ratio = errs[0] / errs[1]
    assert 20 < ratio < 45, (errs, ratio)  # local error O(dt^5): halving dt divides it by ~2^5 = 32


# --- lifted model: the Cartesian states stay F^-1 of the Frenet states --------------------------------


@pytest.fixture(scope="module")
def road_and_solver():
    road = random_road(5)
    ocp = build_ocp(paper_problem("truck", "lifted", "ellipse"))
    sv = RtiSolver(ocp)
    return road, ocp, sv


def _params(sv, ocp, road, s):
    """Stage parameters exactly as RtiSolver.stage_params builds them (window re-cut around s like the closed loop)."""
    sv.set_road(road.window(s - 10.0, ocp.problem.road.samples))
    return sv.stage_params(0, s)


def _control(road, x, t):
    """A lane-keeping steering law plus a slalom perturbation, and a varying drive force."""
    kappa = float(road.eval(x[0])[0])
    delta_des = math.atan(VEH.l * kappa) - 0.05 * (x[1] - 3.0 * math.sin(0.5 * t)) - 0.8 * x[2]
    return np.array([800.0 + 1000.0 * math.sin(0.7 * t), float(np.clip(2.0 * (delta_des - x[4]), -0.39, 0.39))])


def _lifted_drift(road, substeps):
    """Simulate 10 s (100 samples of 0.1 s, `substeps` RK4 steps each) with ocp.dynamics of the lifted truck
    problem; returns the largest |(x, y) - F^-1(s, n, alpha)| (m), |phi - (phi_gamma + alpha)| and the final state."""
    ocp = build_ocp(paper_problem("truck", "lifted", "ellipse", horizon=Horizon(N=40, dt=0.1 / substeps)))
    sv = RtiSolver(ocp)
    xF = np.array([30.0, 2.0, 0.05, 15.0, 0.0])
    x = np.r_[xF, road.to_cartesian(xF[0], xF[1], xF[2])]
    init = np.array(ocp.init_state(xF, _params(sv, ocp, road, xF[0]))).ravel()
    np.testing.assert_allclose(init, x, atol=1e-12)  # init_state appends F^-1 of the Frenet part
    worst_p = worst_phi = 0.0
    for k in range(100):
        u = _control(road, x, 0.1 * k)
        for _ in range(substeps):
            x = np.array(ocp.dynamics(x, u, _params(sv, ocp, road, x[0]))).ravel()
        px, py, phi = road.to_cartesian(x[0], x[1], x[2])
        worst_p = max(worst_p, abs(px - x[5]), abs(py - x[6]))
        worst_phi = max(worst_phi, abs(phi - x[7]))
    return worst_p, worst_phi, x


def test_lifted_cartesian_states_equal_inverse_transform_along_a_trajectory():
    road = random_road(5)
    drift, drift_phi, x = _lifted_drift(road, 1)
    assert x[0] > 190.0 and abs(x[1]) < 8.0 and abs(x[2]) < 0.3  # it really drove 170 m along the road
    # Measured 4.4e-4 m after 10 s. Not below 1e-4: kappa is piecewise linear (only C0), so RK4 loses its
    # order at every knot the step crosses; the error is RK4's, as the next two checks show.
    assert drift < 1e-3, drift
    assert drift_phi < 1e-3, drift_phi
    drift_fine, drift_phi_fine, x_fine = _lifted_drift(road, 10)  # the same controls, dt = 0.01
    assert drift_fine < 0.1 * drift and drift_fine < 5e-5, (drift, drift_fine)
    assert drift_phi_fine < 0.1 * drift_phi, (drift_phi, drift_phi_fine)
    np.testing.assert_allclose(x_fine[:5], x[:5], atol=2e-3)


def test_lifted_consistency_with_exact_integration_is_interpolation_error():
    """The same closed loop integrated exactly (solve_ivp on the numpy interpolants): F^-1 consistency holds up to
    the interpolation error of gamma' vs [cos, sin](phi_gamma) (~1e-5 per metre), i.e. the model is consistent."""
    road = random_road(5)
    rd = lambda s: tuple(float(v) for v in road.eval(s)[:2])
    xF = np.array([30.0, 2.0, 0.05, 15.0, 0.0])
    x = np.r_[xF, road.to_cartesian(xF[0], xF[1], xF[2])]
    worst = 0.0
    for k in range(100):
        u = _control(road, x, 0.1 * k)
        x = solve_ivp(
            lambda t, z, u=u: lifted_ref(z, u, rd),
            (0.0, 0.1),
            x,
            method="DOP853",
            rtol=1e-12,
            atol=1e-12,
            max_step=0.02,
        ).y[:, -1]
        px, py, phi = road.to_cartesian(x[0], x[1], x[2])
        worst = max(worst, abs(px - x[5]), abs(py - x[6]), abs(phi - x[7]))
    assert worst < 1e-5, worst


def test_frenet_part_of_lifted_model_matches_frenet_model(road_and_solver):
    road, ocp_l, sv = road_and_solver
    ocp_f = build_ocp(paper_problem("truck", "direct_elimination", "ellipse"))
    assert ocp_f.np_stage == ocp_l.np_stage  # the same parameter layout: road window, reference, 3 x (x, y, phi)
    rng = np.random.default_rng(4)
    nx = 8
    worst = 0.0
    # the continuous right-hand sides agree exactly when phi = phi_gamma(s) + alpha (same road window)
    xs, us, p = ca.SX.sym("x", nx), ca.SX.sym("u", 2), ca.SX.sym("p", ocp_l.np_stage)
    rp = ocp_l.road_params
    road_fn = lambda s: casadi_road(s, p[: rp.size], rp.samples)[:2]
    f_l = ca.Function("fl", [xs, us, p], [models.lifted_ode(xs, us, road_fn, VEH, WIND)])
    f_f = ca.Function("ff", [xs[:5], us, p], [models.frenet_ode(xs[:5], us, road_fn, VEH, WIND)])
    for _ in range(20):
        s = rng.uniform(20, 1250)
        xF = np.array([s, rng.uniform(-8, 8), rng.uniform(-0.5, 0.5), rng.uniform(1, 38), rng.uniform(-0.3, 0.3)])
        u = np.array([rng.uniform(-1e4, 1e4), rng.uniform(-0.39, 0.39)])
        par = _params(sv, ocp_l, road, s)
        x = np.r_[xF, road.to_cartesian(xF[0], xF[1], xF[2])]
        np.testing.assert_allclose(
            np.array(f_l(x, u, par)).ravel()[:5], np.array(f_f(xF, u, par)).ravel(), rtol=1e-13, atol=1e-13
        )
        # one RK4 step: inside the step the wind sees phi + h*yaw vs phi_gamma(s + h s') + alpha + h alpha',
        # equal to first order in h = dt/2, so the steps agree to O(dt^3) (without wind: exactly, next test)
        step_l = np.array(ocp_l.dynamics(x, u, par)).ravel()[:5]
        step_f = np.array(ocp_f.dynamics(xF, u, par)).ravel()
        worst = max(worst, np.max(np.abs(step_l - step_f)))
    assert worst < 1e-4, worst


def test_lifted_and_frenet_rk4_steps_identical_without_wind():
    road = random_road(6)
    pl = paper_problem("truck", "lifted", "ellipse", wind=Wind(v=0.0))
    pf = paper_problem("truck", "direct_elimination", "ellipse", wind=Wind(v=0.0))
    ol, of = build_ocp(pl), build_ocp(pf)
    sv = RtiSolver(ol)
    rng = np.random.default_rng(7)
    for _ in range(20):
        s = rng.uniform(20, 1250)
        xF = np.array([s, rng.uniform(-8, 8), rng.uniform(-0.5, 0.5), rng.uniform(1, 38), rng.uniform(-0.3, 0.3)])
        u = np.array([rng.uniform(-1e4, 1e4), rng.uniform(-0.39, 0.39)])
        par = _params(sv, ol, road, s)
        x = np.r_[xF, road.to_cartesian(xF[0], xF[1], xF[2])]
        np.testing.assert_allclose(
            np.array(ol.dynamics(x, u, par)).ravel()[:5],
            np.array(of.dynamics(xF, u, par)).ravel(),
            rtol=1e-14,
            atol=1e-12,
        )
