"""The worst-case instruction bound: the solver's caps times the worst observed path of each phase.

Pure arithmetic on the probe's phase instances (``fcgen.wcet.probe``). Every measured interval is a whole number of
SysTick ticks and can read up to one tick short of the instructions it took, so each phase maximum enters the bound
plus one tick (``tick`` instructions).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .probe import SampleProbe


class BoundError(ValueError):
    """The probe runs do not hold what the bound needs (a phase never observed)."""


@dataclass(frozen=True)
class Caps:
    """The solver's structural caps the bound multiplies."""

    rti_budget: int  # the most QP iterations of one feedback (<NAME>_RTI_BUDGET; cold starts included)
    warm: int  # a warm-started QP's cap
    cold: int  # a cold-started QP's cap
    qp_iterations: int  # the iterations the bound charges (OSQP: rti_budget rounded up to check_termination)
    check_termination: int | None = None  # OSQP: iterations between termination checks
    fit_scans: int = 0  # the conventional fit's nearest-sample scans per prepare ((N + 1) NOPP; 0: no fit)
    fit_scan_cap: int = 0  # samples one scan visits at most (the road window's samples, ROAD_MAX)

    def __post_init__(self) -> None:
        if not 1 <= self.warm <= self.cold <= self.rti_budget <= self.qp_iterations:
            raise ValueError(f"caps: need 1 <= warm <= cold <= rti_budget <= qp_iterations, got {self}")


@dataclass(frozen=True)
class PhaseStats:
    """Min / max / count of one phase's instances (instructions)."""

    min: int
    max: int
    count: int


def phase_stats(samples: list[SampleProbe]) -> dict[str, PhaseStats]:
    """Per phase (and prepare / feedback as called; prepare without the fit's scan steps if it has them) its
    instances' min, max and count."""
    values: dict[str, list[int]] = {}
    fit = any("fit_scan_step" in sp.phases for sp in samples)
    for sp in samples:
        for key, v in (("prepare", sp.prepare), ("feedback", sp.feedback), ("prepare_rest", sp.prepare_rest)):
            if v is not None and (fit or key != "prepare_rest"):
                values.setdefault(key, []).append(v)
        for name, vs in sp.phases.items():
            if vs:
                values.setdefault(name, []).extend(vs)
    return {k: PhaseStats(int(min(v)), int(max(v)), len(v)) for k, v in sorted(values.items())}


def _need(stats: dict[str, PhaseStats], *names: str) -> None:
    missing = [n for n in names if n not in stats]
    if missing:
        raise BoundError(f"the probe runs never showed the phase(s) {', '.join(missing)}: run more samples or seeds")


def ipm_feedback(maxima: dict[str, int], iterations: int, tick: int) -> int:
    """Feedback with ``iterations`` QP iterations, each phase at its max: head, iterations + 1 checks, iterations
    steps, the QP's tail, feedback's tail (each plus one tick)."""
    return (
        (maxima["head"] + tick)
        + (iterations + 1) * (maxima["check"] + tick)
        + iterations * (maxima["step"] + tick)
        + (maxima["qp_tail"] + tick)
        + (maxima["feedback_tail"] + tick)
    )


def osqp_per_iteration(samples: list[SampleProbe], qp_iter: list[int], tick: int) -> int:
    """OSQP's instructions per iteration, its checks and fixed cost spread over them: the largest (QP + tick) /
    iterations over the samples that iterated (``qp_iter``: each sample's iterations, the run log's)."""
    ratios = [math.ceil((qp + tick) / n) for sp, n in zip(samples, qp_iter) if n > 0 for qp in sp.phases.get("qp", [])]
    if not ratios:
        raise BoundError("the probe runs never showed an OSQP solve with an iteration")
    return max(ratios)


def osqp_feedback(maxima: dict[str, int], per_iteration: int, iterations: int, tick: int) -> int:
    """Feedback with ``iterations`` OSQP iterations at ``per_iteration`` each, head and tail at their max."""
    return (maxima["head"] + tick) + iterations * per_iteration + (maxima["feedback_tail"] + tick)


def prepare_bound(samples: list[SampleProbe], caps: Caps, tick: int) -> int:
    """Prepare's bound: its max (plus a tick); with the conventional fit, the rest of prepare at its max plus every
    scan at its cap, each scan step at its max (the rest is prepare minus the scan steps: a tick per subtracted
    interval added)."""
    done = [sp for sp in samples if sp.prepare is not None]
    if not done:
        raise BoundError("the probe runs never called prepare")
    if caps.fit_scans == 0:
        return max(sp.prepare for sp in samples if sp.prepare is not None) + tick
    steps = [v for sp in done for v in sp.phases.get("fit_scan_step", [])]
    if not steps:
        raise BoundError("the probe runs never showed a step of the fit's scan")
    rest = max(
        sp.prepare_rest + tick * (1 + len(sp.phases.get("fit_scan_step", [])))
        for sp in done
        if sp.prepare_rest is not None
    )
    return rest + caps.fit_scans * caps.fit_scan_cap * (max(steps) + tick)


def compute_bound(samples: list[SampleProbe], qp_iter: list[int], caps: Caps, backend: str, tick: int) -> dict:
    """``{"prepare", "feedback", "rti", "per_iteration"}`` (instructions) from the probe runs' samples."""
    stats = phase_stats(samples)
    maxima = {k: v.max for k, v in stats.items()}
    if backend == "ipm":
        _need(stats, "head", "check", "step", "qp_tail", "feedback_tail")
        feedback = ipm_feedback(maxima, caps.qp_iterations, tick)
        per_iteration = (maxima["check"] + tick) + (maxima["step"] + tick)
    elif backend == "osqp":
        _need(stats, "head", "qp", "feedback_tail")
        per_iteration = osqp_per_iteration(samples, qp_iter, tick)
        feedback = osqp_feedback(maxima, per_iteration, caps.qp_iterations, tick)
    else:
        raise BoundError(f"backend {backend!r}: no bound model")
    if "feedback_no_qp" in maxima:
        feedback = max(feedback, maxima["feedback_no_qp"] + tick)
    prepare = prepare_bound(samples, caps, tick)
    return {
        "prepare": int(prepare),
        "feedback": int(feedback),
        "rti": int(prepare + feedback),
        "per_iteration": int(per_iteration),
    }


def exceedances(observed: dict[str, np.ndarray], bound: dict[str, int]) -> dict[str, list[int]]:
    """Per phase (prepare, feedback, rti) the indices of the observed samples above the bound."""
    return {
        k: [int(i) for i in np.flatnonzero(np.asarray(observed[k]) > bound[k])] for k in ("prepare", "feedback", "rti")
    }
