"""Where a campaign run's time goes, per part: the solver, the closed loop's Python, the run log, the row.

    python benchmarks/campaign_parts.py [--configs truck/lifted/EL,truck/lifted/HP,car/conventional/C3]
        [--backend ipm] [--profile paper] [--seeds 4] [--cache .fcgen-cache/solvers] [--out FILE]

Each configuration's C solver is built as the campaign builds it (``fcgen.campaign.task.build_solver``), then
``run_task`` (what a campaign worker runs) is called on seeds 0..SEEDS-1 under cProfile, one process. Per part the
cumulative CPU time (cProfile's ``cumtime``) per run: the solver (its own RTI time, from the run log's clock) and the
Python around its C call, the plant, the opponents' predictions, the run log (Cartesian poses, collisions, a_lat),
the scenario and the row (summary, collision kind). cProfile adds a little to every Python call (so the Python parts
are upper bounds); the solver's own time is its clock's. Printed: the table; written: JSON.
"""

from __future__ import annotations

import argparse
import cProfile
import json
import pstats
import time
from pathlib import Path

from fcgen.campaign.grid import make_tasks, paper_grid
from fcgen.campaign.task import build_solver, run_task

PARTS: dict[str, tuple[str, str]] = {
    "run_task (all)": ("task.py", "run_task"),
    "scenario (make_scenario)": ("scenario.py", "make_scenario"),
    "closed loop (run_closed_loop)": ("closedloop.py", "run_closed_loop"),
    "  solver call (C + ctypes wrapper)": ("csolver.py", "step"),
    "  plant step": ("closedloop.py", "step"),
    "  opponents' predictions (table + horizon)": ("scenario.py", "horizon"),
    "  opponents' table (OpponentParams)": ("scenario.py", "__init__"),
    "  run log (_run_log: poses, collisions, a_lat)": ("closedloop.py", "_run_log"),
    "row (make_row: summary)": ("task.py", "make_row"),
    "collision kind (collision_columns)": ("task.py", "collision_columns"),
}
"""part -> (file name, function name) whose cumulative time it is."""


def cumtimes(prof: cProfile.Profile) -> dict[tuple[str, str], float]:
    """(file name, function) -> cumulative seconds, summed over functions of the same name in the same file."""
    out: dict[tuple[str, str], float] = {}
    for (file, _line, fn), (_cc, _nc, _tt, ct, _callers) in pstats.Stats(prof).stats.items():  # type: ignore[attr-defined]
        key = (Path(file).name, fn)
        out[key] = out.get(key, 0.0) + ct
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--configs", default="truck/lifted/EL,truck/lifted/HP,car/conventional/C3")
    ap.add_argument("--backend", default="ipm")
    ap.add_argument("--profile", default="paper")
    ap.add_argument("--seeds", type=int, default=4)
    ap.add_argument("--cache", default=".fcgen-cache/solvers")
    ap.add_argument("--out", type=Path, default=Path("results/campaign_parts.json"))
    args = ap.parse_args()
    grid = paper_grid(backend=args.backend, profile=args.profile)
    want = args.configs.split(",")
    configs = [c for c in grid if any(c.key.startswith(w + "/") for w in want)]
    cache = str(Path(args.cache).resolve())
    results = {}
    for cfg in configs:
        build_solver(cfg, cache)
        tasks = make_tasks([cfg], range(args.seeds), 200, cache, "cpu")
        run_task(tasks[0])  # the solver loaded, caches warm
        prof = cProfile.Profile(time.thread_time)  # CPU time: the machine's load does not count
        solver_s = 0.0
        prof.enable()
        for t in tasks:
            row = prof.runcall(run_task, t)
            solver_s += 1e-3 * sum(row["time_rti_ms"])
        prof.disable()
        ct = cumtimes(prof)
        n = len(tasks)
        parts = {p: ct.get(key, 0.0) / n for p, key in PARTS.items()}
        parts["  of the solver call: the solver's own RTI time"] = solver_s / n
        results[cfg.key] = parts
        total = parts["run_task (all)"]
        print(f"{cfg.key} ({args.profile}), {n} runs x 200 samples: ms per run (share of run_task)")
        for p, s in parts.items():
            print(f"  {p:52s} {1e3 * s:8.2f} ms  {100 * s / total:5.1f} %")
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(json.dumps({"seeds": args.seeds, "profile": args.profile, "configs": results}, indent=2) + "\n")
    print(f"results written to {args.out}")


if __name__ == "__main__":
    main()
