"""The safe profile under plants fcgen did not write, latency, steering lag and noise (docs/plants.md): per perturbation
the colliding runs by responsibility, the plant's |a_lat| above its bound + 0.5 m/s^2, road departures, progress and
QP statuses, beside the unperturbed safe profile on the same seeds.

    python benchmarks/perturbations.py --seeds 20 [--first-seed 0] [--jobs 2] [--samples 200] \\
        [--only st,st+lat1+comp1] [--out results/perturbations.json] [--add EARLIER.json ...] \\
        [--plan-check bend_brake=0]

The compiled C of the safe presets (IPM backend; generated and built into ``.fcgen-cache/solvers``), the car and truck
scenarios, direct elimination and lifted with the ellipse. Prints a Markdown table and writes the per-run rows and
the table (JSON) to ``--out``, each run's row as it ends to ``--out`` with ``.jsonl`` (a stopped measurement keeps its
runs: ``--add`` takes that file too). ``--plan-check`` replaces fields of the safe profile's ``PlanCheck`` (a change
measured against the profile as it is). Runs are independent: use ``nice`` on a shared machine.
"""

from __future__ import annotations

import argparse
import concurrent.futures as cf
import json
import math
import multiprocessing
import subprocess
import time
from pathlib import Path

import numpy as np

from fcgen.sim.plants import DEFAULT_NOISE, PlantSpec

#: label -> (plant spec, solver delay compensation D)
PERTURBATIONS: dict[str, tuple[PlantSpec, int]] = {
    "model": (PlantSpec(), 0),
    "st": (PlantSpec(kind="st"), 0),
    "st+lat1": (PlantSpec(kind="st", latency=1), 0),
    "st+lat1+comp1": (PlantSpec(kind="st", latency=1), 1),
    "st+lat2": (PlantSpec(kind="st", latency=2), 0),
    "st+lat2+comp2": (PlantSpec(kind="st", latency=2), 2),
    "st+noise": (PlantSpec(kind="st", noise=DEFAULT_NOISE), 0),
    "st+lat1+comp1+noise+lag0.1": (PlantSpec(kind="st", latency=1, noise=DEFAULT_NOISE, steer_lag=0.1), 1),
    # the same with solvers that model the steering lag (Problem.steer_lag = 0.1 s)
    "st+lat1+comp1+noise+lag0.1+lagc": (PlantSpec(kind="st", latency=1, noise=DEFAULT_NOISE, steer_lag=0.1), 1),
    # all together with two samples of latency, compensated (with --only)
    "st+lat2+comp2+noise+lag0.1+lagc": (PlantSpec(kind="st", latency=2, noise=DEFAULT_NOISE, steer_lag=0.1), 2),
    # the latency alone, on fcgen's own plant (these and the predictions below: with --only)
    "model+lat1": (PlantSpec(latency=1), 0),
    "model+lat2": (PlantSpec(latency=2), 0),
    "model+lat2+comp2": (PlantSpec(latency=2), 2),
    # predicted traffic, with and without the obstacle margin growing with the prediction's error (c = 1)
    "model+cv": (PlantSpec(prediction="constant-velocity"), 0),
    "model+cv+pm1": (PlantSpec(prediction="constant-velocity", prediction_margin=1.0), 0),
    "model+ca": (PlantSpec(prediction="constant-acceleration"), 0),
    "model+ca+pm1": (PlantSpec(prediction="constant-acceleration", prediction_margin=1.0), 0),
    "model+cv+pm3": (PlantSpec(prediction="constant-velocity", prediction_margin=3.0), 0),
    "worst+cv": (PlantSpec(kind="st", latency=1, noise=DEFAULT_NOISE, prediction="constant-velocity"), 1),
    "worst+cv+pm1": (
        PlantSpec(kind="st", latency=1, noise=DEFAULT_NOISE, prediction="constant-velocity", prediction_margin=1.0),
        1,
    ),
    "worst+cv+pm3": (
        PlantSpec(kind="st", latency=1, noise=DEFAULT_NOISE, prediction="constant-velocity", prediction_margin=3.0),
        1,
    ),
}
#: the labels whose solvers model the plant's steering lag (Problem.steer_lag)
LAG_MODELLED = {"st+lat1+comp1+noise+lag0.1+lagc", "st+lat2+comp2+noise+lag0.1+lagc"}
#: run by default (the others with --only)
DEFAULT_LABELS = [x for x in PERTURBATIONS if not x.startswith(("model+", "worst+", "st+lat2+comp2+noise"))]
CONFIGS = [(sc, form) for sc in ("car", "truck") for form in ("direct_elimination", "lifted")]


def _config(scenario: str, formulation: str, spec: PlantSpec, delay: int):
    from fcgen.campaign.grid import Config

    return Config(scenario, formulation, "ellipse", 0, "c", "ipm", "safe", spec, delay)


def _problem(scenario: str, formulation: str, spec: PlantSpec, delay: int, plan_check: dict, lag: float = 0.0):
    """The configuration's problem, its ``PlanCheck`` fields replaced by ``plan_check``, modelling a steering lag
    ``lag`` (s; 0: none)."""
    from dataclasses import replace

    pb = _config(scenario, formulation, spec, delay).problem()
    pb = pb.with_(plan_check=replace(pb.plan_check, **plan_check)) if plan_check else pb
    return pb.with_(steer_lag=lag, name=f"{pb.name[:29]}_l") if lag else pb


def _lag(label: str) -> float:
    """The steering lag the label's solvers model (0: none)."""
    return PERTURBATIONS[label][0].steer_lag if label in LAG_MODELLED else 0.0


def build(
    scenario: str, formulation: str, delay: int, cache: str, plan_check: dict | None = None, lag: float = 0.0
) -> str:
    from fcgen.campaign.solvers import ensure_solver

    return str(ensure_solver(_problem(scenario, formulation, PlantSpec(), delay, plan_check or {}, lag), cache))


def run_one(
    label: str, scenario: str, formulation: str, seed: int, samples: int, cache: str, plan_check: dict | None = None
) -> dict:
    """One closed loop; its row of figures."""
    from fcgen.campaign.task import collision_columns
    from fcgen.csolver import CSolver
    from fcgen.sim.closedloop import run_closed_loop
    from fcgen.sim.runlog import summary
    from fcgen.sim.scenario import make_scenario

    spec, delay = PERTURBATIONS[label]
    pb = _problem(scenario, formulation, spec, delay, plan_check or {}, _lag(label))
    solver = CSolver(build(scenario, formulation, delay, cache, plan_check, _lag(label)))
    solver.init()
    sc = make_scenario(scenario, seed, n_opp=pb.opponents.count, samples=samples, dt=pb.horizon.dt)
    log = run_closed_loop(pb, sc, controller=solver, plant=spec)
    s = summary(log)
    a = np.abs(np.asarray(log.a_lat))
    n = np.abs(np.asarray(log.ego_frenet)[:, 1])
    coll = collision_columns(sc.road, log)
    am = np.abs(np.asarray(log.a_lat_model)) if log.a_lat_model is not None else a
    return {
        "perturbation": label,
        "scenario": scenario,
        "formulation": formulation,
        "seed": seed,
        "samples": samples,
        "collision": bool(np.any(log.collision)),
        "responsibility": coll["collision_responsibility"],
        "a_lat_over05": int(np.count_nonzero(a > pb.bounds.a_lat_max + 0.5)),
        "a_lat_model_over05": int(np.count_nonzero(am > pb.bounds.a_lat_max + 0.5)),
        "a_lat_states": int(a.size),
        "max_abs_a_lat": float(np.max(a)),
        "road_departure": bool(np.max(n) > pb.bounds.n_max),
        "max_abs_n": float(np.max(n)),
        "progress": float(s["progress"]),
        "qp_status_counts": s["qp_status_counts"],
        "plant_cut_samples": int(log.meta["extra"].get("plant_cut_samples", 0)),
    }


def table(rows: list[dict]) -> list[dict]:
    """Per perturbation: runs, colliding runs by responsibility, share of samples over bound + 0.5, departures,
    mean progress (and relative to the unperturbed runs of the same seeds), QP statuses."""
    base = {(r["scenario"], r["formulation"], r["seed"]): r["progress"] for r in rows if r["perturbation"] == "model"}
    out = []
    for label in PERTURBATIONS:
        rs = [r for r in rows if r["perturbation"] == label]
        if not rs:
            continue
        resp: dict[str, int] = {}
        for r in rs:
            if r["collision"]:
                resp[r["responsibility"] or "unknown"] = resp.get(r["responsibility"] or "unknown", 0) + 1
        status: dict[str, int] = {}
        for r in rs:
            for k, v in r["qp_status_counts"].items():
                status[k] = status.get(k, 0) + v
        pairs = [
            (r["progress"], base[(r["scenario"], r["formulation"], r["seed"])])
            for r in rs
            if (r["scenario"], r["formulation"], r["seed"]) in base
        ]
        out.append(
            {
                "perturbation": label,
                "runs": len(rs),
                "colliding": sum(r["collision"] for r in rs),
                "ego_into_opponent": resp.get("ego_into_opponent", 0),
                "responsibility": resp,
                "a_lat_over05_pct": 100.0 * sum(r["a_lat_over05"] for r in rs) / sum(r["a_lat_states"] for r in rs),
                "a_lat_model_over05_pct": 100.0
                * sum(r["a_lat_model_over05"] for r in rs)
                / sum(r["a_lat_states"] for r in rs),
                "max_abs_a_lat": max(r["max_abs_a_lat"] for r in rs),
                "road_departures": sum(r["road_departure"] for r in rs),
                "progress_mean": float(np.mean([r["progress"] for r in rs])),
                "progress_vs_model_pct": 100.0 * (sum(p for p, _ in pairs) / sum(b for _, b in pairs) - 1.0)
                if pairs
                else math.nan,
                "qp_status": status,
                "plant_cut_samples": sum(r["plant_cut_samples"] for r in rs),
            }
        )
    return out


def markdown(tab: list[dict]) -> str:
    lines = [
        "| perturbation | runs | colliding (ego into opponent) | plant abs(a_lat) > bound + 0.5 | model formula > "
        "bound + 0.5 | largest abs(a_lat) | road departures | progress vs unperturbed | QP statuses |",
        "|---|---|---|---|---|---|---|---|---|",
    ]
    for t in tab:
        st = ", ".join(f"{k} {v}" for k, v in sorted(t["qp_status"].items()))
        lines.append(
            f"| {t['perturbation']} | {t['runs']} | {t['colliding']} ({t['ego_into_opponent']}) | "
            f"{t['a_lat_over05_pct']:.2f} % | {t['a_lat_model_over05_pct']:.2f} % | {t['max_abs_a_lat']:.2f} | "
            f"{t['road_departures']} | {t['progress_vs_model_pct']:+.2f} % | {st} |"
        )
    return "\n".join(lines) + "\n"


def _field_value(text: str) -> float | bool:
    """A ``--plan-check`` value: true or false (the boolean fields), else a number."""
    return {"true": True, "false": False}[text.lower()] if text.lower() in ("true", "false") else float(text)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--seeds", type=int, default=20)
    ap.add_argument("--first-seed", type=int, default=0)
    ap.add_argument("--samples", type=int, default=200)
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--only", default="", help="comma-separated perturbation labels (default: all)")
    ap.add_argument("--cache", default=".fcgen-cache/solvers")
    ap.add_argument("--out", default="results/perturbations.json")
    ap.add_argument("--add", nargs="*", default=[], help="results files (.json or .jsonl) of other runs to merge in")
    ap.add_argument(
        "--plan-check", default="", help="FIELD=VALUE,... replacing the safe PlanCheck's (numbers, true, false)"
    )
    args = ap.parse_args()
    try:
        plan_check = {k: _field_value(v) for k, v in (x.split("=") for x in args.plan_check.split(",") if x)}
    except ValueError:
        ap.error(
            f"--plan-check: {args.plan_check!r} is invalid: allowed FIELD=VALUE,... "
            "(e.g. bend_brake=0,brake_memory=false)"
        )
    labels = [x for x in args.only.split(",") if x] or DEFAULT_LABELS
    if "model" not in labels and not args.add:  # the unperturbed runs of the same seeds (or from an --add file)
        labels.insert(0, "model")
    unknown = [x for x in labels if x not in PERTURBATIONS]
    if unknown:
        ap.error(f"--only: {unknown} is invalid: allowed {', '.join(PERTURBATIONS)}")
    cache = str(Path(args.cache).resolve())
    seeds = range(args.first_seed, args.first_seed + args.seeds)
    t0 = time.time()
    ctx = multiprocessing.get_context("spawn")
    with cf.ProcessPoolExecutor(args.jobs, mp_context=ctx) as ex:
        delays = sorted({(PERTURBATIONS[x][1], _lag(x)) for x in labels})
        for f in [ex.submit(build, sc, form, d, cache, plan_check, g) for sc, form in CONFIGS for d, g in delays]:
            f.result()
        futs = [
            ex.submit(run_one, label, sc, form, seed, args.samples, cache, plan_check)
            for seed in seeds
            for sc, form in CONFIGS
            for label in labels
        ]
        out = Path(args.out)
        out.parent.mkdir(parents=True, exist_ok=True)
        rows = []
        with out.with_suffix(".jsonl").open("w") as runs:
            for f in cf.as_completed(futs):
                rows.append(f.result())
                runs.write(json.dumps(rows[-1]) + "\n")
                runs.flush()
    for extra in map(Path, args.add):  # earlier runs of other seeds
        text = extra.read_text()
        rows += [json.loads(x) for x in text.splitlines()] if extra.suffix == ".jsonl" else json.loads(text)["rows"]
    tab = table(rows)
    text = markdown(tab)
    print(text)
    commit = subprocess.run(["git", "rev-parse", "--short", "HEAD"], capture_output=True, text=True).stdout.strip()
    from fcgen import __version__

    meta = {
        "fcgen": __version__,
        "commit": commit,
        "seeds": sorted({r["seed"] for r in rows}),
        "samples": args.samples,
        "configs": [f"{sc}/{form}/EL/c/ipm/safe" for sc, form in CONFIGS],
        "plan_check": plan_check,
        "wall_s": time.time() - t0,
    }
    out.write_text(json.dumps({"meta": meta, "table": tab, "markdown": text, "rows": rows}, indent=1) + "\n")
    print(f"{len(rows)} runs in {meta['wall_s']:.0f} s, written to {out}")


if __name__ == "__main__":
    main()
