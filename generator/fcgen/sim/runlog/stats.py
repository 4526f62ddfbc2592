"""What a run log says in numbers: the run's metrics (SPEC section 7) and the largest differences between two runs."""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ...contract import EXIT_CODES
from .log import RunLog
from .schema import qp_status_name


def _stats_ms(*xs: NDArray[np.float64]) -> list[dict[str, float]]:
    """Mean, median, p99 and max in ms of each of the arrays ``xs`` (one length): one numpy call per statistic along
    the rows of their stack (row by row the values of the calls on each array; median and percentile cost ~0.1 ms a
    call)."""
    if xs[0].size == 0:
        return [{"mean": math.nan, "median": math.nan, "p99": math.nan, "max": math.nan} for _ in xs]
    ms = 1e3 * np.stack(xs)
    stats = zip(
        np.mean(ms, axis=1).tolist(),
        np.median(ms, axis=1).tolist(),
        np.percentile(ms, 99, axis=1).tolist(),
        np.max(ms, axis=1).tolist(),
    )
    return [{"mean": a, "median": b, "p99": c, "max": d} for a, b, c, d in stats]


def summary(log: RunLog) -> dict[str, Any]:
    """Metrics of one run (SPEC section 7), as plain Python numbers.

    Keys: ``progress`` (final minus initial ``s``, m), ``s_final`` (m), ``n_states``, ``n_controls``,
    ``n_collision_samples``, ``time_total_ms`` / ``time_prepare_ms`` / ``time_feedback_ms`` (dicts with
    mean, median, p99, max in ms), ``qp_iter_mean``, ``qp_iter_max``, ``qp_status_counts`` (status name ->
    count, names from ``QP_STATUS_NAMES``), ``max_slack`` (over the samples with a solution; None without one),
    ``samples_unsolved`` (samples without a solution: their logged slack is not finite) and ``unsolved_exit_codes``
    (exit code name -> count of those samples, from the log's ``exit_code``; ``"unknown"`` without it),
    ``max_abs_a_lat`` (m/s^2). Statistics over an empty set are NaN (``qp_iter_max``: 0).
    """
    s = log.ego_frenet[:, 0]
    counts: dict[str, int] = {}
    codes, n_codes = np.unique(log.qp_status, return_counts=True)
    for code, n in zip(codes.tolist(), n_codes.tolist()):
        name = qp_status_name(code)
        counts[name] = counts.get(name, 0) + n
    k = log.n_controls
    slack = np.asarray(log.max_slack, dtype=float)
    solved = np.isfinite(slack)
    t_total, t_prepare, t_feedback = _stats_ms(log.time_total, log.time_prepare, log.time_feedback)
    return {
        "progress": float(s[-1] - s[0]),
        "s_final": float(s[-1]),
        "n_states": log.n_states,
        "n_controls": k,
        "n_collision_samples": int(np.count_nonzero(log.collision)),
        "time_total_ms": t_total,
        "time_prepare_ms": t_prepare,
        "time_feedback_ms": t_feedback,
        "qp_iter_mean": float(np.mean(log.qp_iter)) if k else math.nan,
        "qp_iter_max": int(np.max(log.qp_iter)) if k else 0,
        "qp_status_counts": dict(sorted(counts.items())),
        "max_slack": float(np.max(slack[solved])) if solved.any() else None,
        "samples_unsolved": int(np.count_nonzero(~solved)),
        "unsolved_exit_codes": unsolved_exit_codes(log, ~solved),
        "max_abs_a_lat": float(np.max(np.abs(log.a_lat))),
    }


def fmt_slack(value: float | None) -> str:
    """A summary's ``max_slack`` as text: ``none`` where no sample had a solution."""
    return "none" if value is None else f"{value:.3g}"


def unsolved_exit_codes(log: RunLog, unsolved: NDArray[np.bool_]) -> dict[str, int]:
    """Exit code name -> count over the samples ``unsolved`` (``"unknown"``: a log without ``exit_code``)."""
    if log.exit_code is None:
        return {"unknown": int(np.count_nonzero(unsolved))} if unsolved.any() else {}
    codes, counts = np.unique(np.asarray(log.exit_code)[unsolved], return_counts=True)
    return {_exit_name(int(c)): int(n) for c, n in zip(codes, counts)}


def _exit_name(code: int) -> str:
    return EXIT_CODES[code] if 0 <= code < len(EXIT_CODES) else f"unknown({code})"


def compare(log_a: RunLog, log_b: RunLog) -> dict[str, float]:
    """Max absolute difference of every per-sample array between two runs (e.g. C vs Python reference).

    Returns ``{field: max |a - b|}`` for all fields of ``STATE_FIELDS`` and ``CONTROL_FIELDS`` (bool and
    int fields are compared as numbers, so 0 means identical). NaN at the same place in both counts as
    equal; NaN in one only gives ``inf``. Timing fields are included but naturally differ between runs.
    Optional fields (``OPTIONAL_FIELDS``) are compared when both logs carry them.
    Raises ValueError if the shapes differ (different number of samples or opponents).
    """
    out: dict[str, float] = {}
    common = [n for n in log_a.sample_fields() if n in log_b.sample_fields()]
    for name in common:
        a = np.asarray(getattr(log_a, name), dtype=np.float64)
        b = np.asarray(getattr(log_b, name), dtype=np.float64)
        if a.shape != b.shape:
            raise ValueError(f"field {name!r}: shapes differ, {a.shape} vs {b.shape}")
        if a.size == 0:
            out[name] = 0.0
            continue
        with np.errstate(invalid="ignore"):
            d = np.abs(a - b)
        both_nan = np.isnan(a) & np.isnan(b)
        d[both_nan] = 0.0
        d[np.isnan(d)] = math.inf  # NaN in only one of them (equal infinities are fixed next)
        same_inf = np.isinf(a) & (a == b)
        d[same_inf] = 0.0
        out[name] = float(np.max(d))
    return out
