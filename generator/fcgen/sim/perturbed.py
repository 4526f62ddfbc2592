"""The closed loop with a plant fcgen did not write or with perturbations between controller and plant
(``plants.PlantSpec``): noise on the measured state, latency, steering lag, a CommonRoad vehicle model."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..dsl import Problem
from ..road import FrenetSingular, LeftRoad, Road
from .plants import PlantSpec
from .plants.actuation import Actuation
from .plants.mapping import model_lateral_acceleration


@dataclass
class PerturbedRun:
    """What the loop produced: true states, computed and applied controls, the controller's results, the plant's
    and the model formula's lateral acceleration, the input limits' cut flags per sample."""

    xs: np.ndarray
    us: np.ndarray
    applied: np.ndarray
    results: list = field(default_factory=list)
    a_lat: np.ndarray | None = None
    a_lat_model: np.ndarray | None = None
    cut: np.ndarray | None = None
    ended: dict | None = None  # the run ended early (``left_road``)


def left_road(j: int, x: np.ndarray, road: Road, exc: LeftRoad) -> dict:
    """How a run ends whose state ``x`` at sample ``j`` has left the road (``exc``): the samples it keeps (``j``: the
    last state the run logs is ``x``) and why."""
    if isinstance(exc, FrenetSingular):
        return {"sample": j, "reason": str(exc)}
    reason = f"the ego's s = {float(x[0]):.2f} m left the road [{road.s0:.1f}, {road.s_end:.1f}] m"
    return {"sample": j, "reason": reason}


def run_perturbed(problem: Problem, sc, spec: PlantSpec, solve, model_step, add=None) -> PerturbedRun:
    """``sc.samples`` samples: ``solve(j, x_measured)`` -> the controller's ``StepResult``; ``model_step(x, u)``:
    fcgen's plant (used when ``spec.kind == "model"``); ``add(j, r)``: the plan log's hook."""
    K, dt = sc.samples, problem.horizon.dt
    act = Actuation(spec, sc.seed, dt)
    run = PerturbedRun(np.zeros((K + 1, 5)), np.zeros((K, 2)), np.zeros((K, 2)))
    run.xs[0] = sc.x0
    a_lat, a_model, cut = np.zeros(K + 1), np.zeros(K + 1), np.zeros(K, dtype=np.int64)
    cr = None
    if spec.kind != "model":
        from .plants.commonroad_vm import CommonRoadPlant

        cr = CommonRoadPlant(problem, spec.kind, spec.params)
        cr.reset(sc.x0, sc.road)
    wheelbase = problem.ego.l
    for j in range(K):
        x = run.xs[j]
        try:  # the solver's window (its start kept on the road) or the plant's can leave the road (road.LeftRoad)
            r = solve(j, act.measure(x))
            run.us[j] = r.u
            if add is not None:
                add(j, r)
            run.results.append(r)
            u = run.applied[j] = act.actuate(r.u, float(x[4]))
            a_model[j] = model_lateral_acceleration(float(x[3]), float(x[4]), wheelbase)
            if cr is None:
                run.xs[j + 1] = model_step(x, u)
                a_lat[j] = a_model[j]
            else:
                xn, info = cr.step((float(u[0]), float(u[1])))
                run.xs[j + 1] = xn
                a_lat[j], cut[j] = info.a_lat, info.cut
        except LeftRoad as exc:
            run.ended, K = left_road(j, x, sc.road, exc), j
            break
    if run.ended is not None:  # the samples up to the last state known
        run.xs, run.us, run.applied, run.results = run.xs[: K + 1], run.us[:K], run.applied[:K], run.results[:K]
        a_lat, a_model, cut = a_lat[: K + 1], a_model[: K + 1], cut[:K]
    xK = run.xs[K]
    a_model[K] = model_lateral_acceleration(float(xK[3]), float(xK[4]), wheelbase)
    last = run.applied[K - 1] if K else np.zeros(2)
    a_lat[K] = a_model[K] if cr is None else cr.lateral_acceleration((float(last[0]), float(last[1]))).a_lat
    run.a_lat, run.a_lat_model, run.cut = a_lat, a_model, cut
    return run


def perturbed_meta(spec: PlantSpec, run: PerturbedRun) -> dict:
    """The run log's ``meta.extra`` entries of a perturbed run: the plant and perturbations, the cut samples."""
    cut = np.asarray(run.cut)
    a_model = np.asarray(run.a_lat_model)
    return {
        "plant": spec.as_meta(),
        "plant_cut_samples": int(np.count_nonzero(cut)),
        "plant_cut_steer_rate": int(np.count_nonzero(cut & 1)),
        "plant_cut_steer_angle": int(np.count_nonzero(cut & 2)),
        "plant_cut_accel": int(np.count_nonzero(cut & 4)),
        "max_abs_a_lat_model": float(np.max(np.abs(a_model))),
    }


def perturbed_fields(run: PerturbedRun) -> dict:
    """The run log's optional fields of a perturbed run (docs/runlog.md)."""
    return {"a_lat_model": run.a_lat_model, "control_applied": run.applied, "plant_cut": run.cut}
