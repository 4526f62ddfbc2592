"""The C API's safety contract (issue 7), in the generated C and in the Python reference alike.

- QP outcome: an unusable QP gives its own exit code, the step is not taken, get_u0 is the documented fallback;
- the applied control always lies in the input box, a projection is reported (flag + size);
- rejected calls are transactional: the good sequence with rejected calls interleaved is bitwise the good sequence;
- reset()/init() after many solves give bitwise what a freshly loaded (zero-initialized) library gives.
The C library is the verification build, bit-exact with the Python reference, so C and Python are compared exactly.
"""

from __future__ import annotations

import shutil
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from fcgen.backends import QP_PRIMAL_INFEASIBLE, QP_USABLE
from fcgen.build import build
from fcgen.codegen.generate import generate
from fcgen.contract import EXIT_CODES
from fcgen.csolver import CSolver
from fcgen.ocp import build_ocp
from fcgen.plant import plant_function
from fcgen.presets import preset
from fcgen.reference import QP_EXIT, RtiSolver, SolverError, input_box
from fcgen.sim.closedloop import WINDOW_BEHIND
from fcgen.sim.scenario import OpponentParams, make_scenario

pytestmark = pytest.mark.skipif(any(shutil.which(t) is None for t in ("gcc", "make")), reason="needs gcc and make")

PRESET = "truck_lifted_ellipse"
CODE = {c: i for i, c in enumerate(EXIT_CODES)}
K = 12  # samples of the good sequence


@pytest.fixture(scope="module")
def lib(tmp_path_factory) -> tuple[Path, Path]:
    """The verification build of the preset's solver: (shared library, header)."""
    info = generate(preset(PRESET), tmp_path_factory.mktemp("contract") / "gen")
    return build(info.out_dir, verify=True), info.out_dir / f"{info.name}_solver.h"


@pytest.fixture
def fresh(lib, tmp_path):
    """fresh(tag): a newly loaded copy of the library (its own static workspace), zero-initialized: no init()."""

    def load(tag: str, init: bool = False) -> CSolver:
        d = tmp_path / tag
        d.mkdir()
        shutil.copy(lib[0], d / lib[0].name)
        return CSolver(d / lib[0].name, header=lib[1], init=init)

    return load


@pytest.fixture(scope="module")
def inputs() -> list[tuple[np.ndarray, object, np.ndarray]]:
    """(x0, road window, opponents) of K closed-loop samples (reference controls through the plant)."""
    return _inputs(seed=1, samples=K)


def _inputs(seed: int, samples: int):
    pb = preset(PRESET)
    ocp = build_ocp(pb)
    sc = make_scenario("truck", seed, samples=samples)
    opp, plant, ref = OpponentParams(pb, sc), plant_function(pb, ocp.road_params.samples), RtiSolver(ocp)
    x, out = sc.x0.copy(), []
    for j in range(samples):
        win = sc.road.window(x[0] - WINDOW_BEHIND, pb.road.samples)
        out.append((x.copy(), win, opp.horizon(j)))
        ref.set_road(win)
        ref.set_opponents(opp.horizon(j))
        u = ref.step(x)
        i0 = int(np.floor((x[0] - sc.road.s0) / sc.road.ds)) - 1
        x = np.array(plant(x, u, ocp.road_params.pack(sc.road, i0))).ravel()
    return out


def snapshot(cs: CSolver) -> dict:
    """Everything the API shows, as bytes (bitwise comparison); the status without its times."""
    st = cs.status()
    snap = {k: v.tobytes() for k, v in cs.get_qp().items()}
    snap.update(
        u0=cs.u0().tobytes(),
        states=cs.states().tobytes(),
        controls=cs.controls().tobytes(),
        slack=np.float64(cs.max_slack()).tobytes(),
        has_guess=cs.has_guess(),
        status=(
            st.exit_code,
            st.qp_status,
            st.qp_raw_status,
            st.qp_iter,
            st.u_projected,
            np.float64(st.u_violation).tobytes(),
        ),
    )
    return snap


def without_exit_code(snap: dict) -> dict:
    return {**snap, "status": snap["status"][1:]}


def good_sample(cs: CSolver, inp) -> int:
    x0, road, opp = inp
    assert cs.set_road(road) == 0 and cs.set_opponents(opp) == 0
    if not cs.has_guess():
        assert cs.set_state(x0) == 0
    assert cs.prepare() == 0
    assert cs.set_state(x0) == 0
    return cs.feedback()


def rejected(cs: CSolver, call, code: str) -> None:
    """A call that must be rejected with `code` and leave everything but status.exit_code as it was."""
    before = snapshot(cs)
    assert call() == CODE[code]
    after = snapshot(cs)
    assert after["status"][0] == CODE[code]
    assert without_exit_code(after) == without_exit_code(before), code


def dirty_sample(cs: CSolver, inp) -> int:
    """The good sample with rejected calls before, between and after its phases."""
    x0, road, opp = inp
    nan = np.full(5, np.nan)
    rejected(cs, cs.feedback, "ERR_NOT_PREPARED")  # wrong order
    rejected(cs, lambda: cs.set_state(nan), "ERR_NONFINITE_STATE")
    rejected(cs, lambda: cs.set_state(np.array([0.0, 1e308 * 10, 0.0, 0.0, 0.0])), "ERR_NONFINITE_STATE")
    rejected(cs, lambda: cs.set_opponents(np.full_like(opp, np.nan)), "ERR_NONFINITE_OPPONENTS")
    rejected(
        cs,
        lambda: cs.set_road_raw(road.s0, road.ds, *(a[:1] for a in (road.kappa, road.phi, road.gx, road.gy))),
        "ERR_ROAD_SIZE",
    )
    # a 12-sample road: set_road accepts it, prepare rejects it (it does not cover the horizon) and changes nothing
    assert cs.set_road_raw(road.s0, road.ds, *(a[:12] for a in (road.kappa, road.phi, road.gx, road.gy))) == 0
    if not cs.has_guess():
        assert cs.set_state(x0) == 0
    rejected(cs, cs.prepare, "ERR_ROAD_WINDOW")
    assert cs.set_road(road) == 0 and cs.set_opponents(opp) == 0
    if not cs.has_guess():
        assert cs.set_state(x0) == 0
    assert cs.prepare() == 0
    before = snapshot(cs)
    assert cs.prepare() == 0 and snapshot(cs) == before  # prepare twice: a no-op, bitwise
    far = x0.copy()
    far[0] += 1e4  # outside the road window
    assert cs.set_state(far) == 0
    rejected(cs, cs.feedback, "ERR_ROAD_WINDOW")  # the preparation is kept
    assert cs.set_state(x0) == 0
    rc = cs.feedback()
    rejected(cs, cs.feedback, "ERR_NOT_PREPARED")  # feedback twice
    return rc


def test_finiteness_check_is_exact_where_a_sum_overflows(fresh, inputs):
    """The inputs' finiteness test sums the entries first (one operation each) and decides exactly only where that sum
    is not finite: large finite entries whose sum overflows are accepted, one infinity among them or +inf with -inf
    (whose sum is NaN) rejected."""
    cs = fresh("finite", init=True)
    opp = inputs[0][2]
    big = np.full_like(opp, 1e308)  # finite; the sum of two already overflows to inf
    with np.errstate(over="ignore"):
        assert not np.isfinite(big.sum()) and cs.set_opponents(big) == 0
    for bad in (np.inf, -np.inf, np.nan):
        b = big.copy()
        b.flat[b.size // 2] = bad
        rejected(cs, lambda b=b: cs.set_opponents(b), "ERR_NONFINITE_OPPONENTS")
    pm = np.ones_like(opp)
    pm.flat[0], pm.flat[-1] = np.inf, -np.inf
    rejected(cs, lambda: cs.set_opponents(pm), "ERR_NONFINITE_OPPONENTS")
    assert cs.set_opponents(opp) == 0


def test_rejected_calls_leave_the_solver_bitwise_unchanged(fresh, inputs):
    clean, dirty = fresh("clean"), fresh("dirty")
    for j, inp in enumerate(inputs):
        assert good_sample(clean, inp) == 0
        assert dirty_sample(dirty, inp) == 0
        a, b = snapshot(clean), snapshot(dirty)
        assert without_exit_code(a) == without_exit_code(b), f"sample {j}"


def test_reset_and_init_equal_a_fresh_library(fresh, inputs):
    ref = fresh("fresh")
    want = []
    for inp in inputs:
        assert good_sample(ref, inp) == 0
        want.append(snapshot(ref))
    used = fresh("used", init=True)
    other = _inputs(seed=4, samples=25)  # another road, other opponents
    for how, history in (("reset", other), ("init", other[:5])):
        for j, inp in enumerate(history):  # 25 (then 5) solves with other data
            rc = good_sample(used, inp)
            if how == "init":  # warm from the last plan of `inputs`, 21 m ahead and 3.8 m aside of the new state: the
                # capped QP's step leaves the input box by 49 %, refused; the kept plan never meets the state again,
                # until the cold restart after COLD_RESTART_AFTER = 3 refusals in a row (from the state set last)
                assert rc == (CODE["ERR_QP_INPUT_BOUNDS"] if j < 3 else 0), j
                assert used.status().cold_restarts == int(j >= 3)
            else:
                assert rc == 0
        x0, road, _opp = other[len(history) - 1]
        assert used.set_road(road) == 0 and used.prepare() == 0
        if how == "init":  # a garbage QP (n = 1e15) before init: capped at 60 iterations, a huge step
            assert used.set_state(np.array([x0[0], 1e15, 0.0, x0[3], 0.0])) == 0
            used.feedback()
        # reset: with a pending preparation left behind
        getattr(used, how)()
        for j, inp in enumerate(inputs):
            assert good_sample(used, inp) == 0
            assert snapshot(used) == want[j], f"{how}: sample {j}"


def _python(inputs_: list) -> RtiSolver:
    sv = RtiSolver(build_ocp(preset(PRESET)))
    for x0, road, opp in inputs_:
        sv.set_road(road)
        sv.set_opponents(opp)
        sv.step(x0)
    return sv


def test_unusable_qp_c_and_python(fresh, inputs):
    """The issue's case, n = 1e15 on a cold start (400 iterations): OSQP finds the QP primal infeasible."""
    cs = fresh("infeasible")
    x0, road, opp = inputs[0]
    bad = x0.copy()
    bad[1] = 1e15
    assert cs.set_road(road) == 0 and cs.set_opponents(opp) == 0 and cs.set_state(x0) == 0 and cs.prepare() == 0
    assert cs.set_state(bad) == 0
    rc = cs.feedback()
    st = cs.status()
    assert rc == CODE["ERR_QP_INFEASIBLE"] == st.exit_code and st.qp_status == QP_PRIMAL_INFEASIBLE
    assert st.qp_raw_status in (3, 4) and QP_EXIT[st.qp_status] == "ERR_QP_INFEASIBLE"  # OSQP: primal infeasible
    # no step: the plan is the initial guess (zero input), the fallback control zeros
    assert np.all(cs.controls() == 0.0) and np.array_equal(cs.u0(), np.zeros(2)) and cs.has_guess()
    assert st.u_projected == 0 and st.u_violation == 0.0
    assert cs.feedback() == CODE["ERR_NOT_PREPARED"]  # the sample is consumed
    # the Python reference: the same code, status, fallback and plan, bitwise
    sv = RtiSolver(build_ocp(preset(PRESET)))
    sv.set_road(road)
    sv.set_opponents(opp)
    sv.set_state(x0)
    sv.prepare()
    sv.set_state(bad)
    with pytest.raises(SolverError) as exc:
        sv.feedback()
    assert exc.value.code == "ERR_QP_INFEASIBLE" and sv.status.exit_code == rc
    assert (sv.status.qp_status, sv.status.qp_raw_status, sv.status.qp_iter) == (
        st.qp_status,
        st.qp_raw_status,
        st.qp_iter,
    )
    assert sv.u0().tobytes() == cs.u0().tobytes() and sv.states().tobytes() == cs.states().tobytes()
    # the next sample recovers from the kept plan, in C and Python alike
    assert good_sample(cs, inputs[1]) == 0
    x1, road1, opp1 = inputs[1]
    sv.set_road(road1)
    sv.set_opponents(opp1)
    u = sv.step(x1)
    assert cs.status().qp_status in QP_USABLE and np.all(np.isfinite(cs.states()))
    assert u.tobytes() == cs.u0().tobytes() and sv.states().tobytes() == cs.states().tobytes()


def test_unusable_qp_keeps_the_shifted_plan(inputs):
    """Warm start (Python reference; the C takes the same code path, see above): the plan is the shifted previous
    plan, get_u0 its first control = u_1 of the previous plan, in the box; the next sample recovers."""
    pb = preset(PRESET)
    lo, hi, _ = input_box(pb)
    # enough iterations to detect the infeasibility from the warm start (about 850)
    sv = RtiSolver(build_ocp(pb), qp=replace(pb.qp, max_iter=1000, check_termination=5))
    for x0, road, opp in inputs[:4]:
        sv.set_road(road)
        sv.set_opponents(opp)
        sv.step(x0)
    prev_controls, prev_states = sv.controls(), sv.states()
    x0, road, opp = inputs[4]
    sv.set_road(road)
    sv.set_opponents(opp)
    sv.prepare()
    sv.set_state(np.r_[x0[0], 1e15, x0[2:]])
    with pytest.raises(SolverError) as exc:
        sv.feedback()
    assert exc.value.code == "ERR_QP_INFEASIBLE" and sv.status.qp_status == QP_PRIMAL_INFEASIBLE
    np.testing.assert_array_equal(sv.controls()[:-1], prev_controls[1:])
    np.testing.assert_array_equal(sv.states()[:-1], prev_states[1:])
    u = sv.u0()
    np.testing.assert_array_equal(u, np.clip(prev_controls[1], lo, hi))
    assert np.all(lo <= u) and np.all(u <= hi)
    x1, road1, opp1 = inputs[5]
    sv.set_road(road1)
    sv.set_opponents(opp1)
    sv.step(x1)
    assert sv.status.exit_code == 0 and np.all(np.isfinite(sv.states()))


def test_python_reference_rejects_with_the_same_codes(inputs):
    sv = _python(inputs[:2])
    x0, road, opp = inputs[2]
    cases = [
        (sv.feedback, "ERR_NOT_PREPARED"),
        (lambda: sv.set_state(np.full(5, np.nan)), "ERR_NONFINITE_STATE"),
        (lambda: sv.set_opponents(np.full_like(opp, np.nan)), "ERR_NONFINITE_OPPONENTS"),
    ]
    sv.set_road(road.window(road.s0, 12))
    cases.append((sv.prepare, "ERR_ROAD_WINDOW"))
    for call, code in cases:
        w, y, status = sv.w.copy(), sv.y.copy(), (sv.status.qp_status, sv.status.qp_iter)
        with pytest.raises(SolverError) as exc:
            call()
        assert exc.value.code == code and sv.status.exit_code == CODE[code]
        assert sv.w.tobytes() == w.tobytes() and sv.y.tobytes() == y.tobytes() and not sv.prepared
        assert (sv.status.qp_status, sv.status.qp_iter) == status
    sv.set_road(road)
    sv.set_opponents(opp)
    sv.prepare()
    w_prep = sv.w_prep.copy()
    sv.prepare()  # a no-op
    assert sv.prepared and sv.w_prep.tobytes() == w_prep.tobytes()
    far = x0.copy()
    far[0] += 1e4
    sv.set_state(far)
    with pytest.raises(SolverError) as exc:
        sv.feedback()
    assert exc.value.code == "ERR_ROAD_WINDOW" and sv.prepared  # the preparation is kept
    sv.set_state(x0)
    sv.feedback()
    assert sv.status.exit_code == 0


def test_projection_is_reported(inputs):
    """A capped QP (12 iterations: u_violation up to 0.03 here, within MAX_INPUT_VIOLATION) leaves the box: get_u0 is
    the projection, flag and size in the status. (Capped at 2 to 4 iterations the steps leave the box by more than
    the margin and are refused, ERR_QP_INPUT_BOUNDS.)"""
    from fcgen.reference import MAX_INPUT_VIOLATION

    pb = preset(PRESET)
    lo, hi, lim = input_box(pb)
    sv = RtiSolver(build_ocp(pb), qp=replace(pb.qp, max_iter=12, max_iter_cold=12))
    seen = 0
    for x0, road, opp in inputs:
        sv.set_road(road)
        sv.set_opponents(opp)
        u = sv.step(x0)
        plan_u0 = sv.controls()[0]
        excess = np.maximum(np.abs(plan_u0) - lim, 0.0) / lim
        assert np.all(lo <= u) and np.all(u <= hi) and excess.max() <= MAX_INPUT_VIOLATION
        if np.any(excess > 0):
            seen += 1
            assert sv.status.u_projected == 1 and sv.status.u_violation == pytest.approx(excess.max(), rel=1e-12)
            np.testing.assert_array_equal(u, np.clip(plan_u0, lo, hi))
        else:
            assert sv.status.u_projected == 0 and sv.status.u_violation == 0.0
            np.testing.assert_array_equal(u, plan_u0)
    assert seen >= 5


def test_c_projection_flag_matches_the_plan(fresh, inputs):
    pb = preset(PRESET)
    lo, hi, lim = input_box(pb)
    cs = fresh("projection")
    for inp in inputs:
        assert good_sample(cs, inp) == 0
        plan_u0, u, st = cs.controls()[0], cs.u0(), cs.status()
        excess = np.maximum(np.abs(plan_u0) - lim, 0.0) / lim
        assert np.all(lo <= u) and np.all(u <= hi)
        assert st.u_projected == int(np.any(excess > 0))
        assert st.u_violation == pytest.approx(excess.max(), rel=1e-12, abs=0.0)
        np.testing.assert_array_equal(u, np.clip(plan_u0, lo, hi))


def test_qp_scaling_depends_only_on_this_samples_data(inputs):
    """OSQP rescales in update_data_mat from the q it holds: the backend loads this sample's q first. A backend with a
    history then solves a sample like a fresh one, up to one scale/unscale rounding of q (the loading order of the
    seam cannot remove it); loading the matrices alone (the old order) leaves the previous sample's q in the scaling."""
    from fcgen.backends import make_backend

    pb = preset(PRESET)
    sv = RtiSolver(build_ocp(pb))
    lay, data = sv.lay, []
    for x0, road, opp in inputs[:6]:
        sv.set_road(road)
        sv.set_opponents(opp)
        if sv.w is None:
            sv.set_state(x0)
        sv.prepare()
        sv.set_state(x0)
        A, q = sv.A_data.copy(), sv.q.copy()
        sv.feedback()
        data.append((A, q, sv.q_fb.copy(), sv.l.copy(), sv.u.copy(), sv.y_prep.copy()))

    def solve(b, d, q_first=True):
        A, q, q_fb, l, u, y = d
        if q_first:
            b.set_matrices(lay.P_diag, A, q)
        else:
            b.solver.update(Px=lay.P_diag, Ax=A)
        return b.solve(q_fb, l, u, y, pb.qp.max_iter).z

    for q_first, bound in ((True, 1e-9), (False, None)):
        worst = 0.0
        for j in range(1, len(data)):
            fresh_b, used_b = make_backend(lay, pb.qp), make_backend(lay, pb.qp)
            for d in data[:j]:
                solve(used_b, d, q_first)
            worst = max(
                worst, float(np.max(np.abs(solve(fresh_b, data[j], q_first) - solve(used_b, data[j], q_first))))
            )
        if bound:
            assert worst < bound
        else:
            assert worst > 1e-3  # the defect the order fixes is visible


@pytest.mark.parametrize("n_bad", [10.0, 100.0, 1e15])
def test_absurd_state_on_a_warm_start_c_and_python(fresh, inputs, monkeypatch, n_bad):
    """The hole of the capped QP (OSQP, 60 iterations): on a warm start an absurd lateral offset n stops OSQP at
    MAX_ITER with a finite but huge step. Its u0 beyond the input box by more than MAX_INPUT_VIOLATION: the QP is
    unusable (ERR_QP_INPUT_BOUNDS), the step is not taken, get_u0 is the fallback, and the next good sample recovers
    without reset(). Within the margin (n = 10: 1.2 %): OK, projected and flagged, as before. C == Python, bitwise."""
    import fcgen.reference as reference

    pb = preset(PRESET)
    lo, hi, lim = input_box(pb)
    cs = fresh(f"absurd{n_bad:g}")
    sv = RtiSolver(build_ocp(pb))
    for inp in inputs[:4]:
        assert good_sample(cs, inp) == 0
        sv.set_road(inp[1])
        sv.set_opponents(inp[2])
        sv.step(inp[0])
    prev_controls = cs.controls()
    x0, road, opp = inputs[4]
    bad = np.r_[x0[0], n_bad, x0[2:]]
    assert cs.set_road(road) == 0 and cs.set_opponents(opp) == 0 and cs.prepare() == 0 and cs.set_state(bad) == 0
    rc, st, qp = cs.feedback(), cs.status(), cs.get_qp()
    assert st.qp_status in QP_USABLE and st.qp_iter == pb.qp.max_iter  # capped: the contract calls it usable
    # the step the QP proposed, from the C's own z: u0 of (prepared guess + D z); the prepared guess's u0 is u_1 of
    # the previous plan, whatever became of the plan
    lay = sv.lay
    iu = lay.var_off[0] + sv.ocp.nx + np.arange(sv.ocp.nu)
    step_u0 = prev_controls[1] + lay.D[iu] * qp["z"][iu]
    step_violation = float(np.max(np.maximum(np.abs(step_u0) - lim, 0.0) / lim))
    sv.set_road(road)
    sv.set_opponents(opp)
    sv.prepare()
    sv.set_state(bad)
    if n_bad == 10.0:  # within the margin: today's behaviour, the step is taken, the control projected and flagged
        assert 0.0 < step_violation <= reference.MAX_INPUT_VIOLATION
        assert rc == CODE["OK"] and st.u_projected == 1 and st.u_violation == pytest.approx(step_violation, rel=1e-12)
        np.testing.assert_array_equal(cs.controls()[0], step_u0)
        np.testing.assert_array_equal(cs.u0(), np.clip(step_u0, lo, hi))
        sv.feedback()
    else:
        assert step_violation > 10.0  # 10 .. 1e14: far beyond any tolerance
        assert rc == CODE["ERR_QP_INPUT_BOUNDS"] == st.exit_code
        np.testing.assert_array_equal(cs.controls()[:-1], prev_controls[1:])  # no step: the shifted previous plan
        np.testing.assert_array_equal(cs.u0(), np.clip(prev_controls[1], lo, hi))  # the fallback, in the box
        assert np.all(lo <= cs.u0()) and np.all(cs.u0() <= hi)
        assert st.u_projected == int(np.any(np.abs(prev_controls[1]) > lim))  # describes the fallback
        with pytest.raises(SolverError) as exc:
            sv.feedback()
        assert exc.value.code == "ERR_QP_INPUT_BOUNDS" and sv.status.exit_code == rc
    assert sv.z.tobytes() == qp["z"].tobytes()
    assert (
        sv.status.qp_status,
        sv.status.qp_raw_status,
        sv.status.qp_iter,
        sv.status.u_projected,
        np.float64(sv.status.u_violation).tobytes(),
    ) == snapshot(cs)["status"][1:]
    assert sv.u0().tobytes() == cs.u0().tobytes() and sv.states().tobytes() == cs.states().tobytes()
    # the next sample, a good state again, recovers from the kept plan without reset(), in C and Python alike
    for inp in inputs[5:7]:
        assert good_sample(cs, inp) == 0
        sv.set_road(inp[1])
        sv.set_opponents(inp[2])
        u = sv.step(inp[0])
        assert cs.status().u_violation <= 0.01 and np.all(np.isfinite(cs.states()))
        assert u.tobytes() == cs.u0().tobytes() and sv.states().tobytes() == cs.states().tobytes()
    if n_bad != 10.0:  # before the rule (no margin): OK with the huge step, the plan garbage
        monkeypatch.setattr(reference, "MAX_INPUT_VIOLATION", float("inf"))
        old = RtiSolver(build_ocp(pb))
        for inp in inputs[:4]:
            old.set_road(inp[1])
            old.set_opponents(inp[2])
            old.step(inp[0])
        old.set_road(road)
        old.set_opponents(opp)
        old.prepare()
        old.set_state(bad)
        old.feedback()
        assert old.status.exit_code == 0 and old.status.u_violation == pytest.approx(step_violation, rel=1e-12)


def test_ipm_backend_goes_through_the_same_rule(tmp_path, monkeypatch):
    """The input-bounds rule lives in the RTI core, not in a backend. The IPM keeps u_0 inside the box on these QPs
    (u_violation 0.0: it never meets the margin), so this build sets the margin below 0, which refuses every usable
    QP: the IPM's usable QPs end in ERR_QP_INPUT_BOUNDS with the step not taken, in the C and in Python alike."""
    import fcgen.codegen.generate as gen
    import fcgen.reference as reference
    from fcgen.dsl import Horizon, QpOptions
    from fcgen.presets import paper_problem

    pb = paper_problem("truck", "lifted", "ellipse", horizon=Horizon(N=10), qp=QpOptions(backend="ipm"))
    ocp = build_ocp(pb)
    sc = make_scenario("truck", 1, samples=2)
    opp = OpponentParams(pb, sc)
    samples = [
        (sc.x0.copy(), sc.road.window(sc.x0[0] - WINDOW_BEHIND, pb.road.samples), opp.horizon(j)) for j in range(2)
    ]
    normal = RtiSolver(ocp)  # the real margin: the IPM's QP is usable and inside the box, OK
    normal.set_road(samples[0][1])
    normal.set_opponents(samples[0][2])
    normal.step(samples[0][0])
    assert normal.status.exit_code == 0 and normal.status.u_violation == 0.0
    monkeypatch.setattr(reference, "MAX_INPUT_VIOLATION", -1.0)
    monkeypatch.setattr(gen, "MAX_INPUT_VIOLATION", -1.0)
    info = generate(pb, tmp_path / "g")
    header = info.out_dir / f"{info.name}_solver.h"
    assert f"#define {info.name.upper()}_MAX_INPUT_VIOLATION (-1.0)" in header.read_text()
    cs = CSolver(build(info.out_dir, verify=True), header=header)
    sv = RtiSolver(ocp)
    for j, (x0, road, o) in enumerate(samples):
        assert good_sample(cs, (x0, road, o)) == CODE["ERR_QP_INPUT_BOUNDS"]
        st = cs.status()
        assert st.qp_status in QP_USABLE and st.exit_code == CODE["ERR_QP_INPUT_BOUNDS"]
        assert np.all(cs.controls() == 0.0) and np.all(cs.u0() == 0.0)  # the initial guess kept (shifted)
        sv.set_road(road)
        sv.set_opponents(o)
        with pytest.raises(SolverError) as exc:
            sv.step(x0)
        assert exc.value.code == "ERR_QP_INPUT_BOUNDS" and sv.status.qp_status == st.qp_status
        assert sv.u0().tobytes() == cs.u0().tobytes() and sv.states().tobytes() == cs.states().tobytes(), j
