"""Export a closed-loop scenario as a data file for the C harness ``firmware_sim/`` (format ``fcgen-scenario/1``).

The file holds everything ``run_closed_loop`` feeds a controller and the plant, precomputed in Python: the whole
road (the harness cuts the per-sample solver window and the plant's local window out of it exactly like
``run_closed_loop`` does), the ego's initial Frenet state, and per sample the opponents' predicted poses of all
stages (``OpponentParams.horizon(j)``) plus the opponents' Cartesian and Frenet poses for the run log. The format is
plain text, documented in docs/scenario_file.md; doubles are written with ``%.17g`` so they read back bit for bit.
"""

from __future__ import annotations

import math
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
    return f"{v:.17g}"


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


def export_scenario(
    problem: Problem,
    scenario: Scenario,
    path: str | PathLike[str],
    samples: int | None = None,
    solver_name: str | None = None,
) -> Path:
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
        if pb.delay:  # a delay-compensated solver: the plant applies each control this many samples late
            f.write(f"latency {pb.delay}\n")
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
                blk = opp_params.horizon(j + pb.delay)  # the plan starts Problem.delay samples later
                if blk.shape != (N + 1, n_opp, n_opp_par):
                    raise ValueError(
                        f"opponent parameters of sample {j} have shape {blk.shape}, "
                        f"expected {(N + 1, n_opp, n_opp_par)}"
                    )
                _line(f, "opp_params", blk)
        f.write("end\n")
    return path
