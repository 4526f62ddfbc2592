"""The lateral band the solver gets at each sample of a CommonRoad run: the lanes the ego uses, and a way back for an
ego that is off it.

Rules (tested in tests/test_commonroad_band.py):

- **The lanes in use** (``lanes_in_use``): the lanes at the ego's ``s`` whose extent (the lanelet's edges) overlaps
  the chassis' lateral extent by more than ``OVERLAP``, and the target lane (``lanes.TargetLane``); they are given by
  the range of their centres. Settled in a lane, that one lane; while it changes lanes, the source and the target
  lane; a chassis across a lane marking, both lanes.
- **Their band** (``lane_band``): at each road sample, from the right edge to the left edge of the lanelets covering
  it whose centre lies in that range (within ``SAME_LANE``), within the road's band (``reference_path.drivable_band``:
  a lane that ends narrows it where it ends); where no such lanelet covers the sample (the road's extensions), the
  road's band.
- **The way back** (``way_back``): where the ego's reference point (the rear axle, whose bound is the band shrunk for
  the chassis) is less than ``BACK_MARGIN`` inside an edge of the band at its ``s`` or beyond it (a start over the
  road's edge, a band that narrows under the ego, a lane change called off), or, after a sample whose QP had no
  solution, would cross it within ``BACK_TURN`` s at its heading (a heading towards the edge it cannot steer out of
  in time), that edge is moved out: to the ego's path at its current heading over ``BACK_STEP`` s (after a sample
  without a solution ``BACK_TURN`` s; the drift held after it) plus ``BACK_ROOM`` (at its ``s`` and behind: its
  ``n`` plus ``BACK_ROOM``), returning to the band ahead along ``3 u^2 - 2 u^3`` over ``max(BACK_MIN, BACK_TIME v)``
  metres. The room beyond the ego is kept small: an obstacle row pushing the plan outwards would use it, sample
  after sample. The QP keeps a solution and the
  plan comes back inside the band, where the band as a hard bound would leave it without one (the contract's
  fallback driving) until the ego stood inside it again. The heading counts only after a failure: counted always,
  it gives the plan room beyond the band wherever the ego heads towards an edge, which the plan uses (measured:
  more road departures, docs/commonroad.md).
- **With the corners' band** (``Bounds.road_bound = "corners"``, ``SolverBand.corners``): the reference points are
  the outermost corner on each side; each corner's row takes the band at its own ``s`` (``road_rows.band_ahead``);
  an edge moves only where such a corner is beyond it or its own path over ``CORNER_STEP`` (its lateral speed from
  the heading and the yaw rate at the held steering angle: what the next sample brings whatever the plan) crosses
  it, to that path without ``BACK_ROOM`` (a corner at the edge is where the band lets the car drive: room beyond it,
  or the rear axle's straight path over ``BACK_STEP``, was used sample after sample), from the front corners' ``s``
  back; after a sample without a solution, as for the rear axle.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..dsl import Vehicle
from ..models import corner_n
from ..road import Road
from .lanes import SAME_LANE, Lane

OVERLAP = 0.1  # m: a lane the chassis overlaps by less is not in use
BACK_MARGIN = 0.1  # m: an ego less than this inside an edge moves it
BACK_ROOM = 0.02  # m: the moved edge lies this far beyond the ego's path
BACK_STEP = 0.2  # s: the ego's path at its heading the moved edge holds (after a sample without a solution: BACK_TURN)
BACK_TIME = 3.0  # s: the moved edge returns to the band over this time at the ego's speed ...
BACK_MIN = 10.0  # m: ... and at least this distance
BACK_TURN = 1.0  # s: the moved edge holds the ego's path at its current heading for this time
CORNER_STEP = 0.1  # s: the corners' path (at their current lateral speed) the moved edge holds


def lanes_in_use(lanes: list[Lane], s: float, n_lo: float, n_hi: float, target: float) -> tuple[float, float]:
    """The range of centres of the lanes at ``s`` that overlap the chassis' lateral extent ``[n_lo, n_hi]`` by more
    than ``OVERLAP``, with the target lane's centre ``target``."""
    centres = [target]
    for lane in lanes:
        if lane.right is None or lane.left is None or not lane.covers(s):
            continue
        r, le = float(np.interp(s, lane.s, lane.right)), float(np.interp(s, lane.s, lane.left))
        if min(le, n_hi) - max(r, n_lo) > OVERLAP:
            centres.append(lane.n_at(s))
    return min(centres), max(centres)


def lane_band(
    lanes: list[Lane], s: np.ndarray, centres: tuple[float, float], road_lo: np.ndarray, road_hi: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """At the road samples ``s``: the band of the lanes whose centre lies within ``SAME_LANE`` of ``centres``
    (lo, hi), within the road's band ``road_lo``/``road_hi``; the road's band where none covers a sample."""
    s = np.asarray(s, dtype=float)
    lo, hi = np.full(s.shape, np.inf), np.full(s.shape, -np.inf)
    for lane in lanes:
        if lane.right is None or lane.left is None:
            continue
        cov = (s >= lane.s[0]) & (s <= lane.s[-1])
        if not cov.any():
            continue
        c = np.interp(s, lane.s, lane.n)
        use = cov & (c >= centres[0] - SAME_LANE) & (c <= centres[1] + SAME_LANE)
        lo = np.where(use, np.minimum(lo, np.interp(s, lane.s, lane.right)), lo)
        hi = np.where(use, np.maximum(hi, np.interp(s, lane.s, lane.left)), hi)
    lo, hi = np.maximum(lo, road_lo), np.minimum(hi, road_hi)
    none = ~(lo < hi)
    return np.where(none, road_lo, lo), np.where(none, road_hi, hi)


def way_back(
    s: np.ndarray,
    lo: np.ndarray,
    hi: np.ndarray,
    s0: float,
    n0: float | tuple[float, float],
    alpha: float,
    v: float,
    heading: bool = True,
    drift: tuple[float, float] | None = None,
) -> tuple[np.ndarray, np.ndarray, bool]:
    """The band ``lo``/``hi`` at the road samples ``s`` with the way back for a reference point at (``s0``, ``n0``),
    heading ``alpha`` to the road, speed ``v`` (module docstring), and whether it moved an edge; ``heading``: whether
    the ego's path at its heading counts (else its position alone). ``n0`` a pair: the points nearest the lower and
    the upper edge, the chassis' outermost corners on each side, whose rows hold them inside the band: then an edge
    moves only where such a corner is beyond it, or after a sample without a solution (the rule as for the rear axle;
    a corner near the edge is where the corners' band lets the car drive, and the room beyond it would be used).
    ``drift``: then the corners' outward motion per metre along the road (lower, upper side), their path's over
    ``CORNER_STEP`` instead of ``BACK_STEP`` at the heading."""
    s, lo, hi = np.asarray(s, dtype=float), np.asarray(lo, dtype=float), np.asarray(hi, dtype=float)
    corners = drift is not None and not heading
    turn = max(v, 0.0) * (BACK_TURN if heading else CORNER_STEP if corners else BACK_STEP)
    ahead = np.clip(s - s0, 0.0, turn)
    u = np.clip((s - s0) / max(BACK_MIN, BACK_TIME * max(v, 0.0)), 0.0, 1.0)
    h = 3.0 * u * u - 2.0 * u * u * u
    moved = False
    n_side: tuple[float, float] = n0 if isinstance(n0, tuple) else (float(n0), float(n0))
    for i, (sign, n_e) in enumerate(zip((-1.0, 1.0), n_side)):  # the lower, then the upper edge
        band = lo if sign < 0 else hi
        per_m = max(sign * (np.tan(alpha) if drift is None or heading else drift[i]), 0.0)  # towards this edge
        room, margin = (0.0, 0.0) if corners else (BACK_ROOM, BACK_MARGIN)
        edge = n_e + sign * (room + per_m * ahead)  # the path at the current heading, then held
        inside = -sign * (n_e - float(np.interp(s0, s, band)))  # how far inside the edge at s0
        if inside > margin and max(float(np.interp(s0 + d, s, sign * (edge - band))) for d in (0.0, turn)) <= 0.0:
            continue
        new = edge + (band - edge) * h
        if not np.any(sign * (new - band) > 0.0):
            continue
        band = np.minimum(band, new) if sign < 0 else np.maximum(band, new)
        lo, hi = (band, hi) if sign < 0 else (lo, band)
        moved = True
    return lo, hi, moved


BAND_RULES = ("road", "road_back", "lanes")
"""``road``: the road's band (every lane of the driving direction); ``road_back``: with the way back; ``lanes``: the
lanes in use with the way back (the default)."""


@dataclass(frozen=True, eq=False)
class SolverBand:
    """What the solver's band at a sample is made of: the rule (``BAND_RULES``), the lanes, the road's band, the
    inset for the chassis (the rear axle's band is the lanes' shrunk by it; with ``corners``, the corners' band by
    it) and the problem's ``Bounds`` it is cut to; the chassis' half length and width and the rear axle's distance to
    its centre; ``corners``: whether the band bounds the chassis' corners (``Bounds.road_bound``)."""

    rule: str
    lanes: list
    road: Road  # the scenario's road with its drivable band
    inset: float
    n_bounds: tuple[float, float]
    half_length: float
    half_width: float
    to_centre: float
    corners: bool = False

    def __post_init__(self) -> None:
        if self.rule not in BAND_RULES:
            raise ValueError(f"band {self.rule!r} is not a band rule: allowed {', '.join(BAND_RULES)}")

    @property
    def vehicle(self) -> Vehicle:
        """The chassis' geometry as a ``Vehicle`` (for ``models.corner_n``)."""
        half = self.half_length
        return Vehicle(l_f=self.to_centre, l_r=self.to_centre, l_f_ch=half, l_r_ch=half, w_ch=2 * self.half_width)

    def corner_motion(self, x: np.ndarray) -> tuple[tuple[float, float], tuple[float, float]]:
        """At Frenet state ``x``: the outermost corner's n on the lower and the upper side, and how far the corners
        there move outwards per metre along the road over ``CORNER_STEP`` (Euler, steering angle held)."""
        s, n, a, v, d = (float(e) for e in x[:5])
        kappa = float(self.road.eval(s)[0])

        def kappa_at(ahead: float) -> float:
            return float(self.road.eval(s + ahead)[0])

        c0 = np.array([float(c) for c in corner_n(n, a, self.vehicle, kappa, kappa_at)])
        t = CORNER_STEP
        s_dot = v * np.cos(a) / (1.0 - n * kappa)
        a1 = a + t * (v * np.tan(d) / (2.0 * self.to_centre) - kappa * s_dot)
        c1 = np.array([float(c) for c in corner_n(n + t * v * np.sin(a), a1, self.vehicle, kappa, kappa_at)])
        path = max(v * t, 1e-9)
        lo_i, hi_i = 2 + int(np.argmin(c0[2:])), int(np.argmax(c0[:2]))
        return (float(c0[lo_i]), float(c0[hi_i])), (
            float(c1[lo_i] - c0[lo_i]) / path,
            float(c1[hi_i] - c0[hi_i]) / path,
        )

    def set(self, win, x: np.ndarray, target: float, heading: bool = False) -> bool:
        """Put the band of the rear axle at state ``x`` (Frenet) into the solver's road window ``win`` (in place);
        ``target``: the target lane's centre; ``heading``: the way back counts the ego's heading (after a sample
        without a solution). Whether the way back moved an edge."""
        if self.rule == "road":
            return False
        s_win = win.s
        if self.rule == "lanes":
            road = self.road
            assert road.n_min is not None and road.n_max is not None  # a scenario's road has its band
            road_lo = np.interp(s_win, road.s, road.n_min) + np.zeros(len(s_win))
            road_hi = np.interp(s_win, road.s, road.n_max) + np.zeros(len(s_win))
            a = float(x[2])
            s_c, n_c = float(x[0]) + self.to_centre, float(x[1]) + self.to_centre * np.sin(a)
            reach = self.half_length * abs(np.sin(a)) + self.half_width * np.cos(a)
            centres = lanes_in_use(self.lanes, s_c, n_c - reach, n_c + reach, target)
            lo_l, hi_l = lane_band(self.lanes, s_win, centres, road_lo, road_hi)
            lo = np.maximum(lo_l + self.inset, self.n_bounds[0])
            hi = np.minimum(hi_l - self.inset, self.n_bounds[1])
            narrow = ~(lo < hi)  # a lane narrower than the chassis there: the road's band
            lo, hi = np.where(narrow, win.n_min, lo), np.where(narrow, win.n_max, hi)
        else:
            lo, hi = win.n_min, win.n_max
        n0: float | tuple[float, float] = float(x[1])
        drift, s0 = None, float(x[0])
        if self.corners:  # the outermost corner on each side, and its lateral speed; from the front corners' s back
            n0, drift = self.corner_motion(x)
            s0 += self.to_centre + self.half_length
        lo, hi, moved = way_back(s_win, lo, hi, s0, n0, float(x[2]), float(x[3]), heading, drift)
        win.n_min[:] = np.maximum(lo, self.n_bounds[0])
        win.n_max[:] = np.minimum(hi, self.n_bounds[1])
        return moved
