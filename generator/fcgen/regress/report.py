"""``fcgen regress``'s report: the verdict, the first divergence and the largest differences as text, JSON and a
plot of the divergence over time."""

from __future__ import annotations

import json
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from ..extras import require
from .compare import FieldResult, LogResult
from .tolerances import Tol


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
        cands = [(lg, f) for lg in self.logs if (f := lg.first_divergence()) is not None]
        return min(cands, key=lambda c: c[1].first_out()["sample"]) if cands else None

    def field_names(self) -> list[str]:
        seen: dict[str, None] = {}
        for lg in self.logs:
            for f in lg.fields:
                seen.setdefault(f.field, None)
        return list(seen)

    def to_dict(self) -> dict[str, Any]:
        fd = self.first_divergence()
        return {
            "format": "fcgen-regress/1",
            "mode": self.mode,
            "new": self.new,
            "golden": self.golden,
            "preset": self.preset,
            "timing": self.timing,
            "passed": self.passed,
            "exit_code": self.exit_code,
            "logs_compared": len(self.logs),
            "logs_out_of_tolerance": sum(not lg.passed for lg in self.logs),
            "first_divergence": None if fd is None else {"log": fd[0].label, "field": fd[1].field, **fd[1].first_out()},
            "notes": self.notes,
            "logs": [lg.to_dict() for lg in self.logs],
        }

    def to_json(self, path: Path | str) -> Path:
        path = Path(path)
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(json.dumps(self.to_dict(), indent=1, sort_keys=True) + "\n")
        return path

    def format(self) -> str:
        """The terminal report: verdict, first divergence, largest difference and counts per field, per log."""
        n_bad = sum(not lg.passed for lg in self.logs)
        lines = [
            f"regress {self.new} vs {self.golden}: {self.mode}, {len(self.logs)} log(s) x "
            f"{self.logs[0].samples if self.logs else 0} samples, tolerances {self.preset!r}"
            + (" (+ timing)" if self.timing else " (timing ignored)")
        ]
        fd = self.first_divergence()
        if fd is not None:
            lg, f = fd
            x = f.first_out()
            idx = "[" + ", ".join(map(str, x["index"])) + "]" if x["index"] else ""
            lines.append(
                f"first divergence: {lg.label}, sample {x['sample']}, field {f.field}{idx}: "
                f"new {x['new']!r}, golden {x['golden']!r} (|diff| {_g(x['diff'])} > allowed "
                f"{_g(x['allowed'])})"
            )
        rows = [("field", "tol abs, rel", "max |diff|", "at (log, sample, index)", "samples out", "result")]
        for name in self.field_names():
            fr = [(lg, f) for lg in self.logs for f in lg.fields if f.field == name]
            worst = max(fr, key=lambda c: c[1].max_abs)
            at = "-"
            if worst[1].max_at is not None:
                s, at_index = worst[1].max_at
                at = f"{worst[0].label}, {s}" + (f", {list(at_index)}" if at_index else "")
            out = sum(f.bad_rows for _, f in fr)
            tot = sum(f.rows for _, f in fr)
            rows.append(
                (name, str(fr[0][1].tol), _g(worst[1].max_abs), at, f"{out}/{tot}", "ok" if out == 0 else "FAIL")
            )
        w = [max(len(r[i]) for r in rows) for i in range(len(rows[0]))]
        for i, r in enumerate(rows):
            lines.append("  " + "  ".join(s.ljust(w[j]) for j, s in enumerate(r)).rstrip())
            if i == 0:
                lines.append("  " + "  ".join("-" * x for x in w))
        if n_bad:
            lines.append("per log, first divergence:")
            for lg in self.logs:
                lf = lg.first_divergence()
                if lf is not None:
                    x = lf.first_out()
                    idx = x["index"]
                    lines.append(f"  {lg.label}: sample {x['sample']}, {lf.field}" + (f"{idx}" if idx else ""))
        skipped = sorted({s for lg in self.logs for s in lg.skipped})
        if skipped:
            lines.append(f"note: only one side carries {', '.join(skipped)} (not compared)")
        lines += [f"note: {n}" for n in self.notes]
        lines.append(
            f"PASS: {len(self.logs)} log(s) within tolerance"
            if not n_bad
            else f"FAIL: {n_bad} of {len(self.logs)} log(s) out of tolerance"
        )
        return "\n".join(lines)

    def plot(self, path: Path | str) -> Path:
        """Divergence over time: per field and sample ``max |diff| / scale`` (log scale), one line per log; the
        dashed line is the field's tolerance, red dots mark samples out of tolerance."""
        with require("plot", "fcgen regress --plot"):
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
        axes[0, 0].set_title(
            f"{self.mode}: |new - golden| / max |golden| per sample ({self.preset}; dashed: "
            f"tolerance, red: out of tolerance)",
            fontsize=9,
        )
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
