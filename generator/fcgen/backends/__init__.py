"""QP backends behind one interface: the RTI core never names a backend.

A backend is one module here (``<b>.py``: its Python solver, which the reference runs, its label and the restore of
its git-ignored library for ``fcgen build``), its C side in ``fcgen.codegen`` (``codegen.qp_backend``: the context of
its template and its extra files) and one template ``templates/backends/<b>.c.j2`` (the static ``qpb_*`` functions
``solver.c.j2`` includes once).
"""

from __future__ import annotations

import importlib
from dataclasses import dataclass
from typing import TYPE_CHECKING, Protocol

import numpy as np

from ..dsl import BACKENDS  # the names QpOptions.backend accepts; each is a module of this package

if TYPE_CHECKING:  # pragma: no cover
    from ..dsl import QpOptions
    from ..qp import QpLayout

QP_STATUSES = (
    "QP_SOLVED",
    "QP_SOLVED_INACCURATE",
    "QP_MAX_ITER",
    "QP_PRIMAL_INFEASIBLE",
    "QP_DUAL_INFEASIBLE",
    "QP_NONCONVEX",
    "QP_NONFINITE",
    "QP_NUMERICAL",
    "QP_OTHER",
)
"""Generic QP status, values 1..9 in this order (0: no QP solved yet); C: ``<NAME>_QP_SOLVED``, ...
QP_NUMERICAL: ill-conditioned / factorization failed; QP_NONFINITE: a non-finite step."""

QP_NONE = 0
(
    QP_SOLVED,
    QP_SOLVED_INACCURATE,
    QP_MAX_ITER,
    QP_PRIMAL_INFEASIBLE,
    QP_DUAL_INFEASIBLE,
    QP_NONCONVEX,
    QP_NONFINITE,
    QP_NUMERICAL,
    QP_OTHER,
) = range(1, len(QP_STATUSES) + 1)

QP_USABLE = (QP_SOLVED, QP_SOLVED_INACCURATE, QP_MAX_ITER)
"""Statuses whose step may be taken (with a finite step only)."""


def qp_status_name(status: int) -> str:
    """``"QP_SOLVED"``, ... for a generic status value; ``"QP_NONE"`` for 0, ``"unknown_<v>"`` otherwise."""
    status = int(status)
    if status == QP_NONE:
        return "QP_NONE"
    return QP_STATUSES[status - 1] if 1 <= status <= len(QP_STATUSES) else f"unknown_{status}"


@dataclass
class QpResult:
    """What one QP solve produced."""

    status: int  # generic QP_* value
    raw_status: int  # the backend's own status value
    iter: int
    z: np.ndarray | None  # primal step in the layout's scaled variables (w_new = w + D z)
    y: np.ndarray | None  # row multipliers, OSQP's sign convention (y > 0 at an active upper bound)


@dataclass(frozen=True)
class BackendLibrary:
    """A backend's problem-independent static library ``lib<name>_<suffix>.a`` (of ``BackendFiles.library_sources``)."""

    suffix: str  # lib<name>_<suffix>.a; CMake target <name>_<suffix>
    label: str  # how the build files and README name it ("OSQP")
    opt_var: str  # make variable of the extra flags of its sources (CMake: <NAME>_<opt_var>)
    opt_flags: str  # their default
    opt_reason: str  # why they get their own flags
    sources_note: str  # README: its sources' flags and where the git-ignored ones come from
    symbols_note: str  # README: how its symbols carry the solver's prefix
    cflags: tuple[str, ...] = ()  # fixed flags of its sources alone, after opt_var's (the precision's, not tuning)
    cflags_reason: str = ""  # why (a build-file comment)


@dataclass(frozen=True)
class BackendFiles:
    """The extra files a generated folder needs for a backend (paths relative to the folder)."""

    sources: tuple[str, ...]  # problem-specific sources (committed)
    headers: tuple[str, ...]
    library_sources: tuple[str, ...]  # problem-independent library (git-ignored, restorable)
    library_headers: tuple[str, ...]
    include_dirs: tuple[str, ...]  # for every file using the solver
    private_include_dirs: tuple[str, ...]  # additionally, for the backend's own sources
    cflags: tuple[str, ...]  # extra flags for the backend's own sources
    link_libs: tuple[str, ...]
    array_bytes: int  # RAM of the backend's arrays (LP64)
    struct_bytes: int  # RAM of the backend's structs (LP64)
    memory_note: str = ""  # README: what of the backend's data is const (flash)
    memory_init_note: str = ""  # README: where its initial values come from ("; ..." or "")
    reset_note: str = ""  # README: how its workspace is restored by init/reset
    precision_note: str = ""  # README: what a float build changes in its settings ("": nothing)
    library: BackendLibrary | None = None  # its own static library (None: all in lib<name>.a)


class QpBackend(Protocol):
    """One QP solver behind the RTI core. Scaling/factorization depend only on the current ``set_matrices`` data."""

    name: str

    def __init__(self, layout: QpLayout, opts: QpOptions) -> None: ...

    def reset(self) -> None:
        """Bitwise the state of a freshly constructed backend."""

    def set_matrices(self, P_x: np.ndarray, A_x: np.ndarray, q: np.ndarray) -> None:
        """Prepare phase (``q``: this sample's q, before the s0 correction)."""

    def solve(self, q: np.ndarray, l: np.ndarray, u: np.ndarray, y_warm: np.ndarray, max_iter: int) -> QpResult:
        """Feedback phase: solve with the primal warm start 0 and the dual warm start ``y_warm``."""


def backend_module(name: str):
    """The module of a backend (``fcgen.backends.<name>``)."""
    if name not in BACKENDS:
        raise ValueError(f"qp.backend: {name!r} is not a QP backend; allowed: {', '.join(BACKENDS)}")
    return importlib.import_module(f"{__name__}.{name}")


def make_backend(layout: QpLayout, opts: QpOptions) -> QpBackend:
    """The backend ``opts.backend`` names, set up for ``layout``."""
    return backend_module(opts.backend).Backend(layout, opts)
