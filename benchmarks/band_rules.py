"""The solver's lateral band on CommonRoad scenarios (``fcgen.commonroad.band.BAND_RULES``): the road's band as a hard
bound (``road``), with the way back (``road_back``), the lanes in use with the way back (``lanes``, the default); per
scenario, traffic mode and rule the collisions (fcgen's check, responsibility), road departures (the drivability
checker; after an on-road start and starts off the road), goal reached, samples without a solution and samples whose
band the way back widened.

    python benchmarks/band_rules.py DIR_OR_XML... [--problem car_lifted_ellipse_ipm_safe] [--rules road,lanes] \\
        [--traffic recorded,reactive] [--plant model|ks|st|std|mb] [--road-bound corners|rear_axle] \\
        [--out results/band_rules.json]

The compiled C of the problem (built into ``.fcgen-cache/solvers``); the criticality measures are left out (they do
not depend on the band and take most of a run's time). Prints a Markdown table (sums per traffic mode and rule) and
writes the per-run rows (JSON) to ``--out``. Runs one after another: use ``nice`` on a shared machine.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import subprocess
import time
from pathlib import Path

import numpy as np


def _row(sc, run, traffic: str, rule: str, cpu: float) -> dict:
    cr = run.log.meta["extra"]["commonroad"]
    dep = run.checker.get("departure_step")
    return {
        "scenario": sc.name,
        "traffic": traffic,
        "band": rule,
        "samples": len(run.log.ego_frenet) - 1,
        "collision": bool(run.fcgen["collision"]),
        "collision_checker": bool(run.checker["collision"]),
        "responsibility": run.responsibility,
        "departure": bool(run.checker["road_departure"]),
        "start_off_road": dep == 0,
        "departure_step": dep,
        "departure_again_step": run.checker.get("departure_again_step"),
        "goal_reached": bool(cr["goal"].get("reached")),
        "unsolved": int(cr["unsolved"]["samples"]),
        "way_back": len(cr["band"]["way_back_samples"]),
        "lane_changes": len(cr["lane_changes"]) - 1,
        "max_abs_a_lat": float(np.max(np.abs(run.log.a_lat))),
        "cpu_s": cpu,
    }


def runs(
    files: list[Path], problem: str, rules: list[str], modes: list[str], cache: str, plant: str, road_bound: str
) -> list[dict]:
    import fcgen.commonroad.criticality as crit
    from fcgen.campaign.commonroad import load_for
    from fcgen.campaign.solvers import ensure_solver
    from fcgen.commonroad import ScenarioRefused
    from fcgen.csolver import CSolver
    from fcgen.presets import preset
    from fcgen.sim.commonroad_run import run_commonroad
    from fcgen.sim.plants import PlantSpec

    crit.criticality = lambda *a, **k: {"error": "left out (benchmarks/band_rules.py)", "series": {}}
    pb = preset(problem)
    pb = pb.with_(bounds=dataclasses.replace(pb.bounds, road_bound=road_bound))
    cs = CSolver(str(ensure_solver(pb, cache)))
    rows = []
    for f in files:
        try:
            sc = load_for(pb, f)
        except ScenarioRefused as exc:
            rows.append({"scenario": f.stem, "refused": str(exc)})
            continue
        for traffic in modes:
            for rule in rules:
                cs.init()
                t0 = time.process_time()
                run = run_commonroad(pb, sc, controller=cs, traffic=traffic, band=rule, plant=PlantSpec(plant))
                row = _row(sc, run, traffic, rule, time.process_time() - t0)
                rows.append({**row, "plant": plant, "road_bound": road_bound})
                print(json.dumps(rows[-1]), flush=True)
    return rows


def markdown(rows: list[dict], rules: list[str], modes: list[str]) -> str:
    lines = [
        "| traffic | band | runs | collisions (ego into opponent) | departures after an on-road start | starts off "
        "the road | goal reached | samples without a solution (runs) | samples the way back widened |",
        "|---|---|---|---|---|---|---|---|---|",
    ]
    for traffic in modes:
        for rule in rules:
            rs = [r for r in rows if r.get("band") == rule and r.get("traffic") == traffic]
            if not rs:
                continue
            dep = [
                r["scenario"].replace("USA_", "").replace("_T-1", "")
                for r in rs
                if r["departure"] and not r["start_off_road"]
            ]
            lines.append(
                f"| {traffic} | {rule} | {len(rs)} | {sum(r['collision'] for r in rs)} "
                f"({sum(r['responsibility'] == 'ego_into_opponent' for r in rs)}) | {len(dep)}"
                f"{' (' + ', '.join(dep) + ')' if dep else ''} | {sum(r['start_off_road'] for r in rs)} | "
                f"{sum(r['goal_reached'] for r in rs)} | {sum(r['unsolved'] for r in rs)} "
                f"({sum(r['unsolved'] > 0 for r in rs)}) | {sum(r['way_back'] for r in rs)} |"
            )
    return "\n".join(lines) + "\n"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("paths", nargs="+")
    ap.add_argument("--problem", default="car_lifted_ellipse_ipm_safe")
    ap.add_argument("--rules", default="road,lanes")
    ap.add_argument("--traffic", default="recorded,reactive")
    ap.add_argument("--cache", default=".fcgen-cache/solvers")
    ap.add_argument("--plant", default="model", help="the plant (sim.plants.PLANT_KINDS)")
    ap.add_argument("--road-bound", default="corners", help="what the band bounds (Bounds.road_bound)")
    ap.add_argument("--out", default="results/band_rules.json")
    args = ap.parse_args()
    files: list[Path] = []
    for p in map(Path, args.paths):
        files += sorted(p.glob("*.xml")) if p.is_dir() else [p]
    rules, modes = args.rules.split(","), args.traffic.split(",")
    t0 = time.time()
    rows = runs(files, args.problem, rules, modes, str(Path(args.cache).resolve()), args.plant, args.road_bound)
    text = markdown(rows, rules, modes)
    print(text)
    commit = subprocess.run(["git", "rev-parse", "--short", "HEAD"], capture_output=True, text=True).stdout.strip()
    from fcgen import __version__

    out = Path(args.out)
    out.parent.mkdir(parents=True, exist_ok=True)
    meta = {"fcgen": __version__, "commit": commit, "problem": args.problem, "plant": args.plant}
    meta["road_bound"] = args.road_bound
    meta["wall_s"] = time.time() - t0
    out.write_text(json.dumps({"meta": meta, "markdown": text, "rows": rows}, indent=1) + "\n")
    print(f"{len(rows)} rows in {meta['wall_s']:.0f} s, written to {out}")


if __name__ == "__main__":
    main()
