"""Why float OSQP is less accurate per iteration than double, per sigma (docs/performance.md, float section).

Usage: .venv/bin/python benchmarks/float_kkt_diagnosis.py [OUT_DIR] [--sigmas 1e-6,1e-4,1e-3] [--seeds 0] [--every 5]

The QPs of a double closed loop of truck_lifted_ellipse (C, truck seeds, every EVERY-th warm-started sample) are
solved by OSQP's embedded code built for each sigma in double and in float (benchmarks/float_kkt_harness.c compiled
with the generated folder's OSQP sources; the float builds take sigma as given, FLOAT_SIGMA_MIN disabled), against a
converged double solution (eps 1e-9). Per sigma and precision (median / max over the QPs):
  kkt      one KKT solve at the converged solution, from OSQP's own right-hand side: |x_tilde - x| (scaled), which
           is 0 in exact arithmetic; float: also from the right-hand side formed in double (double rhs);
           kkt+1: with one step of iterative refinement in working precision
  pivots   smallest positive and largest |negative| pivot of the LDL' factorization (median over the QPs)
  capped   the real-time solve (the problem's settings: 60 iterations, check every 40) minus the double one of the
           same sigma, and minus the double build's (sigma 1e-6), max |z - z'| (scaled step); status counts
"""

import argparse
import collections
import ctypes
import dataclasses
import subprocess
from pathlib import Path

import numpy as np

import fcgen.backends.osqp as osqp_backend
from fcgen.build import build
from fcgen.codegen.generate import generate
from fcgen.csolver import QpRecorder
from fcgen.ocp import build_ocp
from fcgen.presets import preset
from fcgen.qp import build_layout
from fcgen.sim.closedloop import run_closed_loop
from fcgen.sim.scenario import make_scenario

HARNESS = Path(__file__).with_name("float_kkt_harness.c")
PRESET = "truck_lifted_ellipse"


class Harness:
    """One OSQP build (a generated folder's workspace + library) loaded through ctypes."""

    def __init__(self, folder: Path, name: str, use_float: bool):
        so = folder / "harness.so"
        inc = [f"-I{folder / d}" for d in ("osqp", "osqp/lib", "osqp/lib/inc/public", "osqp/lib/inc/private")]
        srcs = [
            str(HARNESS),
            str(folder / f"osqp/{name}_workspace.c"),
            *sorted(map(str, (folder / "osqp/lib/src").glob("*.c"))),
        ]
        subprocess.run(
            [
                "cc",
                "-O2",
                "-fPIC",
                "-shared",
                "-std=c99",
                "-w",
                *inc,
                f'-DWS_HEADER="{name}_workspace.h"',
                f"-DSOLVER={name}_solver",
                f"-DRESET={name}_workspace_reset",
                *srcs,
                "-o",
                str(so),
                "-lm",
            ],
            check=True,
        )
        self.lib = ctypes.CDLL(str(so))
        self.lib.h_settings.argtypes = [ctypes.c_int, ctypes.c_int, ctypes.c_double, ctypes.c_double]
        self.dt = np.float32 if use_float else np.float64

    def _p(self, a: np.ndarray):
        return a.ctypes.data_as(ctypes.c_void_p)

    def _a(self, v) -> np.ndarray:
        return np.ascontiguousarray(v, dtype=self.dt)

    def load(self, qp: dict) -> None:
        self._data = [self._a(qp[k]) for k in ("P_x", "A_x", "q", "l", "u")]
        self.n, self.m = len(qp["q"]), len(qp["l"])
        if self.lib.h_load(*map(self._p, self._data), self.n, len(qp["A_x"])) != 0:
            raise RuntimeError("h_load failed")

    def solve(self, y0, x0=None, max_iter: int = 60, check: int = 40, eps: float = 1e-3):
        self.lib.h_settings(max_iter, check, eps, eps)
        x0 = self._a(np.zeros(self.n) if x0 is None else x0)
        y0 = self._a(y0)
        x, y, it = np.zeros(self.n, self.dt), np.zeros(self.m, self.dt), ctypes.c_int()
        st = self.lib.h_solve(self._p(x0), self._p(y0), self._p(x), self._p(y), ctypes.byref(it))
        return st, x.astype(float), y.astype(float)

    def rhs(self, x, y) -> tuple[np.ndarray, np.ndarray]:
        """OSQP's right-hand side at the warm start (x, y), and the scaled x."""
        b, xs = np.zeros(self.n + self.m, self.dt), np.zeros(self.n, self.dt)
        self.lib.h_rhs(self._p(self._a(x)), self._p(self._a(y)), self._p(b), self._p(xs))
        return b.astype(float), xs.astype(float)

    def kkt(self, b, nref: int) -> np.ndarray:
        """x_tilde of one KKT solve of b (nref steps of iterative refinement)."""
        b = self._a(b)
        self.lib.h_kkt(self._p(b), nref)
        return b[: self.n].astype(float)

    def kkt_error(self, x, y, nref: int, b=None) -> float:
        """One KKT solve at (x, y) from OSQP's right-hand side (or b): max |x_tilde - x| (scaled)."""
        own, xs = self.rhs(x, y)
        return float(np.max(np.abs(self.kkt(own if b is None else b, nref) - xs)))

    def pivots(self) -> tuple[float, float]:
        d = np.zeros(self.n + self.m, self.dt)
        self.lib.h_pivots(self._p(d))
        d = d.astype(float)
        return float(d[d > 0].min()), float(-d[d < 0].min())


def folder(root: Path, sigma: float, use_float: bool, tag: str) -> tuple[Path, str]:
    """truck_lifted_ellipse generated with this sigma (named kd_<tag>) into root/kd_<tag>."""
    pb = preset(PRESET)
    name = f"kd_{tag}"
    pb = pb.with_(name=name, qp=dataclasses.replace(pb.qp, sigma=sigma))
    generate(pb, root / name, use_float=use_float, force=True)
    return root / name, name


def med_max(v) -> str:
    return f"{np.median(v):.1e} / {np.max(v):.1e}"


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("out_dir", nargs="?", default="runs/float_kkt_diagnosis")
    ap.add_argument("--sigmas", default="1e-6,1e-4,1e-3")
    ap.add_argument("--seeds", default="0", help="comma-separated truck seeds of the double closed loop")
    ap.add_argument("--every", type=int, default=5, help="keep every EVERY-th warm-started QP")
    args = ap.parse_args()
    root = Path(args.out_dir)
    osqp_backend.FLOAT_SIGMA_MIN = 0.0  # the float builds take each sigma as given
    pb = preset(PRESET)
    ocp = build_ocp(pb)
    rec = QpRecorder(build(generate(pb.with_(name="kd_loop"), root / "kd_loop", force=True).out_dir), build_layout(ocp))
    for seed in (int(s) for s in args.seeds.split(",")):
        rec.init()
        run_closed_loop(
            pb, make_scenario("truck", seed, n_opp=3, samples=200, dt=pb.horizon.dt), controller=rec, ocp=ocp
        )
    qps = rec.qps[:: args.every]
    sigmas = [float(s) for s in args.sigmas.split(",")]
    builds = {
        (s, fl): Harness(*folder(root, s, fl, f"{'f' if fl else 'd'}{i}"), fl)
        for i, s in enumerate(sigmas)
        for fl in (False, True)
    }
    base = builds.get((pb.qp.sigma, False)) or Harness(*folder(root, pb.qp.sigma, False, "base"), False)
    ref, z_base = [], []
    for qp in qps:  # converged double solution and the double build's capped solve
        base.load(qp)
        _, x, y = base.solve(qp["y_warm"], max_iter=100000, check=10, eps=1e-9)
        ref.append((x, y))
        z_base.append(base.solve(qp["y_warm"])[1])
    print(f"{len(qps)} QPs (truck seeds {args.seeds}, every {args.every}-th warm-started sample); median / max")
    for s in sigmas:
        z_dbl = []
        for fl in (False, True):
            h = builds[(s, fl)]
            kkt, kkt_d, kkt1, pmin, pmax, cap_same, cap_base = [], [], [], [], [], [], []
            status = collections.Counter()
            for j, qp in enumerate(qps):
                if fl:  # the right-hand side formed in double (before h.load: each load rescales what h holds)
                    builds[(s, False)].load(qp)
                    b_dbl = builds[(s, False)].rhs(*ref[j])[0]
                h.load(qp)
                kkt.append(h.kkt_error(*ref[j], 0))
                if fl:
                    kkt_d.append(h.kkt_error(*ref[j], 0, b=b_dbl))
                kkt1.append(h.kkt_error(*ref[j], 1))
                lo, hi = h.pivots()
                pmin.append(lo)
                pmax.append(hi)
                st, z, _ = h.solve(qp["y_warm"])
                status[st] += 1
                if not fl:
                    z_dbl.append(z)
                cap_same.append(np.max(np.abs(z - z_dbl[j])))
                cap_base.append(np.max(np.abs(z - z_base[j])))
            dr = f" (double rhs {med_max(kkt_d)})" if fl else ""
            prec = "float " if fl else "double"
            print(
                f"sigma {s:g} {prec}: kkt {med_max(kkt)}{dr} | kkt+1 {med_max(kkt1)} | pivots "
                f"min {np.median(pmin):.1e}, max |neg| {np.median(pmax):.1e} | capped - double same sigma "
                f"{med_max(cap_same)}, - double build {med_max(cap_base)} | status {dict(sorted(status.items()))}",
                flush=True,
            )


if __name__ == "__main__":
    main()
