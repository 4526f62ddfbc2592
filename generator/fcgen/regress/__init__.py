"""Regression comparison of run logs (``fcgen regress``): tolerances, the sample-by-sample comparison, the report.

``regress(new, golden)`` takes run-log files, golden suites (``fcgen.suite``) or a solver folder as ``new``:

* log vs log, suite vs suite, log vs suite (its log of the same scenario and seed, e.g. a target's
  ``firmware-sim`` log vs a host suite): the logs are compared field by field;
* solver folder vs suite (or log), **replay** mode (default): the new solver gets the golden logs' inputs
  (``fcgen.sim.replay``) and its outputs are compared with the golden outputs;
* solver folder vs suite (or log), **closed-loop** mode: every scenario is run again with the new solver.

A value passes if ``|new - golden| <= abs + rel * scale`` with ``scale`` the largest ``|golden|`` of that component
over the run (e.g. of the steering rate over all samples and stages; NaN equals only NaN). Tolerances come from a named
preset (``PRESETS``; by default the one for the two precisions), overridable per field. Timing fields are compared
only on request. Unusable input raises ``UnusableInput`` (one-line message; the CLI's exit code 2).

One job per module: ``tolerances`` (fields, presets, ``--tol``), ``compare`` (two logs), ``report`` (text, JSON,
plot), ``run`` (what NEW and GOLDEN are, the solver folder built and replayed or run again).
"""

from .compare import FieldResult, LogResult, check_comparable, compare_field, compare_logs, component_scale
from .report import RegressReport
from .run import MODES, regress
from .tolerances import (
    ALL_FIELDS,
    DEFAULT_PRESET,
    PRESETS,
    REPLAY_FIELDS,
    TIMING_FIELDS,
    Tol,
    UnusableInput,
    default_preset,
    parse_tol,
    tolerances,
)

__all__ = [
    "ALL_FIELDS",
    "DEFAULT_PRESET",
    "MODES",
    "PRESETS",
    "REPLAY_FIELDS",
    "TIMING_FIELDS",
    "FieldResult",
    "LogResult",
    "RegressReport",
    "Tol",
    "UnusableInput",
    "check_comparable",
    "compare_field",
    "compare_logs",
    "component_scale",
    "default_preset",
    "parse_tol",
    "regress",
    "tolerances",
]
