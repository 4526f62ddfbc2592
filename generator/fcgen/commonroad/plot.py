"""A picture of a run on the scenario's lanelet network: CommonRoad's own renderer draws the lanes; ours the obstacles
and the ego at a few moments (colour), the ego's path, fcgen's reference path and its drivable band."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ..extras import require


def plot_run(sc, ego_centres: np.ndarray, path: str | Path, moments: int = 4) -> Path:
    """Write the PNG ``path``: the network, the obstacles and the ego at ``moments`` evenly spaced samples."""
    with require("commonroad", "a CommonRoad run's figure"):
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
        from commonroad.visualization.mp_renderer import MPRenderer

    c = np.asarray(ego_centres, dtype=float)
    pad = 40.0
    lim = [
        float(c[:, 0].min() - pad),
        float(c[:, 0].max() + pad),
        float(c[:, 1].min() - pad),
        float(c[:, 1].max() + pad),
    ]
    fig, ax = plt.subplots(figsize=(12, 4.5))
    rnd = MPRenderer(ax=ax, plot_limits=lim)
    sc.scenario.lanelet_network.draw(rnd)
    rnd.render()
    steps = np.linspace(0, len(c) - 1, moments).round().astype(int)
    colours = plt.cm.viridis(np.linspace(0.15, 0.85, moments))
    for k, j in enumerate(steps):
        for ob in sc.obstacles:
            p = ob.pose(sc.first_step + j) if ob.present(sc.first_step + j) else None
            if p is not None:
                ax.add_patch(_rect(p, ob.length, ob.width, colours[k], 0.35, zorder=30))
        ax.add_patch(_rect(c[j], sc.ego_length, sc.ego_width, "red", 0.8, zorder=40))
        ax.annotate(
            f"{j * sc.dt:.1f} s",
            (c[j, 0], c[j, 1]),
            xytext=(0, 8),
            textcoords="offset points",
            fontsize=7,
            color="red",
            zorder=41,
        )
    ax.plot(sc.road.gx, sc.road.gy, "k--", lw=0.6, zorder=35, label="fcgen's reference path")
    for edge, lab in ((sc.road.n_min, "drivable band"), (sc.road.n_max, None)):
        ex, ey, _ = sc.road.to_cartesian(sc.road.s, edge, np.zeros_like(edge))
        ax.plot(ex, ey, "b-", lw=0.8, zorder=35, label=lab)
    ax.plot(c[:, 0], c[:, 1], "r-", lw=1.2, zorder=39, label="ego (chassis centre)")
    ax.set_xlim(lim[0], lim[1])
    ax.set_ylim(lim[2], lim[3])
    ax.set_aspect("equal")
    ax.set_title(f"{sc.name}: {len(c) - 1} samples of {sc.dt} s; obstacles at the ego's moments (colour)")
    ax.legend(loc="upper right", fontsize=8)
    out = Path(path)
    out.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(out, dpi=130, bbox_inches="tight")
    plt.close(fig)
    return out


def _rect(pose, length, width, colour, alpha, zorder):
    with require("plot", "a CommonRoad run's figure"):
        import matplotlib.patches as mp

    x, y, phi = pose
    cs, sn = np.cos(phi), np.sin(phi)
    corners = np.array(
        [[-length / 2, -width / 2], [length / 2, -width / 2], [length / 2, width / 2], [-length / 2, width / 2]]
    )
    rot = corners @ np.array([[cs, sn], [-sn, cs]]) + np.array([x, y])
    return mp.Polygon(rot, closed=True, facecolor=colour, edgecolor="k", lw=0.5, alpha=alpha, zorder=zorder)
