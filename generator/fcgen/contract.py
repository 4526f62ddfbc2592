"""What the Python reference, the generated C and the closed loop agree on: the exit codes, the status of a sample,
one sample's result and the tick rate of the host clocks.

A low module (numpy only) so that the reference, the code generator, the C binding and the closed loop share one
definition without importing each other.
"""

from __future__ import annotations

import ctypes
import struct
from dataclasses import dataclass

import numpy as np

EXIT_CODES = (
    "OK",
    "ERR_NOT_PREPARED",
    "ERR_NO_STATE",
    "ERR_NONFINITE_STATE",
    "ERR_NONFINITE_OPPONENTS",
    "ERR_NONFINITE_ROAD",
    "ERR_ROAD_WINDOW",
    "ERR_ROAD_SIZE",
    "ERR_QP",
    "ERR_QP_INFEASIBLE",
    "ERR_QP_DUAL_INFEASIBLE",
    "ERR_QP_NONCONVEX",
    "ERR_QP_NONFINITE",
    "ERR_QP_NUMERICAL",
    "ERR_OPP_FRENET",
    "ERR_QP_INPUT_BOUNDS",
    "ERR_ROAD_BOUNDS",
    "ERR_OPP_SHAPE",
    "ERR_REFERENCE",
    "ERR_NULL_POINTER",
    "ERR_MARGIN",
)
"""Exit codes shared by the reference and the generated C API (``<NAME>_<code>``), in enum order (new codes are
appended, so a code keeps its number)."""


@dataclass(frozen=True)
class InputRanges:
    """What the run-time setters accept (the C's ``set_road``, ``set_opponent_shapes``, ``set_reference`` and the
    Python reference alike): ranges a road or a vehicle can have, so that no accepted value reaches an overflow."""

    ds_min: float = 1e-3  # road sample spacing, m
    ds_max: float = 100.0
    shape_min: float = 0.1  # an opponent's length and width (and the containing ellipse's semi-axes at most), m
    shape_max: float = 100.0
    v_ref_max: float = 100.0  # the reference speed, m/s (n_ref: within the problem's Bounds.n_min .. n_max)
    margin_max: float = 10.0  # an obstacle margin per stage (set_obstacle_margins), m, at least 0

    def __post_init__(self) -> None:
        if not (
            0.0 < self.ds_min < self.ds_max
            and 0.0 < self.shape_min < self.shape_max
            and self.v_ref_max > 0.0
            and self.margin_max > 0.0
        ):
            raise ValueError(f"input ranges {self!r}: each lower bound must be > 0 and below its upper bound")


INPUT_RANGES = InputRanges()
"""The ranges of the generated C's setters and of the reference (``docs/c_api.md``)."""


def reference_outside(v_ref: float, n_ref: float, n_min: float, n_max: float) -> str:
    """Why set_reference refuses (v_ref, n_ref) given the band ``Bounds.n_min .. n_max`` ('' if it does not)."""
    v_max = INPUT_RANGES.v_ref_max
    if 0.0 <= v_ref <= v_max and n_min <= n_ref <= n_max:
        return ""
    return (
        f"reference: v_ref = {v_ref!r}, n_ref = {n_ref!r}; allowed v_ref in [0, {v_max}] m/s, "
        f"n_ref in [{n_min}, {n_max}] m (Bounds.n_min, n_max)"
    )


HOST_TICKS_PER_SECOND = 1_000_000_000
"""Ticks per second of ``<name>_host_clock`` / ``_host_cpu_clock`` (nanoseconds modulo 2^32;
``<NAME>_HOST_TICKS_PER_SECOND``)."""


INT_MAX = 2**31 - 1
"""The status counters saturate here (the C's int)."""


class SolverError(RuntimeError):
    """A solver call that cannot proceed (bad input or wrong call order); the solver stays usable."""

    def __init__(self, code: str, message: str):
        super().__init__(f"{code}: {message}")
        self.code = code
        self.exit_code = EXIT_CODES.index(code)


@dataclass
class Status:
    """What one sample's solve reports (mirrors the C status struct)."""

    exit_code: int = 0
    qp_status: int = 0  # generic QP_* status (fcgen.backends.QP_STATUSES; 0: no QP solved)
    qp_raw_status: int = 0  # the backend's own status value
    qp_iter: int = 0
    u_projected: int = 0  # 1: get_u0 is the plan's u0 projected on the input box
    u_violation: float = 0.0  # how far the plan's u0 left the box: max_i excess_i / limit_i (0: inside)
    opp_outside: int = 0  # conventional: (stage, opponent) pairs the last prepare left out (off the road)
    qp_unusable_run: int = 0  # feedbacks in a row whose QP was unusable (0 after an OK one and after a cold restart)
    cold_restarts: int = 0  # prepares that cold-started after qp.cold_restart_after unusable QPs in a row
    plan_clearance_stage: int = 0  # the stage of plan_clearance (-1: no opponent)
    plan_reaction: int = 0  # 1: the plan check braked (get_u0 is the braking control, not the plan's u0)
    a_lat_guard: int = 0  # 1: the a_lat guard set get_u0's steering rate, 2: it braked too (PlanCheck.a_lat_guard)
    plan_clearance: float = 0.0  # the plan's smallest SAT clearance to an opponent over stages 0..N, m (inf: none)
    time_prepare: float = 0.0
    time_feedback: float = 0.0


@dataclass
class StepResult:
    """What a controller returns for one sample."""

    u: np.ndarray
    exit_code: int
    qp_status: int
    qp_iter: int
    time_prepare: float
    time_feedback: float
    max_slack: float
    plan_reaction: int = 0  # 1: the plan check braked this sample (status.plan_reaction)
    a_lat_guard: int = 0  # 1: the a_lat guard set the steering rate, 2: it braked too (status.a_lat_guard)


# The C status struct's layout (the ctypes binding, fcgen.csolver)
STATUS_INTS = (
    "exit_code",
    "qp_status",
    "qp_raw_status",
    "qp_iter",
    "u_projected",
    "opp_outside",
    "qp_unusable_run",
    "cold_restarts",
    "plan_clearance_stage",
    "plan_reaction",
    "a_lat_guard",
)
STATUS_REALS = ("u_violation", "plan_clearance")
STATUS_TICKS = ("ticks_prepare", "ticks_feedback")


def status_struct(use_float: bool) -> tuple[type[ctypes.Structure], struct.Struct]:
    """The C status struct (``<name>_get_status``) of a precision as a ctypes class, and its layout for ``struct``
    (all fields in one call; native alignment, as ctypes lays it out)."""
    real, code = (ctypes.c_float, "f") if use_float else (ctypes.c_double, "d")
    fields = (
        [(f, ctypes.c_int) for f in STATUS_INTS]
        + [(f, real) for f in STATUS_REALS]
        + [(f, ctypes.c_uint32) for f in STATUS_TICKS]
    )
    cls = type(f"_CStatus{'Float' if use_float else 'Double'}", (ctypes.Structure,), {"_fields_": fields})
    layout = struct.Struct("@" + "i" * len(STATUS_INTS) + code * len(STATUS_REALS) + "I" * len(STATUS_TICKS))
    assert layout.size == ctypes.sizeof(cls)
    return cls, layout


#: per precision (``use_float``): the ctypes class and the ``struct`` layout of ``<name>_status_t``
STATUS_STRUCTS = {use_float: status_struct(use_float) for use_float in (False, True)}
STATUS_FIELDS = STATUS_INTS + STATUS_REALS + STATUS_TICKS
