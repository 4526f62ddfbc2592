"""Predicted traffic: the opponents' poses over the horizon predicted at each sample from what was observed up to it
(``PREDICTIONS``), instead of their true future (``oracle``); docs/plants.md, "Predicted traffic"."""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np

from ..contract import INPUT_RANGES
from ..road import Road
from .plants.spec import PREDICTIONS

#: samples between the two observed poses a speed is taken from (two such spans for an acceleration)
SPAN = 5

MARGIN_RULE = (
    "m_k = min(10 m, c (tau_k e + tau_k^2 t / 2)): tau_k the time from the last observation to stage k, e the speed "
    "error expected of the prediction, max over the opponents of |v1 - v0| (the speed change observed between the last "
    "two spans of SPAN samples: what a prediction at one speed misses) + sqrt(2) sigma_xy / (SPAN dt) (the noise's "
    "error on a speed from two positions SPAN samples apart); t, for the straight-line predictions, the turn they "
    "miss: max over the opponents of v1 |omega|, omega the heading change observed over the last span per second "
    "(a straight line leaves an arc of that lateral acceleration by tau^2 t / 2); 0 for lane-following"
)
"""The obstacle margin per stage of ``PlantSpec.prediction_margin = c`` (docs/plants.md, "Margins from the
prediction's error"); set with ``set_obstacle_margins`` before each sample's solve."""


class PredictedOpponents:
    """``horizon(i)`` as ``OpponentParams.horizon``, predicted from the poses ``truth(j)`` (n_opp, 3) observed at
    samples j <= i - ``delay`` (with the seeded Gaussian noise ``noise`` = stds of x, y, phi)."""

    def __init__(
        self,
        kind: str,
        truth: Callable[[int], np.ndarray],
        offsets,
        dt: float,
        road: Road | None = None,
        delay: int = 0,
        noise: tuple[float, float, float] = (0.0, 0.0, 0.0),
        seed: int = 0,
    ):
        if kind not in PREDICTIONS[1:]:
            raise ValueError(f"prediction = {kind!r} is invalid: allowed one of {', '.join(PREDICTIONS[1:])}")
        if kind == "lane-following" and road is None:
            raise ValueError("prediction = 'lane-following' needs the road whose reference line the lanes follow")
        self.kind, self.truth, self.dt, self.road, self.delay = kind, truth, float(dt), road, int(delay)
        self.offsets = np.asarray(offsets, dtype=np.int64)
        self.noise, self.seed = np.asarray(noise, dtype=float), int(seed)
        self._seen: dict[int, np.ndarray] = {}

    def observed(self, j: int) -> np.ndarray:
        """The poses observed at sample ``j`` (the same noise draw for a sample whenever it is asked for)."""
        if j not in self._seen:
            p = np.array(self.truth(j), dtype=float)
            if np.any(self.noise > 0):
                rng = np.random.default_rng([self.seed, 48, j + 10**6])
                p = p + rng.standard_normal(p.shape) * self.noise
            self._seen[j] = p
        return self._seen[j]

    def horizon(self, i: int) -> np.ndarray:
        """Poses for stages 0..N at sample ``i`` (stage k: sample i + offsets[k]): shape (N+1, n_opp, 3)."""
        j0 = i - self.delay
        tau = ((i - j0) + self.offsets) * self.dt  # (N+1,) time from the last observation
        p0, p1 = self.observed(j0), self.observed(j0 - SPAN)
        if self.kind == "lane-following":
            return self._lane(p0, p1, tau)
        v1 = np.hypot(*(p0[:, :2] - p1[:, :2]).T) / (SPAN * self.dt)  # mean speed over the last span
        if self.kind == "constant-velocity":
            dist = np.outer(tau, v1)
        else:
            p2 = self.observed(j0 - 2 * SPAN)
            v0 = np.hypot(*(p1[:, :2] - p2[:, :2]).T) / (SPAN * self.dt)
            a = (v1 - v0) / (SPAN * self.dt)
            v = v1 + a * SPAN * self.dt / 2  # the speed now (a mean speed is the speed at the span's middle)
            t_stop = np.where(a < 0, -v / np.where(a < 0, a, -1.0), np.inf)  # a braking opponent stops there
            t = np.minimum(tau[:, None], t_stop[None, :])
            dist = v[None, :] * t + 0.5 * a[None, :] * t**2
        phi = p0[:, 2]
        out = np.empty((len(tau), len(phi), 3))
        out[..., 0] = p0[:, 0] + dist * np.cos(phi)
        out[..., 1] = p0[:, 1] + dist * np.sin(phi)
        out[..., 2] = phi
        return out

    def margins(self, i: int, c: float) -> np.ndarray:
        """The obstacle margin per stage at sample ``i`` (``MARGIN_RULE``)."""
        j0 = i - self.delay
        tau = ((i - j0) + self.offsets) * self.dt
        p0, p1, p2 = (self.observed(j0 - q * SPAN) for q in (0, 1, 2))
        v1 = np.hypot(*(p0[:, :2] - p1[:, :2]).T) / (SPAN * self.dt)
        v0 = np.hypot(*(p1[:, :2] - p2[:, :2]).T) / (SPAN * self.dt)
        e = float(np.max(np.abs(v1 - v0), initial=0.0)) + math.sqrt(2.0) * float(max(self.noise[:2])) / (SPAN * self.dt)
        t = 0.0  # the lateral acceleration a straight line misses (lane-following follows the bends)
        if self.kind != "lane-following":
            omega = np.abs(np.angle(np.exp(1j * (p0[:, 2] - p1[:, 2])))) / (SPAN * self.dt)
            t = float(np.max(v1 * omega, initial=0.0))
        return np.minimum(c * (tau * e + 0.5 * t * tau**2), INPUT_RANGES.margin_max)

    def _lane(self, p0: np.ndarray, p1: np.ndarray, tau: np.ndarray) -> np.ndarray:
        """Along the road's reference line at the observed offset and progress rate ds/dt, heading along it."""
        road = self.road
        assert road is not None
        s0, n0, _ = road.to_frenet(p0[:, 0], p0[:, 1], p0[:, 2])
        s1 = road.project(p1[:, 0], p1[:, 1], s0)
        s = np.asarray(s0)[None, :] + np.outer(tau, (np.asarray(s0) - s1) / (SPAN * self.dt))
        n = np.broadcast_to(np.asarray(n0), s.shape)
        x, y, phi = road.to_cartesian(s, n, np.zeros_like(s))
        return np.stack([x, y, phi], axis=-1)


def opponent_horizon(problem, sc, spec, opp_params, controller=None) -> Callable[[int], np.ndarray]:
    """What the solver is given at each sample: ``opp_params.horizon`` (``oracle``) or the prediction of
    ``spec.prediction`` from the observed poses (with the measured state's noise on s, n, alpha as x, y, phi). With
    ``spec.prediction_margin`` it also sets ``controller``'s obstacle margins of that sample (``MARGIN_RULE``, plus
    ``Problem.obstacle_margin``) each time a sample's prediction is asked for (just before its solve)."""
    if spec.prediction == "oracle":
        return opp_params.horizon
    pred = PredictedOpponents(
        spec.prediction,
        opp_params.at_index,
        problem.horizon.offsets,
        sc.dt,
        sc.road,
        problem.delay,
        tuple(spec.noise[:3]),
        sc.seed,
    )
    if not spec.prediction_margin or controller is None:
        return pred.horizon

    def horizon(i: int) -> np.ndarray:  # on top of the problem's own margin (Problem.obstacle_margin), which it sets
        m = np.minimum(pred.margins(i, spec.prediction_margin) + problem.obstacle_margin, INPUT_RANGES.margin_max)
        rc = controller.set_obstacle_margins(m)
        if rc != 0:
            raise RuntimeError(f"set_obstacle_margins refused the prediction's margins (exit code {rc})")
        return pred.horizon(i)

    return horizon
