"""Plot of one closed-loop run in both frames, like Fig. 1 of the paper.

Uses matplotlib's object API with the Agg canvas directly (no pyplot, no global backend switch), so it
works headless and does not disturb an interactive session.
"""

from __future__ import annotations

from collections.abc import Mapping
from os import PathLike
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ..collision import corners_from_dims
from ..extras import require
from .runlog import RunLog, summary

with require("plot", "a run's plot"):
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure
    from matplotlib.patches import Polygon

__all__ = ["DEFAULT_EGO_DIMS", "plot_run", "project_to_road"]

#: Ego dimensions used when a log carries none (SPEC section 7, paper Table II).
DEFAULT_EGO_DIMS: dict[str, float] = {"l_f": 1.7, "l_r": 1.7, "l_r_ch": 2.0, "l_f_ch": 2.0, "w_ch": 1.9}

_EGO_COLOR = "tab:blue"
_OPP_COLORS = ("tab:red", "tab:orange", "tab:purple", "tab:brown", "tab:pink", "tab:olive")


def project_to_road(
    road: Mapping[str, Any], points: NDArray[np.float64], s_guess: float | None = None, window: float = 60.0
) -> NDArray[np.float64]:
    """Approximate Frenet ``(s, n)`` of Cartesian points ``(P, 2)``: nearest road sample + local linear projection.

    Good enough for plotting (error of order ``ds^2 kappa``), not the Newton projection the solver uses.
    With ``s_guess`` only road samples within ``window`` metres of it are searched, so that a road
    passing close to itself does not capture the points.
    """
    s = np.asarray(road["s"], dtype=float)
    gx = np.asarray(road["gamma_x"], dtype=float)
    gy = np.asarray(road["gamma_y"], dtype=float)
    ph = np.asarray(road["phi_gamma"], dtype=float)
    idx = np.arange(s.size)
    if s_guess is not None:
        near = np.abs(s - s_guess) <= window
        if near.any():
            idx = idx[near]
    pts = np.asarray(points, dtype=float).reshape(-1, 2)
    d2 = (pts[:, None, 0] - gx[None, idx]) ** 2 + (pts[:, None, 1] - gy[None, idx]) ** 2
    j = idx[np.argmin(d2, axis=1)]
    dx, dy = pts[:, 0] - gx[j], pts[:, 1] - gy[j]
    c, sn = np.cos(ph[j]), np.sin(ph[j])
    return np.stack([s[j] + dx * c + dy * sn, -dx * sn + dy * c], axis=-1)


def _outline(corners: NDArray[np.float64], per_edge: int = 8) -> NDArray[np.float64]:
    """Points along the boundary of a polygon (so that its deformation in the Frenet frame shows)."""
    u = np.linspace(0.0, 1.0, per_edge, endpoint=False)[:, None]
    nxt = np.roll(corners, -1, axis=0)
    return np.concatenate([a + u * (b - a) for a, b in zip(corners, nxt)])


def _sample_indices(n: int, every: int) -> list[int]:
    idx = list(range(0, n, every))
    if idx[-1] != n - 1:
        idx.append(n - 1)
    return idx


def plot_run(log: RunLog, path: str | PathLike[str], every: int = 10, dpi: int = 120) -> Path:
    """Write a figure of one run: Cartesian frame (top), Frenet frame (middle), speed and steering (bottom).

    Chassis rectangles of the ego and every opponent are drawn every ``every`` state samples (and at the
    last one), fading in with time; ego rectangles of samples flagged as collisions get a black edge.
    Road bounds ``+-meta["n_bound"]`` are drawn when the log has them. Returns the written path.
    """
    if every < 1:
        raise ValueError("every must be >= 1")
    path = Path(path)
    road = log.road
    ego_dims = log.ego if log.ego is not None else DEFAULT_EGO_DIMS
    n_bound = log.meta.get("n_bound", None)
    k1 = log.n_states
    sel = _sample_indices(k1, every)
    n_opp = len(log.opponents)

    # s range that matters: everything the vehicles cover, plus their length
    s_all = [log.ego_frenet[:, 0]]
    if n_opp:
        s_all.append(log.opp_frenet[:, :, 0].ravel())
    s_cat = np.concatenate(s_all)
    s_cat = s_cat[np.isfinite(s_cat)]
    margin = 30.0
    s_lo, s_hi = float(s_cat.min()) - margin, float(s_cat.max()) + margin
    rs = road["s"]
    on = (rs >= s_lo) & (rs <= s_hi)
    if on.sum() < 2:
        on = np.ones_like(rs, dtype=bool)
    gx, gy, ph = road["gamma_x"][on], road["gamma_y"][on], road["phi_gamma"][on]

    # Cartesian panel height follows the data's aspect ratio (equal axes), within limits
    nb_pad = float(n_bound) if n_bound is not None else 5.0
    xr = float(np.ptp(gx)) + 2 * nb_pad
    yr = float(np.ptp(gy)) + 2 * nb_pad
    width = 11.0
    h_cart = float(np.clip(0.9 * width * yr / max(xr, 1e-9), 2.5, 8.0))
    h_fren, h_time = 3.2, 2.0
    fig = Figure(figsize=(width, h_cart + h_fren + h_time + 1.0), layout="constrained")
    FigureCanvasAgg(fig)
    gs = fig.add_gridspec(3, 1, height_ratios=[h_cart, h_fren, h_time])
    ax_c = fig.add_subplot(gs[0])
    ax_f = fig.add_subplot(gs[1])
    ax_t = fig.add_subplot(gs[2])

    # ---- Cartesian frame
    ax_c.plot(gx, gy, color="0.4", lw=1.0, ls="--", label="centre line")
    if n_bound is not None:
        nb = float(n_bound)
        for sign in (1.0, -1.0):
            ax_c.plot(
                gx - sign * nb * np.sin(ph),
                gy + sign * nb * np.cos(ph),
                color="k",
                lw=1.2,
                label="road bounds" if sign > 0 else None,
            )
    ax_c.plot(log.ego_cartesian[:, 0], log.ego_cartesian[:, 1], color=_EGO_COLOR, lw=1.5, label="ego path (rear axle)")

    ego_corners = corners_from_dims(log.ego_cartesian, ego_dims)  # (K+1, 4, 2)
    opp_corners = [corners_from_dims(log.opp_cartesian[:, i, :], log.opponents[i]) for i in range(n_opp)]
    for rank, k in enumerate(sel):
        alpha = 0.25 + 0.75 * rank / max(len(sel) - 1, 1)
        hit = bool(log.collision[k])
        ax_c.add_patch(
            Polygon(
                ego_corners[k],
                closed=True,
                fc=_EGO_COLOR,
                ec="k" if hit else _EGO_COLOR,
                lw=2.0 if hit else 0.8,
                alpha=alpha,
                label="ego" if rank == 0 else None,
            )
        )
        for i in range(n_opp):
            col = _OPP_COLORS[i % len(_OPP_COLORS)]
            ax_c.add_patch(
                Polygon(
                    opp_corners[i][k],
                    closed=True,
                    fc=col,
                    ec=col,
                    lw=0.8,
                    alpha=alpha,
                    label=f"opponent {i}" if rank == 0 else None,
                )
            )
    ax_c.set_aspect("equal", adjustable="datalim")
    ax_c.autoscale_view()
    ax_c.set_xlabel("x [m]")
    ax_c.set_ylabel("y [m]")
    dt = log.meta.get("dt")
    step = f"every {every * dt:g} s" if isinstance(dt, (int, float)) else f"every {every} samples"
    ax_c.set_title(f"Cartesian frame (chassis {step}, fading in with time)")
    ax_c.legend(loc="best", fontsize=8)
    ax_c.grid(True, lw=0.3)

    # ---- Frenet frame
    rs_on = rs[on]
    ax_f.plot(rs_on, np.zeros_like(rs_on), color="0.4", lw=1.0, ls="--")
    if n_bound is not None:
        for sign in (1.0, -1.0):
            ax_f.axhline(sign * float(n_bound), color="k", lw=1.2)
    ax_f.plot(log.ego_frenet[:, 0], log.ego_frenet[:, 1], color=_EGO_COLOR, lw=1.5)
    for i in range(n_opp):
        ax_f.plot(
            log.opp_frenet[:, i, 0], log.opp_frenet[:, i, 1], color=_OPP_COLORS[i % len(_OPP_COLORS)], lw=0.8, ls=":"
        )
    for rank, k in enumerate(sel):
        alpha = 0.25 + 0.75 * rank / max(len(sel) - 1, 1)
        hit = bool(log.collision[k])
        sn = project_to_road(road, _outline(ego_corners[k]), s_guess=float(log.ego_frenet[k, 0]))
        ax_f.add_patch(
            Polygon(sn, closed=True, fc=_EGO_COLOR, ec="k" if hit else _EGO_COLOR, lw=2.0 if hit else 0.8, alpha=alpha)
        )
        for i in range(n_opp):
            col = _OPP_COLORS[i % len(_OPP_COLORS)]
            sn = project_to_road(road, _outline(opp_corners[i][k]), s_guess=float(log.opp_frenet[k, i, 0]))
            ax_f.add_patch(Polygon(sn, closed=True, fc=col, ec=col, lw=0.8, alpha=alpha))
    ax_f.autoscale_view()
    ax_f.set_xlabel("s [m]")
    ax_f.set_ylabel("n [m]")
    ax_f.set_title("Frenet frame (rectangles mapped by projection onto the centre line)")
    ax_f.grid(True, lw=0.3)

    # ---- speed and steering over time
    ax_t.plot(log.t, log.ego_frenet[:, 3], color=_EGO_COLOR, lw=1.3, label="v")
    ax_t.set_xlabel("t [s]")
    ax_t.set_ylabel("v [m/s]", color=_EGO_COLOR)
    ax_t.grid(True, lw=0.3)
    ax_d = ax_t.twinx()
    ax_d.plot(log.t, log.ego_frenet[:, 4], color="tab:green", lw=1.3, label="delta")
    ax_d.set_ylabel("delta [rad]", color="tab:green")

    m = log.meta
    st = summary(log)
    fig.suptitle(
        f"{m.get('scenario', '?')} / {m.get('formulation', '?')} / {m.get('obstacle_model', '?')} "
        f"({m.get('controller', '?')}, seed {m.get('seed', '?')}): progress {st['progress']:.1f} m, "
        f"{st['n_collision_samples']} collision samples"
    )
    fig.savefig(path, dpi=dpi)
    return path
