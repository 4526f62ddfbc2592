"""What fcgen can drive: a scenario is refused, with the reason's kind, where its route crosses other lanes (an
intersection), where its road carries traffic against the ego's direction (oncoming traffic), where its goal's
lanelets cannot be reached along the lanes from the start, or where the route turns tighter than the car can.

Rules (tested in tests/test_commonroad_refusals.py on scenarios the tests write with commonroad-io):

- **Intersection**: along the reference path from the ego's start over the distance the run can drive
  (``reach_m``: its samples at the larger of the initial and the reference speed, plus the horizon), every
  ``PROBE_STEP`` metres, a lanelet holding the path's point whose heading there differs from the path's by
  ``CROSS_ANGLE`` to 180 - ``CROSS_ANGLE`` degrees (a crossing lane; not one that forks from or merges into the
  route's lanelets at less than ``FORK_ANGLE``: a turning lane that leaves the route's predecessor and crosses it
  further on is a crossing), or a lanelet the network lists inside an
  intersection (an incoming's successor).
- **Oncoming traffic**: a lanelet on that stretch holding the path's point against its direction (more than
  180 - ``CROSS_ANGLE`` degrees off: a shared two-way lane), or a recorded vehicle during the run whose centre is
  in the road's band (the lanes of the ego's direction) within that stretch, heading more than 90 degrees against
  the road.
- **Turn tighter than the car**: on that stretch the reference path turns, over 10, 20 or 40 m (``TURN_WINDOWS``),
  by an angle theta that the car at its largest curvature tan(delta_max) / wheelbase (a radius R of 11.0 m for the
  paper's car: delta_max 0.3 rad, wheelbase 3.4 m) cannot take inside the band: between the turn's two tangents its
  arc lies (R - r)(1 / cos(theta / 2) - 1) inside the path's arc of radius r = window / theta at the middle, more
  than the band's width less the chassis' swept width there (the widest line a driver takes, out-in-out). The swept
  width on an arc of radius rho = max(r, R) through the rear axle runs from the inner side at the rear axle
  (rho - w / 2) to the outer front corner (sqrt((rho + w / 2)^2 + f^2), ``f`` the front of the chassis ahead of the
  rear axle): 2.46 m for the paper's car at 11.0 m (w 1.9 m, f 3.7 m), against 1.9 m on a straight. A junction's
  turn from one street into another (CHN_Sha: 1.3-1.7 rad within 10 m) is one; so is a 1.2 rad turn within 10 m
  (0.5 m to cut) on a band of 2.45-2.7 m (CHN_Sha-12_1, 1_5: 0.55-0.8 m beside the chassis' width, 0-0.2 m beside
  its swept width; driven, 12_1's front corner crossed the lane's edge where the turn begins).
- **Goal unreachable**: the goal names lanelets and none of them can be reached from the start lanelet along
  successors and adjacent lanes of the same direction (fcgen's lane rule moves one lane at a time, the road follows
  successors); or the goal's position lies wholly behind the ego's centre along its road (``check_goal_ahead``: the
  ego drives forwards; DEU_Hhr-1_1's goal lies 4-11 m behind its start, and the run stood for 1800 samples).
"""

from __future__ import annotations

import math

import numpy as np

from ..dsl import Vehicle
from ..road import Road
from .traffic import CrObstacle, ScenarioRefused

PROBE_STEP = 2.0  # m between the path's points probed for crossing lanes
CROSS_ANGLE = 30.0  # degrees: a lanelet this far off the path's heading at a shared point crosses it ...
FORK_ANGLE = 60.0  # ... unless it forks from or merges into the route's lanelets and is less than this far off
OBSTACLE_STRIDE = 5  # recorded steps between the poses checked for oncoming vehicles
TURN_WINDOWS = (10.0, 20.0, 40.0)  # m: the path's turns are measured as its heading's change over these distances


def check_drivable(
    net,
    road: Road,
    first: int,
    goals: set[int],
    obstacles,
    s0: float,
    reach_m: float,
    steps,
    kappa_max=None,
    ego: Vehicle | None = None,
) -> None:
    """The checks below, in order, for a run from ``s0`` (the ego's ``s``) over the time ``steps`` that can drive
    ``reach_m`` (its samples at its speed, plus the horizon); ``kappa_max``: the car's largest curvature (1/m; None:
    the turns are not checked), ``ego``: its chassis (None: a point)."""
    check_goal_reachable(net, first, goals)
    check_route(net, road, s0, reach_m)
    if kappa_max is not None:
        width, front = (ego.w_ch, ego.l / 2 + ego.l_ch / 2) if ego is not None else (0.0, 0.0)
        check_turns(road, s0, reach_m, kappa_max, width, front)
    check_oncoming(obstacles, road, s0, reach_m, steps)


def check_turns(road: Road, s0: float, reach_m: float, kappa_max: float, width: float, front: float = 0.0) -> None:
    """Refuse (``turn tighter than the car``) a reference path that turns, over ``TURN_WINDOWS`` metres somewhere
    between ``s0`` and ``s0 + reach_m``, more than a car of width ``width`` (its front ``front`` ahead of the rear
    axle) at its largest curvature ``kappa_max`` can inside the band (module docstring: ``cut_needed`` against the
    band's width less ``swept_width``)."""
    s = road.s
    on = np.flatnonzero((s >= s0) & (s <= s0 + reach_m))
    for window in TURN_WINDOWS:
        w = max(1, round(window / road.ds))
        if on.size <= w:
            continue
        turn = np.abs(road.phi[on[w:]] - road.phi[on[:-w]])
        rho = np.maximum(w * road.ds / np.maximum(turn, 1e-12), 1.0 / kappa_max)  # the radius the car drives
        free = _band_width(road, on[:-w] + w // 2) - swept_width(rho, width, front)
        need = cut_needed(turn, w * road.ds, 1.0 / kappa_max)
        bad = np.flatnonzero(need > free)
        if bad.size:
            k = int(bad[np.argmax(turn[bad])])
            raise ScenarioRefused(
                f"a turn tighter than the car: the route turns {float(turn[k]):.2f} rad within {w * road.ds:.0f} m, "
                f"{float(s[on[k]] - s0):.0f} m ahead; the car, turning no tighter than {1.0 / kappa_max:.1f} m "
                f"(tan(delta_max) / wheelbase), needs {float(need[k]):.1f} m of the band's {float(free[k]):.1f} m "
                "free width (beside the chassis' swept width) to cut it",
                kind="turn tighter than the car",
            )


def swept_width(radius, width: float, front: float):
    """The width a chassis of width ``width``, its front ``front`` ahead of the rear axle, sweeps on an arc of
    ``radius`` through its rear axle: from the inner side at the rear axle to the outer front corner."""
    outer = np.asarray(radius, dtype=float) + width / 2
    return width + front**2 / (np.sqrt(outer**2 + front**2) + outer)  # sqrt(o^2 + f^2) - o without cancellation


def cut_needed(turn, length: float, r_car: float):
    """How far inside a turn by ``turn`` rad over ``length`` m (an arc of radius length / turn between the same two
    tangents) the arc of radius ``r_car`` lies at its middle: (r_car - r)(1 / cos(turn / 2) - 1), 0 where the car
    turns tighter than the path; infinite for a turn of pi or more."""
    turn = np.asarray(turn, dtype=float)
    r = length / np.maximum(turn, 1e-12)
    half = np.minimum(turn / 2, math.pi / 2 - 1e-9)
    need = np.maximum(r_car - r, 0.0) * (1.0 / np.cos(half) - 1.0)
    return np.where(turn >= math.pi, np.inf, need)


def _band_width(road: Road, idx) -> np.ndarray:
    """The drivable band's width at the road samples ``idx`` (a road without a band: infinite)."""
    if road.n_min is None or road.n_max is None:
        return np.full(len(idx), np.inf)
    return road.n_max[idx] - road.n_min[idx]


def check_route(net, road: Road, s0: float, reach_m: float) -> None:
    """Refuse (``intersection`` or ``oncoming traffic``) a route that crosses lanes or shares one with traffic in
    the other direction between ``s0`` and ``s0 + reach_m`` on ``road``."""
    in_junction = {lid for inter in getattr(net, "intersections", []) for lid in _intersection_lanelets(inter)}
    s = np.arange(s0, min(s0 + reach_m, road.s_end), PROBE_STEP)
    s = s if s.size else np.array([s0])  # a run that cannot move (a standing ego, no speed to reach): its start
    x, y, phi = road.to_cartesian(s, np.zeros_like(s), np.zeros_like(s))
    found = net.find_lanelet_by_position([np.array([xi, yi]) for xi, yi in zip(x, y, strict=True)])
    probes = [
        (si - s0, lid, abs(math.degrees(math.remainder(_heading(net, lid, (xi, yi)) - ph, 2 * math.pi))))
        for si, xi, yi, ph, ids in zip(s, x, y, phi, found, strict=True)
        for lid in ids
    ]
    siblings = _siblings(net, {lid for _, lid, off in probes if off < CROSS_ANGLE})
    for ahead, lid, off in probes:
        if lid in in_junction:
            raise ScenarioRefused(
                f"an intersection: lanelet {lid} of the route {ahead:.0f} m ahead belongs to one", kind="intersection"
            )
        if CROSS_ANGLE <= off <= 180.0 - CROSS_ANGLE and not (lid in siblings and off < FORK_ANGLE):
            raise ScenarioRefused(
                f"an intersection: lanelet {lid} crosses the route {ahead:.0f} m ahead at {off:.0f} degrees",
                kind="intersection",
            )
        if off > 180.0 - CROSS_ANGLE:
            raise ScenarioRefused(
                f"oncoming traffic: lanelet {lid} runs against the route {ahead:.0f} m ahead (a two-way lane)",
                kind="oncoming traffic",
            )


def _siblings(net, route: set[int]) -> set[int]:
    """The lanelets that fork from or merge into the route's (a successor of a route lanelet's predecessor, a
    predecessor of its successor): they leave or join the route, they do not cross it."""
    out = set(route)
    for lid in route:
        lan = net.find_lanelet_by_id(lid)
        for p in lan.predecessor or []:
            out |= set(net.find_lanelet_by_id(p).successor or [])
        for q in lan.successor or []:
            out |= set(net.find_lanelet_by_id(q).predecessor or [])
    return out


def check_oncoming(obstacles: tuple[CrObstacle, ...], road: Road, s0: float, reach_m: float, steps) -> None:
    """Refuse (``oncoming traffic``) a vehicle recorded at one of ``steps`` in the road's band between ``s0`` and
    ``s0 + reach_m``, heading more than 90 degrees against the road."""
    if road.n_min is None or road.n_max is None:
        return
    for ob in obstacles:
        if ob.static:
            continue
        idx = [t - ob.first_step for t in steps if ob.first_step <= t <= ob.last_step][::OBSTACLE_STRIDE]
        if not idx:
            continue
        c = ob.centres[idx]
        s, n, a = road.to_frenet(c[:, 0], c[:, 1], c[:, 2])
        lo = np.interp(s, road.s, road.n_min)
        hi = np.interp(s, road.s, road.n_max)
        against = np.abs(np.remainder(a + np.pi, 2 * np.pi) - np.pi) > np.pi / 2
        bad = (s >= s0) & (s <= s0 + reach_m) & (n > lo) & (n < hi) & against
        if bad.any():
            k = int(np.flatnonzero(bad)[0])
            raise ScenarioRefused(
                f"oncoming traffic: vehicle {ob.id} drives against the road in the ego's lanes "
                f"{float(s[k] - s0):.0f} m ahead at step {ob.first_step + idx[k]}",
                kind="oncoming traffic",
            )


def check_goal_ahead(extent_s: tuple[float, float] | None, s_centre: float) -> None:
    """Refuse (``goal unreachable``) a goal position whose extent along the road, ``extent_s`` (s_lo, s_hi; None: no
    position), ends behind the ego's centre ``s_centre``."""
    if extent_s is not None and extent_s[1] < s_centre:
        raise ScenarioRefused(
            f"goal unreachable: the goal's position lies {s_centre - extent_s[1]:.1f} m and more behind the ego's "
            "start along its road (the ego drives forwards)",
            kind="goal unreachable",
        )


def check_goal_reachable(net, first: int, goals: set[int], depth: int = 200) -> None:
    """Refuse (``goal unreachable``) when ``goals`` (lanelet ids; empty: nothing to check) has no lanelet reachable
    from ``first`` along successors and adjacent lanes of the same direction."""
    if not goals:
        return
    seen, todo = {first}, [first]
    while todo and len(seen) < depth:
        lan = net.find_lanelet_by_id(todo.pop())
        nxt = list(lan.successor or [])
        if lan.adj_left is not None and lan.adj_left_same_direction:
            nxt.append(lan.adj_left)
        if lan.adj_right is not None and lan.adj_right_same_direction:
            nxt.append(lan.adj_right)
        for lid in nxt:
            if lid not in seen and net.find_lanelet_by_id(lid) is not None:
                seen.add(lid)
                todo.append(lid)
    if not seen & goals:
        raise ScenarioRefused(
            f"goal unreachable: none of the goal's lanelets {sorted(goals)} lies along the lanes from lanelet {first}",
            kind="goal unreachable",
        )


def _heading(net, lid: int, xy) -> float:
    from .reference_path import lanelet_heading

    return lanelet_heading(net, lid, xy)


def _intersection_lanelets(inter) -> set[int]:
    """The lanelets inside an intersection of commonroad-io (its incomings' successors)."""
    out: set[int] = set()
    for inc in getattr(inter, "incomings", []):
        for attr in ("successors_right", "successors_straight", "successors_left"):
            out |= set(getattr(inc, attr, None) or ())
    return out
