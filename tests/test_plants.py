"""CommonRoad's vehicle models as plants (docs/plants.md): the state mapping against hand-derived values (a straight
line at constant speed, a steady circle, a stop), the integrator's convergence, the input limits, and the actuation
between controller and plant (latency, steering lag, noise)."""

from __future__ import annotations

import itertools
import math
from dataclasses import replace

import numpy as np
import pytest

from fcgen.dsl import ProblemError, Wind
from fcgen.presets import paper_problem
from fcgen.road import Road, straight_road
from fcgen.sim.plants import DEFAULT_NOISE, PlantSpec, mapping, parse_noise, plant_of
from fcgen.sim.plants.actuation import Actuation
from fcgen.sim.plants.commonroad_vm import (
    CUT_STEER_RATE,
    CommonRoadPlant,
    matched_ego,
    plant_parameters,
)

PB = paper_problem("car", "lifted", "ellipse")


def _hold_force(pb, v: float, psi: float = 0.0) -> float:
    """The drive force that holds speed v against drag (with wind) and rolling resistance."""
    return -pb.ego.m * mapping.drive_acceleration(0.0, v, psi, pb.ego.m, pb.ego.c_air, pb.ego.c_roll, pb.wind)


def test_mapping_round_trip_kinematic_steady_state():
    a, b, delta, v = 1.2, 1.5, 0.1, 15.0
    x = mapping.rear_to_cog(3.0, -2.0, 0.4, v, delta, a, b)
    beta = math.atan(b * math.tan(delta) / (a + b))  # hand: the kinematic slip angle at the centre of gravity
    assert x[6] == pytest.approx(beta, abs=1e-15)
    assert x[3] * math.cos(beta) == pytest.approx(v, abs=1e-12)  # the body's longitudinal speed is fcgen's v
    assert x[5] == pytest.approx(v * math.tan(delta) / (a + b), abs=1e-15)
    assert x[0] == pytest.approx(3.0 + b * math.cos(0.4)) and x[1] == pytest.approx(-2.0 + b * math.sin(0.4))
    back = mapping.cog_to_rear(x[0], x[1], x[4], x[3] * math.cos(x[6]), x[2], b)
    assert back == pytest.approx((3.0, -2.0, 0.4, v, delta), abs=1e-12)


@pytest.mark.parametrize("kind", ["ks", "st"])
def test_straight_line_constant_speed_exact(kind):
    pl = CommonRoadPlant(PB, kind)
    pl.reset([10.0, 1.5, 0.0, 20.0, 0.0], straight_road(800.0))
    u = (_hold_force(PB, 20.0), 0.0)
    for _ in range(30):
        x, info = pl.step(u)
        assert info.a_lat == 0.0 and info.a_lat_model == 0.0 and info.cut == 0
    assert x == pytest.approx([10.0 + 20.0 * 3.0, 1.5, 0.0, 20.0, 0.0], abs=1e-9)


@pytest.mark.parametrize("kind", ["std", "mb"])
def test_straight_line_constant_speed_tyre_models(kind):
    """The drift and multi-body models hold the line with their own tyre slip and suspension settling: within cm."""
    pl = CommonRoadPlant(PB, kind)
    pl.reset([10.0, 1.5, 0.0, 20.0, 0.0], straight_road(800.0))
    for _ in range(20):
        x, _ = pl.step((_hold_force(PB, 20.0), 0.0))
    assert x[0] == pytest.approx(50.0, abs=0.05) and x[1] == pytest.approx(1.5, abs=0.05)
    assert abs(x[2]) < 2e-3 and x[3] == pytest.approx(20.0, abs=0.05)


def test_steady_circle_ks_stays_on_the_circle():
    """ks on a road of curvature tan(delta)/l: the rear axle stays on the centre line, heading along it."""
    delta, v = 0.05, 15.0
    kappa = math.tan(delta) / PB.ego.l
    road = Road.from_curvature(np.full(400, kappa), 1.0)
    pbw = PB.with_(wind=Wind(v=0.0))  # the wind's drag would change along the circle
    pl = CommonRoadPlant(pbw, "ks")
    pl.reset([5.0, 0.0, 0.0, v, delta], road)
    for _ in range(30):
        x, info = pl.step((_hold_force(pbw, v), 0.0))
        assert info.a_lat == pytest.approx(v * v * math.tan(delta) / PB.ego.l, rel=1e-9)
        assert info.a_lat_model == pytest.approx(info.a_lat, rel=1e-9)
    assert x[0] == pytest.approx(5.0 + v * 3.0, abs=1e-3)
    assert abs(x[1]) < 1e-6 and abs(x[2]) < 1e-6 and x[3] == pytest.approx(v, abs=1e-9)


def test_steady_circle_st_hand_derived():
    """st with a = b (the paper's geometry) and equal axle cornering coefficients is neutral steer: the steady circle
    has psi' = v delta / l and beta = delta (b - v^2 / (mu C g)) / l (its two dynamic equations set to zero); the
    plant's a_lat there is v psi' cos(beta) = v^2 delta cos(beta) / l."""
    pbw = PB.with_(wind=Wind(v=0.0))
    pl = CommonRoadPlant(pbw, "st")
    p = pl.p
    mu, C, g = p.tire.p_dy1, -p.tire.p_ky1 / p.tire.p_dy1, 9.81
    lwb, delta, v = p.a + p.b, 0.03, 18.0
    beta = delta * (p.b - v * v / (mu * C * g)) / lwb
    x = [0.0, 0.0, delta, v, 0.0, v * delta / lwb, beta]
    f = pl._f(x, (_hold_force(pbw, v * math.cos(beta)) * pl.m / pbw.ego.m, 0.0))
    assert f[3] == pytest.approx(0.0, abs=1e-12)  # the hold force: no longitudinal acceleration
    assert f[5] == pytest.approx(0.0, abs=1e-9) and f[6] == pytest.approx(0.0, abs=1e-9)
    info = pl.lateral_acceleration((_hold_force(pbw, v * math.cos(beta)), 0.0), x)
    assert info.a_lat == pytest.approx(v * v * delta * math.cos(beta) / lwb, rel=1e-9)
    assert info.a_lat_model == pytest.approx((v * math.cos(beta)) ** 2 * math.tan(delta) / lwb, rel=1e-12)


@pytest.mark.parametrize("kind", ["ks", "st"])
def test_stop(kind):
    """Constant deceleration 3 m/s^2 from 6 m/s: standstill after 2 s, 6 m further (no drag, no wind)."""
    pb = PB.with_(wind=Wind(v=0.0), ego=replace(PB.ego, c_air=0.0))
    pl = CommonRoadPlant(pb, kind)
    pl.reset([0.0, 0.0, 0.0, 6.0, 0.0], straight_road(200.0))
    for _ in range(20):
        x, _ = pl.step((pb.ego.c_roll - 3.0 * pb.ego.m, 0.0))
    assert x == pytest.approx([6.0, 0.0, 0.0, 0.0, 0.0], abs=1e-9)


@pytest.mark.parametrize("kind", ["ks", "st"])
def test_standing_car_with_a_drive_force_below_the_resistance_stays(kind):
    """v = 0 and a drive force of half the rolling resistance (no wind, no drag): the net force -c_roll / 2 would
    take the car backwards at -c_roll / (2 m) per second; resistance only opposes motion, so it stands."""
    pb = PB.with_(wind=Wind(v=0.0), ego=replace(PB.ego, c_air=0.0))
    pl = CommonRoadPlant(pb, kind)
    pl.reset([5.0, 0.5, 0.0, 0.0, 0.0], straight_road(200.0))
    for _ in range(10):
        x, _ = pl.step((0.5 * pb.ego.c_roll, 0.0))
    assert x == pytest.approx([5.0, 0.5, 0.0, 0.0, 0.0], abs=1e-12)


def _manoeuvre(substeps: int) -> np.ndarray:
    pl = CommonRoadPlant(PB, "st", substeps=substeps)
    pl.reset([0.0, 0.0, 0.0, 20.0, 0.0], straight_road(800.0))
    out = []
    for j in range(30):  # a lane change: steer left, back, right, back
        r = 0.3 * (1, -1, -1, 1)[min(j // 5, 3)] if j < 20 else 0.0
        pl.step((_hold_force(PB, 20.0) + 800.0, r))
        out.append(pl.x)
    return np.array(out)


def test_integrator_converged_against_half_step():
    """st at dt/20 against dt/40 and dt/80 on a lane change at 20 m/s: fourth order, and dt/20 within 1e-7 of the
    halved step on every state (measured: 7.1e-9, ratio 16; docs/plants.md)."""
    x20, x40, x80 = _manoeuvre(20), _manoeuvre(40), _manoeuvre(80)
    e20, e40 = np.max(np.abs(x20 - x40)), np.max(np.abs(x40 - x80))
    assert e20 < 1e-7
    assert 8.0 < e20 / e40 < 24.0  # RK4: 16


def test_input_limit_cuts_the_steering_rate():
    pl = CommonRoadPlant(PB, "st")
    pl.reset([0.0, 0.0, 0.0, 20.0, 0.0], straight_road(400.0))
    x, info = pl.step((_hold_force(PB, 20.0), 0.5))  # the BMW's steering velocity limit: 0.4 rad/s
    assert info.cut & CUT_STEER_RATE
    assert x[4] == pytest.approx(0.4 * PB.horizon.dt, abs=1e-12)


def test_parameter_sets():
    p, q = plant_parameters(PB.ego, "matched"), plant_parameters(PB.ego, "paper")
    assert (q.a, q.b, q.m) == (1.7, 1.7, 1160.0)
    assert q.I_z / (q.m * q.a * q.b) == pytest.approx(p.I_z / (p.m * p.a * p.b), rel=1e-12)
    assert q.tire.p_ky1 == p.tire.p_ky1 and q.steering.v_max == 0.4
    e = matched_ego(PB.ego)
    assert (e.l_f, e.l_r, e.m) == (p.a, p.b, p.m) and e.w_ch == PB.ego.w_ch


def test_latency_queue_starts_with_zero_controls():
    act = Actuation(PlantSpec(latency=2), seed=0, dt=0.1)
    got = [act.actuate(np.array([float(k), 0.1 * k]), 0.0) for k in range(1, 5)]
    assert np.allclose(got, [[0, 0], [0, 0], [1, 0.1], [2, 0.2]])


def test_steering_lag_is_the_first_order_response():
    """A constant commanded rate r from rest: delta(t) = r (t - tau (1 - exp(-t/tau))) at every sample end."""
    tau, r, dt = 0.1, 0.2, 0.1
    act = Actuation(PlantSpec(steer_lag=tau), seed=0, dt=dt)
    delta = 0.0
    for k in range(1, 11):
        delta += dt * act.actuate(np.array([0.0, r]), delta)[1]
        t = k * dt
        assert delta == pytest.approx(r * (t - tau * (1 - math.exp(-t / tau))), abs=1e-14)


def test_noise_seeded_and_scaled():
    x = np.zeros(5)
    a = [Actuation(PlantSpec(noise=DEFAULT_NOISE), 7, 0.1) for _ in range(2)]
    assert np.array_equal(a[0].measure(x), a[1].measure(x))
    assert not np.array_equal(Actuation(PlantSpec(noise=DEFAULT_NOISE), 8, 0.1).measure(x), a[0].measure(x))
    draws = np.array([a[0].measure(x) for _ in range(4000)])
    assert np.allclose(draws.std(axis=0), DEFAULT_NOISE, rtol=0.05)


def test_spec_validation_names_the_field():
    with pytest.raises(ProblemError, match=r"latency = 9 is invalid: allowed an integer in \[0, 8\]"):
        PlantSpec(latency=9)
    with pytest.raises(ProblemError, match="plant = 'bicycle'"):
        PlantSpec(kind="bicycle")
    with pytest.raises(ProblemError, match="noise"):
        parse_noise("1,2")
    assert parse_noise("default") == DEFAULT_NOISE and PlantSpec().is_default


def test_closed_loop_on_st_logs_plant_and_model_a_lat():
    from fcgen.sim.closedloop import run_closed_loop
    from fcgen.sim.runlog import RunLog
    from fcgen.sim.scenario import make_scenario

    pb = paper_problem("car", "lifted", "ellipse", profile="safe")
    sc = make_scenario("car", 3, n_opp=pb.opponents.count, samples=25, dt=pb.horizon.dt)
    spec = PlantSpec(kind="st", latency=1, noise=DEFAULT_NOISE, steer_lag=0.1)
    a, b = run_closed_loop(pb, sc, plant=spec), run_closed_loop(pb, sc, plant=spec)
    assert np.array_equal(a.ego_frenet, b.ego_frenet)  # the same seed: the same run, noise included
    assert a.a_lat_model.shape == a.a_lat.shape and not np.allclose(a.a_lat, a.a_lat_model)
    xs = np.asarray(a.ego_frenet)
    assert np.allclose(a.a_lat_model, xs[:, 3] ** 2 * np.tan(xs[:, 4]) / pb.ego.l)
    assert np.array_equal(a.control_applied[1:, 0], a.control[:-1, 0])  # one sample of latency (F_d: no lag)
    assert np.array_equal(a.control_applied[0], [0.0, 0.0])
    back = RunLog.from_json_string(a.to_json_string())
    assert plant_of(back) == spec and np.array_equal(back.plant_cut, a.plant_cut)


def test_campaign_row_of_a_perturbed_configuration():
    from fcgen.campaign.grid import Config, Task
    from fcgen.campaign.task import run_task

    spec = PlantSpec(kind="st", latency=1, noise=DEFAULT_NOISE)
    cfg = Config("car", "lifted", "ellipse", controller="python", profile="safe", plant=spec)
    assert cfg.key == "car/lifted/EL/python/osqp/safe/st+lat1+noise"
    assert "plant" not in Config("car", "lifted", "ellipse").as_dict()  # a default row: the columns as before
    comp = Config("car", "lifted", "ellipse", profile="safe", plant=spec, delay=1)
    assert comp.key.endswith("/st+lat1+noise/comp1") and comp.problem().delay == 1 and comp.as_dict()["delay"] == 1
    row = run_task(Task(cfg, 2, 12, "unused"))
    assert (row["plant"], row["latency"], row["noise"]) == ("st", 1, "0.05,0.05,0.005,0.05,0.002")
    assert row["a_lat_model_over05_samples"] >= 0 and row["max_abs_a_lat_model"] > 0


@pytest.mark.parametrize("v0", [1.0, 3.0, 5.0])
def test_st_stops_steered_without_diverging_or_reversing(v0):
    """Braking to a standstill with the wheels steered: the tyre dynamics stiffen as 1/v (a fixed dt/20 RK4 step
    diverged to a non-finite slip angle below about 1 m/s) and the brake holds the car at v = 0 (the package's
    acceleration would reverse it); the path is the kinematic arc's: no lateral jump."""
    pl = CommonRoadPlant(PB, "st")
    pl.reset([0.0, 0.0, 0.0, v0, 0.15], straight_road(200.0))
    speeds = [pl.step((-800.0 * v0, 0.0))[0][3] for _ in range(40)]
    assert all(math.isfinite(c) for c in pl.x)
    assert min(speeds) == 0.0 and speeds[-1] == 0.0
    assert all(b <= a + 1e-12 for a, b in itertools.pairwise(speeds))  # never speeds up, never reverses
    s, n = pl.frenet()[:2]
    assert 0.0 < s < v0 * v0 and abs(n) < s  # stopped within the braking distance, on the arc's side


def test_the_plant_options_reach_the_run_as_one_plant_spec():
    """The seven plant options, given on the command line, make the run's ``PlantSpec`` (its label on the plant line);
    a bad value is one line naming its option."""
    from click.testing import CliRunner

    from fcgen.cli import main

    args = ["simulate", "--samples", "3", "--plant", "ks", "--latency", "1", "--noise", "default"]
    res = CliRunner().invoke(main, [*args, "--prediction", "constant-velocity", "--prediction-margin", "1"])
    assert res.exit_code == 0, res.output
    assert "plant ks+lat1+noise+cv+pm1 |" in res.output
    res = CliRunner().invoke(main, ["simulate", "--samples", "3", "--noise", "1,2"])
    assert res.exit_code == 1 and res.output.startswith("Error: --noise: noise = '1,2' is invalid")


def test_a_plant_that_leaves_its_domain_stops_the_run_with_one_line(monkeypatch):
    """A plant state that is no longer finite (the ``st`` integration once left the slip-angle mapping's domain on
    car seeds 16 and 29): ``fcgen simulate`` says so in one line, exit 1, no traceback."""
    from click.testing import CliRunner

    from fcgen.cli import main

    monkeypatch.setattr(CommonRoadPlant, "_f", lambda self, x, u: [math.nan] * len(x))
    r = CliRunner().invoke(main, ["simulate", "--scenario", "car", "--plant", "st", "--samples", "3"])
    assert r.exit_code == 1 and r.output.count("\n") == 1, r.output
    assert r.output.startswith("Error: the run stopped: the st plant's state is not finite after a sample")
