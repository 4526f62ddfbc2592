"""The per-stage run-time inputs: a reference per node (``set_reference_stages``) and an obstacle margin per stage
(``set_obstacle_margins``), in the Python reference and the generated C (OSQP and IPM, every formulation)."""

from __future__ import annotations

import math
import shutil
from dataclasses import replace

import numpy as np
import pytest
from one_opponent import one_opponent, window_road

from fcgen import obstacles as obs
from fcgen.build import build
from fcgen.codegen.generate import generate
from fcgen.contract import EXIT_CODES, INPUT_RANGES
from fcgen.csolver import CSolver
from fcgen.dsl import Opponents
from fcgen.ocp import build_ocp
from fcgen.presets import preset
from fcgen.reference import RtiSolver, SolverError

pytestmark = pytest.mark.skipif(any(shutil.which(t) is None for t in ("gcc", "make")), reason="needs gcc and make")

SAFE_EL = preset("car_lifted_ellipse_ipm_safe")  # IPM, curve reference, Ellipse(shape="minkowski")
PAPER_CC = preset("car_direct_elimination_circles")  # OSQP, one speed for the horizon, covering circles
CONV = preset("car_conventional_circles")  # the conventional fit
HYP = preset("car_lifted_hyperplane")  # separating hyperplanes
PRESETS = (SAFE_EL, PAPER_CC, CONV, HYP)


X0 = np.array([0.0, 0.0, 0.0, 15.0, 0.0])


def _ramps(pb):
    """v_ref, n_ref and margins that differ at every stage."""
    k = np.arange(pb.horizon.N + 1) / pb.horizon.N
    return 10.0 + 10.0 * k, 0.2 + 1.0 * k, 0.6 * k


def _prepared(pb, ref=None, stages=None, margins=None) -> RtiSolver:
    sv = RtiSolver(build_ocp(pb))
    sv.set_road(window_road(pb))
    sv.set_opponents(one_opponent(pb))
    if ref is not None:
        sv.set_reference(*ref)
    if stages is not None:
        sv.set_reference_stages(*stages)
    if margins is not None:
        sv.set_obstacle_margins(margins)
    sv.set_state(X0)
    sv.prepare()
    return sv


@pytest.fixture(scope="module")
def c_solvers(tmp_path_factory):
    return {
        pb.name: CSolver(build(generate(pb, tmp_path_factory.mktemp(pb.name) / "s").out_dir, verify=True))
        for pb in PRESETS
    }


def _c_prepared(cs, pb, stages=None, margins=None, ref=None):
    assert cs.init() == 0 and cs.set_road(window_road(pb)) == 0 and cs.set_opponents(one_opponent(pb)) == 0
    if ref is not None:
        assert cs.set_reference(*ref) == 0
    if stages is not None:
        assert cs.set_reference_stages(*stages) == 0
    if margins is not None:
        assert cs.set_obstacle_margins(margins) == 0
    assert cs.set_state(X0) == 0 and cs.prepare() == 0
    return cs.get_qp()


# --- the reference per node ----------------------------------------------------------------------------------------


@pytest.mark.parametrize("pb", PRESETS, ids=lambda p: p.name)
def test_equal_stages_give_the_qp_of_set_reference(pb, c_solvers):
    """N+1 equal values give set_reference's QP: bit for bit where the reference integrates s_ref per node anyway
    (the curve reference), else s_ref up to rounding (s0 + t_k v against a sum of dt v) and everything else exactly."""
    N = pb.horizon.N
    one = _prepared(pb, ref=(12.0, 0.7))
    per = _prepared(pb, stages=(np.full(N + 1, 12.0), np.full(N + 1, 0.7)))
    p_ref = one.ocp.p_ref
    np.testing.assert_array_equal(per.P[:, p_ref][:, 1:], one.P[:, p_ref][:, 1:])
    curve = pb.reference.curve_a_lat > 0.0
    tol = 0.0 if curve else 1e-12
    np.testing.assert_allclose(per.P[:, p_ref][:, 0], one.P[:, p_ref][:, 0], rtol=tol, atol=0)
    for a, b in ((per.q, one.q), (per.l, one.l), (per.u, one.u), (per.A_data, one.A_data)):
        np.testing.assert_allclose(a, b, rtol=tol, atol=tol)
    cs = c_solvers[pb.name]
    c_one = {k: v.copy() for k, v in _c_prepared(cs, pb, ref=(12.0, 0.7)).items()}
    c_per = _c_prepared(cs, pb, stages=(np.full(N + 1, 12.0), np.full(N + 1, 0.7)))
    for key in ("q", "l", "u", "A_x"):
        np.testing.assert_allclose(c_per[key], c_one[key], rtol=tol, atol=tol)


def test_a_per_stage_reference_follows_the_hand_formula():
    """Without the curve speed: x_ref,k = [s0 + sum_{i<k} dt v_i, n_k, 0, v_k, 0]; with it on a straight road (no
    cap below v_max): v_ref,k = min(v_k, v_max) and s_ref the same sum."""
    for pb in (PAPER_CC, SAFE_EL):
        v, n, _ = _ramps(pb)
        v = v.copy()
        v[-1] = pb.bounds.v_max + 5.0  # above the curve speed's cap (the car's v_max) where there is one
        sv = _prepared(pb, stages=(v, n))
        dt = pb.horizon.interval
        v_eff = np.minimum(v, pb.bounds.v_max) if pb.reference.curve_a_lat > 0.0 else v
        s_hand = X0[0] + np.concatenate([[0.0], np.cumsum(dt * v_eff[:-1])])
        x_ref = sv.P[:, sv.ocp.p_ref]
        np.testing.assert_allclose(x_ref[:, 0], s_hand, rtol=0, atol=1e-9)
        np.testing.assert_array_equal(x_ref[:, 1], n)
        np.testing.assert_array_equal(x_ref[:, 3], v_eff)
        np.testing.assert_array_equal(x_ref[:, [2, 4]], 0.0)


# --- the obstacle margin per stage ---------------------------------------------------------------------------------


def _rows(sv, name: str) -> np.ndarray:
    """The constraint values g of the rows called ``name[k]``, k = 0..N (absent stages: NaN)."""
    idx = {nm: i for i, nm in enumerate(sv.lay.row_names)}
    return np.array([sv.g[idx[f"{name}[{k}]"]] if f"{name}[{k}]" in idx else np.nan for k in range(sv.ocp.N + 1)])


def test_a_margin_on_the_ellipse_enlarges_its_semi_axes_by_hand():
    """Ellipse(minkowski): the row of stage k is sqrt(e1^2 / (a + m_k)^2 + e2^2 / (b + m_k)^2) - 1 at the guess's ego
    centre (written out here), with a, b the opponent's containing semi-axes; m = 0 gives the unchanged row."""
    pb = SAFE_EL
    _, _, m = _ramps(pb)
    sv0, sv = _prepared(pb), _prepared(pb, margins=m)
    a, b = obs.vehicle_shape(pb.obstacles, pb.ego, pb.opponents.vehicle)[3:5]
    opp, veh = one_opponent(pb)[:, 0], pb.opponents.vehicle
    names = sv.ocp.first.var_names
    ix, iy, iphi = names.index("x"), names.index("y"), names.index("phi")
    g, g0 = _rows(sv, "opp0_h0"), _rows(sv0, "opp0_h0")
    for k in range(1, pb.horizon.N + 1):
        w = sv.w_prep[sv.lay.var_off[k] : sv.lay.var_off[k + 1]]
        x, y, phi = w[ix], w[iy], w[iphi]
        ego = obs.chassis_shape(x, y, phi, pb.ego)  # the ego's circle: its chassis centre
        cx, cy = float(ego.cx), float(ego.cy)
        ox = opp[k, 0] + 0.5 * veh.l * math.cos(opp[k, 2])  # the opponent's centre: half its wheelbase ahead
        oy = opp[k, 1] + 0.5 * veh.l * math.sin(opp[k, 2])
        c, s = math.cos(opp[k, 2]), math.sin(opp[k, 2])
        e1, e2 = c * (cx - ox) + s * (cy - oy), -s * (cx - ox) + c * (cy - oy)
        for mk, row in ((m[k], g[k]), (0.0, g0[k])):
            hand = math.sqrt(e1 * e1 / (a + mk) ** 2 + e2 * e2 / (b + mk) ** 2 + 1e-12) - 1.0
            assert row == pytest.approx(hand, abs=1e-9), (k, mk)
    assert np.all(g[2:] < g0[2:])  # a margin makes every stage's row tighter


@pytest.mark.parametrize("pb", [PAPER_CC, HYP], ids=lambda p: p.name)
def test_a_margin_equals_an_opponent_grown_on_each_side(pb):
    """Second method: one margin m at every stage gives the rows of the same problem built for an opponent vehicle
    m longer at each end and 2 m wider (the rectangle grown by m on each side, its centre kept)."""
    m = 0.4
    veh = pb.opponents.vehicle
    big = replace(veh, l_f_ch=veh.l_f_ch + m, l_r_ch=veh.l_r_ch + m, w_ch=veh.w_ch + 2.0 * m)
    grown = _prepared(pb.with_(opponents=Opponents(pb.opponents.count, big)))
    sv = _prepared(pb, margins=np.full(pb.horizon.N + 1, m))
    np.testing.assert_allclose(sv.g, grown.g, rtol=0, atol=1e-12)
    assert not np.allclose(sv.g, _prepared(pb).g)  # the margin does enter the rows


# --- C = Python, refused calls ---------------------------------------------------------------------------------------


@pytest.mark.parametrize("pb", PRESETS, ids=lambda p: p.name)
def test_c_equals_the_reference_with_per_stage_values(pb, c_solvers):
    """A reference and margins that differ at every stage: the C's stage parameters and QP equal the reference's
    bit for bit, and 15 closed-loop samples stay together."""
    stages, m = _ramps(pb)[:2], _ramps(pb)[2]
    sv = _prepared(pb, stages=stages, margins=m)
    cs = c_solvers[pb.name]
    qp = _c_prepared(cs, pb, stages=stages, margins=m)
    np.testing.assert_array_equal(cs.get_opp_params(), sv.P[:, sv.ocp.p_opp])
    for key, r in (("q", sv.q), ("A_x", sv.A_data), ("l", sv.l), ("u", sv.u)):
        np.testing.assert_array_equal(np.clip(qp[key], -1e20, 1e20), np.clip(r, -1e20, 1e20), err_msg=key)
    assert cs.set_state(X0) == 0
    rc = cs.feedback()
    try:
        sv.set_state(X0)
        sv.feedback()
        rc_py = 0
    except SolverError as e:
        rc_py = EXIT_CODES.index(e.code)
    assert rc == rc_py
    np.testing.assert_allclose(cs.u0(), sv.u0(), rtol=0, atol=1e-7)


def _code(name: str) -> int:
    return EXIT_CODES.index(name)


BAD_MARGINS = (-1e-3, math.nan, math.inf, INPUT_RANGES.margin_max * 1.01)


def test_bad_per_stage_values_are_refused_and_change_nothing(c_solvers):
    """One bad entry (NaN, inf, a negative or too large margin, n_ref beyond the band, v_ref < 0) or NULL: the
    documented code, in C and Python, and the next prepare gives the QP of the inputs accepted before."""
    pb = SAFE_EL
    cs = c_solvers[pb.name]
    v, n, m = _ramps(pb)
    want = {k: a.copy() for k, a in _c_prepared(cs, pb, stages=(v, n), margins=m).items()}
    sv = _prepared(pb, stages=(v, n), margins=m)
    bad_refs = []
    for k, bad in ((0, math.nan), (7, -0.1), (pb.horizon.N, math.inf)):
        vb = v.copy()
        vb[k] = bad
        bad_refs.append((vb, n))
    nb = n.copy()
    nb[3] = pb.bounds.n_max + 0.1
    bad_refs.append((v, nb))
    assert cs.init() == 0 and cs.set_road(window_road(pb)) == 0 and cs.set_opponents(one_opponent(pb)) == 0
    assert cs.set_reference_stages(v, n) == 0 and cs.set_obstacle_margins(m) == 0
    for vb, nb in bad_refs:
        assert cs.set_reference_stages(vb, nb) == _code("ERR_REFERENCE")
        assert cs.status().exit_code == _code("ERR_REFERENCE")
        with pytest.raises(SolverError, match="stage"):
            sv.set_reference_stages(vb, nb)
    for bad in BAD_MARGINS:
        mb = m.copy()
        mb[5] = bad
        assert cs.set_obstacle_margins(mb) == _code("ERR_MARGIN")
        with pytest.raises(SolverError, match=r"obstacle margin of stage 5 .* allowed in \[0, 10.0\] m"):
            sv.set_obstacle_margins(mb)
    assert cs.set_obstacle_margins(None) == _code("ERR_NULL_POINTER")
    assert cs.set_reference_stages(None, n) == _code("ERR_NULL_POINTER")
    assert cs.set_reference_stages(v, None) == _code("ERR_NULL_POINTER")
    for call in (lambda: sv.set_obstacle_margins(None), lambda: sv.set_reference_stages(v, None)):
        with pytest.raises(SolverError) as e:
            call()
        assert e.value.code == "ERR_NULL_POINTER"
    assert cs.set_state(X0) == 0 and cs.status().exit_code == 0  # the status describes the last call
    assert cs.prepare() == 0
    got = cs.get_qp()
    for key in ("q", "l", "u", "A_x"):
        np.testing.assert_array_equal(got[key], want[key], err_msg=key)
    # the reference after its refused calls: the same QP as the C's
    sv.prepare()
    np.testing.assert_array_equal(got["q"], sv.q)


def test_values_at_the_edges_of_their_ranges_are_accepted(c_solvers):
    """v_ref 0 and 100 m/s, n_ref at Bounds.n_min and n_max, margins 0 and 10 m (alternating over the stages): OK in C
    and Python, and the status says OK."""
    pb = SAFE_EL
    cs, sv = c_solvers[pb.name], RtiSolver(build_ocp(pb))
    k = np.arange(pb.horizon.N + 1) % 2
    v = np.where(k, INPUT_RANGES.v_ref_max, 0.0)
    n = np.where(k, pb.bounds.n_max, pb.bounds.n_min)
    m = np.where(k, INPUT_RANGES.margin_max, 0.0)
    assert cs.init() == 0 and cs.set_reference_stages(v, n) == 0 and cs.set_obstacle_margins(m) == 0
    assert cs.status().exit_code == 0
    sv.set_reference_stages(v, n)
    sv.set_obstacle_margins(m)
    assert sv.status.exit_code == 0
