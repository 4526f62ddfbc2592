"""The conventional formulation's opponent fit, run by the solver's prepare phase (C and Python alike).

Per stage and opponent, from its Cartesian pose ``[x, y, phi]`` and the road given to ``set_road``:

1. ``opp_points`` (CasADi): points on the true chassis rectangle (the edge points, ``points_per_metre`` per metre
   of edge, corners included; the centre; the rear and front centres) and each point's offset
   ``d`` along the heading from the reference point (the chassis centre; for ``overapprox="none"`` the one point is
   the rear axle).
2. Search (C loop / numpy): the road sample nearest to the reference point over the whole road; for every point the
   nearest sample within ``SEARCH`` samples of ``i_ref + round(d / ds)``: the centre of its window of
   ``FOOT_WINDOW`` samples.
3. Foot point (plain C from the road arrays / numpy, the same operations, ``map_points``): a Halley step of
   ``(gamma(s) - p) . t(phi_gamma(s)) = 0`` from that sample (``node_eval``: the sample's own values, no cos or
   sin), clamped into the window, then ``FULL_EVALS`` road evaluations (road.py's interpolant on the window's segment
   holding s, extrapolated beyond it) with a Halley step each: the foot ``s``; ``n`` and ``phi_gamma(s)`` by their
   second-order Taylor expansions from the last evaluation (``foot_n_phi``). On the test and scenario roads s and n
   are within 5e-12 m of the converged projection (two evaluations: 1e-13 m).
4. ``opp_box`` (CasADi): the box fitted around the mapped points and the ``n``/``s`` range the ego can reach next to
   it; then (C loop / numpy) the curvatures of the road samples in that ``s`` range: the ego's sign-aware stretch
   factor ``f = 1 / (1 - max(0, n kappa))`` and the box's padding ``margin + SAG_SAFETY * chord_sag_bound`` (the
   mapped edges are curves between the mapped points: ``obstacles.chord_sag_bound`` bounds how far they leave the
   chords, from the curvature and its slope).

An opponent is *outside the road* at a stage when the reference point's nearest sample is the road's first or last
one, a point's nearest sample has no sample on either side, the ``s`` range of step 4 (plus one ``ds``) is not
inside the road, or its box plus the ego's reach lies beside the band ``[n_min, n_max]``: it is left out
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
from dataclasses import dataclass

import casadi as ca
import numpy as np

from . import obstacles as obs
from .dsl import Conventional, Problem

SEARCH = 4            # samples searched on either side of a point's guessed nearest sample
FOOT_WINDOW = 3       # road samples of a point's window: its nearest sample and one on either side (fixed: 3)
FULL_EVALS = 1        # road evaluations (a Halley step each) after the first step from the nearest sample
NEWTON_DG_MIN = 0.05  # a step divides by g' only where g' > this (else a plain gradient step)
STRETCH_MAX = 0.9     # |n| kappa allowed next to an opponent (obstacles.fit_frenet_shape's bound)
SAG_SAFETY = obs.SAG_SAFETY
BOX = ("c_s", "c_n", "angle", "L", "W", "n_hi", "n_lo", "s_lo", "s_hi", "pn_hi", "pn_lo")
# a road evaluation (the C's layout; the last entry: where it was taken)
EVAL = ("dphi", "cos", "sin", "gx", "gy", "dgx", "dgy", "ddgx", "ddgy", "ddphi", "phi", "s")


def edge_counts(opp_l: float, opp_w: float, points_per_metre: float) -> list[int]:
    """Points per rectangle edge (corner order of ``obstacles.vertices``: width, length, width, length)."""
    return [max(2, int(math.ceil(e * points_per_metre))) for e in (opp_w, opp_l, opp_w, opp_l)]


@dataclass(frozen=True)
class OppFit:
    """The fit's CasADi functions and constants for one problem (``None`` for a non-conventional one)."""

    points: ca.Function     # (pose[3]) -> (P[2 x npt], d[npt])
    box: ca.Function        # (FR[3 x npt], pose[3]) -> (box: BOX; L, W without padding)
    npt: int
    ref_point: int          # index of the reference point of the global search
    n_min: float            # the ego's lateral band (state bounds on n)
    n_max: float
    spacing: float          # the largest distance of two neighbouring edge points (0: no edges)
    margin: float           # the box's margin (0 for overapprox="none")
    reach: float            # how far the ego's chassis reaches from its rear axle (the box's n/s range)


def build_oppfit(problem: Problem) -> OppFit | None:
    """The opponent-fit functions of a conventional problem; ``None`` for the other formulations."""
    form = problem.formulation
    if not isinstance(form, Conventional):
        return None
    opp, ego = problem.opponents.vehicle, problem.ego
    pose = ca.SX.sym("pose", 3)
    x, y, phi = pose[0], pose[1], pose[2]
    c, s = ca.cos(phi), ca.sin(phi)
    if form.overapprox == "none":
        P = ca.vertcat(x, y)
        d = ca.SX(1, 1)
        ref, spacing = 0, 0.0
    else:
        sh = obs.chassis_shape(x, y, phi, opp)
        corners = obs.vertices(sh)
        counts = edge_counts(opp.l_ch, opp.w_ch, form.points_per_metre)
        pts = []
        for i in range(4):
            (ax, ay), (bx, by) = corners[i], corners[(i + 1) % 4]
            ts = np.linspace(0.0, 1.0, counts[i] + 1)
            pts += [(ax + t * (bx - ax), ay + t * (by - ay)) for t in ts[:-1]]
        ref = len(pts)
        ends = [(sh.cx - sh.L * c, sh.cy - sh.L * s), (sh.cx + sh.L * c, sh.cy + sh.L * s)]
        allp = pts + [(sh.cx, sh.cy)] + ends
        P = ca.horzcat(*[ca.vertcat(px, py) for px, py in allp])
        d = ca.vertcat(*[(px - sh.cx) * c + (py - sh.cy) * s for px, py in allp])
        spacing = obs.edge_spacing(opp, form.points_per_metre)
    npt = P.shape[1]
    points = ca.Function("opp_points", [pose], [P, d], ["pose"], ["P", "d"])

    # -- the box around the mapped points (its padding, which needs the road's curvature, comes after)
    FR = ca.SX.sym("FR", 3, npt)
    reach = ego.l + ego.l_ch + ego.w_ch
    if form.overapprox == "none":
        sh = obs.chassis_shape(FR[0, 0], FR[1, 0], pose[2] - FR[2, 0], opp)
        out = [sh.cx, sh.cy, sh.angle, sh.L, sh.W, 0.0, 0.0, FR[0, 0], FR[0, 0], 0.0, 0.0]
    else:
        n_edge = ref
        fs, fn = FR[0, :].T, FR[1, :].T
        rs, rn, qs, qn = fs[npt - 2], fn[npt - 2], fs[npt - 1], fn[npt - 1]
        angle = ca.atan2(qn - rn, qs - rs)
        axs, axn = ca.cos(angle), ca.sin(angle)
        bs, bn = fs[:n_edge + 1], fn[:n_edge + 1]
        a = bs * axs + bn * axn
        b = -bs * axn + bn * axs
        a_hi, a_lo, b_hi, b_lo = ca.mmax(a), ca.mmin(a), ca.mmax(b), ca.mmin(b)
        ca_, cb = 0.5 * (a_hi + a_lo), 0.5 * (b_hi + b_lo)
        out = [ca_ * axs - cb * axn, ca_ * axn + cb * axs, angle, 0.5 * (a_hi - a_lo), 0.5 * (b_hi - b_lo),
               ca.mmax(bn) + reach, ca.mmin(bn) - reach, ca.mmin(bs) - reach, ca.mmax(bs) + reach,
               ca.mmax(bn), ca.mmin(bn)]
    box = ca.Function("opp_box", [FR, pose], [ca.vertcat(*out)], ["FR", "pose"], ["box"])
    margin = 0.0 if form.overapprox == "none" else form.margin
    return OppFit(points, box, npt, ref, problem.bounds.n_min, problem.bounds.n_max, spacing, margin, reach)


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


def road_eval(road, cphi: np.ndarray, sphi: np.ndarray, i0: np.ndarray, s: np.ndarray) -> tuple[np.ndarray, ...]:
    """The road interpolant at s on the segment of the window i0 .. i0 + FOOT_WINDOW - 1 that holds s (the first or
    last one beyond it): EVAL but s (the C's ``fit_road``, operation for operation)."""
    ds = road.ds
    ids = 1.0 / ds
    w0 = road.s0 + i0 * ds
    t = (s - w0) * ids
    fi = np.where(t >= 1.0, 1.0, 0.0)                     # floor(t) clamped into [0, FOOT_WINDOW - 2] (NaN: 0)
    tau = t - fi
    j = i0 + fi.astype(np.int64)
    t2 = tau * tau
    t3 = t2 * tau
    h00 = ((2.0 * t3) - (3.0 * t2)) + 1.0
    h10 = ((t3 - (2.0 * t2)) + tau) * ds
    h01 = (3.0 * t2) - (2.0 * t3)
    h11 = (t3 - t2) * ds
    d00 = (6.0 * t2) - (6.0 * tau)
    d10 = (((3.0 * t2) - (4.0 * tau)) + 1.0) * ds
    d11 = ((3.0 * t2) - (2.0 * tau)) * ds
    e00 = (12.0 * tau) - 6.0
    e10 = ((6.0 * tau) - 4.0) * ds
    e11 = ((6.0 * tau) - 2.0) * ds
    ids2 = ids * ids

    def herm(y, m):
        y0, y1, m0, m1 = y[j], y[j + 1], m[j], m[j + 1]
        val = (((h00 * y0) + (h10 * m0)) + (h01 * y1)) + (h11 * m1)
        der = ((((d00 * y0) + (d10 * m0)) - (d00 * y1)) + (d11 * m1)) * ids
        dd = ((((e00 * y0) + (e10 * m0)) - (e00 * y1)) + (e11 * m1)) * ids2
        return val, der, dd

    phi, dphi, ddphi = herm(road.phi, road.kappa)
    gx, dgx, ddgx = herm(road.gx, cphi)
    gy, dgy, ddgy = herm(road.gy, sphi)
    return dphi, libm(math.cos, phi), libm(math.sin, phi), gx, gy, dgx, dgy, ddgx, ddgy, ddphi, phi


def halley_step(s, ev, px, py):
    """One Halley step of g(s) = (gamma(s) - p) . t(phi_gamma(s)) = 0 from s with the road evaluation ev (EVAL) at s:
    s - 2 g g' / (2 g'^2 - g g''); a Newton step where |g g''| > g'^2, a plain gradient step where
    g' <= NEWTON_DG_MIN."""
    dphi, cg, sg, gx, gy, dx, dy, ddx, ddy, ddphi, _ = ev
    ex, ey = gx - px, gy - py
    g = (ex * cg) + (ey * sg)
    en = (ey * cg) - (ex * sg)
    g1 = ((dx * cg) + (dy * sg)) + (dphi * en)
    g2 = ((((ddx * cg) + (ddy * sg)) + ((2.0 * dphi) * ((dy * cg) - (dx * sg)))) + (ddphi * en)) - ((dphi * dphi) * g)
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        gg = g * g2
        g11 = g1 * g1
        hal = np.where(np.abs(gg) <= g11, ((2.0 * g) * g1) / ((2.0 * g11) - gg), g / g1)
        return s - np.where(g1 > NEWTON_DG_MIN, hal, g)


def foot_n_phi(s, s_ev, ev, px, py):
    """n and phi_gamma at the foot s from the road evaluation ev at s_ev: their second-order Taylor expansions
    (n = (p - gamma) . n(phi_gamma), n' = phi' g - gamma'.n, n'' = phi' gamma'.t - gamma''.n + phi'' g + phi' g')."""
    dphi, cg, sg, gx, gy, dx, dy, ddx, ddy, ddphi, phi = ev
    ex, ey = gx - px, gy - py
    g = (ex * cg) + (ey * sg)
    en = (ey * cg) - (ex * sg)
    g1 = ((dx * cg) + (dy * sg)) + (dphi * en)
    dn = (dphi * g) - ((dy * cg) - (dx * sg))
    ddn = (((dphi * ((dx * cg) + (dy * sg))) - ((ddy * cg) - (ddx * sg))) + (ddphi * g)) + (dphi * g1)
    d = s - s_ev
    h = 0.5 * d
    return ((ex * sg) + ((py - gy) * cg)) + (d * (dn + (h * ddn))), phi + (d * (dphi + (h * ddphi)))


def node_eval(road, cphi: np.ndarray, sphi: np.ndarray, ist: np.ndarray, s: np.ndarray) -> tuple[np.ndarray, ...]:
    """EVAL but s at the road sample ist (s its arc length), from the samples alone (no cos or sin): the derivatives of
    the segment ist .. ist + 1 there."""
    ds = road.ds
    ids2 = (1.0 / ds) * (1.0 / ds)
    k0, k1, p0, p1 = road.kappa[ist], road.kappa[ist + 1], road.phi[ist], road.phi[ist + 1]
    c0, c1, s0, s1 = cphi[ist], cphi[ist + 1], sphi[ist], sphi[ist + 1]
    a, b = 4.0 * ds, 2.0 * ds

    def dd(y0, y1, m0, m1):
        return (((6.0 * (y1 - y0)) - (a * m0)) - (b * m1)) * ids2

    return (k0, c0, s0, road.gx[ist], road.gy[ist], c0, s0, dd(road.gx[ist], road.gx[ist + 1], c0, c1),
            dd(road.gy[ist], road.gy[ist + 1], s0, s1), dd(p0, p1, k0, k1), p0)


def map_points(fit: OppFit, road, P: np.ndarray, ist: np.ndarray):
    """Foot points of all points: (s, n, phi_gamma) each (pairs, npt), and the windows' first s. ``P``:
    (2, pairs, npt); ``ist``: the points' nearest samples (clamped into the road where a point is bad: computed,
    then discarded). Per point: a Halley step from its nearest sample (``node_eval``), clamped into the window, then
    FULL_EVALS road evaluations with a step each; n and phi_gamma from the last one (``foot_n_phi``)."""
    half = FOOT_WINDOW // 2
    i0 = np.clip(ist - half, 0, road.size - FOOT_WINDOW)
    cphi, sphi = libm(math.cos, road.phi), libm(math.sin, road.phi)
    px, py = P[0], P[1]
    w0 = road.s0 + i0 * road.ds
    s = w0 + road.ds                                      # the nearest sample
    s = halley_step(s, node_eval(road, cphi, sphi, i0 + half, s), px, py)
    s = np.minimum(np.maximum(s, w0), w0 + (FOOT_WINDOW - 1) * road.ds)
    for _ in range(FULL_EVALS):
        s_ev = s
        ev = road_eval(road, cphi, sphi, i0, s)
        s = halley_step(s, ev, px, py)
    fn, fp = foot_n_phi(s, s_ev, ev, px, py)
    return s, fn, fp, w0


class OppFitter:
    """The Python reference's fit of all stages and opponents at once (numpy search and foot points, mapped CasADi
    functions)."""

    def __init__(self, fit: OppFit, stages: int, n_opp: int):
        self.fit = fit
        self.stages, self.n_opp = stages, n_opp
        cnt = stages * n_opp
        self._points = fit.points.map(cnt)
        self._box = fit.box.map(cnt)

    def __call__(self, road, poses: np.ndarray) -> tuple[np.ndarray, int, list[tuple[int, int]]]:
        """Fitted parameters (stages, n_opp * 6), the count left out, the (stage, opponent) pairs that cannot be
        mapped (a foot point outside its window, a stretch >= STRETCH_MAX, an edge beyond the chord bound), in
        stage-major order.

        ``poses``: (stages, n_opp, 3).
        """
        f, npt = self.fit, self.fit.npt
        cnt = self.stages * self.n_opp
        pz = np.asarray(poses, dtype=float).reshape(cnt, 3)
        P, d = self._points(pz.T)
        P = np.array(P).reshape(2, cnt, npt)                  # [coord, pair, point]: the map's columns are pair-major
        d = np.array(d).T                                     # [pair, point]
        M = road.size
        # the reference point's nearest sample over the whole road (first minimum)
        rx, ry = P[0, :, f.ref_point], P[1, :, f.ref_point]
        d2 = (road.gx[None, :] - rx[:, None]) ** 2 + (road.gy[None, :] - ry[:, None]) ** 2
        i_ref = np.argmin(d2, axis=1)
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
        boxes = np.array(self._box(_fr_columns(fs, fn, fp), pz.T))
        # a foot outside its window: the nearest sample was not next to it (the point cannot be mapped)
        lost = ~((fs >= w0) & (fs <= w0 + (FOOT_WINDOW - 1) * road.ds))
        first = np.argmax(bad_pt | lost, axis=1)   # the C stops at the first such point
        out = np.empty((cnt, 6))
        outside, singular = 0, []
        s_first, s_last = road.s0, road.s0 + (M - 1) * road.ds
        s_grid = road.s0 + road.ds * np.arange(M)
        for p in range(cnt):
            bx = boxes[:, p]
            lo, hi = bx[7] - road.ds, bx[8] + road.ds
            if i_ref[p] == 0 or i_ref[p] == M - 1:        # the reference point is not next to the road
                out[p] = neutral(road.s0)
                outside += 1
                continue
            if not bad_pt[p, first[p]] and lost[p, first[p]]:
                singular.append(divmod(p, self.n_opp))
                continue
            if (bad_pt[p].any() or not (lo >= s_first and hi <= s_last) or bx[6] > f.n_max or bx[5] < f.n_min):
                out[p] = neutral(road.s0)
                outside += 1
                continue
            kap = road.kappa[(s_grid >= lo) & (s_grid <= hi)]
            st, fac = stretch_factor(bx, kap)
            sag = obs.chord_sag_bound(f.spacing, float(bx[10]), float(bx[9]), kap, road.ds, f.reach)
            if st >= STRETCH_MAX or sag is None:
                singular.append(divmod(p, self.n_opp))
                continue
            pad = f.margin + SAG_SAFETY * sag
            out[p] = [bx[0], bx[1], bx[2], bx[3] + pad, bx[4] + pad, fac]
        return out.reshape(self.stages, self.n_opp * 6), outside, singular


def _fr_columns(fs: np.ndarray, fn: np.ndarray, fp: np.ndarray) -> np.ndarray:
    """(3, pairs * npt) columns of the box map's FR input: pair-major, each pair's (s, n, phi_gamma) per point."""
    return np.stack([fs.ravel(), fn.ravel(), fp.ravel()])
