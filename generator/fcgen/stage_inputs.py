"""The per-stage run-time inputs: the tracking reference per node (``set_reference_stages``) and the obstacle margin
per stage (``set_obstacle_margins``), their checks and what they do to a stage's parameters, as the C does them.

A margin m_k >= 0 grows every opponent's shape in stage k's parameters before the obstacle model covers it: the
chassis' length and width by 2 m_k (the rectangle grown by m_k on each side, centre kept), the containing ellipse's
semi-axes (``Ellipse(shape="minkowski")``) by m_k, the conventional formulation's fitted Frenet box's half-length
and half-width by m_k. The plan check keeps the true shapes. ``docs/c_api.md`` says what that means per model.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence

import numpy as np

from . import obstacles as obs
from .contract import INPUT_RANGES, SolverError, Status, reference_outside
from .dsl import Ellipse
from .ocp import Ocp


def reference_stages(v_ref, n_ref, n_nodes: int, n_min: float, n_max: float) -> tuple[np.ndarray, np.ndarray]:
    """(v_ref, n_ref) per node as float arrays; a ``ValueError`` naming the first node outside the ranges."""
    v = np.array(v_ref, dtype=float).ravel()  # copies: the caller's arrays may change afterwards
    n = np.array(n_ref, dtype=float).ravel()
    if v.size != n_nodes or n.size != n_nodes:
        raise ValueError(f"reference per stage: v_ref has {v.size}, n_ref {n.size} values; allowed N+1 = {n_nodes}")
    for k in range(n_nodes):
        if why := reference_outside(float(v[k]), float(n[k]), n_min, n_max):
            raise ValueError(f"stage {k}: {why}")
    return v, n


def margins_checked(margins, n_nodes: int) -> np.ndarray:
    """The obstacle margin per stage as a float array; a ``ValueError`` naming the first value outside
    [0, ``INPUT_RANGES.margin_max``] m (NaN included)."""
    m = np.array(margins, dtype=float).ravel()
    if m.size != n_nodes:
        raise ValueError(f"obstacle margins: {m.size} values; allowed N+1 = {n_nodes}")
    hi = INPUT_RANGES.margin_max
    for k, v in enumerate(m):
        if not 0.0 <= v <= hi:
            raise ValueError(f"obstacle margin of stage {k} = {float(v)!r} is invalid: allowed in [0, {hi}] m")
    return m


def margin_terms(ocp: Ocp) -> tuple[tuple[int, float], ...]:
    """(index within one opponent's stage parameters, factor) of what a margin m adds factor * m to."""
    if ocp.fit is not None:  # the fitted box: half-length, half-width
        return ((obs.FRENET_SHAPE.index("L"), 1.0), (obs.FRENET_SHAPE.index("W"), 1.0))
    base = len(obs.CARTESIAN_POSE)
    terms = [(base, 2.0), (base + 1, 2.0)]  # length, width
    model = ocp.problem.obstacles
    if isinstance(model, Ellipse) and model.shape == "minkowski":
        terms += [(base + len(obs.OPP_SHAPE), 1.0), (base + len(obs.OPP_SHAPE) + 1, 1.0)]
    return tuple(terms)


def grow_opponents(opp: np.ndarray, n_opp_stage: int, terms: Sequence[tuple[int, float]], m: float) -> np.ndarray:
    """One stage's opponents' parameters with margin m (a copy; m = 0: the same values, bit for bit)."""
    if m == 0.0 or opp.size == 0:
        return opp
    out = np.array(opp, dtype=float).reshape(-1, n_opp_stage)
    for i, f in terms:
        out[:, i] = out[:, i] + f * m
    return out.ravel()


def reference_s(s0: float, times: Sequence[float], v_ref: Sequence[float], k: int) -> float:
    """Node k's s_ref of a per-stage reference without the curve speed: s_0 = s0, s_k = s_(k-1) + (t_k - t_(k-1))
    v_ref,(k-1) (the C's ref_s: the same operations)."""
    s = float(s0)
    for i in range(k):
        s = s + (times[i + 1] - times[i]) * v_ref[i]
    return s


def stage_xref(k: int, s0: float, times, ref, stages: bool, default: tuple[float, float], curve_ref) -> list[float]:
    """x_ref of node k: the curve reference if any, else per-stage (``reference_s``) or one speed for every node
    (s0 + t_k v_ref); ``ref``: (v, n) per node or None (the problem's ``default``)."""
    v_k, n_k = (float(ref[0][k]), float(ref[1][k])) if ref is not None else default
    if curve_ref is not None:
        return [curve_ref[0][k], n_k, 0.0, curve_ref[1][k], 0.0]
    s = reference_s(s0, times, ref[0], k) if stages else s0 + times[k] * v_k
    return [s, n_k, 0.0, v_k, 0.0]


def margin_meaning(ocp: Ocp) -> str:
    """What a margin m_k does to the problem's obstacle rows (the header's and docs' one sentence)."""
    model = ocp.problem.obstacles
    if ocp.fit is not None:
        return "the fitted Frenet box's half-length and half-width grow by m_k (the box grown by m_k on each side)."
    grown = "the chassis' length and width grow by 2 m_k (the rectangle grown by m_k on each side, centre kept)"
    if isinstance(model, Ellipse) and model.shape == "minkowski":
        return (
            "the containing ellipse's semi-axes a, b grow by m_k: the clearance grows by m_k along the opponent's axes "
            "and by at least 2 sqrt(a b) / (a + b) m_k between them (0.8 m_k for a = 4 b)."
        )
    if isinstance(model, Ellipse):
        return grown + ": the paper's semi-axes sqrt(2) L + r, sqrt(2) W + r grow by sqrt(2) m_k."
    if model.kind == "covering_circles":
        return grown + ": the circles are placed and sized on the grown rectangle (radius 'cover': they cover it)."
    return grown + ": the plane separates the grown rectangle, so the ego keeps the model's margin + m_k from it."


class StageInputsMixin:
    """The reference's setters of the per-stage inputs (``RtiSolver``'s; the C's ``set_reference_stages`` and
    ``set_obstacle_margins``): a refused call raises ``SolverError`` and changes nothing but ``status.exit_code``."""

    ocp: Ocp
    ref: tuple[np.ndarray, np.ndarray] | None
    ref_stages: bool
    margins: np.ndarray
    status: Status

    _fail: Callable[[str, str], SolverError]

    def set_reference_stages(self, v_ref, n_ref) -> None:
        """The reference per node k = 0..N (N+1 values each; ``fcgen.stage_inputs``), e.g. a lane change's n_ref."""
        b, n = self.ocp.problem.bounds, self.ocp.N + 1
        if v_ref is None or n_ref is None:
            raise self._fail("ERR_NULL_POINTER", "reference per stage: v_ref and n_ref are required")
        try:
            self.ref, self.ref_stages = reference_stages(v_ref, n_ref, n, b.n_min, b.n_max), True
        except ValueError as e:
            raise self._fail("ERR_REFERENCE", str(e)) from None
        self.status.exit_code = 0  # an accepted call (the C's ok())

    def set_obstacle_margins(self, margins) -> None:
        """An extra distance m_k >= 0 per stage k = 0..N that grows every opponent's shape (``fcgen.stage_inputs``)."""
        if margins is None:
            raise self._fail("ERR_NULL_POINTER", "obstacle margins: N+1 values are required")
        try:
            self.margins = margins_checked(margins, self.ocp.N + 1)
        except ValueError as e:
            raise self._fail("ERR_MARGIN", str(e)) from None
        self.status.exit_code = 0  # an accepted call (the C's ok())
