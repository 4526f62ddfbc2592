"""A planned lane change's n_ref per stage (``fcgen.commonroad.lanes.lane_change_profile``) against the target lane's
centre at once on every stage, on CommonRoad scenarios: per scenario and variant the collisions (fcgen's check and the
drivability checker, with responsibility), road departures, goal reached, lane changes, the largest |a_lat| and the
samples whose QP failed.

    python benchmarks/lane_change_profile.py DIR_OR_XML... [--problem car_lifted_ellipse_ipm_safe] \\
        [--change-times 3,0] [--out results/lane_change_profile.json]

The compiled C of the problem (built into ``.fcgen-cache/solvers``). Prints a Markdown table (sums per variant) and
writes the per-run rows (JSON) to ``--out``. Runs one after another: use ``nice`` on a shared machine.
"""

from __future__ import annotations

import argparse
import json
import subprocess
import time
from pathlib import Path

import numpy as np


def runs(files: list[Path], problem: str, change_times: list[float], cache: str) -> list[dict]:
    from fcgen.campaign.commonroad import load_for
    from fcgen.campaign.solvers import ensure_solver
    from fcgen.commonroad import ScenarioRefused
    from fcgen.csolver import CSolver
    from fcgen.presets import preset
    from fcgen.sim.commonroad_run import run_commonroad

    pb = preset(problem)
    cs = CSolver(str(ensure_solver(pb, cache)))
    rows = []
    for f in files:
        try:
            sc = load_for(pb, f)
        except ScenarioRefused as exc:
            rows.append({"scenario": f.stem, "refused": str(exc)})
            continue
        for ct in change_times:
            cs.init()
            t0 = time.process_time()
            run = run_commonroad(pb, sc, controller=cs, change_time=ct)
            cr = run.log.meta["extra"]["commonroad"]
            n = np.asarray(run.log.ego_frenet)
            rows.append(
                {
                    "scenario": sc.name,
                    "change_time": ct,
                    "samples": len(n) - 1,
                    "collision_fcgen": bool(run.fcgen["collision"]),
                    "collision_checker": bool(run.checker["collision"]),
                    "responsibility": run.responsibility,
                    "road_departure": bool(run.checker["road_departure"]),
                    "goal_reached": bool(cr["goal"].get("reached")),
                    "lane_changes": len(cr["lane_changes"]) - 1,
                    "max_abs_a_lat": float(np.max(np.abs(run.log.a_lat))),
                    "unsolved": int(cr["unsolved"].get("samples", 0)) if isinstance(cr["unsolved"], dict) else 0,
                    "cpu_s": time.process_time() - t0,
                }
            )
            print(json.dumps(rows[-1]), flush=True)
    return rows


def markdown(rows: list[dict], change_times: list[float]) -> str:
    lines = [
        "| n_ref in a lane change | runs | colliding (ego into opponent) | road departures | goal reached | lane "
        "changes | largest abs(a_lat) (median over runs) | unsolved samples |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for ct in change_times:
        rs = [r for r in rows if r.get("change_time") == ct]
        if not rs:
            continue
        label = f"per stage over {ct:g} s" if ct > 0 else "the target's centre at once"
        lines.append(
            f"| {label} | {len(rs)} | {sum(r['collision_fcgen'] for r in rs)} "
            f"({sum(r['responsibility'] == 'ego_into_opponent' for r in rs)}) | "
            f"{sum(r['road_departure'] for r in rs)} | {sum(r['goal_reached'] for r in rs)} | "
            f"{sum(r['lane_changes'] for r in rs)} | {np.median([r['max_abs_a_lat'] for r in rs]):.2f} | "
            f"{sum(r['unsolved'] for r in rs)} |"
        )
    return "\n".join(lines) + "\n"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("paths", nargs="+")
    ap.add_argument("--problem", default="car_lifted_ellipse_ipm_safe")
    ap.add_argument("--change-times", default="3,0")
    ap.add_argument("--cache", default=".fcgen-cache/solvers")
    ap.add_argument("--out", default="results/lane_change_profile.json")
    args = ap.parse_args()
    files: list[Path] = []
    for p in map(Path, args.paths):
        files += sorted(p.glob("*.xml")) if p.is_dir() else [p]
    cts = [float(x) for x in args.change_times.split(",")]
    t0 = time.time()
    rows = runs(files, args.problem, cts, str(Path(args.cache).resolve()))
    text = markdown(rows, cts)
    print(text)
    commit = subprocess.run(["git", "rev-parse", "--short", "HEAD"], capture_output=True, text=True).stdout.strip()
    from fcgen import __version__

    out = Path(args.out)
    out.parent.mkdir(parents=True, exist_ok=True)
    meta = {"fcgen": __version__, "commit": commit, "problem": args.problem, "wall_s": time.time() - t0}
    out.write_text(json.dumps({"meta": meta, "markdown": text, "rows": rows}, indent=1) + "\n")
    print(f"{len(rows)} rows in {meta['wall_s']:.0f} s, written to {out}")


if __name__ == "__main__":
    main()
