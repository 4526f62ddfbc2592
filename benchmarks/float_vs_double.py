"""Float vs double closed loop of truck_lifted_ellipse in C, both QP backends, truck seeds 0-19 x 200 samples.

Usage: .venv/bin/python benchmarks/float_vs_double.py [OUT_DIR] [--backends osqp,ipm] [--seeds 20]
Prints one line per build and one comparison line per backend (mean progress float - double, per-seed range, seeds
beyond 0.5 %); writes OUT_DIR/float_vs_double.json. The float builds use the generator's float settings (OSQP:
``sigma`` raised to ``fcgen.backends.osqp.FLOAT_SIGMA_MIN``); the IPM's float build is generated with ``ipm_tol`` 1e-3.
"""

import argparse
import collections
import dataclasses
import json
from pathlib import Path

import numpy as np

from fcgen.build import build
from fcgen.codegen.generate import generate
from fcgen.csolver import CSolver
from fcgen.ocp import build_ocp
from fcgen.presets import preset
from fcgen.sim.closedloop import run_closed_loop
from fcgen.sim.runlog import summary
from fcgen.sim.scenario import make_scenario

ap = argparse.ArgumentParser()
ap.add_argument("out_dir", nargs="?", default="runs/float_vs_double")
ap.add_argument("--backends", default="osqp,ipm", help="comma-separated: osqp, ipm")
ap.add_argument("--seeds", type=int, default=20, help="truck seeds 0 .. SEEDS-1")
args = ap.parse_args()
root = Path(args.out_dir)
out = {}
for backend in args.backends.split(","):
    for fl in (False, True):
        pb = preset("truck_lifted_ellipse" + ("_ipm" if backend == "ipm" else ""))
        if fl and backend == "ipm":
            pb = pb.with_(qp=dataclasses.replace(pb.qp, ipm_tol=1e-3))
        pb = pb.with_(name=pb.name + ("_f" if fl else "_d"))
        d = root / pb.name
        generate(pb, d, use_float=fl, force=True)
        cs = CSolver(build(d))
        ocp = build_ocp(pb)
        prog, coll, st = [], 0, collections.Counter()
        for seed in range(args.seeds):
            cs.init()
            sc = make_scenario("truck", seed, n_opp=3, samples=200, dt=pb.horizon.dt)
            lg = run_closed_loop(pb, sc, controller=cs, ocp=ocp)
            s = summary(lg)
            prog.append(s["progress"])
            coll += s["n_collision_samples"] > 0
            st.update(s["qp_status_counts"])
        out[f"{backend}-{'float' if fl else 'double'}"] = dict(
            progress_mean=float(np.mean(prog)), runs_with_collision=coll, qp_status=dict(st), progress=prog
        )
        print(backend, "float" if fl else "double", f"{np.mean(prog):.2f}", coll, dict(st), flush=True)
    dbl, flt = (np.array(out[f"{backend}-{p}"]["progress"]) for p in ("double", "float"))
    rel = 100 * (flt / dbl - 1)
    out[f"{backend}-compare"] = dict(
        mean_rel_pct=float(100 * (flt.mean() / dbl.mean() - 1)),
        seed_min_pct=float(rel.min()),
        seed_max_pct=float(rel.max()),
        seeds_beyond_half_pct=int(np.sum(np.abs(rel) > 0.5)),
    )
    mean, lo, hi, beyond = out[f"{backend}-compare"].values()
    print(
        backend,
        f"float - double: mean {mean:+.3f} %, per seed {lo:+.2f} .. {hi:+.2f} %, {beyond} seeds beyond 0.5 %",
        flush=True,
    )
(root / "float_vs_double.json").write_text(json.dumps(out, indent=1))
