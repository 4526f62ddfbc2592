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
from typing import IO

import numpy as np

from ..dsl import Problem
from ..ocp import road_window_samples
from .closedloop import WINDOW_BEHIND, dims
from .plants import PlantSpec
from .plants.actuation import Actuation
from .prediction import opponent_horizon
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


def _line(f: IO[str], key: str, values) -> None:
    f.write(key)
    for v in np.asarray(values, dtype=float).ravel():
        f.write(" ")
        f.write(_g(v))
    f.write("\n")


def _word(text: str) -> str:
    if not text or any(c.isspace() for c in text) or '"' in text or "\\" in text:
        raise ValueError(f"scenario export: {text!r} must be a non-empty word without spaces, quotes or backslashes")
    return text


class HarnessPlantError(ValueError):
    """A plant or perturbation a scenario file for the C harness cannot carry."""


def harness_plant(problem: Problem, plant: PlantSpec | None, external: bool = False) -> PlantSpec:
    """The harness's perturbations: ``plant``, by default the latency a delay-compensated solver compensates; refused
    (``HarnessPlantError``, naming the option) where the harness cannot run what the Python loop runs. ``external``:
    a CommonRoad plant stepped by the host (``sim.cosim``) is allowed."""
    spec = PlantSpec(latency=problem.delay) if plant is None else plant
    why = {
        "plant": spec.kind != "model"
        and not external
        and f"--plant {spec.kind}: CommonRoad's vehicle models are Python: the host steps them in lockstep with the "
        "harness (fcgen firmware-sim on the host target), a scenario file cannot hold them",
        "plant_params": spec.params != "paper" and "--plant-params matched: generate the solver from that problem",
        "prediction_margin": spec.prediction_margin > 0 and "--prediction-margin sets margins per sample",
    }
    for reason in why.values():
        if reason:
            raise HarnessPlantError(
                f"{reason}; the firmware harness carries --latency, --steer-lag, --noise and --prediction "
                "(run the others with `fcgen simulate --controller c` or `fcgen verify`)"
            )
    return spec


def measurement_noise(spec: PlantSpec, seed: int, samples: int, dt: float) -> np.ndarray:
    """The ``samples`` x 5 errors the closed loop adds to the measured state (``Actuation.measure``, seeded by the
    run's seed): the same draws, so that C and Python measure the same states."""
    act = Actuation(spec, seed, dt)
    return np.array([act.measure(np.zeros(5)) for _ in range(samples)]).reshape(samples, 5)


class ScenarioWriter:
    """The data file's records of one run: ``header``, ``sample`` j = 0 .. K, ``end`` (``export_scenario`` writes
    them in one go; ``sim.cosim`` sample by sample, with the host plant's state)."""

    def __init__(self, problem: Problem, scenario: Scenario, samples: int, solver_name: str | None, spec: PlantSpec):
        pb, sc, K = problem, scenario, samples
        if K < 1:
            raise ValueError(f"samples = {K} is invalid: allowed >= 1")
        n_opp = len(sc.opp_s0)
        if n_opp != pb.opponents.count:
            raise ValueError(f"scenario has {n_opp} opponents, problem {pb.name!r} expects {pb.opponents.count}")
        self.pb, self.sc, self.K, self.spec, self.name = pb, sc, K, spec, solver_name or pb.name
        opp_params = OpponentParams(pb, sc)
        self.horizon = opponent_horizon(pb, sc, spec, opp_params)  # the truth, or its prediction
        self.noise = measurement_noise(spec, sc.seed, K, pb.horizon.dt) if spec.noisy else None
        p0 = opp_params.at_index(0)
        self.n_opp, self.n_opp_par = n_opp, (p0.shape[1] if p0.ndim == 2 else 0)
        t = np.arange(K + 1) * sc.dt
        self.opp_cart, self.opp_fr = sc.opp_cartesian(t), sc.opp_frenet(t)

    def header(self, f: IO[str]) -> None:
        """Format line .. the road."""
        pb, sc = self.pb, self.sc
        f.write(FORMAT + "\n")
        for key, word in (
            ("problem", self.name),
            ("formulation", pb.formulation.kind),
            ("obstacle_model", pb.obstacles.kind),
            ("scenario", sc.name),
            ("controller", controller_kind()),
        ):
            f.write(f"{key} {_word(word)}\n")
        for k, v in sorted(package_versions().items()):
            f.write(f"version {_word(k)} {_word(v)}\n")
        f.write(f"seed {int(sc.seed)}\nN {pb.horizon.N}\n")
        _line(f, "dt", [pb.horizon.dt])
        f.write(f"samples {self.K}\nnopp {self.n_opp}\nnopp_par {self.n_opp_par}\n")
        f.write(f"road_window {pb.road.samples}\n")
        f.write(f"plant_window {road_window_samples(pb)}\n")  # = build_ocp(pb).road_params.samples
        _line(f, "window_behind", [WINDOW_BEHIND])
        _line(f, "n_bound", [pb.bounds.n_max])
        self._perturbations(f)
        _line(f, "ego_l", [pb.ego.l])
        de, do = dims(pb.ego), dims(pb.opponents.vehicle)
        _line(f, "ego_dims", [de[k] for k in ("l_f", "l_r", "l_r_ch", "l_f_ch", "w_ch")])
        for _ in range(self.n_opp):
            _line(f, "opp_dims", [do[k] for k in ("l_f", "l_r", "l_r_ch", "l_f_ch", "w_ch")])
        _line(f, "x0", sc.x0)
        road = sc.road
        f.write(f"road {road.size} {_g(road.s0)} {_g(road.ds)}\n")
        _line(f, "kappa", road.kappa)
        _line(f, "phi_gamma", road.phi)
        _line(f, "gamma_x", road.gx)
        _line(f, "gamma_y", road.gy)

    def _perturbations(self, f: IO[str]) -> None:
        spec = self.spec
        if spec.latency:  # the plant applies each control this many samples late
            f.write(f"latency {spec.latency}\n")
        if spec.steer_lag:  # a first-order steering actuator's time constant
            _line(f, "steer_lag", [spec.steer_lag])
        if self.noise is not None:  # the measurement noise's stds; each sample's errors follow its opp_params
            _line(f, "noise", spec.noise)
        if spec.prediction != "oracle":  # opp_params hold this prediction of the opponents' futures
            f.write(f"prediction {spec.prediction}\n")
        if spec.kind != "model":  # the host steps this plant (sim.cosim); its states come in each sample's record
            f.write(f"plant {spec.kind} {spec.params}\n")

    def sample(self, f: IO[str], j: int, plant: tuple | None = None) -> None:
        """Sample j's block; ``plant``: the host plant's (x_j, a_lat_{j-1}, cut_{j-1}) for j >= 1, and for j = K
        also a_lat_K (``sim.cosim``)."""
        f.write(f"sample {j}\n")
        _line(f, "opp_cartesian", self.opp_cart[j])
        _line(f, "opp_frenet", self.opp_fr[j])
        if plant is not None:
            _line(f, "plant_state", [*plant[0], plant[1], plant[2]])
        if j < self.K:
            N, blk = self.pb.horizon.N, self.horizon(j + self.pb.delay)  # the plan starts Problem.delay later
            if blk.shape != (N + 1, self.n_opp, self.n_opp_par):
                raise ValueError(
                    f"opponent parameters of sample {j} have shape {blk.shape}, "
                    f"expected {(N + 1, self.n_opp, self.n_opp_par)}"
                )
            _line(f, "opp_params", blk)
            if self.noise is not None:
                _line(f, "measurement_error", self.noise[j])
        elif plant is not None:
            _line(f, "plant_a_lat", [plant[3]])


def export_scenario(
    problem: Problem,
    scenario: Scenario,
    path: str | PathLike[str],
    samples: int | None = None,
    solver_name: str | None = None,
    plant: PlantSpec | None = None,
) -> Path:
    """Write the data file of ``samples`` closed-loop samples (default ``scenario.samples``); returns the path.

    ``solver_name`` (default ``problem.name``) is the run log's ``meta.problem``; ``plant``: the perturbations
    between solver and plant (``harness_plant``: by default the latency of a delay-compensated solver).
    """
    K = int(scenario.samples if samples is None else samples)
    w = ScenarioWriter(problem, scenario, K, solver_name, harness_plant(problem, plant))
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    with open(path, "w", encoding="ascii", newline="\n") as f:
        w.header(f)
        for j in range(K + 1):
            w.sample(f, j)
        f.write("end\n")
    return path
