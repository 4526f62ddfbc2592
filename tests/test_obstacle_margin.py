"""``Problem.obstacle_margin``: the obstacle margin of every stage from ``init`` on, in the Python reference and the
generated C, and the safe profile's margin where its solver compensates a latency (``presets.safe_delay_margin``)."""

from __future__ import annotations

import math
import shutil

import numpy as np
import pytest
from one_opponent import one_opponent, window_road

from fcgen.build import build
from fcgen.campaign.grid import Config
from fcgen.codegen.generate import generate
from fcgen.contract import INPUT_RANGES
from fcgen.csolver import CSolver
from fcgen.dsl import ProblemError
from fcgen.ocp import build_ocp
from fcgen.presets import SAFE_DELAY_MARGIN, preset, safe_delay_margin
from fcgen.reference import RtiSolver
from fcgen.sim.plants import PlantSpec

SAFE_EL = preset("car_lifted_ellipse_ipm_safe")
M = 0.4
X0 = np.array([0.0, 0.0, 0.0, 15.0, 0.0])


def _prepared(pb, margins=None) -> RtiSolver:
    sv = RtiSolver(build_ocp(pb))
    sv.set_road(window_road(pb))
    sv.set_opponents(one_opponent(pb))
    if margins is not None:
        sv.set_obstacle_margins(margins)
    sv.set_state(X0)
    sv.prepare()
    return sv


@pytest.mark.parametrize("bad", [-0.1, 10.5, math.nan, math.inf, True])
def test_a_margin_outside_its_range_is_refused_naming_the_field(bad):
    with pytest.raises(ProblemError, match=r"obstacle_margin = .* is invalid: allowed \[0, 10\] m"):
        SAFE_EL.with_(obstacle_margin=bad)


def test_the_problems_margin_is_the_run_time_margin_of_every_stage():
    """The reference built with obstacle_margin = m starts with m at every stage and prepares the QP of the plain
    problem given set_obstacle_margins(m, ..., m), bit for bit; set_obstacle_margins replaces it, 0 gives the plain
    problem's QP."""
    with_m = _prepared(SAFE_EL.with_(obstacle_margin=M))
    np.testing.assert_array_equal(with_m.margins, np.full(SAFE_EL.horizon.N + 1, M))
    run_time = _prepared(SAFE_EL, margins=np.full(SAFE_EL.horizon.N + 1, M))
    for a, b in ((with_m.P, run_time.P), (with_m.g, run_time.g), (with_m.l, run_time.l)):
        np.testing.assert_array_equal(a, b)
    plain, replaced = _prepared(SAFE_EL), _prepared(SAFE_EL.with_(obstacle_margin=M), margins=np.zeros(41))
    np.testing.assert_array_equal(replaced.g, plain.g)
    assert not np.array_equal(with_m.g, plain.g)  # the margin does enter the rows


@pytest.mark.skipif(any(shutil.which(t) is None for t in ("gcc", "make")), reason="needs gcc and make")
def test_the_c_starts_with_the_margin_and_reset_keeps_it(tmp_path):
    """The C of obstacle_margin = m: after init its stage parameters are the reference's under
    set_obstacle_margins(m), bit for bit; reset keeps them; set_obstacle_margins(0) gives the plain problem's."""
    pb = SAFE_EL.with_(obstacle_margin=M, name="car_margin")
    cs = CSolver(build(generate(pb, tmp_path / "s").out_dir, verify=True))
    ref_m, ref_0 = _prepared(SAFE_EL, margins=np.full(41, M)), _prepared(SAFE_EL)
    assert cs.init() == 0 and cs.set_road(window_road(pb)) == 0 and cs.set_opponents(one_opponent(pb)) == 0
    assert cs.set_state(X0) == 0 and cs.prepare() == 0
    np.testing.assert_array_equal(cs.get_opp_params(), ref_m.P[:, ref_m.ocp.p_opp])
    cs.reset()
    np.testing.assert_array_equal(cs.get_opp_params(), ref_m.P[:, ref_m.ocp.p_opp])
    assert cs.set_obstacle_margins(np.zeros(41)) == 0
    np.testing.assert_array_equal(cs.get_opp_params(), ref_0.P[:, ref_0.ocp.p_opp])
    assert cs.init() == 0 and cs.set_opponents(one_opponent(pb)) == 0  # init restores the problem's margin
    np.testing.assert_array_equal(cs.get_opp_params(), ref_m.P[:, ref_m.ocp.p_opp])


def test_the_safe_profile_keeps_its_margin_only_under_a_compensated_latency():
    assert safe_delay_margin("safe", 1) == safe_delay_margin("safe", 2) == SAFE_DELAY_MARGIN > 0
    assert safe_delay_margin("safe", 0) == safe_delay_margin("paper", 1) == 0.0
    st = PlantSpec(kind="st", latency=1)
    safe = Config("car", "lifted", "ellipse", 0, "c", "ipm", "safe", st, 1).problem()
    assert safe.delay == 1 and safe.obstacle_margin == SAFE_DELAY_MARGIN
    assert Config("car", "lifted", "ellipse", 0, "c", "ipm", "safe", st, 0).problem().obstacle_margin == 0.0
    assert Config("car", "lifted", "ellipse", 0, "c", "ipm", "paper", st, 1).problem().obstacle_margin == 0.0


def test_prediction_margins_come_on_top_of_the_problems():
    """With predicted traffic and ``PlantSpec.prediction_margin`` the loop sets the rule's margins plus the
    problem's own before each solve (the reference's margins after the last sample are that sample's)."""
    from fcgen.sim.closedloop import ReferenceController, opponent_params, run_closed_loop
    from fcgen.sim.plants import DEFAULT_NOISE
    from fcgen.sim.prediction import PredictedOpponents
    from fcgen.sim.scenario import make_scenario

    pb = SAFE_EL.with_(obstacle_margin=M)
    spec = PlantSpec(prediction="constant-velocity", noise=DEFAULT_NOISE, prediction_margin=1.0)
    sc = make_scenario("car", 2, n_opp=pb.opponents.count, samples=12, dt=pb.horizon.dt)
    ctl = ReferenceController(build_ocp(pb))
    run_closed_loop(pb, sc, controller=ctl, plant=spec)
    opp = opponent_params(pb, sc)
    pred = PredictedOpponents(
        "constant-velocity", opp.at_index, pb.horizon.offsets, sc.dt, noise=DEFAULT_NOISE[:3], seed=sc.seed
    )
    want = pred.margins(sc.samples - 1, 1.0) + M  # within set_obstacle_margins' range
    assert np.count_nonzero(want < INPUT_RANGES.margin_max) > 10
    np.testing.assert_array_equal(ctl.solver.margins, np.minimum(want, INPUT_RANGES.margin_max))
