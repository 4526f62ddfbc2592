"""Instructions per IPM iteration by kernel (callgrind, x86), on recorded QPs (docs/performance.md).

    python benchmarks/ipm_kernel_profile.py [--presets truck_lifted_ellipse_ipm,truck_lifted_ellipse_ipm_safe]
        [--seeds 2] [--qps-dir results/ipm_qps] [--cflags "-O2 -ffp-contract=off -fno-tree-slp-vectorize"]
        [--label NAME] [--out results/ipm_kernel_profile.json]

Per preset: the solver of this checkout is generated into a temporary folder; its warm-started QPs of a closed loop
on seeds 0..SEEDS-1 are recorded once into QPS_DIR/<preset>.bin (kept: a later run, e.g. of another commit, solves
the very same QPs; delete the file to record again). ``benchmarks/ipm_iteration_bench.c`` solves them all once under
valgrind's callgrind (``-g`` added to CFLAGS; line-level counts, so inlined code counts where it is written). Every
instruction of the solver file is charged to the function whose source lines hold it and the functions to the
kernels of ``KERNELS``. Printed: instructions per QP iteration by kernel (and the heaviest functions); written: JSON.
Instruction counts do not depend on the machine's load.
"""

from __future__ import annotations

import argparse
import json
import re
import subprocess
import sys
import tempfile
from collections import defaultdict
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

from ipm_iteration_bench import compile_harness, record, write_qps

from fcgen.codegen.generate import generate
from fcgen.presets import preset as get_preset

ROOT = Path(__file__).resolve().parent.parent

KERNELS: dict[str, tuple[str, ...]] = {
    "cost-to-go [F G]' P [F G]": ("ipm_fg_ctg",),
    "Riccati stage (R, Cholesky, W1, P_k)": (
        "ipm_factor_stage",
        "ipm_pk",
        "ipm_chol_nu",
        "ipm_fwd_nu",
        "ipm_chol",
        "ipm_chol_u",
        "ipm_fwd_u",
        "ipm_fwd",
        "ipm_bwd",
        "ipm_stage_equalities",
        "ipm_eq_project",
    ),
    "stage Hessian, hd (box weights)": ("ipm_stage_hessian", "ipm_stage_diag_any", "ipm_hd"),
    "general rows, written out": (
        "ipm_gen_weights",
        "ipm_gen_rows_h",
        "ipm_gen_couple_h",
        "ipm_gen_ax",
        "ipm_gen_atx",
        "ipm_gen_rhs",
        "ipm_gen_dz",
    ),
    "general rows, generic loops": (
        "ipm_rows_ax_any",
        "ipm_rows_atx_any",
        "ipm_stage_weights_any",
        "ipm_rows_h_any",
        "ipm_couple_h_any",
        "ipm_slacks_rhs_any",
        "ipm_slacks_dz_any",
    ),
    "soft rows": (
        "ipm_sr_av",
        "ipm_sr_check_sums",
        "ipm_sr_forward_sums",
        "ipm_sr_check_rows",
        "ipm_sr_check",
        "ipm_sr_hessian",
        "ipm_sr_rhs",
        "ipm_sr_forward_rows",
        "ipm_sr_forward",
    ),
    "sweeps (backward, forward, [F G] products, input steps)": (
        "ipm_backward",
        "ipm_forward",
        "ipm_forward_stage",
        "ipm_stage_rhs",
        "ipm_stage_c",
        "ipm_stage_eq",
        "ipm_fg_tdot",
        "ipm_fg_axpy",
        "ipm_mv",
        "ipm_mv_add",
        "ipm_wx",
        "ipm_q_wtx",
        "ipm_u_rhs",
        "ipm_u_du",
        "ipm_bwd_nu_sub",
        "ipm_bwd_u_sub",
        "ipm_gather_xu",
        "ipm_add_xu",
        "ipm_set_xu",
    ),
    "residuals (check, A z, A' y, stopping test)": (
        "ipm_check",
        "ipm_take_step",
        "ipm_Ax",
        "ipm_ATx",
        "ipm_ineq_Ax",
        "ipm_eq_residuals",
        "ipm_stationarity_max",
        "ipm_check_side",
        "ipm_ineq_rows",
    ),
    "sides' right-hand sides and steps, step length": (
        "ipm_rc",
        "ipm_side_g",
        "ipm_ineq_ATx",
        "ipm_side_step",
        "ipm_ineq_sides",
        "ipm_direction",
        "ipm_step",
    ),
    "finiteness tests, max / min": ("ipm_nonfinite", "ipm_dz_nonfinite", "ipm_pk_nonfinite", "ipm_max", "ipm_min"),
    "QP start and result": (
        "qpb_solve",
        "qpb_reset",
        "ipm_compose_y",
        "ipm_side_b",
        "ipm_t2_start",
        "ipm_start_sides",
        "ipm_start_soft_rows",
        "ipm_centre",
    ),
}
"""kernel -> the solver file's functions it is made of (inlined code counts where it is written)."""
PREPARE = ("qpb_set_matrices",)
"""Outside the per-iteration figures: the prepare phase's part of the backend (once per QP)."""

_DEF = re.compile(r"^(?:static\s+)?(?:inline\s+)?(?:const\s+)?\w+\s+\**(\w+)\(")


def function_of_lines(source: Path) -> list[str]:
    """Per line of the C file (index = line - 1): the function whose definition holds it ('' outside)."""
    out: list[str] = []
    current = ""
    for line in source.read_text().splitlines():
        m = _DEF.match(line)
        if m is not None and not line.rstrip().endswith(";"):
            current = m.group(1)
        out.append(current)
        if line.startswith("}"):
            current = ""
    return out


def line_costs(callgrind_out: Path, source_name: str) -> dict[int, int]:
    """Self instructions per line of the source file named source_name (callgrind, uncompressed names/positions)."""
    costs: dict[int, int] = defaultdict(int)
    fl = fi = ""
    skip = False
    for line in callgrind_out.read_text().splitlines():
        if line.startswith(("fl=", "fi=", "fe=")):
            name = line[3:]
            if line.startswith("fl="):
                fl = fi = name
            else:
                fi = name
            continue
        if line.startswith("calls="):
            skip = True  # the next cost line is the call's inclusive cost
            continue
        if not line or not line[0].isdigit():
            continue
        if skip:
            skip = False
            continue
        if Path(fi).name == source_name:
            parts = line.split()
            costs[int(parts[0])] += int(parts[1])
    del fl
    return costs


def profile(folder: Path, name: str, qps_file: Path, cflags: list[str], work: Path) -> dict:
    """Callgrind of one pass over the recorded QPs: instructions by kernel and function, iterations."""
    exe = work / "harness"
    compile_harness(folder, name, exe, "cc", [*cflags, "-g"])
    out = work / "callgrind.out"
    run = subprocess.run(
        [
            "valgrind",
            "--tool=callgrind",
            "--dump-instr=no",
            "--dump-line=yes",
            "--compress-strings=no",
            "--compress-pos=no",
            f"--callgrind-out-file={out}",
            str(exe),
            str(qps_file),
            "1",
            "60",
        ],
        check=True,
        capture_output=True,
        text=True,
    )
    iterations = int(run.stdout.split()[1])
    source = folder / f"{name}_solver.c"
    owner = function_of_lines(source)
    by_fn: dict[str, int] = defaultdict(int)
    for ln, ir in line_costs(out, source.name).items():
        by_fn[owner[ln - 1] if 0 < ln <= len(owner) else ""] += ir
    kernel_of = {fn: k for k, fns in KERNELS.items() for fn in fns}
    by_kernel: dict[str, int] = defaultdict(int)
    prepare = 0
    for fn, ir in by_fn.items():
        if fn in PREPARE:
            prepare += ir
        else:
            by_kernel[kernel_of.get(fn, "other")] += ir
    return {
        "iterations": iterations,
        "by_kernel": dict(by_kernel),
        "by_function": dict(by_fn),
        "prepare": prepare,
        "solve": sum(by_kernel.values()),
    }


def qps_for(preset: str, folder: Path, seeds: int, qps_dir: Path) -> tuple[Path, int]:
    """The recorded QPs of the preset (recorded now unless QPS_DIR has them) and their count."""
    path = qps_dir / f"{preset}_s{seeds}.bin"
    if not path.exists():
        _, qps = record(folder, seeds)
        qps_dir.mkdir(parents=True, exist_ok=True)
        write_qps(path, qps)
    return path, int.from_bytes(path.read_bytes()[:4], "little")


def print_table(preset: str, res: dict) -> None:
    it = res["iterations"]
    print(f"{preset}: {res['qps']} QPs, {it} IPM iterations; instructions per QP iteration (k = 1000)")
    for k, ir in sorted(res["by_kernel"].items(), key=lambda kv: -kv[1]):
        print(f"  {k:58s} {ir / it / 1e3:9.1f} k  {100 * ir / res['solve']:5.1f} %")
    print(f"  {'all of the solve':58s} {res['solve'] / it / 1e3:9.1f} k")
    print(f"  (prepare's qpb_set_matrices: {res['prepare'] / res['qps'] / 1e3:.1f} k per QP)")
    top = sorted(res["by_function"].items(), key=lambda kv: -kv[1])[:8]
    print("  heaviest functions: " + ", ".join(f"{fn or '?'} {ir / it / 1e3:.1f} k" for fn, ir in top))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--presets", default="truck_lifted_ellipse_ipm,truck_lifted_ellipse_ipm_safe")
    ap.add_argument("--seeds", type=int, default=2)
    ap.add_argument("--qps-dir", type=Path, default=Path("results/ipm_qps"))
    ap.add_argument("--cflags", default="-O2 -ffp-contract=off -fno-tree-slp-vectorize")
    ap.add_argument("--label", default="", help="a name for this run in the results file (e.g. the commit)")
    ap.add_argument("--out", type=Path, default=Path("results/ipm_kernel_profile.json"))
    args = ap.parse_args()
    results = {}
    for preset in args.presets.split(","):
        with tempfile.TemporaryDirectory() as tmp:
            work = Path(tmp)
            folder = work / "solver"
            generate(get_preset(preset), folder)
            name = next(folder.glob("*_solver.c")).name.removesuffix("_solver.c")
            qps_file, count = qps_for(preset, folder, args.seeds, args.qps_dir)
            res = profile(folder, name, qps_file, args.cflags.split(), work)
        res["qps"] = count
        results[preset] = res
        print_table(preset, res)
    rev = subprocess.run(["git", "-C", str(ROOT), "rev-parse", "--short", "HEAD"], capture_output=True, text=True)
    doc = {"label": args.label, "commit": rev.stdout.strip(), "cflags": args.cflags, "seeds": args.seeds}
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(json.dumps({**doc, "presets": results}, indent=2) + "\n")
    print(f"results written to {args.out}")


if __name__ == "__main__":
    main()
