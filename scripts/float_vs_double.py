"""Float vs double closed loop of truck_lifted_ellipse in C, both QP backends, truck seeds 0-19 x 200 samples.

Usage: .venv/bin/python scripts/float_vs_double.py [OUT_DIR]  (prints one line per build; writes float_vs_double.json)
"""
import collections
import dataclasses
import json
import sys
from pathlib import Path

import numpy as np
from fcgen.codegen.generate import generate
from fcgen.build import build, CSolver
from fcgen.presets import preset
from fcgen.sim.scenario import make_scenario
from fcgen.sim.closedloop import run_closed_loop
from fcgen.sim.runlog import summary
from fcgen.ocp import build_ocp

root = Path(sys.argv[1] if len(sys.argv) > 1 else "runs/float_vs_double")
out = {}
for backend in ("osqp", "ipm"):
    for fl in (False, True):
        pb = preset("truck_lifted_ellipse" + ("_ipm" if backend == "ipm" else ""))
        if fl and backend == "ipm":
            pb = pb.with_(qp=dataclasses.replace(pb.qp, ipm_tol=1e-3))
        pb = pb.with_(name=pb.name + ("_f" if fl else "_d"))
        d = root / pb.name
        generate(pb, d, use_float=fl)
        cs = CSolver(build(d))
        ocp = build_ocp(pb)
        prog, coll, st = [], 0, collections.Counter()
        for seed in range(20):
            cs.init()
            sc = make_scenario("truck", seed, n_opp=3, samples=200, dt=pb.horizon.dt)
            lg = run_closed_loop(pb, sc, controller=cs, ocp=ocp)
            s = summary(lg)
            prog.append(s["progress"]); coll += s["n_collision_samples"] > 0
            st.update(s["qp_status_counts"])
        out[f"{backend}-{'float' if fl else 'double'}"] = dict(progress_mean=float(np.mean(prog)), runs_with_collision=coll, qp_status=dict(st), progress=prog)
        print(backend, "float" if fl else "double", f"{np.mean(prog):.2f}", coll, dict(st), flush=True)
(root / "float_vs_double.json").write_text(json.dumps(out, indent=1))
