"""The lanes along a scenario's road and the rule that picks the lane the ego drives in (its lateral reference).

**Lanes** (``road_lanes``): every lanelet of the scenario that runs in the road's direction, its centre line on the
road's Frenet frame (``s``, ``n``) over the stretch it covers. The lanes at ``s`` are the lanelets covering it; a lane
*continues* past ``s`` while some lanelet covers the same ``n`` (within half a lane, ``SAME_LANE``) farther on.

**The target lane** (``TargetLane.update``, once per sample; tested in tests/test_commonroad_lanes.py). The target is
a lane centre ``n`` (at the start the ego's own lane); the controller gets it as ``set_reference``'s ``n_ref`` (one
value over the horizon), the goal position's centre instead once the target is the goal's lane. When the target
changes, the change is planned from that sample on: for ``CHANGE_TIME`` s the controller gets ``n_ref`` per stage
(``set_reference_stages``, ``lane_change_profile``), moving from the lane the ego tracked to the target's centre along
the horizon. In this order:

1. **The gap closes**: while the ego changes lanes (its ``n`` more than ``SETTLED`` from the target, and the target
   another lane than the one the ego is in) and the target lane's gap is no longer free (the goal's lane: no longer
   has room, step 3), the target goes back to the lane the ego is in. An ego off its own lane's centre (a recorded
   start 0.6 m off it) is not changing lanes: the steps below still apply.
2. **A lane that ends**: where the target lane does not continue over the look-ahead (``LOOK_AHEAD`` s at the
   ego's speed, at least ``MIN_AHEAD``; to the goal where that is nearer: a lane that ends past it does not), the
   adjacent lane that continues (towards the goal's side first, then the left), when its gap is free (else the
   target stays and the NMPC brakes for the lane's end).
3. **The goal's lane**: where the goal gives a position, the lane nearest its centre, one lane at a time, when the
   next lane has room beside the ego (a gap with no time gap asked and ``T_CLOSE_GOAL`` s of closing speed behind:
   the goal is where the recorded driver went, and the NMPC keeps its distance to the vehicles it sees). The room
   counts ``T_OPEN_GOAL`` s of the speed by which a vehicle there opens the gap (a slower one behind drops back, a
   faster one ahead pulls away): the ego's corner crosses the lane line about half-way through the change, so a
   driver starts beside a slower vehicle it is passing rather than waiting until it is clear. A lane on the way to
   the goal's lane gets the same room, during the change too (step 1): the strict gap there kept the ego out of
   dense traffic for the whole run (USA_US101-24_1, 25_1). The next lane is a step only where it lies nearer the
   goal's centre than the target and goes on over the look-ahead (or to the goal, where that is nearer): else step 2
   or this one sends the ego back at the next sample (USA_US101-23_1, whose goal held within the band lies between
   two lanes, went back and forth at every sample for 4 s).
4. **A slower vehicle ahead**: where the ego is settled in its target lane and the vehicle ahead in it within the
   look-ahead drives more than ``SLOWER`` below the reference speed, an adjacent lane whose gap is free and whose
   vehicle ahead (if any) is farther and faster; never away from the goal's lane (step 3 would bring it back).

**A lane that pauses** (a junction, where the map has no lanelet in the road's direction, or the lanes end a few
centimetres apart before it): where no lane at the ego's ``s`` lies within ``SAME_LANE`` of the target but the target
lane goes on over the look-ahead, the target is kept; the nearest lane still present there is not a lane change
(USA_Lanker-2_15: the three lanes end 0.08 m apart before a junction, and the target stepped left twice within 0.2 s).

**A vehicle closing in from behind** (``keep_ahead``): where the nearest vehicle behind in the ego's lane is
within the chassis length plus ``T_BEHIND`` s of its speed and drives faster than the reference speed, its speed is
the reference speed (at most the lane's limit and ``v_max``): recorded traffic does not brake for an ego slower than
the driver it followed (the vehicle ahead stays the NMPC's constraint).

A lane whose centre lies beyond the problem's band (``Bounds.n_min``/``n_max``, ``n_bounds``) is never a target: the
solver refuses such a reference (USA_US101-26_2 in recorded traffic: a lane at 13.85 m, the band +-8.5 m).

A lane is beside the target (a candidate of steps 2-4) when it is the next one to the right or left at ``s`` and its
centre lies within ``ADJACENT`` of the target's: lanelets of the same direction farther off (a parallel road beyond a
median, 19 m to the left of USA_Peach-3_x's start) are not a lane change away.

**A gap is free** when no vehicle in that lane (its centre within ``SAME_LANE`` of the lane's centre) is ahead of the
ego's centre by less than the chassis length plus ``T_GAP`` s at the ego's speed, nor behind by less than the chassis
length plus ``T_GAP`` s at its own speed plus ``T_CLOSE`` s of the speed by which it closes in. The safe profile's
driver (``close_ahead``) asks the same of the vehicle ahead in a lane of steps 2 and 4 (not the goal's lane, where
room is enough): ahead by the chassis length plus ``T_GAP`` s at the ego's speed plus ``T_CLOSE`` s of the speed by
which the ego closes in on it, so that a change never ends in a gap that a slower vehicle ahead closes within that
time.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

SAME_LANE = 1.75  # m: half a lane: a centre within it is in the lane
SETTLED = 0.5  # m: the ego is in its target lane when its n is within this of the lane's centre
LOOK_AHEAD = 4.0  # s: how far ahead (at the ego's speed) a lane end or a slower vehicle matters
MIN_AHEAD = 40.0  # m: at least this far
SLOWER = 2.0  # m/s: a vehicle ahead this much below the reference speed makes another lane worth changing to
T_GAP = 1.0  # s: time gap to the vehicles ahead and behind in a target lane
T_CLOSE = 3.0  # s: of the closing speed of a vehicle behind
T_CLOSE_GOAL = 1.0  # s: of the closing speed of a vehicle behind, towards the goal's lane (no time gap asked)
T_OPEN_GOAL = 1.0  # s: of the speed by which a vehicle in the goal's lane opens the gap, credited to the room there
CHANGE_TIME = 3.0  # s: a planned lane change's n_ref moves from one lane's centre to the next over this time
GOAL_LANE = "the goal's lane"  # the rule's reason for a change towards the goal's lane
T_BEHIND = 1.5  # s: a faster vehicle behind in the ego's lane nearer than this of its speed sets the reference speed
ADJACENT = 5.0  # m: a lane whose centre lies farther from the target's is not beside it (a road beyond a median)


@dataclass(frozen=True, eq=False)
class Lane:
    """One lanelet's centre line on the road's Frenet frame (``s`` increasing)."""

    id: int
    s: np.ndarray
    n: np.ndarray
    right: np.ndarray | None = None  # its right and left edges' n at the same s (None: not known)
    left: np.ndarray | None = None

    def covers(self, s: float) -> bool:
        return bool(self.s[0] <= s <= self.s[-1])

    def n_at(self, s: float) -> float:
        return float(np.interp(s, self.s, self.n))


def road_lanes(net, road) -> list[Lane]:
    """The lanelets running in the road's direction as ``Lane``s (module docstring)."""
    out = []
    for ll in net.lanelets:
        cv = np.asarray(ll.center_vertices, dtype=float)
        if len(cv) < 2:
            continue
        d = np.diff(cv, axis=0)
        head = np.arctan2(d[:, 1], d[:, 0])
        s, n, a = road.to_frenet(cv[:-1, 0], cv[:-1, 1], head)
        s, n, a = np.asarray(s), np.asarray(n), np.asarray(a)
        ok = (np.cos(a) > 0.5) & (np.abs(n) < 30.0)
        if ok.sum() < 2 or not np.all(np.diff(s[ok]) > 0):
            continue
        sides = [_edge_n(road, np.asarray(v, dtype=float), s, len(cv)) for v in (ll.right_vertices, ll.left_vertices)]
        s_end = s[ok][-1] + np.hypot(*d[-1])
        out.append(
            Lane(int(ll.lanelet_id), np.append(s[ok], s_end), *(np.append(e[ok], e[ok][-1]) for e in (n, *sides)))
        )
    return out


def _edge_n(road, v: np.ndarray, s: np.ndarray, count: int) -> np.ndarray:
    """The road's n of a lanelet's edge vertices ``v`` beside its first ``count - 1`` centre vertices (at ``s``)."""
    if len(v) != count:  # commonroad-io's lanelets have as many edge vertices as centre ones; else resample
        t = np.linspace(0.0, 1.0, len(v))
        u = np.linspace(0.0, 1.0, count)
        v = np.stack([np.interp(u, t, v[:, 0]), np.interp(u, t, v[:, 1])], axis=1)
    _, n, _ = road.to_frenet(v[:-1, 0], v[:-1, 1], np.zeros(count - 1), s)
    return np.asarray(n, dtype=float)


def lanes_at(lanes: list[Lane], s: float) -> list[float]:
    """The lane centres at ``s`` (sorted right to left, lanelets of one lane merged)."""
    ns = sorted(lane.n_at(s) for lane in lanes if lane.covers(s))
    merged: list[float] = []
    for n in ns:
        if not merged or n - merged[-1] > SAME_LANE:
            merged.append(n)
    return merged


def continues(lanes: list[Lane], s: float, n: float, ahead: float) -> bool:
    """Whether a lane at offset ``n`` goes on to ``s + ahead`` (some lanelet covers it there within ``SAME_LANE``)."""
    end = s + ahead
    return any(lane.covers(end) and abs(lane.n_at(end) - n) <= SAME_LANE for lane in lanes)


@dataclass(frozen=True)
class Traffic:
    """The vehicles at one sample on the road's Frenet frame: centre ``s``, ``n``, speed ``v`` and length (arrays;
    ``length`` None: not known, taken as 0)."""

    s: np.ndarray
    n: np.ndarray
    v: np.ndarray
    length: np.ndarray | None = None

    def lengths(self) -> np.ndarray:
        return np.zeros(len(self.s)) if self.length is None else np.asarray(self.length, dtype=float)

    def in_lane(self, n_lane: float) -> np.ndarray:
        return np.abs(self.n - n_lane) <= SAME_LANE


def gap_free(
    traffic: Traffic,
    n_lane: float,
    s: float,
    v: float,
    length: float,
    t_gap: float = T_GAP,
    t_close: float = T_CLOSE,
    t_close_ahead: float = 0.0,
    t_open: float = 0.0,
) -> bool:
    """Whether the gap in the lane at ``n_lane`` beside the ego (centre ``s``, speed ``v``) is free (module
    docstring); ``t_close_ahead``: s of the speed by which the ego closes in on a vehicle ahead asked on top (the
    safe profile's ``T_CLOSE``; 0: none); ``t_open``: s of the speed by which a vehicle opens the gap (slower behind,
    faster ahead) credited (the goal's lane's ``T_OPEN_GOAL``; 0: none)."""
    m = traffic.in_lane(n_lane)
    ds, vo = traffic.s[m] - s, traffic.v[m]
    ahead = length + t_gap * v + t_close_ahead * np.maximum(v - vo, 0.0) - t_open * np.maximum(vo - v, 0.0)
    behind = length + t_gap * vo + t_close * np.maximum(vo - v, 0.0) - t_open * np.maximum(v - vo, 0.0)
    ahead_ok = (ds < 0) | (ds > ahead)
    behind_ok = (ds >= 0) | (-ds > behind)
    return bool(np.all(ahead_ok & behind_ok))


def keep_ahead(traffic: Traffic, n_lane: float, s: float, v_ref: float, length: float) -> float | None:
    """The speed of the nearest vehicle behind in the lane at ``n_lane`` (the ego's centre at ``s``) where it is within
    the chassis length plus ``T_BEHIND`` s of its speed and faster than ``v_ref``; None: no such vehicle (module
    docstring: recorded traffic does not brake for an ego slower than the driver it followed)."""
    m = traffic.in_lane(n_lane) & (traffic.s < s)
    if not m.any():
        return None
    i = int(np.argmax(np.where(m, traffic.s, -np.inf)))
    gap, v = float(s - traffic.s[i]), float(traffic.v[i])
    return v if gap < length + T_BEHIND * v and v > v_ref else None


def leader(traffic: Traffic, n_lane: float, s: float, reach: float) -> tuple[float, float] | None:
    """The nearest vehicle ahead in the lane within ``reach``: (distance, speed), None without one."""
    m = traffic.in_lane(n_lane) & (traffic.s > s) & (traffic.s <= s + reach)
    if not m.any():
        return None
    i = int(np.argmin(np.where(m, traffic.s, np.inf)))
    return float(traffic.s[i] - s), float(traffic.v[i])


@dataclass
class TargetLane:
    """The target-lane rule's state over a run (module docstring): the lanes, the goal's lateral offset, the ego's
    chassis length and reference speed; ``n`` the current target."""

    lanes: list[Lane]
    goal_n: float | None
    length: float
    v_ref: float
    n: float
    reason: str = "start"
    close_ahead: bool = False  # the safe profile's gap: also T_CLOSE of closing ahead (not towards the goal's lane)
    goal_s: float | None = None  # the goal position's centre along the road (None: not known)
    n_bounds: tuple[float, float] = (-np.inf, np.inf)  # the problem's band (Bounds): a lane beyond it is not a target

    def update(self, s: float, n_ego: float, v: float, traffic: Traffic) -> tuple[float, str]:
        """The target after the ego's state (centre ``s``, ``n_ego``, speed ``v``) and the traffic at this sample."""
        here = [c for c in lanes_at(self.lanes, s) if self.n_bounds[0] <= c <= self.n_bounds[1]]
        if not here:
            return self.n, self.reason
        reach = max(MIN_AHEAD, LOOK_AHEAD * v)
        if min(abs(c - self.n) for c in here) > SAME_LANE and continues(self.lanes, s, self.n, reach):
            return self._set(self.n, self.reason)  # the target lane pauses here (a junction) and goes on: kept
        own = min(here, key=lambda c: abs(c - n_ego))
        target = min(here, key=lambda c: abs(c - self.n))
        settled = abs(n_ego - target) <= SETTLED

        def free(c: float, to_goal: bool = False) -> bool:
            if to_goal or (self.goal_n is not None and abs(self.goal_n - c) <= SAME_LANE):  # room is enough
                return gap_free(traffic, c, s, v, self.length, 0.0, T_CLOSE_GOAL, t_open=T_OPEN_GOAL)
            return gap_free(traffic, c, s, v, self.length, t_close_ahead=T_CLOSE if self.close_ahead else 0.0)

        if not settled and target != own and not free(target, self.reason == GOAL_LANE):
            return self._set(own, "the gap closed")
        i = here.index(target)
        left = here[i + 1] if i + 1 < len(here) and here[i + 1] - target <= ADJACENT else None
        right = here[i - 1] if i > 0 and target - here[i - 1] <= ADJACENT else None
        toward = None
        if self.goal_n is not None and abs(self.goal_n - target) > SAME_LANE:
            toward = left if self.goal_n > target else right
            if toward is not None and abs(self.goal_n - toward) >= abs(self.goal_n - target):
                toward = None  # not nearer the goal (a goal between two lanes): the lane nearest it is the target
        neighbours = list(dict.fromkeys(c for c in (toward, left, right) if c is not None))
        ahead = self._to_goal(s, reach)
        if not continues(self.lanes, s, target, ahead):
            for c in neighbours:
                if continues(self.lanes, s, c, ahead) and free(c):
                    return self._set(c, "the lane ends")
            return self._set(target, self.reason)
        if toward is not None and continues(self.lanes, s, toward, ahead):
            return self._set(toward if free(toward, True) else target, GOAL_LANE)
        lead = leader(traffic, target, s, reach)
        if settled and lead is not None and lead[1] < self.v_ref - SLOWER:
            for c in neighbours:
                away = self.goal_n is not None and abs(self.goal_n - c) > abs(self.goal_n - target)
                other = leader(traffic, c, s, reach)
                faster = other is None or (other[0] > lead[0] and other[1] > lead[1])
                if not away and faster and continues(self.lanes, s, c, reach) and free(c):
                    return self._set(c, "a slower vehicle ahead")
        return self._set(target, self.reason)

    def _to_goal(self, s: float, reach: float) -> float:
        """How far ahead a lane towards the goal must go on: the look-ahead, or to the goal where it lies nearer."""
        return reach if self.goal_s is None or self.goal_s <= s else min(reach, self.goal_s - s)

    def _set(self, n: float, reason: str) -> tuple[float, str]:
        """Keep the target lane ``n``; the reference is the goal's centre once the target is the goal's lane."""
        if abs(n - self.n) > SAME_LANE:  # another lane (not its centre's drift along the road)
            self.reason = reason
        self.n = n
        if self.goal_n is not None and abs(self.goal_n - n) <= SAME_LANE:
            return self.goal_n, self.reason
        return self.n, self.reason


def target_lane(
    sc, length: float, goal_n: float | None, n_ego: float, close_ahead: bool = False, n_bounds=(-np.inf, np.inf)
) -> TargetLane:
    """The rule's state at the start of a run on ``sc``: its road's lanes, the target the ego's own lane;
    ``close_ahead``: the safe profile's gap (``TargetLane.close_ahead``); ``n_bounds``: the problem's band."""
    lanes = road_lanes(sc.scenario.lanelet_network, sc.road)
    s0 = float(sc.x0[0])
    here = lanes_at(lanes, s0)
    own = min(here, key=lambda c: abs(c - n_ego)) if here else 0.0
    goal_s = None if sc.goal_sn is None else float(sc.goal_sn[0])
    n_bounds = (float(n_bounds[0]), float(n_bounds[1]))
    v_ref = float(sc.v_ref)
    return TargetLane(lanes, goal_n, length, v_ref, own, close_ahead=close_ahead, goal_s=goal_s, n_bounds=n_bounds)


def traffic_at(obstacles, road, step: int, dt: float) -> Traffic:
    """The obstacles present at ``step`` on ``road``'s Frenet frame, their speeds from their poses one step on."""
    rows = []
    for ob in obstacles:
        if not ob.present(step):
            continue
        p, q = ob.pose(step), ob.pose(step + 1)
        if p is None:
            continue
        v = 0.0 if q is None or ob.static else float(np.hypot(q[0] - p[0], q[1] - p[1]) / dt)
        rows.append((p[0], p[1], p[2], v, ob.length))
    if not rows:
        return Traffic(np.zeros(0), np.zeros(0), np.zeros(0), np.zeros(0))
    a = np.array(rows)
    s, n, _ = road.to_frenet(a[:, 0], a[:, 1], a[:, 2])
    s, n = (np.atleast_1d(np.asarray(x, dtype=float)) for x in (s, n))
    return Traffic(s, n, a[:, 3], a[:, 4])


def lane_change_profile(n_from: float, n_to: float, since: float, times, duration: float = CHANGE_TIME) -> np.ndarray:
    """n_ref per node of a lane change planned ``since`` s ago over ``duration`` s: node k (time t_k from now) at
    n_from + (n_to - n_from) h(u), u = (since + t_k) / duration within [0, 1], h(u) = 3 u^2 - 2 u^3 (no lateral speed
    asked at either end)."""
    u = np.clip((since + np.asarray(times, dtype=float)) / duration, 0.0, 1.0)
    return n_from + (n_to - n_from) * (3.0 * u * u - 2.0 * u * u * u)
