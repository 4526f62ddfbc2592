"""Plot of one closed-loop run in both frames, like Fig. 1 of the paper, with what the safe profile is about.

The vehicles are drawn at a few instants only, the ego and every opponent at the same instants and in the same
colour (time), so a footprint of the ego meets only the opponents' footprints of its own time; the paths are lines.
Beside the Cartesian view (fitted to the road the run covers): the Frenet frame, speed and steering, |a_lat| against
its bound and the largest slack of each sample.

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
from ..dsl import Bounds
from ..extras import require
from .runlog import RunLog, summary

with require("plot", "a run's plot"):
    import matplotlib
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.cm import ScalarMappable
    from matplotlib.colors import Normalize
    from matplotlib.figure import Figure
    from matplotlib.patches import Polygon

__all__ = ["DEFAULT_EGO_DIMS", "plot_run", "project_to_road", "run_figure"]

#: Ego dimensions used when a log carries none (SPEC section 7, paper Table II).
DEFAULT_EGO_DIMS: dict[str, float] = {"l_f": 1.7, "l_r": 1.7, "l_r_ch": 2.0, "l_f_ch": 2.0, "w_ch": 1.9}

_EGO_COLOR = "tab:blue"
_OPP_COLORS = ("tab:red", "tab:orange", "tab:purple", "tab:brown", "tab:pink", "tab:olive")
_TIME_CMAP = "viridis"
INSTANTS = 6
"""Instants at which the vehicles are drawn (evenly spaced over the run, the last sample included)."""


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
    return np.concatenate([a + u * (b - a) for a, b in zip(corners, nxt, strict=True)])


def _instants(n: int, every: int | None, count: int = INSTANTS) -> list[int]:
    """State samples at which the vehicles are drawn: every ``every`` samples, or ``count`` evenly spaced; the last
    sample always included."""
    if every is not None:
        if every < 1:
            raise ValueError("every must be >= 1")
        idx = list(range(0, n, every))
    else:
        idx = sorted(set(np.linspace(0, n - 1, min(count, n)).round().astype(int).tolist()))
    if idx[-1] != n - 1:
        idx.append(n - 1)
    return idx


def _road_window(log: RunLog, margin: float = 30.0) -> NDArray[np.bool_]:
    """Road samples within ``margin`` of what the vehicles cover (all of them if fewer than two)."""
    s_all = [log.ego_frenet[:, 0]] + ([log.opp_frenet[:, :, 0].ravel()] if len(log.opponents) else [])
    s_cat = np.concatenate(s_all)
    s_cat = s_cat[np.isfinite(s_cat)]
    rs = np.asarray(log.road["s"])
    on = (rs >= s_cat.min() - margin) & (rs <= s_cat.max() + margin)
    return on if on.sum() >= 2 else np.ones_like(rs, dtype=bool)


def _road_bbox(log: RunLog, on: NDArray[np.bool_], pad: float) -> tuple[float, float, float, float]:
    """(x0, x1, y0, y1) of the road's centre line over ``on``, widened by ``pad`` (the road's half width)."""
    gx, gy = np.asarray(log.road["gamma_x"])[on], np.asarray(log.road["gamma_y"])[on]
    return float(gx.min()) - pad, float(gx.max()) + pad, float(gy.min()) - pad, float(gy.max()) + pad


def _footprint(ax, pts, t_col, edge: str, hit: bool = False, label: str | None = None) -> None:
    """One vehicle's footprint: filled with its instant's colour, edged with the vehicle's colour (black: collision)."""
    ax.add_patch(
        Polygon(pts, closed=True, fc=t_col, ec="k" if hit else edge, lw=2.2 if hit else 1.4, alpha=0.85, label=label)
    )


def _cartesian(ax, log: RunLog, on, n_bound, sel, colors, ego_c, opp_c) -> None:
    """The road, every vehicle's path, the footprints at the instants ``sel``; axes fitted to the road."""
    road = log.road
    gx, gy, ph = (np.asarray(road[k])[on] for k in ("gamma_x", "gamma_y", "phi_gamma"))
    ax.plot(gx, gy, color="0.5", lw=0.8, ls="--", label="centre line")
    if n_bound is not None:
        for sign in (1.0, -1.0):
            nb = sign * float(n_bound)
            ax.plot(
                gx - nb * np.sin(ph), gy + nb * np.cos(ph), color="k", lw=1.0, label="road bounds" if sign > 0 else None
            )
    ax.plot(log.ego_cartesian[:, 0], log.ego_cartesian[:, 1], color=_EGO_COLOR, lw=1.4, label="ego path")
    for i in range(len(log.opponents)):
        col = _OPP_COLORS[i % len(_OPP_COLORS)]
        ax.plot(
            log.opp_cartesian[:, i, 0], log.opp_cartesian[:, i, 1], color=col, lw=0.9, ls=":", label=f"opponent {i}"
        )
    for rank, k in enumerate(sel):
        for i in range(len(log.opponents)):
            _footprint(ax, opp_c[i][k], colors[rank], _OPP_COLORS[i % len(_OPP_COLORS)])
        _footprint(ax, ego_c[k], colors[rank], _EGO_COLOR, bool(log.collision[k]))
    x0, x1, y0, y1 = _road_bbox(log, on, float(n_bound) if n_bound is not None else 5.0)
    ax.set_xlim(x0, x1)
    ax.set_ylim(y0, y1)
    ax.set_aspect("equal", adjustable="box")
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    ax.set_title("Cartesian frame")
    ax.legend(loc="best", fontsize=7)
    ax.grid(True, lw=0.3)


def _frenet(ax, log: RunLog, on, n_bound, sel, colors, ego_c, opp_c) -> None:
    """The same in (s, n): the rectangles mapped by projection onto the centre line."""
    rs = np.asarray(log.road["s"])[on]
    ax.plot(rs, np.zeros_like(rs), color="0.5", lw=0.8, ls="--")
    if n_bound is not None:
        for sign in (1.0, -1.0):
            ax.axhline(sign * float(n_bound), color="k", lw=1.0)
    ax.plot(log.ego_frenet[:, 0], log.ego_frenet[:, 1], color=_EGO_COLOR, lw=1.4)
    for i in range(len(log.opponents)):
        ax.plot(
            log.opp_frenet[:, i, 0], log.opp_frenet[:, i, 1], color=_OPP_COLORS[i % len(_OPP_COLORS)], lw=0.9, ls=":"
        )
    for rank, k in enumerate(sel):
        for i in range(len(log.opponents)):
            sn = project_to_road(log.road, _outline(opp_c[i][k]), s_guess=float(log.opp_frenet[k, i, 0]))
            _footprint(ax, sn, colors[rank], _OPP_COLORS[i % len(_OPP_COLORS)])
        sn = project_to_road(log.road, _outline(ego_c[k]), s_guess=float(log.ego_frenet[k, 0]))
        _footprint(ax, sn, colors[rank], _EGO_COLOR, bool(log.collision[k]))
    ax.autoscale_view()
    ax.set_xlabel("s [m]")
    ax.set_ylabel("n [m]")
    ax.set_title("Frenet frame (rectangles projected onto the centre line)")
    ax.grid(True, lw=0.3)


def _speed(ax, log: RunLog) -> None:
    ax.plot(log.t, log.ego_frenet[:, 3], color=_EGO_COLOR, lw=1.2)
    ax.set_ylabel("v [m/s]", color=_EGO_COLOR)
    ax.grid(True, lw=0.3)
    ax_d = ax.twinx()
    ax_d.plot(log.t, log.ego_frenet[:, 4], color="tab:green", lw=1.2)
    ax_d.set_ylabel("delta [rad]", color="tab:green")


def _a_lat(ax, log: RunLog, bound: float) -> None:
    """|a_lat| of every state sample against the bound; the samples above it marked."""
    a = np.abs(log.a_lat)
    ax.plot(log.t, a, color="tab:purple", lw=1.2, label="|a_lat|")
    ax.axhline(bound, color="k", ls="--", lw=1.0, label=f"bound {bound:g}")
    over = a > bound
    if over.any():
        ax.fill_between(
            log.t, bound, a, where=over, color="tab:red", alpha=0.35, lw=0, label=f"above: {int(over.sum())} samples"
        )
    ax.set_ylabel("|a_lat| [m/s^2]")
    ax.legend(loc="upper right", fontsize=7)
    ax.grid(True, lw=0.3)


def _slack(ax, log: RunLog) -> None:
    """The largest soft-constraint slack of each control sample (0: every soft row held)."""
    ax.plot(log.t[:-1], log.max_slack, color="tab:brown", lw=1.2, drawstyle="steps-post")
    ax.set_ylabel("largest slack")
    ax.set_xlabel("t [s]")
    ax.grid(True, lw=0.3)


def run_figure(log: RunLog, every: int | None = None, a_lat_max: float | None = None) -> Figure:
    """The figure of one run (see the module): ``every``: draw the vehicles every ``every`` samples instead of at
    ``INSTANTS`` instants; ``a_lat_max``: the bound drawn (default: the log's meta, else ``Bounds().a_lat_max``)."""
    sel = _instants(log.n_states, every)
    bound = float(a_lat_max if a_lat_max is not None else log.meta.get("a_lat_max", Bounds().a_lat_max))
    n_bound = log.meta.get("n_bound", None)
    on = _road_window(log)
    x0, x1, y0, y1 = _road_bbox(log, on, float(n_bound) if n_bound is not None else 5.0)
    height = 10.0
    w_cart = float(np.clip((height - 1.0) * (x1 - x0) / max(y1 - y0, 1e-9), 3.0, 14.0))
    fig = Figure(figsize=(w_cart + 8.0, height), layout="constrained")
    FigureCanvasAgg(fig)
    gs = fig.add_gridspec(5, 2, width_ratios=[w_cart, 8.0], height_ratios=[2.6, 1.3, 1.3, 1.3, 0.25])
    ego_c = corners_from_dims(log.ego_cartesian, log.ego if log.ego is not None else DEFAULT_EGO_DIMS)
    opp_c = [corners_from_dims(log.opp_cartesian[:, i, :], o) for i, o in enumerate(log.opponents)]
    cmap = matplotlib.colormaps[_TIME_CMAP]
    t_sel = log.t[sel]
    norm = Normalize(float(log.t[0]), float(max(log.t[-1], log.t[0] + 1e-9)))
    colors = [cmap(norm(t)) for t in t_sel]
    _cartesian(fig.add_subplot(gs[:4, 0]), log, on, n_bound, sel, colors, ego_c, opp_c)
    _frenet(fig.add_subplot(gs[0, 1]), log, on, n_bound, sel, colors, ego_c, opp_c)
    ax_v = fig.add_subplot(gs[1, 1])
    _speed(ax_v, log)
    _a_lat(fig.add_subplot(gs[2, 1], sharex=ax_v), log, bound)
    _slack(fig.add_subplot(gs[3, 1], sharex=ax_v), log)
    cb = fig.colorbar(ScalarMappable(norm, cmap), cax=fig.add_subplot(gs[4, :]), orientation="horizontal")
    cb.set_label(
        f"t [s] of the footprints (at {', '.join(f'{t:g}' for t in t_sel)} s; edge: the vehicle, black: a collision)"
    )
    m, st = log.meta, summary(log)
    fig.suptitle(
        f"{m.get('scenario', '?')} / {m.get('formulation', '?')} / {m.get('obstacle_model', '?')} "
        f"({m.get('controller', '?')}, seed {m.get('seed', '?')}): progress {st['progress']:.1f} m, "
        f"{st['n_collision_samples']} collision samples, largest |a_lat| {st['max_abs_a_lat']:.2f} m/s^2"
    )
    return fig


def plot_run(
    log: RunLog, path: str | PathLike[str], every: int | None = None, dpi: int = 120, a_lat_max: float | None = None
) -> Path:
    """Write :func:`run_figure` of ``log`` to ``path`` (PNG, SVG, ... by its suffix); returns the path."""
    path = Path(path)
    run_figure(log, every, a_lat_max).savefig(path, dpi=dpi)
    return path
