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
"""
from __future__ import annotations

import json
import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from .sim.runlog import CONTROL_FIELDS, OPTIONAL_FIELDS, STATE_FIELDS, RunLog
from .suite import cc_version, is_suite, load_log, load_suite, solver_info

TIMING_FIELDS = ("time_prepare", "time_feedback", "time_total")
ALL_FIELDS = tuple(STATE_FIELDS) + tuple(CONTROL_FIELDS) + tuple(OPTIONAL_FIELDS)
#: fields a replay produces (its state fields are copies of the golden's)
REPLAY_FIELDS = tuple(CONTROL_FIELDS) + tuple(OPTIONAL_FIELDS)
_INT_FIELDS = tuple(n for n, (k, _) in {**STATE_FIELDS, **CONTROL_FIELDS, **OPTIONAL_FIELDS}.items()
                    if k in ("int", "bool"))
MODES = ("replay", "closed-loop")


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
    "float-vs-double": _preset(Tol(5e-2, 5e-2), Tol(math.inf, 0), qp_status=Tol(math.inf, 0),
                               max_slack=Tol(5e-2, 5e-2), collision=Tol(1, 0)),
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
        raise UnusableInput(f"--tol {spec!r} is invalid: allowed FIELD=ABS,REL with FIELD one of {', '.join(ALL_FIELDS)}")
    try:
        a, r = (float(v) for v in vals.split(","))
    except ValueError:
        raise UnusableInput(f"--tol {spec!r} is invalid: allowed FIELD=ABS,REL with two numbers >= 0") from None
    if not (a >= 0 and r >= 0):
        raise UnusableInput(f"--tol {spec!r} is invalid: ABS and REL must be >= 0")
    return name, Tol(a, r)


# ----------------------------------------------------------------------------- comparing two logs

@dataclass
class FieldResult:
    """One field of one log pair: the largest difference, the first sample out of tolerance, counts."""

    field: str
    tol: Tol
    rows: int                           # samples compared
    bad_rows: int = 0                   # samples with any element out of tolerance
    max_abs: float = 0.0
    max_at: tuple[int, tuple[int, ...]] | None = None   # (sample, index in the row) of max_abs
    first: dict[str, Any] | None = None  # first sample out of tolerance: sample, index, new, golden, diff, allowed
    ratio: np.ndarray | None = None     # per sample: max |diff| / allowed
    rel: np.ndarray | None = None       # per sample: max |diff| / scale (scale = component_scale, 1 where 0)
    bad: np.ndarray | None = None       # per sample: any element out of tolerance
    tol_rel: float = 0.0                # the tightest allowed |diff| / scale of the field (the plot's line)

    @property
    def passed(self) -> bool:
        return self.bad_rows == 0

    def to_dict(self) -> dict[str, Any]:
        return {"field": self.field, "abs": _num(self.tol.abs), "rel": _num(self.tol.rel), "samples": self.rows,
                "samples_out_of_tolerance": self.bad_rows, "max_abs_diff": _num(self.max_abs),
                "max_at": None if self.max_at is None else {"sample": self.max_at[0], "index": list(self.max_at[1])},
                "first_divergence": self.first, "passed": self.passed}


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
    res.bad = flat_bad.any(axis=1)
    res.tol_rel = float(np.min(allowed / safe))
    bad_rows = np.flatnonzero(flat_bad.any(axis=1))
    res.bad_rows = int(bad_rows.size)
    k = int(np.argmax(d))
    res.max_abs = float(d.flat[k])
    if res.max_abs > 0:
        idx = np.unravel_index(k, d.shape)
        res.max_at = (int(idx[0]), tuple(int(i) for i in idx[1:]))
    if bad_rows.size:
        j = int(bad_rows[0])
        e = int(np.flatnonzero(flat_bad[j])[0])
        idx = tuple(int(i) for i in np.unravel_index(e, a.shape[1:])) if a.ndim > 1 else ()
        res.first = {"sample": j, "index": list(idx), "new": _num(float(a[j][idx])),
                     "golden": _num(float(b[j][idx])), "diff": _num(float(flat_d[j, e])),
                     "allowed": _num(float(allowed[j][idx]))}
    return res


@dataclass
class LogResult:
    """All compared fields of one log pair."""

    label: str
    scenario: str
    seed: int
    samples: int
    fields: list[FieldResult] = field(default_factory=list)
    skipped: list[str] = field(default_factory=list)     # fields only one of the two logs has

    @property
    def passed(self) -> bool:
        return all(f.passed for f in self.fields)

    def first_divergence(self) -> FieldResult | None:
        """The field that leaves its tolerance first (state row j before the control computed from it)."""
        bad = [f for f in self.fields if f.first is not None]
        if not bad:
            return None
        return min(bad, key=lambda f: (f.first["sample"], 0 if f.field in STATE_FIELDS else 1))

    def to_dict(self) -> dict[str, Any]:
        fd = self.first_divergence()
        return {"label": self.label, "scenario": self.scenario, "seed": self.seed, "samples": self.samples,
                "passed": self.passed, "skipped_fields": self.skipped,
                "first_divergence": None if fd is None else {"field": fd.field, **fd.first},
                "fields": [f.to_dict() for f in self.fields]}


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
        raise UnusableInput(f"{pre}another length: NEW has {new.n_controls} control samples, GOLDEN "
                            f"{gold.n_controls}")
    if len(new.opponents) != len(gold.opponents):
        raise UnusableInput(f"{pre}another problem: {len(new.opponents)} opponents in NEW, {len(gold.opponents)} "
                            f"in GOLDEN")
    for name in ("plan_states", "plan_controls"):
        a, b = getattr(new, name), getattr(gold, name)
        if a is not None and b is not None and a.shape != b.shape:
            raise UnusableInput(f"{pre}another problem: {name} has shape {a.shape} in NEW, {b.shape} in GOLDEN")


def compare_logs(new: RunLog, gold: RunLog, tols: dict[str, Tol], fields: tuple[str, ...] = ALL_FIELDS,
                 timing: bool = False, label: str | None = None) -> LogResult:
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


# ----------------------------------------------------------------------------- the report

@dataclass
class RegressReport:
    """Result of ``regress``: one ``LogResult`` per compared log pair."""

    mode: str
    new: str
    golden: str
    preset: str
    tolerances: dict[str, Tol]
    timing: bool
    logs: list[LogResult] = field(default_factory=list)
    notes: list[str] = field(default_factory=list)

    @property
    def passed(self) -> bool:
        return all(lg.passed for lg in self.logs)

    @property
    def exit_code(self) -> int:
        return 0 if self.passed else 1

    def first_divergence(self) -> tuple[LogResult, FieldResult] | None:
        cands = [(lg, lg.first_divergence()) for lg in self.logs]
        cands = [(lg, f) for lg, f in cands if f is not None]
        return min(cands, key=lambda c: c[1].first["sample"]) if cands else None

    def field_names(self) -> list[str]:
        seen: dict[str, None] = {}
        for lg in self.logs:
            for f in lg.fields:
                seen.setdefault(f.field, None)
        return list(seen)

    def to_dict(self) -> dict[str, Any]:
        fd = self.first_divergence()
        return {"format": "fcgen-regress/1", "mode": self.mode, "new": self.new, "golden": self.golden,
                "preset": self.preset, "timing": self.timing, "passed": self.passed, "exit_code": self.exit_code,
                "logs_compared": len(self.logs), "logs_out_of_tolerance": sum(not lg.passed for lg in self.logs),
                "first_divergence": None if fd is None else {"log": fd[0].label, "field": fd[1].field, **fd[1].first},
                "notes": self.notes, "logs": [lg.to_dict() for lg in self.logs]}

    def to_json(self, path: Path | str) -> Path:
        path = Path(path)
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(json.dumps(self.to_dict(), indent=1, sort_keys=True) + "\n")
        return path

    def format(self) -> str:
        """The terminal report: verdict, first divergence, largest difference and counts per field, per log."""
        n_bad = sum(not lg.passed for lg in self.logs)
        lines = [f"regress {self.new} vs {self.golden}: {self.mode}, {len(self.logs)} log(s) x "
                 f"{self.logs[0].samples if self.logs else 0} samples, tolerances {self.preset!r}"
                 + (" (+ timing)" if self.timing else " (timing ignored)")]
        fd = self.first_divergence()
        if fd is not None:
            lg, f = fd
            x = f.first
            idx = "[" + ", ".join(map(str, x["index"])) + "]" if x["index"] else ""
            lines.append(f"first divergence: {lg.label}, sample {x['sample']}, field {f.field}{idx}: "
                         f"new {x['new']!r}, golden {x['golden']!r} (|diff| {_g(x['diff'])} > allowed "
                         f"{_g(x['allowed'])})")
        rows = [("field", "tol abs, rel", "max |diff|", "at (log, sample, index)", "samples out", "result")]
        for name in self.field_names():
            fr = [(lg, f) for lg in self.logs for f in lg.fields if f.field == name]
            worst = max(fr, key=lambda c: c[1].max_abs)
            at = "-"
            if worst[1].max_at is not None:
                s, i = worst[1].max_at
                at = f"{worst[0].label}, {s}" + (f", {list(i)}" if i else "")
            out = sum(f.bad_rows for _, f in fr)
            tot = sum(f.rows for _, f in fr)
            rows.append((name, str(fr[0][1].tol), _g(worst[1].max_abs), at, f"{out}/{tot}",
                         "ok" if out == 0 else "FAIL"))
        w = [max(len(r[i]) for r in rows) for i in range(len(rows[0]))]
        for i, r in enumerate(rows):
            lines.append("  " + "  ".join(s.ljust(w[j]) for j, s in enumerate(r)).rstrip())
            if i == 0:
                lines.append("  " + "  ".join("-" * x for x in w))
        if n_bad:
            lines.append("per log, first divergence:")
            for lg in self.logs:
                f = lg.first_divergence()
                if f is not None:
                    idx = f.first["index"]
                    lines.append(f"  {lg.label}: sample {f.first['sample']}, {f.field}"
                                 + (f"{idx}" if idx else ""))
        skipped = sorted({s for lg in self.logs for s in lg.skipped})
        if skipped:
            lines.append(f"note: only one side carries {', '.join(skipped)} (not compared)")
        lines += [f"note: {n}" for n in self.notes]
        lines.append(f"PASS: {len(self.logs)} log(s) within tolerance" if not n_bad else
                     f"FAIL: {n_bad} of {len(self.logs)} log(s) out of tolerance")
        return "\n".join(lines)

    def plot(self, path: Path | str) -> Path:
        """Divergence over time: per field and sample ``max |diff| / scale`` (log scale), one line per log; the
        dashed line is the field's tolerance, red dots mark samples out of tolerance."""
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt

        names = self.field_names()
        n = max(1, len(names))
        fig, axes = plt.subplots(n, 1, figsize=(9, 1.7 * n + 0.8), sharex=True, squeeze=False)
        for ax, name in zip(axes[:, 0], names):
            tol_line = 0.0
            for lg in self.logs:
                for f in lg.fields:
                    if f.field == name and f.rel is not None:
                        y = np.clip(np.nan_to_num(f.rel, nan=1e3, posinf=1e3), 1e-17, 1e3)
                        x = np.arange(len(y))
                        ax.semilogy(x, y, lw=0.9, label=lg.label)
                        if f.bad is not None and f.bad.any():
                            ax.plot(x[f.bad], y[f.bad], "r.", ms=3)
                        tol_line = f.tol_rel
            if 0 < tol_line < 1e3:
                ax.axhline(tol_line, color="k", ls="--", lw=0.8)
            ax.set_ylim(5e-18, 2e3)
            ax.set_ylabel(name, rotation=0, ha="right", fontsize=8)
        axes[0, 0].set_title(f"{self.mode}: |new - golden| / max |golden| per sample ({self.preset}; dashed: "
                             f"tolerance, red: out of tolerance)", fontsize=9)
        if len(self.logs) <= 10 and names:
            axes[0, 0].legend(fontsize=6, ncol=5, loc="upper left")
        axes[-1, 0].set_xlabel("sample")
        fig.tight_layout()
        path = Path(path)
        path.parent.mkdir(parents=True, exist_ok=True)
        fig.savefig(path, dpi=90)
        plt.close(fig)
        return path


def _g(v: Any) -> str:
    return f"{v:.3e}" if isinstance(v, float) else str(v)


# ----------------------------------------------------------------------------- inputs and the entry point

def _kind(path: Path) -> str:
    if path.is_dir():
        if any(path.glob("*_solver.h")):
            return "solver"
        if is_suite(path):
            return "suite"
        raise UnusableInput(f"{path}: neither a solver folder (no <name>_solver.h) nor a golden suite "
                            f"(no manifest.json)")
    if path.is_file():
        return "log"
    raise UnusableInput(f"{path}: no such file or folder")


def _unusable(fn, *args):
    try:
        return fn(*args)
    except UnusableInput:
        raise
    except (ValueError, FileNotFoundError) as exc:
        raise UnusableInput(str(exc).splitlines()[0]) from None


def _golden(path: Path) -> tuple[str, list[RunLog], dict[str, Any] | None]:
    """Precision, logs and manifest (None for a single log) of a GOLDEN argument."""
    if _kind(path) == "suite":
        man, logs = _unusable(load_suite, path)
        return man["precision"], logs, man
    if _kind(path) == "log":
        log = _unusable(load_log, path)
        return log.meta.get("precision", "double"), [log], None
    raise UnusableInput(f"{path}: GOLDEN must be a run log or a golden suite, not a solver folder")


def _tolerances(preset: str | None, precisions: tuple[str, str], overrides: dict[str, Tol] | None) -> tuple[str, dict]:
    name = preset or default_preset(*precisions)
    if name not in PRESETS:
        raise UnusableInput(f"--preset {name!r} is invalid: allowed {', '.join(PRESETS)}")
    tols = dict(PRESETS[name])
    tols.update(overrides or {})
    return name, tols


def regress(new: Path | str, golden: Path | str, mode: str | None = None, preset: str | None = None,
            tol: dict[str, Tol] | None = None, timing: bool = False, controller: str = "c",
            build_kw: dict | None = None, progress: bool = False) -> RegressReport:
    """Compare NEW (log, suite or solver folder) with GOLDEN (log or suite); see the module docstring.

    ``mode``: for a solver folder ``"replay"`` (default) or ``"closed-loop"``; ``controller``: ``"c"`` (the folder's
    compiled solver, ``build_kw`` passed to ``fcgen.build.build``; ``verify`` defaults to the golden suite's) or
    ``"python"`` (its Python reference).
    """
    new, golden = Path(new), Path(golden)
    kind_new = _kind(new)
    prec_gold, gold_logs, man = _golden(golden)
    if mode is not None and mode not in MODES:
        raise UnusableInput(f"--mode {mode!r} is invalid: allowed {', '.join(MODES)}")
    if kind_new != "solver" and mode is not None:
        raise UnusableInput(f"--mode {mode} needs NEW to be a solver folder; {new} is a {kind_new}")
    notes: list[str] = []
    if kind_new == "log":   # vs a log, or vs the suite's log of the same scenario and seed
        new_log = _unusable(load_log, new)
        key = (new_log.meta["scenario"], new_log.meta["seed"])
        match = [g for g in gold_logs if (g.meta["scenario"], g.meta["seed"]) == key] if man else gold_logs
        if not match:
            raise UnusableInput(f"{golden}: the suite has no log of {key[0]} seed {key[1]} (the scenario of {new})")
        name, tols = _tolerances(preset, (new_log.meta.get("precision", "double"), prec_gold), tol)
        rep = RegressReport("log vs log", str(new), str(golden), name, tols, timing)
        rep.logs.append(compare_logs(new_log, match[0], tols, timing=timing))
        return rep
    if kind_new == "suite":
        if man is None:
            raise UnusableInput(f"{new} is a suite but {golden} is a run log")
        man_new, new_logs = _unusable(load_suite, new)
        name, tols = _tolerances(preset, (man_new["precision"], prec_gold), tol)
        rep = RegressReport("suite vs suite", str(new), str(golden), name, tols, timing,
                            notes=_record_notes(man_new["problem"], man["problem"], "NEW's suite"))
        by_key = {(lg.meta["scenario"], lg.meta["seed"]): lg for lg in new_logs}
        for g in gold_logs:
            key = (g.meta["scenario"], g.meta["seed"])
            if key not in by_key:
                raise UnusableInput(f"{new}: has no log of {key[0]} seed {key[1]} (in {golden})")
            rep.logs.append(compare_logs(by_key[key], g, tols, timing=timing))
        return rep
    # a solver folder: replay or closed loop
    mode = mode or "replay"
    info = _unusable(solver_info, new)
    prec_new = info["precision"] if controller == "c" else "double"
    name, tols = _tolerances(preset, (prec_new, prec_gold), tol)
    if man is not None:
        _check_problem(info, man, new, golden)
        notes += _record_notes(info["problem"], man["problem"], "the solver")
    rep = RegressReport(mode, str(new), str(golden), name, tols, timing, notes=notes)
    build_kw = dict(build_kw or {})
    if build_kw.get("verify") is None:   # by default the kind of build the golden suite was recorded with
        build_kw["verify"] = bool(man is not None and man.get("build", {}).get("verify"))
    runner = _Runner(new, controller, build_kw, progress)
    runner.golden_dir = golden if golden.is_dir() else golden.parent   # where a CommonRoad log's scenario file is
    if runner.lib is not None:
        stamp = runner.lib.parent / "flags.txt"
        notes.append(f"NEW built with: {stamp.read_text().strip() if stamp.is_file() else 'unknown flags'} "
                     f"({cc_version(build_kw.get('cc'))})")
    else:
        notes.append("NEW: the Python reference of the folder's problem.py")
    if man is not None:
        notes.append(f"GOLDEN built with: {man.get('build', {}).get('compile_line', 'unknown')} "
                     f"({man.get('build', {}).get('cc_version', 'unknown compiler')}, {man['precision']})")
    for g in gold_logs:
        label = f"{g.meta['scenario']} seed {g.meta['seed']}"
        if g.meta["problem"] != info["name"]:
            raise UnusableInput(f"{label}: another problem: GOLDEN was recorded by {g.meta['problem']!r}, NEW is "
                                f"{info['name']!r}")
        out = runner.run(g, mode)
        fields = REPLAY_FIELDS if mode == "replay" else ALL_FIELDS
        rep.logs.append(compare_logs(out, g, tols, fields=fields, timing=timing, label=label))
    return rep


def _record_notes(a: dict[str, Any], b: dict[str, Any], who: str) -> list[str]:
    """Notes where NEW's problem record (``a``) and GOLDEN's (``b``) differ in what may legitimately change between
    two versions (the problem.py source, the QP's sizes)."""
    notes = []
    if a.get("problem_py_sha256") != b.get("problem_py_sha256"):
        notes.append(f"{who}'s problem.py differs from the one the golden suite was recorded with (sha256 "
                     f"{str(a.get('problem_py_sha256'))[:12]} vs {str(b.get('problem_py_sha256'))[:12]})")
    sa, sb = a.get("sizes", {}), b.get("sizes", {})
    diff = [k for k in sorted(set(sa) | set(sb)) if sa.get(k) != sb.get(k)]
    if diff:
        notes.append(f"{who}'s sizes differ from the golden suite's: "
                     + ", ".join(f"{k} {sa.get(k)} vs {sb.get(k)}" for k in diff))
    return notes


def _check_problem(info: dict[str, Any], man: dict[str, Any], new: Path, golden: Path) -> None:
    if info["name"] != man["solver"]:
        raise UnusableInput(f"another problem: {new} is solver {info['name']!r}, {golden} was recorded by "
                            f"{man['solver']!r}")
    a, b = info["problem"], man["problem"]
    for key in ("formulation", "obstacle_model", "N", "dt"):
        if a[key] != b.get(key):
            raise UnusableInput(f"another problem: {key} is {a[key]!r} in {new}, {b.get(key)!r} in {golden}")
    sa, sb = a["sizes"], b.get("sizes", {})
    diff = [k for k in ("N", "NX", "NU", "NOPP", "NOPP_PAR") if k in sa and k in sb and sa[k] != sb[k]]
    if diff:
        raise UnusableInput(f"another problem: sizes {', '.join(f'{k} {sa[k]} vs {sb[k]}' for k in diff)} "
                            f"({new} vs {golden})")


class _Runner:
    """Builds the new solver once and runs it (replay or closed loop) on each golden log."""

    golden_dir: Path = Path(".")

    def _commonroad(self, gold: RunLog, mode: str) -> RunLog:
        """A CommonRoad log: its scenario file (beside the golden log, by name and sha256) run again, in replay on
        the logged states."""
        import hashlib

        from .campaign.commonroad import load_for
        from .sim.commonroad_run import run_commonroad
        from .sim.replay import plan_level
        cr = gold.meta["extra"]["commonroad"]
        path = self.golden_dir / cr.get("file", "")
        if not path.is_file() or hashlib.sha256(path.read_bytes()).hexdigest() != cr.get("sha256"):
            raise ValueError(f"{path}: the CommonRoad scenario of the golden log ({cr.get('scenario')}, sha256 "
                             f"{str(cr.get('sha256'))[:12]}) is not there or differs")
        sc = load_for(self.problem, path, cr.get("planning_problem"))
        states = np.asarray(gold.ego_frenet) if mode == "replay" else None
        return run_commonroad(self.problem, sc, controller=self.make(), ocp=self.ocp, plan=plan_level(gold),
                              progress=self.progress, states=states).log

    def __init__(self, gen_dir: Path, controller: str, build_kw: dict, progress: bool):
        from .ocp import build_ocp
        from .verify import load_solver_problem

        if controller not in ("c", "python"):
            raise UnusableInput(f"--controller {controller!r} is invalid: allowed c, python")
        _, self.problem = _unusable(load_solver_problem, gen_dir)
        self.ocp = build_ocp(self.problem)
        self.controller, self.progress = controller, progress
        self.lib = None
        if controller == "c":
            from .build import build
            self.lib = build(gen_dir, **build_kw)

    def make(self):
        if self.lib is not None:
            from .build import CSolver
            return CSolver(self.lib)   # init(): a fresh workspace per log
        from .sim.closedloop import ReferenceController
        return ReferenceController(self.ocp)

    def run(self, gold: RunLog, mode: str) -> RunLog:
        from .sim.closedloop import run_closed_loop
        from .sim.replay import plan_level, replay, scenario_of

        if "commonroad" in gold.meta.get("extra", {}):
            return _unusable(self._commonroad, gold, mode)
        if mode == "replay":
            return _unusable(replay, self.problem, gold, self.make(), None, self.progress)
        sc = _unusable(scenario_of, gold, self.problem)
        return _unusable(lambda: run_closed_loop(self.problem, sc, controller=self.make(), ocp=self.ocp,
                                                 progress=self.progress, exit_codes=gold.exit_code is not None,
                                                 plan=plan_level(gold)))
