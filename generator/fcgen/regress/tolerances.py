"""``fcgen regress``'s tolerances: the fields compared, ``Tol``, the named presets and the ``--tol`` overrides.

A value passes if ``|new - golden| <= abs + rel * scale`` with ``scale`` the largest ``|golden|`` of that component
over the run. Timing fields are compared only on request.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from ..sim.runlog import CONTROL_FIELDS, OPTIONAL_FIELDS, STATE_FIELDS

TIMING_FIELDS = ("time_prepare", "time_feedback", "time_total")
ALL_FIELDS = tuple(STATE_FIELDS) + tuple(CONTROL_FIELDS) + tuple(OPTIONAL_FIELDS)
#: fields a replay produces (its state fields are copies of the golden's)
REPLAY_FIELDS = tuple(CONTROL_FIELDS) + tuple(OPTIONAL_FIELDS)
_INT_FIELDS = tuple(
    n for n, (k, _) in {**STATE_FIELDS, **CONTROL_FIELDS, **OPTIONAL_FIELDS}.items() if k in ("int", "bool")
)


class UnusableInput(ValueError):
    """The inputs cannot be compared (not a run log, another format version, problem or length)."""


@dataclass(frozen=True)
class Tol:
    """Pass if ``|new - golden| <= abs + rel * scale`` (``scale``: ``component_scale`` of the golden values)."""

    abs: float
    rel: float

    def __str__(self) -> str:
        return f"{self.abs:g}, {self.rel:g}"


def _preset(float_tol: Tol, qp_iter: Tol, timing: Tol = Tol(1e-3, 1.0), **more: Tol) -> dict[str, Tol]:
    out = {f: float_tol for f in ALL_FIELDS if f not in _INT_FIELDS}
    out.update({f: Tol(0.0, 0.0) for f in _INT_FIELDS})
    out["qp_iter"] = qp_iter
    out.update({f: timing for f in TIMING_FIELDS})
    out.update(more)
    return out


#: Named tolerance sets. ``same-build``: the same compiled solver again (bit-exact up to ~1e-12). ``other-flags`` /
#: ``other-compiler``: another optimization level or compiler (rounding differences of ~1e-15 that OSQP's
#: iterations amplify; equal QP status and iterations). ``host-vs-target``: another FPU (e.g. fused multiply-add on
#: a Cortex-M): a QP may stop one iteration earlier or later. ``float-vs-double``: single vs double precision
#: (float OSQP's residuals reach only ~1e-4 relative), QP iterations and status free.
PRESETS: dict[str, dict[str, Tol]] = {
    "same-build": _preset(Tol(1e-12, 1e-12), Tol(0, 0)),
    "other-flags": _preset(Tol(1e-9, 1e-8), Tol(0, 0)),
    "other-compiler": _preset(Tol(1e-9, 1e-8), Tol(0, 0)),
    "host-vs-target": _preset(Tol(1e-6, 1e-5), Tol(2, 0.05), qp_status=Tol(0, 0)),
    "float-vs-double": _preset(
        Tol(5e-2, 5e-2), Tol(math.inf, 0), qp_status=Tol(math.inf, 0), max_slack=Tol(5e-2, 5e-2), collision=Tol(1, 0)
    ),
}
#: default preset per precision pair (either side float -> float-vs-double)
DEFAULT_PRESET = {("double", "double"): "other-compiler", ("float", "float"): "other-compiler"}


def default_preset(prec_new: str, prec_golden: str) -> str:
    return DEFAULT_PRESET.get((prec_new, prec_golden), "float-vs-double")


def parse_tol(spec: str) -> tuple[str, Tol]:
    """``"field=abs,rel"`` -> (field, Tol); UnusableInput naming the field list and the form otherwise."""
    name, sep, vals = spec.partition("=")
    name = name.strip()
    if not sep or name not in ALL_FIELDS:
        raise UnusableInput(
            f"--tol {spec!r} is invalid: allowed FIELD=ABS,REL with FIELD one of {', '.join(ALL_FIELDS)}"
        )
    try:
        a, r = (float(v) for v in vals.split(","))
    except ValueError:
        raise UnusableInput(f"--tol {spec!r} is invalid: allowed FIELD=ABS,REL with two numbers >= 0") from None
    if not (a >= 0 and r >= 0):
        raise UnusableInput(f"--tol {spec!r} is invalid: ABS and REL must be >= 0")
    return name, Tol(a, r)


def tolerances(preset: str | None, precisions: tuple[str, str], overrides: dict[str, Tol] | None) -> tuple[str, dict]:
    """The preset's name (``preset``, else the default for the two precisions) and its tolerances with ``overrides``."""
    name = preset or default_preset(*precisions)
    if name not in PRESETS:
        raise UnusableInput(f"--preset {name!r} is invalid: allowed {', '.join(PRESETS)}")
    tols = dict(PRESETS[name])
    tols.update(overrides or {})
    return name, tols
