"""Between controller and plant: the measurement's noise, the latency of the control and a first-order steering
actuator. Pure and seeded: the same run seed gives the same perturbations."""

from __future__ import annotations

import math
from collections import deque

import numpy as np

from .spec import PlantSpec

#: mixed into the run's seed for the noise's generator (the scenario draws from the seed alone)
NOISE_STREAM = 0x4E4F495345


class Actuation:
    """Noise on the measured state, D samples of latency and the steering actuator of one run.

    The latency's queue starts with D zero controls (no drive force, no steering rate): the same controls the
    generated solver's delay compensation assumes before its first hand-out."""

    def __init__(self, spec: PlantSpec, seed: int, dt: float):
        self.spec, self.dt = spec, dt
        self._rng = np.random.default_rng([int(seed), NOISE_STREAM]) if spec.noisy else None
        self._std = np.asarray(spec.noise, dtype=float)
        self._queue: deque[np.ndarray] = deque(np.zeros(2) for _ in range(spec.latency))
        self._delta_cmd: float | None = None

    def measure(self, x: np.ndarray) -> np.ndarray:
        """The state the controller gets: ``x`` plus the sample's Gaussian noise (``x`` itself without noise)."""
        if self._rng is None:
            return x
        return x + self._std * self._rng.standard_normal(5)

    def actuate(self, u: np.ndarray, delta: float) -> np.ndarray:
        """The control the plant gets this sample, given the one just computed and the plant's steering angle:
        the one computed ``latency`` samples earlier, its steering rate through the actuator's lag."""
        if self.spec.latency:
            self._queue.append(np.array(u, dtype=float))
            u = self._queue.popleft()
        u = np.array(u, dtype=float)
        if self.spec.steer_lag > 0:
            u[1] = self._lagged_rate(float(u[1]), delta)
        return u

    def _lagged_rate(self, r: float, delta: float) -> float:
        """The commanded angle integrates r; the actual angle follows it with time constant tau. Returns the constant
        rate that ends the sample at the first-order response's exact angle (linear in between)."""
        tau, h = self.spec.steer_lag, self.dt
        if self._delta_cmd is None:
            self._delta_cmd = delta
        e0 = self._delta_cmd - delta  # commanded minus actual
        e1 = r * tau + (e0 - r * tau) * math.exp(-h / tau)  # e' = r - e / tau over the sample
        self._delta_cmd += r * h
        return (self._delta_cmd - e1 - delta) / h
