"""Instructions per RTI of the safe vs the paper profile, per grid configuration (docs/performance.md).

    python benchmarks/profiles_instructions.py [--seeds 100,101,102] [--only car/lifted] [--cache DIR] [--out FILE]

Each configuration of the campaign's grid (IPM backend) in both profiles: the solver (`-O2`, the campaign's build),
its C closed loop on the host (`fcgen.sim.harness.firmware_sim`: the harness a user's ECU test would run), then the same
run under valgrind's callgrind. Per RTI = the inclusive instructions of `<name>_prepare` and `<name>_feedback` over
the run's samples. Instruction counts do not depend on the machine's load, unlike the campaign's times. Printed: the
table (pooled over the seeds: the mean of each seed's figure) with the ratio safe / paper; written: JSON.
"""

from __future__ import annotations

import argparse
import json
import math
import re
import subprocess
import tempfile
from pathlib import Path

from fcgen.campaign.grid import paper_grid
from fcgen.campaign.solvers import ensure_solver
from fcgen.sim.harness import firmware_sim


def instructions(exe: Path, data: Path, name: str, work: Path) -> int:
    """Inclusive instructions of prepare + feedback of one harness run under callgrind."""
    out = work / "callgrind.out"
    subprocess.run(
        ["valgrind", "--tool=callgrind", f"--callgrind-out-file={out}", str(exe), str(data), str(work / "run.json")],
        check=True,
        capture_output=True,
    )
    ann = subprocess.run(
        ["callgrind_annotate", "--inclusive=yes", "--threshold=100", str(out)],
        check=True,
        capture_output=True,
        text=True,
    ).stdout
    total = 0
    for phase in ("prepare", "feedback"):
        m = re.search(rf"^\s*([\d,]+) \([^)]*\)\s+\S*:{re.escape(name)}_{phase} \[", ann, re.M)
        if m is None:
            raise RuntimeError(f"{name}_{phase} not in the callgrind profile of {exe}")
        total += int(m.group(1).replace(",", ""))
    return total


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", default="100,101,102")
    ap.add_argument("--only", default="", help="configurations whose key contains this (e.g. car/lifted)")
    ap.add_argument("--cache", default=".fcgen-cache/solvers")
    ap.add_argument("--out", default="results/profiles_instructions.json")
    args = ap.parse_args()
    seeds = [int(s) for s in args.seeds.split(",")]
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        work = Path(tmp)
        for paper, safe in zip(paper_grid(backend="ipm", profile="paper"), paper_grid(backend="ipm", profile="safe")):
            if args.only not in paper.key:
                continue
            per = {}
            for cfg in (paper, safe):
                pb = cfg.problem()
                folder = ensure_solver(pb, Path(args.cache)).parent.parent
                figs = []
                for seed in seeds:
                    log = firmware_sim(folder, cfg.scenario, seed, 200, work / "native.json", problem=pb)
                    exe = folder / "build" / "firmware_sim" / "closed_loop"
                    data = exe.parent / f"scenario_{cfg.scenario}_seed{seed}_200.txt"
                    figs.append(instructions(exe, data, pb.name, work) / len(log.qp_iter))
                per[cfg.profile] = figs
            ratio = sum(per["safe"]) / sum(per["paper"])
            rows.append(
                {
                    "config": paper.key.removesuffix("/c/ipm"),
                    "seeds": seeds,
                    "paper": per["paper"],
                    "safe": per["safe"],
                    "ratio": ratio,
                }
            )
            print(
                f"{rows[-1]['config']:32s} paper {sum(per['paper']) / len(seeds) / 1e6:8.3f} M  "
                f"safe {sum(per['safe']) / len(seeds) / 1e6:8.3f} M  safe/paper {ratio:.3f}",
                flush=True,
            )
    if rows:
        gm = math.exp(sum(math.log(r["ratio"]) for r in rows) / len(rows))
        print(
            f"geometric mean {gm:.3f}, max {max(r['ratio'] for r in rows):.3f}, min {min(r['ratio'] for r in rows):.3f}"
        )
        out = Path(args.out)
        out.parent.mkdir(parents=True, exist_ok=True)
        out.write_text(json.dumps({"rows": rows, "geometric_mean": gm}, indent=1) + "\n")
        print(f"written {out}")


if __name__ == "__main__":
    main()
