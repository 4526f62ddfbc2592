"""A CommonRoad run's picture and animation: what is drawn at a sample (the ego's and the obstacles' footprints against
hand-derived corners), which samples become frames, a GIF with one frame per drawn sample, bad formats refused."""

from __future__ import annotations

import warnings

import numpy as np
import pytest
from crscenes import write_scenario

from fcgen.campaign.commonroad import load_for
from fcgen.commonroad.animate import animate_run, frame_samples
from fcgen.commonroad.plot import plot_run, scene_at
from fcgen.presets import preset

pytestmark = [
    pytest.mark.filterwarnings("ignore::UserWarning"),
    pytest.mark.filterwarnings("ignore::DeprecationWarning"),
]
PB = preset("car_lifted_ellipse_ipm")
# (id, lane, s0, speed, recorded steps, length, width): one standing car, one moving truck
STANDING = (1, 1, 150.0, 0.0, 120, 4.5, 1.8)
TRUCK = (2, 0, 40.0, 15.0, 30, 12.0, 2.5)


@pytest.fixture(scope="module")
def scene(tmp_path_factory):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        sc = load_for(PB, write_scenario(tmp_path_factory.mktemp("cr") / "s.xml", obstacles=[STANDING, TRUCK]))
    k = np.arange(41)
    ego = np.column_stack([50.0 + 2.0 * k, 0.1 * k, np.full(k.shape, 0.05)])  # a straight drift to the left
    return sc, ego


def _box(x, y, length, width):
    """Corners of an axis-aligned rectangle centred on (x, y), counter-clockwise from rear-right."""
    return np.array(
        [
            [x - length / 2, y - width / 2],
            [x + length / 2, y - width / 2],
            [x + length / 2, y + width / 2],
            [x - length / 2, y + width / 2],
        ]
    )


def test_the_scene_at_a_sample(scene):
    """The ego's rectangle is centred on its chassis centre and turned by its heading; an obstacle's is its recorded
    pose's; the truck's recording (30 steps) has ended at sample 35, the standing car is still there."""
    sc, ego = scene
    got = dict(scene_at(sc, ego, 10))
    x, y, phi = ego[10]
    c, s = np.cos(phi), np.sin(phi)
    local = _box(0.0, 0.0, sc.ego_length, sc.ego_width)
    np.testing.assert_allclose(got["ego"], local @ np.array([[c, s], [-s, c]]) + [x, y], atol=1e-12)
    for ob in sc.obstacles:
        px, py, pphi = ob.pose(sc.first_step + 10)
        assert pphi == pytest.approx(0.0, abs=1e-9)  # both drive along x on the straight road
        np.testing.assert_allclose(got[f"obstacle {ob.id}"], _box(px, py, ob.length, ob.width), atol=1e-9)
    assert sorted(dict(scene_at(sc, ego, 35))) == ["ego", "obstacle 1"]


def test_frames_are_every_nth_sample_and_the_last():
    assert frame_samples(11, 5) == [0, 5, 10]
    assert frame_samples(12, 5) == [0, 5, 10, 11]
    assert frame_samples(1, 3) == [0]
    with pytest.raises(ValueError, match="every = 0 is invalid"):
        frame_samples(5, 0)


def test_a_gif_has_a_frame_per_drawn_sample_and_the_picture_is_written(scene, tmp_path):
    from PIL import Image

    sc, ego = scene
    gif = animate_run(sc, ego, tmp_path / "run.gif", every=8)
    with Image.open(gif) as im:
        assert im.n_frames == len(frame_samples(len(ego), 8)) == 6
    assert plot_run(sc, ego, tmp_path / "run.png").stat().st_size > 10_000
    with pytest.raises(ValueError, match=r"'run.avi' has no known format \(allowed: .gif, .mp4\)"):
        animate_run(sc, ego, tmp_path / "run.avi")
