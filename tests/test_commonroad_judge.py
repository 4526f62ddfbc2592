"""The checks a CommonRoad drive is judged by, whoever drove it (fcgen.sim.commonroad_judge): a drive given as
Cartesian rear-axle states (a peer planner's, benchmarks/reactive_planner_peer.py) on the scenario road's frame, and
its verdicts against hand-derived contacts."""

from __future__ import annotations

import math
import warnings

import numpy as np
import pytest
from crscenes import LANE, write_scenario

from fcgen.campaign.commonroad import load_for
from fcgen.presets import preset
from fcgen.sim.commonroad_judge import judge_drive, states_on_road
from fcgen.sim.commonroad_run import scenario_road

pytestmark = [
    pytest.mark.filterwarnings("ignore::UserWarning"),
    pytest.mark.filterwarnings("ignore::DeprecationWarning"),
]
PB = preset("car_lifted_ellipse_ipm")
CAR = PB.ego
STANDING = (1, 1, 150.0, 0.0, 120, 4.5, 1.8)  # (id, lane, s0, speed, recorded steps, length, width)


@pytest.fixture(scope="module")
def straight(tmp_path_factory):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return load_for(PB, write_scenario(tmp_path_factory.mktemp("cr") / "straight.xml", obstacles=[STANDING]))


def _drive(centre_y: np.ndarray, phi: float = 0.0) -> np.ndarray:
    """Rear-axle states [x, y, phi, v, delta]: the centre at x = 100 + j (1 m a step, 10 m/s), ``centre_y``."""
    j = np.arange(len(centre_y))
    return np.column_stack(
        [100.0 + j - CAR.l / 2, centre_y, np.full(len(j), phi), np.full(len(j), 10.0), np.zeros(len(j))]
    )


def test_cartesian_states_on_the_road_frame(straight):
    """The road runs along x with the ego's start centre (50, 0) at rear-axle s = x0[0]: a rear axle at (x, 0.5)
    is at s = x0[0] + x - (50 - l/2), n = 0.5; a heading of 2 pi is alpha 0; speed and steering pass through."""
    road, _ = scenario_road(PB, straight)
    states = _drive(np.full(5, 0.5), phi=2 * math.pi)
    xs, poses = states_on_road(road, states)
    np.testing.assert_allclose(xs[:, 0], straight.x0[0] + states[:, 0] - (50.0 - CAR.l / 2), atol=1e-6)
    np.testing.assert_allclose(xs[:, 1], 0.5, atol=1e-9)
    np.testing.assert_allclose(xs[:, 2], 0.0, atol=1e-12)
    np.testing.assert_array_equal(xs[:, 3:], states[:, 3:])
    np.testing.assert_array_equal(poses, states[:, :3])
    with pytest.raises(ValueError, match=r"states: must be finite \(K \+ 1, 5\)"):
        states_on_road(road, states[:, :4])
    states[2, 3] = np.nan
    with pytest.raises(ValueError, match=r"states: must be finite"):
        states_on_road(road, states)


def test_a_lane_change_into_a_standing_car_is_judged_by_every_check(straight):
    """The centre moves from the right lane (y = -3.5) to the standing car's lane over samples 36-46 (0.35 m a
    sample) at 1 m a sample: the rectangles (ego 4 m, the car 4.5 m centred at x = 150) meet when 100 + j + 2 >
    147.75 with y = 0, first at sample 46, by fcgen's check and the drivability checker alike; the ego changed its
    lane within the second before: it moved into the opponent; the solution hits an obstacle and does not start at
    the scenario's initial state (50, 0)."""
    road, _ = scenario_road(PB, straight)
    y = np.concatenate([np.full(36, -LANE), -LANE + 0.35 * np.arange(1, 11), np.zeros(14)])
    xs, poses = states_on_road(road, _drive(y))
    v = judge_drive(PB, straight, road, xs, poses)
    assert v.fcgen["collision"] and v.fcgen["collision_step"] == 46 and v.fcgen["obstacle_id"] == 1
    assert v.checker["collision"] and v.checker["collision_step"] == 46
    assert v.responsibility == "ego_into_opponent"
    assert v.solution["obstacle_collision"] and not v.solution["starts_at_initial_state"]
    np.testing.assert_allclose(v.centres[:, :2], np.column_stack([100.0 + np.arange(60), y]), atol=1e-9)
    # the same drive in the right lane throughout: no contact, nobody responsible
    xs, poses = states_on_road(road, _drive(np.full(60, -LANE)))
    v = judge_drive(PB, straight, road, xs, poses)
    assert not v.fcgen["collision"] and not v.checker["collision"] and v.responsibility == ""
