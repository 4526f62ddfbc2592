"""Realistic random roads: the scenario generator redraws roads that come back close to themselves."""

from __future__ import annotations

import numpy as np
from scipy.spatial import cKDTree

from fcgen.road import random_road
from fcgen.sim.scenario import (
    ROAD_BEHIND,
    ROAD_CHECKED,
    ROAD_MIN_ARC,
    ROAD_MIN_GAP,
    OpponentParams,
    make_scenario,
    road_is_realistic,
)


def close_far_pairs(road) -> int:
    """Independent count (k-d tree, not the distance matrix): pairs of checked samples closer than ROAD_MIN_GAP in
    the plane but more than ROAD_MIN_ARC apart along the road."""
    keep = road.s <= road.s0 + ROAD_CHECKED
    pts = np.stack([road.gx[keep], road.gy[keep]], axis=1)
    s = road.s[keep]
    pairs = cKDTree(pts).query_pairs(ROAD_MIN_GAP - 1e-9, output_type="ndarray")
    return int(np.count_nonzero(np.abs(s[pairs[:, 0]] - s[pairs[:, 1]]) > ROAD_MIN_ARC))


def test_no_accepted_road_comes_close_to_itself_over_40_seeds():
    for seed in range(40):
        road = make_scenario("truck", seed).road
        assert close_far_pairs(road) == 0, seed
        assert road.s0 == -ROAD_BEHIND and road.s_end >= ROAD_CHECKED - ROAD_BEHIND


def test_the_check_rejects_a_road_that_loops_and_accepts_a_straight_one():
    # a full circle of radius 30 m: the start and the end meet
    kappa = np.full(200, 1 / 30.0)
    from fcgen.road import Road, straight_road

    loop = Road.from_curvature(kappa, 2.0, -ROAD_BEHIND)
    assert close_far_pairs(loop) > 0 and not road_is_realistic(loop)
    assert road_is_realistic(straight_road(1600.0, s0=-ROAD_BEHIND))


def test_same_seed_same_road_and_crossing_seeds_are_redrawn():
    crossing = [sd for sd in range(40) if close_far_pairs(random_road(sd, s0=-ROAD_BEHIND)) > 0]
    passing = [sd for sd in range(40) if sd not in crossing]
    assert 5 <= len(crossing) <= 30  # the raw recipe loops back often: the check matters
    for sd in crossing[:3] + passing[:3]:
        a, b = make_scenario("car", sd).road, make_scenario("truck", sd).road
        np.testing.assert_array_equal(a.kappa, b.kappa)  # reproducible (the road does not depend on the scenario)
        np.testing.assert_array_equal(a.gx, b.gx)
        raw = random_road(sd, s0=-ROAD_BEHIND)
        if sd in crossing:  # a crossing draw is replaced by another road
            assert not np.array_equal(raw.kappa, a.kappa)
        else:  # a road that passed the check is unchanged
            np.testing.assert_array_equal(raw.kappa, a.kappa)
    # different seeds still give different roads
    assert not np.array_equal(
        make_scenario("truck", crossing[0]).road.kappa, make_scenario("truck", crossing[1]).road.kappa
    )


def test_opponents_are_predicted_at_every_stages_sample():
    """Stage k of sample j is sample j + offsets[k] (fine stages one sample apart, coarse ones stride): the poses the
    scenario gives at that time; the per-sample rows (the run log's) are the samples themselves."""
    from fcgen.dsl import Horizon
    from fcgen.presets import paper_problem

    sc = make_scenario("truck", 3, samples=30)
    for stride, fine, last in ((1, 0, 12), (2, 0, 24), (3, 5, 5 + 7 * 3)):
        pb = paper_problem("truck", "lifted", "ellipse", profile="safe").with_(
            horizon=Horizon(N=12, stride=stride, fine=fine)
        )
        assert pb.horizon.offsets[-1] == last
        op = OpponentParams(pb, sc)
        for j in (0, 7, 29, 40):  # 40: beyond the table (computed on demand)
            np.testing.assert_array_equal(
                op.horizon(j), np.stack([sc.opp_cartesian((j + o) * sc.dt) for o in pb.horizon.offsets])
            )
        np.testing.assert_array_equal(op.samples(30), sc.opp_cartesian(np.arange(31) * sc.dt))
