"""The run-time data of real roads and traffic (CommonRoad scenarios): per-sample road bounds (the road's drivable
band), a shape per opponent and the reference speed; the same in the Python reference and the generated C."""

from __future__ import annotations

import contextlib
import shutil
from dataclasses import replace

import numpy as np
import pytest

from fcgen import obstacles as obs
from fcgen.build import build
from fcgen.codegen.generate import generate
from fcgen.contract import EXIT_CODES
from fcgen.csolver import CSolver
from fcgen.dsl import Opponents, Vehicle
from fcgen.ocp import build_ocp
from fcgen.presets import preset
from fcgen.reference import RtiSolver, SolverError
from fcgen.road import Road, straight_road
from fcgen.sim.closedloop import Plant, ReferenceController

pytestmark = pytest.mark.skipif(any(shutil.which(t) is None for t in ("gcc", "make")), reason="needs gcc and make")

SAFE_EL = preset("car_lifted_ellipse_ipm_safe")  # Ellipse(shape="minkowski"): shapes carry the semi-axes
PAPER_CC = preset("car_direct_elimination_circles")  # the paper's covering circles, OSQP
CONV = preset("car_conventional_circles")  # the conventional fit around each opponent's shape
BEHIND = 20.0


def _road(pb, band=None, length: float | None = None) -> Road:
    """A straight road from s = -20 m (the solver's whole road size, or ``length``); ``band(s) -> (n_min, n_max)``."""
    r = straight_road(length=length or (pb.road.samples - 1) * pb.road.ds, ds=pb.road.ds, s0=-BEHIND)
    if band is None:
        return r
    lo, hi = band(r.s)
    return Road(r.s0, r.ds, r.kappa, r.phi, r.gx, r.gy, lo, hi)


def _far(pb) -> np.ndarray:
    opp = np.zeros((pb.horizon.N + 1, pb.opponents.count, 3))
    opp[..., 0], opp[..., 1] = -1000.0, 500.0
    return opp


@pytest.fixture(scope="module")
def c_solvers(tmp_path_factory):
    out = {}
    for pb in (SAFE_EL, PAPER_CC, CONV):
        gen = generate(pb, tmp_path_factory.mktemp(pb.name) / "s")
        out[pb.name] = CSolver(build(gen.out_dir, verify=True))
    return out


def _code(name: str) -> int:
    return EXIT_CODES.index(name)


# --- the road's band -------------------------------------------------------------------------------------------


def _ramp(s):
    """n_min rises 1 cm per metre from -3 m at s = -20; n_max 3 m."""
    return -3.0 + 0.01 * (s + BEHIND), np.full_like(s, 3.0)


@pytest.mark.parametrize("pb", [SAFE_EL, PAPER_CC], ids=lambda p: p.name)
def test_band_rows_take_the_band_at_each_stage_s(pb, c_solvers):
    """After prepare every n-bound row's lower bound is n_min(s_k) / 5 - g (the hand formula of the linear ramp at the
    guess's s_k), its upper 3 / 5 - g; the C builds the same l and u."""
    road = _road(pb, _ramp)
    x0 = np.array([0.0, 0.5, 0.0, 15.0, 0.0])
    sv = RtiSolver(build_ocp(pb))
    sv.set_road(road)
    sv.set_opponents(_far(pb))
    sv.set_state(x0)
    sv.prepare()
    lay = sv.lay
    assert len(lay.band_rows) >= pb.horizon.N  # every stage 1..N bounds n
    for row, k, side in lay.band_rows:
        s_k = sv.w_prep[lay.s_vars[k]]
        edge = -3.0 + 0.01 * (s_k + BEHIND) if side == 0 else 3.0
        got = (sv.l if side == 0 else sv.u)[row] + sv.g[row]
        assert got == pytest.approx(edge / 5.0, abs=1e-12)
    cs = c_solvers[pb.name]
    assert cs.init() == 0 and cs.set_road(road) == 0 and cs.set_opponents(_far(pb)) == 0
    assert cs.set_state(x0) == 0 and cs.prepare() == 0
    qp = cs.get_qp()
    np.testing.assert_allclose(qp["l"], sv.l, rtol=0, atol=1e-12)
    np.testing.assert_allclose(qp["u"], sv.u, rtol=0, atol=1e-12)
    # set_road without a band: the problem's constant bounds again
    assert cs.set_road(_road(pb)) == 0 and cs.prepare() == 0  # prepared: a no-op; reset to prepare again
    cs.reset()
    assert cs.prepare() == 0
    qp = cs.get_qp()
    b = pb.bounds
    for row, _, side in lay.band_rows:  # the same cold guess, so the same g
        edge = b.n_min if side == 0 else b.n_max
        assert (qp["l"] if side == 0 else qp["u"])[row] == pytest.approx(edge / 5.0 - sv.g[row], abs=1e-12)


def _narrowing(s):
    """The left edge comes in from 3 m to 0.5 m between s = 30 and 50 m; the right edge at -3 m."""
    hi = np.interp(s, [30.0, 50.0], [3.0, 0.5])
    return np.full_like(s, -3.0), hi


def _loop(pb, controller, road, x0, samples: int, shapes=None) -> np.ndarray:
    plant = Plant(pb, build_ocp(pb).road_params.samples)
    if shapes is not None:
        assert controller.set_opponent_shapes(shapes) == 0
    xs = [x0]
    for _ in range(samples):
        x = xs[-1]
        r = controller.step(x, road.window(x[0] - 10.0, pb.road.samples), _far(pb))
        assert r.exit_code == 0
        xs.append(plant.step(x, r.u, road))
    return np.array(xs)


def test_the_closed_loop_keeps_a_narrowing_band(c_solvers):
    """The ego drives at n = 2 towards a left edge that comes in to 0.5 m: the plan's hard bound moves it right in
    time; every sample past s = 50 m has n <= 0.5 (+ the plant's rounding); the C drives the same states."""
    pb = PAPER_CC
    road = _road(pb, _narrowing, length=800.0)
    x0 = np.array([0.0, 2.0, 0.0, 15.0, 0.0])
    xs = _loop(pb, ReferenceController(build_ocp(pb)), road, x0, 40)
    past = xs[:, 0] > 50.0 + 2.0  # the chassis' reference point past the narrowing
    assert past.sum() >= 10
    assert np.all(xs[past, 1] <= 0.5 + 1e-6)
    assert xs[0, 1] == 2.0 and np.all(xs[:, 1] >= -3.0 - 1e-6)
    cs = c_solvers[pb.name]
    assert cs.init() == 0
    xc = _loop(pb, cs, road, x0, 40)
    np.testing.assert_allclose(xc, xs, rtol=0, atol=1e-8)


# --- a shape per opponent ----------------------------------------------------------------------------------------


def _python_check(pb, road, x0, opp, shapes):
    sv = RtiSolver(build_ocp(pb))
    sv.set_road(road)
    sv.set_opponents(opp)
    if shapes is not None:
        sv.set_opponent_shapes(shapes)
    with contextlib.suppress(SolverError):
        sv.step(x0)
    return sv.status


def test_a_shape_set_at_run_time_gives_the_hand_derived_clearance(c_solvers):
    """A 10 m x 3 m box whose pose is its centre (offset 0) stands 5 m left of the ego's straight plan: the plan passes
    it 5 - 0.95 - 1.5 = 2.55 m apart (the problem's own car: 3.1 m); Python and C agree."""
    pb = SAFE_EL
    road = _road(pb)
    x0 = np.array([0.0, 0.0, 0.0, 20.0, 0.0])
    opp = _far(pb)
    opp[:, 0, 0], opp[:, 0, 1] = 20.0 + 14.0, 5.0  # the ego's chassis centre (s = 1.3) is x = 21.3
    shapes = obs.opponent_shape(pb.obstacles, pb.ego, 10.0, 3.0, 0.0)
    all_shapes = np.tile(shapes, (pb.opponents.count, 1))
    st = _python_check(pb, road, x0, opp, all_shapes)
    assert st.plan_clearance == pytest.approx(2.55, abs=0.02)
    cs = c_solvers[pb.name]
    assert cs.init() == 0 and cs.set_road(road) == 0 and cs.set_opponents(opp) == 0
    assert cs.set_opponent_shapes(all_shapes) == 0 and cs.set_state(x0) == 0 and cs.prepare() == 0
    cs.feedback()
    assert cs.status().plan_clearance == pytest.approx(st.plan_clearance, abs=1e-9)
    # init: the problem's vehicle again (its pose is the rear axle: its centre 1.7 m further on)
    assert cs.init() == 0 and cs.set_road(road) == 0 and cs.set_opponents(opp) == 0
    assert cs.set_state(x0) == 0 and cs.prepare() == 0
    cs.feedback()
    assert cs.status().plan_clearance == pytest.approx(3.1, abs=0.02)


@pytest.mark.parametrize(
    "name",
    [
        "car_direct_elimination_circles",
        "car_lifted_ellipse",
        "car_lifted_hyperplane",
        "truck_direct_elimination_ellipse_safe",
        "car_lifted_circles_safe",
    ],
)
def test_shape_values_give_the_rows_of_a_problem_built_for_that_vehicle(name):
    """Second method: the stage rows with an opponent's shape given at run time equal the rows of the same problem
    generated for an opponent vehicle of that size (at the same guess and poses)."""
    pb = preset(name)
    van = Vehicle(l_f=1.9, l_r=1.6, l_f_ch=2.6, l_r_ch=2.6, w_ch=2.2)
    pb_van = pb.with_(opponents=Opponents(pb.opponents.count, van))
    road = _road(pb)
    x0 = np.array([0.0, 1.0, 0.05, 15.0, 0.01])
    opp = _far(pb)
    opp[:, 1, 0], opp[:, 1, 1] = 45.0, -2.0
    outs = []
    for p, shapes in (
        (pb, np.tile(obs.vehicle_shape(pb.obstacles, pb.ego, van), (pb.opponents.count, 1))),
        (pb_van, None),
    ):
        sv = RtiSolver(build_ocp(p))
        sv.set_road(road)
        sv.set_opponents(opp)
        if shapes is not None:
            sv.set_opponent_shapes(shapes)
        sv.set_state(x0)
        sv.prepare()
        outs.append(sv.g)
    np.testing.assert_allclose(outs[0], outs[1], rtol=0, atol=1e-12)
    assert not np.allclose(outs[0], _default_rows(pb, road, opp, x0))  # the shape does enter the rows


def _default_rows(pb, road, opp, x0):
    sv = RtiSolver(build_ocp(pb))
    sv.set_road(road)
    sv.set_opponents(opp)
    sv.set_state(x0)
    sv.prepare()
    return sv.g


def test_c_and_python_run_in_lockstep_with_a_band_and_shapes(c_solvers):
    """A band that narrows and three opponents of three sizes (one standing in the ego's lane ahead): 30 samples,
    the C's states equal the reference's to 1e-8 while the ego moves (the conventional fit too). Stopped before the
    standing opponent (|v| < 2.5 m/s) the steering barely acts and the QP is flat in it (its steering rate jumps
    between its bounds): the two solvers' rounding moves delta by up to 1e-6 rad there (measured; 1.4e-8 rad at 2.3 m/s
    with the safe presets' brake memory, the guard's flags equal), so those samples are held to 1e-5."""
    for pb in (SAFE_EL, PAPER_CC, CONV):
        road = _road(pb, _narrowing, length=800.0)
        shapes = np.array(
            [
                obs.opponent_shape(pb.obstacles, pb.ego, ln, wd, off)
                for ln, wd, off in ((4.5, 1.8, 0.0), (12.0, 2.5, 3.0), (6.0, 2.1, 1.0))
            ]
        )
        x0 = np.array([0.0, 2.0, 0.0, 15.0, 0.0])
        ref = ReferenceController(build_ocp(pb))
        cs = c_solvers[pb.name]
        assert cs.init() == 0
        xs = [x0.copy()]
        xc = [x0.copy()]
        plant = Plant(pb, build_ocp(pb).road_params.samples)
        assert ref.set_opponent_shapes(shapes) == 0 and cs.set_opponent_shapes(shapes) == 0
        for j in range(30):
            opp = _far(pb)
            opp[:, 0, 0], opp[:, 0, 1] = 80.0, -1.0  # standing in the way (its centre)
            opp[:, 1, 0] = 20.0 + 12.0 * (j * pb.horizon.dt + np.arange(pb.horizon.N + 1) * pb.horizon.interval)
            opp[:, 1, 1] = -1.5
            for xl, ctl in ((xs, ref), (xc, cs)):
                x = xl[-1]
                r = ctl.step(x, road.window(x[0] - 10.0, pb.road.samples), opp)
                assert r.exit_code in (0, _code("ERR_QP_INPUT_BOUNDS"))
                xl.append(plant.step(x, r.u, road))
            tol = 1e-8 if abs(xs[-2][3]) >= 2.5 else 1e-5
            assert np.max(np.abs(xc[-1] - xs[-1])) < tol, (pb.name, j)


# --- refused inputs ----------------------------------------------------------------------------------------------


def test_bad_bands_and_shapes_are_refused_and_change_nothing(c_solvers):
    pb = SAFE_EL
    cs = c_solvers[pb.name]
    ocp = build_ocp(pb)
    sv = RtiSolver(ocp)
    n = pb.road.samples
    b = pb.bounds
    assert cs.init() == 0
    assert cs.set_road_bounds(np.full(n, -1.0), np.full(n, 1.0)) == _code("ERR_ROAD_BOUNDS")  # no road yet
    road = _road(pb)
    assert cs.set_road(road) == 0
    for lo, hi, code in (
        (b.n_min - 0.1, 1.0, "ERR_ROAD_BOUNDS"),
        (-1.0, b.n_max + 0.1, "ERR_ROAD_BOUNDS"),
        (1.0, 1.0, "ERR_ROAD_BOUNDS"),
        (np.nan, 1.0, "ERR_NONFINITE_ROAD"),
    ):
        assert cs.set_road_bounds(np.full(road.size, lo), np.full(road.size, hi)) == _code(code)
    with pytest.raises(SolverError) as e:
        sv.set_road(replace(road, n_min=np.full(road.size, b.n_min - 0.1), n_max=np.full(road.size, 1.0)))
    assert e.value.code == "ERR_ROAD_BOUNDS" and "n_min" in str(e.value)
    with pytest.raises(ValueError, match="n_min"):
        replace(road, n_min=np.full(road.size, 1.0), n_max=np.full(road.size, 1.0))
    good = np.tile(obs.opponent_shape(pb.obstacles, pb.ego, 5.0, 2.0, 0.0), (pb.opponents.count, 1))
    bad_width = good.copy()
    bad_width[1, 1] = 0.0
    small_axis = good.copy()
    small_axis[2, 3] = small_axis[2, 0] / 2  # a < L/2 + r: cannot contain the grown rectangle
    for shapes in (bad_width, small_axis, np.where(good > 0, np.inf, good)):
        assert cs.set_opponent_shapes(shapes) == _code("ERR_OPP_SHAPE")
        with pytest.raises(SolverError) as e:
            sv.set_opponent_shapes(shapes)
        assert e.value.code == "ERR_OPP_SHAPE"
    np.testing.assert_array_equal(sv.opp_shape, ocp.default_shapes())  # nothing changed
    with pytest.raises(ValueError, match=r"opponent shape width = 0.0 is invalid: allowed in \[0.1, 100.0\] m"):
        obs.opponent_shape(pb.obstacles, pb.ego, 5.0, 0.0, 0.0)


def test_the_conventional_fit_takes_the_shape():
    """Second method: the conventional formulation fits its Frenet boxes around an opponent of the given shape
    (its points on the shape's edges, their spacing, its reach): the fitted boxes equal those of the same problem
    generated for an opponent vehicle of that size; the problem's own vehicle fits other boxes."""
    pb = preset("car_conventional_ellipse")
    van = Vehicle(l_f=1.9, l_r=1.6, l_f_ch=2.6, l_r_ch=2.6, w_ch=2.2)
    pb_van = pb.with_(opponents=Opponents(pb.opponents.count, van))
    road = _road(pb)
    opp = _far(pb)
    opp[:, 1, 0], opp[:, 1, 1], opp[:, 1, 2] = 45.0, -2.0, 0.1
    opp[:, 2, 0], opp[:, 2, 1] = 70.0, 3.0
    boxes = []
    for p, shapes in (
        (pb, np.tile(obs.vehicle_shape(pb.obstacles, pb.ego, van), (pb.opponents.count, 1))),
        (pb_van, None),
        (pb, None),
    ):
        sv = RtiSolver(build_ocp(p))
        sv.set_road(road)
        sv.set_opponents(opp)
        if shapes is not None:
            sv.set_opponent_shapes(shapes)
        sv.set_state(np.array([0.0, 1.0, 0.0, 15.0, 0.0]))
        sv.prepare()
        boxes.append(sv.opp_stage.copy())
    np.testing.assert_allclose(boxes[0], boxes[1], rtol=0, atol=1e-12)
    assert np.max(np.abs(boxes[0] - boxes[2])) > 0.1


# --- the reference speed -----------------------------------------------------------------------------------------


def test_set_reference_moves_the_tracking_reference(c_solvers):
    """set_reference(10, 1.5): every stage's x_ref is [s0 + k dt 10, 1.5, 0, 10, 0] (hand formula), the C's stage
    parameters and QP the same; the closed loop then settles at 10 m/s and moves towards n = 1.5 (the problem's own
    reference: 40 m/s, capped by the terminal bound v_N_max = 15, and n = 0)."""
    pb = PAPER_CC
    road = _road(pb, length=1500.0)
    x0 = np.array([0.0, 0.0, 0.0, 20.0, 0.0])
    ocp = build_ocp(pb)
    sv = RtiSolver(ocp)
    sv.set_road(road.window(-10.0, pb.road.samples))
    sv.set_opponents(_far(pb))
    sv.set_reference(10.0, 1.5)
    sv.set_state(x0)
    sv.prepare()
    for k in (0, 7, pb.horizon.N):
        np.testing.assert_array_equal(sv.P[k, ocp.p_ref], [x0[0] + k * pb.horizon.dt * 10.0, 1.5, 0.0, 10.0, 0.0])
    cs = c_solvers[pb.name]
    assert cs.init() == 0 and cs.set_road(road.window(-10.0, pb.road.samples)) == 0
    assert cs.set_opponents(_far(pb)) == 0 and cs.set_reference(10.0, 1.5) == 0
    assert cs.set_state(x0) == 0 and cs.prepare() == 0
    np.testing.assert_allclose(cs.get_qp()["q"], sv.q, rtol=0, atol=1e-12)
    for bad in ((-1.0, 0.0), (np.nan, 0.0), (20.0, np.inf)):
        assert cs.set_reference(*bad) == _code("ERR_REFERENCE")
        with pytest.raises(SolverError):
            sv.set_reference(*bad)
    ctl = ReferenceController(ocp)
    assert ctl.set_reference(10.0, 1.5) == 0
    xs = _loop(pb, ctl, road, x0, 60)
    assert xs[-1, 3] == pytest.approx(10.0, abs=0.3)
    assert 0.8 < xs[-1, 1] < 1.5 + 1e-3 and np.all(np.diff(xs[30:, 1]) > 0.0)
