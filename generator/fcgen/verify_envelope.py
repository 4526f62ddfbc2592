"""The lockstep's rounding envelope of ``fcgen verify``: how far the reference's own solution of one sample's QP moves
when its measured state changes at rounding level, and the relative difference every comparison uses."""

from __future__ import annotations

import numpy as np

from .ocp import INF
from .qp_outcome import cold_max_iter, warm_max_iter
from .reference import RtiSolver

ENVELOPE_EPS = (1e-15, -1e-15, 1e-13, -1e-13)
"""Relative perturbations of the measured state with which the reference drives the plant again where the independent
closed loops part beyond the tolerance, and solves a lockstep sample's QP again where the solutions do
(``solution_envelope``): how far the reference parts from itself under rounding-level changes."""
SOLUTION_KEYS = ("z", "z_free", "y", "w", "u0")
"""The lockstep's quantities that may be held to a sample's envelope (``solution_envelope``)."""


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


def plan_vector(sv: RtiSolver, w: np.ndarray) -> np.ndarray:
    """The states and controls of the reference's iterate ``w`` (``states()``, ``controls()`` flattened)."""
    nx, nu, N = sv.ocp.nx, sv.ocp.nu, sv.ocp.N
    st = [sv._stage(w, sv.lay, k) for k in range(N + 1)]
    return np.concatenate([np.ravel([s[:nx] for s in st]), np.ravel([s[nx : nx + nu] for s in st[:N]])])


def solution_envelope(sv: RtiSolver) -> dict[str, float]:
    """How far the reference's own solution of this sample's QP moves when its measured state is scaled by ``1 +
    eps`` (``ENVELOPE_EPS``): the same QP solved again with that state embedded as ``RtiSolver.feedback`` does, from
    the same warm start and iteration cap; per lockstep key, the largest difference from the reference's solution."""
    ocp, lay = sv.ocp, sv.lay
    assert sv.w is not None, "no plan yet"
    ir, free, z, w = lay.init_rows, lay.P_diag == 0.0, np.asarray(sv.z), plan_vector(sv, sv.w)
    cap, u0 = cold_max_iter(sv.qp_opts) if sv.cold else warm_max_iter(sv.qp_opts), ocp.nx * (ocp.N + 1)
    env = dict.fromkeys(SOLUTION_KEYS, 0.0)
    for eps in ENVELOPE_EPS:
        x = sv.x_plan * (1.0 + eps)
        l, u = sv.l.copy(), sv.u.copy()
        l[ir] = np.array(ocp.init_state(x, sv.stage_params(0, x[0]))).ravel() / lay.D[: ocp.nx] - sv.g[ir]
        u[ir] = l[ir]
        r = sv.qp.solve(sv.q + lay.q_ds0 * (x[0] - sv.s0_guess), l, u, sv.y_prep, cap)
        if r.z is None or r.y is None:
            continue
        w_e = plan_vector(sv, sv.w_prep + lay.D * r.z)  # its first control at u0
        for k, d in (
            ("z", rel_diff(r.z[~free], z[~free])),
            ("z_free", rel_diff(r.z[free], z[free])),
            ("y", rel_diff(r.y, sv.y)),
            ("w", rel_diff(w_e, w)),
            ("u0", rel_diff(w_e[u0 : u0 + ocp.nu], w[u0 : u0 + ocp.nu])),
        ):
            env[k] = max(env[k], d)
    return env
