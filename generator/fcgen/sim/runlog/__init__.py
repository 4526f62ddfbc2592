"""The versioned JSON run log of one closed-loop run (format ``fcgen-runlog/1``, documented in docs/runlog.md).

Users regression-compare run logs in CI (C controller vs Python reference, or against a stored
baseline), so the file format is stable, strictly validated on read and written deterministically:
sorted keys, fixed layout, floats written with ``repr`` (shortest round-tripping decimal), so a
write/read round trip reproduces every float bit for bit.

Sample timing (SPEC section 1): states are logged at ``t_0 .. t_K`` (``K + 1`` *state samples*),
controls ``u_0 .. u_{K-1}`` (``K`` *control samples*); ``u_k`` is applied during ``[t_k, t_k + dt)``
and the solver statistics of sample ``k`` belong to the solve that produced ``u_k``.

The parts: ``schema`` (version, keys, fields, ``make_meta``), ``jsontext`` (the deterministic JSON text),
``log`` (``RunLog``), ``stats`` (``summary``, ``compare``); ``from fcgen.sim.runlog import X`` is the way to use them.
"""

from __future__ import annotations

from .jsontext import read_text
from .log import RunLog
from .schema import (
    CONTROL_FIELDS,
    CONTROLLER_KINDS,
    DIM_KEYS,
    FORMAT_VERSION,
    META_KEYS,
    OPTIONAL_FIELDS,
    QP_STATUS_NAMES,
    ROAD_ARRAY_KEYS,
    STATE_FIELDS,
    make_meta,
    package_versions,
    qp_status_name,
)
from .stats import compare, fmt_slack, summary

__all__ = [
    "CONTROLLER_KINDS",
    "CONTROL_FIELDS",
    "DIM_KEYS",
    "FORMAT_VERSION",
    "META_KEYS",
    "OPTIONAL_FIELDS",
    "QP_STATUS_NAMES",
    "ROAD_ARRAY_KEYS",
    "STATE_FIELDS",
    "RunLog",
    "compare",
    "fmt_slack",
    "make_meta",
    "package_versions",
    "qp_status_name",
    "read_text",
    "summary",
]
