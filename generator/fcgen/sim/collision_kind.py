"""What a collision looked like: how deep, which corner of the opponent the ego touched, how far the road's bend had
swept that corner out of the opponent's lane; and how much the paper's enlarged ellipse leaves uncovered.

Used to explain the campaign's collisions (``fcgen report``'s "zero collisions" finding). It reads the run log's
true poses only (never the solver's slacks). The kinds of the first colliding sample:

- ``swept_front``: the ego touches a *front* corner of the opponent that lies more than ``SWEEP_MIN`` beyond the
  opponent's half width off its lane: a long straight chassis whose rear axle follows a lane on a bend sweeps its front
  sideways (a 26 m truck on a 25 m radius bend: ~10 m), over the ego's side of the road.
- ``rear_corner``: the ego clips a *rear* corner of the opponent (it swerves past it while overtaking).
- ``front_corner``: any other front-corner contact.
"""
from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np

from ..road import Road
from .collision import corners_from_dims, penetration_over_run

SWEEP_MIN = 1.0   # m beyond the half width off its lane: the opponent's front corner has been swept by the bend
KINDS = ("swept_front", "rear_corner", "front_corner")
#: chassis corner order of ``collision.chassis_corners``: rear-right, front-right, front-left, rear-left
FRONT_CORNERS = (1, 2)


@dataclass(frozen=True)
class CollisionInfo:
    """A run's collisions: deepest penetration (m) and the first colliding sample's situation."""

    depth: float        # largest SAT penetration depth over the run, m
    sample: int         # first colliding sample
    opponent: int       # the opponent touched there (the deepest at that sample)
    corner: int         # the opponent's corner nearest the ego's chassis centre (0..3, chassis_corners order)
    sweep: float        # that corner's lateral distance from the opponent's lane beyond its half width, m
    kind: str           # one of KINDS


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


def first_collision(road: Road, ego_pose: np.ndarray, ego_dims: Mapping[str, float], opp_pose: np.ndarray,
                    opp_frenet: np.ndarray, opp_dims: Sequence[Mapping[str, float]]) -> CollisionInfo | None:
    """The run's collisions (``None`` if there is none): poses ``(K, 3)`` / ``(K, n_opp, 3)`` of the rear axles,
    ``opp_frenet`` ``(K, n_opp, 3)`` their Frenet poses ``[s, n, alpha]`` (lane ``n``), dimension mappings as
    ``collision.DIM_KEYS``."""
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
    along = half_l + half_ch if ci in FRONT_CORNERS else half_l - half_ch   # the corner ahead of the rear axle
    n = corner_frenet_n(road, oc[ci], float(opp_frenet[j, k, 0]) + along)
    sweep = abs(n - float(opp_frenet[j, k, 1])) - 0.5 * float(opp_dims[k]["w_ch"])
    return CollisionInfo(float(pen.max()), j, k, ci, sweep, classify(ci, sweep))


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
