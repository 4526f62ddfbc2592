"""Delay compensation (``Problem.delay``, docs/plants.md): the solver plans from the measured state predicted over D
samples with the controls it handed out last. With fcgen's own plant, D samples of latency and no noise, that
prediction is the state the plant reaches: the plan starts where its first control will act."""

from __future__ import annotations

import numpy as np
import pytest

from fcgen.dsl import ProblemError
from fcgen.ocp import build_ocp
from fcgen.presets import paper_problem
from fcgen.sim.closedloop import ReferenceController, run_closed_loop
from fcgen.sim.plants import PlantSpec
from fcgen.sim.scenario import make_scenario

PB = paper_problem("truck", "lifted", "ellipse", profile="safe")


def test_delay_validated_naming_field_and_range():
    for bad in (-1, 9, 1.5, True):
        with pytest.raises(ProblemError, match=r"delay = .* is invalid: allowed an integer in \[0, 8\] samples"):
            PB.with_(delay=bad)


def predicted_run(pb, D: int, tau: float = 0.0):
    """40 samples of the truck scenario with ``pb``'s reference solver and a plant of latency ``D`` and steering lag
    ``tau``: the plans' start states (the delay compensation's predictions) and the run log."""
    ctrl = ReferenceController(build_ocp(pb))
    planned = []
    step = ctrl.step

    def recording_step(x0, road, opp):
        r = step(x0, road, opp)
        planned.append(ctrl.solver.x_plan.copy())
        return r

    ctrl.step = recording_step
    sc = make_scenario("truck", 0, n_opp=pb.opponents.count, samples=40, dt=pb.horizon.dt)
    return planned, run_closed_loop(pb, sc, controller=ctrl, plant=PlantSpec(latency=D, steer_lag=tau))


@pytest.mark.parametrize("D", [1, 2])
def test_prediction_is_the_state_the_plant_reaches(D):
    planned, log = predicted_run(PB.with_(delay=D), D)
    xs = np.asarray(log.ego_frenet)
    assert np.max(np.abs(np.array(planned[: 40 - D]) - xs[D:40])) < 1e-9
    # the controls it predicted with are the ones the plant got: the latency's queue, zeros first
    assert np.array_equal(np.asarray(log.control_applied)[D:], np.asarray(log.control)[:-D])


def test_no_delay_plans_from_the_measurement():
    ctrl = ReferenceController(build_ocp(PB))
    sc = make_scenario("truck", 0, n_opp=PB.opponents.count, samples=3, dt=PB.horizon.dt)
    run_closed_loop(PB, sc, controller=ctrl)
    assert ctrl.solver.x_plan is ctrl.solver.x0 and ctrl.solver.delay_line.u_hist.shape == (0, 2)


def test_problem_source_names_delay_only_when_set():
    from fcgen.codegen.generate import problem_source

    assert "delay" not in problem_source(PB)
    assert "delay=2" in problem_source(PB.with_(delay=2))


@pytest.mark.parametrize("name, D", [("truck_lifted_ellipse_ipm_safe", 2), ("car_direct_elimination_ellipse_safe", 1)])
def test_c_equals_python_with_latency_noise_lag_and_the_st_plant(tmp_path, name, D):
    """The generated C's delay compensation does what the reference's does (fcgen verify: lockstep and two closed
    loops under the same seeded perturbations)."""
    from fcgen.codegen.generate import generate
    from fcgen.presets import preset
    from fcgen.sim.plants import DEFAULT_NOISE
    from fcgen.verify import verify

    generate(preset(name).with_(delay=D), tmp_path / name)
    spec = PlantSpec(kind="st", latency=D, steer_lag=0.1, noise=DEFAULT_NOISE)
    rep = verify(tmp_path / name, seed=4, samples=60, plant=spec)
    assert rep.passed, rep.format()
    text = (tmp_path / name / f"{preset(name).name}_solver.c").read_text()
    assert "delay_push();" in text
    header = (tmp_path / name / f"{preset(name).name}_solver.h").read_text()
    assert f"#define {preset(name).name.upper()}_DELAY {D}" in header


def test_cli_generate_refuses_a_bad_delay(tmp_path):
    from click.testing import CliRunner

    from fcgen.cli import main

    res = CliRunner().invoke(main, ["generate", "truck_lifted_ellipse", "--delay", "9", "-o", str(tmp_path / "x")])
    assert res.exit_code == 1
    assert "--delay: delay = 9 is invalid: allowed an integer in [0, 8] samples" in res.output
    assert not (tmp_path / "x").exists()


def test_firmware_harness_runs_the_delay_with_its_latency(tmp_path):
    """The C harness applies each control Problem.delay samples late (the scenario file's "latency" line) and gives
    the solver the opponents from the plan's start: the Python closed loop with the compiled solver and the same
    latency, to the harness's tolerance."""
    from fcgen.codegen.generate import generate
    from fcgen.csolver import CSolver
    from fcgen.sim.harness import firmware_sim

    pb = paper_problem("truck", "lifted", "ellipse").with_(delay=1)
    generate(pb, tmp_path / "s")
    log_c = firmware_sim(tmp_path / "s", scenario="truck", seed=0, samples=40, out=tmp_path / "run.json")
    sc = make_scenario("truck", 0, n_opp=pb.opponents.count, samples=40, dt=pb.horizon.dt)
    cs = CSolver.from_dir(tmp_path / "s")
    log_py = run_closed_loop(pb, sc, controller=cs, plant=PlantSpec(latency=1))
    np.testing.assert_allclose(log_c.ego_frenet, log_py.ego_frenet, rtol=0, atol=1e-6)
    np.testing.assert_allclose(log_c.control, log_py.control, rtol=1e-6, atol=1e-6)
    assert "latency 1" in next((tmp_path / "s").rglob("scenario_truck_seed0_40*.txt")).read_text()


def test_fmu_carries_the_delay_compensation(tmp_path):
    """An FMU of a delay-compensated solver records its delay and runs as the C library does, bit for bit, on the st
    plant with the latency it compensates."""
    from fcgen.codegen.generate import generate
    from fcgen.csolver import CSolver
    from fcgen.fmu import FmuController, build_fmu, fmu_problem

    pb = paper_problem("truck", "lifted", "ellipse").with_(delay=1)
    generate(pb, tmp_path / "s")
    fmu = build_fmu(tmp_path / "s", tmp_path / "s.fmu")
    assert fmu_problem(fmu).delay == 1
    sc = make_scenario("truck", 2, n_opp=pb.opponents.count, samples=30, dt=pb.horizon.dt)
    spec = PlantSpec(kind="st", latency=1)
    log_f = run_closed_loop(pb, sc, controller=FmuController(fmu, pb), plant=spec)
    log_c = run_closed_loop(pb, sc, controller=CSolver.from_dir(tmp_path / "s"), plant=spec)
    assert np.array_equal(log_f.ego_frenet, log_c.ego_frenet) and np.array_equal(log_f.control, log_c.control)
