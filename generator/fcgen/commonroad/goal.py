"""The planning problem's goal: whether and when the ego reached it, as CommonRoad defines it
(``GoalRegion.is_reached`` on the ego's states: time step, position, orientation, speed, where the goal gives them),
and the speed the controller drives for it.

Rules (tested in tests/test_commonroad_goal.py):

- **The ego's state** at sample ``j``: time step ``first_step + j``, its chassis centre (CommonRoad's position: the
  initial state's and the solution file's), its heading (wrapped into each goal orientation interval's turn where
  one is given), its speed.
- **Reached** at the first sample ``j >= 1`` whose state is in the goal region; the run ends there.
- **Reference speed** (``goal_speed``; per sample ``speed_now``), in this order: the initial speed (the traffic's);
  brought into the speeds that bring the ego's centre into the middle half of the goal position's extent along the
  road (``GoalTiming.span``; a point: its centre; of a long one, a goal lanelet, all but ``SPAN_MARGIN`` at either
  end) within the middle half of the goal's time window (a quarter of
  either left free at each end for the ego's acceleration and the tracking's lag), computed from the distance and
  the time *left* at each sample (the ego that lost time behind a slower vehicle or in a lane change makes it up; at
  most ``MIN_TIME`` s of urgency: a late ego asks the distance in 1 s, not in 0; an early one is held back only by
  the time left to the window's middle half); into the goal's speed interval
  shrunk by ``SPEED_MARGIN`` (the tracking settles a little below its reference: aimed at the interval's edge the
  ego arrived 0.2 m/s outside it) where the goal gives a position only once it is within the horizon's reach (the
  interval is the speed at the goal, not on the way: recorded traffic behind does not brake for an ego that slows
  early); at most the initial lanelet's speed limit (a ``MAX_SPEED`` sign); at most ``v_max``.
- **A lane change for the goal** (``change_time``): planned over at most the time left to the goal window's start,
  at least ``MIN_CHANGE`` s.
- **The goal's lateral offset** (``goal_frenet``, ``lateral_reference``): the goal position's centre's offset on the
  reference path, held within the band the ego may use at the goal's ``s``: the target-lane rule's goal
  (``commonroad.lanes``); None where the goal gives no position.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..extras import require

WINDOW_MARGIN = 0.25  # of the goal's time window (and its extent along the road) kept free at either end
SPEED_MARGIN = 0.5  # m/s inside the goal's speed interval (at most a quarter of its width): the tracking's offset
MIN_TIME = 1.0  # s: the shortest time the arrival band divides by (a late ego's urgency)
SPAN_MARGIN = 2.0  # m: at most this of the goal's extent along the road kept free at either end (a long goal lanelet)
MIN_CHANGE = 2.0  # s: the shortest lane change planned for the goal


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


def _inside(lo: float, hi: float) -> tuple[float, float]:
    """The speed interval shrunk by ``SPEED_MARGIN`` (at most a quarter of its width) at either end."""
    m = min(SPEED_MARGIN, 0.25 * (hi - lo))
    return lo + m, hi - m


def _shrunk(a: float, b: float) -> tuple[float, float]:
    """The middle of ``[a, b]``: ``WINDOW_MARGIN`` of its width left free at either end."""
    return a + WINDOW_MARGIN * (b - a), b - WINDOW_MARGIN * (b - a)


@dataclass(frozen=True)
class GoalTiming:
    """What the speed reference needs of the goal (module docstring): its position's extent along the road ``span``
    (s, m; None: no position), its time window (s after the initial step; None: none), its speed interval (m/s;
    None: none); the traffic's speed ``v0``, the lane's speed ``limit`` (None: none) and ``v_max``."""

    span: tuple[float, float] | None
    window: tuple[float, float] | None
    speeds: tuple[float, float] | None
    v0: float
    limit: float | None
    v_max: float

    def __post_init__(self) -> None:
        for name in ("span", "window", "speeds"):
            iv = getattr(self, name)
            if iv is not None and not (math.isfinite(iv[0]) and math.isfinite(iv[1]) and iv[0] <= iv[1]):
                raise ValueError(f"GoalTiming.{name} = {iv} is invalid: allowed a finite interval (lo <= hi)")
        if not (math.isfinite(self.v0) and self.v0 >= 0.0 and self.v_max > 0.0):
            raise ValueError(f"GoalTiming v0 = {self.v0}, v_max = {self.v_max} is invalid: allowed v0 >= 0, v_max > 0")


def arrival_band(g: GoalTiming, t: float, s_c: float) -> tuple[float, float] | None:
    """The speeds that bring the ego's centre (at ``s_c`` at time ``t``) into the middle of the goal's extent within the
    middle of its time window, from what is left (module docstring); None: no position or window, or passed it."""
    if g.span is None or g.window is None:
        return None
    m = min(WINDOW_MARGIN * (g.span[1] - g.span[0]), SPAN_MARGIN)
    s_lo, s_hi = g.span[0] + m, g.span[1] - m
    t_a, t_b = (v - t for v in _shrunk(*g.window))
    if s_hi <= s_c:
        return None
    hi = (s_hi - s_c) / t_a if t_a > 0 else math.inf
    lo = max(s_lo - s_c, 0.0) / max(t_b, MIN_TIME)
    return lo, hi


def speed_now(g: GoalTiming, t: float, s_c: float, near: bool) -> tuple[float, str]:
    """The reference speed at time ``t`` with the ego's centre at ``s_c`` on the road, and what set it last (module
    docstring); ``near``: the goal is within the horizon's reach (its speed interval applies)."""
    v, src = float(g.v0), "initial speed"
    band = arrival_band(g, t, s_c)
    if band is not None and not band[0] <= v <= band[1]:
        v, src = min(max(v, band[0]), band[1]), "goal time window"
    if g.speeds is not None and (near or g.span is None):
        lo, hi = _inside(*g.speeds)
        if not lo <= v <= hi:
            v, src = min(max(v, lo), hi), "goal velocity"
    if g.limit is not None and v > g.limit:
        v, src = g.limit, "speed limit"
    if v > g.v_max:
        v, src = g.v_max, "v_max"
    return v, src


def timing_of(pp, dt: float, span: tuple[float, float] | None, v0: float, limit: float | None, v_max: float):
    """The ``GoalTiming`` of a planning problem (its first goal state), ``span`` its position's extent on the road."""
    step0 = int(pp.initial_state.time_step)
    gs = pp.goal.state_list[0]
    t = _interval(gs, "time_step")
    window = None if t is None else ((t[0] - step0) * dt, (t[1] - step0) * dt)
    return GoalTiming(span, window, _interval(gs, "velocity"), float(v0), limit, float(v_max))


def goal_speed(
    pp, v0: float, dt: float, distance: float | None, limit: float | None, v_max: float, near: bool = True
) -> tuple[float, str]:
    """The reference speed at the start and what set it last (``speed_now``): ``distance`` (m) to the goal position's
    centre along the reference path (None: no position), ``limit`` the lane's speed limit (None: none); ``near=False``:
    the speed on the way, before the goal is within the horizon (the goal's speed interval left out)."""
    span = None if distance is None or distance <= 0 else (float(distance), float(distance))
    return speed_now(timing_of(pp, dt, span, v0, limit, v_max), 0.0, 0.0, near or distance is None)


def change_time(g: GoalTiming | None, t: float, default: float) -> float:
    """How long a lane change towards the goal's lane planned at time ``t`` takes (module docstring)."""
    if g is None or g.window is None:
        return default
    return min(default, max(MIN_CHANGE, g.window[0] - t))


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


def _vertices(shape) -> np.ndarray | None:
    """The outline points of a goal position (a rectangle's or polygon's vertices, a circle's bounding square, a shape
    group's together); None: no shape."""
    if shape is None:
        return None
    if hasattr(shape, "shapes"):
        vs = [v for v in (_vertices(s) for s in shape.shapes) if v is not None]
        return np.vstack(vs) if vs else None
    if hasattr(shape, "radius"):
        c, r = np.asarray(shape.center, dtype=float), float(shape.radius)
        return c + r * np.array([[1.0, 1.0], [1.0, -1.0], [-1.0, 1.0], [-1.0, -1.0]])
    v = getattr(shape, "vertices", None)
    return None if v is None else np.asarray(v, dtype=float)[:, :2]


def goal_extent(pp, road) -> tuple[tuple[float, float], tuple[float, float]] | None:
    """The first goal state's position on ``road``: its extent along the road ``(s_lo, s_hi)`` and across it
    ``(n_lo, n_hi)``; None: no position."""
    gs = pp.goal.state_list[0]
    shape = getattr(gs, "position", None) if gs.has_value("position") else None
    v = _vertices(shape)
    if v is None:
        return None
    s, n, _ = road.to_frenet(v[:, 0], v[:, 1], np.zeros(len(v)))
    s, n = np.asarray(s, dtype=float), np.asarray(n, dtype=float)
    return (float(s.min()), float(s.max())), (float(n.min()), float(n.max()))
