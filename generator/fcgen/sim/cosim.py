"""The C harness against a plant on the host: CommonRoad's vehicle models are Python, so the host steps the plant
and the harness runs the solver and the perturbations as an ECU would, the two in lockstep over a pipe.

The harness reads the scenario records from its stdin (``ScenarioWriter``) and answers each sample with the control
the plant gets, one line ``u J F_D R`` on its stdout; the host steps the plant with it and writes the next sample's
record with the plant's state (``plant_state``: x, the plant's a_lat and cut flags of the sample). Numbers cross
the pipe as ``%.17g`` text, so both sides see the same doubles.
"""

from __future__ import annotations

import subprocess
from os import PathLike
from pathlib import Path

from ..dsl import Problem
from .export import ScenarioWriter, harness_plant
from .plants import PlantSpec
from .runlog import RunLog
from .scenario import Scenario


class CosimError(RuntimeError):
    """The harness stopped or answered out of turn; the message holds its output."""


def _control(proc: subprocess.Popen, j: int) -> tuple[float, float]:
    """The harness's control of sample j (its line ``u j F_D R``)."""
    assert proc.stdout is not None
    line = proc.stdout.readline()
    parts = line.split()
    if len(parts) != 4 or parts[0] != "u" or parts[1] != str(j):
        raise CosimError(f"sample {j}: expected the line 'u {j} F_D R' from the harness, got {line.strip()!r}")
    return float(parts[2]), float(parts[3])


def run_cosim(
    exe: str | PathLike[str],
    problem: Problem,
    scenario: Scenario,
    spec: PlantSpec,
    out: str | PathLike[str],
    solver_name: str | None = None,
    timeout: float | None = None,
) -> RunLog:
    """Run the host harness ``exe`` for ``scenario.samples`` samples against ``spec``'s CommonRoad plant stepped
    here; returns the run log it wrote to ``out``."""
    from .plants.commonroad_vm import CommonRoadPlant

    K = scenario.samples
    w = ScenarioWriter(problem, scenario, K, solver_name, harness_plant(problem, spec, external=True))
    plant = CommonRoadPlant(problem, spec.kind, spec.params)
    plant.reset(tuple(float(v) for v in scenario.x0), scenario.road)
    cmd = [str(exe), "/dev/stdin", str(out)]
    proc = subprocess.Popen(
        cmd, stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, encoding="ascii"
    )
    assert proc.stdin is not None
    try:
        w.header(proc.stdin)
        w.sample(proc.stdin, 0)
        proc.stdin.flush()
        for j in range(K):
            u = _control(proc, j)
            xn, info = plant.step(u)
            end = plant.lateral_acceleration(u).a_lat if j == K - 1 else None
            w.sample(proc.stdin, j + 1, (xn, info.a_lat, info.cut, end))
            if j == K - 1:
                proc.stdin.write("end\n")
            proc.stdin.flush()
        stdout, stderr = proc.communicate(timeout=timeout)  # closes stdin: the harness writes its log
    except (BrokenPipeError, CosimError, subprocess.TimeoutExpired) as exc:
        proc.kill()
        _, stderr = proc.communicate()
        raise CosimError(f"{' '.join(cmd)}: {exc}\n{stderr[-4000:]}") from None
    if proc.returncode != 0:
        raise CosimError(f"{' '.join(cmd)} failed (exit {proc.returncode}):\n{stdout[-2000:]}{stderr[-4000:]}")
    return RunLog.from_json(Path(out))
