"""Traffic that reacts (``--traffic reactive``): a recorded vehicle follows its recording until the IDM
(``commonroad.idm``) would brake harder for the vehicle ahead of it in its lane (the ego included) than the recording
does; from then on it follows the IDM along its lane.

Rules (tested in tests/test_commonroad_reactive.py):

- **Lanes and leaders** on the scenario road's Frenet frame: a vehicle's leader is the nearest vehicle present (or
  the ego) whose centre is ahead in ``s`` and within half a lane (``lanes.SAME_LANE``) in ``n``; the gap is bumper to
  bumper along ``s`` (the centres' distance less the half lengths), the closing speed the speeds' difference.
- **The switch**: at each sample, a vehicle still on its recording whose IDM acceleration towards its leader is below
  0 and below its recorded acceleration (the speed change from this step to the next, speeds from the recorded
  positions) reacts from this sample on; the log names it, the sample, its leader (``ego`` or an obstacle id) and
  both accelerations. A vehicle without a leader keeps its recording.
- **After the switch**: its ``s`` and speed follow the IDM (braking at most ``IdmParams.b_max``; ``idm.step``; all
  reacting vehicles updated from the same sample's state), at the lateral offset ``n`` it had when it reacted,
  heading along the road; it is present over its recorded steps, as before. The solver's prediction of a reacting
  vehicle is constant speed along the road from its latest state (its recording no longer says where it goes); a
  vehicle still on its recording is predicted by it.
- **Judged** on what the vehicles drove: the collision checks, the responsibility rule and the criticality measures
  get the scenario with the reacting vehicles' driven trajectories (``driven_scenario``).
"""

from __future__ import annotations

import copy
import dataclasses
import math

import numpy as np

from ..extras import require
from . import idm
from .lanes import SAME_LANE

TRAFFIC_MODES = ("recorded", "reactive")


def check_traffic(mode: str) -> str:
    """``mode`` if it is a traffic mode, else a ValueError naming the option and the allowed values."""
    if mode not in TRAFFIC_MODES:
        raise ValueError(f"traffic {mode!r} is not a traffic mode: allowed {', '.join(TRAFFIC_MODES)}")
    return mode


def leader_of(s: np.ndarray, n: np.ndarray, i: int) -> int | None:
    """Index of the nearest vehicle ahead of vehicle ``i`` in its lane (``s`` larger, ``n`` within ``SAME_LANE``)."""
    ahead = (s > s[i]) & (np.abs(n - n[i]) <= SAME_LANE)
    ahead[i] = False
    if not ahead.any():
        return None
    return int(np.argmin(np.where(ahead, s, np.inf)))


def switches(p: idm.IdmParams, v: float, gap: float, dv: float, a_recorded: float) -> tuple[bool, float]:
    """Whether a vehicle on its recording reacts (the IDM brakes, and harder than the recording), and the IDM's
    acceleration."""
    a = idm.acceleration(p, v, gap, dv)
    return (a < 0.0 and a < a_recorded), a


class ReactiveTraffic:
    """The scenario's obstacles as they drive in reactive traffic (module docstring); ``reactions`` lists
    ``[obstacle id, sample, step, leader, a_idm, a_recorded]`` per vehicle that reacted."""

    def __init__(self, sc, ego_length: float, params: idm.IdmParams | None = None):
        self.sc, self.p, self.ego_length = sc, params or idm.IdmParams(), ego_length
        self.obstacles = [dataclasses.replace(ob, centres=ob.centres.copy()) for ob in sc.obstacles]
        self.state: dict[int, list[float]] = {}  # index -> [s, n, v] of a reacting vehicle
        self.reactions: list[list] = []

    def scenario(self):
        """The scenario with the obstacles as they drive (the loop's ``sc``)."""
        return dataclasses.replace(self.sc, obstacles=tuple(self.obstacles))

    def _speed(self, ob, step: int) -> float:
        p, q = ob.pose(step), ob.pose(step + 1)
        return float(math.hypot(q[0] - p[0], q[1] - p[1]) / ob.dt)

    def _frame(self, t: int, ego: tuple[float, float, float]):
        """The vehicles present at step ``t`` and the ego (last): indices, ``s``, ``n``, speeds, lengths."""
        idx = [i for i, ob in enumerate(self.obstacles) if ob.present(t) and ob.pose(t) is not None]
        pose = np.array([self.obstacles[i].pose(t) for i in idx]).reshape(-1, 3)
        s, n, _ = (np.atleast_1d(np.asarray(a, dtype=float)) for a in self.sc.road.to_frenet(*pose.T))
        for k, i in enumerate(idx):  # a reacting vehicle: its own state (no round trip through x, y)
            if i in self.state:
                s[k], n[k] = self.state[i][0], self.state[i][1]
        v = [self.state[i][2] if i in self.state else self._speed(self.obstacles[i], t) for i in idx]
        length = [self.obstacles[i].length for i in idx]
        return idx, np.append(s, ego[0]), np.append(n, ego[1]), np.append(v, ego[2]), np.append(length, self.ego_length)

    def update(self, j: int, ego_s: float, ego_n: float, ego_v: float) -> None:
        """Sample ``j``: decide the switches from this sample's state (the ego's centre ``ego_s``, ``ego_n``, speed
        ``ego_v``) and move every reacting vehicle one step by the IDM."""
        t = self.sc.first_step + j
        idx, s, n, v, length = self._frame(t, (ego_s, ego_n, ego_v))
        acc: dict[int, float] = {}
        for k, i in enumerate(idx):
            ob = self.obstacles[i]
            if ob.static:
                continue
            lead = leader_of(s, n, k)
            gap = None if lead is None else float(s[lead] - s[k] - (length[lead] + length[k]) / 2)
            dv = 0.0 if lead is None else float(v[k] - v[lead])
            if i in self.state:
                acc[i] = idm.acceleration(self.p, float(v[k]), gap, dv)
            elif gap is not None:
                a_rec = (self._speed(ob, t + 1) - float(v[k])) / ob.dt
                react, a = switches(self.p, float(v[k]), gap, dv, a_rec)
                if react:
                    who = "ego" if lead == len(idx) else int(self.obstacles[idx[lead]].id)
                    self.reactions.append([int(ob.id), j, t, who, _finite(a), a_rec])
                    self.state[i] = [float(s[k]), float(n[k]), float(v[k])]
                    acc[i] = a
        for i, a in acc.items():
            self._advance(i, t, a)

    def _advance(self, i: int, t: int, a: float) -> None:
        """Move reacting vehicle ``i`` from step ``t`` to ``t + 1`` at acceleration ``a``; its later recorded steps
        become constant speed along the road (the solver's prediction)."""
        st, ob = self.state[i], self.obstacles[i]
        d, v1 = idm.step(st[2], max(a, -self.p.b_max), ob.dt)
        st[0], st[2] = st[0] + d, v1
        k0 = t + 1 - ob.first_step
        if k0 < len(ob.centres):
            ss = st[0] + v1 * ob.dt * np.arange(len(ob.centres) - k0)
            x, y, phi = self.sc.road.to_cartesian(ss, np.full_like(ss, st[1]), np.zeros_like(ss))
            ob.centres[k0:] = np.column_stack([x, y, phi])
        self.obstacles[i] = dataclasses.replace(ob, last_velocity=v1)

    def log(self) -> dict:
        """The run log's ``extra.commonroad.traffic``: the mode, the IDM's parameters, the reactions."""
        return {"mode": "reactive", "idm": dataclasses.asdict(self.p), "reactions": self.reactions}


def _finite(a: float) -> float:
    return a if math.isfinite(a) else -1e3


def driven_scenario(sc, obstacles) -> object:
    """A copy of the commonroad-io scenario ``sc.scenario`` whose dynamic obstacles drive ``obstacles``' centre poses
    (``CrObstacle``, the reacting vehicles' driven trajectories) over their recorded steps."""
    with require("commonroad", "reactive traffic's driven scenario"):
        from commonroad.prediction.prediction import TrajectoryPrediction
        from commonroad.scenario.trajectory import Trajectory

    out = copy.deepcopy(sc.scenario)
    by_id = {ob.id: ob for ob in obstacles}
    for dob in out.dynamic_obstacles:
        ob = by_id.get(int(dob.obstacle_id))
        pred = dob.prediction
        if ob is None or pred is None or not hasattr(pred, "trajectory"):
            continue
        states = []
        for st in pred.trajectory.state_list:
            k = int(st.time_step) - ob.first_step
            if not 0 <= k < len(ob.centres):
                continue
            new = copy.copy(st)
            new.position = np.array(ob.centres[k, :2], dtype=float)
            new.orientation = float(ob.centres[k, 2])
            if k + 1 < len(ob.centres) and hasattr(new, "velocity"):
                new.velocity = float(np.hypot(*(ob.centres[k + 1, :2] - ob.centres[k, :2])) / ob.dt)
            states.append(new)
        if states:
            dob.prediction = TrajectoryPrediction(Trajectory(states[0].time_step, states), dob.obstacle_shape)
    return out
