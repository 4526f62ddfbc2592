"""The plan check: the plan's SAT clearance to the opponents' true rectangles after each feedback, and the braking
reaction; the Python reference and the generated C agree."""

from __future__ import annotations

import contextlib
import shutil

import numpy as np
import pytest

from fcgen.build import build
from fcgen.codegen.generate import generate
from fcgen.csolver import CSolver
from fcgen.dsl import PlanCheck
from fcgen.ocp import build_ocp
from fcgen.presets import preset
from fcgen.reference import RtiSolver, SolverError
from fcgen.road import straight_road

pytestmark = pytest.mark.skipif(any(shutil.which(t) is None for t in ("gcc", "make")), reason="needs gcc and make")

PB = preset("car_lifted_ellipse_ipm_safe")


def _inputs(pb, opp_xy):
    road = straight_road(length=(pb.road.samples - 1) * pb.road.ds, ds=pb.road.ds, s0=-20.0)
    x0 = np.array([0.0, 0.0, 0.0, 20.0, 0.0])
    opp = np.zeros((pb.horizon.N + 1, pb.opponents.count, 3))
    opp[..., 0], opp[..., 1] = -1000.0, 500.0  # the others far away
    opp[:, 0, 0], opp[:, 0, 1] = 20.0 + opp_xy[0], opp_xy[1]  # opponent 0 standing there (the ego's s = 0 is x = 20)
    return road, x0, opp


def _python(pb, road, x0, opp):
    sv = RtiSolver(build_ocp(pb))
    sv.set_road(road)
    sv.set_opponents(opp)
    with contextlib.suppress(SolverError):  # an unusable QP falls back: the plan check runs on the fallback plan too
        sv.step(x0)
    return sv.status, sv.u0()


@pytest.fixture(scope="module")
def c_solvers(tmp_path_factory):
    out = {}
    for tag, pb in (("safe", PB), ("report", PB.with_(name="car_report_only", plan_check=PlanCheck(0)))):
        gen = generate(pb, tmp_path_factory.mktemp(tag) / "s")
        out[tag] = (pb, CSolver(build(gen.out_dir, verify=True)))
    return out


def _c(cs: CSolver, road, x0, opp):
    assert cs.init() == 0
    assert cs.set_road(road) == 0 and cs.set_opponents(opp) == 0 and cs.set_state(x0) == 0
    assert cs.prepare() == 0
    cs.feedback()
    return cs.status(), cs.u0()


def test_a_parallel_opponent_gives_the_hand_derived_clearance(c_solvers):
    """A car standing 5 m to the left, 12 m ahead: the plan (straight on n = 0) passes it 5 - 2 x 0.95 = 3.1 m apart
    (the separating axis across the road; along it, the gap shrinks from 8 m to overlapping)."""
    for _tag, (pb, cs) in c_solvers.items():
        road, x0, opp = _inputs(pb, (12.0, 5.0))
        st_py, u_py = _python(pb, road, x0, opp)
        st_c, u_c = _c(cs, road, x0, opp)
        assert st_py.plan_clearance == pytest.approx(3.1, abs=0.02)
        assert st_c.plan_clearance == pytest.approx(st_py.plan_clearance, abs=1e-9)
        assert st_c.plan_clearance_stage == st_py.plan_clearance_stage >= 0
        assert st_py.plan_reaction == st_c.plan_reaction == 0
        np.testing.assert_allclose(u_c, u_py, atol=1e-9)


def test_a_car_standing_ahead_makes_the_solver_brake(c_solvers):
    """A car standing 8 m ahead at 20 m/s cannot be avoided within the first second: the plan overlaps it, the safe
    solver brakes with F_d = -min(F_d_max, m v0 / dt) and says so; report-only (paper) applies the plan's u0."""
    for tag, (pb, cs) in c_solvers.items():
        road, x0, opp = _inputs(pb, (8.0, 0.0))
        st_py, u_py = _python(pb, road, x0, opp)
        st_c, u_c = _c(cs, road, x0, opp)
        assert st_py.plan_clearance < 0.0 and 1 <= st_py.plan_clearance_stage <= 10
        assert st_c.plan_clearance == pytest.approx(st_py.plan_clearance, abs=1e-9)
        assert (st_c.plan_clearance_stage, st_c.plan_reaction) == (st_py.plan_clearance_stage, st_py.plan_reaction)
        brake = -min(pb.bounds.F_d_max, pb.ego.m * 20.0 / pb.horizon.dt)
        if tag == "safe":
            assert st_py.plan_reaction == 1 and u_py[0] == pytest.approx(brake, rel=1e-12)
        else:
            assert st_py.plan_reaction == 0 and u_py[0] != pytest.approx(brake, rel=1e-6)
        np.testing.assert_allclose(u_c, u_py, atol=1e-9)


def test_an_opponent_running_into_the_ego_from_behind_does_not_make_it_brake(c_solvers):
    """A car closing from behind at 30 m/s (the ego at 20) overlaps the plan within the first second, its centre
    behind the ego's: braking would close that gap, so the safe solver does not brake (the clearance is reported)."""
    pb, cs = c_solvers["safe"]
    road, x0, opp = _inputs(pb, (0.0, 0.0))
    k = np.arange(pb.horizon.N + 1)
    opp[:, 0, 0] = 20.0 - 6.0 + 30.0 * pb.horizon.interval * k
    st_py, u_py = _python(pb, road, x0, opp)
    st_c, u_c = _c(cs, road, x0, opp)
    assert st_py.plan_clearance < 0.0 and 1 <= st_py.plan_clearance_stage <= 10
    assert st_py.plan_reaction == st_c.plan_reaction == 0
    assert st_c.plan_clearance == pytest.approx(st_py.plan_clearance, abs=1e-9)
    np.testing.assert_allclose(u_c, u_py, atol=1e-9)


def test_an_opponent_ahead_now_that_the_plan_would_pass_into_makes_the_ego_brake(c_solvers):
    """An opponent 30 m ahead in the next lane now, predicted from the next stage on 1 m behind the ego in its lane
    (where the ego would be at 20 m/s: no plan gets clear of it within 0.1 s): its first overlap has it behind the ego,
    but it is ahead now, so the plan would have to pass it to get there; braking keeps the ego behind it (truck lifted
    HP seed 104: the ego passed a truck into a bend and cut in ahead of its front)."""
    pb, cs = c_solvers["safe"]
    road, x0, opp = _inputs(pb, (30.0, 5.0))
    k = np.arange(1, pb.horizon.N + 1)
    opp[1:, 0, 0], opp[1:, 0, 1] = 20.0 + 20.0 * pb.horizon.interval * k - 1.0, 0.0
    st_py, u_py = _python(pb, road, x0, opp)
    st_c, u_c = _c(cs, road, x0, opp)
    assert st_py.plan_clearance < 0.0 and st_py.plan_clearance_stage >= 1
    assert st_py.plan_reaction == st_c.plan_reaction == 1
    brake = -min(pb.bounds.F_d_max, pb.ego.m * 20.0 / pb.horizon.dt)
    assert u_py[0] == pytest.approx(brake, rel=1e-12)
    np.testing.assert_allclose(u_c, u_py, atol=1e-9)
