"""Predicted traffic on a CommonRoad scenario (``--prediction`` with ``--commonroad``; docs/commonroad.md,
"Predicted traffic"): at each sample every obstacle's future is predicted from its poses observed up to that sample,
and the solver (and the choice of the obstacles in its slots) sees the prediction; the collision checks and the
responsibility rule judge the recorded (or, reactive, the driven) motion.

- ``constant-velocity``: along the last observed heading at the speed between the poses ``SPAN`` samples apart
  (fewer while the obstacle has been seen for less; seen once: its recorded speed at that step, what a radar reads).
- ``constant-acceleration``: the same with the acceleration between the last two spans' speeds (zero until two are
  seen), a braking obstacle stopping where its speed reaches zero.
- ``lane-following``: along the centre line of the lanelet it occupies (of those containing its position, the one
  whose direction is nearest its heading) and its successors (at a fork the one that turns least), at the observed
  speed, keeping its offset from the centre line, heading along it; past the last successor straight on. Off every
  lanelet: constant velocity.

Hand-written, not commonroad-prediction's predictors: those predict a whole scenario (a deep copy per call) from each
obstacle's *recorded* initial state (speed, acceleration, yaw rate), not from observed poses, and keep the heading's
angle to the lane; the straight-line rules are those of the paper's road (``sim.prediction``).
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from .plants.spec import PREDICTIONS
from .prediction import SPAN

SUCCESSOR_REACH = 400.0  # m: a lane path follows successors until it reaches this far past the obstacle


@dataclass(frozen=True, eq=False)
class LanePath:
    """A lane's centre line as a polyline ``xy`` (M, 2) with its arc lengths ``s`` (M,)."""

    xy: np.ndarray
    s: np.ndarray

    @classmethod
    def of(cls, xy) -> LanePath:
        xy = np.asarray(xy, dtype=float)
        keep = np.r_[True, np.hypot(*np.diff(xy, axis=0).T) > 1e-9]  # repeated vertices (a joint) once
        xy = xy[keep]
        return cls(xy, np.r_[0.0, np.cumsum(np.hypot(*np.diff(xy, axis=0).T))])

    def project(self, x: float, y: float) -> tuple[float, float]:
        """The arc length of the nearest point and the signed offset (left positive) of (x, y)."""
        a, d = self.xy[:-1], np.diff(self.xy, axis=0)
        seg = np.diff(self.s)
        t = np.clip(((x - a[:, 0]) * d[:, 0] + (y - a[:, 1]) * d[:, 1]) / seg**2, 0.0, 1.0)
        px, py = a[:, 0] + t * d[:, 0], a[:, 1] + t * d[:, 1]
        i = int(np.argmin(np.hypot(x - px, y - py)))
        cross = d[i, 0] * (y - a[i, 1]) - d[i, 1] * (x - a[i, 0])
        return float(self.s[i] + t[i] * seg[i]), float(math.copysign(math.hypot(x - px[i], y - py[i]), cross))

    def at(self, s: np.ndarray, n: float) -> np.ndarray:
        """Poses (len(s), 3) at arc lengths ``s``, offset ``n``, heading along the line (straight on past its ends)."""
        s = np.asarray(s, dtype=float)
        i = np.clip(np.searchsorted(self.s, s, side="right") - 1, 0, len(self.s) - 2)
        d = self.xy[i + 1] - self.xy[i]
        u = d / np.hypot(d[:, 0], d[:, 1])[:, None]
        p = self.xy[i] + u * (s - self.s[i])[:, None]
        return np.column_stack([p[:, 0] - n * u[:, 1], p[:, 1] + n * u[:, 0], np.arctan2(u[:, 1], u[:, 0])])


def _heading(xy: np.ndarray, k: int) -> float:
    d = xy[min(k + 1, len(xy) - 1)] - xy[min(k, len(xy) - 2)]
    return math.atan2(d[1], d[0])


def _turn(a: float, b: float) -> float:
    return abs(math.remainder(a - b, 2 * math.pi))


def lane_path(network, x: float, y: float, phi: float) -> LanePath | None:
    """The centre line of the lanelet at (x, y) nearest heading ``phi`` and its successors (the least turning at each
    fork, until ``SUCCESSOR_REACH`` past the position); None off every lanelet."""
    ids = network.find_lanelet_by_position([np.array([x, y])])[0]
    if not ids:
        return None

    def misalign(lid: int) -> float:
        c = np.asarray(network.find_lanelet_by_id(lid).center_vertices, dtype=float)
        k = int(np.argmin(np.hypot(c[:, 0] - x, c[:, 1] - y)))
        return _turn(_heading(c, k), phi)

    lan = network.find_lanelet_by_id(min(sorted(ids), key=misalign))
    parts, seen = [np.asarray(lan.center_vertices, dtype=float)], {lan.lanelet_id}
    reach = float(np.hypot(*(parts[0][-1] - (x, y))))
    while reach < SUCCESSOR_REACH and lan.successor:
        end = _heading(parts[-1], len(parts[-1]) - 2)
        nxt = [network.find_lanelet_by_id(i) for i in sorted(lan.successor) if i not in seen]
        if not nxt:
            break
        lan = min(nxt, key=lambda q: _turn(_heading(np.asarray(q.center_vertices, dtype=float), 0), end))
        parts.append(np.asarray(lan.center_vertices, dtype=float))
        seen.add(lan.lanelet_id)
        reach += float(LanePath.of(parts[-1]).s[-1])
    return LanePath.of(np.vstack(parts))


class ScenarioPrediction:
    """The obstacles as the solver sees them at a sample (``at``): observed up to it, predicted after it."""

    def __init__(self, kind: str, network, dt: float, noise=(0.0, 0.0, 0.0), seed: int = 0):
        if kind not in PREDICTIONS[1:]:
            raise ValueError(f"prediction = {kind!r} is invalid: allowed one of {', '.join(PREDICTIONS[1:])}")
        if kind == "lane-following" and network is None:
            raise ValueError("prediction = 'lane-following' needs the scenario's lanelet network")
        self.kind, self.network, self.dt = kind, network, float(dt)
        self.noise, self.seed = np.asarray(noise, dtype=float), int(seed)

    def observed(self, ob, step: int) -> np.ndarray:
        """The obstacle's centre pose observed at ``step`` (with the seeded noise, the same draw every time)."""
        p = np.asarray(ob.pose(step), dtype=float)
        if np.any(self.noise > 0):
            p = p + np.random.default_rng([self.seed, 48, int(ob.id), step + 10**6]).standard_normal(3) * self.noise
        return p

    def at(self, obstacles, step: int) -> tuple:
        """``obstacles`` as seen at scenario ``step``: the static ones as they are, the others ``PredictedObstacle``."""
        return tuple(ob if ob.static else PredictedObstacle(ob, step, self) for ob in obstacles)

    def speeds(self, ob, now: int) -> tuple[np.ndarray, float, float]:
        """The pose observed now, the speed now and the acceleration (zero but for constant-acceleration)."""
        seen = now - ob.first_step
        p0 = self.observed(ob, now)
        k1 = min(SPAN, seen)
        if k1 == 0:
            return p0, ob.speed_at(now), 0.0
        p1 = self.observed(ob, now - k1)
        v1 = float(np.hypot(*(p0[:2] - p1[:2]))) / (k1 * self.dt)
        k2 = min(SPAN, seen - k1)
        if self.kind != "constant-acceleration" or k2 == 0:
            return p0, v1, 0.0
        v0 = float(np.hypot(*(p1[:2] - self.observed(ob, now - k1 - k2)[:2]))) / (k2 * self.dt)
        a = (v1 - v0) / ((k1 + k2) / 2 * self.dt)  # between the spans' middles
        return p0, v1 + a * k1 * self.dt / 2, a

    def predict(self, ob, now: int, tau: np.ndarray) -> np.ndarray:
        """Poses (len(tau), 3) ``tau`` seconds after ``now``."""
        p0, v, a = self.speeds(ob, now)
        if self.kind == "lane-following" and self.network is not None:
            path = lane_path(self.network, float(p0[0]), float(p0[1]), float(p0[2]))
            if path is not None:
                s0, n0 = path.project(float(p0[0]), float(p0[1]))
                return path.at(s0 + v * tau, n0)
        t = np.minimum(tau, -v / a) if a < 0 else tau  # a braking obstacle stops
        dist = v * t + 0.5 * a * t**2
        return np.column_stack([p0[0] + dist * math.cos(p0[2]), p0[1] + dist * math.sin(p0[2]), np.full_like(t, p0[2])])


def seen_traffic(spec, sc) -> Callable:
    """``view(sc, j)``: the scenario as the solver sees it at loop sample ``j`` under a ``PlantSpec``'s prediction
    (the measurement's noise on x, y, phi): ``sc`` itself for ``oracle``, else its obstacles predicted."""
    if spec.prediction == "oracle":
        return lambda s, j: s
    net = getattr(sc.scenario, "lanelet_network", None)
    pred = ScenarioPrediction(spec.prediction, net, sc.dt, spec.noise[:3])
    return lambda s, j: dataclasses.replace(s, obstacles=pred.at(s.obstacles, s.first_step + j))


class PredictedObstacle:
    """One obstacle as seen at step ``now``: its observed poses up to ``now``, its prediction after (``CrObstacle``'s
    interface: ``id``, ``static``, ``length``, ``width``, ``dt``, ``present``, ``pose``)."""

    def __init__(self, ob, now: int, pred: ScenarioPrediction):
        self.ob, self.now, self.pred = ob, now, pred
        self.id, self.static, self.length, self.width, self.dt = ob.id, ob.static, ob.length, ob.width, ob.dt
        self._ahead: dict[int, np.ndarray] = {}

    def present(self, step: int) -> bool:
        return self.ob.present(step)

    def pose(self, step: int) -> np.ndarray | None:
        if step <= self.now:
            return None if step < self.ob.first_step else self.pred.observed(self.ob, step)
        if step not in self._ahead:
            tau = np.arange(1, step - self.now + 1 + 40) * self.dt  # this step and the next 40 at once
            for k, p in enumerate(self.pred.predict(self.ob, self.now, tau)):
                self._ahead.setdefault(self.now + 1 + k, p)
        return self._ahead[step].copy()
