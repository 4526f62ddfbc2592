"""The paper's randomized scenarios (SPEC section 7): road, ego start, opponents' trajectories, solver parameters."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..dsl import Problem
from ..road import Road, random_road

OPP_SPEED = 15.0      # opponents' Frenet progress rate ds/dt, m/s (constant n, alpha = 0)
EGO_SPEED0 = 15.0
ROAD_BEHIND = 50.0    # the road starts this far behind the ego's start s = 0


@dataclass(frozen=True, eq=False)
class Scenario:
    """One seeded run: the whole road, the ego's initial Frenet state, the opponents' Frenet lanes and start s."""

    name: str
    seed: int
    road: Road
    x0: np.ndarray              # ego [s, n, alpha, v, delta]
    opp_s0: np.ndarray          # (n_opp,)
    opp_n: np.ndarray           # (n_opp,)
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


def make_scenario(scenario: str, seed: int, n_opp: int = 3, samples: int = 200, dt: float = 0.1,
                  road_length: float = 1600.0) -> Scenario:
    """Seeded, reproducible: road from ``seed``, then ego n0 and opponents' n from U[-5, 5]."""
    if scenario not in ("car", "truck"):
        raise ValueError(f"scenario = {scenario!r} is invalid: allowed 'car' or 'truck'")
    if not isinstance(seed, int) or seed < 0:
        raise ValueError(f"seed = {seed!r} is invalid: allowed an integer >= 0")
    road = random_road(seed, length=road_length, s0=-ROAD_BEHIND)
    rng = np.random.default_rng([seed, 1])
    n0 = rng.uniform(-5.0, 5.0)
    opp_n = rng.uniform(-5.0, 5.0, n_opp)
    x0 = np.array([0.0, n0, 0.0, EGO_SPEED0, 0.0])
    return Scenario(scenario, seed, road, x0, 50.0 * (np.arange(n_opp) + 1), opp_n, samples, dt)


class OpponentParams:
    """Per-stage opponent poses for the solver (every formulation: rear axle [x, y, phi]; the conventional solver fits
    its Frenet boxes itself), cached per absolute time index (they only depend on it)."""

    def __init__(self, problem: Problem, scenario: Scenario):
        self.problem = problem
        self.sc = scenario
        self._cache: dict[int, np.ndarray] = {}

    def at_index(self, j: int) -> np.ndarray:
        """Poses (n_opp, 3) at absolute time j * dt."""
        if j not in self._cache:
            self._cache[j] = self.sc.opp_cartesian(j * self.sc.dt)
        return self._cache[j]

    def horizon(self, j: int) -> np.ndarray:
        """Poses for stages 0..N at sample j: shape (N+1, n_opp, 3)."""
        return np.stack([self.at_index(j + k) for k in range(self.problem.horizon.N + 1)])
