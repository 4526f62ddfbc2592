"""The paper's randomized scenarios (SPEC section 7): road, ego start, opponents' trajectories, solver parameters."""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import lru_cache

import numpy as np

from ..dsl import Problem
from ..road import Road, min_self_distance, random_road

OPP_SPEED = 15.0  # opponents' Frenet progress rate ds/dt, m/s (constant n, alpha = 0)
EGO_SPEED0 = 15.0
ROAD_BEHIND = 50.0  # the road starts this far behind the ego's start s = 0

# Realistic roads (SPEC section 3 only bounds the curvature; a random walk of the heading can loop back): a road is
# redrawn when two of its points more than ROAD_MIN_ARC apart along it are less than ROAD_MIN_GAP apart in the plane.
# ROAD_MIN_GAP = the truck scenario's road width (2 x 10 m) + a truck's chassis length (26 m): the two corridors
# stay a truck length apart. ROAD_MIN_ARC = pi / kappa_max (62.8 m), the half turn of the tightest bend: closer
# points belong to one bend, whose chord the curvature bound already limits. Only the first ROAD_CHECKED metres are
# checked: what a 200-sample run can reach at v_max = 40 m/s with its 40-sample horizon (50 + 800 + 160 m).
ROAD_MIN_GAP = 46.0
ROAD_MIN_ARC = math.pi / 0.05
ROAD_CHECKED = 1010.0
ROAD_MAX_DRAWS = 100


@dataclass(frozen=True, eq=False)
class Scenario:
    """One seeded run: the whole road, the ego's initial Frenet state, the opponents' Frenet lanes and start s."""

    name: str
    seed: int
    road: Road
    x0: np.ndarray  # ego [s, n, alpha, v, delta]
    opp_s0: np.ndarray  # (n_opp,)
    opp_n: np.ndarray  # (n_opp,)
    samples: int = 200
    dt: float = 0.1

    def opp_frenet(self, t: float | np.ndarray) -> np.ndarray:
        """Opponents' Frenet poses [s, n, alpha] at time(s) t: shape (..., n_opp, 3)."""
        t = np.asarray(t, dtype=float)[..., None]
        s = self.opp_s0 + OPP_SPEED * t
        n = np.broadcast_to(self.opp_n, s.shape)
        return np.stack([s, n, np.zeros_like(s)], axis=-1)

    def opp_cartesian(self, t: float | np.ndarray) -> np.ndarray:
        """Opponents' rear-axle Cartesian poses [x, y, phi] at time(s) t: shape (..., n_opp, 3)."""
        f = self.opp_frenet(t)
        x, y, phi = self.road.to_cartesian(f[..., 0], f[..., 1], f[..., 2])
        return np.stack([x, y, phi], axis=-1)


def make_scenario(
    scenario: str, seed: int, n_opp: int = 3, samples: int = 200, dt: float = 0.1, road_length: float = 1600.0
) -> Scenario:
    """Seeded, reproducible: a realistic road from ``seed`` (``realistic_road``), then ego n0 and opponents' n
    from U[-5, 5]."""
    if scenario not in ("car", "truck"):
        raise ValueError(f"scenario = {scenario!r} is invalid: allowed 'car' or 'truck'")
    if not isinstance(seed, int) or seed < 0:
        raise ValueError(f"seed = {seed!r} is invalid: allowed an integer >= 0")
    road = realistic_road(seed, length=road_length)
    rng = np.random.default_rng([seed, 1])
    n0 = rng.uniform(-5.0, 5.0)
    opp_n = rng.uniform(-5.0, 5.0, n_opp)
    x0 = np.array([0.0, n0, 0.0, EGO_SPEED0, 0.0])
    return Scenario(scenario, seed, road, x0, 50.0 * (np.arange(n_opp) + 1), opp_n, samples, dt)


def road_is_realistic(road: Road) -> bool:
    """No two points of the checked part more than ROAD_MIN_ARC apart along the road are closer than ROAD_MIN_GAP."""
    return min_self_distance(road, ROAD_MIN_ARC, road.s0 + ROAD_CHECKED) >= ROAD_MIN_GAP


@lru_cache(maxsize=64)
def realistic_road(seed: int, length: float = 1600.0) -> Road:
    """The first realistic road of the seeded sequence: draw 0 from ``seed`` (so roads that passed before are
    unchanged), draw k >= 1 from the derived seed ``[seed, 2, k]``; reproducible. Kept per process (every
    configuration of a seed drives the same road), so its arrays are read-only."""
    for k in range(ROAD_MAX_DRAWS):
        road = random_road(seed if k == 0 else [seed, 2, k], length=length, s0=-ROAD_BEHIND)
        if road_is_realistic(road):
            for a in (road.kappa, road.phi, road.gx, road.gy):
                a.flags.writeable = False
            return road
    raise ValueError(f"seed = {seed}: no realistic road in {ROAD_MAX_DRAWS} draws (ROAD_MIN_GAP = {ROAD_MIN_GAP} m)")


class OpponentParams:
    """Per-stage opponent poses for the solver (every formulation: rear axle [x, y, phi]; the conventional solver fits
    its Frenet boxes itself). They only depend on the absolute time index, so the poses of every index a run reaches
    (0 .. samples + N) are computed once, in one vectorized call (the same values as one call per index)."""

    def __init__(self, problem: Problem, scenario: Scenario):
        self.problem = problem
        self.sc = scenario
        self.n_stages = problem.horizon.N + 1
        self.offsets = np.array(problem.horizon.offsets)  # stage k is sample j + offsets[k]
        self.span = int(self.offsets[-1]) + 1
        table = scenario.opp_cartesian(np.arange(scenario.samples + self.span) * scenario.dt)
        table.flags.writeable = False
        self._table = table

    def at_index(self, j: int) -> np.ndarray:
        """Poses (n_opp, 3) at absolute time j * dt (read-only)."""
        if 0 <= j < len(self._table):
            return self._table[j]
        return self.sc.opp_cartesian(j * self.sc.dt)

    def horizon(self, j: int) -> np.ndarray:
        """Poses for stages 0..N at sample j (stage k: sample j + offsets[k]): shape (N+1, n_opp, 3) (read-only)."""
        if j >= 0 and j + self.span <= len(self._table):
            if self.span == self.n_stages:  # one sample per stage: a view
                return self._table[j : j + self.span]
            out = self._table[j + self.offsets]
            out.flags.writeable = False
            return out
        return np.stack([self.at_index(j + int(o)) for o in self.offsets])

    def samples(self, K: int) -> np.ndarray:
        """Poses at samples 0..K: shape (K+1, n_opp, 3) (the rows the solver was given)."""
        if len(self._table) >= K + 1:
            return self._table[: K + 1]
        return np.stack([self.at_index(j) for j in range(K + 1)])
