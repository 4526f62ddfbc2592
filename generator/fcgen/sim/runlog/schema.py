"""The run log's schema (format ``fcgen-runlog/1``, docs/runlog.md): its version, the keys of ``meta`` and ``road``,
the per-sample fields with their kinds and shapes, the QP status names, and a valid ``meta``."""

from __future__ import annotations

from collections.abc import Mapping
from functools import lru_cache
from importlib import metadata
from typing import Any

from ...backends import QP_STATUSES

#: Format identifier written to and required in every file (see the versioning policy in docs/runlog.md).
FORMAT_VERSION = "fcgen-runlog/1"

#: Allowed values of ``meta["controller"]``.
CONTROLLER_KINDS: tuple[str, ...] = ("python-reference", "c", "c-firmware_sim", "c-fmu")

#: Keys ``meta`` must contain (more keys are allowed and preserved).
META_KEYS: tuple[str, ...] = (
    "problem",
    "formulation",
    "obstacle_model",
    "scenario",
    "seed",
    "N",
    "dt",
    "versions",
    "controller",
    "extra",
)

#: Array keys of ``road`` (all of one length M, on a uniform grid of spacing ``road["ds"]``).
ROAD_ARRAY_KEYS: tuple[str, ...] = ("s", "kappa", "gamma_x", "gamma_y", "phi_gamma")

#: Keys of a vehicle-dimension mapping (``ego`` and each entry of ``opponents``), metres.
DIM_KEYS: tuple[str, ...] = ("l_f", "l_r", "l_r_ch", "l_f_ch", "w_ch")

# name -> (dtype kind, trailing shape); "O" in a trailing shape stands for the number of opponents.
#: Per-state-sample fields (K + 1 rows, times t_0 .. t_K).
STATE_FIELDS: dict[str, tuple[str, tuple[Any, ...]]] = {
    "t": ("float", ()),
    "ego_frenet": ("float", (5,)),
    "ego_cartesian": ("float", (3,)),
    "opp_cartesian": ("float", ("O", 3)),
    "opp_frenet": ("float", ("O", 3)),
    "collision": ("bool", ()),
    "a_lat": ("float", ()),
}
#: Per-control-sample fields (K rows, one per applied control / solver call).
CONTROL_FIELDS: dict[str, tuple[str, tuple[Any, ...]]] = {
    "control": ("float", (2,)),
    "time_prepare": ("float", ()),
    "time_feedback": ("float", ()),
    "time_total": ("float", ()),
    "qp_iter": ("int", ()),
    "qp_status": ("int", ()),
    "max_slack": ("float", ()),
}
#: The required per-sample fields: state fields, then control fields.
SAMPLE_FIELDS = {**STATE_FIELDS, **CONTROL_FIELDS}
#: Optional per-control-sample fields (K rows; for replay comparison, docs/runlog.md): "N" in a trailing shape is
#: ``meta["N"]``, "*" any positive size (one value for all rows). A log either has a field with this shape or not.
OPTIONAL_FIELDS: dict[str, tuple[str, tuple[Any, ...]]] = {
    "exit_code": ("int", ()),
    "plan_states": ("float", ("N+1", "*")),
    "plan_controls": ("float", ("N", "*")),
    # a plant other than fcgen's model or a perturbed loop (docs/plants.md): the model formula's a_lat on the plant's
    # states (K + 1 rows), the control the plant got (after latency and steering lag), the input limits that cut it
    "a_lat_model": ("float", ()),
    "control_applied": ("float", (2,)),
    "plant_cut": ("int", ()),
}
#: The optional fields with one row per state sample (K + 1); the others have one per control sample (K).
OPTIONAL_STATE_FIELDS: tuple[str, ...] = ("a_lat_model",)

#: Generic QP status codes (``fcgen.backends.QP_STATUSES``: the same for every QP backend, C and Python alike), without
#: the ``QP_`` prefix, lower case. The backend's own status is not logged.
QP_STATUS_NAMES: dict[int, str] = {
    code: name.removeprefix("QP_").lower() for code, name in enumerate(QP_STATUSES, start=1)
}


def qp_status_name(code: int) -> str:
    """Name of a generic QP status code (``"unknown_<code>"`` for other codes, e.g. 0: no QP solved)."""
    return QP_STATUS_NAMES.get(int(code), f"unknown_{int(code)}")


def package_versions() -> dict[str, str]:
    """Installed versions of fcgen, casadi, osqp and numpy, for ``meta["versions"]`` (no imports needed)."""
    return dict(_package_versions())


@lru_cache(maxsize=1)
def _package_versions() -> dict[str, str]:
    """``package_versions`` looked up once per process (the metadata scan costs ~7 ms; installs do not change)."""
    out = {}
    for name in ("fcgen", "casadi", "osqp", "numpy"):
        try:
            out[name] = metadata.version(name)
        except metadata.PackageNotFoundError:
            out[name] = "unknown"
    return out


def make_meta(
    *,
    problem: str,
    formulation: str,
    obstacle_model: str,
    scenario: str,
    seed: int,
    N: int,
    dt: float,
    controller: str,
    n_bound: float | None = None,
    extra: Mapping[str, Any] | None = None,
    versions: Mapping[str, str] | None = None,
) -> dict[str, Any]:
    """Build a valid ``meta`` dict, filling in the package versions of the running interpreter."""
    meta: dict[str, Any] = {
        "problem": problem,
        "formulation": formulation,
        "obstacle_model": obstacle_model,
        "scenario": scenario,
        "seed": int(seed),
        "N": int(N),
        "dt": float(dt),
        "controller": controller,
        "versions": dict(package_versions() if versions is None else versions),
        "extra": dict(extra or {}),
    }
    if n_bound is not None:
        meta["n_bound"] = float(n_bound)
    return meta
