"""The IPM's initial floors: iterations on recorded QPs with other ``lam_min`` / ``lam_center`` (docs/performance.md).

    python benchmarks/ipm_start_floors.py [--variants "0.1/0.5,0.003/0.3"] [--qps-dir results/ipm_qps] [PRESET ...]

Per preset (default: the 11 of docs/performance.md) the C solver's warm QPs of a closed loop on seeds 0-1 are
recorded once into QPS_DIR/<preset>_s2.bin (``ipm_iteration_bench.record``; kept, as ``ipm_kernel_profile.py``
keeps them), then solved by the Python IPM with each variant ``lam_min/lam_center`` (the first is the default,
0.1/0.5). Printed per preset and variant: the iterations over all QPs, the worst QP's, the statuses. The variants
exist only here (``IpmSettings``); the backend is unchanged.
"""

from __future__ import annotations

import argparse
import dataclasses
import struct
import sys
import tempfile
from collections import Counter
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

from ipm_iteration_bench import record, write_qps

from fcgen.backends import ipm
from fcgen.codegen.generate import generate
from fcgen.ocp import build_ocp
from fcgen.presets import preset
from fcgen.qp import build_layout

PRESETS = (
    "truck_lifted_ellipse_ipm",
    "truck_lifted_ellipse_ipm_safe",
    "truck_direct_elimination_ellipse_ipm_safe",
    "car_direct_elimination_circles_ipm",
    "truck_conventional_ellipse_ipm",
    "truck_lifted_hyperplane_ipm_safe",
    "car_conventional_hyperplane_ipm_safe",
    "truck_lifted_circles_ipm",
    "truck_direct_elimination_circles_ipm",
    "truck_lifted_circles_ipm_safe",
    "car_lifted_hyperplane_ipm",
)


def qps_of(name: str, folder: Path) -> np.ndarray:
    """The preset's recorded QPs (recorded first if the file is missing): one row per QP, q | l | u | A_x | y_warm."""
    path = folder / f"{name}_s2.bin"
    if not path.exists():
        folder.mkdir(parents=True, exist_ok=True)
        with tempfile.TemporaryDirectory() as tmp:
            gen = generate(preset(name), Path(tmp) / "s")
            write_qps(path, record(gen.out_dir, 2)[1])
    lay = build_layout(build_ocp(preset(name)))
    raw = path.read_bytes()
    count = struct.unpack("i", raw[:4])[0]
    return np.frombuffer(raw[4:], dtype=np.float64).reshape(count, lay.n + 3 * lay.m + lay.nnz_A)


def solve_all(name: str, data: np.ndarray, lam_min: float, lam_center: float) -> tuple[int, int, dict]:
    """Total and largest iterations, and the statuses, of the Python IPM with these floors on every recorded QP."""
    pb = preset(name)
    lay = build_layout(build_ocp(pb))
    n, m, nnz = lay.n, lay.m, lay.nnz_A
    settings = dataclasses.replace(ipm.ipm_settings(pb.qp), lam_min=lam_min, lam_center=lam_center)
    be = ipm.Backend(lay, pb.qp, settings)
    total, worst, status = 0, 0, Counter()
    for row in data:
        q, lo, up = row[:n], row[n : n + m], row[n + m : n + 2 * m]
        be.set_matrices(lay.P_diag, row[n + 2 * m : n + 2 * m + nnz], q)
        res = be.solve(q, lo, up, row[n + 2 * m + nnz :], 60)
        total, worst = total + res.iter, max(worst, res.iter)
        status[res.status] += 1
    return total, worst, dict(status)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("presets", nargs="*", default=list(PRESETS))
    ap.add_argument("--variants", default="0.1/0.5,0.003/0.3", help="lam_min/lam_center, comma-separated")
    ap.add_argument("--qps-dir", type=Path, default=Path("results/ipm_qps"))
    args = ap.parse_args()
    variants = [tuple(float(x) for x in v.split("/")) for v in args.variants.split(",")]
    sums = Counter()
    for name in args.presets:
        data = qps_of(name, args.qps_dir)
        for lam_min, lam_center in variants:
            total, worst, status = solve_all(name, data, lam_min, lam_center)
            sums[(lam_min, lam_center)] += total
            print(
                f"{name}: lam_min {lam_min:g}, lam_center {lam_center:g}: {total} iterations over {len(data)} QPs,"
                f" worst {worst}, statuses {status}",
                flush=True,
            )
    for (lam_min, lam_center), total in sums.items():
        print(f"all: lam_min {lam_min:g}, lam_center {lam_center:g}: {total} iterations")


if __name__ == "__main__":
    main()
