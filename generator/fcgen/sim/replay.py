"""Replay: feed a logged run's measured states, road and opponents to a controller, sample by sample.

The closed loop's inputs at sample ``j`` are the measured state ``x_j``, the road window cut at ``x_j`` and the
opponents' parameters of stages ``j .. j + N``. A replay rebuilds the scenario from the log's ``meta`` (kind, seed,
length; the road and opponents in the log must be the ones the seed gives) and makes exactly the controller calls of
``run_closed_loop`` (``step`` = ``prepare_phase`` then ``feedback_phase``) with the *logged* state instead of its own
plant's. The controller keeps its own warm start. So the outputs of another solver can be compared with the logged
ones sample by sample, and a difference is pinned to the first sample where the solvers disagree, even when a closed
loop would have taken another manoeuvre afterwards.
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import replace

import numpy as np

from .. import extras
from ..dsl import Problem
from ..road import Road
from .closedloop import PLAN_LEVELS, Controller, PlanLog, solver_window
from .runlog import RunLog, make_meta
from .scenario import OpponentParams, Scenario, make_scenario

#: ``scenario_of``: how far a log's road arrays (kappa, phi_gamma, gamma_x, gamma_y) may be from the regenerated
#: ones, relative to each array's largest magnitude (at least 1). The scenario generator gives the same bits on every
#: CPU for one Python/numpy/glibc (road.py), but another libm (another glibc; a CPU without FMA, where glibc picks
#: another sin/cos kernel: 1 ulp apart on ~0.07 % of arguments) may move the integrated centre line by a few ulps of
#: its magnitude (a 1.6 km road: ~1e-13 m). 1e-12 of the magnitude (~1 nm on such a road) leaves room for that;
#: any real change of the generator moves the curvature by far more (the knots are O(kappa_max) = O(0.05)).
ROAD_RTOL = 1e-12
_ROAD_ARRAYS = (("kappa", "kappa"), ("phi_gamma", "phi"), ("gamma_x", "gx"), ("gamma_y", "gy"))


def _road_deviation(logged, new: np.ndarray) -> tuple[float, float]:
    """Largest |logged - new| (NaN if any is) and the allowed one (``ROAD_RTOL``); arrays of one length."""
    allowed = ROAD_RTOL * max(1.0, float(np.max(np.abs(new), initial=0.0)))
    return float(np.max(np.abs(np.asarray(logged, dtype=float) - new), initial=0.0)), allowed


def scenario_of(log: RunLog, problem: Problem) -> Scenario:
    """The scenario a log was run on (from ``meta``), checked against the log's road and opponents (ValueError).

    The road's grid must be the regenerated one exactly, its arrays within ``ROAD_RTOL``; when they are not the
    same bits, the scenario gets the log's own road, so a replay feeds the solver the recorded road windows.
    """
    m = log.meta
    if len(log.opponents) != problem.opponents.count:
        raise ValueError(
            f"log has {len(log.opponents)} opponents, problem {problem.name!r} expects {problem.opponents.count}"
        )
    try:
        sc = make_scenario(m["scenario"], m["seed"], n_opp=len(log.opponents), samples=log.n_controls, dt=m["dt"])
    except ValueError as exc:
        raise ValueError(f"log's scenario cannot be rebuilt: {exc}") from None
    r = sc.road
    what = f"log's road is not the one of scenario {m['scenario']!r} seed {m['seed']} (another scenario generator?)"
    if not (len(log.road["s"]) == r.size and log.road["ds"] == r.ds and np.array_equal(log.road["s"], r.s)):
        raise ValueError(f"{what}: another grid")
    for key, attr in _ROAD_ARRAYS:
        dev, allowed = _road_deviation(log.road[key], getattr(r, attr))
        if not dev <= allowed:
            raise ValueError(f"{what}: {key} differs by {dev:.3g} (allowed {allowed:.3g})")
    if not all(np.array_equal(log.road[key], getattr(r, attr)) for key, attr in _ROAD_ARRAYS):
        sc = replace(sc, road=Road(r.s0, r.ds, *(np.asarray(log.road[key], dtype=float) for key, _ in _ROAD_ARRAYS)))
    if not np.array_equal(log.opp_frenet, sc.opp_frenet(log.t)):
        raise ValueError(f"log's opponents are not those of scenario {m['scenario']!r} seed {m['seed']}")
    return sc


def plan_level(log: RunLog) -> str:
    """How much plan a log carries (``PLAN_LEVELS``)."""
    if log.plan_states is not None:
        return "full"
    return "controls" if log.plan_controls is not None else "none"


def replay(
    problem: Problem, log: RunLog, controller: Controller, plan: str | None = None, progress: bool = False
) -> RunLog:
    """The controller's outputs on the logged inputs, as a run log (state fields copied from ``log``).

    ``plan`` (``PLAN_LEVELS``, default: what ``log`` carries) selects the logged plan fields; the exit code of
    every sample is always logged.
    """
    plan = plan_level(log) if plan is None else plan
    if plan not in PLAN_LEVELS:
        raise ValueError(f"plan = {plan!r} is invalid: allowed {', '.join(PLAN_LEVELS)}")
    if log.meta["N"] != problem.horizon.N:
        raise ValueError(f"log has N = {log.meta['N']}, problem {problem.name!r} has N = {problem.horizon.N}")
    sc = scenario_of(log, problem)
    opp_params = OpponentParams(problem, sc)
    K = log.n_controls
    us = np.zeros((K, 2))
    tp, tf, slack = np.zeros(K), np.zeros(K), np.zeros(K)
    qi, qs = np.zeros(K, dtype=np.int64), np.zeros(K, dtype=np.int64)
    planlog = PlanLog(K, problem.horizon.N, plan)
    it: Iterable[int] = range(K)
    if progress:
        it = extras.progress(it, desc=f"replay {problem.name} seed {sc.seed}", unit="sample", leave=False)
    for j in it:
        x = np.array(log.ego_frenet[j])
        r = controller.step(x, solver_window(problem, sc.road, x), opp_params.horizon(j + problem.delay))
        us[j] = r.u
        tp[j], tf[j], qi[j], qs[j], slack[j] = r.time_prepare, r.time_feedback, r.qp_iter, r.qp_status, r.max_slack
        planlog.add(j, controller, r)
    m = log.meta
    meta = make_meta(
        problem=problem.name,
        formulation=problem.formulation.kind,
        obstacle_model=problem.obstacles.kind,
        scenario=m["scenario"],
        seed=m["seed"],
        N=problem.horizon.N,
        dt=problem.horizon.dt,
        controller=controller.kind,
        n_bound=m.get("n_bound"),
        extra={"exit_codes_nonzero": int(np.count_nonzero(planlog.exit_code)), "replay": True},
    )
    states = {
        k: getattr(log, k)
        for k in ("t", "ego_frenet", "ego_cartesian", "opp_cartesian", "opp_frenet", "collision", "a_lat")
    }
    return RunLog(
        meta=meta,
        road=log.road,
        opponents=log.opponents,
        ego=log.ego,
        control=us,
        time_prepare=tp,
        time_feedback=tf,
        time_total=tp + tf,
        qp_iter=qi,
        qp_status=qs,
        max_slack=slack,
        **states,
        **planlog.fields(),
    )
