"""A scenario's road for fcgen: the reference path along the lanes, its curvature on fcgen's grid, and the drivable band
on each side at each sample.

Rules (tested in tests/test_commonroad.py):

- **Reference path**: the centre line of the initial lanelet (the one holding the ego's start; of several, the one
  whose heading is nearest the ego's) and its successors; at a fork the successor from which a goal lanelet can be
  reached, else the first listed; behind the start, its predecessors (the first listed) up to ``behind`` metres.
- **fcgen's road**: the path resampled every ``ds`` metres of arc length, its heading from a smoothing spline (a
  polyline's kinks would make curvature spikes; its first and last ``END_TRIM`` samples, where a spline bends away,
  are left out and extended over), the curvature its derivative, integrated by
  ``Road.from_curvature`` from the path's first pose; the integrated centre line must stay within
  ``MAX_DEVIATION`` of the lanelets' (refused otherwise).
- **Extension**: where the lanelets start less than ``behind`` before the ego, the road is extended backwards
  straight; past the lanelets' end it continues with the last curvature (the median of the path's last ``HOLD_SAMPLES``
  samples: a spline's end is its least certain part) for ``horizon`` metres, then straight (what
  the run needs beyond: the horizon from the last sample the ego can reach).
- **Band**: at each sample, from the centre line outwards along the normal, the extent of the lanelets of the same
  driving direction (heading within 90 degrees of the road's) that hold the point, found by stepping
  ``BAND_STEP`` and bisecting to ``BAND_TOL``; where the centre itself is on no lanelet (the extensions) the nearest
  sample's band is held. A lane that ends narrows the band where it ends.
"""

from __future__ import annotations

import math

import numpy as np

from ..road import Road
from .traffic import ScenarioRefused

MAX_DEVIATION = 1.0  # m: the integrated centre line against the lanelets' (else refused)
BAND_STEP = 0.5  # m: the band's outward steps ...
BAND_TOL = 0.02  # m: ... then bisection to this
BAND_MAX = 30.0  # m: the farthest a band edge is looked for
HOLD_SAMPLES = 10  # the extension's curvature: the median over the path's last samples
END_TRIM = 4  # samples left out at either end of the spline (its end effects), extended over instead
SMOOTHING = 0.01  # m: the smoothing spline may leave a vertex by about this much (root mean square)


def initial_lanelet(net, xy, heading: float) -> int:
    """The lanelet holding the ego's start (of several: heading nearest the ego's)."""
    ids = net.find_lanelet_by_position([np.asarray(xy, dtype=float)])[0]
    if not ids:
        where = f"({xy[0]:.1f}, {xy[1]:.1f})"
        raise ScenarioRefused(f"no lanelet at the ego's start {where}", kind="no lanelet at the start")

    return min(ids, key=lambda lid: (abs(math.remainder(lanelet_heading(net, lid, xy) - heading, 2 * math.pi)), lid))


def lanelet_heading(net, lid: int, xy) -> float:
    """The heading of a lanelet's centre line at its vertex nearest ``xy`` (the segment from it onwards)."""
    cv = net.find_lanelet_by_id(lid).center_vertices
    i = int(np.argmin(np.hypot(cv[:, 0] - xy[0], cv[:, 1] - xy[1])))
    j = min(i + 1, len(cv) - 1)
    i = j - 1
    return math.atan2(cv[j, 1] - cv[i, 1], cv[j, 0] - cv[i, 0])


def _reaches(net, start: int, goals: set[int], depth: int = 50) -> bool:
    seen: set[int] = set()
    todo = [start]
    while todo and len(seen) < depth:
        lid = todo.pop()
        if lid in goals:
            return True
        if lid in seen:
            continue
        seen.add(lid)
        todo += list(net.find_lanelet_by_id(lid).successor or [])
    return False


def lanelet_chain(net, first: int, goals: set[int], ahead: float, behind: float, start_xy) -> list[int]:
    """The lanelets of the reference path: predecessors up to ``behind`` m, ``first``, successors (towards a goal)."""
    chain, length, lid = [first], 0.0, first
    while True:
        succ = list(net.find_lanelet_by_id(lid).successor or [])
        succ = [s for s in succ if s not in chain]
        if not succ:
            break
        towards = [s for s in succ if goals and _reaches(net, s, goals)]
        lid = (towards or succ)[0]
        chain.append(lid)
        length += _polyline_length(net.find_lanelet_by_id(lid).center_vertices)
        if length > ahead + 500.0:
            break
    back, lid = 0.0, first
    while back < behind:
        pred = [p for p in (net.find_lanelet_by_id(lid).predecessor or []) if p not in chain]
        if not pred:
            break
        lid = pred[0]
        chain.insert(0, lid)
        back += _polyline_length(net.find_lanelet_by_id(lid).center_vertices)
    return chain


def _polyline_length(p: np.ndarray) -> float:
    return float(np.sum(np.hypot(np.diff(p[:, 0]), np.diff(p[:, 1]))))


def centre_polyline(net, chain: list[int]) -> np.ndarray:
    """The chain's centre vertices, joined (a repeated joint vertex dropped)."""
    pts: list[np.ndarray] = []
    for lid in chain:
        cv = np.asarray(net.find_lanelet_by_id(lid).center_vertices, dtype=float)
        if pts and np.hypot(*(cv[0] - pts[-1][-1])) < 1e-6:
            cv = cv[1:]
        pts.append(cv)
    p = np.concatenate(pts)
    keep = np.r_[True, np.hypot(np.diff(p[:, 0]), np.diff(p[:, 1])) > 1e-6]
    return p[keep]


def smooth_heading(p: np.ndarray, ds: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Samples every ``ds`` of arc length of the polyline ``p``: points (M, 2), heading and curvature of a smoothing
    spline through it (scipy ``splprep``, about ``SMOOTHING`` off the vertices)."""
    from scipy.interpolate import splev, splprep

    seg = np.hypot(np.diff(p[:, 0]), np.diff(p[:, 1]))
    u = np.r_[0.0, np.cumsum(seg)]
    k = min(3, len(p) - 1)
    tck, _ = splprep([p[:, 0], p[:, 1]], u=u, k=k, s=len(p) * SMOOTHING**2)
    # arc length of the spline on a fine grid, then samples every ds
    fine = np.linspace(0.0, u[-1], max(2, int(u[-1] / 0.1) + 1))
    dx, dy = splev(fine, tck, der=1)
    arc = np.r_[0.0, np.cumsum(0.5 * (np.hypot(dx[1:], dy[1:]) + np.hypot(dx[:-1], dy[:-1])) * np.diff(fine))]
    m = int(arc[-1] // ds) + 1
    ui = np.interp(np.arange(m) * ds, arc, fine)
    x, y = splev(ui, tck)
    dx, dy = splev(ui, tck, der=1)
    heading = np.unwrap(np.arctan2(dy, dx))
    kappa = np.gradient(heading, ds) if len(heading) > 1 else np.zeros(1)  # integrates back to these headings
    return np.stack([x, y], axis=1), heading, kappa


def build_road(
    net, chain: list[int], start_xy, ds: float, behind: float, horizon: float, ahead: float
) -> tuple[Road, dict]:
    """fcgen's road along the chain with its band, reaching ``behind`` m behind and ``ahead`` m ahead of the ego's
    start (extended as the module docstring says: the last curvature for up to ``horizon`` m, then straight); and
    facts about it."""
    poly = centre_polyline(net, chain)
    pts, heading, kappa = smooth_heading(poly, ds)
    if len(pts) > 4 * END_TRIM:  # a spline's ends bend away (end effects): the extensions replace them
        pts, heading, kappa = pts[END_TRIM:-END_TRIM], heading[END_TRIM:-END_TRIM], kappa[END_TRIM:-END_TRIM]
    # where the ego starts along the path
    i0 = int(np.argmin(np.hypot(pts[:, 0] - start_xy[0], pts[:, 1] - start_xy[1])))
    s_start = i0 * ds
    n_back = max(0, math.ceil((behind - s_start) / ds))  # straight extension behind
    n_more = max(1, math.ceil((ahead - (len(pts) - 1 - i0) * ds) / ds))
    n_bend = min(n_more, math.ceil(horizon / ds))
    last = float(np.median(kappa[-min(len(kappa), HOLD_SAMPLES) :]))  # a spline's end is its least certain part
    kap = np.r_[np.zeros(n_back), kappa, np.full(n_bend, last), np.zeros(n_more - n_bend)]
    lo, hi = n_back, n_back + len(pts)
    # the start pose that lays the integrated centre line best onto the path (least squares, rotation and shift:
    # a spline's end tangent is its least certain heading)
    trial = Road.from_curvature(kap, ds, s0=0.0, x0=(0.0, 0.0, 0.0))
    rot, shift = _rigid_fit(np.stack([trial.gx[lo:hi], trial.gy[lo:hi]], axis=1), pts)
    road = Road.from_curvature(kap, ds, s0=-(s_start + n_back * ds), x0=(shift[0], shift[1], rot))
    dev = float(np.max(np.hypot(road.gx[lo:hi] - pts[:, 0], road.gy[lo:hi] - pts[:, 1])))
    if dev > MAX_DEVIATION:
        raise ScenarioRefused(
            f"the reference path's integrated centre line leaves the lanelets' by {dev:.2f} m "
            f"(allowed {MAX_DEVIATION} m)",
            kind="path not followed",
        )
    n_min, n_max = drivable_band(net, road)
    road = Road(road.s0, road.ds, road.kappa, road.phi, road.gx, road.gy, n_min, n_max)
    info = {
        "lanelets": [int(i) for i in chain],
        "extended_behind_m": n_back * ds,
        "extended_ahead_m": n_more * ds,
        "path_length_m": (len(pts) - 1) * ds,
        "path_ahead_m": (len(pts) - 1 - i0) * ds,
        "max_deviation_m": dev,
    }
    return road, info


def _rigid_fit(a: np.ndarray, b: np.ndarray) -> tuple[float, np.ndarray]:
    """The rotation angle and shift that map the points ``a`` onto ``b`` best (least squares, 2-D Kabsch)."""
    ca, cb = a.mean(axis=0), b.mean(axis=0)
    h = (a - ca).T @ (b - cb)
    ang = math.atan2(h[0, 1] - h[1, 0], h[0, 0] + h[1, 1])
    r = np.array([[math.cos(ang), -math.sin(ang)], [math.sin(ang), math.cos(ang)]])
    return ang, cb - r @ ca


def _same_direction(net, lids: list[int], heading: float, xy) -> bool:
    """Whether one of the lanelets runs within 90 degrees of ``heading`` at ``xy``."""
    return any(math.cos(lanelet_heading(net, lid, xy) - heading) > 0.0 for lid in lids)


def drivable_band(net, road: Road) -> tuple[np.ndarray, np.ndarray]:
    """Per road sample: the right and left edges (n) of the same-direction lanelets along the normal."""
    m = road.size
    nx, ny = -np.sin(road.phi), np.cos(road.phi)
    inside_centre = [
        bool(ids) and _same_direction(net, ids, road.phi[i], (road.gx[i], road.gy[i]))
        for i, ids in enumerate(net.find_lanelet_by_position([np.array([road.gx[i], road.gy[i]]) for i in range(m)]))
    ]

    def inside(i: int, n: float) -> bool:
        p = np.array([road.gx[i] + n * nx[i], road.gy[i] + n * ny[i]])
        ids = net.find_lanelet_by_position([p])[0]
        return bool(ids) and _same_direction(net, ids, road.phi[i], p)

    def edge(i: int, sign: float) -> float:
        n = 0.0
        while abs(n) < BAND_MAX and inside(i, n + sign * BAND_STEP):
            n += sign * BAND_STEP
        a, b = n, n + sign * BAND_STEP  # a inside, b outside
        while abs(b - a) > BAND_TOL:
            c = 0.5 * (a + b)
            if inside(i, c):
                a = c
            else:
                b = c
        return a

    lo, hi = np.full(m, np.nan), np.full(m, np.nan)
    for i in range(m):
        if inside_centre[i]:
            lo[i], hi[i] = edge(i, -1.0), edge(i, 1.0)
    ok = np.flatnonzero(np.isfinite(lo))
    if not ok.size:
        raise ScenarioRefused("the reference path lies on no lanelet", kind="path not followed")
    for gap in np.flatnonzero(~np.isfinite(lo)):  # held from the nearest sample on the lanelets
        j = ok[np.argmin(np.abs(ok - gap))]
        lo[gap], hi[gap] = lo[j], hi[j]
    return lo, hi
