"""A straight road the size of a problem's window and one opponent ahead: the set-up the C-vs-reference tests of the
stage inputs and the obstacle margin share."""

from __future__ import annotations

import numpy as np

from fcgen.road import straight_road


def window_road(pb):
    """A straight road as long as the problem's road window, starting 20 m behind the ego."""
    return straight_road(length=(pb.road.samples - 1) * pb.road.ds, ds=pb.road.ds, s0=-20.0)


def one_opponent(pb) -> np.ndarray:
    """One opponent 40 m ahead, 0.5 m left, at 5 m/s; the others far away."""
    N = pb.horizon.N
    opp = np.zeros((N + 1, pb.opponents.count, 3))
    opp[..., 0], opp[..., 1] = -1000.0, 500.0
    opp[:, 0, 0] = 40.0 + 5.0 * np.arange(N + 1) * pb.horizon.interval
    opp[:, 0, 1] = 0.5
    return opp
