"""The firmware harness under perturbations (docs/plants.md): latency, a steering actuator's lag and seeded
measurement noise between a delay-compensated C solver and fcgen's plant, the same as the Python closed loop with the
same compiled solver and the same seeded perturbations; each perturbation checked by hand on the C run log."""

from __future__ import annotations

import math

import numpy as np
import pytest
from click.testing import CliRunner

from fcgen.presets import paper_problem
from fcgen.sim.export import HarnessPlantError, export_scenario, harness_plant, measurement_noise
from fcgen.sim.plants import DEFAULT_NOISE, PlantSpec
from fcgen.sim.scenario import make_scenario

PB = paper_problem("truck", "lifted", "ellipse").with_(delay=1)
K = 40
SPEC = PlantSpec(latency=1, steer_lag=0.1, noise=DEFAULT_NOISE)


@pytest.fixture(scope="module")
def solver(tmp_path_factory):
    from fcgen.codegen.generate import generate

    out = tmp_path_factory.mktemp("perturbed") / "s"
    generate(PB, out)
    return out


@pytest.fixture(scope="module")
def runs(solver, tmp_path_factory):
    """The C harness and the Python closed loop with the same compiled solver (verification build), seed 3."""
    from fcgen.csolver import CSolver
    from fcgen.sim.closedloop import run_closed_loop
    from fcgen.sim.harness import firmware_sim

    d = tmp_path_factory.mktemp("runs")
    log_c = firmware_sim(solver, "truck", 3, K, d / "c.json", verify=True, plant=SPEC)
    sc = make_scenario("truck", 3, n_opp=PB.opponents.count, samples=K, dt=PB.horizon.dt)
    log_py = run_closed_loop(PB, sc, controller=CSolver.from_dir(solver, verify=True), plant=SPEC)
    return log_c, log_py


def test_c_equals_python_under_latency_lag_noise_and_compensation(runs):
    """Same states, computed and applied controls, QP figures: the perturbations are the same draws and formulas
    (the harness's tolerance: its plant is the generated C, the Python loop's CasADi's own evaluation)."""
    log_c, log_py = runs
    for f in ("ego_frenet", "ego_cartesian", "control", "control_applied", "a_lat", "a_lat_model", "max_slack"):
        np.testing.assert_allclose(getattr(log_c, f), getattr(log_py, f), rtol=1e-6, atol=1e-6, err_msg=f)
    assert np.array_equal(log_c.qp_iter, log_py.qp_iter) and np.array_equal(log_c.qp_status, log_py.qp_status)
    assert np.array_equal(log_c.plant_cut, np.zeros(K, dtype=int))
    assert log_c.meta["extra"]["plant"] == SPEC.as_meta() == log_py.meta["extra"]["plant"]
    assert log_c.meta["extra"]["max_abs_a_lat_model"] == pytest.approx(float(np.max(np.abs(log_c.a_lat))), abs=0)


def test_latency_and_lag_by_hand(runs):
    """One sample of latency: the plant's steering rate command at sample j is the control computed at j - 1 (zero
    at j = 0); the drive force is applied unchanged. The lag: with the commanded angle c (integral of the command)
    and the plant's angle delta, e = c - delta follows e' = r - e / tau exactly over each sample."""
    log_c, _ = runs
    u, ua, x = np.asarray(log_c.control), np.asarray(log_c.control_applied), np.asarray(log_c.ego_frenet)
    cmd = np.vstack([np.zeros((1, 2)), u[:-1]])  # the latency's queue: zeros first
    np.testing.assert_array_equal(ua[:, 0], cmd[:, 0])
    assert not np.allclose(ua[:, 1], cmd[:, 1], atol=1e-6)  # the lag moved the steering rate
    h, tau = PB.horizon.dt, SPEC.steer_lag
    c = x[0, 4] + h * np.concatenate([[0.0], np.cumsum(cmd[:, 1])])
    e = c - x[:, 4]  # fcgen's plant integrates delta' = r exactly: the angle is the applied rate's integral
    r = cmd[:, 1]
    np.testing.assert_allclose(e[1:], r * tau + (e[:-1] - r * tau) * math.exp(-h / tau), rtol=0, atol=1e-12)


def test_noise_is_the_seeded_draws_in_the_scenario_file(solver, tmp_path):
    """The file carries each sample's measurement error: the Python loop's draws (same seed, same errors; another
    seed, others), with the stds asked for; the harness measures x + error."""
    sc = make_scenario("truck", 3, n_opp=PB.opponents.count, samples=K, dt=PB.horizon.dt)
    path = export_scenario(PB, sc, tmp_path / "sc.txt", plant=SPEC)
    lines = path.read_text().splitlines()
    errs = np.array([[float(v) for v in ln.split()[1:]] for ln in lines if ln.startswith("measurement_error ")])
    assert errs.shape == (K, 5)
    np.testing.assert_array_equal(errs, measurement_noise(SPEC, 3, K, PB.horizon.dt))
    assert "latency 1" in lines and "steer_lag 0.10000000000000001" in lines
    assert not np.array_equal(errs, measurement_noise(SPEC, 4, K, PB.horizon.dt))
    many = measurement_noise(SPEC, 3, 4000, PB.horizon.dt)  # the stds per state, to sampling error (~1.1 %)
    np.testing.assert_allclose(many.std(axis=0), DEFAULT_NOISE, rtol=0.05)
    assert abs(np.corrcoef(many[:, 0], many[:, 1])[0, 1]) < 0.05  # independent per state


def test_unperturbed_file_has_no_perturbation_lines(tmp_path):
    pb = paper_problem("truck", "lifted", "ellipse")
    sc = make_scenario("truck", 0, n_opp=pb.opponents.count, samples=3, dt=pb.horizon.dt)
    text = export_scenario(pb, sc, tmp_path / "sc.txt").read_text()
    assert not any(w in text for w in ("latency", "steer_lag", "noise", "measurement_error", "prediction"))
    assert harness_plant(PB, None) == PlantSpec(latency=1)  # a compensated solver: its latency by default


def test_a_file_refuses_what_it_cannot_hold_naming_the_option():
    for spec, opt in (
        (PlantSpec(kind="st"), "--plant st"),
        (PlantSpec(params="matched"), "--plant-params matched"),
        (PlantSpec(prediction="constant-velocity", prediction_margin=1.0), "--prediction-margin"),
    ):
        with pytest.raises(HarnessPlantError, match=opt):
            harness_plant(PB, spec)


def test_cli_firmware_sim_with_perturbations(solver, tmp_path):
    """The command takes the plant options; an explicit --latency 0 runs a compensated solver without latency."""
    from fcgen.cli import main
    from fcgen.sim.runlog import RunLog

    args = ["firmware-sim", str(solver), "--seed", "3", "--samples", "5", "--verify"]
    res = CliRunner().invoke(main, [*args, "--noise", "default", "--out", str(tmp_path / "a.json")])
    assert res.exit_code == 0, res.output
    assert RunLog.from_json(tmp_path / "a.json").meta["extra"]["plant"]["noise"] == list(DEFAULT_NOISE)
    res = CliRunner().invoke(main, [*args, "--latency", "0", "--out", str(tmp_path / "b.json")])
    assert res.exit_code == 0, res.output
    assert "plant" not in RunLog.from_json(tmp_path / "b.json").meta["extra"]
    res = CliRunner().invoke(main, [*args, "--plant", "st", "--target", "cortex-m7", "--out", str(tmp_path / "c.json")])
    assert res.exit_code == 1 and "--plant st: the host steps the plant in lockstep with the host harness" in res.output


def test_st_plant_on_the_host_c_equals_python(solver, tmp_path):
    """CommonRoad's single-track plant stepped on the host in lockstep with the C harness (sim.cosim), with latency,
    steering lag, noise and the solver's compensation: the Python closed loop with the same compiled solver, bit for
    bit (the same plant code on both sides, the numbers crossing the pipe as %.17g)."""
    from fcgen.csolver import CSolver
    from fcgen.sim.closedloop import run_closed_loop
    from fcgen.sim.harness import firmware_sim

    spec = PlantSpec(kind="st", latency=1, steer_lag=0.1, noise=DEFAULT_NOISE)
    log_c = firmware_sim(solver, "truck", 3, K, tmp_path / "c.json", verify=True, plant=spec)
    sc = make_scenario("truck", 3, n_opp=PB.opponents.count, samples=K, dt=PB.horizon.dt)
    log_py = run_closed_loop(PB, sc, controller=CSolver.from_dir(solver, verify=True), plant=spec)
    for f in ("ego_frenet", "control", "control_applied", "a_lat", "a_lat_model", "plant_cut", "qp_iter"):
        assert np.array_equal(getattr(log_c, f), getattr(log_py, f)), f
    assert log_c.meta["extra"]["plant"] == spec.as_meta()
    for k in ("plant_cut_samples", "plant_cut_steer_rate", "max_abs_a_lat_model"):
        assert log_c.meta["extra"][k] == log_py.meta["extra"][k], k
    assert not np.allclose(log_c.a_lat, log_c.a_lat_model, atol=1e-3)  # the tyre's a_lat, not the formula's


def test_simulate_refuses_a_problem_without_the_solvers_delay(solver):
    """The closed loop hands a compensated solver the opponents from the plan's start (Problem.delay samples ahead):
    a --problem without the folder's delay would hand them out of step, so it is refused naming the fix."""
    from fcgen.cli import main

    args = ["simulate", "--controller", "c", "--solver-dir", str(solver), "--samples", "2", "--latency", "1"]
    res = CliRunner().invoke(main, [*args, "--problem", "truck_lifted_ellipse"])
    assert res.exit_code == 1
    assert f"compensates delay = 1 samples, the problem 'truck_lift_el' has delay = 0: give --problem {solver}" in (
        res.output
    )
    res = CliRunner().invoke(main, [*args, "--problem", str(solver / "problem.py")])
    assert res.exit_code == 0, res.output


def test_cosim_names_a_harness_out_of_turn(tmp_path):
    """A harness that answers a sample with anything but its control line stops the co-simulation with one error
    naming the sample and the line (and the harness is ended)."""
    from fcgen.sim.cosim import CosimError, run_cosim

    fake = tmp_path / "fake_harness"
    fake.write_text("#!/bin/sh\necho 'hello'\ncat > /dev/null\n")
    fake.chmod(0o755)
    pb = paper_problem("truck", "lifted", "ellipse")
    sc = make_scenario("truck", 0, n_opp=pb.opponents.count, samples=3, dt=pb.horizon.dt)
    with pytest.raises(CosimError, match=r"sample 0: expected the line 'u 0 F_D R' from the harness, got 'hello'"):
        run_cosim(fake, pb, sc, PlantSpec(kind="st"), tmp_path / "run.json", timeout=60)


def test_prediction_in_the_harness_c_equals_python(solver, tmp_path):
    """With --prediction the file's opp_params are the prediction's futures: the Python loop's, to the tolerance."""
    from fcgen.csolver import CSolver
    from fcgen.sim.closedloop import run_closed_loop
    from fcgen.sim.harness import firmware_sim

    spec = PlantSpec(latency=1, noise=DEFAULT_NOISE, prediction="constant-velocity")
    log_c = firmware_sim(solver, "truck", 3, 20, tmp_path / "c.json", verify=True, plant=spec)
    sc = make_scenario("truck", 3, n_opp=PB.opponents.count, samples=20, dt=PB.horizon.dt)
    log_py = run_closed_loop(PB, sc, controller=CSolver.from_dir(solver, verify=True), plant=spec)
    np.testing.assert_allclose(log_c.ego_frenet, log_py.ego_frenet, rtol=0, atol=1e-6)
    np.testing.assert_allclose(log_c.control, log_py.control, rtol=1e-6, atol=1e-6)
    assert log_c.meta["extra"]["plant"] == spec.as_meta()
    assert "prediction constant-velocity" in next(solver.rglob("scenario_truck_seed3_20_*cv.txt")).read_text()
