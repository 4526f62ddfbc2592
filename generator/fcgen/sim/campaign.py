"""Randomized campaigns: many seeds per (formulation, obstacle model), aggregated like the paper's Table III."""
from __future__ import annotations

import numpy as np

from ..ocp import build_ocp
from ..presets import paper_problem
from .closedloop import run_closed_loop
from .runlog import summary
from .scenario import make_scenario


def run_campaign(scenario: str, formulations: list[str], obstacles: list[str], seeds: int, samples: int = 200,
                 circles: int | None = None, progress: bool = False) -> dict:
    """Per configuration: progress, collisions and solver time over seeds 0..seeds-1 (Python reference)."""
    out = {"scenario": scenario, "seeds": seeds, "samples": samples, "configs": []}
    for ob in obstacles:
        for form in formulations:
            pb = paper_problem(scenario, form, ob, circles)
            ocp = build_ocp(pb)
            seeds_it = range(seeds)
            if progress:
                from tqdm import tqdm
                seeds_it = tqdm(seeds_it, desc=f"{scenario} {form} {ob}", unit="run")
            prog, coll, it_mean, slack, alat = [], [], [], [], []
            times = []
            for seed in seeds_it:
                log = run_closed_loop(pb, make_scenario(scenario, seed, samples=samples), ocp=ocp)
                s = summary(log)
                prog.append(s["progress"])
                coll.append(s["n_collision_samples"])
                times.append(log.time_total)
                it_mean.append(s["qp_iter_mean"])
                slack.append(s["max_slack"])
                alat.append(s["max_abs_a_lat"])
            t = np.concatenate(times) * 1e3
            out["configs"].append({
                "formulation": form, "obstacles": ob, "problem": pb.name,
                "progress": prog, "collision_samples": coll,
                "runs_with_collision": int(np.count_nonzero(coll)),
                "progress_mean": float(np.mean(prog)), "progress_std": float(np.std(prog)),
                "time_ms_mean": float(np.mean(t)), "time_ms_std": float(np.std(t)),
                "time_ms_median": float(np.median(t)), "time_ms_p99": float(np.percentile(t, 99)),
                "qp_iter_mean": float(np.mean(it_mean)), "max_slack": float(np.max(slack)),
                "max_abs_a_lat": float(np.max(alat)),
            })
    return out


def format_table(res: dict) -> str:
    """Markdown table: time (mean +- std, % vs conventional), progress, collisions."""
    rows = ["| obstacles | formulation | time ms (mean ± std) | vs conv. | progress m (mean ± std) | runs with collision "
            "| QP iter mean | max slack |", "|---|---|---|---|---|---|---|---|"]
    base = {c["obstacles"]: c["time_ms_mean"] for c in res["configs"] if c["formulation"] == "conventional"}
    for c in res["configs"]:
        ref = base.get(c["obstacles"])
        rel = f"{100 * (c['time_ms_mean'] / ref - 1):+.1f}%" if ref else "-"
        rows.append(f"| {c['obstacles']} | {c['formulation']} | {c['time_ms_mean']:.2f} ± {c['time_ms_std']:.2f} | {rel} "
                    f"| {c['progress_mean']:.1f} ± {c['progress_std']:.1f} | {c['runs_with_collision']}/{res['seeds']} "
                    f"| {c['qp_iter_mean']:.0f} | {c['max_slack']:.3g} |")
    return "\n".join(rows)
