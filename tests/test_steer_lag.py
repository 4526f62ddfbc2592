"""The steering lag the solver models (``Problem.steer_lag``, docs/plants.md): the delay compensation's prediction and
the a_lat guard's plant step apply each commanded steering rate through a first-order actuator whose lag (commanded
minus actual angle) the solver keeps. With fcgen's own plant, D samples of latency, the closed loop's steering
actuator of the same time constant and no noise, the prediction is the state the plant reaches (the closed loop's
actuator, ``sim.plants.actuation``, is the second method)."""

from __future__ import annotations

import numpy as np
import pytest
from test_delay import predicted_run

from fcgen.dsl import ProblemError
from fcgen.presets import paper_problem
from fcgen.sim.plants import PlantSpec

PB = paper_problem("truck", "lifted", "ellipse", profile="safe")


def test_steer_lag_validated_naming_field_and_range():
    for bad in (-0.1, 2.5, float("nan"), True):
        with pytest.raises(ProblemError, match=r"steer_lag = .* is invalid: allowed \[0, 2\] s"):
            PB.with_(steer_lag=bad)


def test_problem_source_names_the_lag_only_when_set():
    from fcgen.codegen.generate import problem_source

    assert "steer_lag" not in problem_source(PB)
    assert "steer_lag=0.1" in problem_source(PB.with_(steer_lag=0.1))


@pytest.mark.parametrize("D, tau", [(1, 0.1), (2, 0.2)])
def test_prediction_through_the_lag_is_the_state_the_plant_reaches(D, tau):
    pb = PB.with_(delay=D, steer_lag=tau)
    planned, log = predicted_run(pb, D, tau)
    xs = np.asarray(log.ego_frenet)
    rates = np.asarray(log.control)[:, 1]
    assert np.ptp(rates) > 0.05  # the run steers: the lag matters
    assert np.max(np.abs(np.array(planned[: 40 - D]) - xs[D:40])) < 1e-9
    # a prediction without the lag (the steering angle integrating the commanded rates) misses the plant's by far more
    u = np.vstack([np.zeros((D, 2)), np.asarray(log.control)])
    no_lag = [xs[j, 4] + pb.horizon.dt * np.sum(u[j : j + D, 1]) for j in range(40 - D)]
    assert np.max(np.abs(np.array(no_lag) - xs[D:40, 4])) > 1e-3


@pytest.mark.parametrize("name, D", [("truck_lifted_ellipse_ipm_safe", 1), ("car_direct_elimination_ellipse_safe", 0)])
def test_c_equals_python_with_the_lag_modelled(tmp_path, name, D):
    """The generated C's lag (prediction, guard step and rate, the lag's update) does what the reference's does
    (fcgen verify: lockstep and two closed loops under the same seeded perturbations, the st plant, latency D,
    the closed loop's steering lag of the same time constant, noise)."""
    from fcgen.codegen.generate import generate
    from fcgen.presets import preset
    from fcgen.sim.plants import DEFAULT_NOISE
    from fcgen.verify import verify

    generate(preset(name).with_(delay=D, steer_lag=0.1), tmp_path / name)
    spec = PlantSpec(kind="st", latency=D, steer_lag=0.1, noise=DEFAULT_NOISE)
    rep = verify(tmp_path / name, seed=7, samples=60, plant=spec)
    assert rep.passed, rep.format()
    text = (tmp_path / name / f"{preset(name).name}_solver.c").read_text()
    assert "actuator_push();" in text and "#define LAG_TAU" in text
