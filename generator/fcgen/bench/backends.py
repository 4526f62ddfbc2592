"""``fcgen bench --backends``: one folder's problem solved by several QP backends (OSQP real-time, OSQP converged,
the IPM) on the same closed loops, built and run one after the other."""

from __future__ import annotations

import platform
from typing import Any

import numpy as np

from ..build import build
from ..codegen.generate import generate
from ..csolver import CSolver
from ..ocp import build_ocp
from ..sim.closedloop import run_closed_loop
from ..sim.scenario import make_scenario
from ..solver_folder import FolderLike, as_folder, read_folder
from ..verify import infer_scenario
from .host import _makefile_cflags, aggregate

BACKEND_VARIANTS = ("osqp", "osqp-converged", "ipm")
"""``--backends`` names: OSQP's real-time mode (QpOptions()), OSQP converged (QpOptions.converged()), the IPM."""


def parse_backends(text: str) -> list[str]:
    """The variants of a ``--backends`` list (comma-separated names of ``BACKEND_VARIANTS``); one-line error else."""
    variants = [v.strip() for v in text.split(",") if v.strip()]
    bad = [v for v in variants if v not in BACKEND_VARIANTS]
    if bad or not variants:
        raise ValueError(
            f"--backends: {', '.join(bad) or 'empty'} invalid; allowed a comma list of {', '.join(BACKEND_VARIANTS)}"
        )
    return variants


def variant_qp(variant: str, own):
    """The QpOptions of a ``--backends`` variant; a variant of the folder's own backend keeps its settings."""
    import dataclasses

    from ..dsl import QpOptions

    if variant == "osqp":
        return own if own.backend == "osqp" and own.max_iter < 1000 else QpOptions()
    if variant == "osqp-converged":
        return QpOptions.converged()
    if variant == "ipm":
        return own if own.backend == "ipm" else dataclasses.replace(QpOptions(), backend="ipm")
    raise ValueError(f"backends: {variant!r} is not a variant; allowed: {', '.join(BACKEND_VARIANTS)}")


def bench_backends(
    folder: FolderLike,
    variants: list[str],
    scenario: str | None = None,
    seeds: int = 3,
    samples: int = 200,
    cc: str | None = None,
    cflags: str | None = None,
    progress: bool = False,
    clock: str = "wall",
) -> dict:
    """One run, several QP backends: the folder's problem generated once per variant (``<dir>/build/variants``),
    built with the same flags, then per seed one closed loop of each variant in turn (alternating, so machine load
    is shared alike). Ratios against the first variant's median time per RTI."""
    import dataclasses

    folder = as_folder(folder)
    pb, gen_dir = folder.problem, folder.path
    scenario = scenario or infer_scenario(pb)
    if not variants:
        raise ValueError("backends: give at least one variant")
    tags = {"osqp": "rt", "osqp-converged": "cv", "ipm": "ipm"}
    solvers, ram, libs = {}, {}, {}
    for v in variants:
        qp = variant_qp(v, pb.qp)
        pv = dataclasses.replace(pb, name=f"{pb.name}_{tags[v]}", qp=qp)
        out = gen_dir / "build" / "variants" / v
        info = generate(pv, out)
        variant = read_folder(info.out_dir)
        libs[v] = build(variant, verify=False, cc=cc, cflags=cflags)
        solvers[v] = CSolver(libs[v], clock=clock, folder=variant)
        ram[v] = variant.sizes["WORKSPACE_BYTES"]
        assert info.workspace_bytes == ram[v]
    ocp = build_ocp(pb)
    logs: dict[str, list] = {v: [] for v in variants}
    for seed in range(seeds):
        sc = make_scenario(scenario, seed, n_opp=pb.opponents.count, samples=samples, dt=pb.horizon.dt)
        for v in variants:
            if solvers[v].init() != 0:
                raise RuntimeError(f"{v}: init() failed")
            logs[v].append(run_closed_loop(pb, sc, controller=solvers[v], ocp=ocp, progress=progress))
    res: dict[str, Any] = {
        "format": "fcgen-bench-backends/1",
        "problem": pb.name,
        "gen_dir": str(gen_dir),
        "scenario": scenario,
        "seeds": list(range(seeds)),
        "samples": samples,
        "variants": list(variants),
        "build": {"cc": cc, "cflags": cflags if cflags is not None else _makefile_cflags(gen_dir)},
        "clock": clock,
        "host": {"machine": platform.machine(), "processor": platform.processor()},
        "results": {},
    }
    base = variants[0]
    for v in variants:
        agg = aggregate(logs[v])
        qs = np.concatenate([lg.qp_status for lg in logs[v]])
        agg["qp_solved_fraction"] = float(np.mean(qs == 1))
        agg["static_ram_bytes"] = ram[v]
        agg["qp"] = dataclasses.asdict(variant_qp(v, pb.qp))
        res["results"][v] = agg
    t0 = res["results"][base]["time_ms"]["total"]["median"]
    for v in variants:
        r = res["results"][v]
        r["speedup_vs_" + base] = t0 / r["time_ms"]["total"]["median"]
        if "osqp-converged" in variants:
            p_ref = res["results"]["osqp-converged"]["quality"]["progress_mean"]
            r["progress_vs_converged_pct"] = 100.0 * (r["quality"]["progress_mean"] - p_ref) / p_ref
    return res


def format_backends(res: dict) -> str:
    """A text table of ``bench_backends`` results."""
    base = res["variants"][0]
    lines = [
        f"bench {res['problem']}: {res['scenario']} scenario, seeds {res['seeds'][0]}..{res['seeds'][-1]}, "
        f"{res['samples']} samples each, backends alternated per seed; CFLAGS {res['build']['cflags']}; "
        f"{res['clock']} clock"
    ]
    hdr = (
        "backend",
        "median ms",
        "p99 ms",
        "max ms",
        "prep med",
        "fb med",
        f"x vs {base}",
        "QP iter mean/max",
        "QP solved",
        "progress m",
        "vs converged",
        "collisions",
        "static RAM",
    )
    rows = [hdr]
    for v in res["variants"]:
        r = res["results"][v]
        t = r["time_ms"]
        pc = r.get("progress_vs_converged_pct")
        rows.append(
            (
                v,
                f"{t['total']['median']:.3f}",
                f"{t['total']['p99']:.3f}",
                f"{t['total']['max']:.3f}",
                f"{t['prepare']['median']:.3f}",
                f"{t['feedback']['median']:.3f}",
                f"{r['speedup_vs_' + base]:.2f}",
                f"{r['qp_iter']['mean']:.1f}/{r['qp_iter']['max']}",
                f"{100 * r['qp_solved_fraction']:.1f} %",
                f"{r['quality']['progress_mean']:.2f}",
                "-" if pc is None else f"{pc:+.3f} %",
                str(r["quality"]["collision_samples"]),
                f"{r['static_ram_bytes'] / 1024:.1f} KiB",
            )
        )
    w = [max(len(x[i]) for x in rows) for i in range(len(hdr))]
    for i, x in enumerate(rows):
        lines.append("  ".join(s.ljust(w[j]) if j == 0 else s.rjust(w[j]) for j, s in enumerate(x)))
        if i == 0:
            lines.append("  ".join("-" * n for n in w))
    return "\n".join(lines)
