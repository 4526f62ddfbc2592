"""What a collision looked like: how deep, which corner of the opponent the ego touched, how far the road's bend had
swept that corner out of the opponent's lane; and how much the paper's enlarged ellipse leaves uncovered.

Used to explain the campaign's collisions (``fcgen report``'s "zero collisions" finding). It reads the run log's
true poses only (never the solver's slacks). The kinds of the first colliding sample:

- ``swept_front``: the ego touches a *front* corner of the opponent that lies more than ``SWEEP_MIN`` beyond the
  opponent's half width off its lane: a long straight chassis whose rear axle follows a lane on a bend sweeps its front
  sideways (a 26 m truck on a 25 m radius bend: ~10 m), over the ego's side of the road.
- ``rear_corner``: the ego clips a *rear* corner of the opponent (it swerves past it while overtaking).
- ``front_corner``: any other front-corner contact.

Who moved into whom (``responsibility``), at the first colliding sample, from the true poses (rule ``responsible``),
the first that applies:

1. ``opponent_from_behind``: the opponent's centre is behind the ego's (along the ego's heading) and the opponent is
   faster along that heading: it ran into the ego's rear.
2. ``ego_into_opponent``: the ego ran into the rear of an opponent ahead that kept its lane: the opponent's centre is
   ahead of the ego's (along the ego's heading), the ego is faster along that heading, the ego's chassis centre lies
   behind the opponent's rear edge (along the opponent's heading: the ego's front touches the opponent's rear face
   or a rear corner from behind, not its side) and the opponent's Frenet n stayed within ``LANE_KEPT`` of its value
   at contact over the ``LANE_WINDOW`` before; whether the ego kept its lane or not (a rear-end in the lane).
3. ``opponent_from_side``: the ego kept its lane (its Frenet n within ``LANE_KEPT`` of its value at contact over the
   ``LANE_WINDOW`` before): the opponent came into the ego's lane (a truck's front swept across it by a bend, the
   truck's rear axle in its lane; an opponent cutting in ahead, its n moving toward the ego's).
4. ``ego_into_opponent``: everything else: the ego changed its lane into the opponent.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np

from ..collision import corners_from_dims, penetration_over_run
from ..road import Road

SWEEP_MIN = 1.0  # m beyond the half width off its lane: the opponent's front corner has been swept by the bend
KINDS = ("swept_front", "rear_corner", "front_corner")
RESPONSIBILITIES = ("ego_into_opponent", "opponent_from_behind", "opponent_from_side")
LANE_KEPT = 0.25  # m: the ego's n stayed this close to its value at contact ...
LANE_WINDOW = 1.0  # s: ... over this long before contact: it kept its lane
#: chassis corner order of ``collision.chassis_corners``: rear-right, front-right, front-left, rear-left
FRONT_CORNERS = (1, 2)


@dataclass(frozen=True)
class CollisionInfo:
    """A run's collisions: deepest penetration (m) and the first colliding sample's situation."""

    depth: float  # largest SAT penetration depth over the run, m
    sample: int  # first colliding sample
    opponent: int  # the opponent touched there (the deepest at that sample)
    corner: int  # the opponent's corner nearest the ego's chassis centre (0..3, chassis_corners order)
    sweep: float  # that corner's lateral distance from the opponent's lane beyond its half width, m
    kind: str  # one of KINDS
    responsibility: str = ""  # one of RESPONSIBILITIES


def corner_frenet_n(road: Road, xy: np.ndarray, s_guess: float) -> float:
    """Lateral Frenet offset ``n`` of a point (forward transform, SPEC section 1)."""
    s = road.project(np.array([xy[0]]), np.array([xy[1]]), np.array([s_guess]))
    _, phi, gx, gy, _, _ = road.eval(s)
    return float(-(xy[0] - gx[0]) * math.sin(phi[0]) + (xy[1] - gy[0]) * math.cos(phi[0]))


def classify(kind_corner: int, sweep: float) -> str:
    """The kind of a contact at ``kind_corner`` whose corner is ``sweep`` m beyond the half width off the lane."""
    if kind_corner not in FRONT_CORNERS:
        return "rear_corner"
    return "swept_front" if sweep > SWEEP_MIN else "front_corner"


def kept_lane(n_before: np.ndarray) -> bool:
    """Whether a vehicle kept its lane: its Frenet n over ``LANE_WINDOW`` up to the contact (finite, last = at
    contact) stayed within ``LANE_KEPT`` of its value at contact."""
    n = np.asarray(n_before, dtype=float)
    return bool(n.size) and bool(np.all(np.isfinite(n))) and float(np.max(np.abs(n - n[-1]))) <= LANE_KEPT


def behind_rear(ego_c: np.ndarray, opp_c: np.ndarray, opp_phi: float, opp_half_length: float) -> bool:
    """Whether the ego's chassis centre ``ego_c`` lies behind the rear edge of the opponent's chassis (centre
    ``opp_c``, heading ``opp_phi``, half length ``opp_half_length``): a contact there is on its rear, not its side."""
    h = np.array([math.cos(opp_phi), math.sin(opp_phi)])
    return float((np.asarray(ego_c) - np.asarray(opp_c)) @ h) < -opp_half_length


def responsible(
    ego_c: np.ndarray,
    ego_phi: float,
    ego_v: np.ndarray,
    opp_c: np.ndarray,
    opp_v: np.ndarray,
    n_before: np.ndarray,
    *,
    opp_n_before: np.ndarray,
    rear: bool,
) -> str:
    """The responsibility class (module docstring) of a contact: chassis centres ``ego_c``/``opp_c``, the ego's
    heading, both velocities (m/s, Cartesian), the ego's and the opponent's Frenet n over ``LANE_WINDOW`` up to the
    contact, ``rear``: the ego's centre behind the opponent's rear edge (``behind_rear``)."""
    h = np.array([math.cos(ego_phi), math.sin(ego_phi)])
    ahead, closing = float((opp_c - ego_c) @ h), float(ego_v @ h) - float(opp_v @ h)
    if ahead < 0.0 and closing < 0.0:
        return "opponent_from_behind"
    if ahead > 0.0 and closing > 0.0 and rear and kept_lane(opp_n_before):
        return "ego_into_opponent"
    if kept_lane(n_before):
        return "opponent_from_side"
    return "ego_into_opponent"


def first_collision(
    road: Road,
    ego_pose: np.ndarray,
    ego_dims: Mapping[str, float],
    opp_pose: np.ndarray,
    opp_frenet: np.ndarray,
    opp_dims: Sequence[Mapping[str, float]],
    ego_n: np.ndarray | None = None,
    dt: float = 0.1,
) -> CollisionInfo | None:
    """The run's collisions (``None`` if there is none): poses ``(K, 3)`` / ``(K, n_opp, 3)`` of the rear axles,
    ``opp_frenet`` ``(K, n_opp, 3)`` their Frenet poses ``[s, n, alpha]`` (lane ``n``), dimension mappings as
    ``collision.DIM_KEYS``; ``ego_n`` the ego's Frenet n per sample and ``dt`` the sample time (responsibility;
    without ``ego_n`` it is not classified)."""
    pen = penetration_over_run(ego_pose, ego_dims, opp_pose, opp_dims)
    hit = np.nonzero(pen.max(axis=1, initial=0.0) > 0.0)[0]
    if not hit.size:
        return None
    j = int(hit[0])
    k = int(np.argmax(pen[j]))
    oc = corners_from_dims(opp_pose[j, k], opp_dims[k])
    centre = corners_from_dims(ego_pose[j], ego_dims).mean(axis=0)
    ci = int(np.argmin(np.linalg.norm(oc - centre, axis=1)))
    d = opp_dims[k]
    half_l, half_ch = 0.5 * (float(d["l_f"]) + float(d["l_r"])), 0.5 * (float(d["l_r_ch"]) + float(d["l_f_ch"]))
    along = half_l + half_ch if ci in FRONT_CORNERS else half_l - half_ch  # the corner ahead of the rear axle
    n = corner_frenet_n(road, oc[ci], float(opp_frenet[j, k, 0]) + along)
    sweep = abs(n - float(opp_frenet[j, k, 1])) - 0.5 * float(opp_dims[k]["w_ch"])
    who = ""
    if ego_n is not None:
        j0 = max(j - 1, 0)  # velocities from the sample before contact (forward difference into it)
        span = max(j - j0, 1) * dt
        ego_v = (ego_pose[j, :2] - ego_pose[j0, :2]) / span
        opp_v = (opp_pose[j, k, :2] - opp_pose[j0, k, :2]) / span
        w = round(LANE_WINDOW / dt)
        opp_c, opp_phi = oc.mean(axis=0), float(opp_pose[j, k, 2])
        who = responsible(
            centre,
            float(ego_pose[j, 2]),
            ego_v,
            opp_c,
            opp_v,
            np.asarray(ego_n[max(0, j - w) : j + 1], dtype=float),
            opp_n_before=np.asarray(opp_frenet[max(0, j - w) : j + 1, k, 1], dtype=float),
            rear=behind_rear(centre, opp_c, opp_phi, half_ch),
        )
    return CollisionInfo(float(pen.max()), j, k, ci, sweep, classify(ci, sweep), who)


def ellipse_shortfall(half_length: float, half_width: float, r: float, samples: int = 20001) -> float:
    """How far the paper's ellipse (semi-axes ``sqrt(2) L + r``, ``sqrt(2) W + r``, SPEC section 4) falls short of
    covering the opponent rectangle grown by the ego's circle of radius ``r``: ``r`` minus the smallest distance from
    the ellipse to the rectangle (0 if it covers). The ego's circle can overlap the rectangle by that much while the
    ellipse constraint holds, and the ego's chassis (inside its circle, corners on it) too."""
    a, b = math.sqrt(2.0) * half_length + r, math.sqrt(2.0) * half_width + r
    t = np.linspace(0.0, 0.5 * math.pi, samples)
    x, y = a * np.cos(t), b * np.sin(t)
    dist = np.hypot(np.maximum(x - half_length, 0.0), np.maximum(y - half_width, 0.0))
    return max(0.0, r - float(dist.min()))
