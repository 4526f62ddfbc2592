"""``fcgen regress``'s comparison of two run logs, field by field and sample by sample, under the tolerances."""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ..sim.runlog import STATE_FIELDS, RunLog
from .tolerances import ALL_FIELDS, TIMING_FIELDS, Tol, UnusableInput


@dataclass
class FieldResult:
    """One field of one log pair: the largest difference, the first sample out of tolerance, counts."""

    field: str
    tol: Tol
    rows: int  # samples compared
    bad_rows: int = 0  # samples with any element out of tolerance
    max_abs: float = 0.0
    max_at: tuple[int, tuple[int, ...]] | None = None  # (sample, index in the row) of max_abs
    first: dict[str, Any] | None = None  # first sample out of tolerance: sample, index, new, golden, diff, allowed
    ratio: np.ndarray | None = None  # per sample: max |diff| / allowed
    rel: np.ndarray | None = None  # per sample: max |diff| / scale (scale = component_scale, 1 where 0)
    bad: np.ndarray | None = None  # per sample: any element out of tolerance
    tol_rel: float = 0.0  # the tightest allowed |diff| / scale of the field (the plot's line)

    @property
    def passed(self) -> bool:
        return self.bad_rows == 0

    def first_out(self) -> dict[str, Any]:
        """``first`` of a field that has a sample out of tolerance."""
        if self.first is None:
            raise ValueError(f"{self.field}: no sample out of tolerance")
        return self.first

    def to_dict(self) -> dict[str, Any]:
        return {
            "field": self.field,
            "abs": _num(self.tol.abs),
            "rel": _num(self.tol.rel),
            "samples": self.rows,
            "samples_out_of_tolerance": self.bad_rows,
            "max_abs_diff": _num(self.max_abs),
            "max_at": None if self.max_at is None else {"sample": self.max_at[0], "index": list(self.max_at[1])},
            "first_divergence": self.first,
            "passed": self.passed,
        }


def _num(v: float) -> float | str:
    return v if math.isfinite(v) else ("inf" if v > 0 else ("-inf" if v < 0 else "nan"))


def component_scale(b: np.ndarray) -> np.ndarray:
    """``max |golden|`` of each component over the run (per last-axis index; one value for a scalar field)."""
    mag = np.where(np.isfinite(b), np.abs(b), 0.0)
    if b.ndim <= 1:
        return np.full_like(mag, np.max(mag, initial=0.0))
    return np.broadcast_to(np.max(mag, axis=tuple(range(b.ndim - 1)), keepdims=True, initial=0.0), b.shape)


def compare_field(name: str, new: np.ndarray, gold: np.ndarray, tol: Tol) -> FieldResult:
    """Compare one per-sample array (rows = samples) under ``tol``."""
    a = np.asarray(new, dtype=np.float64)
    b = np.asarray(gold, dtype=np.float64)
    res = FieldResult(name, tol, a.shape[0] if a.ndim else 0)
    if a.size == 0:
        res.ratio = res.rel = np.zeros(res.rows)
        res.bad = np.zeros(res.rows, dtype=bool)
        return res
    with np.errstate(invalid="ignore", over="ignore"):
        d = np.abs(a - b)
        same = (a == b) | (np.isnan(a) & np.isnan(b))
        d = np.where(same, 0.0, np.where(np.isnan(d), math.inf, d))
        scale = component_scale(b)
        allowed = tol.abs + tol.rel * scale
        bad = d > allowed
        ratio = np.where(d == 0, 0.0, np.divide(d, allowed, out=np.full_like(d, math.inf), where=allowed > 0))
        safe = np.where(scale > 0, scale, 1.0)
        rel = d / safe
    rows = a.shape[0]
    flat_d, flat_bad = d.reshape(rows, -1), bad.reshape(rows, -1)
    res.ratio = ratio.reshape(rows, -1).max(axis=1)
    res.rel = rel.reshape(rows, -1).max(axis=1)
    res.bad = np.asarray(flat_bad.any(axis=1), dtype=bool)
    res.tol_rel = float(np.min(allowed / safe))
    bad_rows = np.flatnonzero(flat_bad.any(axis=1))
    res.bad_rows = int(bad_rows.size)
    k = int(np.argmax(d))
    res.max_abs = float(d.flat[k])
    if res.max_abs > 0:
        idx = np.unravel_index(k, d.shape)
        res.max_at = (int(idx[0]), tuple(int(ix) for ix in idx[1:]))
    if bad_rows.size:
        j = int(bad_rows[0])
        e = int(np.flatnonzero(flat_bad[j])[0])
        at = tuple(int(i) for i in np.unravel_index(e, a.shape[1:])) if a.ndim > 1 else ()
        res.first = {
            "sample": j,
            "index": list(at),
            "new": _num(float(a[j][at])),
            "golden": _num(float(b[j][at])),
            "diff": _num(float(flat_d[j, e])),
            "allowed": _num(float(allowed[j][at])),
        }
    return res


@dataclass
class LogResult:
    """All compared fields of one log pair."""

    label: str
    scenario: str
    seed: int
    samples: int
    fields: list[FieldResult] = field(default_factory=list)
    skipped: list[str] = field(default_factory=list)  # fields only one of the two logs has

    @property
    def passed(self) -> bool:
        return all(f.passed for f in self.fields)

    def first_divergence(self) -> FieldResult | None:
        """The field that leaves its tolerance first (state row j before the control computed from it)."""
        bad = [f for f in self.fields if f.first is not None]
        if not bad:
            return None
        return min(bad, key=lambda f: (f.first_out()["sample"], 0 if f.field in STATE_FIELDS else 1))

    def to_dict(self) -> dict[str, Any]:
        fd = self.first_divergence()
        return {
            "label": self.label,
            "scenario": self.scenario,
            "seed": self.seed,
            "samples": self.samples,
            "passed": self.passed,
            "skipped_fields": self.skipped,
            "first_divergence": None if fd is None else {"field": fd.field, **fd.first_out()},
            "fields": [f.to_dict() for f in self.fields],
        }


def check_comparable(new: RunLog, gold: RunLog, where: str = "") -> None:
    """UnusableInput unless both logs are of the same problem, scenario and length."""
    pre = f"{where}: " if where else ""
    mn, mg = new.meta, gold.meta
    for key in ("problem", "formulation", "obstacle_model", "N", "dt"):
        if mn[key] != mg[key]:
            raise UnusableInput(f"{pre}another problem: meta.{key} is {mn[key]!r} in NEW, {mg[key]!r} in GOLDEN")
    for key in ("scenario", "seed"):
        if mn[key] != mg[key]:
            raise UnusableInput(f"{pre}another scenario: meta.{key} is {mn[key]!r} in NEW, {mg[key]!r} in GOLDEN")
    if new.n_controls != gold.n_controls:
        raise UnusableInput(f"{pre}another length: NEW has {new.n_controls} control samples, GOLDEN {gold.n_controls}")
    if len(new.opponents) != len(gold.opponents):
        raise UnusableInput(
            f"{pre}another problem: {len(new.opponents)} opponents in NEW, {len(gold.opponents)} in GOLDEN"
        )
    for name in ("plan_states", "plan_controls"):
        a, b = getattr(new, name), getattr(gold, name)
        if a is not None and b is not None and a.shape != b.shape:
            raise UnusableInput(f"{pre}another problem: {name} has shape {a.shape} in NEW, {b.shape} in GOLDEN")


def compare_logs(
    new: RunLog,
    gold: RunLog,
    tols: dict[str, Tol],
    fields: tuple[str, ...] = ALL_FIELDS,
    timing: bool = False,
    label: str | None = None,
) -> LogResult:
    """Compare the fields both logs carry (of ``fields``; timing fields only if ``timing``)."""
    check_comparable(new, gold, label or "")
    m = gold.meta
    res = LogResult(label or f"{m['scenario']} seed {m['seed']}", m["scenario"], m["seed"], gold.n_controls)
    have_new, have_gold = set(new.sample_fields()), set(gold.sample_fields())
    for name in fields:
        if name in TIMING_FIELDS and not timing:
            continue
        if name not in have_new or name not in have_gold:
            if name in have_new or name in have_gold:
                res.skipped.append(name)
            continue
        res.fields.append(compare_field(name, getattr(new, name), getattr(gold, name), tols[name]))
    return res
