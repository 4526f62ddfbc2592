"""``fcgen bench --target``: instructions per prepare and per feedback of a solver on an emulated Cortex-M target
(QEMU -icount: independent of the machine's load)."""

from __future__ import annotations

import time

import numpy as np

from ..sim.harness import firmware_sim
from ..solver_folder import FolderLike, as_folder
from ..targets import TARGETS, get_target
from ..verify import infer_scenario
from .host import aggregate


def _instr_stats(x: np.ndarray) -> dict[str, float]:
    return {"median": float(np.median(x)), "max": float(np.max(x)), "min": float(np.min(x)), "mean": float(np.mean(x))}


def bench_target(
    folder: FolderLike,
    target: str,
    scenario: str | None = None,
    seeds: int = 1,
    samples: int = 50,
    timeout: float | None = None,
    cflags: str | None = None,
) -> dict:
    """Instructions per prepare and per feedback on an emulated target (``fcgen bench --target``).

    Runs the bare-metal closed loop (``firmware_sim`` image) under QEMU with ``-icount shift=0``: every
    instruction advances the virtual clock by 1 ns, the harness's clock hook reads SysTick, so the solver's own
    ``time_prepare`` / ``time_feedback`` times 1e9 are instruction counts (granularity: one SysTick period),
    independent of the machine's load.
    """
    tgt = get_target(target)
    if not tgt.bare_metal:
        raise ValueError(
            f"--target {target}: instruction counts need an emulated target "
            f"({', '.join(t for t, v in TARGETS.items() if v.bare_metal)})"
        )
    folder = as_folder(folder)
    name, pb, gen_dir = folder.name, folder.problem, folder.path
    scenario = scenario or infer_scenario(pb)
    logs = []
    t0 = time.perf_counter()
    for seed in range(seeds):
        out = gen_dir / tgt.build_subdir / "bench" / f"run_{scenario}_seed{seed}_{samples}.json"
        logs.append(firmware_sim(folder, scenario, seed, samples, out, target=target, timeout=timeout, cflags=cflags))
    wall = time.perf_counter() - t0
    scale = tgt.instructions_per_second
    tp = np.round(np.concatenate([lg.time_prepare for lg in logs]) * scale)
    tf = np.round(np.concatenate([lg.time_feedback for lg in logs]) * scale)
    qi = np.concatenate([lg.qp_iter for lg in logs])
    agg = aggregate(logs)
    return {
        "format": "fcgen-bench-target/1",
        "solver": name,
        "gen_dir": str(gen_dir),
        "target": tgt.name,
        "target_description": tgt.description,
        "qemu_machine": tgt.qemu_machine,
        "cflags": tgt.cflags(cflags if cflags is not None else "-O2"),
        "problem": pb.name,
        "scenario": scenario,
        "seeds": list(range(seeds)),
        "samples": samples,
        "granularity_instructions": scale / tgt.systick_hz,
        "instructions": {"prepare": _instr_stats(tp), "feedback": _instr_stats(tf), "total": _instr_stats(tp + tf)},
        "feedback_per_qp_iteration": float(np.median(tf / np.maximum(qi, 1))),
        "qp_iter": agg["qp_iter"],
        "qp_status_counts": agg["qp_status_counts"],
        "quality": agg["quality"],
        "wall_seconds": wall,
    }


def format_bench_target(res: dict) -> str:
    """A text table of ``bench_target`` results (millions of instructions)."""
    lines = [
        f"bench {res['solver']} on {res['target']} ({res['target_description']}), QEMU -icount shift=0: "
        f"{res['scenario']} scenario, seeds {res['seeds'][0]}..{res['seeds'][-1]}, {res['samples']} samples "
        f"each; granularity {res['granularity_instructions']:.0f} instructions"
    ]
    rows = [("phase", "median Minstr", "max Minstr", "mean Minstr")]
    for k in ("prepare", "feedback", "total"):
        s = res["instructions"][k]
        rows.append((k, f"{s['median'] / 1e6:.3f}", f"{s['max'] / 1e6:.3f}", f"{s['mean'] / 1e6:.3f}"))
    w = [max(len(r[i]) for r in rows) for i in range(4)]
    for i, r in enumerate(rows):
        lines.append("  ".join(c.ljust(w[j]) if j == 0 else c.rjust(w[j]) for j, c in enumerate(r)))
        if i == 0:
            lines.append("  ".join("-" * v for v in w))
    q = res["quality"]
    lines.append(
        f"feedback per QP iteration (median): {res['feedback_per_qp_iteration'] / 1e6:.3f} Minstr | "
        f"QP iterations mean {res['qp_iter']['mean']:.1f}, max {res['qp_iter']['max']} | QP status "
        + ", ".join(f"{k} {v}" for k, v in res["qp_status_counts"].items())
        + f" | progress {q['progress_mean']:.2f} m, collision samples {q['collision_samples']}"
    )
    return "\n".join(lines)
