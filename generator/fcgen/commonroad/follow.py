"""The safe profile's speed reference behind a vehicle ahead (tested in tests/test_commonroad_follow.py).

The goal's reference speed (``goal.goal_speed``) ignores the traffic: the NMPC then keeps its distance to a slower
vehicle ahead only where its obstacle rows bind, a few metres behind it, and closes in on it at the full speed
difference. With ``Following`` the reference speed is also at most

    v_follow = max(0, v_lead + max(0, gap - s0 - t_gap v_lead) / t_close)

for the nearest vehicle ahead in the ego's corridor: its centre ahead of the ego's centre and within half a lane
(``lanes.SAME_LANE``) across the road of the ego's centre (the vehicles the criticality measures ask about), ``gap``
bumper to bumper along the road (the centres' distance less the half lengths), ``v_lead`` its speed. Beyond the
gap ``s0 + t_gap v_lead`` the ego closes in at most at ``(gap - s0 - t_gap v_lead) / t_close``, so the time to
collision at the reference speed, ``gap / (v_ref - v_lead)``, is at least ``t_close`` (``gap t_close / (gap - s0 -
t_gap v_lead)``); within it the reference is the vehicle's speed (no closing in; the rule does not brake below it to
open the gap: the NMPC's obstacle rows keep the distance, and braking below the traffic's speed cost goals and drew
recorded followers into the ego in a first design, docs/commonroad.md).

**The leader's rows** (``LeadRows``): the reference is a wish the NMPC trades against its obstacle rows. Squeezed
(a vehicle in the next lane coming level from behind, whose safe ellipse reaches across the ego's lane), the plan
drives at full force towards its leader whatever the reference, until the leader's own ellipse binds about 0.9 m
bumper to bumper. So the leader's rectangle the solver gets (its rows and the plan check) is also lengthened backwards
by ``t_row`` times the speed by which the ego closes in on it (rounded up to ``row_step``): at that closing speed the
rows bind at a time to collision of more than ``t_row``; at the leader's speed or slower it is the vehicle as it is.
The lengthened rear stays ``row_gap`` ahead of the ego's front (closer, the rows hold the ego where it is rather than
push it back).
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

import numpy as np

from .lanes import SAME_LANE, Traffic


@dataclass(frozen=True)
class Following:
    """The rule's parameters: the time gap ``t_gap`` (s) and standstill gap ``s0`` (m) it settles at, and the time
    ``t_close`` (s) over which it closes a larger gap (the smallest time to collision its reference asks for)."""

    t_gap: float = 1.0
    s0: float = 2.0
    t_close: float = 2.0
    t_row: float = 1.5  # s: the leader's rectangle lengthened by this times the closing speed (module docstring)
    row_step: float = 0.5  # m: the lengthening rounded up to a multiple of this (fewer shapes to compute)
    b_release: float = 2.0  # m/s^2: the lengthening shrinks at most as this deceleration would close it (LeadRows)
    row_gap: float = 1.0  # m: the lengthened rear stays at least this far ahead of the ego's front

    def __post_init__(self) -> None:
        for name in ("t_gap", "s0", "t_close", "t_row", "row_step", "b_release", "row_gap"):
            v = getattr(self, name)
            if not (isinstance(v, (int, float)) and math.isfinite(v) and v > 0.0):
                raise ValueError(f"Following.{name} = {v!r}: must be a finite number > 0")

    def speed(self, gap: float, v_lead: float) -> float:
        """v_follow (module docstring) for a bumper-to-bumper ``gap`` (m) to a vehicle ahead at ``v_lead`` (m/s)."""
        return max(0.0, v_lead + max(0.0, gap - self.s0 - self.t_gap * v_lead) / self.t_close)

    def extension(self, v_ego: float, v_lead: float, gap: float, held: float = 0.0) -> float:
        """How far (m) the leader's rectangle is lengthened backwards at a bumper-to-bumper ``gap``: ``t_row``
        (v_ego - v_lead), at least 0 and ``held``, rounded up to a multiple of ``row_step``; at most ``gap -
        row_gap`` rounded down to one (the rows hold the ego where it is, they never push it back)."""
        g = self.row_step * math.ceil(max(self.t_row * max(0.0, v_ego - v_lead), held) / self.row_step - 1e-9)
        return min(g, self.row_step * math.floor(max(0.0, gap - self.row_gap) / self.row_step + 1e-9))


def vehicle_ahead(
    traffic: Traffic, s: float, lanes_n: tuple[float, ...], ego_length: float
) -> tuple[float, float, int] | None:
    """The nearest vehicle ahead in the ego's corridor (module docstring): (gap bumper to bumper, speed, its index
    in ``traffic``), None without one. ``s``: the ego's centre; ``lanes_n``: the lateral offsets whose half lane is
    the corridor; ``ego_length``: the ego's chassis length; the vehicles' lengths are ``traffic.length``."""
    corridor = np.zeros(len(traffic.s), dtype=bool)
    for n in lanes_n:
        corridor |= np.abs(traffic.n - n) <= SAME_LANE
    m = corridor & (traffic.s > s)
    if not m.any():
        return None
    lengths = traffic.lengths()
    gaps = np.where(m, traffic.s - s - (lengths + ego_length) / 2, np.inf)
    i = int(np.argmin(gaps))
    return float(gaps[i]), float(traffic.v[i]), i


class LeadRows:
    """The leader's rectangle over a run (module docstring): ``shapes`` lengthens it sample by sample. The lengthening
    follows the closing speed up at once and down at most by ``t_row b_release dt`` a sample (as a deceleration of
    ``b_release`` would shrink it) while the ego closes in; none once it does not. Lengthened and shortened with the
    speed each sample, the rows pulled the plan to full braking and back to full force in turn (US101-5_1); held
    below the leader's speed, they pushed a stopped ego backwards. ``samples`` counts the samples it lengthens."""

    def __init__(self, rule: Following, dt: float):
        self.rule, self.dt = rule, dt
        self.lead: int | None = None  # the leader's obstacle id
        self.held = 0.0  # m: the last lengthening before rounding
        self.samples = 0

    def shapes(self, sc, step: int, ids, shapes: np.ndarray, ego, x: np.ndarray) -> np.ndarray:
        """The opponent slots' shapes (length, width, offset) with the leader's lengthened backwards: the nearest
        occupant ahead in the ego's corridor (``vehicle_ahead`` among the slots' vehicles at scenario step ``step``;
        ``x``: the ego's rear-axle state on ``sc.road``, ``ego``: its ``Vehicle``); ``shapes`` itself without one or
        without a lengthening."""
        from .lanes import traffic_at

        by_id = {int(ob.id): ob for ob in sc.obstacles}
        slots = [j for j, i in enumerate(ids) if i is not None and int(i) in by_id]
        traffic = traffic_at([by_id[int(ids[j])] for j in slots], sc.road, step, sc.dt)
        half = ego.l / 2
        s_c, n_c = float(x[0]) + half * math.cos(float(x[2])), float(x[1]) + half * math.sin(float(x[2]))
        ok = len(traffic.s) == len(slots)  # else an occupant without a pose at the step: its slot is unknown
        lead = vehicle_ahead(traffic, s_c, (n_c,), ego.l_ch) if ok else None
        gap, v_lead, i = (0.0, math.inf, -1) if lead is None else lead
        oid, closing = (None if lead is None else int(ids[slots[i]])), float(x[3]) > v_lead
        held = self.held - self.rule.t_row * self.rule.b_release * self.dt if closing and oid == self.lead else 0.0
        self.lead = oid
        self.held = max(self.rule.t_row * (float(x[3]) - v_lead), held) if closing else 0.0
        g = self.rule.extension(float(x[3]), v_lead, gap, self.held) if closing else 0.0
        if g <= 0.0:
            return shapes
        out = np.array(shapes, dtype=float)
        j = slots[i]
        out[j] = (out[j, 0] + g, out[j, 1], out[j, 2] - g / 2)  # the front where it is, the rear g further back
        self.samples += 1
        return out


def follow_speed(rule: Following, traffic: Traffic, s: float, lanes_n: tuple[float, ...], ego_length: float):
    """The reference speed's cap behind the vehicle ahead (``Following.speed``), None without a vehicle ahead."""
    lead = vehicle_ahead(traffic, s, lanes_n, ego_length)
    return None if lead is None else rule.speed(lead[0], lead[1])


def follow_log(rule: Following | None, followed: int, rows: LeadRows | None) -> dict | None:
    """The run log's ``extra.commonroad.follow``: the rule's parameters, the samples whose reference the vehicle
    ahead capped (``samples``) and whose leader's rectangle it lengthened (``lead``); None without the rule."""
    if rule is None:
        return None
    return {**dataclasses.asdict(rule), "samples": followed, "lead": 0 if rows is None else rows.samples}


def profile_following(problem) -> Following | None:
    """The driver's rule of ``problem``'s profile: ``Following()`` for the safe profile (its curve speed on,
    ``Reference.curve_a_lat > 0``), None for the paper's (``presets.PAPER_CURVE_A_LAT = 0``: the reference as
    given)."""
    return Following() if problem.reference.curve_a_lat > 0.0 else None
