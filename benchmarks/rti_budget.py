"""The RTI budget's closed-loop effect: each preset with several budgets against no extra cap (docs/wcet.md).

    python benchmarks/rti_budget.py [--seeds 20] [--samples 200] [--budgets 400,30,25,20,15,12,10] [PRESET ...]

Per preset (default: truck_lifted_ellipse_ipm, truck_direct_elimination_ellipse_ipm,
truck_lifted_hyperplane_ipm_safe) and budget, the C solver (generated and built once into ``.fcgen-cache``,
``fcgen.campaign.solvers``) closes the loop on seeds 0..SEEDS-1 of its scenario. The first budget is the baseline:
400 = ``max(max_iter, max_iter_cold)`` is what the solver did before the budget (warm 60, cold 400). Printed per
budget: mean progress and its difference to the baseline (mean, and the largest per seed), collision samples (runs),
runs with a collision the baseline does not have, QP statuses, QP iterations (max; at sample 0, the cold start: max
over seeds). ``--json FILE`` also writes the numbers.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
from pathlib import Path

import numpy as np

from fcgen.campaign.solvers import ensure_solver
from fcgen.csolver import CSolver
from fcgen.ocp import build_ocp
from fcgen.presets import preset
from fcgen.sim.closedloop import run_closed_loop
from fcgen.sim.runlog import qp_status_name
from fcgen.sim.scenario import make_scenario
from fcgen.verify import infer_scenario

PRESETS = ("truck_lifted_ellipse_ipm", "truck_direct_elimination_ellipse_ipm", "truck_lifted_hyperplane_ipm_safe")
CACHE = Path(__file__).resolve().parent.parent / ".fcgen-cache" / "rti_budget"


def runs(name: str, budget: int, seeds: int, samples: int) -> list:
    """The closed loops of preset ``name`` with ``qp.rti_budget = budget`` on seeds 0..seeds-1."""
    pb = preset(name)
    pv = dataclasses.replace(pb, name=f"b{budget}_{pb.name[:20]}", qp=dataclasses.replace(pb.qp, rti_budget=budget))
    cs = CSolver(ensure_solver(pv, CACHE))
    ocp, scenario = build_ocp(pb), infer_scenario(pb)
    logs = []
    for seed in range(seeds):
        sc = make_scenario(scenario, seed, n_opp=pb.opponents.count, samples=samples, dt=pb.horizon.dt)
        assert cs.init() == 0
        logs.append(run_closed_loop(pb, sc, controller=cs, ocp=ocp))
    return logs


def figures(logs: list, base: list | None) -> dict:
    """Progress, collisions, statuses and iterations of one budget's runs (differences against ``base``)."""
    prog = np.array([lg.ego_frenet[-1, 0] - lg.ego_frenet[0, 0] for lg in logs])
    coll = np.array([int(np.count_nonzero(lg.collision)) for lg in logs])
    qs = np.concatenate([lg.qp_status for lg in logs])
    names, counts = np.unique([qp_status_name(s) for s in qs.tolist()], return_counts=True)
    out = {
        "progress_mean": float(prog.mean()),
        "collision_samples": int(coll.sum()),
        "runs_with_collision": int(np.count_nonzero(coll)),
        "qp_status_counts": {str(k): int(v) for k, v in zip(names, counts)},
        "qp_iter_max": int(max(int(np.max(lg.qp_iter)) for lg in logs)),
        "qp_iter_mean": float(np.mean(np.concatenate([lg.qp_iter for lg in logs]))),
        "qp_iter_sample0_max": int(max(int(lg.qp_iter[0]) for lg in logs)),
    }
    if base is not None:
        p0 = np.array([lg.ego_frenet[-1, 0] - lg.ego_frenet[0, 0] for lg in base])
        c0 = np.array([int(np.count_nonzero(lg.collision)) for lg in base])
        out["progress_diff_pct"] = float(100.0 * (prog.mean() - p0.mean()) / p0.mean())
        out["progress_diff_pct_worst_seed"] = float(np.max(np.abs(100.0 * (prog - p0) / p0)))
        out["new_collision_runs"] = int(np.count_nonzero((coll > 0) & (c0 == 0)))
        out["max_state_diff"] = float(max(np.max(np.abs(a.ego_frenet - b.ego_frenet)) for a, b in zip(logs, base)))
    return out


def table(name: str, res: dict[int, dict]) -> str:
    """A Markdown table of one preset's budgets."""
    lines = [
        f"**{name}**",
        "",
        "| budget | progress m | vs baseline | worst seed | collision samples (runs) | "
        "new collision runs | QP statuses | QP iter mean / max | sample 0 iter (max) |",
        "|---|---|---|---|---|---|---|---|---|",
    ]
    for b, r in res.items():
        st = ", ".join(f"{k.removeprefix('QP_').lower()} {v}" for k, v in r["qp_status_counts"].items())
        diff = "baseline" if "progress_diff_pct" not in r else f"{r['progress_diff_pct']:+.3f} %"
        worst = "-" if "progress_diff_pct" not in r else f"{r['progress_diff_pct_worst_seed']:.3f} %"
        new = "-" if "new_collision_runs" not in r else str(r["new_collision_runs"])
        lines.append(
            f"| {b} | {r['progress_mean']:.2f} | {diff} | {worst} | {r['collision_samples']} "
            f"({r['runs_with_collision']}) | {new} | {st} | {r['qp_iter_mean']:.2f} / {r['qp_iter_max']} | "
            f"{r['qp_iter_sample0_max']} |"
        )
    return "\n".join(lines)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("presets", nargs="*", default=list(PRESETS))
    ap.add_argument("--seeds", type=int, default=20)
    ap.add_argument("--samples", type=int, default=200)
    ap.add_argument("--budgets", default="400,30,25,20,15,12,10")
    ap.add_argument("--json", type=Path)
    a = ap.parse_args()
    budgets = [int(b) for b in a.budgets.split(",")]
    out = {}
    for name in a.presets:
        base = None
        res: dict[int, dict] = {}
        for b in budgets:
            logs = runs(name, b, a.seeds, a.samples)
            res[b] = figures(logs, base)
            base = logs if base is None else base
        out[name] = res
        print(table(name, res), "\n", flush=True)
    if a.json:
        a.json.write_text(json.dumps({"seeds": a.seeds, "samples": a.samples, "results": out}, indent=1) + "\n")


if __name__ == "__main__":
    main()
