"""The QP outcome contract shared by the Python reference and the generated C: the exit code of each QP status, the
input box a usable step's u0 must keep to, what get_u0 returns and the guess becomes after an unusable QP, the cold
restart, and the QP's iteration caps.

``fcgen.reference`` applies it; ``fcgen.codegen`` emits it (the header's macros and tables, the README's table).
"""

from __future__ import annotations

import numpy as np

from .backends import (
    QP_DUAL_INFEASIBLE,
    QP_MAX_ITER,
    QP_NONCONVEX,
    QP_NONFINITE,
    QP_NUMERICAL,
    QP_OTHER,
    QP_PRIMAL_INFEASIBLE,
    QP_SOLVED,
    QP_SOLVED_INACCURATE,
    QP_STATUSES,
    QP_USABLE,
)
from .dsl import QpOptions

MAX_INPUT_VIOLATION = 0.05
"""The largest input-box violation (``u_violation``: max_i excess_i / limit_i) a usable QP's step may have: beyond
it the QP counts as unusable (``ERR_QP_INPUT_BOUNDS``). A usable QP's u0 leaves the box only by its tolerance: normal
closed loops (capped at 60 iterations) peak at 0.0008, a cold start capped at 60 left 0.016; a warm-started QP
capped on an absurd state (n = 100 m, 1e15) left 10 .. 1e14 with a garbage plan. 5 % of the bound is 3x the worst
tolerance case and far below the garbage. Emitted as ``<NAME>_MAX_INPUT_VIOLATION``."""

QP_EXIT = {
    0: "ERR_QP",
    QP_SOLVED: "OK",
    QP_SOLVED_INACCURATE: "OK",
    QP_MAX_ITER: "OK",
    QP_PRIMAL_INFEASIBLE: "ERR_QP_INFEASIBLE",
    QP_DUAL_INFEASIBLE: "ERR_QP_DUAL_INFEASIBLE",
    QP_NONCONVEX: "ERR_QP_NONCONVEX",
    QP_NONFINITE: "ERR_QP_NONFINITE",
    QP_NUMERICAL: "ERR_QP_NUMERICAL",
    QP_OTHER: "ERR_QP",
}
"""The QP outcome contract: the exit code feedback() returns for each generic QP status (OK: the step is taken).
A usable status with a non-finite step or multipliers counts as QP_NONFINITE; one whose step's u0 leaves the input box
by more than MAX_INPUT_VIOLATION gives ERR_QP_INPUT_BOUNDS (the status stays the backend's)."""
assert set(QP_EXIT) == set(range(len(QP_STATUSES) + 1)) and {s for s, c in QP_EXIT.items() if c == "OK"} == set(
    QP_USABLE
)

KEPT = "kept: the shifted previous plan (see the cold restart)"
"""What becomes of the guess after an unusable QP."""

QP_CONTRACT = (
    (
        f"QP_SOLVED, QP_SOLVED_INACCURATE, QP_MAX_ITER (finite step, its u0's u_violation <= {MAX_INPUT_VIOLATION:g})",
        "OK",
        "u0 of the new plan, projected on the input box",
        "the new plan (guess + step), its multipliers",
    ),
    (
        f"QP_SOLVED, QP_SOLVED_INACCURATE, QP_MAX_ITER (finite step, its u0's u_violation > {MAX_INPUT_VIOLATION:g}"
        ": far outside the input box)",
        "ERR_QP_INPUT_BOUNDS",
        "fallback",
        KEPT,
    ),
    ("QP_PRIMAL_INFEASIBLE", "ERR_QP_INFEASIBLE", "fallback", KEPT),
    ("QP_DUAL_INFEASIBLE", "ERR_QP_DUAL_INFEASIBLE", "fallback", KEPT),
    ("QP_NONCONVEX", "ERR_QP_NONCONVEX", "fallback", KEPT),
    ("QP_NONFINITE (or a usable status with a non-finite step)", "ERR_QP_NONFINITE", "fallback", KEPT),
    ("QP_NUMERICAL (the backend failed)", "ERR_QP_NUMERICAL", "fallback", KEPT),
    ("QP_OTHER", "ERR_QP", "fallback", KEPT),
)
"""(QP status, exit code, what get_u0 returns, what becomes of the guess) for the README and the header.
Fallback: u_1 of the previous plan (= u0 of the shifted guess), projected on the input box; zeros on a cold start.
After ``qp.cold_restart_after`` unusable QPs in a row the next prepare cold-starts (:data:`COLD_RESTART_NOTE`)."""

COLD_RESTART_NOTE = (
    "after COLD_RESTART_AFTER unusable QPs in a row (status.qp_unusable_run; 0 = never) the next prepare does not "
    "shift the kept plan but cold-starts: the initial guess from the state set last, zero duals, a reset QP backend, "
    "the cold iteration budget (what reset() would give; the inputs are kept, status.cold_restarts counts it). "
    "Without it (0) a plan shifted N times is its last stage repeated, its fallback u_{N-1} held forever; with "
    "1 <= COLD_RESTART_AFTER < N the plan is never shifted past its end (with more, u_{N-1} is "
    "held until the restart), and a cold guess's fallback is zero input"
)
"""The cold-restart rule, for the README and the header (the macro name is prefixed there)."""


def input_box(problem) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The hard input box [F_d, r]: lower, upper bound and the limit the violation is measured against."""
    lim = np.array([problem.bounds.F_d_max, problem.bounds.r_max], dtype=float)
    return -lim, lim.copy(), lim


def project_control(u: np.ndarray, lo: np.ndarray, hi: np.ndarray, lim: np.ndarray) -> tuple[np.ndarray, float]:
    """u projected on [lo, hi] and the largest excess relative to the limit (0: inside); the C arithmetic."""
    out = np.empty(len(u))
    worst = 0.0
    for i, v in enumerate(np.asarray(u, dtype=float).tolist()):
        a, b = float(lo[i]), float(hi[i])
        excess = (a - v) / float(lim[i]) if v < a else ((v - b) / float(lim[i]) if v > b else 0.0)
        out[i] = a if v < a else (b if v > b else v)
        if excess > worst:
            worst = excess
    return out, worst


def cold_max_iter(opts: QpOptions) -> int:
    """Iteration cap of a cold-started QP (no shifted guess): never below the warm one, never above the RTI budget."""
    return opts.caps[1]


def warm_max_iter(opts: QpOptions) -> int:
    """Iteration cap of a warm-started QP (the shifted plan): ``max_iter``, never above the RTI budget."""
    return opts.caps[0]
