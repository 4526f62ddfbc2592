"""The lockstep's rounding envelope of ``fcgen verify``: how far the reference's own solution of one sample's QP moves
when its measured state changes at rounding level, and the relative difference every comparison uses."""

from __future__ import annotations

import math

import numpy as np

from .ocp import INF
from .reference import RtiSolver

ENVELOPE_EPS = (1e-15, -1e-15, 1e-13, -1e-13)
"""Relative perturbations of the measured state with which the reference drives the plant again where the independent
closed loops part beyond the tolerance, and solves a lockstep sample's QP again where the solutions do
(``solution_envelope``): how far the reference parts from itself under rounding-level changes."""
SOLUTION_KEYS = ("z", "z_free", "y", "w", "u0", "max_slack", "plan_clearance")
"""The lockstep's quantities that may be held to a sample's envelope (``solution_envelope``): the QP's solution, the
iterate and u0, and what is computed from the iterate alone (its largest slack, the plan check's clearance)."""


def rel_diff(c, r) -> float:
    """``max |c - r| / max(1, max |r|)`` over the finite entries of ``r`` (0 for empty arrays; inf if only one side
    is NaN). An entry at the "no bound" marker (``|r| >= INF``, a QP's infinite bound) must be matched exactly and
    stays out of the scale: a scale of 1e30 would hide any difference of the finite bounds beside it."""
    c = np.asarray(c, dtype=float).ravel()
    r = np.asarray(r, dtype=float).ravel()
    if c.shape != r.shape:
        raise ValueError(f"shape mismatch: C {c.shape} vs reference {r.shape}")
    if r.size == 0:
        return 0.0
    both_nan = np.isnan(c) & np.isnan(r)
    unbounded = np.abs(r) >= INF
    d = np.where(both_nan, 0.0, np.abs(c - r))
    d = np.where(unbounded, np.where(c == r, 0.0, np.inf), d)
    d = np.where(np.isnan(d), np.inf, d)
    finite = np.isfinite(r) & ~unbounded
    scale = max(1.0, float(np.max(np.abs(np.where(finite, r, 0.0)), initial=0.0)))
    return float(np.max(d)) / scale


def clearance_diff(c: float, r: float, plan: np.ndarray) -> float:
    """The plan check's clearance, C vs reference, at the scale of the positions it is computed from: ``|c - r| /
    max(1, |r|, max |s_k|)``. The plans are compared relative to their largest state (the arc length s, hundreds of
    metres: the iterate's row of the table); a length built from those positions inherits their rounding, so relative
    to max(1, |r|) alone it was held 100-1000x tighter than the plan it is measured on."""
    if c == r:
        return 0.0
    if math.isinf(c) or math.isinf(r):
        return rel_diff(c, r)
    return abs(c - r) / max(1.0, abs(r), float(np.max(np.abs(plan[:, 0]), initial=0.0)))


def iterate_outputs(sv: RtiSolver, w: np.ndarray) -> tuple[float, float]:
    """The largest slack and the plan check's clearance (inf without opponents) of the reference's iterate ``w``, as
    ``feedback`` reports them for its plan."""
    slack = float(np.max(sv.slacks(w), initial=0.0))
    return slack, float(np.min(sv.plan_clearances(w)[0])) if sv.ocp.problem.opponents.count else math.inf


def plan_vector(sv: RtiSolver, w: np.ndarray) -> np.ndarray:
    """The states and controls of the reference's iterate ``w`` (``states(w)``, ``controls(w)`` flattened)."""
    return np.concatenate([sv.states(w).ravel(), sv.controls(w).ravel()])


def solution_envelope(sv: RtiSolver) -> dict[str, float]:
    """How far the reference's own solution of this sample's QP moves when its measured state is scaled by ``1 +
    eps`` (``ENVELOPE_EPS``): the same QP solved again with that state embedded as ``RtiSolver.feedback`` does
    (``RtiSolver.embedding``), from the same warm start; per lockstep key, the largest difference from the
    reference's solution, and under ``qp_iter`` the most its iteration count moves."""
    ocp, lay = sv.ocp, sv.lay
    assert sv.w is not None, "no plan yet"
    ir, free, z, w = lay.init_rows, lay.P_diag == 0.0, np.asarray(sv.z), plan_vector(sv, sv.w)
    u0, (slack, clear), states = ocp.nx * (ocp.N + 1), iterate_outputs(sv, sv.w), sv.states()
    env = dict.fromkeys((*SOLUTION_KEYS, "qp_iter"), 0.0)
    for eps in ENVELOPE_EPS:
        x0_full, q, cap = sv.embedding(sv.x_plan * (1.0 + eps))
        l, u = sv.l.copy(), sv.u.copy()
        l[ir] = x0_full / lay.D[: ocp.nx] - sv.g[ir]
        u[ir] = l[ir]
        r = sv.qp.solve(q, l, u, sv.y_prep, cap)
        env["qp_iter"] = max(env["qp_iter"], float(abs(r.iter - sv.status.qp_iter)))
        if r.z is None or r.y is None:
            continue
        w_full = sv.w_prep + lay.D * r.z
        w_e, (slack_e, clear_e) = plan_vector(sv, w_full), iterate_outputs(sv, w_full)  # w_e: its first control at u0
        for k, d in (
            ("z", rel_diff(r.z[~free], z[~free])),
            ("z_free", rel_diff(r.z[free], z[free])),
            ("y", rel_diff(r.y, sv.y)),
            ("w", rel_diff(w_e, w)),
            ("u0", rel_diff(w_e[u0 : u0 + ocp.nu], w[u0 : u0 + ocp.nu])),
            ("max_slack", rel_diff(slack_e, slack)),
            ("plan_clearance", clearance_diff(clear_e, clear, states)),
        ):
            env[k] = max(env[k], d)
    return env
