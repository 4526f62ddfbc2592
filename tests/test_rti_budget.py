"""The RTI budget (``QpOptions.rti_budget``): validated, the caps it gives (Python reference and generated C alike),
the header's ``<NAME>_RTI_BUDGET``; a tiny budget runs a closed loop without a crash, C = Python: QP_MAX_ITER
statuses, finite controls within the input box."""

from __future__ import annotations

import re
import shutil
from dataclasses import replace

import numpy as np
import pytest

from fcgen.backends import QP_MAX_ITER
from fcgen.build import build
from fcgen.codegen.generate import generate
from fcgen.csolver import CSolver
from fcgen.dsl import RTI_BUDGET_DEFAULT, Horizon, ProblemError, QpOptions
from fcgen.presets import paper_problem, preset
from fcgen.reference import cold_max_iter, input_box, warm_max_iter
from fcgen.sim.closedloop import run_closed_loop
from fcgen.sim.scenario import make_scenario

needs_cc = pytest.mark.skipif(any(shutil.which(t) is None for t in ("gcc", "make")), reason="needs gcc and make")


@pytest.mark.parametrize("bad", [0, 1_000_001, 2.5, True, "10"])
def test_rti_budget_is_validated(bad):
    with pytest.raises(ProblemError, match=re.escape("qp.rti_budget") + r".*\[1, 1e6\]"):
        QpOptions(rti_budget=bad)


def test_caps_are_the_budget_applied_to_both_caps():
    assert QpOptions(rti_budget=25).caps == (25, 25)
    assert QpOptions(rti_budget=100).caps == (60, 100)
    assert QpOptions(rti_budget=1_000_000).caps == (60, 400)
    assert QpOptions(max_iter=80, max_iter_cold=10, rti_budget=50).caps == (50, 50)  # cold never below warm
    o = QpOptions(rti_budget=7)
    assert (warm_max_iter(o), cold_max_iter(o)) == (7, 7)


def test_default_budget_is_the_backends():
    """None resolves per backend: OSQP keeps its two caps, the IPM gets its measured default."""
    assert RTI_BUDGET_DEFAULT["osqp"] is None and QpOptions().caps == (60, 400)
    ipm = QpOptions(backend="ipm")
    assert ipm.budget == RTI_BUDGET_DEFAULT["ipm"]
    assert ipm.caps == (min(60, ipm.budget or 60), min(400, ipm.budget or 400))
    assert preset("truck_lifted_hyperplane_ipm").qp.rti_budget is None  # not measured: the backend's default


def test_measured_presets_and_campaign_runs_share_the_budget():
    """IPM_RTI_BUDGET's configurations: their _ipm preset and the campaign's IPM run of them carry the budget (one
    problem, the one fcgen wcet bounds); the safe profile and the other configurations keep the default; OSQP's
    presets and campaign runs carry OSQP_MAX_ITER's cap."""
    from fcgen.campaign.grid import Config
    from fcgen.presets import IPM_RTI_BUDGET

    assert IPM_RTI_BUDGET[("paper", "lifted", "ellipse")] == 7
    for sc in ("car", "truck"):
        for f in ("conventional", "direct_elimination", "lifted"):
            for o, n in (("ellipse", 0), ("hyperplane", 0)):
                want = IPM_RTI_BUDGET.get(("paper", f, o))
                pb = preset(f"{sc}_{f}_{o}_ipm")
                assert pb.qp.rti_budget == want and pb.qp.budget == (want or RTI_BUDGET_DEFAULT["ipm"])
                assert Config(sc, f, o, n, backend="ipm").problem().qp == pb.qp
                assert preset(f"{sc}_{f}_{o}_ipm_safe").qp == QpOptions(backend="ipm")
                # the paper's OSQP presets: the defaults but the IPM's start (the paper profile's, no effect on OSQP)
                # and the measured ADMM cap (35 with the ellipse, 60 with the hyperplanes), as their campaign runs
                cap = {"ellipse": 35, "hyperplane": 60}[o]
                assert preset(f"{sc}_{f}_{o}").qp == replace(QpOptions(), ipm_scaled_start=False, max_iter=cap)
                assert Config(sc, f, o, n).problem().qp == preset(f"{sc}_{f}_{o}").qp


@needs_cc
@pytest.mark.parametrize("backend", ["ipm", "osqp"])
def test_tiny_budget_closed_loop(backend, tmp_path):
    """Budget 2: every QP stops at QP_MAX_ITER; its step is taken where finite and its u0 within the input box's
    margin, else the fallback: either way the applied control is finite and inside the box, and C (verification
    build) = Python sample by sample."""
    pb = paper_problem(
        "truck",
        "lifted",
        "ellipse",
        horizon=Horizon(N=10),
        name=f"tiny_{backend}",
        qp=QpOptions(backend=backend, rti_budget=2),
    )
    info = generate(pb, tmp_path / "gen")
    header = (info.out_dir / f"{info.name}_solver.h").read_text()
    solver = (info.out_dir / f"{info.name}_solver.c").read_text()
    assert f"#define {info.name.upper()}_RTI_BUDGET 2 " in header
    assert re.search(r"^#define MAX_ITER 2 ", solver, re.M) and re.search(r"^#define MAX_ITER_COLD 2 ", solver, re.M)
    lib = build(info.out_dir, verify=True)
    sc = make_scenario("truck", 1, n_opp=pb.opponents.count, samples=40, dt=pb.horizon.dt)
    log_c = run_closed_loop(pb, sc, controller=CSolver(lib), exit_codes=True)
    log_py = run_closed_loop(pb, sc, exit_codes=True)
    lo, hi, _ = input_box(pb)
    for log in (log_c, log_py):
        assert np.all(log.qp_iter <= 2) and np.all(log.qp_status == QP_MAX_ITER)
        assert np.all(np.isfinite(log.control)) and np.all(log.control >= lo) and np.all(log.control <= hi)
        assert np.all(np.isfinite(log.ego_frenet))
    np.testing.assert_array_equal(log_c.qp_iter, log_py.qp_iter)
    np.testing.assert_array_equal(log_c.qp_status, log_py.qp_status)
    np.testing.assert_array_equal(log_c.exit_code, log_py.exit_code)
    np.testing.assert_allclose(log_c.ego_frenet, log_py.ego_frenet, rtol=0, atol=1e-6)
