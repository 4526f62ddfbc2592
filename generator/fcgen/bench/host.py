"""Closed-loop benchmark of a generated solver (``fcgen bench``): the optimized C build vs the Python reference.

Per seed one closed loop (Python plant, C controller from the default optimized build, timed with the library's
host clock hook: ``status.time_prepare`` / ``time_feedback``) and, optionally, the same run with the Python
reference controller (timed with ``time.perf_counter`` inside ``RtiSolver``). Per controller: per-sample prepare,
feedback and total time (median, p99, max, mean; ms) over all samples of all seeds, QP iterations (mean, max),
QP status counts, and closed-loop quality per seed (progress, collision samples, max slack, max |a_lat|).
"""

from __future__ import annotations

import json
import math
import platform
import time
from pathlib import Path
from typing import Any

import numpy as np

from ..build import build
from ..csolver import CSolver
from ..ocp import build_ocp
from ..sim.closedloop import run_closed_loop
from ..sim.runlog import fmt_slack, qp_status_name, summary
from ..sim.scenario import make_scenario
from ..solver_folder import FolderLike, as_folder
from ..verify import infer_scenario

TIME_KEYS = ("prepare", "feedback", "total")
STAT_KEYS = ("median", "p99", "max", "mean")


def _stats_ms(x: np.ndarray) -> dict[str, float]:
    if x.size == 0:
        return {k: math.nan for k in STAT_KEYS}
    ms = 1e3 * np.asarray(x, dtype=float)
    return {
        "median": float(np.median(ms)),
        "p99": float(np.percentile(ms, 99)),
        "max": float(np.max(ms)),
        "mean": float(np.mean(ms)),
    }


def _makefile_cflags(gen_dir: Path) -> str | None:
    """The default ``CFLAGS ?= ...`` of a generated Makefile (what a plain ``make`` uses unless $CFLAGS is set)."""
    import os
    import re

    if os.environ.get("CFLAGS"):
        return os.environ["CFLAGS"]
    mk = gen_dir / "Makefile"
    m = re.search(r"^CFLAGS \?= ?(.*)$", mk.read_text(), re.M) if mk.is_file() else None
    return m.group(1).strip() if m else None


def aggregate(logs: list) -> dict:
    """Timing, QP and quality figures over the run logs of one controller."""
    if not logs:
        return {}
    tp = np.concatenate([lg.time_prepare for lg in logs])
    tf = np.concatenate([lg.time_feedback for lg in logs])
    qi = np.concatenate([lg.qp_iter for lg in logs])
    qs = np.concatenate([lg.qp_status for lg in logs])
    counts: dict[str, int] = {}
    for code in qs.tolist():
        counts[qp_status_name(code)] = counts.get(qp_status_name(code), 0) + 1
    runs = []
    for lg in logs:
        s = summary(lg)
        runs.append(
            {
                "seed": int(lg.meta["seed"]),
                "samples": s["n_controls"],
                "progress": s["progress"],
                "collision_samples": s["n_collision_samples"],
                "max_slack": s["max_slack"],
                "max_abs_a_lat": s["max_abs_a_lat"],
                "nonzero_exit_codes": int(lg.meta["extra"].get("exit_codes_nonzero", 0)),
            }
        )

    def mean(key):
        return float(np.mean([r[key] for r in runs]))

    return {
        "runs": len(logs),
        "samples": int(tp.size),
        "time_ms": {"prepare": _stats_ms(tp), "feedback": _stats_ms(tf), "total": _stats_ms(tp + tf)},
        "qp_iter": {"mean": float(np.mean(qi)), "max": int(np.max(qi))},
        "qp_status_counts": dict(sorted(counts.items())),
        "quality": {
            "progress_mean": mean("progress"),
            "collision_samples": int(sum(r["collision_samples"] for r in runs)),
            "runs_with_collision": int(sum(r["collision_samples"] > 0 for r in runs)),
            "max_slack": max((r["max_slack"] for r in runs if r["max_slack"] is not None), default=None),
            "max_abs_a_lat": float(np.max([r["max_abs_a_lat"] for r in runs])),
            "nonzero_exit_codes": int(sum(r["nonzero_exit_codes"] for r in runs)),
        },
        "per_run": runs,
    }


def bench(
    folder: FolderLike,
    scenario: str | None = None,
    seeds: int = 3,
    samples: int = 200,
    python: bool = True,
    python_seeds: int | None = None,
    python_samples: int | None = None,
    cc: str | None = None,
    cflags: str | None = None,
    progress: bool = False,
) -> dict:
    """Benchmark a generated folder (a :class:`~.solver_folder.SolverFolder` or its path); returns the JSON-able
    results (see ``format_bench``).

    Seeds are ``0 .. seeds-1``. The Python reference runs on the first ``python_seeds`` seeds (default: all) with
    ``python_samples`` samples (default: ``samples``).
    """
    folder = as_folder(folder)
    name, pb, gen_dir = folder.name, folder.problem, folder.path
    scenario = scenario or infer_scenario(pb)
    if seeds < 1 or samples < 1:
        raise ValueError("seeds and samples must be >= 1")
    py_seeds = seeds if python_seeds is None else min(python_seeds, seeds)
    py_samples = samples if python_samples is None else python_samples
    t_build = time.perf_counter()
    lib = build(folder, verify=False, cc=cc, cflags=cflags)
    t_build = time.perf_counter() - t_build
    cs = CSolver(lib, folder=folder)
    ocp = build_ocp(pb)
    logs_c, logs_py = [], []
    wall = {"c": 0.0, "python": 0.0}
    for seed in range(seeds):
        sc = make_scenario(scenario, seed, n_opp=pb.opponents.count, samples=samples, dt=pb.horizon.dt)
        if cs.init() != 0:
            raise RuntimeError(f"{name}_init() failed")
        t0 = time.perf_counter()
        logs_c.append(run_closed_loop(pb, sc, controller=cs, ocp=ocp, progress=progress))
        wall["c"] += time.perf_counter() - t0
        if python and seed < py_seeds:
            sc_py = (
                sc
                if py_samples == samples
                else make_scenario(scenario, seed, n_opp=pb.opponents.count, samples=py_samples, dt=pb.horizon.dt)
            )
            t0 = time.perf_counter()
            logs_py.append(run_closed_loop(pb, sc_py, ocp=ocp, progress=progress))
            wall["python"] += time.perf_counter() - t0
    res: dict[str, Any] = {
        "format": "fcgen-bench/1",
        "solver": name,
        "gen_dir": str(gen_dir),
        "problem": pb.name,
        "formulation": pb.formulation.kind,
        "obstacle_model": pb.obstacles.kind,
        "scenario": scenario,
        "seeds": list(range(seeds)),
        "samples": samples,
        "build": {
            "library": str(lib),
            "variant": "optimized (default)",
            "cc": cc,
            "cflags": cflags if cflags is not None else _makefile_cflags(gen_dir),
            "build_seconds": t_build,
        },
        "host": _host(),
        "sizes": {k: cs.sizes[k] for k in ("N", "NX", "QP_N", "QP_M", "QP_NNZ_A") if k in cs.sizes},
        "c": aggregate(logs_c),
        "python": None,
        "wall_seconds": wall,
    }
    if logs_py:
        res.update(
            _python_figures(res["c"], logs_c, logs_py, same_runs=py_samples == samples, all_seeds=py_seeds == seeds)
        )
        res["python"]["seeds"] = list(range(py_seeds))
        res["python"]["samples_per_run"] = py_samples
    return res


def _host() -> dict[str, str]:
    """The machine a benchmark ran on."""
    return {
        "machine": platform.machine(),
        "processor": platform.processor(),
        "python": platform.python_version(),
        "system": platform.system(),
    }


def _python_figures(c: dict, logs_c: list, logs_py: list, same_runs: bool, all_seeds: bool) -> dict[str, Any]:
    """The Python reference's figures beside the C's (``c``: their aggregate): its aggregate, the speed-up per phase
    and, on the same runs (``same_runs``: as many samples), the largest state difference of the two closed loops."""
    py, tc = aggregate(logs_py), c["time_ms"]
    tpy = py["time_ms"]
    out: dict[str, Any] = {
        "python": py,
        "speedup_python_over_c": {
            k: tpy[k]["median"] / tc[k]["median"] if tc[k]["median"] > 0 else math.nan for k in TIME_KEYS
        },
        "python_same_runs": same_runs and all_seeds,
    }
    if same_runs:
        # the two closed loops of the same seeds: identical up to rounding (optimized build, FMA)
        diffs = [float(np.max(np.abs(a.ego_frenet - b.ego_frenet))) for a, b in zip(logs_c, logs_py)]
        out["max_abs_state_diff_c_vs_python"] = max(diffs)
    return out


def write_results(res: dict, out: Path | str) -> Path:
    """The results as JSON, written atomically (``fcgen.atomic``)."""
    from ..atomic import write_text

    return write_text(out, json.dumps(res, indent=1, sort_keys=True, default=float) + "\n")


def format_bench(res: dict) -> str:
    """A text table of ``bench`` results."""
    ctrl = [("C", res["c"])] + ([("Python", res["python"])] if res.get("python") else [])
    lines = [
        f"bench {res['solver']} ({res['formulation']}, {res['obstacle_model']}): {res['scenario']} scenario, "
        f"seeds {res['seeds'][0]}..{res['seeds'][-1]}, {res['samples']} samples each; C = optimized build"
    ]
    if res.get("python"):
        py = res["python"]
        lines[0] += f"; Python reference on seeds {py['seeds'][0]}..{py['seeds'][-1]} x {py['samples_per_run']} samples"
    hdr: tuple[str, ...] = ("controller", "phase", "median ms", "p99 ms", "max ms", "mean ms")
    rows: list[tuple[str, ...]] = [hdr]
    for label, r in ctrl:
        for k in TIME_KEYS:
            t = r["time_ms"][k]
            rows.append((label, k, f"{t['median']:.3f}", f"{t['p99']:.3f}", f"{t['max']:.3f}", f"{t['mean']:.3f}"))
    w = [max(len(x[i]) for x in rows) for i in range(len(hdr))]
    for i, x in enumerate(rows):
        lines.append("  ".join(s.ljust(w[j]) if j < 2 else s.rjust(w[j]) for j, s in enumerate(x)))
        if i == 0:
            lines.append("  ".join("-" * v for v in w))
    lines.append("")
    hdr = (
        "controller",
        "QP iter mean",
        "QP iter max",
        "QP status [samples]",
        "progress m",
        "collision samples (runs)",
        "max slack",
        "max |a_lat| m/s^2",
    )
    rows = [hdr]
    for label, r in ctrl:
        q = r["quality"]
        rows.append(
            (
                label,
                f"{r['qp_iter']['mean']:.1f}",
                str(r["qp_iter"]["max"]),
                ", ".join(f"{k} {v}" for k, v in r["qp_status_counts"].items()),
                f"{q['progress_mean']:.2f}",
                f"{q['collision_samples']} (in {q['runs_with_collision']} of {r['runs']} runs)",
                fmt_slack(q["max_slack"]),
                f"{q['max_abs_a_lat']:.2f}",
            )
        )
    w = [max(len(x[i]) for x in rows) for i in range(len(hdr))]
    for i, x in enumerate(rows):
        lines.append("  ".join(s.ljust(w[j]) if j in (0, 3) else s.rjust(w[j]) for j, s in enumerate(x)))
        if i == 0:
            lines.append("  ".join("-" * v for v in w))
    if res.get("speedup_python_over_c"):
        sp = res["speedup_python_over_c"]
        lines.append("")
        lines.append("Python / C median time: " + ", ".join(f"{k} {sp[k]:.1f}x" for k in TIME_KEYS))
    if "max_abs_state_diff_c_vs_python" in res:
        lines.append(
            f"max |state difference| C (optimized) vs Python closed loops: {res['max_abs_state_diff_c_vs_python']:.3g}"
        )
    return "\n".join(lines)
