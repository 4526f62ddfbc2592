"""An animation of a run on the scenario's lanelet network (GIF through Pillow, MP4 through ffmpeg): per frame the ego
and the obstacles present at that sample, the ego's path so far."""

from __future__ import annotations

import shutil
from pathlib import Path

import numpy as np

from ..extras import require
from .plot import draw_background, polygon, scene_at, view_limits

#: the animation formats and what writes them
WRITERS = {".gif": "pillow", ".mp4": "ffmpeg"}


def frame_samples(samples: int, every: int) -> list[int]:
    """The run's samples drawn as frames: every ``every``-th, the last one always included."""
    if every < 1:
        raise ValueError(f"animation: every = {every} is invalid (an integer >= 1)")
    ks = list(range(0, samples, every))
    return ks if ks and ks[-1] == samples - 1 else [*ks, samples - 1]


def animate_run(sc, ego_centres: np.ndarray, path: str | Path, every: int = 1) -> Path:
    """Write ``path`` (.gif or .mp4): one frame per ``every`` samples, in real time (frame rate 1 / (every dt))."""
    out = Path(path)
    writer = WRITERS.get(out.suffix.lower())
    if writer is None:
        raise ValueError(f"animation: {out.name!r} has no known format (allowed: {', '.join(WRITERS)})")
    if writer == "ffmpeg" and shutil.which("ffmpeg") is None:
        raise ValueError(f"animation: {out.name!r} needs ffmpeg on PATH (or write a .gif)")
    with require("commonroad", "a CommonRoad run's animation"):
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
        from matplotlib.animation import FuncAnimation

    c = np.asarray(ego_centres, dtype=float)
    ks = frame_samples(len(c), every)
    fig, ax = plt.subplots(figsize=(10, 4))
    draw_background(ax, sc, view_limits(c))
    (trail,) = ax.plot([], [], "r-", lw=1.0, zorder=39)
    drawn: list = []

    def frame(k: int):
        for p in drawn:
            p.remove()
        drawn.clear()
        for who, corners in scene_at(sc, c, k):
            ego = who == "ego"
            drawn.append(ax.add_patch(polygon(corners, "red" if ego else "tab:blue", 0.8 if ego else 0.5, 40)))
        trail.set_data(c[: k + 1, 0], c[: k + 1, 1])
        ax.set_title(f"{sc.name}: t = {k * sc.dt:.1f} s")
        return [*drawn, trail]

    anim = FuncAnimation(fig, frame, frames=ks, blit=False)
    out.parent.mkdir(parents=True, exist_ok=True)
    anim.save(out, writer=writer, fps=max(1.0, 1.0 / (every * sc.dt)), dpi=90)
    plt.close(fig)
    return out
