"""OSQP's time per RTI against the IPM's, alternated in one run (docs/performance.md).

    python benchmarks/osqp_rti_ratio.py [--preset truck_lifted_ellipse] [--seeds 5] [--samples 200] [--rounds 2]
        [--osqp-caps 60,40] [--cflags -O2] [--out results/osqp_rti_ratio.json]

Solvers (generated and built once into ``.fcgen-cache/osqp_ratio`` with CFLAGS): the preset with OSQP at each warm
cap of ``--osqp-caps`` (``QpOptions.max_iter``; the rest of its options as the preset has them) and with the IPM
(``QpOptions(backend="ipm")``: the defaults, as ``fcgen bench --backends ipm`` builds it). Per round and seed every
solver closes the loop on the same scenario one after the other (the order rotated per seed), timed by the solver
thread's CPU clock (``host_cpu_clock``: other processes on the machine do not count). Printed per solver: median /
p99 time per RTI over all samples, the QP iterations, the ratio of the medians to the IPM's and the progress;
written: JSON.
"""

from __future__ import annotations

import argparse
import ctypes
import dataclasses
import json
from pathlib import Path

import numpy as np

from fcgen.campaign.solvers import ensure_solver
from fcgen.csolver import CSolver
from fcgen.dsl import QpOptions
from fcgen.ocp import build_ocp
from fcgen.presets import preset
from fcgen.sim.closedloop import run_closed_loop
from fcgen.sim.scenario import make_scenario
from fcgen.verify import infer_scenario

CACHE = Path(__file__).resolve().parent.parent / ".fcgen-cache" / "osqp_ratio"


def solvers(name: str, caps: list[int], cflags: str) -> dict[str, tuple]:
    """label -> (problem, CSolver, ocp) for OSQP at each cap and the IPM."""
    pb = preset(name)
    out = {}
    for cap in caps:
        pv = dataclasses.replace(pb, name=f"c{cap}_{pb.name}"[:31], qp=dataclasses.replace(pb.qp, max_iter=cap))
        out[f"osqp_cap{cap}"] = pv
    out["ipm"] = dataclasses.replace(pb, name=f"i_{pb.name}"[:31], qp=QpOptions(backend="ipm"))
    res = {}
    for label, pv in out.items():
        res[label] = (pv, CSolver(ensure_solver(pv, CACHE, cflags=cflags)), build_ocp(pv))
    return res


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--preset", default="truck_lifted_ellipse")
    ap.add_argument("--seeds", type=int, default=5)
    ap.add_argument("--samples", type=int, default=200)
    ap.add_argument("--rounds", type=int, default=2)
    ap.add_argument("--osqp-caps", default="60,40")
    ap.add_argument("--cflags", default="-O2")
    ap.add_argument("--out", type=Path, default=Path("results/osqp_rti_ratio.json"))
    a = ap.parse_args()
    sv = solvers(a.preset, [int(c) for c in a.osqp_caps.split(",")], a.cflags)
    scenario = infer_scenario(preset(a.preset))
    labels = list(sv)
    times: dict[str, list[float]] = {k: [] for k in labels}
    iters: dict[str, list[int]] = {k: [] for k in labels}
    prog: dict[str, list[float]] = {k: [] for k in labels}
    for rnd in range(a.rounds):
        for seed in range(a.seeds):
            shift = (seed + rnd) % len(labels)
            for label in labels[shift:] + labels[:shift]:
                pv, cs, ocp = sv[label]
                sc = make_scenario(scenario, seed, n_opp=pv.opponents.count, samples=a.samples, dt=pv.horizon.dt)
                if cs.init() != 0:
                    raise RuntimeError(f"{pv.name}_init() failed")
                cs._f("set_clock")(ctypes.cast(cs._f("host_cpu_clock"), ctypes.c_void_p))
                lg = run_closed_loop(pv, sc, controller=cs, ocp=ocp)
                times[label] += (1e3 * np.asarray(lg.time_total, dtype=float)).tolist()
                if rnd == 0:
                    iters[label] += np.asarray(lg.qp_iter).tolist()
                    prog[label].append(float(lg.ego_frenet[-1, 0] - lg.ego_frenet[0, 0]))
    ipm_median = float(np.median(times["ipm"]))
    res = {}
    for label in labels:
        t = np.asarray(times[label])
        res[label] = {
            "median_ms": float(np.median(t)),
            "p99_ms": float(np.percentile(t, 99)),
            "qp_iter_mean": float(np.mean(iters[label])),
            "ratio_to_ipm": float(np.median(t)) / ipm_median,
            "progress_mean": float(np.mean(prog[label])),
        }
        r = res[label]
        print(
            f"{label:12s} median {r['median_ms']:.3f} ms  p99 {r['p99_ms']:.3f}  x IPM {r['ratio_to_ipm']:.2f}  "
            f"QP iter {r['qp_iter_mean']:.1f}  progress {r['progress_mean']:.2f} m"
        )
    a.out.parent.mkdir(parents=True, exist_ok=True)
    meta = {"preset": a.preset, "seeds": a.seeds, "samples": a.samples, "rounds": a.rounds, "cflags": a.cflags}
    a.out.write_text(json.dumps({**meta, "results": res}, indent=1) + "\n")
    print(f"written {a.out}")


if __name__ == "__main__":
    main()
