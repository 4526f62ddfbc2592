"""The a_lat guard (``PlanCheck.a_lat_guard``): the control the solver hands out keeps the plant's next |a_lat| within
``bounds.a_lat_max``, whatever the plan says (its a_lat rows are soft).

Independent expectations: the steering rate and the braking force worked out by hand for a state the rate bound
cannot bring back; the physical bound itself on closed loops whose plans exceed it (the paper's weights make the a_lat
row a cost: 40-56 % of its samples above the bound) and where the guard acted the next sample at exactly
``a_lat_max - a_lat_margin`` (the closed form of the rate that ends there); the generated C equal to the Python
reference sample by sample.
"""

from __future__ import annotations

import shutil
from dataclasses import replace

import numpy as np
import pytest
from test_plan_check import _c, _inputs, _python

from fcgen.build import build
from fcgen.codegen.generate import generate
from fcgen.csolver import CSolver
from fcgen.ocp import build_ocp
from fcgen.presets import preset
from fcgen.sim.closedloop import ReferenceController, run_closed_loop
from fcgen.sim.scenario import make_scenario

pytestmark = pytest.mark.skipif(any(shutil.which(t) is None for t in ("gcc", "make")), reason="needs gcc and make")

PAPER = preset("car_direct_elimination_ellipse")  # the paper's weights: the a_lat row is a cost
GUARDED = PAPER.with_(
    name="car_guarded",
    plan_check=replace(PAPER.plan_check, a_lat_guard=True),
    bounds=replace(PAPER.bounds, a_lat_margin=0.05),
)  # the guard needs a margin
SEED = 3


@pytest.fixture(scope="module")
def c_guarded(tmp_path_factory):
    gen = generate(GUARDED, tmp_path_factory.mktemp("guard") / "s")
    return CSolver(build(gen.out_dir, verify=True))


def _a_lat(x: np.ndarray, pb) -> np.ndarray:
    return x[..., 3] ** 2 * np.tan(x[..., 4]) / pb.ego.l


def test_a_state_the_steering_rate_cannot_bring_back_makes_the_solver_brake(c_guarded):
    """20 m/s at the steering bound (0.3 rad): |a_lat| = 400 tan(0.3) / 3.4 = 36.4 m/s^2. One sample at the rate bound
    takes delta to 0.261 (31 m/s^2 at about 20 m/s), far from the 0.042 rad that 4.95 m/s^2 allows: the guard steers at
    -r_max and brakes with F_d = -min(F_d_max, m v0 / dt) = -1e4 N (status 2), in C and in Python alike."""
    pb = GUARDED
    road, _, opp = _inputs(pb, (500.0, 500.0))  # every opponent far away
    x0 = np.array([0.0, 0.0, 0.0, 20.0, 0.3])
    results = (_python(pb, road, x0, opp), _c(c_guarded, road, x0, opp))
    expected = [-pb.bounds.F_d_max, -pb.bounds.r_max]
    for st, u in results:
        assert st.a_lat_guard == 2
        np.testing.assert_array_equal(u, expected)


def _closed_loop(pb, controller):
    sc = make_scenario("car", SEED, n_opp=pb.opponents.count, samples=200, dt=pb.horizon.dt)
    return run_closed_loop(pb, sc, controller=controller)


def test_plans_above_the_bound_are_applied_within_it_in_c_as_in_python(c_guarded):
    """The paper's car DE EL (with the margin), campaign seed 3: without the guard the applied |a_lat| exceeds 5 m/s^2
    by far; with it every sample stays within a_lat_max, the guard acts, and where it did not need the rate bound the
    next sample's |a_lat| is a_lat_max - a_lat_margin. The C's controls, states and guard flags equal the Python
    reference's."""
    unguarded = GUARDED.with_(plan_check=replace(GUARDED.plan_check, a_lat_guard=False))
    free = _closed_loop(unguarded, ReferenceController(build_ocp(unguarded)))
    assert np.max(np.abs(free.a_lat)) > 5.5
    flags: dict[str, list[int]] = {}

    class Recorder:  # a controller that records each sample's guard flag
        def __init__(self, inner):
            self.inner, self.kind = inner, inner.kind

        def step(self, x, road, opp):
            r = self.inner.step(x, road, opp)
            flags.setdefault(self.kind, []).append(r.a_lat_guard)
            return r

    assert c_guarded.init() == 0
    c = _closed_loop(GUARDED, Recorder(c_guarded))
    py = _closed_loop(GUARDED, Recorder(ReferenceController(build_ocp(GUARDED))))
    b = GUARDED.bounds
    for log in (c, py):
        assert np.max(np.abs(log.a_lat)) <= b.a_lat_max
    guard = np.array(flags[c_guarded.kind])
    np.testing.assert_array_equal(guard, flags[ReferenceController.kind])
    assert np.count_nonzero(guard == 1) >= 5 and not np.any(guard == 2)
    # a guarded sample whose rate stayed inside its bound ends at the guard's target (the 20 m/s wind moves the
    # speed with the rate: within 1e-4 m/s^2)
    rate = c.control[:, 1]
    hit = np.flatnonzero((guard[:-1] == 1) & (np.abs(rate[:-1]) < b.r_max))
    assert hit.size
    np.testing.assert_allclose(
        np.abs(_a_lat(c.ego_frenet[hit + 1], GUARDED)), b.a_lat_max - b.a_lat_margin, rtol=0, atol=1e-4
    )
    np.testing.assert_allclose(c.control, py.control, rtol=0, atol=1e-7)
    np.testing.assert_allclose(c.ego_frenet, py.ego_frenet, rtol=0, atol=1e-7)
