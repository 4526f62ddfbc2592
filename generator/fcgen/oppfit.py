"""The conventional formulation's opponent fit, run by the solver's prepare phase (C and Python alike).

Per stage and opponent, from its Cartesian pose ``[x, y, phi]`` and the road given to ``set_road``:

1. ``opp_points`` (CasADi): points on the true chassis rectangle (edges, centre, edge mid-points, rear and front
   centres; ``obstacles.fit_frenet_shape``'s set) and each point's offset ``d`` along the heading from the reference
   point (the chassis centre; for ``overapprox="none"`` the one point is the rear axle).
2. Search (C loop / numpy): the road sample nearest to the reference point over the whole road; for every point the
   nearest sample within ``SEARCH`` samples of ``i_ref + round(d / ds)``.
3. ``opp_foot`` (CasADi): ``NEWTON_STEPS`` Newton steps on the road interpolant (the three samples around that sample,
   the stage functions' formula), from that sample: the foot point ``s``, the offset ``n`` and ``phi_gamma(s)``.
4. ``opp_box`` (CasADi): the box fitted around the mapped points (chord-sag padding, margin) and the ``n``/``s``
   range the ego can reach next to it; then (C loop / numpy) the extreme curvatures of the road samples in that
   ``s`` range and the ego's sign-aware stretch factor ``f = 1 / (1 - max(0, n kappa))``.

An opponent is *outside the road* at a stage when the reference point's nearest sample is the road's first or last
one, a point's nearest sample has no sample on either side, the ``s`` range of step 4 (plus one ``ds``) is not
inside the road, or its box plus the ego's reach lies beside the band ``[n_min, n_max]``: it is left out
(``neutral`` parameters, a box 1000 m behind the road) and counted in the status (``opp_outside``). A stretch
``max(n kappa) >= STRETCH_MAX`` (the Frenet frame is singular next to the opponent), or a foot point that the
Newton steps leave outside its three-sample window (the nearest sample was not next to it: the point cannot be
mapped), fails the prepare phase with ``ERR_OPP_FRENET``. Also the ``s`` and ``phi_gamma`` of ``overapprox="none"``
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
from .road import _hermite, window_segment

SEARCH = 4            # samples searched on either side of a point's guessed nearest sample
FOOT_WINDOW = 3       # road samples of a point's Newton window: its nearest sample and one on either side
NEWTON_STEPS = 4      # fixed Newton steps of the foot-point iteration (3 already reach 1e-13 m on the test roads)
STRETCH_MAX = 0.9     # |n| kappa allowed next to an opponent (obstacles.fit_frenet_shape's bound)
BOX = ("c_s", "c_n", "angle", "L", "W", "n_hi", "n_lo", "s_lo", "s_hi")


def edge_counts(opp_l: float, opp_w: float, points_per_metre: float) -> list[int]:
    """Points per rectangle edge (corner order of ``obstacles.vertices``: width, length, width, length)."""
    return [max(2, int(math.ceil(e * points_per_metre))) for e in (opp_w, opp_l, opp_w, opp_l)]


@dataclass(frozen=True)
class OppFit:
    """The fit's CasADi functions and constants for one problem (``None`` for a non-conventional one)."""

    points: ca.Function     # (pose[3]) -> (P[2 x npt], d[npt])
    foot: ca.Function       # (pt[2], win[window_size]) -> (fr[3]: s, n, phi_gamma)
    box: ca.Function        # (FR[3 x npt], pose[3]) -> (box[9]: BOX)
    npt: int
    ref_point: int          # index of the reference point of the global search
    n_min: float            # the ego's lateral band (state bounds on n)
    n_max: float

    @property
    def window_size(self) -> int:
        return 2 + 6 * FOOT_WINDOW


def _foot_road(s, win):
    """The road interpolant (road.py's formula) at s on a point's window [s_w0, ds, kappa, phi, gx, gy, cos phi,
    sin phi] (the node slopes precomputed once per road sample): kappa, phi_gamma, gamma, gamma'."""
    ds = win[1]
    tau, ends = window_segment(s, win, FOOT_WINDOW, 6)
    (k0, k1), (p0, p1), (x0, x1), (y0, y1), (c0, c1), (s0, s1) = ends
    phi, _ = _hermite(tau, ds, p0, p1, k0, k1)
    gx, dgx = _hermite(tau, ds, x0, x1, c0, c1)
    gy, dgy = _hermite(tau, ds, y0, y1, s0, s1)
    return (1 - tau) * k0 + tau * k1, phi, gx, gy, dgx, dgy


def foot_window(road, i0: np.ndarray, cphi: np.ndarray, sphi: np.ndarray) -> np.ndarray:
    """Windows (len(i0), window_size) of FOOT_WINDOW samples from i0 (the C packs the same values)."""
    idx = i0[:, None] + np.arange(FOOT_WINDOW)
    return np.concatenate([(road.s0 + i0 * road.ds)[:, None], np.full((i0.size, 1), road.ds), road.kappa[idx],
                           road.phi[idx], road.gx[idx], road.gy[idx], cphi[idx], sphi[idx]], axis=1)


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
        ref = 0
    else:
        sh = obs.chassis_shape(x, y, phi, opp)
        corners = obs.vertices(sh)
        counts = edge_counts(opp.l_ch, opp.w_ch, form.points_per_metre)
        pts, mids = [], []
        for i in range(4):
            (ax, ay), (bx, by) = corners[i], corners[(i + 1) % 4]
            ts = np.linspace(0.0, 1.0, counts[i] + 1)
            pts += [(ax + t * (bx - ax), ay + t * (by - ay)) for t in ts[:-1]]
            mids += [(ax + t * (bx - ax), ay + t * (by - ay)) for t in 0.5 * (ts[:-1] + ts[1:])]
        ref = len(pts)
        ends = [(sh.cx - sh.L * c, sh.cy - sh.L * s), (sh.cx + sh.L * c, sh.cy + sh.L * s)]
        allp = pts + [(sh.cx, sh.cy)] + mids + ends
        P = ca.horzcat(*[ca.vertcat(px, py) for px, py in allp])
        d = ca.vertcat(*[(px - sh.cx) * c + (py - sh.cy) * s for px, py in allp])
    npt = P.shape[1]
    points = ca.Function("opp_points", [pose], [P, d], ["pose"], ["P", "d"])

    # -- foot point: fixed Newton steps on the interpolant of a three-sample window, from its centre sample
    pt = ca.SX.sym("pt", 2)
    win = ca.SX.sym("win", 2 + 6 * FOOT_WINDOW)
    sv = win[0] + (FOOT_WINDOW // 2) * win[1]
    for _ in range(NEWTON_STEPS):
        kappa, phg, gx, gy, dx, dy = _foot_road(sv, win)
        cg, sg = ca.cos(phg), ca.sin(phg)
        ex, ey = gx - pt[0], gy - pt[1]
        g = ex * cg + ey * sg
        dg = dx * cg + dy * sg + kappa * (-ex * sg + ey * cg)
        sv = sv - ca.if_else(dg > 0.05, g / dg, g)
    _, phg, gx, gy, _, _ = _foot_road(sv, win)
    n = -(pt[0] - gx) * ca.sin(phg) + (pt[1] - gy) * ca.cos(phg)
    foot = ca.Function("opp_foot", [pt, win], [ca.vertcat(sv, n, phg)], ["pt", "win"], ["fr"])

    # -- the box around the mapped points
    FR = ca.SX.sym("FR", 3, npt)
    reach = ego.l + ego.l_ch + ego.w_ch
    if form.overapprox == "none":
        sh = obs.chassis_shape(FR[0, 0], FR[1, 0], pose[2] - FR[2, 0], opp)
        out = [sh.cx, sh.cy, sh.angle, sh.L, sh.W, 0.0, 0.0, FR[0, 0], FR[0, 0]]
    else:
        n_edge = ref
        fs, fn = FR[0, :].T, FR[1, :].T
        es, en = fs[:n_edge], fn[:n_edge]
        ms, mn = fs[n_edge + 1:npt - 2], fn[n_edge + 1:npt - 2]
        nxt = list(range(1, n_edge)) + [0]
        cs, cn = 0.5 * (es + es[nxt]), 0.5 * (en + en[nxt])
        sag = ca.mmax(ca.sqrt((ms - cs) ** 2 + (mn - cn) ** 2))
        margin = form.margin + 2.0 * sag
        rs, rn, qs, qn = fs[npt - 2], fn[npt - 2], fs[npt - 1], fn[npt - 1]
        angle = ca.atan2(qn - rn, qs - rs)
        axs, axn = ca.cos(angle), ca.sin(angle)
        bs, bn = fs[:n_edge + 1], fn[:n_edge + 1]
        a = bs * axs + bn * axn
        b = -bs * axn + bn * axs
        a_hi, a_lo, b_hi, b_lo = ca.mmax(a), ca.mmin(a), ca.mmax(b), ca.mmin(b)
        L = 0.5 * (a_hi - a_lo) + margin
        W = 0.5 * (b_hi - b_lo) + margin
        ca_, cb = 0.5 * (a_hi + a_lo), 0.5 * (b_hi + b_lo)
        out = [ca_ * axs - cb * axn, ca_ * axn + cb * axs, angle, L, W, ca.mmax(bn) + reach, ca.mmin(bn) - reach,
               ca.mmin(bs) - reach, ca.mmax(bs) + reach]
    box = ca.Function("opp_box", [FR, pose], [ca.vertcat(*out)], ["FR", "pose"], ["box"])
    return OppFit(points, foot, box, npt, ref, problem.bounds.n_min, problem.bounds.n_max)


def neutral(s0: float) -> np.ndarray:
    """Parameters of an opponent left out: a unit box 1000 m behind the road's first sample, no stretch."""
    return np.array([s0 - 1000.0, 0.0, 0.0, 1.0, 1.0, 1.0])


def stretch_factor(box: np.ndarray, kap: np.ndarray) -> tuple[float, float]:
    """(max(0, n kappa) over the box's n range and the curvature samples, 1 / (1 - it)); the C computes the same."""
    kmax, kmin = float(np.max(kap)), float(np.min(kap))
    n_hi, n_lo = float(box[5]), float(box[6])
    st = max(0.0, n_hi * kmax, n_hi * kmin, n_lo * kmax, n_lo * kmin)
    return st, 1.0 / (1.0 - st)


class OppFitter:
    """The Python reference's fit of all stages and opponents at once (numpy search, mapped CasADi functions)."""

    def __init__(self, fit: OppFit, stages: int, n_opp: int):
        self.fit = fit
        self.stages, self.n_opp = stages, n_opp
        cnt = stages * n_opp
        self._points = fit.points.map(cnt)
        self._foot = fit.foot.map(cnt * fit.npt)
        self._box = fit.box.map(cnt)

    def __call__(self, road, poses: np.ndarray) -> tuple[np.ndarray, int, list[tuple[int, int]]]:
        """Fitted parameters (stages, n_opp * 6), the count left out, the (stage, opponent) pairs that cannot be
        mapped (a foot point outside its window, or a stretch >= STRETCH_MAX), in stage-major order.

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
        # Newton windows (clamped where a point is bad: computed, then discarded)
        i0 = np.clip(ist - half, 0, M - FOOT_WINDOW).ravel()
        # libm's cos and sin (math.cos, as the C calls them), once per road sample
        cphi = np.array([math.cos(v) for v in road.phi])
        sphi = np.array([math.sin(v) for v in road.phi])
        W = foot_window(road, i0, cphi, sphi)
        pts = P.reshape(2, -1)
        fr = np.array(self._foot(pts, W.T))                    # (3, cnt * npt)
        boxes = np.array(self._box(fr, pz.T))                  # fr's columns: pair-major, as the map wants
        # a foot outside its window: the nearest sample was not next to it (the point cannot be mapped)
        sf = fr[0].reshape(cnt, npt)
        w0 = W[:, 0].reshape(cnt, npt)
        lost = ~((sf >= w0) & (sf <= w0 + (FOOT_WINDOW - 1) * road.ds))
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
            sel = (s_grid >= lo) & (s_grid <= hi)
            st, fac = stretch_factor(bx, road.kappa[sel])
            if st >= STRETCH_MAX:
                singular.append(divmod(p, self.n_opp))
            out[p] = [bx[0], bx[1], bx[2], bx[3], bx[4], fac]
        return out.reshape(self.stages, self.n_opp * 6), outside, singular
