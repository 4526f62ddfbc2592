"""A picture of a run on the scenario's lanelet network: CommonRoad's own renderer draws the lanes and the planning
problem's goal region; ours the ego's path coloured by time, the obstacles and the ego at a few moments (same colour),
fcgen's reference path and its drivable band."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ..collision import chassis_corners
from ..extras import require

#: the colour map of time (the ego's path, the moments, the animation's trail)
TIME_CMAP = "viridis"


def centred_corners(pose, length: float, width: float) -> np.ndarray:
    """The (4, 2) corners of a ``length`` x ``width`` rectangle centred on ``pose`` = (x, y, phi)."""
    x, y, phi = (float(v) for v in pose)
    return chassis_corners(x, y, phi, 0.0, 0.5 * length, 0.5 * length, width)


def scene_at(sc, ego_centres: np.ndarray, k: int) -> list[tuple[str, np.ndarray]]:
    """What is on the road at sample ``k`` of the run: ``("ego", corners)`` and ``("obstacle <id>", corners)`` for
    every recorded obstacle present then."""
    out = [("ego", centred_corners(ego_centres[k], sc.ego_length, sc.ego_width))]
    step = sc.first_step + k
    for ob in sc.obstacles:
        if ob.present(step):
            out.append((f"obstacle {ob.id}", centred_corners(ob.pose(step), ob.length, ob.width)))
    return out


def view_limits(ego_centres: np.ndarray, pad: float = 40.0) -> list[float]:
    """x_min, x_max, y_min, y_max: the ego's path with ``pad`` metres around it."""
    c = np.asarray(ego_centres, dtype=float)
    return [
        float(c[:, 0].min() - pad),
        float(c[:, 0].max() + pad),
        float(c[:, 1].min() - pad),
        float(c[:, 1].max() + pad),
    ]


def draw_background(ax, sc, lim: list[float]) -> None:
    """The lanelets and the goal region (CommonRoad's renderer), fcgen's reference path and drivable band."""
    with require("commonroad", "a CommonRoad run's figure"):
        from commonroad.visualization.mp_renderer import MPRenderer

    rnd = MPRenderer(ax=ax, plot_limits=lim)
    sc.scenario.lanelet_network.draw(rnd)
    if sc.planning_problem is not None:
        sc.planning_problem.draw(rnd)
    rnd.render()
    ax.plot(sc.road.gx, sc.road.gy, "k--", lw=0.6, zorder=35, label="fcgen's reference path")
    for edge, lab in ((sc.road.n_min, "drivable band"), (sc.road.n_max, None)):
        ex, ey, _ = sc.road.to_cartesian(sc.road.s, edge, np.zeros_like(edge))
        ax.plot(ex, ey, "b-", lw=0.8, zorder=35, label=lab)
    ax.set_xlim(lim[0], lim[1])
    ax.set_ylim(lim[2], lim[3])
    ax.set_aspect("equal")


def polygon(corners: np.ndarray, colour, alpha: float, zorder: int):
    """A matplotlib patch of a footprint."""
    with require("plot", "a CommonRoad run's figure"):
        import matplotlib.patches as mp

    return mp.Polygon(corners, closed=True, facecolor=colour, edgecolor="k", lw=0.5, alpha=alpha, zorder=zorder)


def plot_run(sc, ego_centres: np.ndarray, path: str | Path, moments: int = 4) -> Path:
    """Write the PNG ``path``: the network, the goal, the ego's path (colour: time), the obstacles and the ego at
    ``moments`` evenly spaced samples."""
    with require("commonroad", "a CommonRoad run's figure"):
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt

    c = np.asarray(ego_centres, dtype=float)
    fig, ax = plt.subplots(figsize=(12, 4.5))
    draw_background(ax, sc, view_limits(c))
    cmap = plt.get_cmap(TIME_CMAP)
    t = np.arange(len(c)) * sc.dt
    path_pts = ax.scatter(c[:, 0], c[:, 1], c=t, cmap=cmap, s=4, zorder=39, label="ego (chassis centre)")
    fig.colorbar(path_pts, ax=ax, label="time [s]", fraction=0.03, pad=0.01)
    steps = np.linspace(0, len(c) - 1, moments).round().astype(int)
    for j in steps:
        colour = cmap(t[j] / max(t[-1], 1e-9))
        for who, corners in scene_at(sc, c, int(j)):
            ego = who == "ego"
            ax.add_patch(polygon(corners, "red" if ego else colour, 0.8 if ego else 0.35, 40 if ego else 30))
        ax.annotate(
            f"{t[j]:.1f} s", (c[j, 0], c[j, 1]), xytext=(0, 8), textcoords="offset points", fontsize=7, zorder=41
        )
    ax.set_title(f"{sc.name}: {len(c) - 1} samples of {sc.dt} s; obstacles at the ego's moments (colour: time)")
    ax.legend(loc="upper right", fontsize=8)
    out = Path(path)
    out.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(out, dpi=130, bbox_inches="tight")
    plt.close(fig)
    return out
