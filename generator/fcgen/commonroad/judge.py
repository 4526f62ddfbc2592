"""A run on a scenario, judged twice: by the CommonRoad drivability checker (``commonroad_dc``: the ego's rectangle
against every obstacle of the scenario over time, and against the road boundary) and by fcgen's own rectangle check
(separating axes, the campaign's judge) against the same obstacles at the same steps; and written out as a
CommonRoad solution file (``solution``).

``ego_centres`` (K + 1, 3): the ego chassis' centre pose [x, y, phi] at steps ``sc.first_step + j``.
"""

from __future__ import annotations

import importlib

import numpy as np

from ..collision import corners_from_dims, sat_overlap
from ..extras import require


def centre_dims(length: float, width: float) -> dict:
    """Run-log / ``fcgen.collision`` dimensions of a rectangle whose pose is its centre (CommonRoad's obstacles)."""
    return {"l_f": 0.0, "l_r": 0.0, "l_r_ch": length / 2, "l_f_ch": length / 2, "w_ch": width}


def _rect(pycrcc, length: float, width: float, pose) -> object:
    return pycrcc.RectOBB(length / 2, width / 2, float(pose[2]), float(pose[0]), float(pose[1]))


def drivability_verdict(sc, ego_centres: np.ndarray, length: float, width: float) -> dict:
    """The checker's verdict: ``collision`` / ``collision_step`` (first closed-loop sample touching an obstacle,
    None without), ``obstacle_id``, ``road_departure`` / ``departure_step`` (the ego's rectangle touching the road
    boundary of the lanelet network, obb_rectangles); after a start off the road (``departure_step`` 0) the first
    sample clear of the boundary (``back_on_road_step``) and the first touching it again after that
    (``departure_again_step``; None without)."""
    with require("commonroad", "the drivability checker"):
        from commonroad_dc.boundary.boundary import create_road_boundary_obstacle
        from commonroad_dc.collision.collision_detection.pycrcc_collision_dispatch import create_collision_checker

        pycrcc = importlib.import_module("commonroad_dc.pycrcc")  # by name: its stub file does not parse (mypy)
    cc = create_collision_checker(sc.scenario)
    _, boundary = create_road_boundary_obstacle(sc.scenario, method="obb_rectangles")
    hit = dep = back = again = None
    for j, pose in enumerate(np.asarray(ego_centres, dtype=float)):
        r = _rect(pycrcc, length, width, pose)
        if hit is None and cc.time_slice(sc.first_step + j).collide(r):
            hit = j
        if dep is None or dep == 0:
            off = boundary.collide(r)
            dep = j if dep is None and off else dep
            if dep == 0 and back is None and not off:
                back = j
            elif back is not None and again is None and off:
                again = j
        if hit is not None and dep is not None and (dep > 0 or again is not None):
            break
    return {
        "collision": hit is not None,
        "collision_step": hit,
        "road_departure": dep is not None,
        "departure_step": dep,
        "back_on_road_step": back,
        "departure_again_step": again,
    }


def penetrations(sc, ego_centres: np.ndarray, length: float, width: float) -> np.ndarray:
    """(K + 1, obstacles): the separating-axis penetration depth (m, 0 apart) of the ego's rectangle and every
    obstacle present at each step (the campaign's judge)."""
    c = np.asarray(ego_centres, dtype=float)
    pen = np.zeros((len(c), len(sc.obstacles)))
    dims = centre_dims(length, width)
    for j, pose in enumerate(c):
        ego = corners_from_dims(pose, dims)
        for i, ob in enumerate(sc.obstacles):
            if ob.present(sc.first_step + j):
                opp = corners_from_dims(ob.pose(sc.first_step + j), centre_dims(ob.length, ob.width))
                pen[j, i] = max(0.0, float(sat_overlap(ego, opp)))
    return pen


def fcgen_verdict(sc, pen: np.ndarray) -> dict:
    """fcgen's verdict from ``penetrations``: ``collision``, ``collision_step``, ``obstacle_id`` (of the first
    contact), ``depth`` (the deepest penetration, m)."""
    hit = np.flatnonzero(pen.max(axis=1, initial=0.0) > 0.0)
    first = int(hit[0]) if hit.size else None
    who = sc.obstacles[int(np.flatnonzero(pen[first] > 0.0)[0])].id if first is not None else None
    return {
        "collision": first is not None,
        "collision_step": first,
        "obstacle_id": who,
        "depth": float(pen.max(initial=0.0)),
    }


def fcgen_collisions(sc, ego_centres: np.ndarray, length: float, width: float) -> dict:
    """fcgen's verdict with its own rectangle check against every obstacle present at each step (``fcgen_verdict``)."""
    return fcgen_verdict(sc, penetrations(sc, ego_centres, length, width))
