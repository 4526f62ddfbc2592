"""The plant options on CommonRoad scenarios (``fcgen.sim.commonroad_plant``, ``simulate --commonroad --plant``): the
default is fcgen's model bit for bit; CommonRoad's single-track model on a straight lane drives what the kinematic
model drives; a prediction margin is refused with one line (predictions: tests/test_cr_prediction.py)."""

from __future__ import annotations

import numpy as np
import pytest
from click.testing import CliRunner
from crscenes import write_scenario

from fcgen.campaign.commonroad import load_for
from fcgen.cli import main
from fcgen.ocp import build_ocp
from fcgen.presets import preset
from fcgen.sim.closedloop import Plant
from fcgen.sim.commonroad_plant import ScenarioPlant
from fcgen.sim.commonroad_run import run_commonroad, scenario_road
from fcgen.sim.plants import PlantSpec

pytestmark = [
    pytest.mark.filterwarnings("ignore::UserWarning"),
    pytest.mark.filterwarnings("ignore::DeprecationWarning"),
]
PB = preset("car_lifted_ellipse_ipm_safe")


@pytest.fixture(scope="module")
def lane(tmp_path_factory):
    """Three straight lanes, no traffic, the ego at 20 m/s in the middle one, 15 samples."""
    return write_scenario(tmp_path_factory.mktemp("cp") / "p.xml", goal_steps=(15, 15))


def test_the_default_plant_is_fcgens_model_bit_for_bit(lane):
    sc = load_for(PB, lane)
    road, _ = scenario_road(PB, sc)
    model = Plant(PB, build_ocp(PB).road_params.samples)
    plant = ScenarioPlant(PB, PlantSpec(), model, sc.x0, road)
    x = np.asarray(sc.x0, dtype=float)
    assert plant.measure(x) is x
    u = np.array([800.0, 0.05])
    np.testing.assert_array_equal(plant.step(x, u, road), model.step(x, u, road))
    with pytest.raises(ValueError, match="prediction_margin is not for a CommonRoad run"):
        ScenarioPlant(PB, PlantSpec(prediction="constant-velocity", prediction_margin=1.0), model, sc.x0, road)


def test_the_single_track_plant_on_a_straight_lane_drives_as_the_model(lane):
    """No traffic, the lane's centre as the reference: the lateral offset stays within 1 cm of the kinematic run's
    and the speed within 0.1 m/s (no lateral acceleration for the tyres to differ in); the log names the plant."""
    sc = load_for(PB, lane)
    ref = run_commonroad(PB, sc)
    st = run_commonroad(PB, sc, plant=PlantSpec("st"))
    a, b = np.asarray(ref.log.ego_frenet), np.asarray(st.log.ego_frenet)
    assert len(a) == len(b) == 16
    assert np.max(np.abs(a[:, 1] - b[:, 1])) < 0.01
    assert np.max(np.abs(a[:, 3] - b[:, 3])) < 0.1
    assert st.log.meta["extra"]["plant"]["kind"] == "st"
    assert "plant" not in ref.log.meta["extra"]


def test_simulate_commonroad_with_a_plant_and_a_refused_prediction(lane):
    args = ["simulate", "--commonroad", str(lane), "--problem", "car_lifted_ellipse_ipm_safe", "--samples", "3"]
    r = CliRunner().invoke(main, [*args, "--plant", "st", "--latency", "1"])
    assert r.exit_code == 0, r.output
    assert "plant st+lat1 | samples whose control the plant's input limits cut:" in r.output
    assert "band: lanes; the way back widened it at " in r.output
    r = CliRunner().invoke(main, [*args, "--prediction", "constant-velocity", "--prediction-margin", "0.5"])
    assert r.exit_code != 0
    assert "--prediction-margin is not for --commonroad" in r.output
