"""The road band's rows of a stage: the rear axle's n (soft) or the chassis' four corners (``Bounds.road_bound``).

A row is ``(name, g, lower, upper)`` with ``g`` in units of ``BAND_SCALE`` (m); the rows named in ``BAND_SIDES`` take
the road's band at the stage's ``s`` at run time (``qp.layout``), on the side given. The rear axle's hard bound is a
box row of the state (``ocp``), not one of these.
"""

from __future__ import annotations

from .dsl import Problem
from .models import CORNERS, corner_n

INF = 1e30  # OSQP_INFTY (as ocp.INF)
BAND_SCALE = 5.0  # m: the rows' scale (ocp.STATE_SCALE["n"])

CORNER_ROWS = tuple(f"road_{c}" for c in CORNERS)
BAND_SIDES = {"road_lo": (0,), "road_hi": (1,)} | {
    name: ((1,) if name.endswith("left") else (0,)) for name in CORNER_ROWS
}
"""Row name -> the sides of the road's band it takes (0: lower <- n_min, 1: upper <- n_max)."""


def band_ahead(pb: Problem, name: str) -> float:
    """How far ahead of the stage's ``s`` the row ``name`` takes the road's band (m): a corner's row at the corner's
    own ``s`` (its chassis position ``x_c`` ahead of the rear axle, the heading's share left out), the rear axle's at
    the stage's ``s``."""
    if name not in CORNER_ROWS:
        return 0.0
    veh = pb.ego
    return veh.l / 2 + (veh.l_ch / 2 if "front" in name else -veh.l_ch / 2)


def road_rows(pb: Problem, n, alpha, sigma, kappa, kappa_at=None) -> list[tuple]:
    """The road's rows of a stage at rear-axle offset ``n``, heading ``alpha`` to the road of curvature ``kappa`` there
    (``kappa_at(d)``: ``d`` ahead; ``models.corner_n``): with ``soft_road`` on
    the slack ``sigma`` (else hard); the rear axle's two rows, or one per corner (left corners: the upper edge, right
    corners: the lower one). None for the rear axle's hard bound (a box row)."""
    bnd, soft = pb.bounds, pb.soft.soft_road
    sg = sigma if soft else 0.0
    if bnd.road_bound == "rear_axle":
        if not soft:
            return []
        points = [("road_lo", n, 0), ("road_hi", n, 1)]
    else:
        left = (1, 1, 0, 0)
        points = [
            (name, c, side) for name, c, side in zip(CORNER_ROWS, corner_n(n, alpha, pb.ego, kappa, kappa_at), left)
        ]
    rows = []
    for name, c, side in points:
        if side == 0:
            rows.append((name, (c + sg) / BAND_SCALE, bnd.n_min / BAND_SCALE, INF))
        else:
            rows.append((name, (c - sg) / BAND_SCALE, -INF, bnd.n_max / BAND_SCALE))
    return rows
