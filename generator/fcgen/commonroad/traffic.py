"""A scenario's obstacles as fcgen's opponents: their shapes, their recorded trajectories as predictions, and which
of them fill the solver's opponent slots.

Rules (tested in tests/test_commonroad.py):

- **Shape**: a CommonRoad ``Rectangle`` (length, width) whose pose is its centre (shape offset 0). Any other shape
  refuses the scenario (``ScenarioRefused`` naming the obstacle), so does a set-based prediction (occupancy sets:
  the drivability checker sees them grow, fcgen would see the obstacle only at its initial step).
- **Prediction = the recording** (the paper's perfect-prediction assumption): the recorded centre pose at every
  recorded step; **after the recorded end, constant velocity along the last heading** (the last state's velocity,
  else the last two positions' difference); before its first step an obstacle is not there (``None``). A static
  obstacle stands at its pose at every step.
- **Presence**: an obstacle is present at step t when it is static or recorded at t (it appears at its first step
  and disappears after its last: the drivability checker sees it over the same steps).
- **Relevance** (``select_opponents``): of the obstacles present at a step, the ``n_slots`` nearest to the ego's
  centre, ties by obstacle id: in a closed loop by their closest approach over the horizon, the obstacles as
  predicted and the ego along its heading at constant speed, **the nearer of two approaches: the ego at its own
  speed, and at the run's reference speed** ``v_ref`` where that is faster (where the ego drives if nothing is in
  the way). A standing or slow ego so sees the standing vehicle ahead in its lane (it would reach it) before those
  passing beside it, and keeps a vehicle closing from behind (it would reach the ego at its own speed); a slower
  vehicle ahead comes before one beside at the same speed. Without the ego's motion: by the Euclidean distance of
  the centres at that step.
- **Oncoming traffic beyond the band** (``separated_oncoming``; where the road bound is the chassis' corners): a
  vehicle heading against the road whose rectangle stays outside the road's band now and at every stage of its
  prediction gets no slot. The band's rows keep the ego's chassis inside the band, so they already keep it apart;
  its ellipse, grown by the ego's circle, would reach across a lane of a two-way street and leave no room to pass.
- **Empty slots**: a neutral opponent, a 4 m x 2 m box 1 km beyond the road's bounding box (south-west of it),
  heading 0, standing: it never constrains the plan (the conventional fit leaves it out).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..extras import require

NEUTRAL_SHAPE = (4.0, 2.0, 0.0)
NEUTRAL_DISTANCE = 1000.0


class ScenarioRefused(ValueError):
    """A scenario fcgen cannot drive; the message is one line naming the reason, ``kind`` the reason's class (one
    of ``REFUSAL_KINDS``: the campaign counts refusals by it)."""

    def __init__(self, message: str, kind: str = "other") -> None:
        if kind not in REFUSAL_KINDS:
            raise ValueError(f"ScenarioRefused kind {kind!r} is invalid: allowed {', '.join(REFUSAL_KINDS)}")
        super().__init__(message)
        self.kind = kind

    def __reduce__(self):  # pickled with its kind (a worker's refusal reaches the campaign's process)
        return (type(self), (str(self), self.kind))


#: the classes of reasons a scenario is refused for (docs/commonroad.md, "What a scenario becomes")
REFUSAL_KINDS = (
    "hash differs",
    "not in the cache",
    "unreadable file",
    "no planning problem",
    "no goal",
    "no lanelet at the start",
    "goal unreachable",
    "intersection",
    "oncoming traffic",
    "turn tighter than the car",
    "non-rectangular obstacle",
    "set-based prediction",
    "non-consecutive recording",
    "path shorter than the horizon",
    "path not followed",
    "band outside the bounds",
    "reference refused",
    "time step",
    "other",
)


@dataclass(frozen=True, eq=False)
class CrObstacle:
    """One obstacle: its rectangle and its recorded centre poses ``centres[i]`` at step ``first_step + i``."""

    id: int
    static: bool
    length: float
    width: float
    first_step: int
    last_step: int
    centres: np.ndarray  # (steps, 3): x, y, orientation of the rectangle's centre
    last_velocity: float  # m/s along the last heading (the extrapolation's)
    dt: float
    speeds: np.ndarray | None = None  # (steps,) the recorded speed at each step, NaN where not recorded

    def speed_at(self, step: int) -> float:
        """The recorded speed at ``step`` (what a radar reads); 0 where none is recorded."""
        i = step - self.first_step
        ok = self.speeds is not None and 0 <= i < len(self.speeds) and math.isfinite(float(self.speeds[i]))
        return float(self.speeds[i]) if ok else 0.0  # type: ignore[index]

    def present(self, step: int) -> bool:
        """Recorded at ``step`` (a static obstacle: always)."""
        return self.static or self.first_step <= step <= self.last_step

    def pose(self, step: int) -> np.ndarray | None:
        """Centre pose at ``step``: recorded, extrapolated at constant velocity after the end, None before it."""
        if self.static:
            return self.centres[0].copy()
        if step < self.first_step:
            return None
        if step <= self.last_step:
            return self.centres[step - self.first_step].copy()
        x, y, phi = self.centres[-1]
        d = self.last_velocity * (step - self.last_step) * self.dt
        return np.array([x + d * math.cos(phi), y + d * math.sin(phi), phi])


def obstacle_from(ob, dt: float) -> CrObstacle:
    """A commonroad-io static or dynamic obstacle as a ``CrObstacle`` (refused unless a rectangle)."""
    with require("commonroad", "a CommonRoad scenario's traffic"):
        from commonroad.geometry.shape import Rectangle
        from commonroad.scenario.obstacle import StaticObstacle

    shape = ob.obstacle_shape
    if not isinstance(shape, Rectangle):
        raise ScenarioRefused(
            f"obstacle {ob.obstacle_id}: its shape is a {type(shape).__name__}, not a rectangle",
            kind="non-rectangular obstacle",
        )
    states = [ob.initial_state]
    static = isinstance(ob, StaticObstacle)
    if not static and ob.prediction is not None and not hasattr(ob.prediction, "trajectory"):
        raise ScenarioRefused(
            f"obstacle {ob.obstacle_id}: a {type(ob.prediction).__name__} (occupancy sets, not a recorded trajectory)",
            kind="set-based prediction",
        )
    if not static and ob.prediction is not None and hasattr(ob.prediction, "trajectory"):
        states += [s for s in ob.prediction.trajectory.state_list if s.time_step > ob.initial_state.time_step]
    states.sort(key=lambda s: s.time_step)
    steps = [int(s.time_step) for s in states]
    if steps != list(range(steps[0], steps[0] + len(steps))):
        raise ScenarioRefused(
            f"obstacle {ob.obstacle_id}: its recorded time steps are not consecutive", kind="non-consecutive recording"
        )
    centres = np.array(
        [[float(s.position[0]), float(s.position[1]), float(getattr(s, "orientation", 0.0) or 0.0)] for s in states]
    )
    v = getattr(states[-1], "velocity", None)
    if v is None:
        v = (float(np.hypot(*(centres[-1, :2] - centres[-2, :2]))) / dt) if len(states) > 1 else 0.0
    speeds = np.array([math.nan if getattr(s, "velocity", None) is None else float(s.velocity) for s in states])
    return CrObstacle(
        int(ob.obstacle_id),
        static,
        float(shape.length),
        float(shape.width),
        steps[0],
        steps[-1],
        centres,
        float(v),
        dt,
        speeds,
    )


def select_opponents(
    obstacles,
    step: int,
    ego_xy,
    n_slots: int,
    ego_motion=None,
    offsets=None,
    N: int = 0,
    v_ref: float = 0.0,
    band_road=None,
) -> tuple[int | None, ...]:
    """Indices into ``obstacles`` of the ``n_slots`` present obstacles nearest to ``ego_xy`` at ``step`` (ties by
    id); ``None`` for the slots left empty. With the ego's ``ego_motion`` (speed, heading): nearest by their closest
    approach over the horizon's ``N`` stages (stage k ``offsets[k]`` steps on, default k), the ego along its heading
    at its own speed and at ``v_ref`` where that is faster (the nearer of the two), the obstacles as predicted.
    ``band_road``: a road whose band keeps the ego's chassis; its ``separated_oncoming`` vehicles are left out."""
    cand = []
    for i, ob in enumerate(obstacles):
        if ob.present(step) and not (band_road is not None and separated_oncoming(ob, band_road, step, offsets, N)):
            cand.append((_relevance(ob, step, ego_xy, ego_motion, v_ref, offsets, N), ob.id, i))
    cand.sort()
    chosen = [i for _, _, i in cand[:n_slots]]
    return tuple(chosen) + (None,) * (n_slots - len(chosen))


def separated_oncoming(ob, road, step: int, offsets=None, N: int = 0) -> bool:
    """The vehicle heads more than 90 degrees against ``road`` and its rectangle lies beside the road's band (on one
    side, within the road's length) at ``step`` and at each of the horizon's ``N`` stages (stage k ``offsets[k]``
    steps on, default k), as predicted (module docstring)."""
    if ob.static or road.n_min is None or road.n_max is None:
        return False
    p = ob.pose(step)
    if abs(math.remainder(float(np.ravel(road.to_frenet(p[0], p[1], p[2])[2])[0]), 2 * math.pi)) <= math.pi / 2:
        return False  # (most vehicles: one projection)
    on = [0] + [k if offsets is None else int(offsets[k]) for k in range(1, N + 1)]
    c = np.array([ob.pose(step + m) for m in on])
    s, n, a = road.to_frenet(c[:, 0], c[:, 1], c[:, 2])
    a = np.remainder(np.asarray(a) + np.pi, 2 * np.pi) - np.pi
    half = 0.5 * ob.length * np.abs(np.sin(a)) + 0.5 * ob.width * np.abs(np.cos(a))  # across the road
    lo, hi = np.interp(s, road.s, road.n_min), np.interp(s, road.s, road.n_max)
    beside = (n - half >= hi) | (n + half <= lo)
    within = (s > road.s[0]) & (s < road.s[-1])
    return bool(np.all((np.abs(a) > math.pi / 2) & beside & within))


def _relevance(ob, step: int, ego_xy, ego_motion, v_ref: float, offsets, N: int) -> float:
    """The obstacle's distance now, or its closest approach to the ego at its own speed or at ``v_ref`` (the nearer)."""
    if ego_motion is None:
        return _approach(ob, step, ego_xy, None, offsets, N)
    v, heading = float(ego_motion[0]), float(ego_motion[1])
    c, s = math.cos(heading), math.sin(heading)
    return min(_approach(ob, step, ego_xy, (u * c, u * s), offsets, N) for u in {v, max(v, float(v_ref))})


def _approach(ob, step: int, ego_xy, ego_v, offsets, N: int) -> float:
    """The obstacle's distance to the ego now, or (``ego_v`` = (vx, vy) given) its closest approach over the
    horizon, the ego at that constant velocity."""
    p = ob.pose(step)
    d = math.hypot(p[0] - ego_xy[0], p[1] - ego_xy[1])
    if ego_v is None:
        return d
    dt = ob.dt
    for k in range(1, N + 1):
        m = k if offsets is None else int(offsets[k])
        q = ob.pose(step + m)
        ex, ey = ego_xy[0] + ego_v[0] * m * dt, ego_xy[1] + ego_v[1] * m * dt
        d = min(d, math.hypot(q[0] - ex, q[1] - ey))
    return d


def neutral_pose(road) -> np.ndarray:
    """Where an empty slot's opponent stands: ``NEUTRAL_DISTANCE`` beyond the road's bounding box."""
    return np.array([float(np.min(road.gx)) - NEUTRAL_DISTANCE, float(np.min(road.gy)) - NEUTRAL_DISTANCE, 0.0])


def opponent_horizon(sc, step: int, ego_xy, n_slots: int, N: int, offsets=None, ego_motion=None, separated=False):
    """The solver's opponents at closed-loop sample ``step`` (scenario step ``sc.first_step + step``): centre poses
    (N+1, n_slots, 3) over the horizon (stage k: ``offsets[k]`` scenario steps later, default k), shapes
    (n_slots, 3) [length, width, offset 0], the chosen obstacles' ids
    (None for an empty slot); ``ego_motion``: the ego's (speed, heading) for the relevance rule
    (``select_opponents``, with the scenario's ``v_ref``); ``separated``: the chassis' corners bound the band, so the
    ``separated_oncoming`` vehicles get no slot."""
    t0 = sc.first_step + step
    band = sc.road if separated else None
    idx = select_opponents(sc.obstacles, t0, ego_xy, n_slots, ego_motion, offsets, N, sc.v_ref, band)
    poses = np.zeros((N + 1, n_slots, 3))
    shapes = np.zeros((n_slots, 3))
    ids: list[int | None] = []
    far = neutral_pose(sc.road)
    for j, i in enumerate(idx):
        if i is None:
            poses[:, j] = far
            shapes[j] = NEUTRAL_SHAPE
            ids.append(None)
            continue
        ob = sc.obstacles[i]
        for k in range(N + 1):
            poses[k, j] = ob.pose(t0 + (k if offsets is None else int(offsets[k])))
        shapes[j] = (ob.length, ob.width, 0.0)
        ids.append(ob.id)
    return poses, shapes, tuple(ids)
