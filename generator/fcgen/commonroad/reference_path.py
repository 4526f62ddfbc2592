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
  driving direction (heading within 90 degrees of the road's) joined to the one holding the centre: the normal's
  exact pieces in each lanelet, a piece joining where it overlaps the joined ones or, a lanelet of a lane section
  already joined (lanelets linked by adjacency, whose hull the drivability checker's road is), lies within
  ``BAND_STEP`` of them. A crack between lanelets the map does not make adjacent, however narrow, ends the band:
  the checker's road boundary runs along it (an on-ramp beside a lane, USA_US101-17_1 to 21_1). Where the centre
  itself is on no lanelet (the extensions) the nearest sample's band is held. A lane that ends narrows the band
  where it ends.
"""

from __future__ import annotations

import math

import numpy as np

from ..road import Road
from .traffic import ScenarioRefused

MAX_DEVIATION = 1.0  # m: the integrated centre line against the lanelets' (else refused)
BAND_STEP = 0.5  # m: lanelets of one lane section this close along the normal join (the checker's hull spans them)
GAP_TOL = 1e-6  # m: other lanelets join only where they overlap within this (a crack is the checker's boundary)
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
    """Per road sample: the right and left edges (n) of the same-direction lanelets along the normal, joined where
    they overlap or, lanelets of one lane section (``lane_sections``), lie within ``BAND_STEP`` of each other."""
    import shapely

    m = road.size
    nx, ny = -np.sin(road.phi), np.cos(road.phi)
    segs = shapely.linestrings(
        np.stack([road.gx - BAND_MAX * nx, road.gx + BAND_MAX * nx], axis=1),
        np.stack([road.gy - BAND_MAX * ny, road.gy + BAND_MAX * ny], axis=1),
    )
    tree, section = shapely.STRtree(segs), lane_sections(net)
    hits: list[list[tuple[float, float, int]]] = [[] for _ in range(m)]
    for ll in net.lanelets:
        poly = ll.polygon.shapely_object
        poly = poly if poly.is_valid else shapely.make_valid(poly)  # a self-touching border (DEU_A9-1_1)
        for i in tree.query(poly, predicate="intersects"):
            for part in shapely.get_parts(shapely.intersection(segs[i], poly)):
                xy = shapely.get_coordinates(part)
                n = (xy[:, 0] - road.gx[i]) * nx[i] + (xy[:, 1] - road.gy[i]) * ny[i]
                mid = xy[int(np.argmin(np.abs(n - n.mean())))]
                if math.cos(lanelet_heading(net, ll.lanelet_id, mid) - road.phi[i]) > 0.0:
                    hits[i].append((float(n.min()), float(n.max()), section[ll.lanelet_id]))
    lo, hi = np.full(m, np.nan), np.full(m, np.nan)
    for i, found in enumerate(hits):
        if any(a <= GAP_TOL and b >= -GAP_TOL for a, b, _ in found):
            lo[i], hi[i] = -_joined([(-b, -a, k) for a, b, k in found]), _joined(found)
    ok = np.flatnonzero(np.isfinite(lo))
    if not ok.size:
        raise ScenarioRefused("the reference path lies on no lanelet", kind="path not followed")
    for gap in np.flatnonzero(~np.isfinite(lo)):  # held from the nearest sample on the lanelets
        j = ok[np.argmin(np.abs(ok - gap))]
        lo[gap], hi[gap] = lo[j], hi[j]
    return lo, hi


def _joined(found: list[tuple[float, float, int]]) -> float:
    """The upper end of the intervals (a, b, section) joined to those holding n = 0: another joins where it overlaps
    the joined ones (within ``GAP_TOL``) or lies within ``BAND_STEP`` of them in a section already joined."""
    seed = [(b, k) for a, b, k in found if a <= GAP_TOL and b >= -GAP_TOL]
    hi, sections = max(b for b, _ in seed), {k for _, k in seed}
    grown = True
    while grown:
        grown = False
        for a, b, k in found:
            if b > hi and (a <= hi + GAP_TOL or (k in sections and a <= hi + BAND_STEP)):
                hi, grown = b, True
                sections.add(k)
    return hi


def lane_sections(net) -> dict[int, int]:
    """Each lanelet's lane section: the lanelets joined by adjacency (either direction), as the drivability checker's
    road boundary joins them (``commonroad_dc.boundary.lanelet_bounds.lane_sections``)."""
    out: dict[int, int] = {}
    for ll in net.lanelets:
        if ll.lanelet_id in out:
            continue
        todo = [ll.lanelet_id]
        while todo:
            lid = todo.pop()
            if lid in out:
                continue
            out[lid] = ll.lanelet_id
            lan = net.find_lanelet_by_id(lid)
            todo += [a for a in (lan.adj_left, lan.adj_right) if a is not None and net.find_lanelet_by_id(a)]
    return out
