"""The planning problem's goal: whether and when the ego reached it, as CommonRoad defines it
(``GoalRegion.is_reached`` on the ego's states: time step, position, orientation, speed, where the goal gives them),
and the speed the controller drives for it.

Rules (tested in tests/test_commonroad_goal.py):

- **The ego's state** at sample ``j``: time step ``first_step + j``, its chassis centre (CommonRoad's position: the
  initial state's and the solution file's), its heading (wrapped into each goal orientation interval's turn where
  one is given), its speed.
- **Reached** at the first sample ``j >= 1`` whose state is in the goal region; the run ends there.
- **Reference speed** (``goal_speed``), in this order: the initial speed (the traffic's); brought into the speeds
  that arrive at the goal position's centre (its distance ``d`` ahead along the reference path) within the middle
  half of the goal's time window ``[t_a, t_b]`` (``d / t_b <= v <= d / t_a``, a quarter of the window left free at
  either end for the ego's acceleration and the tracking's lag); into the goal's speed interval (where the goal
  gives a position: only once it is within the horizon's reach, ``v_goal``: the interval is the speed at the goal,
  not on the way, and recorded traffic behind does not brake for an ego that slows early); at most the initial
  lanelet's speed limit (a ``MAX_SPEED`` sign); at most ``v_max``.
- **The goal's lateral offset** (``goal_frenet``, ``lateral_reference``): the goal position's centre's offset on the
  reference path, held within the band the ego may use at the goal's ``s``: the target-lane rule's goal
  (``commonroad.lanes``); None where the goal gives no position.
"""

from __future__ import annotations

import math

import numpy as np

from ..extras import require

WINDOW_MARGIN = 0.25  # of the goal's time window kept free at either end (the ego's acceleration, the tracking's lag)


def _goal_centre(shape) -> np.ndarray | None:
    """The centre of a goal position (a rectangle, circle, polygon, or the mean of a shape group's centres)."""
    if shape is None:
        return None
    if hasattr(shape, "shapes"):
        cs = [c for c in (_goal_centre(s) for s in shape.shapes) if c is not None]
        return np.mean(cs, axis=0) if cs else None
    c = getattr(shape, "center", None)
    return None if c is None else np.asarray(c, dtype=float)


def goal_centres(pp) -> list[np.ndarray]:
    """The centres of the goal states' positions (those that give one)."""
    out = []
    for gs in pp.goal.state_list:
        c = _goal_centre(getattr(gs, "position", None)) if gs.has_value("position") else None
        if c is not None:
            out.append(c)
    return out


def _interval(gs, name: str):
    v = getattr(gs, name, None) if gs.has_value(name) else None
    return (float(v.start), float(v.end)) if v is not None and hasattr(v, "start") else None


def speed_limit(net, lanelet_id: int) -> float | None:
    """The initial lanelet's speed limit (m/s) from a ``MAX_SPEED`` sign, None without one."""
    for sid in sorted(net.find_lanelet_by_id(lanelet_id).traffic_signs or []):
        for el in net.find_traffic_sign_by_id(sid).traffic_sign_elements:
            if "MAX_SPEED" in str(el.traffic_sign_element_id.name) and el.additional_values:
                return float(el.additional_values[0])
    return None


def goal_speed(
    pp, v0: float, dt: float, distance: float | None, limit: float | None, v_max: float, near: bool = True
) -> tuple[float, str]:
    """The reference speed and what set it last (module docstring): ``distance`` (m) to the goal position's centre
    along the reference path (None: no position), ``limit`` the lane's speed limit (None: none); ``near=False``: the
    speed on the way, before the goal is within the horizon (the goal's speed interval left out)."""
    v, src = float(v0), "initial speed"
    step0 = int(pp.initial_state.time_step)
    gs = pp.goal.state_list[0]
    t = _interval(gs, "time_step")
    if distance is not None and distance > 0 and t is not None:
        t_a, t_b = (t[0] - step0) * dt, (t[1] - step0) * dt
        t_a, t_b = t_a + WINDOW_MARGIN * (t_b - t_a), t_b - WINDOW_MARGIN * (t_b - t_a)
        hi = distance / t_a if t_a > 0 else math.inf
        lo = distance / t_b if t_b > 0 else math.inf
        if not lo <= v <= hi:
            v, src = min(max(v, lo), hi), "goal time window"
    vi = _interval(gs, "velocity") if near or distance is None else None
    if vi is not None and not vi[0] <= v <= vi[1]:
        v, src = min(max(v, vi[0]), vi[1]), "goal velocity"
    if limit is not None and v > limit:
        v, src = limit, "speed limit"
    if v > v_max:
        v, src = v_max, "v_max"
    return v, src


def _wrapped(phi: float, pp) -> list[float]:
    """The heading wrapped to (-pi, pi] and into each goal orientation interval's turn."""
    out = [math.remainder(phi, 2 * math.pi)]
    for gs in pp.goal.state_list:
        iv = _interval(gs, "orientation")
        if iv is not None:
            out.append(iv[0] + (phi - iv[0]) % (2 * math.pi))
    return out


def reached(pp, step: int, centre, phi: float, v: float) -> bool:
    """Whether the ego's state (chassis centre ``centre``, heading ``phi``, speed ``v`` at ``step``) is in the goal
    region (``GoalRegion.is_reached``)."""
    with require("commonroad", "the goal region's check"):
        from commonroad.scenario.state import KSState

    pos = np.asarray(centre[:2], dtype=float)
    for a in _wrapped(float(phi), pp):
        st = KSState(time_step=int(step), position=pos, orientation=a, velocity=float(v), steering_angle=0.0)
        if pp.goal.is_reached(st):
            return True
    return False


def first_reached(pp, first_step: int, centres: np.ndarray, v: np.ndarray) -> int | None:
    """The first sample ``j >= 1`` whose state is in the goal region (None: never); ``centres`` (K + 1, 3)."""
    for j in range(1, len(centres)):
        if reached(pp, first_step + j, centres[j], float(centres[j, 2]), float(v[j])):
            return j
    return None


def goal_frenet(pp, road) -> tuple[float, float] | None:
    """``(s, n)`` of the goal position's centre on ``road`` (None: the goal gives no position)."""
    cs = goal_centres(pp)
    if not cs:
        return None
    s, n, _ = road.to_frenet(np.array([cs[0][0]]), np.array([cs[0][1]]), np.array([0.0]))
    return float(s[0]), float(n[0])


def lateral_reference(goal_sn: tuple[float, float] | None, road) -> tuple[float, str]:
    """The lateral reference and its source (module docstring); ``road``: the band the ego's reference point may
    use."""
    if goal_sn is None or road.n_min is None:
        return 0.0, "reference path"
    s, n = goal_sn
    i = int(np.clip(round((s - road.s0) / road.ds), 0, len(road.kappa) - 1))
    lo, hi = float(road.n_min[i]), float(road.n_max[i])
    if lo <= n <= hi:
        return n, "goal position"
    return min(max(n, lo), hi), "goal position, held within the band"
