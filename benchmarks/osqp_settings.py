"""OSQP's real-time settings in closed loop: progress, QP iterations and caps per variant (docs/performance.md).

    python benchmarks/osqp_settings.py [--seeds 20] [--samples 200] [--configs lifted/EL,direct_elimination/EL]
        [--scenario truck] [--jobs 2] [--out results/osqp_settings.json] VARIANT ...

A VARIANT is ``label:field=value,field=value`` of ``QpOptions`` (``base:`` for the presets' own options), e.g.
``cap40:max_iter=40`` or ``cap40_rho15:max_iter=40,rho=0.15``. The first variant is the baseline. Per variant and
configuration of the truck grid (``--scenario car``: the car's) with OSQP (``fcgen.campaign.grid.paper_grid``;
``--configs``: those whose key contains one of the comma-separated parts), the C solver (generated and built once
into ``.fcgen-cache/osqp_settings``) closes the loop on seeds 0..SEEDS-1. Printed per variant: mean progress over
all runs and its difference to the baseline (all runs; the worst configuration; the worst seed), collision samples,
runs with a collision the baseline does not have, QP iterations (mean; share of warm QPs at their cap), QP statuses.
Written: JSON with the per-run figures.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import zlib
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import numpy as np

from fcgen.campaign.grid import paper_grid
from fcgen.campaign.solvers import ensure_solver
from fcgen.csolver import CSolver
from fcgen.ocp import build_ocp
from fcgen.sim.closedloop import run_closed_loop
from fcgen.sim.runlog import qp_status_name
from fcgen.sim.scenario import make_scenario

CACHE = Path(__file__).resolve().parent.parent / ".fcgen-cache" / "osqp_settings"


def parse_variant(text: str) -> tuple[str, dict]:
    """``label:field=value,...`` -> (label, {field: value}) with int / float / bool values."""
    label, _, rest = text.partition(":")
    over: dict = {}
    for item in filter(None, rest.split(",")):
        key, _, val = item.partition("=")
        if val in ("True", "False"):
            over[key] = val == "True"
        else:
            over[key] = int(val) if val.lstrip("-").isdigit() else float(val)
    return label, over


def run_config(job: tuple) -> list[dict]:
    """The closed loops of one configuration with one variant's QP options on seeds 0..seeds-1."""
    cfg, label, over, seeds, samples = job
    pb = cfg.problem()
    name = f"s{zlib.crc32(label.encode()) % 10**5}_{pb.name}"[:31]
    pv = dataclasses.replace(pb, name=name, qp=dataclasses.replace(pb.qp, **over))
    cs = CSolver(ensure_solver(pv, CACHE))
    ocp = build_ocp(pv)
    cap = pv.qp.caps[0]
    rows = []
    for seed in range(seeds):
        sc = make_scenario(cfg.scenario, seed, n_opp=pb.opponents.count, samples=samples, dt=pb.horizon.dt)
        if cs.init() != 0:
            raise RuntimeError(f"{pv.name}_init() failed")
        lg = run_closed_loop(pv, sc, controller=cs, ocp=ocp)
        it = np.asarray(lg.qp_iter)[1:]
        rows.append(
            {
                "config": cfg.key,
                "seed": seed,
                "progress": float(lg.ego_frenet[-1, 0] - lg.ego_frenet[0, 0]),
                "collision_samples": int(np.count_nonzero(lg.collision)),
                "qp_iter_mean": float(np.mean(lg.qp_iter)),
                "warm_at_cap": int(np.count_nonzero(it >= cap)),
                "warm_qps": int(it.size),
                "statuses": [qp_status_name(s) for s in np.asarray(lg.qp_status).tolist()],
            }
        )
    return rows


def figures(rows: list[dict], base: list[dict] | None) -> dict:
    """One variant's figures over all its runs (differences against the baseline's runs, matched by config/seed)."""
    prog = np.array([r["progress"] for r in rows])
    names, counts = np.unique([s for r in rows for s in r["statuses"]], return_counts=True)
    out = {
        "runs": len(rows),
        "progress_mean": float(prog.mean()),
        "collision_samples": int(sum(r["collision_samples"] for r in rows)),
        "qp_iter_mean": float(np.mean([r["qp_iter_mean"] for r in rows])),
        "warm_at_cap_share": sum(r["warm_at_cap"] for r in rows) / max(1, sum(r["warm_qps"] for r in rows)),
        "qp_status_counts": {str(k): int(v) for k, v in zip(names, counts)},
    }
    if base is not None:
        p0 = np.array([r["progress"] for r in base])
        out["progress_diff_pct"] = float(100.0 * (prog.mean() - p0.mean()) / p0.mean())
        out["worst_seed_pct"] = float(np.max(np.abs(100.0 * (prog - p0) / p0)))
        per_cfg = {}
        for key in dict.fromkeys(r["config"] for r in rows):
            idx = [i for i, r in enumerate(rows) if r["config"] == key]
            per_cfg[key] = float(100.0 * (prog[idx].mean() - p0[idx].mean()) / p0[idx].mean())
        out["progress_diff_pct_per_config"] = per_cfg
        out["new_collision_runs"] = sum(
            1 for r, b in zip(rows, base) if r["collision_samples"] > 0 and b["collision_samples"] == 0
        )
    return out


def line(label: str, f: dict) -> str:
    """One printed line of a variant's figures."""
    diff = "baseline" if "progress_diff_pct" not in f else f"{f['progress_diff_pct']:+.3f} %"
    extra = ""
    if "progress_diff_pct_per_config" in f:
        worst = min(f["progress_diff_pct_per_config"].items(), key=lambda kv: kv[1])
        extra = f"  worst config {worst[0]} {worst[1]:+.3f} %  worst seed {f['worst_seed_pct']:.2f} %"
        extra += f"  new collision runs {f['new_collision_runs']}"
    st = ", ".join(f"{k.removeprefix('QP_').lower()} {v}" for k, v in f["qp_status_counts"].items())
    return (
        f"{label:22s} progress {f['progress_mean']:8.2f} m {diff:>10s}  QP iter {f['qp_iter_mean']:6.2f}  "
        f"at cap {100 * f['warm_at_cap_share']:5.1f} %  collision samples {f['collision_samples']}{extra}  [{st}]"
    )


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("variants", nargs="+")
    ap.add_argument("--seeds", type=int, default=20)
    ap.add_argument("--samples", type=int, default=200)
    ap.add_argument("--configs", default="", help="comma-separated parts of the configuration keys to keep")
    ap.add_argument("--scenario", choices=("truck", "car"), default="truck")
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--out", type=Path, default=Path("results/osqp_settings.json"))
    a = ap.parse_args()
    parts = [p for p in a.configs.split(",") if p]
    grid = paper_grid(scenarios=(a.scenario,), backend="osqp")
    cfgs = [c for c in grid if not parts or any(p in c.key for p in parts)]
    variants = [parse_variant(v) for v in a.variants]
    results: dict[str, dict] = {}
    base = None
    with ProcessPoolExecutor(a.jobs) as pool:
        for label, over in variants:
            jobs = [(c, label, over, a.seeds, a.samples) for c in cfgs]
            rows = [r for rs in pool.map(run_config, jobs) for r in rs]
            f = figures(rows, base)
            base = rows if base is None else base
            results[label] = {"options": over, "figures": f, "rows": rows}
            print(line(label, f), flush=True)
            for key, d in f.get("progress_diff_pct_per_config", {}).items():
                print(f"    {key:32s} {d:+.3f} %")
            a.out.parent.mkdir(parents=True, exist_ok=True)  # after every variant: a long run keeps what it has
            a.out.write_text(json.dumps({"seeds": a.seeds, "samples": a.samples, "variants": results}, indent=1) + "\n")
    print(f"written {a.out}")


if __name__ == "__main__":
    main()
