"""What ``fcgen verify`` found: one :class:`Check` per compared quantity and the :class:`VerifyReport` that holds them
(its table, its JSON)."""

from __future__ import annotations

import json
import math
from dataclasses import asdict, dataclass, field
from pathlib import Path

ENVELOPE_FACTOR = 2.0
"""A closed-loop difference passes within this factor of that envelope (the largest over ``ENVELOPE_EPS``)."""

_COUNTS = {"exit_code", "qp_status", "qp_iter", "plan_check", "cl_qp_iter", "cl_exit_code"}


def iterations_differ(c_iter: int, ref_iter: int, spread: float) -> bool:
    """A lockstep sample's QP iteration counts differ beyond ``ENVELOPE_FACTOR`` times how far the reference's own
    count moves under the envelope's rounding-level changes (``spread``; 0 where not measured: any difference)."""
    return abs(c_iter - ref_iter) > ENVELOPE_FACTOR * spread


@dataclass
class Check:
    """One compared quantity: the largest difference over the run, where it occurred, its tolerance."""

    key: str
    group: str
    description: str
    tol: float
    max_diff: float = 0.0
    sample: int = -1  # sample of the largest difference (-1: none / all zero)
    count: int = 0  # for mismatch counts: samples that differ
    compared: int = 0  # samples compared
    envelope: float = 0.0  # the reference's own difference under ENVELOPE_EPS (0: not measured)
    beyond: int = 0  # lockstep samples beyond their own allowance, max(tol, ENVELOPE_FACTOR x their envelope)

    @property
    def allowed(self) -> float:
        """The tolerance, or ENVELOPE_FACTOR times the reference's own rounding envelope where that is larger."""
        return max(self.tol, ENVELOPE_FACTOR * self.envelope)

    @property
    def passed(self) -> bool:
        return bool(self.max_diff <= self.allowed) and not self.beyond  # NaN fails

    def update(self, diff: float, sample: int, envelope: float = 0.0) -> None:
        """One lockstep sample's difference and (where measured) that sample's envelope: each sample is held to its
        own allowance, so one sample's envelope cannot excuse another's difference."""
        self.compared += 1
        if self.key in _COUNTS:
            if diff:
                self.count += 1
                if self.sample < 0:
                    self.sample = sample
            self.max_diff = float(self.count)
            return
        diff = math.inf if math.isnan(diff) else float(diff)
        self.envelope = max(self.envelope, envelope)
        self.beyond += int(diff > max(self.tol, ENVELOPE_FACTOR * envelope))
        if diff > self.max_diff:
            self.max_diff, self.sample = diff, sample


@dataclass
class VerifyReport:
    """Result of ``verify``: one ``Check`` per quantity."""

    solver: str
    gen_dir: str
    problem: str
    scenario: str
    seed: int
    samples: int
    checks: list[Check] = field(default_factory=list)
    notes: list[str] = field(default_factory=list)
    extra: dict = field(default_factory=dict)

    @property
    def passed(self) -> bool:
        return all(c.passed for c in self.checks)

    @property
    def failures(self) -> list[Check]:
        return [c for c in self.checks if not c.passed]

    def check(self, key: str) -> Check:
        for c in self.checks:
            if c.key == key:
                return c
        raise KeyError(key)

    def to_dict(self) -> dict:
        d = asdict(self)
        for c, cd in zip(self.checks, d["checks"], strict=True):
            cd["passed"], cd["allowed"] = c.passed, c.allowed
        d["passed"] = self.passed
        return d

    def to_json(self, path: Path | str) -> None:
        path = Path(path)
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(json.dumps(self.to_dict(), indent=1, sort_keys=True, default=float) + "\n")

    def format(self) -> str:
        head = (
            f"verify {self.solver} ({self.gen_dir}): {self.scenario} scenario, seed {self.seed}, "
            f"{self.samples} samples, C verification build vs Python reference"
        )
        rows = [("group", "quantity", "max rel. diff", "sample", "tolerance", "result")]
        for c in self.checks:
            if c.key == "cl_exit_code":
                diff = f"{c.count}"
            elif c.key in _COUNTS:
                diff = f"{c.count}/{c.compared}"
            else:
                diff = f"{c.max_diff:.3e}"
            tol = f"{c.tol:.0e}" if c.tol else "0"
            if c.allowed > c.tol:
                env = f"({ENVELOPE_FACTOR:g}x envelope)"
                tol = f"{c.allowed:.0f} {env}" if c.key in _COUNTS else f"{c.allowed:.1e} {env}"
            rows.append(
                (
                    c.group,
                    c.description,
                    diff,
                    str(c.sample) if c.sample >= 0 else "-",
                    tol,
                    "ok" if c.passed else (f"FAIL ({c.beyond} beyond)" if c.beyond and c.envelope else "FAIL"),
                )
            )
        w = [max(len(r[i]) for r in rows) for i in range(len(rows[0]))]
        lines = [head]
        for i, r in enumerate(rows):
            lines.append("  ".join(s.ljust(w[j]) if j < 2 else s.rjust(w[j]) for j, s in enumerate(r)).rstrip())
            if i == 0:
                lines.append("  ".join("-" * x for x in w))
        lines.append(
            "max rel. diff: max |C - Python| / max(1, max |Python|) over the run (infinite bounds matched "
            "exactly); n/m: samples that differ of those compared"
        )
        lines += [f"note: {n}" for n in self.notes]
        bad = self.failures
        lines.append(
            "PASS: all tolerances met"
            if not bad
            else f"FAIL: {len(bad)} tolerance(s) broken: " + ", ".join(f"{c.group}/{c.description}" for c in bad)
        )
        return "\n".join(lines)
