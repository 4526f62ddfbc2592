"""The long run of the C API's contract fuzzer (tests/c/fuzz_contract.c), and its libFuzzer entry where clang is
installed, on one solver of each backend and precision and one with delay compensation (docs/verification.md):

    .venv/bin/python scripts/fuzz_contract.py --trials 5000                 # 1,000,000 random calls per solver
    .venv/bin/python scripts/fuzz_contract.py --trials 0 --libfuzzer 600 --only ipm_double,osqp_conventional

Prints the driver's progress (calls so far, calls/s) while it runs, then its counts per solver (calls per entry, the
processor seconds per entry, the slowest call) and writes them to results/fuzz_contract.json; exit 1 on any violation
or sanitizer report. The call mix is the driver's default except where MIX says otherwise (--mix overrides it).
OSQP's own library (third-party; its ADMM iterations are most of an OSQP feedback's time: about 4x slower under
ASan) is built without the sanitizers unless --sanitize-qp-lib; the solver's code, its tables and the driver keep
them (the short run in the tests sanitizes everything).
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "tests"))

from fuzzbuild import CLANG, REPORT, SAN_ENV, SOLVERS, build_fuzzer, counts, run

from fcgen import __version__

# The driver's weights per kind (its default: set_state 14, set_road 5, set_road_bounds 5, set_opponents 10,
# set_opponent_shapes 5, set_reference 5, set_clock 2, prepare 16, feedback 16, reset 2, init 1, getter 12: feedback
# one call in six). Where a feedback's QP is most of the run's time, the long run draws the setters and getters twice
# as often: the hyperplane solver's N = 40 IPM with prepare and feedback at half the default (feedback one call in
# seventeen), OSQP's capped iterations on the conventional formulation at a quarter (one call in thirty-two).
LIGHT = (
    "set_state=28,set_road=10,set_road_bounds=10,set_opponents=20,set_opponent_shapes=10,set_reference=10,"
    "set_clock=4,prepare=8,feedback=8,reset=2,init=1,getter=24"
)
MIX = {"ipm_hyperplane": LIGHT, "osqp_conventional": LIGHT.replace("prepare=8,feedback=8", "prepare=4,feedback=4")}


def run_streamed(cmd: list[str], label: str) -> tuple[int, str, str]:
    """Run under the sanitizers' options, echoing the driver's progress lines; its code, stdout and stderr."""
    proc = subprocess.Popen(
        cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env={**os.environ, **SAN_ENV}
    )
    assert proc.stderr is not None and proc.stdout is not None
    err = []
    for line in proc.stderr:
        err.append(line)
        if line.startswith("progress "):
            print(label, line.rstrip(), flush=True)
    out = proc.stdout.read()
    return proc.wait(), out, "".join(err)


def seeded(key: str, a: argparse.Namespace) -> dict:
    """The seeded run on one solver: its entry of the results."""
    t0 = time.time()
    exe = build_fuzzer(key, a.work / key, qp_lib_sanitized=a.sanitize_qp_lib)
    mix = a.mix or MIX.get(key)
    cmd = [str(exe), str(a.seed), str(a.trials), "200", *([mix] if mix else [])]
    rc, out, err = run_streamed(cmd, key)
    c = counts(out)
    report = REPORT.search(err) is not None
    slowest = [ln for ln in err.splitlines() if ln.startswith("slowest_call ")]
    entry = {"solver": SOLVERS[key]._asdict(), "calls": c.get("calls"), "violations": c.get("violations")}
    entry |= {"report": report, "returncode": rc, "wall_seconds": round(time.time() - t0, 1), "mix": mix}
    entry |= {"qp_lib_sanitized": a.sanitize_qp_lib, "slowest_call": slowest[-1:], "counts": c, "seconds": counts(err)}
    if rc != 0 or report:
        print(err[-4000:], file=sys.stderr)
    return entry


def libfuzz(key: str, a: argparse.Namespace) -> dict:
    """libFuzzer on one solver for a.libfuzzer seconds: executions, the final stats, its code."""
    lf = build_fuzzer(key, a.work / f"{key}_libfuzzer", libfuzzer=True, qp_lib_sanitized=a.sanitize_qp_lib)
    corpus = a.work / f"{key}_corpus"
    corpus.mkdir(parents=True, exist_ok=True)
    opts = [f"-max_total_time={a.libfuzzer}", "-max_len=4096", f"-seed={a.seed}", "-print_final_stats=1"]
    r = run([str(lf), str(corpus), *opts])
    stats = {
        ln.split(":")[2].strip(): ln.split(":")[-1].strip() for ln in r.stderr.splitlines() if ln.startswith("stat::")
    }
    done = [ln for ln in r.stderr.splitlines() if "Done " in ln]
    report = REPORT.search(r.stderr) is not None
    if r.returncode != 0 or report:
        print(r.stderr[-4000:], file=sys.stderr)
    return {"seconds": a.libfuzzer, "returncode": r.returncode, "report": report, "done": done[-1:], "stats": stats}


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--trials", type=int, default=5000, help="trials of 200 random calls per solver (0: none)")
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--libfuzzer", type=int, default=0, help="seconds of libFuzzer per solver (clang only)")
    ap.add_argument("--only", default=",".join(sorted(SOLVERS)), help="solvers: " + ", ".join(sorted(SOLVERS)))
    ap.add_argument("--mix", default=None, help="the driver's weights: kind=w,... (e.g. feedback=8)")
    ap.add_argument("--sanitize-qp-lib", action="store_true", help="OSQP's own library with the sanitizers too")
    ap.add_argument("--work", type=Path, default=Path("build/fuzz_contract"), help="build folder")
    ap.add_argument("--out", type=Path, default=Path("results/fuzz_contract.json"))
    a = ap.parse_args()
    results: dict = {"fcgen": __version__, "trials": a.trials, "seed": a.seed}
    bad = False
    for key in a.only.split(","):
        entry = results[key] = seeded(key, a) if a.trials > 0 else {}
        bad |= entry.get("returncode", 0) != 0 or entry.get("report", False)
        if a.libfuzzer and CLANG:
            lf = entry["libfuzzer"] = libfuzz(key, a)
            bad |= lf["returncode"] != 0 or lf["report"]
        kinds = {k.removeprefix("kind_"): int(v) for k, v in entry.get("counts", {}).items() if k.startswith("kind_")}
        keep = ("calls", "violations", "report", "wall_seconds", "slowest_call", "libfuzzer")
        print(key, json.dumps({k: entry[k] for k in keep if k in entry} | {"per_entry": kinds}), flush=True)
        a.out.parent.mkdir(parents=True, exist_ok=True)
        a.out.write_text(json.dumps(results, indent=1) + "\n")  # after each solver: a long run keeps what it did
    return 1 if bad else 0


if __name__ == "__main__":
    raise SystemExit(main())
