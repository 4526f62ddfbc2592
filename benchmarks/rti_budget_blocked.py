"""The RTI budget where the QPs are hard: a lane that closes and a vehicle beside the ego (docs/wcet.md).

    python benchmarks/rti_budget_blocked.py [--budgets 7,10,20,60] [--samples 30] [--json FILE] [PRESET ...]

The scenario of ``tests/test_runtime_inputs.py``'s lockstep: a straight road whose left edge comes in from 3 m to
0.5 m between s = 30 and 50 m, the ego at s = 0, n = 2 m, 15 m/s; a vehicle standing at s = 80 m, n = -1 m; one
at n = -1.5 m driving at 12 m/s from s = 20 m; the three opponents' shapes 4.5 x 1.8, 12 x 2.5 and 6 x 2.1 m. Per
preset (default: car_lifted_ellipse_ipm_safe, car_lifted_ellipse_ipm) and budget the Python reference and the C
solver (generated and built once into ``.fcgen-cache``) close the loop side by side, each on its own plant.
Printed: where the reference stops (s and the first sample at v < 0.01 m/s), its QP iterations (mean, max) and QPs
at the budget, and the largest difference of the C's state from the reference's over the run.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
from pathlib import Path

import numpy as np

from fcgen import obstacles as obs
from fcgen.campaign.solvers import ensure_solver
from fcgen.csolver import CSolver
from fcgen.ocp import build_ocp
from fcgen.presets import preset
from fcgen.road import Road, straight_road
from fcgen.sim.closedloop import Plant, ReferenceController

PRESETS = ("car_lifted_ellipse_ipm_safe", "car_lifted_ellipse_ipm")
CACHE = Path(__file__).resolve().parent.parent / ".fcgen-cache" / "rti_budget_blocked"
SHAPES = ((4.5, 1.8, 0.0), (12.0, 2.5, 3.0), (6.0, 2.1, 1.0))  # length, width, offset of each opponent


def road_of(pb) -> Road:
    """800 m of straight road from s = -20 m, the left edge closing from 3 to 0.5 m over s = 30..50 m."""
    r = straight_road(length=800.0, ds=pb.road.ds, s0=-20.0)
    hi = np.interp(r.s, [30.0, 50.0], [3.0, 0.5])
    return Road(r.s0, r.ds, r.kappa, r.phi, r.gx, r.gy, np.full_like(r.s, -3.0), hi)


def opponents(pb, j: int) -> np.ndarray:
    """The opponents' predicted poses at sample ``j``: one standing at s = 80 m, one driving at 12 m/s, the rest far."""
    opp = np.zeros((pb.horizon.N + 1, pb.opponents.count, 3))
    opp[..., 0], opp[..., 1] = -1000.0, 500.0
    opp[:, 0, 0], opp[:, 0, 1] = 80.0, -1.0
    opp[:, 1, 0] = 20.0 + 12.0 * (j * pb.horizon.dt + np.arange(pb.horizon.N + 1) * pb.horizon.interval)
    opp[:, 1, 1] = -1.5
    return opp


def run(name: str, budget: int, samples: int) -> dict:
    """The reference and the C side by side with ``qp.rti_budget = budget``."""
    base = preset(name)
    pb = dataclasses.replace(
        base, name=f"b{budget}_{base.name[:20]}", qp=dataclasses.replace(base.qp, rti_budget=budget)
    )
    ocp = build_ocp(pb)
    road = road_of(pb)
    shapes = np.array([obs.opponent_shape(pb.obstacles, pb.ego, ln, wd, off) for ln, wd, off in SHAPES])
    ref, cs = ReferenceController(ocp), CSolver(ensure_solver(pb, CACHE))
    assert cs.init() == 0
    assert ref.set_opponent_shapes(shapes) == 0 and cs.set_opponent_shapes(shapes) == 0
    plant = Plant(pb, ocp.road_params.samples)
    x0 = np.array([0.0, 2.0, 0.0, 15.0, 0.0])
    xr, xc, iters, apart = [x0], [x0], [], 0.0
    for j in range(samples):
        opp = opponents(pb, j)
        for xs, ctl in ((xr, ref), (xc, cs)):
            r = ctl.step(xs[-1], road.window(xs[-1][0] - 10.0, pb.road.samples), opp)
            xs.append(plant.step(xs[-1], r.u, road))
            if ctl is ref:
                iters.append(int(r.qp_iter))
        apart = max(apart, float(np.max(np.abs(xc[-1] - xr[-1]))))
    v = np.array([x[3] for x in xr])
    stop = np.flatnonzero(v < 0.01)
    return {
        "budget": budget,
        "s_end": float(xr[-1][0]),
        "stop_sample": int(stop[0]) if stop.size else None,
        "qp_iter_mean": float(np.mean(iters)),
        "qp_iter_max": int(max(iters)),
        "qps_at_budget": int(sum(i >= budget for i in iters)),
        "c_apart_max": apart,
    }


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("presets", nargs="*", default=list(PRESETS))
    ap.add_argument("--budgets", default="7,10,20,60")
    ap.add_argument("--samples", type=int, default=30)
    ap.add_argument("--json", type=Path)
    args = ap.parse_args()
    out = {}
    for name in args.presets:
        rows = [run(name, int(b), args.samples) for b in args.budgets.split(",")]
        out[name] = rows
        print(name)
        for r in rows:
            stop = "-" if r["stop_sample"] is None else r["stop_sample"]
            print(
                f"  budget {r['budget']:3d}: s at the end {r['s_end']:7.2f} m, stopped at sample {stop}, QP iterations"
                f" mean {r['qp_iter_mean']:.1f} max {r['qp_iter_max']}, {r['qps_at_budget']} of {args.samples} at the"
                f" budget; C - reference, largest state difference {r['c_apart_max']:.1e}"
            )
    if args.json:
        args.json.write_text(json.dumps(out, indent=1) + "\n")


if __name__ == "__main__":
    main()
