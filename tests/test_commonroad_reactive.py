"""Reactive traffic (fcgen.commonroad.idm, fcgen.commonroad.reactive): the IDM against its closed-form steady state,
and the switching rule on a constructed road with a recorded vehicle and an ego."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import pytest

from fcgen.commonroad import idm
from fcgen.commonroad.reactive import ReactiveTraffic, check_traffic, leader_of
from fcgen.commonroad.traffic import CrObstacle
from fcgen.road import Road, straight_road

P = idm.IdmParams()
DT = 0.1


def test_parameters_are_the_highway_set_and_checked():
    # Treiber & Kesting, Traffic Flow Dynamics (2013), Table 11.2, highway
    assert (P.v0, P.T, P.s0, P.delta, P.a, P.b) == pytest.approx((120 / 3.6, 1.0, 2.0, 4.0, 1.0, 1.5))
    with pytest.raises(ValueError, match=r"IdmParams\.T = -1.0: must be a finite number > 0"):
        idm.IdmParams(T=-1.0)


def test_equilibrium_gap_by_hand():
    # s_e(20) = (2 + 20 * 1) / sqrt(1 - (20 / 33.333)^4) = 22 / sqrt(1 - 0.6^4) = 22 / sqrt(0.8704)
    assert idm.equilibrium_gap(P, 20.0) == pytest.approx(22.0 / math.sqrt(0.8704), rel=1e-12)
    assert idm.equilibrium_gap(P, 0.0) == pytest.approx(2.0)
    with pytest.raises(ValueError, match=r"v = 40.0 m/s must lie in \[0, v0"):
        idm.equilibrium_gap(P, 40.0)


@pytest.mark.parametrize("v", [0.0, 5.0, 15.0, 25.0, 32.0])
def test_no_acceleration_at_the_equilibrium_gap(v):
    assert idm.acceleration(P, v, idm.equilibrium_gap(P, v), 0.0) == pytest.approx(0.0, abs=1e-12)
    # closer brakes, farther accelerates
    assert idm.acceleration(P, v, 0.9 * idm.equilibrium_gap(P, v), 0.0) < 0.0
    assert idm.acceleration(P, v, 1.1 * idm.equilibrium_gap(P, v), 0.0) > 0.0


def test_a_follower_settles_at_the_equilibrium_gap():
    # a follower starting 60 m behind a leader at a constant 15 m/s ends at the leader's speed and at s_e(15)
    x_lead, x, v = 60.0, 0.0, 25.0
    for _ in range(6000):
        d, v = idm.step(v, idm.acceleration(P, v, x_lead - x, v - 15.0), DT)
        x, x_lead = x + d, x_lead + 15.0 * DT
    assert v == pytest.approx(15.0, abs=1e-6)
    assert x_lead - x == pytest.approx(idm.equilibrium_gap(P, 15.0), abs=1e-4)


def test_free_road_and_contact():
    assert idm.acceleration(P, 0.0) == pytest.approx(P.a)
    assert idm.acceleration(P, P.v0) == pytest.approx(0.0, abs=1e-15)
    assert idm.acceleration(P, 10.0, 0.0, 0.0) == -math.inf


def test_a_step_never_reverses():
    d, v = idm.step(1.0, -10.0, 0.5)  # stops after 0.1 s, 0.05 m
    assert (d, v) == pytest.approx((0.05, 0.0))
    assert idm.step(10.0, -1.0, 0.1) == pytest.approx((0.995, 9.9))


def test_unknown_traffic_mode_names_the_allowed_ones():
    assert check_traffic("reactive") == "reactive"
    with pytest.raises(ValueError, match=r"traffic 'replay' is not a traffic mode: allowed recorded, reactive"):
        check_traffic("replay")


def test_leader_is_the_nearest_ahead_in_the_lane():
    s = np.array([0.0, 30.0, 10.0, 20.0])
    n = np.array([0.0, 0.0, 3.5, 1.0])
    assert leader_of(s, n, 0) == 3  # 2 is a lane over (3.5 m > 1.75 m), 3 within half a lane
    assert leader_of(s, n, 1) is None


@dataclass(frozen=True)
class _Sc:
    """What ReactiveTraffic reads of a scenario."""

    road: Road
    obstacles: tuple
    first_step: int = 0


def _recorded(oid: int, s0: float, n: float, v: float, steps: int, road: Road) -> CrObstacle:
    s = s0 + v * DT * np.arange(steps)
    x, y, phi = road.to_cartesian(s, np.full_like(s, n), np.zeros_like(s))
    return CrObstacle(oid, False, 4.0, 2.0, 0, steps - 1, np.column_stack([x, y, phi]), v, DT)


def test_a_follower_reacts_to_a_slower_ego_when_the_idm_brakes_and_then_follows_it():
    road = straight_road(3000.0)
    steps = 1200
    behind = _recorded(1, 50.0, 0.0, 15.0, steps, road)  # recorded at a constant 15 m/s: recorded acceleration 0
    beside = _recorded(2, 50.0, 3.5, 15.0, steps, road)  # a lane over: never reacts to the ego
    ahead = _recorded(3, 400.0, 0.0, 15.0, steps, road)  # ahead of the ego, nobody ahead of it: never reacts
    world = ReactiveTraffic(_Sc(road, (behind, beside, ahead)), ego_length=4.0)
    ego_s = lambda j: 154.0 + 10.0 * DT * j
    # by hand: the first sample where the IDM's acceleration towards the ego is below 0 (recorded: 0)
    first = next(j for j in range(steps) if idm.acceleration(P, 15.0, 100.0 - 0.5 * j, 5.0) < 0.0)
    assert 90 < first < 110  # s* = 2 + 15 + 15 * 5 / (2 sqrt(1.5)) = 47.6 m: gap 48.6 m, about sample 103
    for j in range(steps - 1):
        world.update(j, ego_s(j), 0.0, 10.0)
        if j < first:
            assert not world.reactions
    assert [r[0] for r in world.reactions] == [1]
    _oid, sample, step, who, a_idm, a_rec = world.reactions[0]
    assert (sample, step, who) == (first, first, "ego")
    assert a_idm < 0.0 and a_rec == pytest.approx(0.0, abs=1e-9)
    # after 100 s behind the ego it drives the ego's speed at the IDM's equilibrium gap, in its lane
    sc = world.scenario()
    k = steps - 1
    p = sc.obstacles[0].pose(k)
    s, n, _ = road.to_frenet(np.array([p[0]]), np.array([p[1]]), np.array([p[2]]))
    gap = ego_s(k) - float(s[0]) - 4.0
    assert gap == pytest.approx(idm.equilibrium_gap(P, 10.0), abs=1e-3)
    assert float(n[0]) == pytest.approx(0.0, abs=1e-6)
    v_end = np.hypot(*(sc.obstacles[0].pose(k)[:2] - sc.obstacles[0].pose(k - 1)[:2])) / DT
    assert v_end == pytest.approx(10.0, abs=1e-3)
    # the others kept their recordings
    assert np.array_equal(sc.obstacles[1].centres, beside.centres)
    assert np.array_equal(sc.obstacles[2].centres, ahead.centres)
    # the log
    assert world.log()["reactions"] == world.reactions and world.log()["mode"] == "reactive"


def test_a_cut_in_brakes_at_most_b_max_and_recorded_traffic_without_reason_keeps_its_recording():
    road = straight_road(2000.0)
    behind = _recorded(1, 50.0, 0.0, 20.0, 200, road)
    world = ReactiveTraffic(_Sc(road, (behind,)), ego_length=4.0)
    world.update(0, 50.0 + 4.0 + 3.0, 0.0, 10.0)  # the ego 3 m ahead at 10 m/s: the IDM asks for far more than b_max
    assert world.reactions[0][3] == "ego"
    p0, p1 = world.obstacles[0].pose(0), world.obstacles[0].pose(1)
    v1 = float(np.hypot(*(p1[:2] - p0[:2]))) / DT
    assert v1 == pytest.approx(20.0 - 0.5 * P.b_max * DT, abs=1e-9)  # distance of one step braking at b_max
    quiet = ReactiveTraffic(_Sc(road, (_recorded(1, 50.0, 0.0, 20.0, 200, road),)), ego_length=4.0)
    for j in range(150):
        quiet.update(j, 1500.0, 0.0, 20.0)  # the ego far ahead: no reason to brake
    assert not quiet.reactions
