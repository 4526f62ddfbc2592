"""``fcgen wcet``: probe runs of a solver folder under QEMU, the bound from them, validation runs of the normal build.

Probe runs: the solver library built with ``-D<NAME>_PROBE`` (``build/<target>/wcet_probe``) and the harness with
``-DFS_PROBE -DFS_PROBE_RESET=RESET_EVERY`` (a reset before every RESET_EVERY-th sample: cold starts, the longest
QPs), one closed loop per seed; the side files give each phase's instructions (``fcgen.wcet.probe``). Validation
runs: the normal build (no probe) on seeds 0..K-1, each sample's prepare, feedback and RTI (the solver's own clock,
``time_prepare`` / ``time_feedback`` x 1e9) against the bound.
"""

from __future__ import annotations

import math
import time
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import numpy as np

from ..dsl import Conventional
from ..sim.export import export_scenario
from ..sim.harness import build_harness, run_harness
from ..sim.scenario import make_scenario
from ..solver_folder import FolderLike, SolverFolder, as_folder
from ..targets import get_target
from ..verify import infer_scenario
from .bound import Caps, compute_bound, exceedances, phase_stats
from .probe import SampleProbe, read_probe, tick_instructions

FORMAT = "fcgen-wcet/1"
PROBE_VARIANT = "wcet_probe"
RESET_EVERY = 10
"""The probe harness resets the solver before every 10th sample: 20 cold starts in 200 samples."""


class WcetError(RuntimeError):
    """The folder or the target cannot give a bound (an old folder, an unsupported setting)."""


def solver_caps(folder: SolverFolder) -> Caps:
    """The caps of a folder: its header's ``<NAME>_RTI_BUDGET`` (= the problem's cold cap), OSQP's termination
    checks, the conventional fit's scans."""
    gen_dir, name, pb, macros = folder.path, folder.name, folder.problem, folder.sizes
    if "RTI_BUDGET" not in macros:
        raise WcetError(
            f"{gen_dir}: its header has no {name.upper()}_RTI_BUDGET (generated before the RTI budget): "
            f"regenerate it with fcgen generate {gen_dir / 'problem.py'} -o {gen_dir}"
        )
    warm, cold = pb.qp.caps
    budget = int(macros["RTI_BUDGET"])
    if budget != cold:
        raise WcetError(f"{gen_dir}: {name.upper()}_RTI_BUDGET = {budget} but problem.py gives {cold}: regenerate")
    ct, iterations = None, budget
    if pb.qp.backend == "osqp":
        if pb.qp.adaptive_rho:
            raise WcetError("qp.adaptive_rho: OSQP's refactorizations are not in the bound's model (turn it off)")
        ct = pb.qp.check_termination
        iterations = math.ceil(budget / ct) * ct
    fit = isinstance(pb.formulation, Conventional) and pb.opponents.count > 0
    return Caps(
        rti_budget=budget,
        warm=warm,
        cold=cold,
        qp_iterations=iterations,
        check_termination=ct,
        fit_scans=(macros["N"] + 1) * macros["NOPP"] if fit else 0,
        fit_scan_cap=macros["ROAD_MAX"] if fit else 0,
    )


def _run_all(jobs: int, fn, seeds: list[int]) -> list:
    if jobs <= 1 or len(seeds) <= 1:
        return [fn(s) for s in seeds]
    with ThreadPoolExecutor(max_workers=jobs) as ex:  # each run is one QEMU process
        return list(ex.map(fn, seeds))


def probe_runs(
    folder: SolverFolder,
    target: str,
    seeds: int,
    samples: int,
    cflags: str | None,
    timeout: float | None,
    jobs: int = 1,
) -> tuple[list[SampleProbe], list[int], int]:
    """The probe build's closed loops on seeds 0..seeds-1: every sample's phases, its QP iterations, the tick."""
    name, pb = folder.name, folder.problem
    exe = build_harness(
        folder,
        cflags=cflags,
        target=target,
        variant=PROBE_VARIANT,
        extra_cflags=f"-D{name.upper()}_PROBE",
        harness_defines=("-DFS_PROBE", f"-DFS_PROBE_RESET={RESET_EVERY}"),
    )
    scenario = infer_scenario(pb)
    tgt = get_target(target)

    def one(seed: int):
        sc = make_scenario(scenario, seed, n_opp=pb.opponents.count, samples=samples, dt=pb.horizon.dt)
        data = export_scenario(
            pb, sc, exe.parent / f"scenario_{scenario}_seed{seed}_{samples}.txt", samples, solver_name=name
        )
        out = exe.parent / f"probe_{scenario}_seed{seed}_{samples}.json"
        log = run_harness(exe, data, out, timeout=timeout, target=target)
        side = Path(f"{out}.probe")
        return (
            read_probe(side, tgt.instructions_per_second),
            [int(i) for i in log.qp_iter],
            tick_instructions(side, tgt.instructions_per_second),
        )

    res = _run_all(jobs, one, list(range(seeds)))
    return [s for r in res for s in r[0]], [i for r in res for i in r[1]], res[0][2]


def validation_runs(
    folder: SolverFolder,
    target: str,
    seeds: int,
    samples: int,
    cflags: str | None,
    timeout: float | None,
    jobs: int = 1,
) -> dict[str, np.ndarray]:
    """The normal build's closed loops on seeds 0..seeds-1: every sample's prepare, feedback and RTI instructions."""
    name, pb = folder.name, folder.problem
    exe = build_harness(folder, cflags=cflags, target=target)
    scenario = infer_scenario(pb)
    scale = get_target(target).instructions_per_second

    def one(seed: int):
        sc = make_scenario(scenario, seed, n_opp=pb.opponents.count, samples=samples, dt=pb.horizon.dt)
        data = export_scenario(
            pb, sc, exe.parent / f"scenario_{scenario}_seed{seed}_{samples}.txt", samples, solver_name=name
        )
        log = run_harness(
            exe,
            data,
            exe.parent / f"wcet_validate_{scenario}_seed{seed}_{samples}.json",
            timeout=timeout,
            target=target,
        )
        return np.round(np.asarray(log.time_prepare) * scale), np.round(np.asarray(log.time_feedback) * scale)

    res = _run_all(jobs, one, list(range(seeds)))
    tp = np.concatenate([r[0] for r in res]).astype(np.int64)
    tf = np.concatenate([r[1] for r in res]).astype(np.int64)
    return {"prepare": tp, "feedback": tf, "rti": tp + tf}


def validate(observed: dict[str, np.ndarray], bound: dict[str, int], seeds: int, samples: int) -> dict:
    """The ``validated`` entry: observed max per phase, its fraction of the bound, the samples above it."""
    over = exceedances(observed, bound)
    return {
        "seeds": list(range(seeds)),
        "samples": samples,
        "observed_max": {k: int(np.max(observed[k])) for k in ("prepare", "feedback", "rti")},
        "fraction_of_bound": {k: float(np.max(observed[k]) / bound[k]) for k in ("prepare", "feedback", "rti")},
        "exceeding_samples": {k: len(v) for k, v in over.items()},
        "passed": not any(over.values()),
    }


def wcet(
    folder: FolderLike,
    target: str,
    seeds: int = 3,
    samples: int = 200,
    validate_seeds: int = 0,
    cflags: str | None = None,
    timeout: float | None = None,
    jobs: int = 1,
    bound_scale: float = 1.0,
) -> dict:
    """The bound of a folder's build on an emulated target, validated on ``validate_seeds`` closed loops; the
    results (``FORMAT``). ``folder``: a :class:`~..solver_folder.SolverFolder` or its path. ``bound_scale`` (a test's
    hook) multiplies the bound before the validation."""
    tgt = get_target(target)
    if not tgt.bare_metal:
        raise WcetError(f"--target {target}: instruction counts need an emulated target (cortex-m7, cortex-m4f)")
    t0 = time.perf_counter()
    folder = as_folder(folder)
    name, pb = folder.name, folder.problem
    caps = solver_caps(folder)
    samples_p, qp_iter, tick = probe_runs(folder, target, seeds, samples, cflags, timeout, jobs)
    bound = compute_bound(samples_p, qp_iter, caps, pb.qp.backend, tick)
    if bound_scale != 1.0:
        bound = {k: int(v * bound_scale) for k, v in bound.items()}
    stats = phase_stats(samples_p)
    res = {
        "format": FORMAT,
        "solver": name,
        "gen_dir": str(folder.path),
        "problem": pb.name,
        "backend": pb.qp.backend,
        "precision": folder.precision,
        "target": tgt.name,
        "target_description": tgt.description,
        "cflags": tgt.cflags(cflags if cflags is not None else "-O2"),
        "unit": "instructions",
        "tick_instructions": tick,
        "bound": {k: bound[k] for k in ("prepare", "feedback", "rti")},
        "per_iteration": bound["per_iteration"],
        "caps": {
            "rti_budget": caps.rti_budget,
            "warm": caps.warm,
            "cold": caps.cold,
            "qp_iterations": caps.qp_iterations,
            "check_termination": caps.check_termination,
            "fit_scans": caps.fit_scans,
            "fit_scan_cap": caps.fit_scan_cap,
        },
        "phases": {k: {"min": v.min, "max": v.max, "count": v.count} for k, v in stats.items()},
        "probe": {
            "scenario": infer_scenario(pb),
            "seeds": list(range(seeds)),
            "samples": samples,
            "reset_every": RESET_EVERY,
            "cold_starts": sum(1 for s in samples_p if s.reset or s.sample == 0),
            "qp_iter_max": max(qp_iter),
            "qp_steps_max": max(s.steps for s in samples_p),
        },
        "validated": {
            "seeds": [],
            "samples": 0,
            "observed_max": None,
            "fraction_of_bound": None,
            "exceeding_samples": None,
            "passed": None,
        },
    }
    if bound_scale != 1.0:
        res["bound_scale"] = bound_scale
    if validate_seeds > 0:
        observed = validation_runs(folder, target, validate_seeds, samples, cflags, timeout, jobs)
        res["validated"] = validate(observed, bound, validate_seeds, samples)
    res["wall_seconds"] = time.perf_counter() - t0
    return res
