"""The C API's contract on every entry, and the Python reference's alike: inputs checked against documented ranges
before anything changes, status.exit_code describing the last call, getters refusing NULL, a refused prepare keeping
the opponent fit, and a plan check that covers every stage whatever road was set after prepare (each a finding of
the random-call fuzzer, tests/c/fuzz_contract.c)."""

from __future__ import annotations

import contextlib
import math
import shutil

import numpy as np
import pytest

from fcgen.build import build
from fcgen.codegen.generate import generate
from fcgen.contract import EXIT_CODES, INPUT_RANGES
from fcgen.csolver import CSolver
from fcgen.ocp import build_ocp
from fcgen.presets import preset
from fcgen.reference import RtiSolver, SolverError
from fcgen.road import Road, straight_road

pytestmark = pytest.mark.skipif(any(shutil.which(t) is None for t in ("gcc", "make")), reason="needs gcc and make")

LIFTED = preset("truck_lifted_ellipse_ipm_safe")
CONVENTIONAL = preset("truck_conventional_circles")
OK, NULL = 0, EXIT_CODES.index("ERR_NULL_POINTER")


def code(name: str) -> int:
    return EXIT_CODES.index(name)


@pytest.fixture(scope="module")
def lifted(tmp_path_factory) -> CSolver:
    return CSolver(build(generate(LIFTED, tmp_path_factory.mktemp("lifted") / "s").out_dir))


@pytest.fixture(scope="module")
def conventional(tmp_path_factory) -> CSolver:
    return CSolver(build(generate(CONVENTIONAL, tmp_path_factory.mktemp("conv") / "s").out_dir))


def _road(pb) -> Road:
    return straight_road(length=(pb.road.samples - 1) * pb.road.ds, ds=pb.road.ds, s0=-20.0)


def _opponents(pb, ahead: float, n: float = 0.0) -> np.ndarray:
    """Opponent 0 standing `ahead` metres in front of the ego (s = 0 is x = 0 on the straight road), the others far."""
    opp = np.zeros((pb.horizon.N + 1, pb.opponents.count, 3))
    opp[..., 0], opp[..., 1] = -1000.0, 500.0
    opp[:, 0, 0], opp[:, 0, 1] = ahead, n
    return opp


X0 = np.array([0.0, 0.0, 0.0, 20.0, 0.0])


# -- status.exit_code describes the last call ------------------------------------------------------------------------
def test_an_accepted_call_sets_exit_code_ok(lifted):
    cs = lifted
    assert cs.init() == OK
    assert cs._fns["set_state"](None) == code("ERR_NO_STATE") and cs.status().exit_code == code("ERR_NO_STATE")
    assert cs.set_state(X0) == OK and cs.status().exit_code == OK  # was: still ERR_NO_STATE
    assert cs.set_reference(-1.0, 0.0) == code("ERR_REFERENCE")
    assert cs.set_road(_road(LIFTED)) == OK and cs.status().exit_code == OK
    assert cs.set_opponents(_opponents(LIFTED, 80.0)) == OK and cs.prepare() == OK
    assert cs.set_state([math.nan] * 5) == code("ERR_NONFINITE_STATE")
    assert cs.prepare() == OK and cs.status().exit_code == OK  # the no-op prepare is an accepted call too
    assert cs.set_state([math.nan] * 5) == code("ERR_NONFINITE_STATE")
    cs._fns["set_clock"](None)
    assert cs.status().exit_code == OK


def test_the_reference_sets_exit_code_ok_after_an_accepted_call():
    sv = RtiSolver(build_ocp(LIFTED))
    with pytest.raises(SolverError):
        sv.set_state([math.nan] * 5)
    assert sv.status.exit_code == code("ERR_NONFINITE_STATE")
    sv.set_state(X0)
    assert sv.status.exit_code == OK
    sv.set_road(_road(LIFTED))
    sv.set_opponents(_opponents(LIFTED, 80.0))
    sv.prepare()
    with pytest.raises(SolverError):
        sv.set_reference(math.inf, 0.0)
    sv.prepare()  # no-op
    assert sv.status.exit_code == OK


# -- getters given NULL ------------------------------------------------------------------------------------------------
@pytest.mark.parametrize("getter", ["get_u0", "get_states", "get_controls", "get_opp_params", "get_status"])
def test_a_getter_given_null_returns_an_error_and_changes_nothing(lifted, getter):
    cs = lifted
    cs.init()
    assert cs.set_state([math.nan] * 5) == code("ERR_NONFINITE_STATE")  # a status to keep
    before = cs.status()
    assert cs._fns[getter](None) == NULL  # was: a segmentation fault
    assert cs.status() == before


def test_get_qp_accepts_null_pointers(lifted):
    assert lifted._fns["get_qp"](*([None] * 7)) == OK


# -- input ranges ------------------------------------------------------------------------------------------------------
def test_road_spacing_outside_its_range_is_refused(lifted):
    cs, road = lifted, _road(LIFTED)
    cs.init()
    assert cs.set_road(road) == OK
    for ds in (1e-30, 0.0, -1.0, 0.999 * INPUT_RANGES.ds_min, 1.001 * INPUT_RANGES.ds_max, 1e30):
        assert cs.set_road_raw(0.0, ds, road.kappa, road.phi, road.gx, road.gy) == code("ERR_ROAD_SIZE"), ds
        with pytest.raises(ValueError, match=r"road\.ds"):
            Road(0.0, ds, road.kappa, road.phi, road.gx, road.gy)
    for ds in (INPUT_RANGES.ds_min, INPUT_RANGES.ds_max):
        assert cs.set_road_raw(0.0, ds, road.kappa, road.phi, road.gx, road.gy) == OK, ds


def _shape(pb, **kw) -> np.ndarray:
    ocp = build_ocp(pb)
    v = ocp.default_shapes()
    names = ("length", "width", "offset", "a", "b")
    for k, x in kw.items():
        if names.index(k) < v.shape[1]:
            v[:, names.index(k)] = x
    return v


@pytest.mark.parametrize(
    "bad",
    [
        {"length": 1e30, "a": 1e30},  # F1: accepted (> 0), then UB in the conventional fit's floor
        {"length": 0.05},
        {"width": 101.0, "b": 101.0},
        {"offset": 1e30},  # accepted without a word before
        {"offset": -20.0},  # behind the chassis of a truck shorter than 40 m
        {"a": 1e3},
    ],
)
def test_shapes_outside_their_ranges_are_refused_by_the_c_and_the_reference(lifted, bad):
    cs = lifted
    cs.init()
    v = _shape(LIFTED, **bad)
    assert cs.set_opponent_shapes(v) == code("ERR_OPP_SHAPE")
    sv = RtiSolver(build_ocp(LIFTED))
    with pytest.raises(SolverError, match="ERR_OPP_SHAPE"):
        sv.set_opponent_shapes(v)


def test_a_shape_at_the_edges_of_its_ranges_is_accepted(lifted):
    r = 0.5 * INPUT_RANGES.shape_max
    v = _shape(LIFTED, length=INPUT_RANGES.shape_max, width=INPUT_RANGES.shape_min, offset=r, a=INPUT_RANGES.shape_max)
    lifted.init()
    assert lifted.set_opponent_shapes(v) == OK
    RtiSolver(build_ocp(LIFTED)).set_opponent_shapes(v)


@pytest.mark.parametrize("v_ref, n_ref", [(-1.0, 0.0), (101.0, 0.0), (10.0, 1e30), (10.0, math.nan)])
def test_a_reference_outside_its_range_is_refused(lifted, v_ref, n_ref):
    lifted.init()
    assert lifted.set_reference(v_ref, n_ref) == code("ERR_REFERENCE")
    with pytest.raises(SolverError, match="ERR_REFERENCE"):
        RtiSolver(build_ocp(LIFTED)).set_reference(v_ref, n_ref)


# -- a refused prepare keeps the opponent fit (conventional formulation) ---------------------------------------------
def test_a_refused_prepare_leaves_the_opponent_fit_as_it_was(conventional):
    cs, pb = conventional, CONVENTIONAL
    road = _road(pb)
    cs.init()
    assert cs.set_road(road) == OK and cs.set_opponents(_opponents(pb, 40.0)) == OK and cs.set_state(X0) == OK
    assert cs.prepare() == OK
    cs.feedback()
    fit = cs.get_opp_params()
    assert np.all(np.isfinite(fit)) and np.any(fit != 0.0)
    assert cs.set_opponents(_opponents(pb, 25.0, 1.0)) == OK
    assert cs.set_road(road.window(-10.0, 12)) == OK  # too short for the horizon
    assert cs.prepare() == code("ERR_ROAD_WINDOW")
    assert np.array_equal(cs.get_opp_params(), fit)  # was: the refused call's fit
    sv = RtiSolver(build_ocp(pb))
    sv.set_road(road)
    sv.set_opponents(_opponents(pb, 40.0))
    sv.set_state(X0)
    sv.prepare()
    with contextlib.suppress(SolverError):  # an unusable QP consumes the sample too
        sv.feedback()
    kept = sv.opp_stage.copy()
    sv.set_opponents(_opponents(pb, 25.0, 1.0))
    sv.set_road(road.window(-10.0, 12))
    with pytest.raises(SolverError, match="ERR_ROAD_WINDOW"):
        sv.prepare()
    assert np.array_equal(sv.opp_stage, kept)


# -- the plan check covers every stage whatever road was set after prepare ------------------------------------------
def _c_sample(cs: CSolver, pb, road_after: Road | None):
    cs.init()
    assert cs.set_road(_road(pb)) == OK and cs.set_opponents(_opponents(pb, 30.0)) == OK
    assert cs.set_state(X0) == OK and cs.prepare() == OK
    if road_after is not None:
        assert cs.set_road(road_after) == OK
    rc = cs.feedback()
    return rc, cs.status(), cs.u0()


def _py_sample(pb, road_after: Road | None):
    sv = RtiSolver(build_ocp(pb))
    sv.set_road(_road(pb))
    sv.set_opponents(_opponents(pb, 30.0))
    sv.set_state(X0)
    sv.prepare()
    if road_after is not None:
        sv.set_road(road_after)
    with contextlib.suppress(SolverError):
        sv.feedback()
    return sv.status, sv.u0()


def test_the_plan_check_reacts_the_same_with_the_road_set_before_or_after_prepare(lifted):
    pb = LIFTED
    short = _road(pb).window(-10.0, 12)  # covers the state's window, not the plan's stages
    rc, full, u_full = _c_sample(lifted, pb, None)
    rc_after, after, u_after = _c_sample(lifted, pb, short)
    assert rc == rc_after == OK
    assert full.plan_clearance < 0.0 and 1 <= full.plan_clearance_stage <= pb.horizon.N, full  # the opponent is met
    assert full.plan_reaction == 1 and u_full[0] < 0.0  # and the ego brakes
    key = ("plan_clearance", "plan_clearance_stage", "plan_reaction")
    assert [getattr(after, k) for k in key] == [getattr(full, k) for k in key]  # was: +6.9 m at stage 1, no reaction
    assert np.array_equal(u_after, u_full)
    py_full, pu_full = _py_sample(pb, None)
    py_after, pu_after = _py_sample(pb, short)
    assert [getattr(py_after, k) for k in key] == [getattr(py_full, k) for k in key]
    assert np.array_equal(pu_after, pu_full)
    assert py_full.plan_clearance_stage == full.plan_clearance_stage and py_full.plan_reaction == 1
    assert py_full.plan_clearance == pytest.approx(full.plan_clearance, abs=1e-6)


# -- the delay compensation's line: only a feedback that consumed its sample moves it ---------------------------------
@pytest.fixture(scope="module")
def delayed(tmp_path_factory) -> CSolver:
    return CSolver(build(generate(LIFTED.with_(delay=2), tmp_path_factory.mktemp("delay") / "s").out_dir))


def _delayed_run(cs: CSolver, refused: list | None) -> list:
    """Five samples on a straight road, the ego at 20 m/s; before the fourth feedback the states given, each
    feedback on them refused."""
    pb, out = LIFTED, []
    assert cs.init() == OK and cs.set_road(_road(pb)) == OK and cs.set_opponents(_opponents(pb, 60.0)) == OK
    for k in range(5):
        x = X0 + np.array([2.0 * k, 0.1, 0.0, 0.0, 0.0])
        assert cs.set_state(x) == OK and cs.prepare() == OK
        if k == 3 and refused:
            for x_bad in refused:  # finite, so accepted; the prediction leaves the road or overflows
                assert cs.set_state(x_bad) == OK
                assert cs.feedback() in (code("ERR_ROAD_WINDOW"), code("ERR_NONFINITE_STATE")), x_bad
            assert cs.set_state(x) == OK
        assert cs.feedback() == OK
        out.append((cs.u0().copy(), cs.states().copy()))
    return out


def test_a_feedback_refused_by_the_delay_prediction_leaves_the_delay_line(delayed):
    """A state whose prediction over the delay leaves the road (or overflows) refuses the feedback before its QP: the
    controls the vehicle has yet to apply stay as they were, so the samples after it are bit for bit the same."""
    plain = _delayed_run(delayed, None)
    fast = X0 + np.array([6.0, 0.1, 0.0, 1e6, 0.0])  # on the road; a sample later 1e5 m further: off it
    huge = X0 + np.array([6.0, 0.1, 0.0, 1e300, 0.0])
    refused = _delayed_run(delayed, [fast, huge])
    for (u_a, x_a), (u_b, x_b) in zip(plain, refused, strict=True):
        assert np.array_equal(u_a, u_b) and np.array_equal(x_a, x_b)
    assert not np.array_equal(plain[3][1][0], plain[2][1][0])  # the samples move: the check can see a change
