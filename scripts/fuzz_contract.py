"""The long run of the C API's contract fuzzer (tests/c/fuzz_contract.c), and its libFuzzer entry where clang is
installed, on one solver of each backend and precision (docs/verification.md):

    .venv/bin/python scripts/fuzz_contract.py --trials 5000                 # 1,000,000 random calls per solver
    .venv/bin/python scripts/fuzz_contract.py --libfuzzer 600 --only ipm_double,osqp_conventional

Prints the driver's counts per solver and writes them to results/fuzz_contract.json; exit 1 on any violation or
sanitizer report.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "tests"))

from fuzzbuild import CLANG, REPORT, SOLVERS, build_fuzzer, counts, run

from fcgen import __version__


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--trials", type=int, default=5000, help="trials of 200 random calls per solver")
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--libfuzzer", type=int, default=0, help="seconds of libFuzzer per solver (clang only)")
    ap.add_argument("--only", default=",".join(sorted(SOLVERS)), help="solvers: " + ", ".join(sorted(SOLVERS)))
    ap.add_argument("--work", type=Path, default=Path("build/fuzz_contract"), help="build folder")
    ap.add_argument("--out", type=Path, default=Path("results/fuzz_contract.json"))
    a = ap.parse_args()
    results, bad = {"fcgen": __version__, "trials": a.trials, "seed": a.seed}, False
    for key in a.only.split(","):
        t0 = time.time()
        exe = build_fuzzer(key, a.work / key)
        res = run([str(exe), str(a.seed), str(a.trials)])
        c = counts(res.stdout)
        report = REPORT.search(res.stderr) is not None
        entry = {"solver": SOLVERS[key], "calls": c.get("calls"), "violations": c.get("violations"), "report": report}
        entry |= {"seconds": round(time.time() - t0, 1), "counts": c}
        bad |= res.returncode != 0 or report
        if a.libfuzzer and CLANG:
            lf = build_fuzzer(key, a.work / f"{key}_libfuzzer", libfuzzer=True)
            corpus = a.work / f"{key}_corpus"
            corpus.mkdir(parents=True, exist_ok=True)
            r = run([str(lf), str(corpus), f"-max_total_time={a.libfuzzer}", "-max_len=4096", f"-seed={a.seed}"])
            execs = [ln for ln in r.stderr.splitlines() if "Done " in ln]
            entry["libfuzzer"] = {"seconds": a.libfuzzer, "returncode": r.returncode, "done": execs[-1:]}
            bad |= r.returncode != 0
            if r.returncode != 0:
                print(r.stderr[-4000:], file=sys.stderr)
        results[key] = entry
        print(key, json.dumps({k: v for k, v in entry.items() if k != "counts"}), flush=True)
    a.out.parent.mkdir(parents=True, exist_ok=True)
    a.out.write_text(json.dumps(results, indent=1) + "\n")
    return 1 if bad else 0


if __name__ == "__main__":
    raise SystemExit(main())
