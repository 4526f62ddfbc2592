"""Prepare-phase timing of the four conventional presets (truck/car, ellipse/hyperplane), several builds alternated.

    python benchmarks/bench_oppfit.py gen ROOT TAG        # generate + build the presets into ROOT/TAG/<preset>
    python benchmarks/bench_oppfit.py run ROOT A,B [SEEDS] [SAMPLES]

``run`` closes the loop (C solver, CPU clock of the solver thread) on seeds 0..SEEDS-1, per seed each build in turn,
and prints per build the median / mean / max prepare and the median feedback time [ms] and the mean progress [m].
To compare against an older generator, run ``gen`` from a checkout of that commit (e.g. ``git worktree add``) into
the same ROOT. ``FULL=2`` in the environment of ``gen``: two road evaluations per fitted point (oppfit.FULL_EVALS).
"""

from __future__ import annotations

import argparse
import dataclasses
import os
from pathlib import Path

import numpy as np

from fcgen.build import build
from fcgen.codegen.generate import generate
from fcgen.csolver import CSolver
from fcgen.ocp import build_ocp
from fcgen.presets import preset
from fcgen.sim.closedloop import run_closed_loop
from fcgen.sim.scenario import make_scenario

NAMES = [
    "truck_conventional_ellipse",
    "truck_conventional_hyperplane",
    "car_conventional_ellipse",
    "car_conventional_hyperplane",
]


def gen(root: Path, tag: str) -> None:
    if os.environ.get("FULL"):
        from fcgen import oppfit

        oppfit.FULL_EVALS = int(os.environ["FULL"])
    for n in NAMES:
        pb = preset(n)
        pv = dataclasses.replace(pb, name=f"{n[:3]}{n.split('_')[-1][:2]}_{tag}")  # distinct symbols per build
        out = root / tag / n
        generate(pv, out)
        print(build(out, verify=False))


def run(root: Path, tags: list[str], seeds: int, samples: int) -> None:
    for n in NAMES:
        pb = preset(n)
        ocp = build_ocp(pb)
        sols = {t: CSolver(next((root / t / n / "build").glob("*.so")), clock="cpu") for t in tags}
        logs: dict[str, list] = {t: [] for t in tags}
        for seed in range(seeds):
            sc = make_scenario(n.split("_")[0], seed, n_opp=pb.opponents.count, samples=samples, dt=pb.horizon.dt)
            for t in tags:
                assert sols[t].init() == 0
                logs[t].append(run_closed_loop(pb, sc, controller=sols[t], ocp=ocp))
        line = [n]
        for t in tags:
            tp = 1e3 * np.concatenate([np.asarray(lg.time_prepare) for lg in logs[t]])
            tf = 1e3 * np.concatenate([np.asarray(lg.time_feedback) for lg in logs[t]])
            prog = np.mean([lg.ego_frenet[-1, 0] - lg.ego_frenet[0, 0] for lg in logs[t]])
            line.append(
                f"{t}: prepare median {np.median(tp):.3f} mean {tp.mean():.3f} max {tp.max():.3f}, "
                f"feedback median {np.median(tf):.3f}, progress {prog:.1f}"
            )
        print(" | ".join(line), flush=True)


def main() -> None:
    ap = argparse.ArgumentParser(
        description="Prepare-phase timing of the four conventional presets, builds alternated (docs/problem.md)."
    )
    sub = ap.add_subparsers(dest="cmd", required=True)
    g = sub.add_parser("gen", help="generate and build the presets into ROOT/TAG/<preset>")
    g.add_argument("root", type=Path)
    g.add_argument("tag")
    r = sub.add_parser("run", help="close the loop with each build in turn and print the timings")
    r.add_argument("root", type=Path)
    r.add_argument("tags", help="comma-separated TAGs written by gen")
    r.add_argument("seeds", type=int, nargs="?", default=2)
    r.add_argument("samples", type=int, nargs="?", default=200)
    args = ap.parse_args()
    if args.cmd == "gen":
        gen(args.root, args.tag)
    else:
        run(args.root, args.tags.split(","), args.seeds, args.samples)


if __name__ == "__main__":
    main()
