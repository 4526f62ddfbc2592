"""Calibrating the exact penalties of the safe profile: how large a multiplier the obstacle and a_lat rows take.

An L1 penalty ``l1 * dt * sigma`` on a soft row's slack is *exact* (the slack stays 0 wherever the hard row can be
met) when ``l1`` exceeds the multiplier the hard row needs. Run closed loops with the rows effectively hard (L1 =
``HARD_L1``) and read each QP's multipliers ``y`` in the L1 weight's units: ``|y_i| |A_i,sigma| / (cost_scale dt)``
(stationarity of the scaled QP in the slack: ``cost_scale (l1 + 2 l2 sigma) dt + A_i,sigma y_i + y_bound = 0``).
``python -m fcgen.safety`` prints the distribution per row group; docs/safe_profile.md has the figures.
"""

from __future__ import annotations

import argparse
import re
from dataclasses import dataclass

import numpy as np

from .dsl import Problem, SoftPenalties
from .ocp import build_ocp
from .qp import build_layout

HARD_L1 = 1e12
_OBSTACLE_ROW = re.compile(r"^opp\d+_h\d+\[\d+\]$")
_ALAT_ROW = re.compile(r"^a_lat_(lo|hi)\[\d+\]$")


@dataclass(frozen=True)
class RowGroups:
    """Indices of a QP's obstacle rows and a_lat rows, and the factor from |y| to the L1 weight's units."""

    obstacle: np.ndarray
    a_lat: np.ndarray
    obstacle_unit: float
    a_lat_unit: float


def row_groups(problem: Problem) -> RowGroups:
    ocp = build_ocp(problem)
    lay = build_layout(ocp)
    names = lay.row_names
    obstacle = np.array([i for i, n in enumerate(names) if _OBSTACLE_ROW.match(n)], dtype=int)
    a_lat = np.array([i for i, n in enumerate(names) if _ALAT_ROW.match(n)], dtype=int)
    per = 1.0 / (ocp.cost_scale * ocp.interval)  # the costs weigh a stage by the (first) interval
    return RowGroups(obstacle, a_lat, per, per / problem.bounds.a_lat_max)  # a_lat rows are divided by a_lat_max


def hard(problem: Problem) -> Problem:
    """The problem with obstacle and a_lat rows effectively hard (L1 = HARD_L1; the L2 weights kept)."""
    s = problem.soft
    return problem.with_(
        name=f"{problem.name}_hard"[:31],
        soft=SoftPenalties(
            obstacle_l1=HARD_L1,
            obstacle_l2=s.obstacle_l2,
            a_lat_l1=HARD_L1,
            a_lat_l2=s.a_lat_l2,
            soft_road=s.soft_road,
            road_l1=s.road_l1,
            road_l2=s.road_l2,
        ),
    )


def multipliers(problem: Problem, scenario: str, seeds, samples: int = 200) -> dict[str, np.ndarray]:
    """Per sample of C closed loops of ``hard(problem)``: the largest obstacle-row and a_lat-row multiplier in L1
    units (NaN where the QP was unusable)."""
    import tempfile
    from pathlib import Path

    from .build import build
    from .codegen.generate import generate
    from .csolver import CSolver
    from .sim.closedloop import run_closed_loop
    from .sim.scenario import make_scenario

    pb = hard(problem)
    groups = row_groups(pb)
    out: dict[str, list] = {"obstacle": [], "a_lat": []}
    with tempfile.TemporaryDirectory() as tmp:
        cs = CSolver(build(generate(pb, Path(tmp) / "s").out_dir))

        class Recorder:
            kind = "c"

            def step(self, x0, road, opp):
                r = cs.step(x0, road, opp)
                y = cs.get_qp()["y"] if r.exit_code == 0 else None
                for key, idx, unit in (
                    ("obstacle", groups.obstacle, groups.obstacle_unit),
                    ("a_lat", groups.a_lat, groups.a_lat_unit),
                ):
                    out[key].append(np.nan if y is None or not len(idx) else float(np.max(np.abs(y[idx]))) * unit)
                return r

        for seed in seeds:
            cs.init()
            sc = make_scenario(scenario, int(seed), n_opp=pb.opponents.count, samples=samples, dt=pb.horizon.dt)
            run_closed_loop(pb, sc, controller=Recorder())
    return {k: np.array(v) for k, v in out.items()}


def main(argv=None) -> None:
    from .presets import load_problem

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("problems", nargs="+", help="presets or problem files")
    ap.add_argument("--seeds", type=int, default=5)
    ap.add_argument("--samples", type=int, default=200)
    a = ap.parse_args(argv)
    from .presets import PAPER_SOFT

    print(
        "| problem | row group | samples | median | 99th percentile | max | above the paper's L1 | above the safe L1 |"
    )
    print("|---|---|---|---|---|---|---|---|")
    for spec in a.problems:
        pb = load_problem(spec)
        scenario = "truck" if pb.opponents.vehicle.l_ch > 10 else "car"
        m = multipliers(pb, scenario, range(a.seeds), a.samples)
        for key, l1, l1_paper in (
            ("obstacle", SoftPenalties().obstacle_l1, PAPER_SOFT.obstacle_l1),
            ("a_lat", SoftPenalties().a_lat_l1, PAPER_SOFT.a_lat_l1),
        ):
            v = m[key][np.isfinite(m[key])]
            print(
                f"| {pb.name} | {key} | {len(v)} | {np.median(v):.3g} | {np.percentile(v, 99):.3g} | "
                f"{v.max():.3g} | {100 * np.mean(v > l1_paper):.1f} % of {l1_paper:.0e} | "
                f"{100 * np.mean(v > l1):.2f} % of {l1:.0e} |",
                flush=True,
            )


if __name__ == "__main__":
    main()
