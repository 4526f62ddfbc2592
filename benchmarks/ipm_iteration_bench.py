"""Host time per IPM iteration, this code against an earlier commit's, on the same recorded QPs (docs/wcet.md).

    python benchmarks/ipm_iteration_bench.py [--old 4061078] [--folder generated/truck_lifted_ellipse_ipm]
                                          [--seeds 2] [--rounds 12] [--repeats 3] [--out FILE]

The folder's solver (this checkout) closes the loop on seeds 0..SEEDS-1 of its scenario and keeps every warm-started
QP (``fcgen.csolver.QpRecorder``: the data and the shifted duals the backend was given). Both the folder and the same
folder at commit OLD are compiled with ``benchmarks/ipm_iteration_bench.c`` (their own ``qpb_*`` backend, the
Makefile's default flags ``-O2 -ffp-contract=off -fno-tree-slp-vectorize`` unless --cflags) and solve all QPs, the
two alternated ROUNDS times (old, new, old, new, ...; each REPEATS passes, the fastest kept). Printed: microseconds
per QP iteration of each (median over rounds), the ratio old / new per round (median, min, max), iterations of
each. Only QP sizes equal in both commits can be compared (checked).
"""

from __future__ import annotations

import argparse
import json
import shutil
import statistics
import struct
import subprocess
import tempfile
from pathlib import Path

import numpy as np

from fcgen.build import build
from fcgen.csolver import QpRecorder
from fcgen.ocp import build_ocp
from fcgen.qp import build_layout
from fcgen.sim.closedloop import run_closed_loop
from fcgen.sim.scenario import make_scenario
from fcgen.verify import infer_scenario, load_solver_problem

ROOT = Path(__file__).resolve().parent.parent
HARNESS = Path(__file__).with_suffix(".c")


def record(folder: Path, seeds: int) -> tuple[str, list[dict]]:
    """The folder's C solver in closed loop on seeds 0..seeds-1: its name and every warm-started QP."""
    name, pb = load_solver_problem(folder)
    ocp = build_ocp(pb)
    rec = QpRecorder(build(folder), build_layout(ocp))
    for seed in range(seeds):
        rec.init()
        sc = make_scenario(infer_scenario(pb), seed, n_opp=pb.opponents.count, samples=200, dt=pb.horizon.dt)
        run_closed_loop(pb, sc, controller=rec, ocp=ocp)
    return name, rec.qps


def write_qps(path: Path, qps: list[dict]) -> None:
    with open(path, "wb") as f:
        f.write(struct.pack("i", len(qps)))
        for qp in qps:
            for key in ("q", "l", "u", "A_x", "y_warm"):
                f.write(np.ascontiguousarray(qp[key], dtype=np.float64).tobytes())


def sizes(folder: Path, name: str) -> dict[str, int]:
    head = (folder / f"{name}_solver.h").read_text()
    out = {}
    for key in ("QP_N", "QP_M", "QP_NNZ_A"):
        tag = f"#define {name.upper()}_{key} "
        out[key] = int(head.split(tag, 1)[1].split()[0])
    return out


def compile_harness(folder: Path, name: str, exe: Path, cc: str, cflags: list[str]) -> None:
    cmd = [
        cc,
        "-std=c99",
        *cflags,
        f'-DSOLVER_C="{folder / (name + "_solver.c")}"',
        f"-DQPH_PREFIX={name.upper()}",
        f"-I{folder}",
        str(HARNESS),
        str(folder / f"{name}_model.c"),
        "-o",
        str(exe),
        "-lm",
    ]
    subprocess.run(cmd, check=True)


def run(exe: Path, qps_file: Path, repeats: int, max_iter: int) -> tuple[float, int]:
    out = subprocess.run(
        [str(exe), str(qps_file), str(repeats), str(max_iter)], check=True, capture_output=True, text=True
    ).stdout.split("\n")
    rows = [line.split() for line in out if line.strip()]
    return min(float(r[0]) for r in rows), int(rows[0][1])


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--old", default="4061078", help="the commit to compare with (default: before issue 20)")
    ap.add_argument("--folder", default="generated/truck_lifted_ellipse_ipm")
    ap.add_argument("--seeds", type=int, default=2)
    ap.add_argument("--rounds", type=int, default=12)
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--max-iter", type=int, default=60, help="the cap passed to both (default: 60)")
    ap.add_argument("--cc", default="cc")
    ap.add_argument("--cflags", default="-O2 -ffp-contract=off -fno-tree-slp-vectorize")
    ap.add_argument("--out", type=Path, default=Path("results/ipm_iteration_bench.json"))
    args = ap.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        new = tmp / "new"
        shutil.copytree(ROOT / args.folder, new, ignore=shutil.ignore_patterns("build", "golden"))
        old = tmp / "old"
        old.mkdir()
        archive = subprocess.run(
            ["git", "-C", str(ROOT), "archive", args.old, args.folder], check=True, capture_output=True
        ).stdout
        subprocess.run(
            ["tar", "-x", "-C", str(old), "--strip-components", str(len(Path(args.folder).parts))],
            input=archive,
            check=True,
        )
        name, qps = record(new, args.seeds)
        if sizes(old, name) != sizes(new, name):
            raise SystemExit(f"the QP sizes differ: {sizes(old, name)} (old) vs {sizes(new, name)}")
        qps_file = tmp / "qps.bin"
        write_qps(qps_file, qps)
        exes = {}
        for tag, folder in (("old", old), ("new", new)):
            exes[tag] = tmp / f"harness_{tag}"
            compile_harness(folder, name, exes[tag], args.cc, args.cflags.split())
        per_iter = {"old": [], "new": []}
        iters = {}
        for _ in range(args.rounds):
            for tag in ("old", "new"):
                t, it = run(exes[tag], qps_file, args.repeats, args.max_iter)
                per_iter[tag].append(1e6 * t / it)
                iters[tag] = it
    ratios = [o / n for o, n in zip(per_iter["old"], per_iter["new"])]
    result = {
        "folder": args.folder,
        "old": args.old,
        "qps": len(qps),
        "seeds": args.seeds,
        "cflags": args.cflags,
        "rounds": args.rounds,
        "iterations": iters,
        "us_per_iteration": {k: statistics.median(v) for k, v in per_iter.items()},
        "ratio_old_over_new": {"median": statistics.median(ratios), "min": min(ratios), "max": max(ratios)},
    }
    print(
        f"{len(qps)} warm-started QPs of {args.folder} (seeds 0..{args.seeds - 1}), {args.cflags}, "
        f"{args.rounds} rounds alternated"
    )
    for tag in ("old", "new"):
        print(
            f"  {tag:3s} ({args.old if tag == 'old' else 'this checkout'}): "
            f"{result['us_per_iteration'][tag]:.2f} us per QP iteration, {iters[tag]} iterations"
        )
    r = result["ratio_old_over_new"]
    print(f"  old / new per round: median {r['median']:.3f} (min {r['min']:.3f}, max {r['max']:.3f})")
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(json.dumps(result, indent=2) + "\n")
    print(f"results written to {args.out}")


if __name__ == "__main__":
    main()
