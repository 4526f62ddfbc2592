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


@pytest.mark.parametrize("D", [1, 2])
def test_prediction_is_the_state_the_plant_reaches(D):
    pb = PB.with_(delay=D)
    ctrl = ReferenceController(build_ocp(pb))
    planned = []
    step = ctrl.step

    def recording_step(x0, road, opp):
        r = step(x0, road, opp)
        planned.append(ctrl.solver.x_plan.copy())
        return r

    ctrl.step = recording_step
    sc = make_scenario("truck", 0, n_opp=pb.opponents.count, samples=40, dt=pb.horizon.dt)
    log = run_closed_loop(pb, sc, controller=ctrl, plant=PlantSpec(latency=D))
    xs = np.asarray(log.ego_frenet)
    assert np.max(np.abs(np.array(planned[: 40 - D]) - xs[D:40])) < 1e-9
    # the controls it predicted with are the ones the plant got: the latency's queue, zeros first
    assert np.array_equal(np.asarray(log.control_applied)[D:], np.asarray(log.control)[:-D])


def test_no_delay_plans_from_the_measurement():
    ctrl = ReferenceController(build_ocp(PB))
    sc = make_scenario("truck", 0, n_opp=PB.opponents.count, samples=3, dt=PB.horizon.dt)
    run_closed_loop(PB, sc, controller=ctrl)
    assert ctrl.solver.x_plan is ctrl.solver.x0 and ctrl.solver.u_hist.shape == (0, 2)


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
    assert f"#define DELAY_SAMPLES {D}" in text and "delay_push();" in text


def test_cli_generate_refuses_a_bad_delay(tmp_path):
    from click.testing import CliRunner

    from fcgen.cli import main

    res = CliRunner().invoke(main, ["generate", "truck_lifted_ellipse", "--delay", "9", "-o", str(tmp_path / "x")])
    assert res.exit_code == 1
    assert "--delay: delay = 9 is invalid: allowed an integer in [0, 8] samples" in res.output
    assert not (tmp_path / "x").exists()
