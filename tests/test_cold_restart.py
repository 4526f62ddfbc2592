"""The cold restart: after ``qp.cold_restart_after`` (K) unusable QPs in a row the next prepare cold-starts.

A kept plan that no longer meets the state is refused sample after sample (the defect: truck conventional
hyperplane, seed 6, OSQP capped at 60: refused from sample 14 on, until the plan shifted past its end braked the ego
into reverse). After K refusals in a row the solver does what reset() + set_state would: the cold-start guess from
the state, zero duals, a reset QP backend, the cold iteration budget. C == Python bitwise (the verification build).
"""

from __future__ import annotations

import shutil
from dataclasses import replace

import numpy as np
import pytest
from test_contract import _inputs, good_sample, snapshot

from fcgen.build import build
from fcgen.codegen.generate import generate
from fcgen.contract import EXIT_CODES
from fcgen.csolver import CSolver
from fcgen.dsl import ProblemError, QpOptions
from fcgen.ocp import build_ocp
from fcgen.presets import preset
from fcgen.reference import RtiSolver, SolverError
from fcgen.sim.closedloop import ReferenceController, run_closed_loop
from fcgen.sim.scenario import make_scenario

needs_cc = pytest.mark.skipif(any(shutil.which(t) is None for t in ("gcc", "make")), reason="needs gcc and make")

PRESET = "truck_lifted_ellipse"
OK = EXIT_CODES.index("OK")
BAD_N = 1e15  # an absurd lateral offset: on a warm start the capped QP's step is refused (ERR_QP_INPUT_BOUNDS)


@pytest.mark.parametrize("value", [-1, 1.5, True, "3", 1_000_001])
def test_cold_restart_after_is_validated(value):
    with pytest.raises(
        ProblemError, match=r"^qp\.cold_restart_after = .* is invalid: allowed an integer in \[0, 1e6\]"
    ):
        QpOptions(cold_restart_after=value)


def test_cold_restart_after_default_and_never():
    assert QpOptions().cold_restart_after == 3 and QpOptions(cold_restart_after=0).cold_restart_after == 0


@pytest.fixture(scope="module")
def inputs():
    return _inputs(seed=1, samples=9)


@pytest.fixture(scope="module")
def lib(tmp_path_factory):
    info = generate(preset(PRESET), tmp_path_factory.mktemp("restart") / "gen")
    header = info.out_dir / f"{info.name}_solver.h"
    assert f"#define {info.name.upper()}_COLD_RESTART_AFTER 3 " in header.read_text()
    return build(info.out_dir, verify=True), header


def _load(lib, tmp_path, tag: str) -> CSolver:
    d = tmp_path / tag
    d.mkdir()
    shutil.copy(lib[0], d / lib[0].name)
    return CSolver(d / lib[0].name, header=lib[1])


def _py_sample(sv: RtiSolver, inp, state=None) -> str:
    """One sample of the reference, the sample's state set before prepare (only a cold start reads it); state: the
    feedback's state (default the sample's); returns the exit code."""
    x0, road, opp = inp
    sv.set_road(road)
    sv.set_opponents(opp)
    sv.set_state(x0)
    sv.prepare()
    sv.set_state(x0 if state is None else state)
    try:
        sv.feedback()
    except SolverError as exc:
        return exc.code
    return "OK"


def _c_bad_sample(cs: CSolver, inp) -> int:
    x0, road, opp = inp
    assert cs.set_road(road) == 0 and cs.set_opponents(opp) == 0 and cs.prepare() == 0
    assert cs.set_state(np.r_[x0[0], BAD_N, x0[2:]]) == 0
    return cs.feedback()


K = 3


@needs_cc
def test_k_unusable_qps_then_a_cold_start_c_and_python(lib, tmp_path, inputs):
    """4 good samples, K absurd states (each refused), then the (K+1)-th prepare cold-starts: the prepared guess is
    the cold-start guess of that state (Python: bitwise a fresh solver's initial guess), and the whole sample is
    bitwise what reset() + set_state gives (C); C == Python bitwise; the sample after recovers."""
    auto, manual = _load(lib, tmp_path, "auto"), _load(lib, tmp_path, "manual")
    sv = RtiSolver(build_ocp(preset(PRESET)))
    for inp in inputs[:4]:
        assert good_sample(auto, inp) == OK and good_sample(manual, inp) == OK and _py_sample(sv, inp) == "OK"
    for j, inp in enumerate(inputs[4 : 4 + K]):
        rc = _c_bad_sample(auto, inp)
        assert _c_bad_sample(manual, inp) == rc != OK
        assert _py_sample(sv, inp, np.r_[inp[0][0], BAD_N, inp[0][2:]]) == EXIT_CODES[rc]
        st = auto.status()
        assert (st.qp_unusable_run, st.cold_restarts) == (j + 1, 0)
        assert (sv.status.qp_unusable_run, sv.status.cold_restarts) == (j + 1, 0)
        assert sv.states().tobytes() == auto.states().tobytes() and sv.u0().tobytes() == auto.u0().tobytes()
    # the (K+1)-th sample, a good state again (set before prepare, as after a reset)
    x0, road, opp = inputs[4 + K]
    stale = sv.w[sv.lay.var_shift]  # what the old rule would have prepared
    manual.reset()
    for cs in (auto, manual):
        assert cs.set_road(road) == 0 and cs.set_opponents(opp) == 0 and cs.set_state(x0) == 0
        assert cs.prepare() == 0
    assert (auto.status().qp_unusable_run, auto.status().cold_restarts) == (0, 1)
    assert (manual.status().qp_unusable_run, manual.status().cold_restarts) == (0, 0)
    sv.set_road(road)
    sv.set_opponents(opp)
    sv.set_state(x0)
    sv.prepare()
    assert sv.cold and (sv.status.qp_unusable_run, sv.status.cold_restarts) == (0, 1)
    assert np.all(sv.y_prep == 0.0)
    fresh = RtiSolver(build_ocp(preset(PRESET)))
    fresh.set_road(road)
    fresh.set_opponents(opp)
    fresh.set_state(x0)
    w_cold = fresh.initial_guess()[0]
    assert sv.w_prep.tobytes() == w_cold.tobytes() and not np.array_equal(sv.w_prep, stale)
    for cs in (auto, manual):
        assert cs.feedback() == OK
    sv.feedback()
    a, m = snapshot(auto), snapshot(manual)
    assert a == m  # the automatic cold start is the manual reset(), bitwise (status counters apart: not in snapshot)
    assert auto.status().qp_iter > preset(PRESET).qp.max_iter  # the cold budget (400) was used: more than 60
    assert sv.status.qp_iter == auto.status().qp_iter and sv.status.exit_code == OK
    assert sv.states().tobytes() == auto.states().tobytes() and sv.u0().tobytes() == auto.u0().tobytes()
    # the next sample: warm again, from the new plan
    inp = inputs[5 + K]
    assert good_sample(auto, inp) == OK and _py_sample(sv, inp) == "OK"
    assert auto.status().cold_restarts == sv.status.cold_restarts == 1
    assert sv.states().tobytes() == auto.states().tobytes()


def test_never_keeps_shifting_the_stale_plan(inputs):
    """K = 0: the old behaviour, the (K+1)-th prepare shifts the kept plan; the counter keeps counting."""
    pb = preset(PRESET)
    sv = RtiSolver(build_ocp(pb), qp=replace(pb.qp, cold_restart_after=0))
    for inp in inputs[:4]:
        assert _py_sample(sv, inp) == "OK"
    for j, inp in enumerate(inputs[4:8]):
        assert _py_sample(sv, inp, np.r_[inp[0][0], BAD_N, inp[0][2:]]) != "OK"
        assert (sv.status.qp_unusable_run, sv.status.cold_restarts) == (j + 1, 0)
    _x0, road, opp = inputs[8]
    stale = sv.w[sv.lay.var_shift]
    sv.set_road(road)
    sv.set_opponents(opp)
    sv.prepare()
    assert not sv.cold and sv.w_prep.tobytes() == stale.tobytes() and sv.status.cold_restarts == 0


def test_k_one_restarts_after_every_refusal(inputs):
    pb = preset(PRESET)
    sv = RtiSolver(build_ocp(pb), qp=replace(pb.qp, cold_restart_after=1))
    for inp in inputs[:4]:
        assert _py_sample(sv, inp) == "OK"
    x0, _road, _opp = inputs[4]
    assert _py_sample(sv, inputs[4], np.r_[x0[0], BAD_N, x0[2:]]) != "OK"
    assert sv.status.qp_unusable_run == 1
    assert _py_sample(sv, inputs[5]) == "OK"  # cold-started from the good state set before prepare
    assert sv.cold and sv.status.cold_restarts == 1 and sv.status.qp_unusable_run == 0


def _seed6(samples: int, k: int):
    pb = preset("truck_conventional_hyperplane")
    sv = RtiSolver(build_ocp(pb), qp=replace(pb.qp, cold_restart_after=k))
    log = run_closed_loop(
        pb, make_scenario("truck", 6, samples=samples), ReferenceController(sv.ocp, sv), exit_codes=True
    )
    return log, sv


def test_seed6_osqp_finishes_with_the_cold_restart():
    """The grid's failure (OSQP capped at 60): refused at samples 14-16, cold-started at 17, driving on. Without the
    rule (K = 0) every sample from 14 on is refused (the stale plan never meets the state again)."""
    log, sv = _seed6(40, 3)
    s, v = log.ego_frenet[:, 0], log.ego_frenet[:, 3]
    assert np.all(np.diff(s) > 0) and v.min() > 10.0
    bad = np.flatnonzero(log.exit_code)
    assert 1 <= len(bad) <= 2 * K and sv.status.cold_restarts >= 1
    assert np.all(log.exit_code[bad] == EXIT_CODES.index("ERR_QP_INPUT_BOUNDS"))
    old, _ = _seed6(40, 0)
    first = np.flatnonzero(old.exit_code)[0]
    assert first == bad[0] and np.all(old.exit_code[first:] != 0)
    assert s[-1] > old.ego_frenet[-1, 0]
