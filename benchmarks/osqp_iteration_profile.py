"""Where an OSQP RTI and one ADMM iteration go: instructions by part (callgrind, x86; docs/performance.md).

    python benchmarks/osqp_iteration_profile.py [--preset truck_lifted_ellipse] [--set max_iter=40,rho=0.2]
        [--seed 0] [--samples 60] [--cflags "-O2 -g"] [--out results/osqp_iteration_profile.json]

The preset's solver (``--set``: QpOptions fields changed, ``field=value,...``) is generated and built into
``.fcgen-cache/osqp_profile`` with CFLAGS (OSQP's library keeps its ``-O3`` after them: the build's own flags; ``-g``
for the symbols), its C closed loop (``fcgen.sim.harness.firmware_sim``) runs on the seed, then twice under
valgrind's callgrind: the whole run (inclusive instructions of ``<name>_prepare``, ``<name>_feedback`` and OSQP's
calls in them, per RTI), with ``--toggle-collect`` on ``osqp_solve`` (every function's own instructions inside
the solves, per ADMM iteration of the run, grouped into the parts of ``PARTS``) and on ``<name>_prepare`` (per RTI,
grouped into ``PREPARE_PARTS``). Instruction counts do not depend on
the machine's load. Printed: the tables; written: JSON.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import re
import subprocess
import tempfile
from collections import defaultdict
from pathlib import Path

import numpy as np

from fcgen.campaign.solvers import ensure_solver
from fcgen.presets import preset
from fcgen.sim.harness import firmware_sim

CACHE = Path(__file__).resolve().parent.parent / ".fcgen-cache" / "osqp_profile"

PARTS: dict[str, tuple[str, ...]] = {
    "KKT solve: forward substitution L (QDLDL_Lsolve)": ("QDLDL_Lsolve",),
    "KKT solve: backward substitution L' (QDLDL_Ltsolve)": ("QDLDL_Ltsolve",),
    "KKT solve: D, permutations, rho terms": ("QDLDL_solve", "solve_linsys_qdldl", "permute_x", "permutet_x"),
    "ADMM vector updates (x, z, y, rhs)": (
        "update_xz_tilde",
        "update_x",
        "update_z",
        "update_y",
        "compute_rhs",
        "swap_vectors",
        "OSQPVectorf_add_scaled",
        "OSQPVectorf_add_scaled3",
        "OSQPVectorf_ew_prod",
        "OSQPVectorf_ew_bound_vec",
        "OSQPVectorf_copy",
        "OSQPVectorf_plus",
        "OSQPVectorf_minus",
        "OSQPVectorf_mult_scalar",
        "OSQPVectorf_project_polar_reccone",
    ),
    "matrix-vector products (P x, A x, A' y)": ("OSQPMatrix_Axpy", "OSQPMatrix_Atxpy", "csc_Axpy", "csc_Atxpy"),
}
"""The parts of an ADMM iteration and the functions charged to them (OSQP 1.1.3's names without the solver prefix);
every other function inside ``osqp_solve`` (residuals, norms, termination and infeasibility checks, warm start,
solution copy-out) is charged to "residuals, termination checks, the rest"."""
REST = "residuals, termination checks, the rest"

PREPARE_PARTS: dict[str, tuple[str, ...]] = {
    "OSQP: numeric LDL' factorization (QDLDL_factor)": ("QDLDL_factor",),
    "OSQP: Ruiz scaling (unscale, norms, scale)": (
        "scale_data",
        "unscale_data",
        "csc_lmult_diag",
        "csc_rmult_diag",
        "csc_col_norm_inf",
        "csc_row_norm_inf",
        "OSQPMatrix_lmult_diag",
        "OSQPMatrix_rmult_diag",
        "OSQPMatrix_col_norm_inf",
        "OSQPMatrix_row_norm_inf",
        "OSQPVectorf_ew_prod",
        "OSQPVectorf_ew_sqrt",
        "OSQPVectorf_ew_reciprocal",
        "OSQPVectorf_set_scalar_if_gt",
        "OSQPVectorf_set_scalar_if_lt",
        "OSQPVectorf_set_scalar",
        "OSQPVectorf_mult_scalar",
        "OSQPVectorf_norm_inf",
        "OSQPVectorf_norm_1",
        "OSQPVectorf_mean",
        "vec_set_scalar",
        "limit_scaling_vector",
        "limit_scaling_scalar",
        "compute_inf_norm_cols_KKT",
    ),
    "OSQP: KKT values and data update": (
        "update_KKT_A",
        "update_KKT_P",
        "update_KKT_param2",
        "csc_update_values",
        "OSQPMatrix_update_values",
        "update_linsys_solver_matrices_qdldl",
        "osqp_update_data_mat",
        "osqp_update_data_vec",
    ),
}
"""The parts of a prepare charged to OSQP (names without the solver prefix); the rest of ``<name>_prepare`` (the
model's CasADi functions, the shift, the gathers, libm) is "the solver's own (linearization, shift, gathers)"."""
PREPARE_REST = "the solver's own (linearization, shift, gathers)"


def parse_set(text: str) -> dict:
    """``field=value,...`` -> {field: int | float}."""
    out: dict = {}
    for item in filter(None, text.split(",")):
        k, _, v = item.partition("=")
        out[k] = int(v) if v.lstrip("-").isdigit() else float(v)
    return out


def callgrind(exe: Path, data: Path, work: Path, toggle: str | None) -> str:
    """callgrind_annotate's text of one harness run (``toggle``: collect only inside that function)."""
    out = work / "callgrind.out"
    cmd = ["valgrind", "--tool=callgrind", f"--callgrind-out-file={out}"]
    cmd += [f"--toggle-collect={toggle}"] if toggle else []
    subprocess.run([*cmd, str(exe), str(data), str(work / "run.json")], check=True, capture_output=True)
    inclusive = "yes" if toggle is None else "no"
    return subprocess.run(
        ["callgrind_annotate", f"--inclusive={inclusive}", "--threshold=100", str(out)],
        check=True,
        capture_output=True,
        text=True,
    ).stdout


def function_costs(annotate: str, prefix: str) -> dict[str, int]:
    """Instructions per function name (the solver prefix stripped) from callgrind_annotate's text."""
    costs: dict[str, int] = {}
    for m in re.finditer(r"^\s*([\d,]+) \([^)]*\)\s+\S*:(\w+)(?: \[|\s*$)", annotate, re.M):
        costs.setdefault(m.group(2).removeprefix(prefix), int(m.group(1).replace(",", "")))  # its first listing
    return costs


def parts_of(costs: dict[str, int], parts: dict[str, tuple[str, ...]], rest: str) -> dict[str, int]:
    """Self instructions grouped into ``parts`` (the rest under ``rest``)."""
    owner = {fn: part for part, fns in parts.items() for fn in fns}
    out: dict[str, int] = defaultdict(int)
    for fn, c in costs.items():
        out[owner.get(fn, rest)] += c
    return dict(out)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--preset", default="truck_lifted_ellipse")
    ap.add_argument("--set", default="", help="QpOptions fields to change: field=value,...")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--samples", type=int, default=60)
    ap.add_argument("--cflags", default="-O2 -g")
    ap.add_argument("--out", type=Path, default=Path("results/osqp_iteration_profile.json"))
    a = ap.parse_args()
    pb = preset(a.preset)
    over = parse_set(a.set)
    if over:
        pb = dataclasses.replace(pb, qp=dataclasses.replace(pb.qp, **over))
    folder = ensure_solver(pb, CACHE, cflags=a.cflags).parent.parent
    with tempfile.TemporaryDirectory() as tmp:
        work = Path(tmp)
        log = firmware_sim(folder, "truck", a.seed, a.samples, work / "native.json", problem=pb, cflags=a.cflags)
        exe = folder / "build" / "firmware_sim" / "closed_loop"
        data = exe.parent / f"scenario_truck_seed{a.seed}_{a.samples}.txt"
        prefix = f"{pb.name}_"
        whole = function_costs(callgrind(exe, data, work, None), prefix)
        inside = function_costs(callgrind(exe, data, work, f"{prefix}osqp_solve"), prefix)
        prep = function_costs(callgrind(exe, data, work, f"{prefix}prepare"), prefix)
    iters = np.asarray(log.qp_iter)
    n_rti, n_iter = len(iters), int(iters.sum())
    per_rti = {k: whole.get(k, 0) / n_rti for k in ("prepare", "feedback", "osqp_update_data_mat", "osqp_solve")}
    parts = parts_of(inside, PARTS, REST)
    total = sum(parts.values())
    prep_parts = parts_of(prep, PREPARE_PARTS, PREPARE_REST)
    res = {
        "preset": a.preset,
        "qp_options": over,
        "seed": a.seed,
        "samples": a.samples,
        "cflags": a.cflags,
        "qp_iter_mean": float(iters.mean()),
        "admm_iterations": n_iter,
        "per_rti": per_rti,
        "per_iteration": {k: v / n_iter for k, v in sorted(parts.items(), key=lambda kv: -kv[1])},
        "per_iteration_total": total / n_iter,
        "prepare_per_rti": {k: v / n_rti for k, v in sorted(prep_parts.items(), key=lambda kv: -kv[1])},
        "top_functions": dict(sorted(((k, v / n_iter) for k, v in inside.items()), key=lambda kv: -kv[1])[:20]),
    }
    print(f"{a.preset} {over or ''} seed {a.seed}, {n_rti} RTIs, {n_iter} ADMM iterations ({iters.mean():.1f} a QP)")
    print("per RTI (inclusive, M instructions): " + ", ".join(f"{k} {v / 1e6:.3f}" for k, v in per_rti.items()))
    print(f"per ADMM iteration inside osqp_solve: {total / n_iter / 1e3:.1f} k instructions")
    for k, v in res["per_iteration"].items():
        print(f"  {k:55s} {v / 1e3:8.1f} k  {100 * v * n_iter / total:5.1f} %")
    print("per prepare (M instructions):")
    for k, v in res["prepare_per_rti"].items():
        print(f"  {k:55s} {v / 1e6:8.3f}")
    a.out.parent.mkdir(parents=True, exist_ok=True)
    a.out.write_text(json.dumps(res, indent=1) + "\n")
    print(f"written {a.out}")


if __name__ == "__main__":
    main()
