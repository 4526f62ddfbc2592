"""The scenario generator gives the same bits on every CPU (for one Python/numpy/glibc), so golden suites recorded on
one machine replay on another: roads and the opponents' poses the solvers get use no numpy transcendental ufunc, no
BLAS/LAPACK kernel and no SIMD reduction (their results depend on the CPU: SVML on AVX-512, per-CPU OpenBLAS
kernels), only elementwise IEEE arithmetic, fixed-order sums and libm's sin/cos. And ``scenario_of`` accepts a logged
road a few ulps away (another libm) but not another road.
"""

from __future__ import annotations

import itertools
import json
import math
import os
import platform
import subprocess
import sys
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from fcgen.presets import load_problem, paper_problem
from fcgen.road import GL10_NODES, GL10_WEIGHTS, Road, _segment, libm_cos, libm_sin, random_road
from fcgen.sim import scenario as scn
from fcgen.sim.replay import ROAD_RTOL, scenario_of
from fcgen.sim.runlog import RunLog

ROOT = Path(__file__).resolve().parents[1]
GOLDEN_LOG = ROOT / "generated" / "truck_lifted_ellipse" / "golden" / "truck_seed0.json.xz"


def _bits(a) -> bytes:
    return np.ascontiguousarray(a, dtype=np.float64).tobytes()


def _scenario_and_poses(seed: int):
    """A freshly generated scenario (road cache cleared) and its OpponentParams table (the solvers' poses)."""
    pb = paper_problem("truck", "lifted", "ellipse")
    scn.realistic_road.cache_clear()
    sc = scn.make_scenario("truck", seed, n_opp=pb.opponents.count, samples=60, dt=pb.horizon.dt)
    return sc, scn.OpponentParams(pb, sc)._table


# --- no CPU-dispatched numpy on the path ------------------------------------------------------------------------

_FORBIDDEN = (
    "sin",
    "cos",
    "tan",
    "arctan2",
    "arctan",
    "hypot",
    "exp",
    "log",
    "power",
    "convolve",
    "correlate",
    "dot",
    "vdot",
    "inner",
    "matmul",
    "einsum",
    "tensordot",
)


def test_road_and_opponent_poses_use_no_numpy_trig_blas_or_lapack(monkeypatch):
    want = {sd: _scenario_and_poses(sd) for sd in (0, 3)}

    def forbidden(name):
        def f(*args, **kwargs):
            raise AssertionError(f"np.{name} called by the scenario generator (its results depend on the CPU)")

        return f

    for name in _FORBIDDEN:
        monkeypatch.setattr(np, name, forbidden(name))
    monkeypatch.setattr(np.polynomial.legendre, "leggauss", forbidden("polynomial.legendre.leggauss"))
    for name in ("eig", "eigh", "eigvalsh", "eigvals", "solve", "lstsq", "norm"):
        monkeypatch.setattr(np.linalg, name, forbidden(f"linalg.{name}"))
    try:
        got = {sd: _scenario_and_poses(sd) for sd in (0, 3)}
    finally:
        scn.realistic_road.cache_clear()  # no road built under the patch outlives it
    for sd, (sc, table) in want.items():
        sc2, table2 = got[sd]
        for name in ("kappa", "phi", "gx", "gy"):
            assert _bits(getattr(sc2.road, name)) == _bits(getattr(sc.road, name)), (sd, name)
        assert _bits(table2) == _bits(table), sd


_CHILD = """
import hashlib, json, sys
import numpy as np
from fcgen.presets import paper_problem
from fcgen.sim.scenario import OpponentParams, make_scenario
pb = paper_problem("truck", "lifted", "ellipse")
out = {}
for seed in (0, 1, 3):
    sc = make_scenario("truck", seed, n_opp=pb.opponents.count, samples=60, dt=pb.horizon.dt)
    r = sc.road
    arrays = (r.kappa, r.phi, r.gx, r.gy, OpponentParams(pb, sc)._table)
    out[seed] = [hashlib.sha256(np.ascontiguousarray(a, dtype=np.float64).tobytes()).hexdigest() for a in arrays]
json.dump(out, sys.stdout)
"""


def _child_digests(env_extra: dict[str, str]) -> dict:
    env = {**os.environ, **env_extra}
    res = subprocess.run([sys.executable, "-c", _CHILD], env=env, capture_output=True, text=True, timeout=300)
    assert res.returncode == 0, res.stderr
    return json.loads(res.stdout)


@pytest.mark.skipif(platform.machine().lower() not in ("x86_64", "amd64"), reason="x86-64 kernel names")
def test_scenario_bits_do_not_depend_on_numpy_simd_or_blas_kernels():
    """The same scenarios with numpy's SIMD dispatch limited to the x86-64-v2 baseline and with OpenBLAS forced to an
    SSE-only kernel (what another CPU would pick): the same bits as with this CPU's kernels. (np.convolve and
    ``@`` gave other last bits of gamma with OpenBLAS's Nehalem kernel than with its Haswell one.)"""
    here = _child_digests({})
    for env in ({"NPY_DISABLE_CPU_FEATURES": "X86_V3 X86_V4"}, {"OPENBLAS_CORETYPE": "Nehalem"}):
        assert _child_digests(env) == here, env


# --- bit for bit the libm formulas --------------------------------------------------------------------------


def _reference_kappa(seed, length=1600.0, ds=2.0, kappa_max=0.05, knot_spacing=25.0) -> list[float]:
    """random_road's smoothed curvature by a plain Python loop: the moving sum in window order, then / width."""
    rng = np.random.default_rng(seed)
    knots = rng.uniform(-kappa_max, kappa_max, math.ceil(length / knot_spacing) + 3)
    s = np.arange(math.ceil(length / ds) + 1) * ds
    raw = np.interp(s, np.arange(len(knots)) * knot_spacing, knots).tolist()
    width = max(1, round(knot_spacing / ds) | 1)
    padded = [raw[0]] * (width // 2) + raw + [raw[-1]] * (width // 2)
    out = []
    for i in range(len(raw)):
        acc = padded[i]
        for k in range(1, width):
            acc += padded[i + k]
        out.append(acc / width)
    return out


def _reference_centre_line(kappa: list[float], ds: float, x0=(0.0, 0.0, 0.0)):
    """Road.from_curvature by plain Python loops with math.cos/math.sin: phi by the running trapezoid sum, gamma by the
    Gauss-Legendre sum over the points in node order per segment, then the running sum of the segments."""
    tau = [0.5 * (x + 1.0) for x in GL10_NODES.tolist()]
    w = [0.5 * x for x in GL10_WEIGHTS.tolist()]
    phi, run = [x0[2]], 0.0
    for a, b in itertools.pairwise(kappa):
        run += ds * 0.5 * (a + b)
        phi.append(x0[2] + run)
    gx, gy, rx, ry = [x0[0]], [x0[1]], 0.0, 0.0
    for i in range(len(kappa) - 1):
        k0, k1 = kappa[i], kappa[i + 1]
        sx = sy = 0.0
        for q in range(len(w)):
            ph = phi[i] + ds * (k0 * tau[q] + 0.5 * (k1 - k0) * (tau[q] * tau[q]))
            if q == 0:
                sx, sy = math.cos(ph) * w[q], math.sin(ph) * w[q]
            else:
                sx, sy = sx + math.cos(ph) * w[q], sy + math.sin(ph) * w[q]
        rx, ry = rx + ds * sx, ry + ds * sy
        gx.append(x0[0] + rx)
        gy.append(x0[1] + ry)
    return phi, gx, gy


@pytest.mark.parametrize("seed", [0, 7])
def test_random_road_is_the_libm_formula_bit_for_bit(seed):
    road = random_road(seed, s0=-50.0)
    kappa = _reference_kappa(seed)
    phi, gx, gy = _reference_centre_line(kappa, 2.0)
    for name, ref in (("kappa", kappa), ("phi", phi), ("gx", gx), ("gy", gy)):
        assert _bits(getattr(road, name)) == _bits(ref), name


def test_centre_line_from_a_start_pose_is_the_libm_formula_bit_for_bit():
    kappa = np.random.default_rng(5).uniform(-0.05, 0.05, 300)
    road = Road.from_curvature(kappa, 1.5, s0=3.0, x0=(5.0, -3.0, 40.7))  # a large heading: reduced by libm
    phi, gx, gy = _reference_centre_line(kappa.tolist(), 1.5, (5.0, -3.0, 40.7))
    for name, ref in (("phi", phi), ("gx", gx), ("gy", gy)):
        assert _bits(getattr(road, name)) == _bits(ref), name


def test_opponent_poses_are_the_libm_formula_bit_for_bit():
    sc, table = _scenario_and_poses(4)
    r = sc.road
    t = np.arange(len(table)) * sc.dt
    f = sc.opp_frenet(t)
    for j in range(0, len(t), 7):
        for o in range(f.shape[1]):
            s, n, alpha = (float(v) for v in f[j, o])
            i = min(max(math.floor((s - r.s0) / r.ds), 0), r.size - 2)
            tau = (s - r.s0) / r.ds - i
            p0, p1 = float(r.phi[i]), float(r.phi[i + 1])
            _, phg, gx, gy, _, _ = _segment(
                tau,
                r.ds,
                float(r.kappa[i]),
                float(r.kappa[i + 1]),
                p0,
                p1,
                float(r.gx[i]),
                float(r.gx[i + 1]),
                float(r.gy[i]),
                float(r.gy[i + 1]),
                math.cos(p0),
                math.cos(p1),
                math.sin(p0),
                math.sin(p1),
            )
            want = (gx - n * math.sin(phg), gy + n * math.cos(phg), phg + alpha)
            assert _bits(table[j, o]) == _bits(want), (j, o)


def test_libm_helpers_are_math_cos_and_sin_elementwise():
    x = np.random.default_rng(2).uniform(-60.0, 60.0, (7, 13))
    assert _bits(libm_cos(x)) == _bits([[math.cos(v) for v in row] for row in x.tolist()])
    assert _bits(libm_sin(x)) == _bits([[math.sin(v) for v in row] for row in x.tolist()])
    assert libm_cos(x).shape == (7, 13) and libm_sin(np.zeros(0)).shape == (0,)
    c = libm_cos(np.float64(0.3))
    assert isinstance(c, np.float64) and c == math.cos(0.3)


def test_gauss_legendre_constants_are_the_10_point_rule():
    x, w = GL10_NODES, GL10_WEIGHTS
    assert np.all(np.diff(x) > 0) and np.array_equal(x, -x[::-1]) and np.array_equal(w, w[::-1])
    # exact for every polynomial of degree <= 19: the integral of x^k over [-1, 1]
    for k in range(20):
        exact = 2.0 / (k + 1) if k % 2 == 0 else 0.0
        assert math.fsum((w * x**k).tolist()) == pytest.approx(exact, abs=4e-16), k
    # and within a few ulps of LAPACK's (independent: the Golub-Welsch eigenvalues)
    xl, wl = np.polynomial.legendre.leggauss(10)
    np.testing.assert_allclose(x, xl, rtol=0, atol=4e-16)
    np.testing.assert_allclose(w, wl, rtol=0, atol=2e-15)


# --- the replay's road check ----------------------------------------------------------------------------------


@pytest.fixture(scope="module")
def log_and_problem():
    """The checked-in golden log of seed 0 with its road replaced by the one this generator gives (so the test does
    not depend on whether the goldens were recorded with this generator)."""
    log = RunLog.from_json(GOLDEN_LOG)
    pb = load_problem(str(GOLDEN_LOG.parents[1] / "problem.py"))
    r = scn.make_scenario(log.meta["scenario"], log.meta["seed"]).road
    road = {**log.road, "s": r.s, "kappa": r.kappa, "phi_gamma": r.phi, "gamma_x": r.gx, "gamma_y": r.gy}
    return replace(log, road=road), pb


def _with_road(log: RunLog, key: str, change) -> RunLog:
    a = np.array(log.road[key], dtype=float)
    change(a)
    return replace(log, road={**log.road, key: a})


def test_scenario_of_the_generated_road_is_the_cached_scenario(log_and_problem):
    log, pb = log_and_problem
    sc = scenario_of(log, pb)
    assert sc.road is scn.make_scenario(log.meta["scenario"], log.meta["seed"]).road  # not a copy


def test_scenario_of_accepts_a_road_a_few_ulps_away_and_replays_the_logged_one(log_and_problem):
    log, pb = log_and_problem
    gx = np.asarray(log.road["gamma_x"])

    def ulps(a):
        a[100:400] = np.nextafter(np.nextafter(a[100:400], np.inf), np.inf)

    near = _with_road(_with_road(log, "gamma_x", ulps), "kappa", ulps)
    sc = scenario_of(near, pb)
    assert not np.array_equal(sc.road.gx, gx)
    for key, name in (("kappa", "kappa"), ("phi_gamma", "phi"), ("gamma_x", "gx"), ("gamma_y", "gy")):
        assert _bits(getattr(sc.road, name)) == _bits(near.road[key]), key
    assert sc.road.s0 == log.road["s"][0] and sc.road.ds == log.road["ds"]


@pytest.mark.parametrize(
    "key, index, delta, shown",
    [
        ("gamma_x", 300, 1e-8, "allowed"),  # 1e-8 m: 15x the tolerance on this road (|gamma_x| <= 661 m)
        ("gamma_y", 0, np.nan, "nan"),
        ("kappa", 250, 2 * ROAD_RTOL, "allowed"),  # kappa's scale is 1: twice its tolerance
        ("phi_gamma", 10, 1e-6, "allowed"),
    ],
)
def test_scenario_of_rejects_another_road(log_and_problem, key, index, delta, shown):
    log, pb = log_and_problem

    def bump(a):
        a[index] += delta

    with pytest.raises(
        ValueError,
        match=rf"log's road is not the one of scenario 'truck' seed 0 \(another scenario "
        rf"generator\?\): {key} differs by .*{shown}",
    ):
        scenario_of(_with_road(log, key, bump), pb)


def test_scenario_of_rejects_another_grid(log_and_problem):
    log, pb = log_and_problem
    with pytest.raises(ValueError, match="another grid"):
        scenario_of(_with_road(log, "s", lambda a: a.__setitem__(slice(None), a + 1e-9)), pb)
