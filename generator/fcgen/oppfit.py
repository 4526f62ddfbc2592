"""The conventional formulation's opponent fit, run by the solver's prepare phase (C and Python alike).

Per stage and opponent, from its Cartesian pose ``[x, y, phi]`` and the road given to ``set_road``:

1. ``opp_points`` (CasADi): points on the true chassis rectangle (the edge points, ``points_per_metre`` per metre
   of edge, corners included; the centre; the rear and front centres) and each point's offset
   ``d`` along the heading from the reference point (the chassis centre; for ``overapprox="none"`` the one point is
   the rear axle).
2. Search (C loop / numpy): the road sample nearest to the reference point over the whole road; for every point the
   nearest sample within ``SEARCH`` samples of ``i_ref + round(d / ds)``: the centre of its window of
   ``FOOT_WINDOW`` samples. (The C finds the same samples with less work: the whole-road scan skips samples that
   the triangle inequality proves farther than the best so far, from the previous stage's sample as the first
   guess; a point's window is walked down from its guess where its squared distances are provably unimodal,
   ``fit_window``; the first minimum either way, as numpy's ``argmin``.)
3. Foot point (plain C from the road arrays / numpy, the same operations, ``map_points``): a Halley step of
   ``(gamma(s) - p) . t(phi_gamma(s)) = 0`` from that sample (``node_step``: the sample's own values, no cos or
   sin), clamped into the window, then ``FULL_EVALS`` road evaluations (``segment_eval``: road.py's interpolant on
   the window's segment holding s, extrapolated beyond it, as its cubic Taylor expansion at the segment's first
   sample from ``road_data``; cos and sin of phi_gamma by rotating the sample's by the difference, ``rot_cos_sin``)
   with a Halley step each: the foot ``s``; ``n`` and ``phi_gamma(s)`` by their second-order Taylor expansions from
   the last evaluation (``foot_n_phi``). On the test and scenario roads s and n are within 5e-12 m of the converged
   projection (two evaluations: 1e-13 m).
4. ``opp_box`` (CasADi; the C does its operations in a plain loop, ``fit_box``): the box fitted around the mapped
   points and the ``n``/``s`` range the ego can reach next to it; then (C loop / numpy) the curvatures of the road
   samples in that ``s`` range: the ego's sign-aware stretch factor ``f = 1 / (1 - max(0, n kappa))`` and the box's
   padding ``margin + SAG_SAFETY * chord_sag_bound`` (the mapped edges are curves between the mapped points:
   ``obstacles.chord_sag_bound`` bounds how far they leave the chords, from the curvature and its slope).

An opponent is *outside the road* at a stage when the reference point's nearest sample is the road's first or last
one, the reference point is farther from that sample than ``far`` plus the largest sample spacing (no point of the
opponent can then come within the band plus the ego's reach: without this test, an opponent far beside a bend of the
road window, e.g. one the ego passed 130 m before whose road bends back, had its points searched on the wrong part of
the road and failed the prepare phase with ``ERR_OPP_FRENET``; 8 of the 12,000 campaign runs), a point's nearest
sample has no sample on either side, the ``s`` range of step 4 (plus one ``ds``) is not inside the road, or its box
plus the ego's reach lies beside the band ``[n_min, n_max]``: it is left out
(``neutral`` parameters, a box 1000 m behind the road) and counted in the status (``opp_outside``). A stretch
``max(n kappa) >= STRETCH_MAX`` (the Frenet frame is singular next to the opponent), an edge whose chord bound does
not apply (``obstacles.chord_sag_bound``), or a foot point that the steps leave outside its window (the
nearest sample was not next to it: the point cannot be mapped), fails the prepare phase with ``ERR_OPP_FRENET``
(points in index order: the first failing one decides). Also the ``s`` and ``phi_gamma`` of ``overapprox="none"``
come from this projection (of the rear axle).

The global search assumes the road does not come back near itself: on a road whose far part passes within a few
metres of the opponent, the nearest sample can lie on the wrong branch (truck seed 29 of the original road
generator: the wrong branch left a foot point outside its window, ERR_OPP_FRENET on 18 samples; a branch parallel to
the opponent would go unnoticed). The scenario generator's realistic roads keep far parts of the road apart.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import casadi as ca
import numpy as np

from . import obstacles as obs
from .dsl import Conventional, Problem

SEARCH = 4  # samples searched on either side of a point's guessed nearest sample
FOOT_WINDOW = 3  # road samples of a point's window: its nearest sample and one on either side (fixed: 3)
FULL_EVALS = 1  # road evaluations (a Halley step each) after the first step from the nearest sample
NEWTON_DG_MIN = 0.05  # a step divides by g' only where g' > this (else a plain gradient step)
STRETCH_MAX = 0.9  # |n| kappa allowed next to an opponent (obstacles.fit_frenet_shape's bound)
SAG_SAFETY = obs.SAG_SAFETY
# cos and sin of an evaluated phi_gamma: the rotation of its segment's first sample by the difference dl, cos(dl) and
# sin(dl) by their Taylor polynomials (Horner in dl^2) where |dl| <= ROT_MAX (the next terms are below 3e-18), else libm
ROT_MAX = 0.125
SIN_C = (-1.0 / 6.0, 1.0 / 120.0, -1.0 / 5040.0, 1.0 / 362880.0)
COS_C = (-1.0 / 2.0, 1.0 / 24.0, -1.0 / 720.0, 1.0 / 40320.0, -1.0 / 3628800.0)
BOX = ("c_s", "c_n", "angle", "L", "W", "n_hi", "n_lo", "s_lo", "s_hi", "pn_hi", "pn_lo")
# a road evaluation relative to a point p (the C's layout): phi_gamma', cos and sin of phi_gamma, gamma - p, gamma',
# gamma'', phi_gamma'', phi_gamma less its value at the segment's first sample
EVAL = ("dphi", "cos", "sin", "ex", "ey", "dgx", "dgy", "ddgx", "ddgy", "ddphi", "dl")


def edge_counts(opp_l: float, opp_w: float, points_per_metre: float) -> list[int]:
    """Points per rectangle edge (corner order of ``obstacles.vertices``: width, length, width, length)."""
    return [max(2, math.ceil(e * points_per_metre)) for e in (opp_w, opp_l, opp_w, opp_l)]


@dataclass(frozen=True)
class OppFit:
    """The fit's CasADi functions and constants for one problem (``None`` for a non-conventional one). An opponent's
    shape (``obstacles.OPP_SHAPE``: length, width, centre offset) is data: its edges get the point counts of the
    problem's opponent vehicle (``counts``), so the spacing of its points and how far it reaches depend on it
    (``spacing_of``, ``far_of``); ``spacing`` and ``far`` are the problem's vehicle's."""

    points: ca.Function  # (pose[3], shape[3]) -> (P[2 x npt], d[npt])
    box: ca.Function  # (FR[3 x npt], pose[3], shape[3]) -> (box: BOX; L, W without padding)
    npt: int
    ref_point: int  # index of the reference point of the global search
    n_min: float  # the ego's lateral band (state bounds on n)
    n_max: float
    spacing: float  # the largest distance of two neighbouring edge points (0: no edges)
    n_edge: int  # edge points (points 0 .. n_edge - 1; 0 for overapprox="none")
    margin: float  # the box's margin (0 for overapprox="none")
    reach: float  # how far the ego's chassis reaches from its rear axle (the box's n/s range)
    far: float  # a reference point farther than this (+ a road spacing) from every road sample: left out
    counts: tuple[int, int] = (0, 0)  # points on a width edge, on a length edge (0, 0: no edges)
    far_base: float = 0.0  # far less the opponent's own reach (``far_of``)
    shape0: tuple[float, ...] = ()  # the problem's opponent vehicle as OPP_SHAPE values

    def spacing_of(self, shape) -> float:
        """The largest distance of neighbouring edge points of an opponent of ``shape`` (0: no edges)."""
        if not self.n_edge:
            return 0.0
        return max(float(shape[1]) / self.counts[0], float(shape[0]) / self.counts[1])

    def far_of(self, shape) -> float:
        """``far`` for an opponent of ``shape``: the band and the ego's reach, plus how far the opponent's chassis
        reaches from its reference point (its centre; the pose's point for ``overapprox="none"``)."""
        half_l, half_w = float(shape[0]) / 2, float(shape[1]) / 2
        to_centre = 0.0 if self.n_edge else float(shape[2])
        return (self.far_base + to_centre) + math.sqrt((half_l * half_l) + (half_w * half_w))


def _box_function(form: Conventional, pose: ca.SX, shape: ca.SX, npt: int, ref: int, reach: float) -> ca.Function:
    """``opp_box``: (FR, pose, shape) -> the box around an opponent's ``npt`` points mapped into the Frenet frame
    (``FR``: s, n, angle per point; the first ``ref`` on the chassis' edges, then its centre and its axis' two ends),
    the band padded by the ego's ``reach``; without over-approximation the opponent's own rectangle."""
    FR = ca.SX.sym("FR", 3, npt)
    if form.overapprox == "none":
        sh = obs.shape_of(FR[0, 0], FR[1, 0], pose[2] - FR[2, 0], shape)
        out = [sh.cx, sh.cy, sh.angle, sh.L, sh.W, 0.0, 0.0, FR[0, 0], FR[0, 0], 0.0, 0.0]
    else:
        n_edge = ref
        fs, fn = FR[0, :].T, FR[1, :].T
        rs, rn, qs, qn = fs[npt - 2], fn[npt - 2], fs[npt - 1], fn[npt - 1]
        angle = ca.atan2(qn - rn, qs - rs)
        axs, axn = ca.cos(angle), ca.sin(angle)
        bs, bn = fs[: n_edge + 1], fn[: n_edge + 1]
        a = bs * axs + bn * axn
        b = -bs * axn + bn * axs
        a_hi, a_lo, b_hi, b_lo = ca.mmax(a), ca.mmin(a), ca.mmax(b), ca.mmin(b)
        ca_, cb = 0.5 * (a_hi + a_lo), 0.5 * (b_hi + b_lo)
        out = [
            ca_ * axs - cb * axn,
            ca_ * axn + cb * axs,
            angle,
            0.5 * (a_hi - a_lo),
            0.5 * (b_hi - b_lo),
            ca.mmax(bn) + reach,
            ca.mmin(bn) - reach,
            ca.mmin(bs) - reach,
            ca.mmax(bs) + reach,
            ca.mmax(bn),
            ca.mmin(bn),
        ]
    return ca.Function("opp_box", [FR, pose, shape], [ca.vertcat(*out)], ["FR", "pose", "shape"], ["box"])


def build_oppfit(problem: Problem) -> OppFit | None:
    """The opponent-fit functions of a conventional problem; ``None`` for the other formulations."""
    form = problem.formulation
    if not isinstance(form, Conventional):
        return None
    opp, ego = problem.opponents.vehicle, problem.ego
    pose = ca.SX.sym("pose", 3)
    shape = ca.SX.sym("shape", len(obs.OPP_SHAPE))
    x, y, phi = pose[0], pose[1], pose[2]
    c, s = ca.cos(phi), ca.sin(phi)
    counts = [0, 0, 0, 0]
    if form.overapprox == "none":
        P = ca.vertcat(x, y)
        d = ca.SX(1, 1)
        ref, spacing = 0, 0.0
    else:
        sh = obs.shape_of(x, y, phi, shape)
        corners = obs.vertices(sh)
        counts = edge_counts(opp.l_ch, opp.w_ch, form.points_per_metre)
        pts = []
        for i in range(4):
            (ax, ay), (bx, by) = corners[i], corners[(i + 1) % 4]
            ts = np.linspace(0.0, 1.0, counts[i] + 1)
            pts += [(ax + t * (bx - ax), ay + t * (by - ay)) for t in ts[:-1]]
        ref = len(pts)
        ends = [(sh.cx - sh.L * c, sh.cy - sh.L * s), (sh.cx + sh.L * c, sh.cy + sh.L * s)]
        allp = [*pts, (sh.cx, sh.cy), *ends]
        P = ca.horzcat(*[ca.vertcat(px, py) for px, py in allp])
        d = ca.vertcat(*[(px - sh.cx) * c + (py - sh.cy) * s for px, py in allp])
        spacing = obs.edge_spacing(opp, form.points_per_metre)
    npt = P.shape[1]
    points = ca.Function("opp_points", [pose, shape], [P, d], ["pose", "shape"], ["P", "d"])

    # -- the box around the mapped points (its padding, which needs the road's curvature, comes after)
    reach = ego.l + ego.l_ch + ego.w_ch
    box = _box_function(form, pose, shape, npt, ref, reach)
    margin = 0.0 if form.overapprox == "none" else form.margin
    n_edge = 0 if form.overapprox == "none" else ref
    # beyond `far` from the road no point of the opponent is within the band plus the ego's reach (its chassis
    # reaches hypot(l_ch, w_ch) / 2 from its centre; the rear-axle reference point is l / 2 behind the centre)
    far_base = max(abs(problem.bounds.n_min), abs(problem.bounds.n_max)) + reach
    fit = OppFit(
        points,
        box,
        npt,
        ref,
        problem.bounds.n_min,
        problem.bounds.n_max,
        spacing,
        n_edge,
        margin,
        reach,
        0.0,
        (counts[0], counts[1]),
        far_base,
    )
    shape0 = default_shape(problem)
    return replace(fit, far=fit.far_of(shape0), shape0=tuple(float(v) for v in shape0))


def default_shape(problem: Problem) -> np.ndarray:
    """The problem's opponent vehicle as ``OPP_SHAPE`` values (its pose is its rear axle)."""
    v = problem.opponents.vehicle
    return np.array([v.l_ch, v.w_ch, v.l / 2])


def neutral(s0: float) -> np.ndarray:
    """Parameters of an opponent left out: a unit box 1000 m behind the road's first sample, no stretch."""
    return np.array([s0 - 1000.0, 0.0, 0.0, 1.0, 1.0, 1.0])


def stretch_factor(box: np.ndarray, kap: np.ndarray) -> tuple[float, float]:
    """(max(0, n kappa) over the box's n range and the curvature samples, 1 / (1 - it)); the C computes the same."""
    kmax, kmin = float(np.max(kap)), float(np.min(kap))
    n_hi, n_lo = float(box[5]), float(box[6])
    st = max(0.0, n_hi * kmax, n_hi * kmin, n_lo * kmax, n_lo * kmin)
    return st, 1.0 / (1.0 - st)


# --- the foot point (numpy over all pairs at once; the C does the same operations point by point) ----------------


def libm(fun, v: np.ndarray) -> np.ndarray:
    """libm's cos or sin elementwise (math.cos: what the C calls; numpy's own may differ in the last bit)."""
    return np.array([fun(t) for t in v.ravel().tolist()]).reshape(v.shape)


@dataclass(frozen=True)
class RoadData:
    """The road's data for the fit (the C's ``fit_road_data``, operation for operation): cos and sin of phi_gamma at
    the samples (the node slopes of gamma's interpolant); per segment j (samples j, j + 1; the last entry unused) the
    second derivatives of phi_gamma, gamma_x, gamma_y at its first sample (``dd_*``) and their third derivatives
    (``d3_*``, constant: the interpolant is cubic on a segment)."""

    cos: np.ndarray
    sin: np.ndarray
    dd_phi: np.ndarray
    dd_x: np.ndarray
    dd_y: np.ndarray
    d3_phi: np.ndarray
    d3_x: np.ndarray
    d3_y: np.ndarray


def road_data(road) -> RoadData:
    """``RoadData`` of a road."""
    ds = road.ds
    a, b, c = 4.0 * ds, 2.0 * ds, 6.0 * ds
    ids = 1.0 / ds
    ids2 = ids * ids
    ids3 = ids2 * ids
    cphi, sphi = libm(math.cos, road.phi), libm(math.sin, road.phi)

    def dd(y, m):
        h = y[1:] - y[:-1]
        return (
            np.append((((6.0 * h) - (a * m[:-1])) - (b * m[1:])) * ids2, 0.0),
            np.append(((c * (m[:-1] + m[1:])) - (12.0 * h)) * ids3, 0.0),
        )

    (ddp, d3p), (ddx, d3x), (ddy, d3y) = dd(road.phi, road.kappa), dd(road.gx, cphi), dd(road.gy, sphi)
    return RoadData(cphi, sphi, ddp, ddx, ddy, d3p, d3x, d3y)


def rot_cos_sin(phi0: np.ndarray, dl: np.ndarray, c0: np.ndarray, s0: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """cos and sin of phi0 + dl from those (c0, s0) of phi0 (the C's ``fit_segment``): the rotation by dl, its cos
    and sin by their Taylor polynomials where |dl| <= ROT_MAX, else libm of phi0 + dl."""
    d2 = dl * dl
    sd = dl + ((dl * d2) * (SIN_C[0] + (d2 * (SIN_C[1] + (d2 * (SIN_C[2] + (d2 * SIN_C[3])))))))
    cd = 1.0 + (d2 * (COS_C[0] + (d2 * (COS_C[1] + (d2 * (COS_C[2] + (d2 * (COS_C[3] + (d2 * COS_C[4])))))))))
    near = (dl <= ROT_MAX) & (dl >= -ROT_MAX)
    c = np.where(near, (c0 * cd) - (s0 * sd), 0.0)
    s = np.where(near, (s0 * cd) + (c0 * sd), 0.0)
    if not np.all(near):
        far = ~near
        c[far] = libm(math.cos, (phi0 + dl)[far])
        s[far] = libm(math.sin, (phi0 + dl)[far])
    return c, s


def segment_eval(road, rd: RoadData, j: np.ndarray, h: np.ndarray, px: np.ndarray, py: np.ndarray):
    """The road's interpolant (road.py's) on its segment j at h = s - (s0 + j ds), relative to the point (px, py):
    EVAL (the C's ``fit_segment``): its Taylor expansion at the segment's first sample (exact: a cubic)."""
    k0, c0, s0 = road.kappa[j], rd.cos[j], rd.sin[j]
    pp, xx, yy = rd.dd_phi[j], rd.dd_x[j], rd.dd_y[j]
    p3, x3, y3 = rd.d3_phi[j], rd.d3_x[j], rd.d3_y[j]
    sixth = 1.0 / 6.0
    dl = h * (k0 + (h * ((0.5 * pp) + (h * (p3 * sixth)))))
    dphi = k0 + (h * (pp + (h * (0.5 * p3))))
    cg, sg = rot_cos_sin(road.phi[j], dl, c0, s0)
    ex = (road.gx[j] - px) + (h * (c0 + (h * ((0.5 * xx) + (h * (x3 * sixth))))))
    ey = (road.gy[j] - py) + (h * (s0 + (h * ((0.5 * yy) + (h * (y3 * sixth))))))
    dx = c0 + (h * (xx + (h * (0.5 * x3))))
    dy = s0 + (h * (yy + (h * (0.5 * y3))))
    return dphi, cg, sg, ex, ey, dx, dy, xx + (h * x3), yy + (h * y3), pp + (h * p3), dl


def halley_length(g, g1, g2):
    """The length of one Halley step of g(s) = (gamma(s) - p) . t(phi_gamma(s)) = 0 with g' = g1, g'' = g2:
    2 g g' / (2 g'^2 - g g''); a Newton step's where |g g''| > g'^2, a plain gradient step's (g) where
    g' <= NEWTON_DG_MIN."""
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        gg = g * g2
        g11 = g1 * g1
        hal = np.where(np.abs(gg) <= g11, ((2.0 * g) * g1) / ((2.0 * g11) - gg), g / g1)
        return np.where(g1 > NEWTON_DG_MIN, hal, g)


def halley_step(s, ev):
    """One Halley step from s with the road evaluation ev (EVAL) at s."""
    dphi, cg, sg, ex, ey, dx, dy, ddx, ddy, ddphi, _ = ev
    g = (ex * cg) + (ey * sg)
    en = (ey * cg) - (ex * sg)
    g1 = ((dx * cg) + (dy * sg)) + (dphi * en)
    g2 = ((((ddx * cg) + (ddy * sg)) + ((2.0 * dphi) * ((dy * cg) - (dx * sg)))) + (ddphi * en)) - ((dphi * dphi) * g)
    return s - halley_length(g, g1, g2)


def node_step(road, rd: RoadData, c: np.ndarray, s: np.ndarray, px: np.ndarray, py: np.ndarray) -> np.ndarray:
    """A Halley step from the road sample c (s its arc length) from the samples alone (no cos or sin): the segment
    c .. c + 1's derivatives there (``segment_eval`` at h = 0; gamma' = t: g' = |t|^2 + phi' e.n, gamma'.n = 0)."""
    kc, cc, sc = road.kappa[c], rd.cos[c], rd.sin[c]
    ex, ey = road.gx[c] - px, road.gy[c] - py
    g = (ex * cc) + (ey * sc)
    en = (ey * cc) - (ex * sc)
    g1 = ((cc * cc) + (sc * sc)) + (kc * en)
    g2 = (((rd.dd_x[c] * cc) + (rd.dd_y[c] * sc)) + (rd.dd_phi[c] * en)) - ((kc * kc) * g)
    return s - halley_length(g, g1, g2)


def foot_n_phi(s, s_ev, phi0, ev):
    """n and phi_gamma at the foot s from the road evaluation ev at s_ev on the segment whose first sample has
    phi_gamma = phi0: their second-order Taylor expansions (n = (p - gamma) . n(phi_gamma), n' = phi' g - gamma'.n,
    n'' = phi' gamma'.t - gamma''.n + phi'' g + phi' g')."""
    dphi, cg, sg, ex, ey, dx, dy, ddx, ddy, ddphi, dl = ev
    g = (ex * cg) + (ey * sg)
    en = (ey * cg) - (ex * sg)
    tg = (dx * cg) + (dy * sg)
    g1 = tg + (dphi * en)
    dn = (dphi * g) - ((dy * cg) - (dx * sg))
    ddn = (((dphi * tg) - ((ddy * cg) - (ddx * sg))) + (ddphi * g)) + (dphi * g1)
    d = s - s_ev
    h = 0.5 * d
    return -en + (d * (dn + (h * ddn))), phi0 + (dl + (d * (dphi + (h * ddphi))))


def map_points(fit: OppFit, road, P: np.ndarray, ist: np.ndarray, rd: RoadData | None = None):
    """Foot points of all points: (s, n, phi_gamma) each (pairs, npt), and the windows' first s. ``P``:
    (2, pairs, npt); ``ist``: the points' nearest samples (clamped into the road where a point is bad: computed,
    then discarded). Per point: a Halley step from its nearest sample (``node_step``), clamped into the window, then
    FULL_EVALS road evaluations (``segment_eval`` on the window's segment holding s, the first or last one beyond
    it) with a step each; n and phi_gamma from the last one (``foot_n_phi``)."""
    rd = road_data(road) if rd is None else rd
    half = FOOT_WINDOW // 2
    i0 = np.clip(ist - half, 0, road.size - FOOT_WINDOW)
    px, py = P[0], P[1]
    ds = road.ds
    w0 = road.s0 + i0 * ds
    s = node_step(road, rd, i0 + half, w0 + ds, px, py)
    s = np.minimum(np.maximum(s, w0), w0 + (FOOT_WINDOW - 1) * ds)
    for _ in range(FULL_EVALS):
        h = s - w0
        right = h >= ds  # the segment holding s, clamped into the window (NaN: 0)
        j = i0 + right.astype(np.int64)
        s_ev = s
        ev = segment_eval(road, rd, j, np.where(right, h - ds, h), px, py)
        s = halley_step(s, ev)
    fn, fp = foot_n_phi(s, s_ev, road.phi[j], ev)
    return s, fn, fp, w0


def far_squared(far: float, road) -> float:
    """(far + the largest distance of neighbouring road samples)^2, as the C computes it (``fit_road_data``,
    ``fit_opponents``): a reference point farther than this from its nearest sample is left out (no curve point is
    more than that spacing from a sample)."""
    h2 = float(np.max(np.diff(road.gx) ** 2 + np.diff(road.gy) ** 2)) if road.size > 1 else 0.0
    far = far + (math.sqrt(h2) * 1.001 + 1e-6)
    return far * far


class OppFitter:
    """The Python reference's fit of all stages and opponents at once (numpy search and foot points, mapped CasADi
    functions)."""

    def __init__(self, fit: OppFit, stages: int, n_opp: int):
        self.fit = fit
        self.stages, self.n_opp = stages, n_opp
        cnt = stages * n_opp
        self._points = fit.points.map(cnt)
        self._box = fit.box.map(cnt)

    def __call__(
        self, road, poses: np.ndarray, shapes: np.ndarray | None = None
    ) -> tuple[np.ndarray, int, list[tuple[int, int]]]:
        """Fitted parameters (stages, n_opp * 6), the count left out, the (stage, opponent) pairs that cannot be
        mapped (a foot point outside its window, a stretch >= STRETCH_MAX, an edge beyond the chord bound), in
        stage-major order.

        ``poses``: (stages, n_opp, 3); ``shapes``: (n_opp, 3) ``OPP_SHAPE`` values (None: the problem's vehicle).
        """
        f, npt = self.fit, self.fit.npt
        cnt = self.stages * self.n_opp
        pz = np.asarray(poses, dtype=float).reshape(cnt, 3)
        one = f.shape0 if shapes is None else np.asarray(shapes, dtype=float)[:, :3]
        shp = np.tile(np.asarray(one, dtype=float).reshape(-1, 3), (cnt // len(np.atleast_2d(one)), 1))
        P, d = self._points(pz.T, shp.T)
        P = np.array(P).reshape(2, cnt, npt)  # [coord, pair, point]: the map's columns are pair-major
        d = np.array(d).T  # [pair, point]
        M = road.size
        # the reference point's nearest sample over the whole road (first minimum)
        rx, ry = P[0, :, f.ref_point], P[1, :, f.ref_point]
        d2 = (road.gx[None, :] - rx[:, None]) ** 2 + (road.gy[None, :] - ry[:, None]) ** 2
        i_ref = np.argmin(d2, axis=1)
        far2 = np.array([far_squared(f.far_of(shp[p]), road) for p in range(cnt)])
        is_far = d2[np.arange(cnt), i_ref] > far2
        # every point's nearest sample within SEARCH of its guess
        g = i_ref[:, None] + np.floor(d / road.ds + 0.5).astype(np.int64)
        offs = np.arange(-SEARCH, SEARCH + 1)
        cand = g[:, :, None] + offs
        valid = (cand >= 0) & (cand <= M - 1)
        cc = np.clip(cand, 0, M - 1)
        dd = (road.gx[cc] - P[0][:, :, None]) ** 2 + (road.gy[cc] - P[1][:, :, None]) ** 2
        dd = np.where(valid, dd, np.inf)
        ist = np.take_along_axis(cc, np.argmin(dd, axis=2)[:, :, None], axis=2)[:, :, 0]
        half = FOOT_WINDOW // 2
        bad_pt = ~np.any(valid, axis=2) | (ist < half) | (ist > M - 1 - half)
        fs, fn, fp, w0 = map_points(f, road, P, np.where(bad_pt, half, ist))
        boxes = np.array(self._box(_fr_columns(fs, fn, fp), pz.T, shp.T))
        # a foot outside its window: the nearest sample was not next to it (the point cannot be mapped)
        lost = ~((fs >= w0) & (fs <= w0 + (FOOT_WINDOW - 1) * road.ds))
        first = np.argmax(bad_pt | lost, axis=1)  # the C stops at the first such point
        out = np.empty((cnt, 6))
        outside, singular = 0, []
        s_first, s_last = road.s0, road.s0 + (M - 1) * road.ds
        s_grid = road.s0 + road.ds * np.arange(M)
        for p in range(cnt):
            bx = boxes[:, p]
            lo, hi = bx[7] - road.ds, bx[8] + road.ds
            if i_ref[p] == 0 or i_ref[p] == M - 1 or is_far[p]:  # the reference point is not next to the road
                out[p] = neutral(road.s0)
                outside += 1
                continue
            if not bad_pt[p, first[p]] and lost[p, first[p]]:
                singular.append(divmod(p, self.n_opp))
                continue
            if bad_pt[p].any() or not (lo >= s_first and hi <= s_last) or bx[6] > f.n_max or bx[5] < f.n_min:
                out[p] = neutral(road.s0)
                outside += 1
                continue
            kap = road.kappa[(s_grid >= lo) & (s_grid <= hi)]
            st, fac = stretch_factor(bx, kap)
            sag = obs.chord_sag_bound(f.spacing_of(shp[p]), float(bx[10]), float(bx[9]), kap, road.ds, f.reach)
            if st >= STRETCH_MAX or sag is None:
                singular.append(divmod(p, self.n_opp))
                continue
            pad = f.margin + SAG_SAFETY * sag
            out[p] = [bx[0], bx[1], bx[2], bx[3] + pad, bx[4] + pad, fac]
        return out.reshape(self.stages, self.n_opp * 6), outside, singular


def _fr_columns(fs: np.ndarray, fn: np.ndarray, fp: np.ndarray) -> np.ndarray:
    """(3, pairs * npt) columns of the box map's FR input: pair-major, each pair's (s, n, phi_gamma) per point."""
    return np.stack([fs.ravel(), fn.ravel(), fp.ravel()])
