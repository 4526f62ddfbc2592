"""The robustness grid (``fcgen campaign --robustness``, docs/plants.md): each configuration under one perturbation
at a time at growing magnitudes, and the combined worst cases, beside the unperturbed run; its estimated time."""

from __future__ import annotations

from dataclasses import dataclass, replace

from ..dsl import ProblemError
from ..sim.plants import DEFAULT_NOISE, PlantSpec
from .grid import Config

#: the axes and, per axis, its cells: (label, plant spec, the solvers' delay compensation)
AXES: tuple[str, ...] = ("plant", "latency", "noise", "steer-lag", "prediction", "combined")


@dataclass(frozen=True)
class Cell:
    """One perturbation of the grid: its axis, its magnitude (as a label), the plant spec and the compensation."""

    axis: str
    magnitude: str
    spec: PlantSpec
    delay: int = 0


def _noise(k: float) -> PlantSpec:
    return PlantSpec(noise=tuple(k * v for v in DEFAULT_NOISE))


def _worst(prediction: str, margin: float = 0.0) -> PlantSpec:
    """The plant issue's worst case with a prediction: st, one sample of latency (compensated), default noise."""
    return PlantSpec(kind="st", latency=1, noise=DEFAULT_NOISE, prediction=prediction, prediction_margin=margin)


#: c of the margins that grow with the prediction's expected error (``PlantSpec.prediction_margin``) in the cells that
#: measure them beside the fixed margin (docs/plants.md, "Margins from the prediction's error")
MARGIN_C = 1.0


def cells(axes=AXES) -> list[Cell]:
    """The unperturbed cell, then each axis' cells in growing magnitude (latency: without, then with compensation)."""
    for a in axes:
        if a not in AXES:
            raise ProblemError(f"axes: {a!r} is invalid: allowed {', '.join(AXES)}")
    by_axis = {
        "plant": [Cell("plant", k, PlantSpec(kind=k)) for k in ("st", "std")],
        "latency": [Cell("latency", f"{n}", PlantSpec(latency=n)) for n in (1, 2, 3)]
        + [Cell("latency", f"{n}+comp", PlantSpec(latency=n), n) for n in (1, 2, 3)],
        "noise": [Cell("noise", f"{k:g}x", _noise(k)) for k in (1.0, 2.0, 4.0)],
        "steer-lag": [Cell("steer-lag", f"{t:g}", PlantSpec(steer_lag=t)) for t in (0.1, 0.2)],
        "prediction": [
            Cell("prediction", p, PlantSpec(prediction=p))
            for p in ("constant-velocity", "constant-acceleration", "lane-following")
        ]
        + [
            Cell("prediction", f"{p}+margin{MARGIN_C:g}", PlantSpec(prediction=p, prediction_margin=MARGIN_C))
            for p in ("constant-velocity", "lane-following")
        ],
        "combined": [Cell("combined", f"st+lat1comp+noise+{p}", _worst(p), 1) for p in ("oracle", "constant-velocity")]
        + [Cell("combined", "st+lat1comp+noise+lane-following", _worst("lane-following"), 1)]
        + [
            Cell(
                "combined",
                f"st+lat1comp+noise+constant-velocity+margin{MARGIN_C:g}",
                _worst("constant-velocity", MARGIN_C),
                1,
            )
        ],
    }
    return [Cell("none", "0", PlantSpec())] + [c for a in AXES if a in axes for c in by_axis[a]]


def robustness_grid(configs: list[Config], axes=AXES) -> list[Config]:
    """Every configuration in every cell (cell-major: the unperturbed runs first)."""
    return [replace(c, plant=cell.spec, delay=cell.delay) for cell in cells(axes) for c in configs]


#: CPU seconds of one 200-sample run by plant (C solvers, safe profile, car lifted ellipse, OSQP; measured at
#: 97bc8c6 with 3 seeds: model 0.25, st 0.45, std 1.39; ks taken as st, mb a guess); lane-following predictions add
#: LANE_SECONDS (the road projection at every sample: 0.53 s in all with fcgen's model)
RUN_SECONDS = {"model": 0.3, "ks": 0.5, "st": 0.5, "std": 1.4, "mb": 4.0}
LANE_SECONDS = 0.3
#: the same on the IPM (the worker's CPU per run in the safe profile's robustness grid at 063e868, car and truck, DE
#: and lifted, ellipse and hyperplane, seeds 0-7, 1,226 runs: model 0.15, st 0.33, std 1.46; lane-following +0.32)
IPM_RUN_SECONDS = {"model": 0.15, "ks": 0.33, "st": 0.33, "std": 1.46, "mb": 4.0}


def run_seconds(c: Config) -> float:
    """The estimated CPU seconds of one 200-sample run of ``c`` (by plant and backend)."""
    table = IPM_RUN_SECONDS if c.backend == "ipm" else RUN_SECONDS
    return table[c.plant.kind] + (LANE_SECONDS if c.plant.prediction == "lane-following" else 0.0)


def estimated_minutes(
    configs: list[Config], seeds: int | range, samples: int, jobs: int, done: frozenset | set = frozenset()
) -> float:
    """The grid's estimated time on ``jobs`` otherwise idle cores for the runs not in ``done`` (the (config key, seed)
    pairs already in the results at these samples and clock); solvers compiled once per problem not included."""
    seeds = range(seeds) if isinstance(seeds, int) else seeds
    runs = sum(run_seconds(c) for c in configs for s in seeds if (c.key, s) not in done)
    return runs * samples / 200.0 / max(1, jobs) / 60.0
