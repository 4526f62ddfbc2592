"""The cold-start guess (fcgen.guess, RtiSolver.initial_guess) follows the road (issue 10: seed 69).

Independent expectations: the hand-written guess formula, the road's own numpy inverse Frenet transform
(``Road.to_cartesian`` on the whole road, not the solver's CasADi window interpolant), and a zero-input rollout
(the old guess) that demonstrably leaves the road window on the same road.
"""

from __future__ import annotations

import numpy as np
import pytest

from fcgen.dsl import Horizon
from fcgen.guess import cold_start_frenet, last_window_s
from fcgen.ocp import build_ocp
from fcgen.presets import paper_problem
from fcgen.reference import RtiSolver, SolverError
from fcgen.road import Road
from fcgen.sim.closedloop import run_closed_loop
from fcgen.sim.runlog import summary
from fcgen.sim.scenario import make_scenario

# seed 69's shape: a left bend (+0.03), then a right bend (-0.042 at s = 45-60 m) within the horizon's reach
S = np.arange(-50.0, 602.0, 2.0)
KAPPA = np.interp(S, [-50, 0, 15, 25, 45, 60, 85], [0.0, 0.01, 0.03, 0.03, -0.042, -0.042, 0.0])
BEND = Road.from_curvature(KAPPA, 2.0, s0=-50.0)
X0 = np.array([0.0, -4.0, 0.0, 15.0, 0.0])  # the campaign's start (alpha, delta 0): the old guess fails here
X1 = np.array([5.0, 2.5, 0.05, 12.0, -0.02])  # alpha, delta non-zero: held (delta) and reset (alpha, k >= 1)


@pytest.fixture(
    scope="module",
    params=[("lifted", "ellipse"), ("direct_elimination", "hyperplane"), ("conventional", "ellipse")],
    ids=lambda p: "-".join(p),
)
def ocp(request):
    return build_ocp(paper_problem("truck", *request.param))


def solver_at(ocp, road, x0, n_opp_s=(150.0, 200.0, 250.0)):
    sv = RtiSolver(ocp)
    sv.set_road(road)
    pose = np.array([road.to_cartesian(s, 3.0, 0.0) for s in n_opp_s])
    sv.set_opponents(np.tile(pose, (ocp.N + 1, 1, 1)))
    sv.set_state(x0)
    return sv


def zero_input_rollout(sv):
    """The old cold start: the model rolled out from x0 with zero input (raises when it leaves the window)."""
    ocp = sv.ocp
    x = np.array(ocp.init_state(sv.x0, sv.stage_params(0, sv.x0[0]))).ravel()
    for k in range(ocp.N):
        x = np.array(ocp.dynamics(x, np.zeros(ocp.nu), sv.stage_params(k, x[0]))).ravel()
    return x


def test_cold_start_frenet_formula():
    times = list(Horizon(N=4, dt=0.1, stride=1).times)
    g = cold_start_frenet([10.0, -2.0, 0.3, 20.0, 0.05], times, s_last=15.0)
    expect = np.array(
        [
            [10.0, -2.0, 0.3, 20.0, 0.05],
            [12.0, -2.0, 0.0, 20.0, 0.05],
            [14.0, -2.0, 0.0, 20.0, 0.05],
            [15.0, -2.0, 0.0, 20.0, 0.05],
            [15.0, -2.0, 0.0, 20.0, 0.05],
        ]
    )
    np.testing.assert_allclose(g, expect, rtol=0, atol=1e-12)
    back = cold_start_frenet([10.0, 1.0, 0.0, -3.0, 0.0], times, s_last=15.0)  # reversing: s stays at s0
    assert np.all(back[:, 0] == 10.0)


def test_last_window_s_is_the_last_accepted_stage_window(ocp):
    win = BEND.window(-50.0, ocp.problem.road.samples)
    sv = solver_at(ocp, win, X0)
    s_last = last_window_s(win, ocp.road_params.samples)
    sv.stage_params(0, s_last)  # accepted
    with pytest.raises(SolverError, match="does not cover"):
        sv.stage_params(0, s_last + win.ds)  # the next grid point is not


@pytest.mark.parametrize("x0", [X0, X1], ids=["x0-start", "x0-turned"])
def test_guess_follows_a_curved_road(ocp, x0):
    win = BEND.window(-50.0, ocp.problem.road.samples)
    sv = solver_at(ocp, win, x0)
    if x0 is X0:
        with pytest.raises(SolverError, match="ERR_ROAD_WINDOW"):
            zero_input_rollout(sv)  # the old guess fails on this road
    w, y = sv.initial_guess()
    lay = sv.lay
    X = np.stack([w[lay.var_off[k] : lay.var_off[k] + ocp.nx] for k in range(ocp.N + 1)])
    k = np.arange(ocp.N + 1)
    np.testing.assert_allclose(X[:, 0], x0[0] + k * ocp.dt * x0[3], rtol=0, atol=1e-12)  # s_k = s0 + k dt v0
    assert np.all(X[:, 1] == x0[1]) and np.all(X[:, 3] == x0[3]) and np.all(X[:, 4] == x0[4])
    assert X[0, 2] == x0[2] and np.all(X[1:, 2] == 0.0)
    for s in X[:, 0]:
        sv.stage_params(0, s)  # every stage inside the solver's window
    kap = np.interp(X[:, 0], BEND.s, BEND.kappa)
    assert np.min(1.0 - X[:, 1] * kap) > 0.8  # far from the singularity
    if ocp.state_kind == "lifted":
        cart = np.stack(BEND.to_cartesian(X[:, 0], X[:, 1], X[:, 2]), axis=1)
        np.testing.assert_allclose(X[:, 5:8], cart, rtol=0, atol=1e-9)
    assert not np.any(y)
    u_idx = [lay.var_off[k] + ocp.nx + i for k in range(ocp.N) for i in range(ocp.nu)]
    assert not np.any(w[u_idx])  # zero inputs
    sig = [lay.var_off[k + 1] - ocp.n_sigma + i for k in range(1, ocp.N + 1) for i in range(ocp.n_sigma)]
    assert not np.any(w[sig])  # zero slacks
    sv.prepare()  # and the cold prepare accepts it
    assert sv.cold


def test_guess_stops_at_the_end_of_the_road(ocp):
    K = ocp.road_params.samples
    win = BEND.window(-50.0, 60)  # 118 m of road, the last stage window from 58 m on
    x0 = np.array([-40.0, 1.0, 0.0, 40.0, 0.0])  # 160 m of horizon: past the road's end
    sv = solver_at(ocp, win, x0, n_opp_s=(-20.0, -10.0, 0.0))
    s_last = last_window_s(win, K)
    w, _ = sv.initial_guess()
    s = w[sv.lay.s_vars]
    expect = np.minimum(x0[0] + np.arange(ocp.N + 1) * ocp.dt * x0[3], s_last)
    np.testing.assert_allclose(s, expect, rtol=0, atol=1e-12)
    assert s_last == -50.0 + (60 - K + 1) * 2.0 and s[-1] == s_last and s[0] == x0[0] and s[20] < s_last
    sv.prepare()  # no ERR_ROAD_WINDOW


def test_seed_69_closed_loop_runs():
    """Issue 10: every prepare of seed 69 failed (ERR_ROAD_WINDOW) until the ego left the road at sample 39."""
    pb = paper_problem("truck", "lifted", "ellipse")
    sc = make_scenario("truck", 69, n_opp=pb.opponents.count, samples=60, dt=pb.horizon.dt)
    log = run_closed_loop(pb, sc)
    assert log.meta["extra"]["exit_codes_nonzero"] == 0
    n = log.ego_frenet[:, 1]
    assert np.all((n > pb.bounds.n_min) & (n < pb.bounds.n_max))  # on the road
    assert summary(log)["progress"] > 60 * pb.horizon.dt * 15.0 * 0.9  # it drives on (about the start speed)
