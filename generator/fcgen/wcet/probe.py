"""The probe harness's side file (``RUN_LOG.probe``, written by ``firmware_sim/closed_loop.c`` with ``-DFS_PROBE``)
read into the instructions of each phase of each sample.

Events (the harness's and the solver's ``QPB_PROBE``): 10/11 prepare called/returned, 12/13 feedback called/returned,
0 QP start, 1 check, 2 step, 3 QP end, 4 the conventional fit's scan starts, 5 one sample of that scan done. The
intervals between consecutive events are the phases (``PHASES``); a pair of events outside that table is an error
(the solver or the harness changed without this reader).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

FORMAT = "fcgen-probe/1"
PREPARE, PREPARED, FEEDBACK, FED = 10, 11, 12, 13
START, CHECK, STEP, END, SCAN, SCAN_STEP = 0, 1, 2, 3, 4, 5

PHASES: dict[tuple[int, int], str] = {
    (FEEDBACK, START): "head",  # feedback called -> the QP's iterates initialized (embedding, warm start)
    (START, CHECK): "check",  # an iterate's residuals and stopping test
    (STEP, CHECK): "check",
    (CHECK, STEP): "step",  # one predictor-corrector step
    (CHECK, END): "qp_tail",  # the result composed (after the last check, or a failed step)
    (STEP, END): "qp_tail",
    (START, END): "qp",  # a backend probed at start and end only (OSQP): the whole solve
    (END, FED): "feedback_tail",  # the step taken or the fallback, the control, the plan check
    (FEEDBACK, FED): "feedback_no_qp",  # a feedback rejected before its QP
    (SCAN, SCAN_STEP): "fit_scan_step",  # one sample of the conventional fit's nearest-sample scan
    (SCAN_STEP, SCAN_STEP): "fit_scan_step",
}
"""(event, next event) -> phase name, inside feedback and inside prepare (the fit's scan steps)."""
_IN_PREPARE = {SCAN, SCAN_STEP}
_IN_FEEDBACK = {START, CHECK, STEP, END}


class ProbeError(RuntimeError):
    """A probe file that is not what the harness writes (format, truncation, an unexpected event order)."""


@dataclass(frozen=True)
class SampleProbe:
    """One sample's instructions: prepare and feedback as called, and each phase instance in order."""

    sample: int
    reset: bool  # the harness reset the solver before it (a cold start)
    prepare: int | None  # None: not called (an earlier call was rejected)
    feedback: int | None
    prepare_rest: int | None  # prepare without the fit's scan steps
    phases: dict[str, list[int]] = field(default_factory=dict)

    @property
    def steps(self) -> int:
        """QP steps (IPM iterations) probed in this sample."""
        return len(self.phases.get("step", []))


def _phases(j: int, events: list[tuple[int, int]], per_tick: int) -> SampleProbe:
    """The phases of one sample from its (event, tick) list."""

    def dt(a: int, b: int) -> int:
        return ((events[b][1] - events[a][1]) % 2**32) * per_tick

    marks = {e: i for i, (e, _) in enumerate(events) if e in (PREPARE, PREPARED, FEEDBACK, FED)}
    phases: dict[str, list[int]] = {}
    for i in range(len(events) - 1):
        a, b = events[i][0], events[i + 1][0]
        inside_prepare = a in _IN_PREPARE or b in _IN_PREPARE
        if (a, b) in ((PREPARE, PREPARED), (PREPARED, FEEDBACK)) or (inside_prepare and (a, b) not in PHASES):
            continue  # prepare's own intervals (total: below), harness time between the calls, the fit's other work
        name = PHASES.get((a, b))
        if name is None:
            raise ProbeError(f"sample {j}: event {b} after {a} is not a phase this reader knows")
        phases.setdefault(name, []).append(dt(i, i + 1))
    for i, (e, _) in enumerate(events):
        if e in _IN_FEEDBACK and not (marks.get(FEEDBACK, len(events)) < i < marks.get(FED, -1)):
            raise ProbeError(f"sample {j}: QP event {e} outside feedback")
    prepare = dt(marks[PREPARE], marks[PREPARED]) if PREPARE in marks and PREPARED in marks else None
    feedback = dt(marks[FEEDBACK], marks[FED]) if FEEDBACK in marks and FED in marks else None
    rest = None if prepare is None else prepare - sum(phases.get("fit_scan_step", []))
    return SampleProbe(j, False, prepare, feedback, rest, phases)


def read_probe(path: str | Path, instructions_per_second: float = 1e9) -> list[SampleProbe]:
    """Every sample of a probe file; tick counts become instructions (``-icount shift=0``: one per ns)."""
    lines = Path(path).read_text().splitlines()
    head = lines[0].split() if lines else []
    if len(head) != 3 or head[0] != FORMAT:
        raise ProbeError(f"{path}: not a probe file of format {FORMAT}")
    hz = int(head[1])
    per_tick = instructions_per_second / hz
    if per_tick != int(per_tick):
        raise ProbeError(f"{path}: {hz} ticks a second is not a whole number of instructions a tick")
    out = []
    for n, line in enumerate(lines[1:], start=2):
        tok = line.split()
        if len(tok) < 4 or tok[0] != "s" or len(tok) != 4 + 2 * int(tok[3]):
            raise ProbeError(f"{path}:{n}: a truncated or malformed sample line")
        ints = [int(t) for t in tok[4:]]
        events = list(zip(ints[0::2], ints[1::2]))
        sp = _phases(int(tok[1]), events, int(per_tick))
        out.append(SampleProbe(sp.sample, tok[2] == "1", sp.prepare, sp.feedback, sp.prepare_rest, sp.phases))
    return out


def tick_instructions(path: str | Path, instructions_per_second: float = 1e9) -> int:
    """Instructions per tick of a probe file (its granularity)."""
    head = Path(path).read_text().split("\n", 1)[0].split()
    return int(instructions_per_second / int(head[1]))
