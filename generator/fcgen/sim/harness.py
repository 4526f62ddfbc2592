"""The C closed-loop harness ``firmware_sim/``: built against a solver folder, run on a scenario data file
(``fcgen.sim.export``) on the host or, for a bare-metal target, as a semihosting image under QEMU.

Every function is handed the :class:`~..solver_folder.SolverFolder` (or its path, read once); none of them reads
the folder again.
"""

from __future__ import annotations

import os
import subprocess
from dataclasses import replace
from os import PathLike
from pathlib import Path

from ..build import BuildError, build, run_make
from ..codegen.render import render_template
from ..dsl import Problem
from ..locks import folder_lock
from ..solver_folder import FolderLike, as_folder
from ..targets import HARNESS_STACK, Target, TargetError, get_target
from .cosim import CosimError, run_cosim
from .export import export_scenario, harness_plant
from .plants import PlantSpec
from .runlog import RunLog
from .scenario import make_scenario


class HarnessError(RuntimeError):
    """Building or running the C closed-loop harness failed; the message holds the tool's output."""


def harness_source_dir() -> Path:
    """The harness sources ``firmware_sim/`` (shipped in the package; a link to the repository's folder)."""
    d = Path(__file__).resolve().parents[1] / "firmware_sim"
    if not (d / "closed_loop.c").is_file() or not (d / "Makefile").is_file():
        raise FileNotFoundError(f"{d}: the C harness (closed_loop.c, Makefile) is missing from the installation")
    return d


def linker_script(target: Target) -> str:
    """The harness image's linker script for a bare-metal target: vectors + code + constants in flash,
    data/bss/heap/stack in RAM, the harness's buffers in the board's external RAM."""
    if target.flash is None or target.ram is None or target.xram is None:
        raise TargetError(f"--target {target.name}: no memory map")
    return render_template(
        target.linker_template, target=target, flash=target.flash, ram=target.ram, xram=target.xram, stack=HARNESS_STACK
    )


def build_harness(
    folder: FolderLike,
    verify: bool = False,
    cc: str | None = None,
    cflags: str | None = None,
    target: str = "host",
    variant: str | None = None,
    extra_cflags: str = "",
    harness_defines: tuple[str, ...] = (),
) -> Path:
    """Build the solver folder (``fcgen.build.build``) and the harness against it; returns the executable.

    The harness goes into ``<solver build>/firmware_sim`` (``build[/<target>][/<variant>][/verify]/firmware_sim``).
    For a bare-metal target it is a semihosting image (``closed_loop.elf``) linked with our startup
    (``fs_baremetal.c``) and the linker script rendered from the target's memory map. ``variant``, ``extra_cflags``:
    a solver build of its own with these flags added (``fcgen wcet``'s probe build); ``harness_defines``: ``-D``
    flags of the harness alone (its ``CPPFLAGS``).
    """
    folder = as_folder(folder)
    tgt = get_target(target)
    with folder_lock(folder.path):  # the solver's build and the harness's, one process at a time
        try:
            build(
                folder, verify=verify, cc=cc, cflags=cflags, target=target, extra_cflags=extra_cflags, variant=variant
            )
        except BuildError as exc:
            raise HarnessError(str(exc)) from None
        solver_dir = folder.path.resolve()
        lib_dir = folder.build_dir(verify, target, variant).resolve()
        out = lib_dir / "firmware_sim"
        variables = [
            f"SOLVER_DIR={solver_dir}",
            f"SOLVER={folder.name}",
            f"SOLVER_BUILD={lib_dir}",
            f"BUILD={out}",
            f"VERIFY={int(verify)}",
            *([f"CPPFLAGS={' '.join(harness_defines)}"] if harness_defines else []),
        ]
        if tgt.bare_metal:
            ld = out / f"{tgt.name}.ld"
            out.mkdir(parents=True, exist_ok=True)
            text = linker_script(tgt)
            if not ld.is_file() or ld.read_text() != text:
                ld.write_text(text)
            variables += tgt.harness_make_variables(ld)
            cc = cc or tgt.cc
        run_make(harness_source_dir(), variables, cc, cflags, HarnessError)
    return out / tgt.harness_executable


def run_harness(
    exe: str | PathLike[str],
    scenario_file: str | PathLike[str],
    out: str | PathLike[str],
    timeout: float | None = None,
    target: str = "host",
) -> RunLog:
    """Run the harness on a scenario file (a bare-metal image under QEMU, with ``-icount shift=0``); returns the run
    log it wrote (validated by ``RunLog.from_json``)."""
    tgt = get_target(target)
    cwd = None
    if tgt.bare_metal:
        # semihosting opens the files relative to QEMU's working folder: run there with plain names
        tgt.check_tools(qemu=True)
        scenario_file, out = Path(scenario_file).resolve(), Path(out).resolve()
        cwd = out.parent
        args = [os.path.relpath(scenario_file, cwd), out.name]
        bad = [a for a in args if any(c.isspace() or c == "," for c in a)]
        if bad:  # semihosting's command line is split at spaces, QEMU's options at commas
            raise HarnessError(f"{bad[0]!r}: paths for the emulated harness must not contain spaces or commas")
        cmd = tgt.qemu_command(Path(exe).resolve(), args)
    else:
        cmd = [str(exe), str(scenario_file), str(out)]
    try:
        res = subprocess.run(cmd, capture_output=True, text=True, timeout=timeout, cwd=cwd)
    except (OSError, subprocess.TimeoutExpired) as exc:
        raise HarnessError(f"{' '.join(cmd)}: {exc}") from None
    if res.returncode != 0:
        raise HarnessError(f"{' '.join(cmd)} failed (exit {res.returncode}):\n{res.stdout[-2000:]}{res.stderr[-4000:]}")
    return RunLog.from_json(out)


def firmware_sim(
    folder: FolderLike,
    scenario: str = "truck",
    seed: int = 0,
    samples: int = 200,
    out: str | PathLike[str] = "run.json",
    verify: bool = False,
    cc: str | None = None,
    cflags: str | None = None,
    problem: Problem | None = None,
    target: str = "host",
    timeout: float | None = None,
    plant: PlantSpec | None = None,
) -> RunLog:
    """Build solver and harness, export the scenario, run the C closed loop; returns the run log written to ``out``.

    The problem defaults to the one the folder records (``problem.py``), so data file and compiled solver agree.
    ``target``: a name of ``fcgen.targets`` (a bare-metal target runs the image under QEMU). ``plant``: the latency,
    steering lag, measurement noise and prediction between solver and plant (``export.harness_plant``; default: the
    latency a delay-compensated solver compensates); a CommonRoad plant is stepped on the host in lockstep with the
    host harness (``sim.cosim``).
    """
    folder = as_folder(folder)
    problem = folder.problem if problem is None else problem
    kind = "model" if plant is None else plant.kind
    host_plant = kind != "model"  # CommonRoad's models: stepped here (sim.cosim)
    if host_plant and get_target(target).bare_metal:
        raise HarnessError(f"--plant {kind}: the host steps the plant in lockstep with the host harness only")
    spec = harness_plant(problem, plant, external=host_plant)  # refused before anything is built
    sc = make_scenario(scenario, seed, n_opp=problem.opponents.count, samples=samples, dt=problem.horizon.dt)
    exe = build_harness(folder, verify=verify, cc=cc, cflags=cflags, target=target)
    Path(out).parent.mkdir(parents=True, exist_ok=True)
    if host_plant:
        try:
            log = run_cosim(exe, problem, sc, spec, out, solver_name=folder.name, timeout=timeout)
        except CosimError as exc:
            raise HarnessError(str(exc)) from None
    else:
        label = "" if spec.is_default else f"_{spec.label().replace(':', '_')}"
        data = exe.parent / f"scenario_{scenario}_seed{seed}_{samples}{label}.txt"
        export_scenario(problem, sc, data, samples, solver_name=folder.name, plant=spec)
        log = run_harness(exe, data, out, timeout=timeout, target=target)
    # record where it ran and in which precision (meta.precision as `fcgen record` writes it: `fcgen regress` picks
    # its tolerance preset from it)
    meta = {
        **log.meta,
        "precision": folder.precision,
        "extra": {**log.meta.get("extra", {}), "target": get_target(target).name},
    }
    log = replace(log, meta=meta)
    log.to_json(out)
    return log
