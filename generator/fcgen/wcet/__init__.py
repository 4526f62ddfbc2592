"""``fcgen wcet``: an upper bound on the instructions of prepare, feedback and one RTI of a solver build on an
emulated Cortex-M, from the solver's caps and the worst observed path of each phase (docs/wcet.md).

``probe`` reads the probe harness's side file, ``bound`` does the arithmetic, ``run`` runs QEMU, ``table`` prints.
"""

from .bound import BoundError, Caps, compute_bound, exceedances, ipm_feedback, osqp_feedback, phase_stats
from .probe import ProbeError, read_probe
from .run import FORMAT, WcetError, wcet
from .table import format_wcet

__all__ = [
    "FORMAT",
    "BoundError",
    "Caps",
    "ProbeError",
    "WcetError",
    "compute_bound",
    "exceedances",
    "format_wcet",
    "ipm_feedback",
    "osqp_feedback",
    "phase_stats",
    "read_probe",
    "wcet",
]
