"""Tests of the road (fcgen.road, SPEC sections 1 and 3): interpolants, centre-line integration, Frenet transforms,
random roads, and the CasADi window evaluation.

Independent references: closed forms (a circle for constant curvature), solve_ivp for a clothoid, finite
differences, the Birkhoff-Priver error bound of cubic Hermite interpolation, and geometric identities.
"""

from __future__ import annotations

import math

import casadi as ca
import numpy as np
import pytest
from scipy.integrate import solve_ivp

from fcgen.road import (
    Road,
    RoadWindowParams,
    casadi_road,
    casadi_to_cartesian,
    random_road,
    straight_road,
    wrap_angle,
)

SEEDS = [0, 1, 7, 42]


def interior_points(road: Road, rng, count: int, lo: float = 0.1, hi: float = 0.9, margin: int = 0):
    """Random s strictly inside segments (local coordinate tau in [lo, hi])."""
    i = rng.integers(margin, road.size - 1 - margin, count)
    return road.s0 + road.ds * (i + rng.uniform(lo, hi, count))


# --- Frenet transforms --------------------------------------------------------------------------------


@pytest.mark.parametrize("seed", SEEDS)
def test_frenet_round_trip_F_of_Finv(seed):
    road = random_road(seed)
    rng = np.random.default_rng(100 + seed)
    m = 2000
    s = rng.uniform(road.s0 + 5, road.s_end - 5, m)
    n = rng.uniform(-8, 8, m)
    alpha = rng.uniform(-1.0, 1.0, m)
    x, y, phi = road.to_cartesian(s, n, alpha)
    s2, n2, a2 = road.to_frenet(x, y, phi, s_guess=s + rng.uniform(-3, 3, m))
    np.testing.assert_allclose(s2, s, atol=1e-9, rtol=0)
    np.testing.assert_allclose(n2, n, atol=1e-9, rtol=0)
    np.testing.assert_allclose(a2, alpha, atol=1e-9, rtol=0)


@pytest.mark.parametrize("seed", SEEDS)
def test_frenet_round_trip_Finv_of_F(seed):
    road = random_road(seed)
    rng = np.random.default_rng(200 + seed)
    m = 2000
    # arbitrary Cartesian points within 8 m of the centre line (offset in any direction, not only the normal)
    s_base = rng.uniform(road.s0 + 20, road.s_end - 20, m)
    _, _, gx, gy, _, _ = road.eval(s_base)
    ang, rad = rng.uniform(-math.pi, math.pi, m), 8.0 * np.sqrt(rng.uniform(0, 1, m))
    px, py = gx + rad * np.cos(ang), gy + rad * np.sin(ang)
    phi = rng.uniform(-math.pi, math.pi, m)
    s, n, alpha = road.to_frenet(px, py, phi, s_guess=s_base)
    assert np.all(np.abs(n) <= 8.0 + 1e-9)
    x2, y2, phi2 = road.to_cartesian(s, n, alpha)
    np.testing.assert_allclose(x2, px, atol=1e-9, rtol=0)
    np.testing.assert_allclose(y2, py, atol=1e-9, rtol=0)
    np.testing.assert_allclose(phi2, phi, atol=1e-12, rtol=0)
    # the foot point is orthogonal: |n| is the distance to gamma(s*)
    _, _, gx2, gy2, _, _ = road.eval(s)
    np.testing.assert_allclose(np.abs(n), np.hypot(px - gx2, py - gy2), atol=1e-9)


def test_to_frenet_without_guess_finds_the_nearest_point():
    road = random_road(3, length=400.0)
    rng = np.random.default_rng(9)
    s = rng.uniform(10, 390, 300)
    n = rng.uniform(-8, 8, 300)
    x, y, phi = road.to_cartesian(s, n, 0.0 * s)
    s2, n2, _ = road.to_frenet(x, y, phi)
    np.testing.assert_allclose(s2, s, atol=1e-9)
    np.testing.assert_allclose(n2, n, atol=1e-9)
    # scalar call
    s1, n1, a1 = road.to_frenet(float(x[0]), float(y[0]), 0.3)
    assert s1 == pytest.approx(s[0], abs=1e-9) and n1 == pytest.approx(n[0], abs=1e-9)
    assert a1 == pytest.approx(0.3 - float(road.eval(s[0])[1]), abs=1e-9)


def test_inverse_transform_by_hand_on_a_straight_road():
    road = straight_road(100.0)
    # n is positive to the left: heading +x, left is +y
    x, y, phi = road.to_cartesian(10.0, 2.0, 0.25)
    assert (x, y, phi) == pytest.approx((10.0, 2.0, 0.25), abs=1e-12)


def test_inverse_transform_by_hand_on_a_left_turn():
    k = 0.05
    road = Road.from_curvature(np.full(41, k), 2.0)
    s, n = 15.0, 3.0
    # centre of the circle at (0, 1/k); a point n to the left is at radius 1/k - n
    x, y, phi = road.to_cartesian(s, n, 0.0)
    R = 1 / k - n
    assert x == pytest.approx(R * math.sin(k * s), abs=1e-5)
    assert y == pytest.approx(1 / k - R * math.cos(k * s), abs=1e-5)
    assert phi == pytest.approx(k * s, abs=1e-12)


# --- interpolant consistency ----------------------------------------------------------------------------


@pytest.mark.parametrize("seed", SEEDS)
def test_dphi_ds_equals_kappa(seed):
    road = random_road(seed)
    rng = np.random.default_rng(seed)
    s = interior_points(road, rng, 3000)
    h = 1e-4
    dphi = (road.eval(s + h)[1] - road.eval(s - h)[1]) / (2 * h)
    np.testing.assert_allclose(dphi, road.eval(s)[0], atol=1e-8, rtol=0)


@pytest.mark.parametrize("seed", SEEDS)
def test_returned_tangent_is_the_derivative_of_gamma(seed):
    road = random_road(seed)
    rng = np.random.default_rng(seed + 1)
    s = interior_points(road, rng, 3000)
    h = 1e-4
    _, _, _, _, dgx, dgy = road.eval(s)
    np.testing.assert_allclose((road.eval(s + h)[2] - road.eval(s - h)[2]) / (2 * h), dgx, atol=1e-7, rtol=0)
    np.testing.assert_allclose((road.eval(s + h)[3] - road.eval(s - h)[3]) / (2 * h), dgy, atol=1e-7, rtol=0)


def test_dgamma_ds_is_unit_tangent_on_constant_curvature():
    # gamma'''' = kappa^3 (normal), so the Hermite derivative error is at most sqrt(3)/216 h^3 kappa^3 = 8.0e-6
    road = Road.from_curvature(np.full(801, -0.05), 2.0)
    s = np.linspace(0, road.s_end, 100001)
    _, phi, _, _, dgx, dgy = road.eval(s)
    err = np.hypot(dgx - np.cos(phi), dgy - np.sin(phi))
    assert err.max() < 1e-5
    assert err.max() <= math.sqrt(3) / 216 * 2.0**3 * 0.05**3 * (1 + 1e-6)


@pytest.mark.parametrize("seed", SEEDS)
def test_dgamma_ds_is_unit_tangent_up_to_interpolation_error(seed):
    road = random_road(seed)
    h = road.ds
    tau = np.linspace(0, 1, 41)
    i = np.arange(road.size - 1)
    s = (road.s0 + h * (i[:, None] + tau[None, :])).ravel()
    _, phi, _, _, dgx, dgy = road.eval(s)
    err = np.hypot(dgx - np.cos(phi), dgy - np.sin(phi)).reshape(len(i), len(tau)).max(axis=1)
    # Birkhoff-Priver: |f' - p'| <= sqrt(3)/216 h^3 max|f''''|; within a segment kappa is linear, so
    # |gamma''''| = |-3 kappa kappa' T + (kappa'' - kappa^3) N| <= 3 |kappa| |kappa'| + |kappa|^3
    kmax = np.maximum(np.abs(road.kappa[:-1]), np.abs(road.kappa[1:]))
    dk = np.abs(np.diff(road.kappa)) / h
    bound = math.sqrt(3) / 216 * h**3 * (3 * kmax * dk + kmax**3)
    assert np.all(err <= bound * 1.001 + 1e-12), np.max(err / bound)
    assert err.max() < 5e-5


@pytest.mark.parametrize("seed", SEEDS)
def test_interpolants_pass_through_samples_and_are_C1_at_knots(seed):
    road = random_road(seed)
    knots = road.s[1:-1]
    k, phi, gx, gy, _dgx, _dgy = road.eval(road.s)
    np.testing.assert_allclose(phi, road.phi, atol=1e-12)
    np.testing.assert_allclose(gx, road.gx, atol=1e-10)
    np.testing.assert_allclose(gy, road.gy, atol=1e-10)
    np.testing.assert_allclose(k, road.kappa, atol=1e-15)
    eps, d = 1e-9, 1e-5
    left = [np.asarray(a) for a in road.eval(knots - eps)]
    right = [np.asarray(a) for a in road.eval(knots + eps)]
    for j in range(6):  # values continuous (kappa, phi, gamma and the tangent)
        np.testing.assert_allclose(left[j], right[j], atol=1e-8)
    for j in (1, 2, 3):  # one-sided first derivatives of phi, gamma_x, gamma_y agree
        fl = (road.eval(knots - eps)[j] - road.eval(knots - eps - d)[j]) / d
        fr = (road.eval(knots + eps + d)[j] - road.eval(knots + eps)[j]) / d
        np.testing.assert_allclose(fl, fr, atol=2e-6)  # O(d * f'') = 1e-5 * 0.05 on each side


# --- centre-line integration ---------------------------------------------------------------------


@pytest.mark.parametrize("kappa", [0.05, -0.03, 0.01])
def test_constant_curvature_road_is_a_circle(kappa):
    road = Road.from_curvature(np.full(501, kappa), 2.0)
    s = road.s
    np.testing.assert_allclose(road.phi, kappa * s, atol=1e-12)
    np.testing.assert_allclose(road.gx, np.sin(kappa * s) / kappa, atol=1e-9, rtol=0)
    np.testing.assert_allclose(road.gy, (1 - np.cos(kappa * s)) / kappa, atol=1e-9, rtol=0)
    # between samples: cubic Hermite error <= h^4/384 max|gamma''''| = 16/384 * |kappa|^3
    sf = np.linspace(0, road.s_end, 20001)
    _, phi, gx, gy, _, _ = road.eval(sf)
    np.testing.assert_allclose(phi, kappa * sf, atol=1e-12)
    err = np.hypot(gx - np.sin(kappa * sf) / kappa, gy - (1 - np.cos(kappa * sf)) / kappa)
    assert err.max() <= 2.0**4 / 384 * abs(kappa) ** 3 + 1e-9


def test_constant_curvature_with_start_pose_and_offset_s0():
    kappa, (x0, y0, p0) = 0.04, (5.0, -3.0, 0.7)
    road = Road.from_curvature(np.full(301, kappa), 2.0, s0=-50.0, x0=(x0, y0, p0))
    t = road.s - road.s0
    cx, cy = x0 - math.sin(p0) / kappa, y0 + math.cos(p0) / kappa  # circle centre to the left
    np.testing.assert_allclose(road.phi, p0 + kappa * t, atol=1e-12)
    np.testing.assert_allclose(road.gx, cx + np.sin(p0 + kappa * t) / kappa, atol=1e-9, rtol=0)
    np.testing.assert_allclose(road.gy, cy - np.cos(p0 + kappa * t) / kappa, atol=1e-9, rtol=0)
    assert road.s[0] == -50.0 and road.s_end == pytest.approx(550.0)


def test_clothoid_against_solve_ivp():
    ds = 2.0
    s = np.arange(0, 600.0 + ds / 2, ds)
    kappa = -0.05 + 0.1 * s / 600.0  # linear: the interpolant is exact
    road = Road.from_curvature(kappa, ds)

    def rhs(t, z):
        k = -0.05 + 0.1 * t / 600.0
        return [math.cos(z[2]), math.sin(z[2]), k]

    sol = solve_ivp(rhs, (0, 600), [0, 0, 0], t_eval=s, method="DOP853", rtol=1e-13, atol=1e-13)
    np.testing.assert_allclose(road.gx, sol.y[0], atol=1e-9)
    np.testing.assert_allclose(road.gy, sol.y[1], atol=1e-9)
    np.testing.assert_allclose(road.phi, sol.y[2], atol=1e-11)


# --- random roads ------------------------------------------------------------------------------------


def test_random_roads_are_reproducible_and_seed_dependent():
    a, b, c = random_road(11), random_road(11), random_road(12)
    for name in ("kappa", "phi", "gx", "gy"):
        assert np.array_equal(getattr(a, name), getattr(b, name))
    assert not np.allclose(a.kappa, c.kappa)
    assert a.ds == 2.0 and a.s0 == 0.0 and a.s_end >= 1600.0


@pytest.mark.parametrize("seed", range(10))
@pytest.mark.parametrize("kappa_max", [0.05, 0.02])
def test_random_road_curvature_bounded(seed, kappa_max):
    road = random_road(seed, kappa_max=kappa_max)
    assert np.max(np.abs(road.kappa)) <= kappa_max
    # and the road really curves: it uses a good part of the allowed range
    assert np.max(np.abs(road.kappa)) > 0.3 * kappa_max
    # centre line consistent with the curvature: phi is the integral of kappa
    np.testing.assert_allclose(np.diff(road.phi), road.ds * 0.5 * (road.kappa[1:] + road.kappa[:-1]), atol=1e-14)
    # unit speed: consecutive samples are at most ds apart (chord <= arc) and nearly ds
    chord = np.hypot(np.diff(road.gx), np.diff(road.gy))
    assert np.all(chord <= road.ds + 1e-12) and np.all(chord >= road.ds * (1 - kappa_max**2 * road.ds**2 / 24) - 1e-12)


def test_random_road_s0():
    road = random_road(2, s0=-50.0)
    assert road.s0 == -50.0
    assert road.eval(-50.0)[2] == pytest.approx(0.0) and road.eval(-50.0)[1] == pytest.approx(0.0)


# --- numpy vs CasADi window ---------------------------------------------------------------------------


@pytest.mark.parametrize("samples", [7, 20])
@pytest.mark.parametrize("seed", [0, 5])
def test_numpy_equals_casadi_window(seed, samples):
    road = random_road(seed)
    rp = RoadWindowParams(samples)
    s_sym, p_sym = ca.SX.sym("s"), ca.SX.sym("p", rp.size)
    f = ca.Function("road", [s_sym, p_sym], list(casadi_road(s_sym, p_sym, samples)))
    n_sym, a_sym = ca.SX.sym("n"), ca.SX.sym("a")
    g = ca.Function(
        "finv", [s_sym, n_sym, a_sym, p_sym], list(casadi_to_cartesian(s_sym, n_sym, a_sym, p_sym, samples))
    )
    rng = np.random.default_rng(seed)
    for _ in range(20):
        i0 = int(rng.integers(0, road.size - samples))
        p = rp.pack(road, i0)
        assert p.size == rp.size == 2 + 4 * samples
        lo = road.s0 + i0 * road.ds
        for s in np.r_[rng.uniform(lo, lo + (samples - 1) * road.ds, 10), lo, lo + (samples - 1) * road.ds]:
            num = np.array([float(v) for v in road.eval(s)])
            cas = np.array([float(v) for v in f(s, p)])
            np.testing.assert_allclose(cas, num, rtol=0, atol=1e-12)
            n, a = rng.uniform(-8, 8), rng.uniform(-1, 1)
            np.testing.assert_allclose(
                np.array([float(v) for v in g(s, n, a, p)]),
                np.array(road.to_cartesian(s, n, a), dtype=float),
                rtol=0,
                atol=1e-12,
            )


# --- window ------------------------------------------------------------------------------------------


def test_window_contents_and_errors():
    road = random_road(4, s0=-50.0)
    w = road.window(33.3, 141)
    assert w.s0 == pytest.approx(32.0) and w.size == 141 and w.ds == road.ds
    s = np.linspace(w.s0, w.s_end, 777)
    for a, b in zip(w.eval(s), road.eval(s)):
        np.testing.assert_allclose(a, b, atol=1e-12)
    with pytest.raises(ValueError, match="outside the road"):
        road.window(-60.0, 10)  # starts before the road
    with pytest.raises(ValueError, match="outside the road"):
        road.window(road.s_end - 20.0, 141)  # runs past its end
    road.window(road.s_end - 2 * road.ds, 3)  # just fits


def test_road_validation():
    with pytest.raises(ValueError, match="same length"):
        Road(0.0, 2.0, np.zeros(5), np.zeros(5), np.zeros(4), np.zeros(5))
    with pytest.raises(ValueError, match="ds"):
        Road(0.0, 0.0, np.zeros(5), np.zeros(5), np.zeros(5), np.zeros(5))
    with pytest.raises(ValueError, match="NaN"):
        Road(0.0, 2.0, np.array([0, np.nan, 0.0]), np.zeros(3), np.zeros(3), np.zeros(3))


def test_wrap_angle_takes_whole_turns_off_and_keeps_a_heading_in_range_bit_for_bit():
    """-3.351 is 2 pi - 3.351 = 2.932185..., -4.7 is 1.583185..., 7 is 0.716815...; 1.0 and pi stay as they are."""
    assert wrap_angle(-3.351) == pytest.approx(2.932185307179586, abs=1e-12)
    assert wrap_angle(-4.7) == pytest.approx(1.583185307179586, abs=1e-12)
    assert wrap_angle(7.0) == pytest.approx(0.7168146928204138, abs=1e-12)
    assert wrap_angle(1.0) == 1.0 and wrap_angle(math.pi) == math.pi
    a = np.array([-3.351, 0.3, -math.pi, 4.0 * math.pi + 0.25])
    np.testing.assert_allclose(wrap_angle(a), [2.932185307179586, 0.3, -math.pi, 0.25], rtol=0, atol=1e-12)
    assert wrap_angle(a)[1] == 0.3
