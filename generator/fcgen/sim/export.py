"""Export a closed-loop scenario as a data file for the C harness ``firmware_sim/`` (format ``fcgen-scenario/1``).

The file holds everything ``run_closed_loop`` feeds a controller and the plant, precomputed in Python: the whole
road (the harness cuts the per-sample solver window and the plant's local window out of it exactly like
``run_closed_loop`` does), the ego's initial Frenet state, and per sample the opponents' predicted poses of all
stages (``OpponentParams.horizon(j)``) plus the opponents' Cartesian and Frenet poses for the run log. The format is
plain text, documented in docs/scenario_file.md; doubles are written with ``%.17g`` so they read back bit for bit.
"""
from __future__ import annotations

import math
import os
from os import PathLike
from pathlib import Path
from typing import TextIO

import numpy as np

from ..dsl import Problem
from ..ocp import road_window_samples
from .closedloop import WINDOW_BEHIND, dims
from .runlog import CONTROLLER_KINDS, package_versions
from .scenario import OpponentParams, Scenario

FORMAT = "fcgen-scenario/1"

#: the ``meta.controller`` value the harness writes (falls back to ``"c"`` while the run-log format does not list it)
FIRMWARE_SIM_KIND = "c-firmware_sim"


def controller_kind() -> str:
    return FIRMWARE_SIM_KIND if FIRMWARE_SIM_KIND in CONTROLLER_KINDS else "c"


def _g(v: float) -> str:
    v = float(v)
    if math.isnan(v):
        return "nan"
    if math.isinf(v):
        return "inf" if v > 0 else "-inf"
    return "%.17g" % v


def _line(f: TextIO, key: str, values) -> None:
    f.write(key)
    for v in np.asarray(values, dtype=float).ravel():
        f.write(" ")
        f.write(_g(v))
    f.write("\n")


def _word(text: str) -> str:
    if not text or any(c.isspace() for c in text) or '"' in text or "\\" in text:
        raise ValueError(f"scenario export: {text!r} must be a non-empty word without spaces, quotes or backslashes")
    return text


def export_scenario(problem: Problem, scenario: Scenario, path: str | PathLike[str], samples: int | None = None,
                    solver_name: str | None = None) -> Path:
    """Write the data file of ``samples`` closed-loop samples (default ``scenario.samples``); returns the path.

    ``solver_name`` (default ``problem.name``) is the run log's ``meta.problem``.
    """
    K = int(scenario.samples if samples is None else samples)
    if K < 1:
        raise ValueError(f"samples = {K} is invalid: allowed >= 1")
    pb, sc = problem, scenario
    N = pb.horizon.N
    n_opp = len(sc.opp_s0)
    if n_opp != pb.opponents.count:
        raise ValueError(f"scenario has {n_opp} opponents, problem {pb.name!r} expects {pb.opponents.count}")
    opp_params = OpponentParams(pb, sc)
    p0 = opp_params.at_index(0)
    n_opp_par = p0.shape[1] if p0.ndim == 2 else 0
    road = sc.road
    t = np.arange(K + 1) * sc.dt
    opp_cart = sc.opp_cartesian(t)
    opp_fr = sc.opp_frenet(t)
    plant_window = road_window_samples(pb)  # = build_ocp(pb).road_params.samples, the plant's local window

    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    with open(path, "w", encoding="ascii", newline="\n") as f:
        f.write(FORMAT + "\n")
        f.write(f"problem {_word(solver_name or pb.name)}\n")
        f.write(f"formulation {_word(pb.formulation.kind)}\n")
        f.write(f"obstacle_model {_word(pb.obstacles.kind)}\n")
        f.write(f"scenario {_word(sc.name)}\n")
        f.write(f"controller {_word(controller_kind())}\n")
        for k, v in sorted(package_versions().items()):
            f.write(f"version {_word(k)} {_word(v)}\n")
        f.write(f"seed {int(sc.seed)}\n")
        f.write(f"N {N}\n")
        _line(f, "dt", [pb.horizon.dt])
        f.write(f"samples {K}\n")
        f.write(f"nopp {n_opp}\n")
        f.write(f"nopp_par {n_opp_par}\n")
        f.write(f"road_window {pb.road.samples}\n")
        f.write(f"plant_window {plant_window}\n")
        _line(f, "window_behind", [WINDOW_BEHIND])
        _line(f, "n_bound", [pb.bounds.n_max])
        _line(f, "ego_l", [pb.ego.l])
        de = dims(pb.ego)
        _line(f, "ego_dims", [de[k] for k in ("l_f", "l_r", "l_r_ch", "l_f_ch", "w_ch")])
        do = dims(pb.opponents.vehicle)
        for _ in range(n_opp):
            _line(f, "opp_dims", [do[k] for k in ("l_f", "l_r", "l_r_ch", "l_f_ch", "w_ch")])
        _line(f, "x0", sc.x0)
        f.write(f"road {road.size} {_g(road.s0)} {_g(road.ds)}\n")
        _line(f, "kappa", road.kappa)
        _line(f, "phi_gamma", road.phi)
        _line(f, "gamma_x", road.gx)
        _line(f, "gamma_y", road.gy)
        for j in range(K + 1):
            f.write(f"sample {j}\n")
            _line(f, "opp_cartesian", opp_cart[j])
            _line(f, "opp_frenet", opp_fr[j])
            if j < K:
                blk = opp_params.horizon(j)
                if blk.shape != (N + 1, n_opp, n_opp_par):
                    raise ValueError(f"opponent parameters of sample {j} have shape {blk.shape}, "
                                     f"expected {(N + 1, n_opp, n_opp_par)}")
                _line(f, "opp_params", blk)
        f.write("end\n")
    return path


# ----------------------------------------------------------------------------- the C harness firmware_sim/

class HarnessError(RuntimeError):
    """Building or running the C closed-loop harness failed; the message holds the tool's output."""


def harness_source_dir() -> Path:
    """The harness sources ``firmware_sim/`` (shipped in the package; a link to the repository's folder)."""
    d = Path(__file__).resolve().parents[1] / "firmware_sim"
    if not (d / "closed_loop.c").is_file() or not (d / "Makefile").is_file():
        raise FileNotFoundError(f"{d}: the C harness (closed_loop.c, Makefile) is missing from the installation")
    return d


def build_harness(solver_dir: str | PathLike[str], verify: bool = False, cc: str | None = None,
                  cflags: str | None = None, target: str = "host", variant: str | None = None,
                  extra_cflags: str = "", harness_defines: tuple[str, ...] = ()) -> Path:
    """Build the solver folder (``fcgen.build.build``) and the harness against it; returns the executable.

    The harness goes into ``<solver build>/firmware_sim`` (``build[/<target>][/<variant>][/verify]/firmware_sim``).
    For a bare-metal target it is a semihosting image (``closed_loop.elf``) linked with our startup
    (``fs_baremetal.c``) and the linker script rendered from the target's memory map. ``variant``, ``extra_cflags``:
    a solver build of its own with these flags added (``fcgen wcet``'s probe build); ``harness_defines``: ``-D``
    flags of the harness alone (its ``CPPFLAGS``).
    """
    from ..build import BuildError, build, build_dir, run_make, solver_name
    from ..targets import get_target

    tgt = get_target(target)
    solver_dir = Path(solver_dir).resolve()
    name = solver_name(solver_dir)
    try:
        build(solver_dir, verify=verify, cc=cc, cflags=cflags, target=target, extra_cflags=extra_cflags,
              variant=variant)
    except BuildError as exc:
        raise HarnessError(str(exc)) from None
    lib_dir = build_dir(solver_dir, verify, target, variant)
    out = lib_dir / "firmware_sim"
    variables = [f"SOLVER_DIR={solver_dir}", f"SOLVER={name}", f"SOLVER_BUILD={lib_dir}", f"BUILD={out}",
                 f"VERIFY={int(verify)}", *([f"CPPFLAGS={' '.join(harness_defines)}"] if harness_defines else [])]
    if tgt.bare_metal:
        ld = out / f"{tgt.name}.ld"
        out.mkdir(parents=True, exist_ok=True)
        text = tgt.linker_script()
        if not ld.is_file() or ld.read_text() != text:
            ld.write_text(text)
        variables += tgt.harness_make_variables(ld)
        cc = cc or tgt.cc
    run_make(harness_source_dir(), variables, cc, cflags, HarnessError)
    return out / tgt.harness_executable


def run_harness(exe: str | PathLike[str], scenario_file: str | PathLike[str], out: str | PathLike[str],
                timeout: float | None = None, target: str = "host"):
    """Run the harness on a scenario file (a bare-metal image under QEMU, with ``-icount shift=0``); returns the run
    log it wrote (validated by ``RunLog.from_json``)."""
    import subprocess

    from ..targets import get_target
    from .runlog import RunLog

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
        raise HarnessError(f"{' '.join(cmd)} failed (exit {res.returncode}):\n{res.stdout[-2000:]}"
                           f"{res.stderr[-4000:]}")
    return RunLog.from_json(out)


def firmware_sim(solver_dir: str | PathLike[str], scenario: str = "truck", seed: int = 0, samples: int = 200,
                 out: str | PathLike[str] = "run.json", verify: bool = False, cc: str | None = None,
                 cflags: str | None = None, problem: Problem | None = None, target: str = "host",
                 timeout: float | None = None):
    """Build solver and harness, export the scenario, run the C closed loop; returns the run log written to ``out``.

    The problem defaults to the one the folder records (``problem.py``), so data file and compiled solver agree.
    ``target``: a name of ``fcgen.targets`` (a bare-metal target runs the image under QEMU).
    """
    from ..build import solver_name
    from ..presets import load_problem
    from ..targets import get_target
    from .scenario import make_scenario

    solver_dir = Path(solver_dir)
    name = solver_name(solver_dir)
    if problem is None:
        problem = load_problem(str(solver_dir / "problem.py"))
    sc = make_scenario(scenario, seed, n_opp=problem.opponents.count, samples=samples, dt=problem.horizon.dt)
    exe = build_harness(solver_dir, verify=verify, cc=cc, cflags=cflags, target=target)
    data = exe.parent / f"scenario_{scenario}_seed{seed}_{samples}.txt"
    export_scenario(problem, sc, data, samples, solver_name=name)
    Path(out).parent.mkdir(parents=True, exist_ok=True)
    log = run_harness(exe, data, out, timeout=timeout, target=target)
    # record where it ran and in which precision (meta.precision as `fcgen record` writes it: `fcgen regress` picks
    # its tolerance preset from it)
    from dataclasses import replace

    from ..build import solver_uses_float
    meta = {**log.meta, "precision": "float" if solver_uses_float(solver_dir) else "double",
            "extra": {**log.meta.get("extra", {}), "target": get_target(target).name}}
    log = replace(log, meta=meta)
    log.to_json(out)
    return log
