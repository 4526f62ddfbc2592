"""Does Mehrotra's corrector pay on every step? The Python IPM on recorded QPs, the corrector skipped where the
predictor's step to the boundary a_aff is at least a threshold (docs/performance.md).

    python benchmarks/ipm_corrector_skip.py [--preset truck_lifted_ellipse_ipm] [--thresholds 2,0.95,0.9]
        [--qps results/ipm_qps/truck_lifted_ellipse_ipm_s2.bin]

The QPs: the file ``benchmarks/ipm_kernel_profile.py`` records (run it first). A threshold above 1 is the backend as
it is. Per threshold: IPM iterations over all QPs, the steps that skipped the corrector, the statuses. The variant
only exists here (a replaced ``Backend._step``), the backend is unchanged.
"""

from __future__ import annotations

import argparse
import struct
from collections import Counter
from pathlib import Path

import numpy as np

from fcgen.backends import ipm
from fcgen.ocp import build_ocp
from fcgen.presets import preset
from fcgen.qp import build_layout

_STEP = ipm.Backend._step


def skipping_step(threshold: float, counter: Counter):
    """``Backend._step`` that takes the predictor's step (tau of the way to the boundary) where a_aff >= threshold."""

    def _step(self, t, lam, r_d, r_eq, r_p, mu):
        inv_t = 1.0 / t
        W = np.zeros(self.lay.m + 1)
        np.add.at(W, self.sv.side_row, lam * inv_t)
        if not self._factor(W):
            return 5, ()
        dz, dnu, dt, dlam = self._direction(t * lam, lam, inv_t, r_d, r_eq, r_p)
        a_aff = ipm._max_step(t, lam, dt, dlam)
        counter["steps"] += 1
        if a_aff < threshold:
            return _STEP(self, t, lam, r_d, r_eq, r_p, mu)  # the predictor again: the counts, not the cost, matter
        counter["skipped"] += 1
        if not np.all(np.isfinite(dz)):
            return 4, ()
        return 0, (min(1.0, self.set.tau * a_aff), dz, dnu, dt, dlam)

    return _step


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--preset", default="truck_lifted_ellipse_ipm")
    ap.add_argument("--thresholds", default="2,0.95,0.9")
    ap.add_argument("--qps", type=Path, default=None, help="default: results/ipm_qps/<preset>_s2.bin")
    args = ap.parse_args()
    pb = preset(args.preset)
    lay = build_layout(build_ocp(pb))
    n, m, nnz = lay.n, lay.m, lay.nnz_A
    raw = (args.qps or Path(f"results/ipm_qps/{args.preset}_s2.bin")).read_bytes()
    count = struct.unpack("i", raw[:4])[0]
    data = np.frombuffer(raw[4:], dtype=np.float64).reshape(count, n + 3 * m + nnz)
    for thr in (float(x) for x in args.thresholds.split(",")):
        counter: Counter = Counter()
        ipm.Backend._step = skipping_step(thr, counter) if thr <= 1.0 else _STEP  # type: ignore[method-assign]
        be = ipm.Backend(lay, pb.qp)
        iters, status = 0, Counter()
        for row in data:
            q, lo, up = row[:n], row[n : n + m], row[n + m : n + 2 * m]
            be.set_matrices(lay.P_diag, row[n + 2 * m : n + 2 * m + nnz], q)
            res = be.solve(q, lo, up, row[n + 2 * m + nnz :], 60)
            iters += res.iter
            status[res.status] += 1
        ipm.Backend._step = _STEP  # type: ignore[method-assign]
        print(f"a_aff >= {thr}: {iters} iterations, corrector skipped {counter['skipped']}, {dict(status)}", flush=True)


if __name__ == "__main__":
    main()
