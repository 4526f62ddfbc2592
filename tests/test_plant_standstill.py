"""The closed loop's plant at a standstill: resistance and brakes stop a vehicle, they never move it backwards."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from fcgen.ocp import road_window_samples
from fcgen.plant import plant_function
from fcgen.presets import paper_problem
from fcgen.road import straight_road
from fcgen.sim.closedloop import Plant


@pytest.fixture(scope="module")
def setup():
    pb = paper_problem("car", "lifted", "ellipse")
    K = road_window_samples(pb)
    return pb, Plant(pb, K), straight_road(length=800.0, ds=pb.road.ds, s0=-100.0)


def test_a_standing_vehicle_without_enough_drive_stays_where_it_is(setup):
    """v = 0, a drive force below the rolling resistance (and a brake force): the model alone would go to
    -(c_roll - F_d) / m * dt; the plant keeps the pose, v = 0, and turns the wheels by r * dt."""
    pb, plant, road = setup
    x = np.array([10.0, 0.3, 0.02, 0.0, 0.01])
    for F in (0.0, 0.5 * pb.ego.c_roll, -3000.0):
        u = np.array([F, 0.05])
        xn = plant.step(x, u, road)
        assert xn[3] == 0.0
        np.testing.assert_array_equal(xn[:3], x[:3])
        assert xn[4] == pytest.approx(x[4] + 0.05 * pb.horizon.dt, abs=1e-15)
        step = plant.road_stepper(road)
        assert step(x, u).tobytes() == xn.tobytes()


def test_a_braking_vehicle_stops_within_the_sample_where_the_ode_says(setup):
    """From 0.3 m/s, braking hard on a straight road (the preset's head wind): stopped at the end of the sample,
    after the distance the longitudinal ODE integrated to v = 0 gives (scipy's event, an independent integrator)."""
    pb, plant, road = setup
    ego, F = pb.ego, -4000.0
    assert pb.wind.phi == 0.0  # the road runs along x: the wind's whole speed adds to the ego's
    x = np.array([10.0, 0.0, 0.0, 0.3, 0.0])
    u = np.array([F, 0.0])
    xn = plant.step(x, u, road)

    def rhs(_t, y):
        v_rel = y[1] + pb.wind.v
        return [y[1], (F - ego.c_air * v_rel * abs(v_rel) - ego.c_roll) / ego.m]

    def halt(_t, y):
        return y[1]

    halt.terminal, halt.direction = True, -1
    sol = solve_ivp(rhs, (0.0, pb.horizon.dt), [0.0, 0.3], events=halt, rtol=1e-12, atol=1e-12)
    assert sol.t_events[0].size == 1  # the ODE stops inside the sample
    assert xn[3] == 0.0
    assert xn[0] - x[0] == pytest.approx(sol.y_events[0][0][0], abs=1e-6)
    np.testing.assert_array_equal(xn[1:3], x[1:3])
    assert plant.road_stepper(road)(x, u).tobytes() == xn.tobytes()


def test_a_vehicle_that_moves_on_is_the_models_step_bit_for_bit(setup):
    """No stop within the sample (driving off from rest, braking at speed): the plant is the model's RK4 step."""
    pb, plant, road = setup
    f = plant_function(pb, road_window_samples(pb))
    for x, F in (([10.0, 0.0, 0.0, 0.0, 0.0], 2.0 * pb.ego.c_roll), ([10.0, 0.2, 0.01, 8.0, 0.0], -4000.0)):
        x = np.array(x)
        u = np.array([F, 0.01])
        xn = plant.step(x, u, road)
        assert xn[3] > 0.0
        p = np.zeros(plant.road_params.size)
        plant.road_params.pack_into(p, road, int(np.floor((x[0] - road.s0) / road.ds)) - 1)
        assert xn.tobytes() == np.array(f(x, u, p)).ravel().tobytes()
