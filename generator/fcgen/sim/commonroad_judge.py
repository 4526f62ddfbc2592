"""The checks a CommonRoad run is judged by, whoever drove it: fcgen's rectangle check and the drivability checker
against every obstacle, the responsibility of the first contact (``collision_kind``), the criticality measures, the
goal and the solution's verdict; on the scenario as its vehicles drove (reactive traffic: ``driven``).

``judge_drive`` takes the ego's rear-axle states on the scenario road's Frenet frame; fcgen's closed loop
(``commonroad_run``) and a peer planner's (``benchmarks/reactive_planner_peer.py``) are judged by the same code.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from ..dsl import Problem
from ..road import Road
from .collision_kind import LANE_WINDOW, behind_rear, responsible
from .commonroad_status import _plain, goal_status


@dataclass(frozen=True, eq=False)
class Judged:
    """The verdicts of one drive: poses, penetrations and each check's result."""

    sc: object  # the CrScenario as driven
    ego_cart: np.ndarray  # (K + 1, 3) rear-axle poses [x, y, phi]
    centres: np.ndarray  # (K + 1, 3) chassis centre poses
    opp_cart: np.ndarray  # (K + 1, O, 3) every obstacle (NaN where not recorded)
    pen: np.ndarray  # (K + 1, O) penetration depths (fcgen's check)
    responsibility: str
    criticality: dict
    checker: dict  # the drivability checker's verdict
    fcgen: dict  # fcgen's verdict
    goal: dict
    solution: dict


def driven(sc, world) -> object:
    """The scenario a run is judged on: ``sc`` in recorded traffic (``world`` None), else the reactive traffic's
    obstacles as they drove, with a commonroad-io copy that drives them (``reactive.driven_scenario``)."""
    if world is None:
        return sc
    from ..commonroad.reactive import driven_scenario

    out = world.scenario()
    return replace(out, scenario=driven_scenario(out, out.obstacles))


NOT_MEASURED = "not measured (criticality off)"


def judge_drive(
    problem: Problem, sc, road: Road, xs: np.ndarray, ego_cart: np.ndarray | None = None, criticality: bool = True
) -> Judged:
    """Judge the ego's rear-axle states ``xs`` (K + 1, 5: s, n, alpha, v, delta on ``road``) on the driven scenario
    ``sc``; ``ego_cart``: the rear-axle poses if the driver has them (else from ``xs`` on ``road``); ``criticality``:
    False leaves the criticality measures out (their ``error``: ``NOT_MEASURED``)."""
    from .. import commonroad as cr
    from ..commonroad.criticality import criticality as measures
    from ..commonroad.criticality import unmeasured
    from ..commonroad.judge import fcgen_verdict, penetrations

    ego = problem.ego
    if ego_cart is None:
        ex, ey, ephi = road.to_cartesian(xs[:, 0], xs[:, 1], xs[:, 2])
        ego_cart = np.stack([ex, ey, ephi], axis=1)
    centres = np.asarray(ego_cart, dtype=float).copy()
    centres[:, 0] += ego.l / 2 * np.cos(centres[:, 2])
    centres[:, 1] += ego.l / 2 * np.sin(centres[:, 2])
    opp_cart = obstacle_poses(sc, len(xs))
    pen = penetrations(sc, centres, ego.l_ch, ego.w_ch)
    who = responsibility(pen, ego_cart, centres, xs, opp_cart, sc, road)
    # before the drivability checker: after it has read the scenario, CriMe's lanelet queries on the turned copy
    # find nothing (a state of commonroad-io's objects the copy keeps; docs/commonroad.md)
    crit = measures(sc, centres, xs[:, 3], ego.l_ch, ego.w_ch) if criticality else unmeasured(NOT_MEASURED)
    checker = cr.drivability_verdict(sc, centres, ego.l_ch, ego.w_ch)
    own = fcgen_verdict(sc, pen)
    solution = _plain(cr.solution_verdict(sc, np.column_stack([centres, xs[:, 3:5]])))
    goal = goal_status(sc, road, centres, xs)
    return Judged(sc, np.asarray(ego_cart), centres, opp_cart, pen, who, crit, checker, own, goal, solution)


def obstacle_poses(sc, n_states: int) -> np.ndarray:
    """(K + 1, O, 3) every obstacle of the scenario at every sample where it is recorded (NaN elsewhere)."""
    opp_cart = np.full((n_states, len(sc.obstacles), 3), np.nan)
    for i, ob in enumerate(sc.obstacles):
        for j in range(n_states):
            step = sc.first_step + j
            if ob.static or ob.first_step <= step <= ob.last_step:
                p = ob.pose(step)
                if p is not None:
                    opp_cart[j, i] = p
    return opp_cart


def responsibility(
    pen: np.ndarray, ego_cart: np.ndarray, centres: np.ndarray, xs: np.ndarray, opp_cart: np.ndarray, sc, road: Road
) -> str:
    """The responsibility class of the first contact (``collision_kind.responsible``; "" without one); the obstacles'
    lanes kept or not by their centres' n on the ego's ``road``."""
    hit = np.flatnonzero(pen.max(axis=1, initial=0.0) > 0.0)
    if not hit.size:
        return ""
    j = int(hit[0])
    k = int(np.argmax(pen[j]))
    j0 = max(j - 1, 0)
    span = max(j - j0, 1) * sc.dt
    ego_v = (centres[j, :2] - centres[j0, :2]) / span
    prev = opp_cart[j0, k, :2] if np.all(np.isfinite(opp_cart[j0, k, :2])) else opp_cart[j, k, :2]
    opp_v = (opp_cart[j, k, :2] - prev) / span
    win = slice(max(0, j - round(LANE_WINDOW / sc.dt)), j + 1)
    seen = opp_cart[win, k]
    opp_n = np.full(len(seen), np.nan)  # NaN where not recorded: the lane not known kept
    ok = np.all(np.isfinite(seen), axis=1)
    if ok.any():
        opp_n[ok] = road.to_frenet(seen[ok, 0], seen[ok, 1], seen[ok, 2])[1]
    rear = behind_rear(centres[j, :2], opp_cart[j, k, :2], float(opp_cart[j, k, 2]), 0.5 * sc.obstacles[k].length)
    return responsible(
        centres[j, :2],
        float(ego_cart[j, 2]),
        ego_v,
        opp_cart[j, k, :2],
        opp_v,
        xs[win, 1],
        opp_n_before=opp_n,
        rear=rear,
    )


def states_on_road(road: Road, states: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """A drive given as Cartesian rear-axle states ``states`` (K + 1, 5: x, y, phi, v, delta; a planner that is not
    fcgen's) as ``judge_drive`` takes it: the Frenet states on ``road`` (s, n, alpha, v, delta) and the rear-axle
    poses (K + 1, 3)."""
    st = np.asarray(states, dtype=float)
    if st.ndim != 2 or st.shape[1] != 5 or not np.all(np.isfinite(st)):
        raise ValueError(f"states: must be finite (K + 1, 5) [x, y, phi, v, delta] rows, got shape {st.shape}")
    s, n, alpha = road.to_frenet(st[:, 0], st[:, 1], st[:, 2])
    alpha = np.angle(np.exp(1j * np.asarray(alpha, dtype=float)))  # a heading's turns left out
    xs = np.column_stack([s, n, alpha, st[:, 3], st[:, 4]])
    return xs, st[:, :3].copy()
