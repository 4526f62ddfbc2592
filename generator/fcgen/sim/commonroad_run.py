"""A closed loop on a CommonRoad scenario (``fcgen.commonroad``): its road with the drivable band, its recorded
traffic as the opponents' predictions, its ego start and speed; judged by fcgen's own rectangle check and by the
CommonRoad drivability checker.

Per sample ``j`` (scenario time step ``sc.first_step + j``): the ``NOPP`` most relevant obstacles
(``commonroad.select_opponents``) fill the solver's opponent slots with their predicted centre poses over the horizon
and their shapes (``set_opponent_shapes`` when a slot's occupant changes); the road window and its band go to the
solver as in the paper's loop; the plant is the same kinematic model. The reference is ``set_reference(v_ref, 0)``:
the scenario's speed and the reference path's lane centre.

The solver's lateral bound is on the ego's reference point (its rear axle), so it gets the drivable band shrunk by
half the ego's width plus ``HEADING_MARGIN`` (what a heading of up to ~4 degrees adds at the chassis' front corners):
the chassis stays on the road while the bound holds. The problem's road band ``Bounds.n_min``/``n_max`` stays what it
is: where the scenario's band is wider, the solver gets it cut to that (stated in the log's
``extra.commonroad.band_cut``). A scenario's time step must be the problem's ``dt`` (else the scenario is refused).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .. import obstacles as obs
from ..dsl import Problem
from ..ocp import Ocp, build_ocp
from ..road import Road
from .closedloop import Controller, PlanLog, Plant, ReferenceController, dims, solver_window
from .collision_kind import LANE_WINDOW, responsible
from .runlog import RunLog, make_meta


@dataclass(frozen=True, eq=False)
class CommonRoadRun:
    """One run on a scenario: the run log (its ``extra.commonroad`` holds the verdicts) and the verdicts."""

    log: RunLog
    checker: dict          # the drivability checker's verdict (``commonroad.drivability_verdict``)
    fcgen: dict            # fcgen's rectangle check against every obstacle (``commonroad.fcgen_collisions``)
    responsibility: str    # of the first collision by fcgen's check ("" without one; rule: sim/collision_kind.py)
    ego_centres: np.ndarray   # (K + 1, 3) the ego's chassis centre poses (the solution file's and the checker's)

    @property
    def ego_states(self) -> np.ndarray:
        """(K + 1, 5): the ego's rear axle [x, y, phi], speed and steering angle per sample (the solution file's)."""
        f = np.asarray(self.log.ego_frenet)
        return np.column_stack([np.asarray(self.log.ego_cartesian), f[:, 3], f[:, 4]])

    @property
    def agree(self) -> bool:
        """Whether the two checks give the same collision verdict."""
        return bool(self.checker["collision"]) == bool(self.fcgen["collision"])


HEADING_MARGIN = 0.25   # m: the band's extra shrink for the chassis' corners at a small heading


def scenario_road(problem: Problem, sc) -> tuple[Road, float]:
    """The scenario's road with the band the ego's rear axle may use (shrunk by half its width and
    ``HEADING_MARGIN``), cut to the problem's ``Bounds`` (the solver refuses a wider one); and how much was cut at
    most (m, 0: none)."""
    road, b = sc.road, problem.bounds
    inset = problem.ego.w_ch / 2 + HEADING_MARGIN
    lo0, hi0 = road.n_min + inset, road.n_max - inset
    lo, hi = np.maximum(lo0, b.n_min), np.minimum(hi0, b.n_max)
    cut = float(max(np.max(lo - lo0), np.max(hi0 - hi), 0.0))
    if np.any(lo >= hi):
        i = int(np.flatnonzero(lo >= hi)[0])
        raise ValueError(f"scenario {sc.name}: the drivable band at s = {road.s[i]:.1f} m lies outside the problem's "
                         f"[{b.n_min}, {b.n_max}] m")
    return Road(road.s0, road.ds, road.kappa, road.phi, road.gx, road.gy, lo, hi), cut


def run_commonroad(problem: Problem, sc, controller: Controller | None = None, ocp: Ocp | None = None,
                   plan: str = "none", progress: bool = False, states: np.ndarray | None = None) -> CommonRoadRun:
    """Run ``sc.samples`` samples of a loaded CommonRoad scenario (``fcgen.commonroad.load_scenario``).

    ``states`` (K + 1, 5): a replay (``fcgen regress``): the controller gets these measured states instead of the
    plant's, sample by sample, and the log keeps them."""
    from .. import commonroad as cr
    from ..commonroad.judge import centre_dims, fcgen_verdict, penetrations

    if not math.isclose(sc.dt, problem.horizon.dt, rel_tol=1e-9):
        raise cr.ScenarioRefused(f"scenario {sc.name}: its time step {sc.dt} s is not the problem's dt "
                                 f"{problem.horizon.dt} s")
    if controller is None:
        ocp = ocp or build_ocp(problem)
        controller = ReferenceController(ocp)
    N, n_slots, ego = problem.horizon.N, problem.opponents.count, problem.ego
    road, cut = scenario_road(problem, sc)
    plant = Plant(problem, ocp.road_params.samples if ocp is not None else build_ocp(problem).road_params.samples)
    K = sc.samples if states is None else len(states) - 1
    xs = np.zeros((K + 1, 5))
    xs[0] = sc.x0
    if states is not None:
        xs[:] = states
    us = np.zeros((K, 2))
    planlog = PlanLog(K, N, plan)
    rc = controller.set_reference(sc.v_ref, 0.0)
    if rc:
        raise ValueError(f"scenario {sc.name}: set_reference({sc.v_ref}, 0) refused (exit code {rc})")
    shape_cache: dict[tuple, np.ndarray] = {}
    slots_now: tuple | None = None
    results, slot_ids = [], []
    it = range(K)
    if progress:
        from tqdm import tqdm
        it = tqdm(it, desc=f"{problem.name} {sc.name}", unit="sample", leave=False)
    half_l = ego.l / 2
    for j in it:
        x = xs[j]
        rx, ry, rphi = (float(v) for v in road.to_cartesian(x[0], x[1], x[2]))
        centre = (rx + half_l * math.cos(rphi), ry + half_l * math.sin(rphi))
        poses, shapes, ids = cr.opponent_horizon(sc, j, centre, n_slots, N, problem.horizon.offsets)
        key = tuple(map(tuple, np.asarray(shapes, dtype=float)))
        if key != slots_now:
            vals = []
            for length, width, offset in key:
                v = shape_cache.get((length, width, offset))
                if v is None:
                    v = shape_cache[(length, width, offset)] = obs.opponent_shape(problem.obstacles, ego, length,
                                                                                   width, offset)
                vals.append(v)
            rc = controller.set_opponent_shapes(np.array(vals).reshape(n_slots, -1))
            if rc:
                raise ValueError(f"scenario {sc.name}: set_opponent_shapes refused at sample {j} (exit code {rc})")
            slots_now = key
        slot_ids.append([-1 if i is None else int(i) for i in ids])
        r = controller.step(x, solver_window(problem, road, x), poses)
        us[j] = r.u
        if plan != "none":
            planlog.add(j, controller, r)
        else:
            planlog.exit_code[j] = r.exit_code
        results.append(r)
        if states is None:
            xs[j + 1] = plant.step(x, us[j], road)
    t = np.arange(K + 1) * sc.dt
    ex, ey, ephi = road.to_cartesian(xs[:, 0], xs[:, 1], xs[:, 2])
    ego_cart = np.stack([ex, ey, ephi], axis=1)
    centres = ego_cart.copy()
    centres[:, 0] += half_l * np.cos(ephi)
    centres[:, 1] += half_l * np.sin(ephi)
    # every obstacle of the scenario at every sample where it is recorded (NaN elsewhere)
    O = len(sc.obstacles)
    opp_cart = np.full((K + 1, O, 3), np.nan)
    for i, ob in enumerate(sc.obstacles):
        for j in range(K + 1):
            step = sc.first_step + j
            if ob.static or ob.first_step <= step <= ob.last_step:
                p = ob.pose(step)
                if p is not None:
                    opp_cart[j, i] = p
    opp_dims = [centre_dims(ob.length, ob.width) for ob in sc.obstacles]
    ego_dims = dims(ego)
    pen = penetrations(sc, centres, ego.l_ch, ego.w_ch)
    coll = (pen > 0.0).any(axis=1)
    who = _responsibility(pen, ego_cart, centres, xs, opp_cart, sc.dt)
    checker = cr.drivability_verdict(sc, centres, ego.l_ch, ego.w_ch)
    own = fcgen_verdict(sc, pen)
    opp_fr = np.full_like(opp_cart, np.nan)
    ok = np.isfinite(opp_cart[..., 0])
    if ok.any():
        s, n, a = road.to_frenet(opp_cart[..., 0][ok], opp_cart[..., 1][ok], opp_cart[..., 2][ok])
        opp_fr[ok] = np.stack([s, n, a], axis=-1)
    extra = {"exit_codes_nonzero": int(np.count_nonzero(planlog.exit_code)),
             "plan_reactions": int(sum(r.plan_reaction for r in results)),
             "a_lat_guards": int(sum(r.a_lat_guard > 0 for r in results)),
             "commonroad": {"scenario": sc.name, "file": sc.file, "sha256": sc.sha256,
                            "planning_problem": sc.planning_problem_id, "v_ref": float(sc.v_ref), "band_cut": cut,
                            "obstacle_ids": [int(ob.id) for ob in sc.obstacles], "slots": slot_ids,
                            "checker": _plain(checker), "fcgen": _plain(own), "responsibility": who,
                            "agree": bool(checker["collision"]) == bool(own["collision"])}}
    meta = make_meta(problem=problem.name, formulation=problem.formulation.kind,
                     obstacle_model=problem.obstacles.kind, scenario=sc.name, seed=0, N=N, dt=problem.horizon.dt,
                     controller=controller.kind, n_bound=problem.bounds.n_max, extra=extra)
    road_dict = {"s": road.s, "kappa": road.kappa, "gamma_x": road.gx, "gamma_y": road.gy,
                 "phi_gamma": road.phi, "ds": road.ds}
    a_lat = xs[:, 3] ** 2 * np.tan(xs[:, 4]) / ego.l
    stats = {key: np.array([getattr(r, key) for r in results]) for key in
             ("time_prepare", "time_feedback", "qp_iter", "qp_status", "max_slack")}
    log = RunLog(meta=meta, road=road_dict, opponents=opp_dims, t=t, ego_frenet=xs, ego_cartesian=ego_cart,
                 opp_cartesian=opp_cart, opp_frenet=opp_fr, collision=coll, a_lat=a_lat, control=us,
                 time_prepare=stats["time_prepare"], time_feedback=stats["time_feedback"],
                 time_total=stats["time_prepare"] + stats["time_feedback"], qp_iter=stats["qp_iter"],
                 qp_status=stats["qp_status"], max_slack=stats["max_slack"], ego=ego_dims, **planlog.fields())
    return CommonRoadRun(log, checker, own, who, centres)


def _responsibility(pen: np.ndarray, ego_cart: np.ndarray, centres: np.ndarray, xs: np.ndarray,
                    opp_cart: np.ndarray, dt: float) -> str:
    """The responsibility class of the first contact (``collision_kind.responsible``; "" without one)."""
    hit = np.flatnonzero(pen.max(axis=1, initial=0.0) > 0.0)
    if not hit.size:
        return ""
    j = int(hit[0])
    k = int(np.argmax(pen[j]))
    j0 = max(j - 1, 0)
    span = max(j - j0, 1) * dt
    ego_v = (centres[j, :2] - centres[j0, :2]) / span
    prev = opp_cart[j0, k, :2] if np.all(np.isfinite(opp_cart[j0, k, :2])) else opp_cart[j, k, :2]
    opp_v = (opp_cart[j, k, :2] - prev) / span
    w = int(round(LANE_WINDOW / dt))
    return responsible(centres[j, :2], float(ego_cart[j, 2]), ego_v, opp_cart[j, k, :2], opp_v,
                       xs[max(0, j - w):j + 1, 1])


def _plain(d: dict) -> dict:
    """A verdict as plain JSON data (numpy scalars and None kept as numbers / null)."""
    out = {}
    for k, v in d.items():
        if isinstance(v, (np.integer, np.bool_)):
            v = v.item()
        elif isinstance(v, np.floating):
            v = float(v)
        elif isinstance(v, (list, tuple, np.ndarray)):
            v = [x.item() if hasattr(x, "item") else x for x in v]
        out[k] = v
    return out
