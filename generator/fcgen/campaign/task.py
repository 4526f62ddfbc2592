"""The one task function of a campaign: one closed-loop run -> one flat result row (the same in every executor).

Per process it keeps the loaded solvers (one static workspace per shared library, re-initialised before each run,
guarded by a lock so that a multi-threaded worker serialises runs of one solver instead of corrupting it), each
configuration's problem, solver hash and plant function, and the Python OCPs (the Python controller only: a C run
needs none). Collisions are the true-rectangle check of ``fcgen.collision`` (the run log's ``collision`` field), never
the slacks.
"""

from __future__ import annotations

import ctypes
import json
import math
import os
import socket
import threading
import time
from functools import cache

import numpy as np

from ..sim.runlog import summary
from .grid import Config, Task

_LOCK = threading.Lock()
_SOLVERS: dict[str, tuple[object, threading.Lock]] = {}
_OCPS: dict[str, object] = {}

#: the statistics of summary()'s timing dicts kept as columns (time_total_ms_mean, ...)
STAT_KEYS = ("mean", "median", "p99", "max")


def _solver(lib: str):
    from ..csolver import CSolver

    with _LOCK:
        if lib not in _SOLVERS:
            _SOLVERS[lib] = (CSolver(lib), threading.Lock())
        return _SOLVERS[lib]


def _set_clock(solver, clock: str) -> None:
    """Time the solver's phases with its thread's CPU time (``cpu``: the library's own ``host_cpu_clock``, no call
    back into Python) or its monotonic host clock (``wall``)."""
    fn = solver._f("host_cpu_clock" if clock == "cpu" else "host_clock")
    solver._f("set_clock")(ctypes.cast(fn, ctypes.c_void_p))


def _ocp(problem):
    from ..ocp import build_ocp

    with _LOCK:
        if problem.name not in _OCPS:
            _OCPS[problem.name] = build_ocp(problem)
        return _OCPS[problem.name]


@cache
def _prepared(config: Config, cache_dir: str, cflags: str | None = None) -> tuple:
    """Per process and configuration: its problem, its solver hash and (C controller) its compiled library, generated
    and built into the cache on first use."""
    from ..ocp import road_window_samples
    from ..plant import plant_function
    from .solvers import ensure_solver, solver_hash

    pb = config.problem()
    lib = str(ensure_solver(pb, cache_dir, cflags=cflags)) if config.controller == "c" else None
    plant_function(pb, road_window_samples(pb))  # built once per process, outside the runs' timed CPU (~20 ms)
    return pb, solver_hash(pb, cflags=cflags), lib


def build_solver(config: Config, cache_dir: str, cflags: str | None = None) -> str:
    """Generate and compile ``config``'s C solver into the cache (a no-op when it is there); returns its library."""
    return _prepared(config, cache_dir, cflags)[2]


def _alat_outcome(a_lat: np.ndarray, bound: float) -> dict:
    """The soft lateral-acceleration bound: samples above it, and by how far (m/s^2)."""
    excess = np.abs(a_lat) - bound
    over = excess > 0
    return {
        "a_lat_bound": float(bound),
        "a_lat_over_samples": int(np.count_nonzero(over)),
        "a_lat_excess_max": float(np.max(excess[over])) if over.any() else 0.0,
        "a_lat_excess_mean": float(np.mean(excess[over])) if over.any() else 0.0,
    }


def _plant_columns(log, bound: float) -> dict:
    """A perturbed run's extra columns: the model formula's a_lat outcome on the plant's states, the plant's and the
    formula's samples above bound + 0.5 m/s^2, the controls the plant's limits cut."""
    ex = log.meta["extra"]
    plant, model = np.abs(np.asarray(log.a_lat)), np.abs(np.asarray(log.a_lat_model))
    return {
        "a_lat_over05_samples": int(np.count_nonzero(plant > bound + 0.5)),
        "a_lat_model_over05_samples": int(np.count_nonzero(model > bound + 0.5)),
        "a_lat_model_over_samples": int(np.count_nonzero(model > bound)),
        "max_abs_a_lat_model": float(np.max(model)),
        "plant_cut_samples": int(ex.get("plant_cut_samples", 0)),
        "plant_cut_steer_rate": int(ex.get("plant_cut_steer_rate", 0)),
        "plant_cut_accel": int(ex.get("plant_cut_accel", 0)),
    }


def run_task(task: Task) -> dict:
    """Run one closed loop of ``task`` (C solver from the cache, or the Python reference); returns its row."""
    from ..sim.closedloop import ReferenceController, run_closed_loop
    from ..sim.scenario import make_scenario

    cfg = task.config
    pb, hash_, lib = _prepared(cfg, task.cache_dir, task.cflags if cfg.controller == "c" else None)
    sc = make_scenario(cfg.scenario, task.seed, n_opp=pb.opponents.count, samples=task.samples, dt=pb.horizon.dt)
    if cfg.controller == "c":
        solver, lock = _solver(lib)
        with lock:
            t_start, t0, c0 = time.time(), time.perf_counter(), time.process_time()
            rc = solver.init()
            if rc:
                raise RuntimeError(f"{pb.name}_init() returned {rc}")
            _set_clock(solver, task.clock)
            log = run_closed_loop(pb, sc, controller=solver, plant=cfg.plant)
            wall, cpu = time.perf_counter() - t0, time.process_time() - c0
        sizes = {"qp_n": solver.n, "qp_m": solver.m, "qp_nnz_a": solver.nnz_A, "n_opp_par": solver.n_opp_par}
    else:
        ocp = _ocp(pb)
        t_start, t0, c0 = time.time(), time.perf_counter(), time.process_time()
        ctrl = ReferenceController(ocp)
        log = run_closed_loop(pb, sc, controller=ctrl, ocp=ocp, plant=cfg.plant)
        wall, cpu = time.perf_counter() - t0, time.process_time() - c0
        lay = ctrl.solver.lay
        sizes = {"qp_n": lay.n, "qp_m": lay.m, "qp_nnz_a": lay.nnz_A, "n_opp_par": ocp.n_opp_par}
    return make_row(task, pb, log, wall, cpu, t_start, sizes, hash_, collision_columns(sc.road, log))


def collision_columns(road, log) -> dict:
    """How the run's collision looked (``sim.collision_kind``): its depth, the kind of its first contact and how far
    the bend had swept the touched corner out of the opponent's lane; 0 / "" without a collision."""
    from ..sim.collision_kind import first_collision

    none = {"collision_depth_m": 0.0, "collision_kind": "", "collision_sweep_m": 0.0, "collision_responsibility": ""}
    if not np.any(log.collision):  # the log's collision column is the same overlap test of the same poses
        return none
    info = first_collision(
        road,
        np.asarray(log.ego_cartesian),
        log.ego,
        np.asarray(log.opp_cartesian),
        np.asarray(log.opp_frenet),
        log.opponents,
        np.asarray(log.ego_frenet)[:, 1],
        float(log.meta["dt"]),
    )
    if info is None:
        return none
    return {
        "collision_depth_m": info.depth,
        "collision_kind": info.kind,
        "collision_sweep_m": info.sweep,
        "collision_responsibility": info.responsibility,
    }


def make_row(
    task: Task,
    problem,
    log,
    wall: float,
    cpu: float,
    t_start: float,
    sizes: dict,
    hash_: str,
    collision: dict | None = None,
) -> dict:
    """The flat row of one run: configuration, seed, every ``summary`` figure, wall and CPU time (of the whole closed
    loop, plant and scenario included), collision, a_lat outcome."""
    s = summary(log)
    row = {
        "config": task.config.key,
        **task.config.as_dict(),
        "model": task.config.model,
        "problem": problem.name,
        "seed": task.seed,
        "samples": task.samples,
        "solver_hash": hash_,
        "clock": task.timed_by,
        "cflags": (task.cflags or "default") if task.config.controller == "c" else "",
    }
    for k, v in s.items():
        if isinstance(v, dict) and k.endswith("_ms"):
            row.update({f"{k}_{q}": float(v[q]) for q in STAT_KEYS})
        elif k in ("qp_status_counts", "unsolved_exit_codes"):  # name -> count, as JSON text
            row[k] = json.dumps(v, sort_keys=True)
        else:
            row[k] = v
    t_ms = 1e3 * np.asarray(log.time_total, dtype=float)
    row["time_total_ms_std"] = float(np.std(t_ms)) if t_ms.size else math.nan
    row["collision"] = bool(s["n_collision_samples"] > 0)
    row["exit_codes_nonzero"] = int(log.meta["extra"].get("exit_codes_nonzero", 0))
    row["plan_reactions"] = int(log.meta["extra"].get("plan_reactions", 0))  # samples the plan check braked
    row["a_lat_guards"] = int(log.meta["extra"].get("a_lat_guards", 0))  # samples the a_lat guard acted
    ended = log.meta["extra"].get("ended_early")
    if ended:  # the ego left the road: the run's samples before it (n_controls)
        row["ended_early_sample"] = int(ended["sample"])
    row.update(_alat_outcome(np.asarray(log.a_lat), problem.bounds.a_lat_max))
    if log.a_lat_model is not None:  # a perturbed run: the plant's a_lat above, the model formula's here
        row.update(_plant_columns(log, problem.bounds.a_lat_max))
    row.update(collision or {})
    row.update(sizes)
    row["wall_s"] = float(wall)
    row["cpu_s"] = float(cpu)
    row["t_start"] = float(t_start)
    row["t_end"] = float(t_start + wall)
    row["worker"] = f"{socket.gethostname()}:{os.getpid()}"
    row["load_1min"] = float(os.getloadavg()[0])  # the machine's load when the run ended (how shared it was)
    row["time_rti_ms"] = t_ms.astype(np.float32).tolist()
    return row
