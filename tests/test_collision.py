"""Tests of the exact separating-axis rectangle-overlap check (fcgen.collision)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from fcgen.collision import (
    chassis_corners,
    collisions_over_run,
    corners_from_dims,
    penetration_depth,
    penetration_over_run,
    rectangles_overlap,
    sat_overlap,
)


def box(x0: float, y0: float, x1: float, y1: float) -> np.ndarray:
    """Axis-aligned rectangle, corners counter-clockwise."""
    return np.array([[x0, y0], [x1, y0], [x1, y1], [x0, y1]], dtype=float)


def rect(cx: float, cy: float, length: float, width: float, phi: float) -> np.ndarray:
    """Rectangle by centre, size and heading (built with chassis_corners: zero wheelbase, centred)."""
    return chassis_corners(cx, cy, phi, 0.0, length / 2, length / 2, width)


def diamond(cx: float, cy: float, h: float) -> np.ndarray:
    """Square rotated by 45 degrees with half-diagonal h."""
    return rect(cx, cy, h * math.sqrt(2), h * math.sqrt(2), math.pi / 4)


# ---------------------------------------------------------------- corners


def test_corners_known_pose():
    # rear axle (1, 2), heading +90 deg, wheelbase 3.4, chassis 2 + 2 by 1.9:
    # centre (1, 3.7); forward = +y, left = -x.
    c = chassis_corners(1.0, 2.0, math.pi / 2, 3.4, 2.0, 2.0, 1.9)
    expected = np.array([[1.95, 1.7], [1.95, 5.7], [0.05, 5.7], [0.05, 1.7]])  # RR, FR, FL, RL
    np.testing.assert_allclose(c, expected, atol=1e-12)


def test_corners_heading_zero_and_split_does_not_matter():
    c = chassis_corners(0.0, 0.0, 0.0, 3.4, 2.0, 2.0, 1.9)
    np.testing.assert_allclose(c, [[-0.3, -0.95], [3.7, -0.95], [3.7, 0.95], [-0.3, 0.95]], atol=1e-12)
    # SPEC: centred at the wheelbase midpoint, only l_r_ch + l_f_ch matters
    np.testing.assert_allclose(chassis_corners(0.0, 0.0, 0.0, 3.4, 1.0, 3.0, 1.9), c, atol=1e-12)


def test_corners_vectorized_and_from_dims():
    poses = np.array([[0.0, 0.0, 0.0], [1.0, 2.0, math.pi / 2], [-3.0, 4.0, -2.0]])
    dims = {"l_f": 1.7, "l_r": 1.7, "l_r_ch": 2.0, "l_f_ch": 2.0, "w_ch": 1.9}
    batch = corners_from_dims(poses, dims)
    assert batch.shape == (3, 4, 2)
    for k in range(3):
        np.testing.assert_allclose(batch[k], chassis_corners(*poses[k], 3.4, 2.0, 2.0, 1.9), atol=0)
    # counter-clockwise order: positive signed area = length * width
    x, y = batch[..., 0], batch[..., 1]
    area = 0.5 * np.sum(x * np.roll(y, -1, axis=-1) - np.roll(x, -1, axis=-1) * y, axis=-1)
    np.testing.assert_allclose(area, 4.0 * 1.9, rtol=1e-12)


# ---------------------------------------------------------------- hand-derived overlap cases


def test_axis_aligned_overlap_and_depth():
    a = box(0, 0, 2, 1)
    b = box(1.5, 0.2, 3.5, 1.2)  # x overlap 0.5, y overlap 0.8
    assert rectangles_overlap(a, b) and rectangles_overlap(b, a)
    assert penetration_depth(a, b) == pytest.approx(0.5, abs=1e-12)
    assert penetration_depth(b, a) == pytest.approx(0.5, abs=1e-12)


def test_axis_aligned_separated_by_0_1():
    a = box(0, 0, 2, 1)
    b = box(2.1, 0, 4, 1)  # gap 0.1 along x
    assert not rectangles_overlap(a, b) and not rectangles_overlap(b, a)
    assert penetration_depth(a, b) == 0.0
    assert float(sat_overlap(a, b)) == pytest.approx(-0.1, abs=1e-12)
    c = box(0, 1.1, 2, 2)  # gap 0.1 along y
    assert not rectangles_overlap(a, c)


def test_touching_is_not_overlap():
    a = box(0, 0, 2, 1)
    assert not rectangles_overlap(a, box(2, 0, 4, 1))  # shared edge
    assert not rectangles_overlap(a, box(2, 1, 3, 2))  # shared corner
    assert penetration_depth(a, box(2, 0, 4, 1)) == 0.0


def test_rotated_square_aabb_overlap_but_no_overlap():
    """The classic SAT case: the AABBs overlap, only the diamond's own axis separates them."""
    a = box(0, 0, 1, 1)
    d = diamond(1.6, 1.6, 1.0)  # edge x + y = 2.2 > 2 = max over a of x + y
    lo, hi = d.min(axis=0), d.max(axis=0)
    assert np.all(lo < 1.0) and np.all(hi > 0.0), "bounding boxes must overlap for this test"
    assert not rectangles_overlap(a, d) and not rectangles_overlap(d, a)
    assert float(sat_overlap(a, d)) == pytest.approx(-0.2 / math.sqrt(2), abs=1e-12)
    assert penetration_depth(a, d) == 0.0


def test_rotated_square_overlapping():
    a = box(0, 0, 1, 1)
    d = diamond(1.4, 1.4, 1.0)  # edge x + y = 1.8 < 2: a's corner (1, 1) lies inside the diamond
    assert rectangles_overlap(a, d) and rectangles_overlap(d, a)
    assert penetration_depth(a, d) == pytest.approx(0.2 / math.sqrt(2), abs=1e-12)
    # the diamond's corner (0.5, 0.5) pokes into a
    d2 = diamond(1.5, 0.5, 1.0)
    assert rectangles_overlap(a, d2)
    assert penetration_depth(a, d2) == pytest.approx(0.5, abs=1e-12)


def test_identical_poses_overlap():
    c = chassis_corners(10.0, -3.0, 0.7, 3.4, 2.0, 2.0, 1.9)
    assert rectangles_overlap(c, c)
    assert penetration_depth(c, c) == pytest.approx(1.9, abs=1e-12)  # the width axis limits


def test_cross_shape_no_corner_inside():
    """Two long thin rectangles crossing: no corner of either is inside the other, yet they overlap."""
    a = rect(0, 0, 10, 1, 0.0)
    b = rect(0, 0, 10, 1, math.pi / 2)
    assert rectangles_overlap(a, b)
    assert penetration_depth(a, b) == pytest.approx(1.0, abs=1e-12)


def test_penetration_depth_is_minimum_translation():
    rng = np.random.default_rng(3)
    for _ in range(50):
        a = rect(*rng.uniform(-1, 1, 2), *rng.uniform(0.5, 4, 2), rng.uniform(-np.pi, np.pi))
        b = rect(*rng.uniform(-1, 1, 2), *rng.uniform(0.5, 4, 2), rng.uniform(-np.pi, np.pi))
        depth = penetration_depth(a, b)
        if depth <= 1e-6:
            continue
        # moving b by a bit less than the depth in any direction cannot separate them
        for ang in np.linspace(0, 2 * np.pi, 16, endpoint=False):
            shift = 0.99 * depth * np.array([np.cos(ang), np.sin(ang)])
            assert rectangles_overlap(a, b + shift)


# ---------------------------------------------------------------- vectorized run helpers


def test_run_helpers():
    ego_dims = {"l_f": 1.7, "l_r": 1.7, "l_r_ch": 2.0, "l_f_ch": 2.0, "w_ch": 1.9}
    truck = {"l_f": 10.0, "l_r": 10.0, "l_r_ch": 13.0, "l_f_ch": 13.0, "w_ch": 4.0}
    ego = np.array([[0.0, 0.0, 0.0], [10.0, 0.0, 0.0], [20.0, 0.0, 0.0]])
    opp = np.array(
        [
            [[5.0, 0.0, 0.0], [0.0, 10.0, 0.0]],  # car 1 m ahead of the ego's front; truck far to the left
            [[14.0, 0.0, 0.0], [0.0, 10.0, 0.0]],  # car rear touches the ego's front: no overlap
            [[22.0, 1.0, 0.5], [5.0, 3.0, 0.0]],  # car overlaps; truck: y in [1, 5] vs ego [-0.95, 0.95]: no
        ]
    )
    flags = collisions_over_run(ego, ego_dims, opp, [ego_dims, truck])
    depth = penetration_over_run(ego, ego_dims, opp, [ego_dims, truck])
    assert flags.shape == (3, 2) and depth.shape == (3, 2)
    for k in range(3):
        for i, dims in enumerate([ego_dims, truck]):
            ce = corners_from_dims(ego[k], ego_dims)
            co = corners_from_dims(opp[k, i], dims)
            assert flags[k, i] == rectangles_overlap(ce, co)
            assert depth[k, i] == pytest.approx(penetration_depth(ce, co), abs=1e-12)
    # ego chassis x in [-0.3, 3.7]; opponent at 5 has chassis in [4.7, 8.7]: separated
    assert not flags[0, 0]
    # touching: ego [9.7, 13.7], opp [13.7, 17.7]
    assert not flags[1, 0]
    assert flags[2, 0] and not flags[2, 1]
    assert collisions_over_run(ego, ego_dims, np.zeros((3, 0, 3)), []).shape == (3, 0)


def test_run_helpers_skip_only_pairs_that_are_apart():
    """The run helpers test by SAT only pairs whose circumscribed circles meet: their results are sat_overlap's on
    every pair, bit for bit (random runs, near and far, touching, identical and NaN poses), and degenerate chassis
    still raise."""
    rng = np.random.default_rng(7)
    car = {"l_f": 1.2, "l_r": 1.4, "l_r_ch": 1.0, "l_f_ch": 3.6, "w_ch": 1.8}
    truck = {"l_f": 4.0, "l_r": 2.0, "l_r_ch": 10.0, "l_f_ch": 16.0, "w_ch": 4.0}
    hits = 0
    for trial in range(300):
        k, n = int(rng.integers(1, 40)), int(rng.integers(1, 4))
        ego_dims, opp_dims = (car, truck)[trial % 2], [(car, truck)[int(rng.integers(2))] for _ in range(n)]
        base = rng.uniform(-2000.0, 2000.0, 2)
        ego = np.column_stack([base[0] + rng.normal(0, 15, k), base[1] + rng.normal(0, 15, k), rng.uniform(-4, 4, k)])
        opp = ego[:, None, :] + np.stack(
            [rng.normal(0, 12, (k, n)), rng.normal(0, 6, (k, n)), rng.normal(0, 0.5, (k, n))], axis=-1
        )
        opp[0, 0] = ego[0]
        if trial % 5 == 0:
            ego[-1, 1] = math.nan
        ego_c = corners_from_dims(ego, ego_dims)
        full = np.stack([sat_overlap(ego_c, corners_from_dims(opp[:, i], d)) for i, d in enumerate(opp_dims)], axis=1)
        flags = collisions_over_run(ego, ego_dims, opp, opp_dims)
        depth = penetration_over_run(ego, ego_dims, opp, opp_dims)
        assert flags.tobytes() == (full > 0.0).tobytes()
        assert depth.tobytes() == np.maximum(full, 0.0).tobytes()
        hits += int(flags.sum())
    assert hits > 100
    flat = dict(car, w_ch=0.0)
    with pytest.raises(ValueError, match="degenerate"):
        collisions_over_run(np.zeros((2, 3)), car, np.full((2, 1, 3), 100.0), [flat])


# ---------------------------------------------------------------- randomized cross-check


def _grid(corners: np.ndarray, h: float) -> np.ndarray:
    """Points on a grid of spacing <= h covering the rectangle (boundary included)."""
    o, e1, e2 = corners[0], corners[1] - corners[0], corners[3] - corners[0]
    n1 = int(np.ceil(np.linalg.norm(e1) / h)) + 1
    n2 = int(np.ceil(np.linalg.norm(e2) / h)) + 1
    u, v = np.meshgrid(np.linspace(0, 1, n1), np.linspace(0, 1, n2), indexing="ij")
    return o + u.reshape(-1, 1) * e1 + v.reshape(-1, 1) * e2


def _strictly_inside(points: np.ndarray, corners: np.ndarray) -> np.ndarray:
    """Point-in-convex-polygon test (counter-clockwise corners), strict."""
    inside = np.ones(len(points), dtype=bool)
    for i in range(4):
        a, b = corners[i], corners[(i + 1) % 4]
        cross = (b[0] - a[0]) * (points[:, 1] - a[1]) - (b[1] - a[1]) * (points[:, 0] - a[0])
        inside &= cross > 0
    return inside


def _sampled_overlap(c1: np.ndarray, c2: np.ndarray, h: float) -> bool:
    return bool(_strictly_inside(_grid(c1, h), c2).any() or _strictly_inside(_grid(c2, h), c1).any())


def test_random_cross_check_against_point_sampling():
    """SAT vs dense point sampling, on cases that are unambiguous by a margin m.

    Label 'overlap' if the rectangles shrunk by m on every side still share a sampled point (then the
    originals overlap for sure); label 'separated' if the rectangles grown by m share no sampled point on
    a grid of spacing h <= m (any common point of the originals would put a disk of radius m into both
    grown rectangles, which a grid of spacing m always hits). Otherwise the case is skipped.
    """
    rng = np.random.default_rng(20230601)
    m = h = 0.05
    labelled = {True: 0, False: 0}
    for _ in range(400):
        p1 = (*rng.uniform(-3, 3, 2), *rng.uniform(0.5, 4.0, 2), rng.uniform(-np.pi, np.pi))
        p2 = (*rng.uniform(-3, 3, 2), *rng.uniform(0.5, 4.0, 2), rng.uniform(-np.pi, np.pi))

        def make(p, grow):
            return rect(p[0], p[1], p[2] + 2 * grow, p[3] + 2 * grow, p[4])

        if _sampled_overlap(make(p1, -m), make(p2, -m), h):
            truth = True
        elif not _sampled_overlap(make(p1, m), make(p2, m), h):
            truth = False
        else:
            continue
        labelled[truth] += 1
        c1, c2 = make(p1, 0.0), make(p2, 0.0)
        assert rectangles_overlap(c1, c2) is truth, (p1, p2)
        assert rectangles_overlap(c2, c1) is truth, (p1, p2)
        assert (penetration_depth(c1, c2) > 0) is truth
    assert labelled[True] >= 50 and labelled[False] >= 50, labelled
