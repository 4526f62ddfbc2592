"""Single-precision OSQP accuracy: a float build's capped QP solves against the double solve of the same QPs.

The independent expectation is OSQP's Python package (double) run on the very QPs the float C solver solved (its
data, read back with get_qp, and its warm start) with the float build's settings: the two differ only by float's
rounding. On the 24 warm-started QPs of truck seed 0, samples 1-24 (max |z_float - z_double| of the scaled step):
with the double build's sigma = 1e-6 in float, median 3.5e-3 and max 4.6e-2; with FLOAT_SIGMA_MIN = 1e-3, median
7e-5 and max 4e-4 (docs/performance.md, "Single precision in closed loop").
"""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pytest

from fcgen.backends import osqp as osqp_backend
from fcgen.build import build
from fcgen.codegen.generate import generate
from fcgen.csolver import QpRecorder
from fcgen.dsl import QpOptions
from fcgen.ocp import build_ocp
from fcgen.presets import preset
from fcgen.qp import build_layout
from fcgen.sim.closedloop import run_closed_loop
from fcgen.sim.scenario import make_scenario

PRESET = "truck_lifted_ellipse"
SAMPLES = 25


def _float_vs_double(tmp: Path) -> np.ndarray:
    """max |z_float - z_double| (scaled step) of each warm-started QP of a short float closed loop (truck seed 0)."""
    pb = preset(PRESET).with_(name="flacc")
    ocp = build_ocp(pb)
    lay = build_layout(ocp)
    rec = QpRecorder(build(generate(pb, tmp / "f", use_float=True, force=True).out_dir), lay)
    run_closed_loop(pb, make_scenario("truck", 0, n_opp=3, samples=SAMPLES, dt=pb.horizon.dt), controller=rec, ocp=ocp)
    ref = osqp_backend.Backend(lay, dataclasses.replace(pb.qp, sigma=osqp_backend.osqp_sigma(pb.qp, True)))
    diffs = []
    for qp in rec.qps:
        ref.set_matrices(qp["P_x"], qp["A_x"], qp["q"])
        res = ref.solve(qp["q"], qp["l"], qp["u"], qp["y_warm"], pb.qp.max_iter)
        diffs.append(np.max(np.abs(qp["z"] - res.z)))
    assert len(diffs) == SAMPLES - 1  # every sample but the cold first one
    return np.array(diffs)


def test_float_osqp_tracks_double(tmp_path: Path) -> None:
    d = _float_vs_double(tmp_path)
    assert np.median(d) < 5e-4 and np.max(d) < 5e-3, (np.median(d), np.max(d))  # measured: 7e-5, 4e-4


def test_float_osqp_with_double_sigma_does_not(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """The check above can fail: with the double build's sigma (1e-6) in float it does."""
    monkeypatch.setattr(osqp_backend, "FLOAT_SIGMA_MIN", 1e-6)
    d = _float_vs_double(tmp_path)
    assert np.median(d) > 1e-3 and np.max(d) > 1e-2, (np.median(d), np.max(d))  # measured: 3.5e-3, 4.6e-2


def test_float_sigma_rule() -> None:
    """Only a float build changes sigma, and only upwards: a larger qp.sigma is kept."""
    assert osqp_backend.osqp_settings(QpOptions())["sigma"] == 1e-6
    assert osqp_backend.osqp_settings(QpOptions(), use_float=True)["sigma"] == osqp_backend.FLOAT_SIGMA_MIN == 1e-3
    assert osqp_backend.osqp_sigma(QpOptions(sigma=0.01), use_float=True) == 0.01
