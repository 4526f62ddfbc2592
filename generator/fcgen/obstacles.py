"""Obstacle constraints (SPEC section 4) and the conventional formulation's Frenet over-approximation.

Every vehicle shape is described the same way: a centre ``c``, an axis angle, half-length ``L``, half-width ``W``.
The constraint expressions are written once on that description and work on floats, numpy and CasADi SX;
rows are ``h >= 0`` (outside), ``h < 0`` inside.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import casadi as ca
import numpy as np

from .contract import INPUT_RANGES
from .dsl import CoveringCircles, Ellipse, ObstacleModel, Problem, SeparatingHyperplane, Vehicle
from .road import Road, casadi_to_cartesian

SQRT2 = math.sqrt(2.0)
# A conventional (Frenet) shape: centre (s, n), axis angle, half-length, half-width, ego inflation factor.
FRENET_SHAPE = ("c_s", "c_n", "angle", "L", "W", "f")
# A Cartesian opponent pose: rear axle and heading.
CARTESIAN_POSE = ("x", "y", "phi")
# An opponent's own shape (set_opponent_shapes): chassis length and width, and how far its centre lies ahead of the
# pose's point along the heading (a rear-axle pose: half the wheelbase; a centre pose, as CommonRoad's: 0).
OPP_SHAPE = ("length", "width", "offset")
# Ellipse(shape="minkowski") also takes the ellipse's semi-axes per opponent: containing_ellipse_axes is a numerical
# search (not a run-time expression), so the caller computes them (``opponent_shape``) and the solver checks them.
ELLIPSE_AXES = ("a", "b")


Num = Any
"""A float or a CasADi expression (SX, MX): the rows' functions serve the reference's numbers and the NLP alike."""


@dataclass(frozen=True)
class Shape:
    """Oriented rectangle: centre, axis angle, half-length, half-width (floats or CasADi expressions)."""

    cx: Num
    cy: Num
    angle: Num
    L: Num
    W: Num


def _cos(a):
    return ca.cos(a) if isinstance(a, (ca.SX, ca.MX)) else np.cos(a)


def _sin(a):
    return ca.sin(a) if isinstance(a, (ca.SX, ca.MX)) else np.sin(a)


def chassis_shape(x, y, phi, veh: Vehicle) -> Shape:
    """Chassis rectangle of a vehicle whose rear axle is at (x, y) with heading phi."""
    c, s = _cos(phi), _sin(phi)
    return Shape(x + veh.l / 2 * c, y + veh.l / 2 * s, phi, veh.l_ch / 2, veh.w_ch / 2)


def shape_of(x, y, phi, shape) -> Shape:
    """The chassis rectangle of an opponent at pose (x, y, phi) with its ``OPP_SHAPE`` values ``shape`` (floats or
    CasADi): ``chassis_shape`` with the vehicle's dimensions as data."""
    c, s = _cos(phi), _sin(phi)
    return Shape(x + shape[2] * c, y + shape[2] * s, phi, shape[0] / 2, shape[1] / 2)


def shape_names(model: ObstacleModel) -> tuple[str, ...]:
    """The per-opponent shape values a problem's solver takes: ``OPP_SHAPE`` (+ ``ELLIPSE_AXES`` for the
    containing ellipse)."""
    return OPP_SHAPE + (ELLIPSE_AXES if isinstance(model, Ellipse) and model.shape == "minkowski" else ())


def ego_radius(model: ObstacleModel, ego: Vehicle) -> float:
    """The radius of each of the ego's circles in the ellipse rows (the r the opponent's ellipse is grown by):
    ``circle_radius`` of ``Ellipse.n_ego`` circles with ``cover`` (one circle: half the chassis diagonal)."""
    n = model.n_ego if isinstance(model, Ellipse) else 1
    return float(circle_radius(ego.l_ch / 2, ego.w_ch / 2, n, cover=True))


def opponent_shape(model: ObstacleModel, ego: Vehicle, length: float, width: float, offset: float) -> np.ndarray:
    """The solver's shape values of one opponent (``shape_names(model)``); checks them as the solver does."""
    out = np.array([length, width, offset], dtype=float)
    check_opponent_shape(model, ego, out[:3])
    if isinstance(model, Ellipse) and model.shape == "minkowski":
        out = np.r_[out, containing_ellipse_axes(out[0] / 2, out[1] / 2, ego_radius(model, ego))]
    return out


def vehicle_shape(model: ObstacleModel, ego: Vehicle, veh: Vehicle) -> np.ndarray:
    """The shape values of an opponent given by a rear-axle pose of ``veh`` (the problem's default opponent)."""
    return opponent_shape(model, ego, veh.l_ch, veh.w_ch, veh.l / 2)


def check_opponent_shape(model: ObstacleModel, ego: Vehicle, values) -> None:
    """Refuse one opponent's shape values with a ``ValueError`` naming the value and its range, as the C's
    ``set_opponent_shapes`` (``ERR_OPP_SHAPE``): finite, length and width within ``INPUT_RANGES``' shape range, the
    offset within the chassis; the ellipse's semi-axes at least half the length (width) plus the ego's radius
    (``ego_radius``: necessary for containment; ``opponent_shape`` computes them), at most the range's top."""
    v = np.asarray(values, dtype=float)
    names = shape_names(model)[: len(v)]
    for nm, x in zip(names, v):
        if not math.isfinite(x):
            raise ValueError(f"opponent shape {nm} = {x!r} is invalid: allowed a finite value")
    lo, hi = INPUT_RANGES.shape_min, INPUT_RANGES.shape_max
    for i, nm in enumerate(("length", "width")):
        if not lo <= v[i] <= hi:
            raise ValueError(f"opponent shape {nm} = {float(v[i])!r} is invalid: allowed in [{lo}, {hi}] m")
    if not abs(v[2]) <= v[0] / 2:
        raise ValueError(f"opponent shape offset = {float(v[2])!r} is invalid: allowed |offset| <= length / 2")
    if len(v) > 3:
        r = ego_radius(model, ego)
        for i, nm in ((3, "a"), (4, "b")):
            need = float(v[i - 3] / 2 + r)
            if not need <= v[i] <= hi:
                raise ValueError(
                    f"opponent shape {nm} = {float(v[i])!r} is invalid: allowed in [{need!r}, {hi}] m "
                    "(half the size plus the ego's radius, at most the largest shape)"
                )


def vertices(sh: Shape) -> list[tuple]:
    """The four corners of a shape."""
    c, s = _cos(sh.angle), _sin(sh.angle)
    out = []
    for a, b in ((1, 1), (1, -1), (-1, -1), (-1, 1)):
        out.append((sh.cx + a * sh.L * c - b * sh.W * s, sh.cy + a * sh.L * s + b * sh.W * c))
    return out


def circle_radius(L, W, n: int, cover: bool):
    """Radius of n circles along the axis: w/sqrt(2) (SPEC), or just large enough to cover when ``cover``."""
    if n == 1:
        return (L * L + W * W) ** 0.5
    if not cover:
        return SQRT2 * W
    half_gap = (L - W) / (n - 1)
    big: Num = ca.fmax(W, half_gap) if isinstance(half_gap, (ca.SX, ca.MX)) else max(W, half_gap)
    return (W * W + big * big) ** 0.5


def circle_centres(sh: Shape, n: int) -> list[tuple]:
    """n centres spread from -(L - W) to +(L - W) along the axis (one circle: the centre)."""
    if n == 1:
        return [(sh.cx, sh.cy)]
    c, s = _cos(sh.angle), _sin(sh.angle)
    out = []
    for i in range(n):
        d = -(sh.L - sh.W) + 2 * (sh.L - sh.W) * i / (n - 1)
        out.append((sh.cx + d * c, sh.cy + d * s))
    return out


def _sqrt(v):
    return ca.sqrt(v) if isinstance(v, (ca.SX, ca.MX)) else np.sqrt(v)


def ellipse_h(px, py, opp: Shape, a, b):
    """Ellipse with semi-axes (a, b) along ``opp``'s axes, centred on it: sqrt(d^T R D^-2 R^T d) - 1.

    The square root keeps the row's gradient of the size 1/a at every distance (the squared form grows with it
    and ruins the QP's conditioning); the zero level set and the sign are the paper's.
    """
    c, s = _cos(opp.angle), _sin(opp.angle)
    dx, dy = px - opp.cx, py - opp.cy
    e1 = c * dx + s * dy
    e2 = -s * dx + c * dy
    return _sqrt(e1 * e1 / (a * a) + e2 * e2 / (b * b) + 1e-12) - 1


def paper_ellipse_axes(L, W, r):
    """The paper's ellipse (SPEC section 4): semi-axes sqrt(2) L + r, sqrt(2) W + r (not containing, see below)."""
    return SQRT2 * L + r, SQRT2 * W + r


def paper_ellipse_h(px, py, opp: Shape, r):
    """The paper's ellipse row of an ego circle of radius r (``Ellipse(shape="paper")``)."""
    return ellipse_h(px, py, opp, *paper_ellipse_axes(opp.L, opp.W, r))


ELLIPSE_GRID = 20001  # directions of the support-function condition (a quarter turn)
ELLIPSE_SAFETY = 1e-6  # relative growth of b over the grid's maximum: covers the directions between grid points


def containing_ellipse_axes(L, W, r):
    """Semi-axes (a, b) of an ellipse along a half-``L`` x half-``W`` rectangle's axes that contains the rectangle
    grown by a disk of radius ``r`` (the Minkowski sum: every point within r of the rectangle).

    A convex set contains another iff its support function is at least the other's in every direction u = (c, s):
    sqrt(a^2 c^2 + b^2 s^2) >= L |c| + W |s| + r. For numbers: the smallest-area such ellipse (for each a > L + r
    the least b is a maximum over directions; a 1-D search over a; b grown by ``ELLIPSE_SAFETY``). For CasADi
    expressions (the conventional formulation's fitted boxes, sized at run time): sqrt(2) (L + r), sqrt(2) (W + r),
    the covering ellipse of the (L + r) x (W + r) rectangle, which contains the grown one
    ((x + y)^2 <= 2 (x^2 + y^2) and c + s >= 1).
    """
    if any(isinstance(v, (ca.SX, ca.MX)) for v in (L, W, r)):
        return SQRT2 * (L + r), SQRT2 * (W + r)
    return _containing_axes(float(L), float(W), float(r))


def _containing_axes(L: float, W: float, r: float) -> tuple[float, float]:
    from scipy.optimize import minimize_scalar

    t = np.linspace(0.0, 0.5 * math.pi, ELLIPSE_GRID)[1:]
    c, s = np.cos(t), np.sin(t)
    need = (L * c + W * s + r) ** 2

    def b_of(a: float) -> float:
        return math.sqrt(max(0.0, float(np.max((need - a * a * c * c) / (s * s)))))

    lo = L + r
    res = minimize_scalar(
        lambda a: a * b_of(a),
        bounds=(lo * (1 + 1e-6), 4.0 * (lo + W + r)),
        method="bounded",
        options={"xatol": 1e-9 * lo},
    )
    a = float(res.x)
    return a, b_of(a) * (1.0 + ELLIPSE_SAFETY)


def circles_h(ego: Shape, n_ego: int, opp: Shape, n_opp: int, cover: bool) -> list:
    """||p_i - p_j|| / (r_i + r_j) - 1 for every ego/opponent circle pair (dimensionless)."""
    r = circle_radius(ego.L, ego.W, n_ego, cover) + circle_radius(opp.L, opp.W, n_opp, cover)
    rows = []
    for pi in circle_centres(ego, n_ego):
        for pj in circle_centres(opp, n_opp):
            dx, dy = pi[0] - pj[0], pi[1] - pj[1]
            rows.append(_sqrt(dx * dx + dy * dy + 1e-12) / r - 1)
    return rows


def hyperplane_h(ego: Shape, opp: Shape, theta, length: float, margin: float = 0.0) -> tuple[list, Num]:
    """Separating hyperplane rows: -theta.[p - c_opp, 1] >= 0 (ego corners), theta.[p - c_opp, 1] >= 0 (opponent
    corners), each divided by ``length``, the ego's kept ``margin`` away; and the normalization t1^2 + t2^2 - 1 = 0.

    The plane is written relative to the opponent centre so t3 stays of the size of the vehicles.
    """
    t1, t2, t3 = theta[0], theta[1], theta[2]
    rows = []
    for px, py in vertices(ego):
        rows.append((-(t1 * (px - opp.cx) + t2 * (py - opp.cy) + t3) - margin) / length)
    for px, py in vertices(opp):
        rows.append((t1 * (px - opp.cx) + t2 * (py - opp.cy) + t3) / length)
    return rows, t1 * t1 + t2 * t2 - 1


def midpoint_plane(ego: Shape, opp: Shape) -> list:
    """The plane halfway between the two centres, normal from the ego's to the opponent's: [t1, t2, t3] relative to
    the opponent's centre (``hyperplane_h``); the initial guess and the safe profile's anchor."""
    dx, dy = opp.cx - ego.cx, opp.cy - ego.cy
    d = _sqrt(dx * dx + dy * dy + 1e-12)
    return [dx / d, dy / d, d / 2]


def sat_clearance(a: Shape, b: Shape):
    """Separating-axis clearance of two rectangles (CasADi): the largest gap of their projections over the four edge
    normals; positive: apart (a lower bound of their distance), negative: overlapping by its magnitude (the
    penetration depth). Minus ``fcgen.collision.sat_overlap`` of the same rectangles: the campaign's judge."""
    ca_, cb = vertices(a), vertices(b)
    gaps = []
    for ang in (a.angle, b.angle):
        for ux, uy in ((ca.cos(ang), ca.sin(ang)), (-ca.sin(ang), ca.cos(ang))):
            pa = [ux * x + uy * y for x, y in ca_]
            pb = [ux * x + uy * y for x, y in cb]
            lo_a, hi_a = _fold(ca.fmin, pa), _fold(ca.fmax, pa)
            lo_b, hi_b = _fold(ca.fmin, pb), _fold(ca.fmax, pb)
            gaps.append(ca.fmax(lo_a, lo_b) - ca.fmin(hi_a, hi_b))  # minus the projections' overlap
    return _fold(ca.fmax, gaps)


def _fold(op, values: list):
    out = values[0]
    for v in values[1:]:
        out = op(out, v)
    return out


def rows_per_opponent(model: ObstacleModel) -> int:
    """Soft constraint rows per opponent and stage."""
    if isinstance(model, Ellipse):
        return model.n_ego
    if isinstance(model, CoveringCircles):
        return model.n * model.ego_circles
    return 8


def thetas_per_opponent(model: ObstacleModel) -> int:
    return 3 if isinstance(model, SeparatingHyperplane) else 0


def constraint_rows(model: ObstacleModel, ego: Shape, opp: Shape, theta, cover: bool, length: float, axes=None):
    """(soft rows h >= 0, equality rows == 0) of one opponent at one stage; ``cover``: covering circles whatever the
    model's radius rule (the conventional formulation's fitted boxes); ``axes``: the containing ellipse's semi-axes
    given with the opponent's shape (else computed from its size)."""
    if isinstance(model, Ellipse):
        # the ego's n_ego circles (placed and sized as the covering circles' ``cover``): one row each
        r = circle_radius(ego.L, ego.W, model.n_ego, cover=True)
        if axes is None:
            axes = (containing_ellipse_axes if model.shape == "minkowski" else paper_ellipse_axes)(opp.L, opp.W, r)
        return [ellipse_h(px, py, opp, *axes) for px, py in circle_centres(ego, model.n_ego)], []
    if isinstance(model, CoveringCircles):
        return circles_h(ego, model.ego_circles, opp, model.n, cover or model.radius == "cover"), []
    rows, eq = hyperplane_h(ego, opp, theta, length, model.margin)
    return rows, [eq]


# --- conventional formulation: shapes in (s, n) -------------------------------------------------


def frenet_ego_shape(s, n, alpha, f, veh: Vehicle) -> Shape:
    """The ego chassis in (s, n), inflated by the Frenet stretch factor f >= 1 (``1 / (1 - |n| kappa)``)."""
    half_l = veh.l / 2
    return Shape(
        s + half_l * _cos(alpha),
        n + half_l * _sin(alpha),
        alpha,
        f * (veh.l_ch / 2 + half_l) - half_l,
        f * veh.w_ch / 2,
    )


SAG_SAFETY = 2.0  # the box's padding: this times chord_sag_bound (the road interpolant is no exact Frenet frame)


def edge_spacing(opp: Vehicle, points_per_metre: float) -> float:
    """The largest distance between two neighbouring points of the fitted rectangle's edges."""
    return max(e / max(2, math.ceil(e * points_per_metre)) for e in (opp.w_ch, opp.l_ch))


def chord_sag_bound(h: float, n_lo: float, n_hi: float, kap: np.ndarray, ds: float, reach: float) -> float | None:
    """How far a straight edge piece of length <= ``h``, mapped into (s, n), can leave the chord of its mapped ends.

    A line p(t) = p0 + t u (|u| = 1) in the Frenet frame of a road with curvature kappa(s): from
    u = s' (1 - n kappa) T + n' N, T' = kappa N, N' = -kappa T (' = d/dt along the line, kappa' = d kappa / ds),
    s' = (u.T) / (1 - n kappa), n' = u.N, n'' = -kappa (u.T)^2 / (1 - n kappa) and
    s'' = (kappa sin(2 theta) + n kappa' cos(theta)^2 / (1 - n kappa)) / (1 - n kappa)^2 (theta: u against T). So
    |r''| <= |s''| + |n''| <= (K + |n| K' / q) / q^2 + K / q with K = max |kappa|, K' = max |kappa'|,
    q = min(1 - n kappa) > 0 over the piece, and a C1 curve with bounded r'' leaves its chord by at most
    h^2 / 8 max |r''| (the linear interpolation error). ``n_lo``/``n_hi``: the mapped ends' n range (the piece stays
    within h / 2 of it, |n'| <= 1); ``kap``: the road's curvature samples (spacing ``ds``, piecewise linear between
    them) around the ends, at least ``reach + ds`` beyond them along s (the piece stays within h / (2 q) of them,
    |s'| <= 1 / q). ``None`` where that does not hold (the frame is nearly singular there): the edge cannot be
    bounded. 0 for h = 0 (no edges).
    """
    nl, nh = n_lo - (0.5 * h), n_hi + (0.5 * h)
    kmax, kmin = float(np.max(kap)), float(np.min(kap))
    q = 1.0 - max(0.0, nh * kmax, nh * kmin, nl * kmax, nl * kmin)
    if not ((0.5 * h) <= (q * (reach + ds))):
        return None
    k_abs = max(kmax, -kmin)
    dk = float(np.max(np.abs(np.diff(kap)))) if len(kap) > 1 else 0.0
    n_abs = max(nh, -nl)
    b_s = (k_abs + ((n_abs * (dk / ds)) / q)) / (q * q)
    b_n = k_abs / q
    return ((h * h) / 8.0) * (b_s + b_n)


def fit_frenet_shape(
    road: Road,
    pose_xyphi,
    opp: Vehicle,
    ego: Vehicle,
    margin: float,
    s_guess: float | None = None,
    points_per_metre: float = 4.0,
) -> np.ndarray:
    """Map the opponent's true rectangle into (s, n) and fit an oriented box around all mapped points.

    Returns ``FRENET_SHAPE`` values. The box axis joins the mapped rear and front centres; it is padded by the margin
    and ``SAG_SAFETY`` times the edges' chord bound (``chord_sag_bound``); the ego inflation factor uses the largest
    n kappa (signed: only the outside of a bend stretches) the ego can meet next to the box.
    """
    x, y, phi = (float(v) for v in pose_xyphi)
    sh = chassis_shape(x, y, phi, opp)
    corners = vertices(sh)
    pts = []
    for i in range(4):
        p0, p1 = np.array(corners[i]), np.array(corners[(i + 1) % 4])
        # points per edge from its nominal length (width, length, width, length): no rounding decides the count
        m = max(2, math.ceil((opp.w_ch if i % 2 == 0 else opp.l_ch) * points_per_metre))
        ts = np.linspace(0.0, 1.0, m + 1)
        pts += [p0 + t * (p1 - p0) for t in ts[:-1]]
    n_edge = len(pts)
    pts.append(np.array([sh.cx, sh.cy]))
    c, s = math.cos(phi), math.sin(phi)
    ends = [np.array([sh.cx - sh.L * c, sh.cy - sh.L * s]), np.array([sh.cx + sh.L * c, sh.cy + sh.L * s])]
    if s_guess is None:
        s_guess = road.project(x, y)
    P = np.array(pts + ends)
    guess = s_guess + (P - np.array([x, y])) @ np.array([c, s])
    sp = road.project(P[:, 0], P[:, 1], guess)
    _, phg, gx, gy, _, _ = road.eval(sp)
    fr = np.stack([sp, -(P[:, 0] - gx) * np.sin(phg) + (P[:, 1] - gy) * np.cos(phg)], axis=1)
    rear, front = fr[-2], fr[-1]
    body = fr[: n_edge + 1]
    angle = math.atan2(front[1] - rear[1], front[0] - rear[0])
    ax = np.array([math.cos(angle), math.sin(angle)])
    nm = np.array([-ax[1], ax[0]])
    a, b = body @ ax, body @ nm
    reach = ego.l + ego.l_ch + ego.w_ch
    n_hi, n_lo = body[:, 1].max() + reach, body[:, 1].min() - reach
    s_lo, s_hi = body[:, 0].min() - reach, body[:, 0].max() + reach
    sel = (road.s >= s_lo - road.ds) & (road.s <= s_hi + road.ds)
    kap = road.kappa[sel] if sel.any() else road.kappa
    # the ego is stretched by 1 / (1 - n kappa) only where n kappa > 0 (outside of the bend)
    stretch = max(0.0, n_hi * kap.max(), n_hi * kap.min(), n_lo * kap.max(), n_lo * kap.min())
    centre_s = 0.5 * (a.max() + a.min()) * ax[0] + 0.5 * (b.max() + b.min()) * nm[0]
    if stretch >= 0.9:
        raise ValueError(
            f"conventional over-approximation: |n| kappa = {stretch:.2f} near s = {centre_s:.1f} m; "
            "allowed < 0.9 (the Frenet frame is singular there)"
        )
    # the mapped edges are curves between the mapped points: pad by their bound off the chords
    sag = chord_sag_bound(
        edge_spacing(opp, points_per_metre), float(body[:, 1].min()), float(body[:, 1].max()), kap, road.ds, reach
    )
    if sag is None:
        raise ValueError(
            f"conventional over-approximation: the edges near s = {centre_s:.1f} m cannot be bounded "
            "(the Frenet frame is nearly singular there)"
        )
    margin = margin + SAG_SAFETY * sag
    L = 0.5 * (a.max() - a.min()) + margin
    W = 0.5 * (b.max() - b.min()) + margin
    centre = 0.5 * (a.max() + a.min()) * ax + 0.5 * (b.max() + b.min()) * nm
    return np.array([centre[0], centre[1], angle, L, W, 1.0 / (1.0 - stretch)])


def naive_frenet_shape(frenet_pose, opp: Vehicle) -> np.ndarray:
    """The Cartesian rectangle used unchanged in (s, n) at the opponent's Frenet pose: naive, unsafe."""
    s, n, alpha = (float(v) for v in frenet_pose)
    sh = chassis_shape(s, n, alpha, opp)
    return np.array([sh.cx, sh.cy, sh.angle, sh.L, sh.W, 1.0])


def plan_clearance_function(pb: Problem, xs, p, p_road, samples: int, lifted: bool) -> ca.Function:
    """The plan check of one stage: the ego's true chassis at the plan's state (Frenet states: F^-1 on the stage's
    road window) against every opponent's true chassis at its pose [x, y, phi] (as given to set_opponents) with its
    shape (set_opponent_shapes): the SAT clearance, and how far ahead of the ego (along its heading) the opponent's
    centre is."""
    n_opp = pb.opponents.count
    ns = len(shape_names(pb.obstacles))
    opp = ca.SX.sym("opp", n_opp * len(CARTESIAN_POSE))
    shape = ca.SX.sym("shape", n_opp * ns)
    pose: tuple[Any, Any, Any] = (
        (xs[5], xs[6], xs[7]) if lifted else casadi_to_cartesian(xs[0], xs[1], xs[2], p_road, samples)
    )
    ego_sh = chassis_shape(*pose, pb.ego)
    clearance, ahead = [], []
    for j in range(n_opp):
        opp_sh = shape_of(opp[3 * j], opp[3 * j + 1], opp[3 * j + 2], shape[ns * j : ns * j + 3])
        clearance.append(sat_clearance(ego_sh, opp_sh))
        # the opponent's centre along the ego's heading from the ego's centre: > 0 ahead (braking opens the gap)
        ahead.append((opp_sh.cx - ego_sh.cx) * ca.cos(pose[2]) + (opp_sh.cy - ego_sh.cy) * ca.sin(pose[2]))
    empty = ca.SX(0, 1)
    return ca.Function(
        "plan_clearance",
        [xs, p, opp, shape],
        [ca.vertcat(*clearance) if n_opp else empty, ca.vertcat(*ahead) if n_opp else empty],
        ["x", "p", "opp", "shape"],
        ["clearance", "ahead"],
    )
