"""The field's criticality measures of a run, computed with ``commonroad-crime`` (CriMe, TUM) on the logged scenario:
the scenario's lanelets with its vehicles as they drove (recorded, or in reactive traffic as they reacted) and the ego
added as a dynamic obstacle with its driven trajectory.

Per run (tested in tests/test_commonroad_criticality.py on a constructed two-vehicle scenario):

- **Time-to-collision** (CriMe's ``TTC``: the headway along the ego's lanelets' curvilinear frame, bumper to bumper,
  over the closing speed, with constant accelerations where they differ by more than 0.1 m/s^2) to the vehicle
  ahead: its minimum over the samples and the vehicles in the ego's lanelets (CriMe's "same lanelet": the occupied
  lanelets with their predecessors and successors); to the vehicle behind: the same with the follower as CriMe's
  ego and the ego as the other vehicle. Infinite (stored as None) where nobody closes in.
- **Time headway** (CriMe's ``THW``: the time the follower's front needs to reach where the leader's rear is now,
  on the follower's driven trajectory; resolution one time step) to the vehicle ahead and behind, minimum likewise.
- Which vehicles are asked at a sample: those in the ego's lane by fcgen's lane rule (centres within half a lane,
  ``LATERAL``, across the road on fcgen's Frenet frame) within ``REACH`` m, for the measures ahead those whose centre
  is ahead of the ego's, behind those behind it; CriMe's own "same lanelet" test (occupied lanelets with their
  predecessors and successors) must agree. Without the first, CriMe counts a vehicle beside the ego whose rectangle
  touches the ego's lanelet, with a headway of its longitudinal offset (a TTC of 0.01 s beside a car in the next
  lane, on US-101).

Not an extra: ``commonroad-crime`` needs ``commonroad-clcs``, which pins ``osqp~=0.6.5`` against ``osqp==1.1.3``;
scripts/setup.sh installs both without their declared dependencies. Where it is missing, ``error`` says so.

**The frame** (``logged_scenario``, ``turn_for_crime``): CriMe's TTC takes the speeds along the lane as the speeds
times the cosine of the lanelet's orientation in the scenario's frame (``cos(orientation)``, not of the angle between
vehicle and lane), and its headway (``HW``) moves a position by half the vehicle's length on x and on y alike
(``position + length / 2``): both are right only for a lane heading along x. And CriMe keeps the lanelets'
orientations in [0, 2 pi) and interpolates them linearly along a lanelet (``get_orientation_point``, whose own comment
names the problem): where a lanelet's orientation crosses 0 it reads about pi between the two vertices, a vehicle
there drives backwards, and a vehicle ahead at a constant gap seems to close in at twice its speed (US101-6_3: 0.35 s
where gap and speeds give 3.6 s). CriMe gets the logged scenario turned so that the lanelets the vehicles drive on
(the ego's, the others' at their states) head along x but all above 0: their smallest orientation as CriMe computes it
(its smoothing, ``crime_orientations``) at ``MARGIN`` rad. The cost is the lanes' spread of orientations ``theta``
(0.00-0.06 rad on US-101): a headway longer by at most (l_1 + l_2) / 2 (cos theta + sin theta - 1) and speeds along
the lane smaller by the factor cos theta. The lanelets' spatial index is rebuilt (commonroad-io's rotation keeps the
old one). CriMe falls back to a lanelet's vertices as they are where its smoothing of the centre or of a border
fails, and whether it fails can change with the turn itself (US101-28_1: a border's smoothing failed only once
turned, the raw centre reached 0.017 rad below 0, and a vehicle 5.4 m ahead and faster read 0.19 s): the turn puts
the raw centres' orientations above 0 as well (``crime_orientations``), and is applied again (at most ``TURNS``
times) while one still reads below 0. Tested on a constructed road turned by 45 degrees, and on a bend whose
orientation crosses 0 with a vehicle ahead at a constant gap (no closing).

**The lanelets CriMe gets** (``off_route``): CriMe measures in the frame of the first lanelet it finds under the
ego (its orientation at both vehicles' positions, its curvilinear frame). At a junction that can be a lanelet
turning off where the ego drives straight on; and a turning lanelet set the turn above (DEU_Muc-17: its smallest
orientation -1.57 rad turned the straight road 1.6 rad off x; a vehicle 19.6 m ahead and 5.1 m/s faster read 0.85 s,
its speed along the turning lanelet under the ego about -10 m/s). CriMe's copy leaves out the lanelets that turn
off the ego's road: those with a centre segment on the road (within its drivable band widened by ``ROUTE_SLACK``)
heading more than ``OFF_ROUTE`` away from the road's heading (turning and oncoming lanes), but for those under an ego
pose that lies on no other lanelet (``kept_back``: CriMe needs a lanelet under each pose). A vehicle on them is still
asked where it lies on a kept lanelet, and not where it does not (CriMe's "same lanelet" test). Tested on a junction's
turning and oncoming lanelets (left out) beside its straight one (kept).

The ego's states for CriMe: position (the chassis centre), orientation, speed; CriMe differentiates the speeds for
the accelerations. A run CriMe cannot measure (an ego start outside every lanelet) gets ``error`` and no values; a
value it cannot compute at one step (a vehicle outside the curvilinear frame of the follower's lanelets) is left out
and counted (``skipped``).
"""

from __future__ import annotations

import contextlib
import copy
import importlib.util
import logging
import math
from collections.abc import Collection

import numpy as np

from ..extras import require
from .lanes import SAME_LANE

MARGIN = 0.002  # rad: the smallest lanelet orientation CriMe gets (above its wrap at 0)
TURNS = 3  # the turn for CriMe applied at most this often (module docstring, ``logged_scenario``)
OFF_ROUTE = 0.25  # rad: a lanelet heading further from the road where it lies on it is left out of CriMe's copy
ROUTE_SLACK = 2.0  # m: "on the road": within its drivable band widened by this on each side
SAME_DIRECTION = math.pi / 2  # rad: a lanelet turned further from the ego's heading is not the ego's direction
REACH = 120.0  # m: vehicles farther from the ego's centre are not asked
LATERAL = SAME_LANE  # m across the road: a centre farther to the side is in another lane (commonroad.lanes)
MEASURES = ("ttc_ahead", "ttc_behind", "thw_ahead", "thw_behind")
NOT_INSTALLED = "commonroad-crime is not installed (scripts/setup.sh installs it: docs/commonroad.md)"


def logged_scenario(sc, centres: np.ndarray, speeds: np.ndarray, length: float, width: float, keep=None):
    """A copy of ``sc.scenario`` (the driven vehicles; only the obstacle ids in ``keep`` if given) with the ego as a
    dynamic obstacle (chassis centre poses ``centres`` (K + 1, 3) and ``speeds`` at steps ``sc.first_step + j``); and
    the ego's obstacle id."""
    with require("commonroad", "the criticality measures' logged scenario"):
        from commonroad.geometry.shape import Rectangle
        from commonroad.prediction.prediction import TrajectoryPrediction
        from commonroad.scenario.lanelet import LaneletNetwork
        from commonroad.scenario.obstacle import DynamicObstacle, ObstacleType
        from commonroad.scenario.state import CustomState, InitialState
        from commonroad.scenario.trajectory import Trajectory

    out = copy.deepcopy(sc.scenario)
    ego_id = out.generate_object_id()
    if keep is not None:
        out.remove_obstacle([ob for ob in out.obstacles if ob.obstacle_id not in keep])
    off = off_route(out.lanelet_network, sc.road)
    back = kept_back(off, out.lanelet_network.find_lanelet_by_position(list(centres[:, :2])))
    for i in sorted(set(off) - back):  # CriMe needs a lanelet under each of the ego's poses (US101-32_1)
        out.lanelet_network.remove_lanelet(i, rtree=False)  # (the index is rebuilt below)
    shape = Rectangle(length, width)

    def state(cls, j: int):
        c = centres[j]
        return cls(
            position=np.array(c[:2], dtype=float),
            orientation=float(c[2]),
            velocity=float(speeds[j]),
            time_step=sc.first_step + j,
        )

    init = state(InitialState, 0)
    init.acceleration, init.yaw_rate, init.slip_angle = 0.0, 0.0, 0.0
    traj = [state(CustomState, j) for j in range(1, len(centres))]
    pred = TrajectoryPrediction(Trajectory(sc.first_step + 1, traj), shape) if traj else None
    out.add_objects(DynamicObstacle(ego_id, ObstacleType.CAR, shape, init, pred))
    out.translate_rotate(np.zeros(2), -float(centres[0, 2]))  # first the ego's initial heading along x
    out.replace_lanelet_network(LaneletNetwork.create_from_lanelet_network(out.lanelet_network))  # index rebuilt
    turn = turn_for_crime(out)  # then the driven lanelets above CriMe's wrap at 0 (module docstring)
    for _ in range(TURNS):  # turned again while a smoothing the turn changed still reads below 0
        if not turn:
            break
        out.translate_rotate(np.zeros(2), turn)
        out.replace_lanelet_network(LaneletNetwork.create_from_lanelet_network(out.lanelet_network))
        turn = turn_for_crime(out)
        turn = turn if turn > MARGIN else 0.0
    return out, ego_id


def off_route(net, road) -> list[int]:
    """The ids of the lanelets of ``net`` that turn off the ego's ``road``: a segment of the centre line on the road
    (its drivable band widened by ``ROUTE_SLACK``) heading more than ``OFF_ROUTE`` away from the road's heading."""
    lo_n, hi_n = (
        (np.full(len(road.s), -np.inf), np.full(len(road.s), np.inf))
        if road.n_min is None
        else (road.n_min, road.n_max)
    )
    out = []
    for la in net.lanelets:
        c = np.asarray(la.center_vertices, dtype=float)
        d = np.diff(c, axis=0)
        mid, phi = (c[:-1] + c[1:]) / 2, np.arctan2(d[:, 1], d[:, 0])
        s, n, a = (np.asarray(v, dtype=float) for v in road.to_frenet(mid[:, 0], mid[:, 1], phi))
        on = (s >= road.s[0]) & (s <= road.s[-1])
        on &= (n >= np.interp(s, road.s, lo_n) - ROUTE_SLACK) & (n <= np.interp(s, road.s, hi_n) + ROUTE_SLACK)
        if np.any(on & (np.abs(np.angle(np.exp(1j * a))) > OFF_ROUTE)):
            out.append(int(la.lanelet_id))
    return out


def kept_back(off: Collection[int], under) -> set[int]:
    """Of the lanelets ``off`` (``off_route``'s), those under an ego pose (``under``: the lanelet ids under each) that
    lies on no other lanelet: CriMe needs one under every pose (US101-32_1's on-ramp), but a pose that also lies on a
    lanelet along the road keeps the turning one out (DEU_Muc-17: CriMe would measure in the turn)."""
    off = set(off)
    return {i for ids in under if ids and set(ids) <= off for i in ids}


def crime_orientations(lanelet) -> np.ndarray:
    """Every orientation CriMe may take along a lanelet's centre line, in (-pi, pi]: its smoothed centre line's and
    its centre vertices' (``compute_lanelet_width_orientation`` takes these where the smoothing of the centre or of a
    border fails, and a rotation of a few mrad can make it fail: US101-28_1)."""
    with require("commonroad", "the criticality measures (commonroad-crime)"):
        from commonroad_clcs.util import compute_orientation_from_polyline  # type: ignore[import-untyped]
        from commonroad_crime.utility.solver import smoothing_reference_path

    lines = [lanelet.center_vertices]
    with contextlib.suppress(TypeError, ValueError):  # CriMe's own fallback: the vertices as they are
        lines.append(smoothing_reference_path(lanelet.center_vertices, 5, 15))
    o = np.concatenate([np.asarray(compute_orientation_from_polyline(c), dtype=float) for c in lines])
    return np.angle(np.exp(1j * o))


def driven_lanelets(scenario) -> set[int]:
    """The ids of the lanelets under a vehicle of ``scenario`` at one of its states."""
    pts = []
    for ob in scenario.dynamic_obstacles:
        states = [ob.initial_state, *([] if ob.prediction is None else ob.prediction.trajectory.state_list)]
        pts += [np.asarray(st.position, dtype=float) for st in states]
    found = scenario.lanelet_network.find_lanelet_by_position(pts) if pts else []
    return {int(i) for ids in found for i in ids}


def turn_for_crime(scenario) -> float:
    """The rotation (rad) after which the lanelets the vehicles drive on that head within ``SAME_DIRECTION`` of x
    have their smallest orientation (``crime_orientations``) at ``MARGIN``; 0 without such a lanelet."""
    net = scenario.lanelet_network
    per = [crime_orientations(net.find_lanelet_by_id(i)) for i in sorted(driven_lanelets(scenario))]
    o = np.concatenate(per) if per else np.zeros(0)
    o = o[np.abs(o) < SAME_DIRECTION]
    return float(MARGIN - np.min(o)) if len(o) else 0.0


def candidates(sc, centres: np.ndarray, j: int) -> dict[int, bool]:
    """The obstacle ids present at sample ``j`` near the ego (``REACH``, ``LATERAL`` on the road's Frenet frame), each
    with whether its centre is ahead of the ego's."""
    t = sc.first_step + j
    obs = [ob for ob in sc.obstacles if not ob.static and ob.present(t) and ob.pose(t) is not None]
    if not obs:
        return {}
    p = np.array([ob.pose(t) for ob in obs])
    s, n, _ = (np.atleast_1d(np.asarray(a, dtype=float)) for a in sc.road.to_frenet(*p.T))
    c = centres[j]
    es, en, _ = (float(np.atleast_1d(a)[0]) for a in sc.road.to_frenet(*(np.array([v]) for v in c)))
    near = (np.abs(s - es) <= REACH) & (np.abs(n - en) <= LATERAL)
    return {int(ob.id): bool(si > es) for ob, k, si in zip(obs, near, s) if k}


def _measures(config_cls, scenario, ego_id: int):
    """CriMe's TTC and THW with ``ego_id`` as CriMe's ego."""
    with require("commonroad", "the criticality measures (commonroad-crime)"):
        from commonroad_crime.measure import THW, TTC

    cfg = config_cls()
    cfg.update(ego_id=ego_id, sce=scenario)
    cfg.debug.save_plots = False
    return TTC(cfg), THW(cfg)


def _follower(config_cls, scenario, oid: int) -> tuple:
    """CriMe's TTC and THW with obstacle ``oid`` as CriMe's ego (the ego as the vehicle ahead); () where CriMe cannot
    place it on a lanelet at its first step (it is then not asked as a follower)."""
    try:
        return _measures(config_cls, scenario, oid)
    except (IndexError, KeyError, TypeError, ValueError):
        return ()


def _value(measure, other: int, step: int, skipped: dict[str, int]) -> float:
    """CriMe's value at ``step``; a value CriMe cannot compute there (a vehicle outside its curvilinear frame or
    off every lanelet) is left out and counted in ``skipped`` by the exception's name."""
    try:
        return float(measure.compute(other, step, verbose=False))
    except Exception as exc:  # noqa: BLE001 - what CriMe raises at a step it cannot measure, counted in the log
        skipped[type(exc).__name__] = skipped.get(type(exc).__name__, 0) + 1
        return math.inf


def unmeasured(error: str) -> dict:
    """``criticality``'s result for a run not measured (``error`` says why)."""
    out: dict = {m: {"min": None, "obstacle": None, "sample": None} for m in MEASURES}
    out["series"], out["error"] = {m: [] for m in MEASURES}, error
    return out


def criticality(sc, centres: np.ndarray, speeds: np.ndarray, length: float, width: float) -> dict:
    """The run's measures: per name of ``MEASURES`` ``{"min": s or None (infinite), "obstacle": id, "sample": j}``,
    the per-sample minima ``series`` (None: infinite), ``skipped`` (the values CriMe could not compute, by exception)
    and ``error`` ("" when measured)."""
    out = unmeasured("")
    series: dict[str, list] = out["series"]
    if importlib.util.find_spec("commonroad_crime") is None:
        return unmeasured(NOT_INSTALLED)
    with require("commonroad", "the criticality measures (commonroad-crime)"):
        from commonroad_crime.data_structure.configuration import CriMeConfiguration

    logging.getLogger("commonroad_crime").setLevel(logging.ERROR)
    near = [candidates(sc, centres, j) for j in range(len(centres))]
    others = sorted({i for ids in near for i in ids})
    scenario, ego_id = logged_scenario(sc, centres, speeds, length, width, keep=set(others))
    vals = {m: np.full(len(centres), np.inf) for m in MEASURES}
    skipped: dict[str, int] = {}
    who = {m: np.full(len(centres), -1) for m in MEASURES}
    try:
        scenario.assign_obstacles_to_lanelets(obstacle_ids={ego_id, *others})
        ego = _measures(CriMeConfiguration, scenario, ego_id)
        for oid in others:  # one other vehicle at a time: CriMe prepares a vehicle's states once per change
            ahead = [j for j, ids in enumerate(near) if ids.get(oid) is True]
            behind = [j for j, ids in enumerate(near) if ids.get(oid) is False]
            fol = _follower(CriMeConfiguration, scenario, oid) if behind else ()
            pairs = [("ttc_ahead", ego[0], oid, ahead), ("thw_ahead", ego[1], oid, ahead)]
            pairs += [("ttc_behind", fol[0], ego_id, behind), ("thw_behind", fol[1], ego_id, behind)] if fol else []
            for name, measure, other, steps in pairs:
                for j in steps:
                    v = _value(measure, other, sc.first_step + j, skipped)
                    if math.isfinite(v) and v < vals[name][j]:
                        vals[name][j], who[name][j] = v, oid
    except Exception as exc:  # noqa: BLE001 - what CriMe raises on a run it cannot measure, stated in the log
        out["error"] = f"{type(exc).__name__}: {str(exc).splitlines()[0] if str(exc) else ''}"
        return out
    out["skipped"] = skipped
    for m in MEASURES:
        series[m][:] = [float(v) if math.isfinite(v) else None for v in vals[m]]
        if np.isfinite(vals[m]).any():
            j = int(np.argmin(vals[m]))
            out[m] = {"min": float(vals[m][j]), "obstacle": int(who[m][j]), "sample": j}
    return out
