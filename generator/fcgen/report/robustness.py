"""The report's robustness section (rows of ``fcgen campaign --robustness``): per configuration and perturbation
cell the colliding runs by responsibility, the plant's a_lat above its bound + 0.5, progress, QP statuses, plan-check
and guard reactions, and the magnitude where each axis first breaks."""

from __future__ import annotations

import json

from ..campaign.robustness import Cell, cells
from ..extras import require

with require("campaign", "the campaign's report"):
    import pandas as pd

#: a cell breaks a configuration when the ego causes a collision or the plant's |a_lat| exceeds its bound + 0.5 in
#: more than this share of the samples
A_LAT_SHARE = 0.001


def suffix(cell: Cell) -> str:
    """The end of a configuration key that a cell appends (``campaign.grid.Config.key``)."""
    if cell.spec.is_default:
        return "" if not cell.delay else f"/comp{cell.delay}"
    return f"/{cell.spec.label()}" + (f"/comp{cell.delay}" if cell.delay else "")


def split_keys(df: pd.DataFrame) -> pd.DataFrame:
    """``df`` with ``base`` (the configuration without its perturbation), ``axis`` and ``magnitude`` per row."""
    known = sorted(((suffix(c), c) for c in cells()), key=lambda t: -len(t[0]))
    base, axis, mag = [], [], []
    for key in df["config"]:
        sfx, cell = next((s, c) for s, c in known if key.endswith(s))  # "" (unperturbed) matches last
        base.append(key[: len(key) - len(sfx)] if sfx else key)
        axis.append(cell.axis)
        mag.append(cell.magnitude)
    return df.assign(base=base, axis=axis, magnitude=mag)


def _cell_figures(g: pd.DataFrame) -> dict:
    resp = g["collision_responsibility"].fillna("") if "collision_responsibility" in g else pd.Series([""] * len(g))
    over = g["a_lat_over05_samples"] if "a_lat_over05_samples" in g else pd.Series([float("nan")] * len(g))
    statuses: dict = {}
    for s in g["qp_status_counts"]:
        for k, v in json.loads(s).items():
            statuses[k] = statuses.get(k, 0) + v
    samples = float(g["samples"].sum())
    return {
        "runs": len(g),
        "ego": int((g["collision"] & (resp == "ego_into_opponent")).sum()),
        "others": int((g["collision"] & (resp != "ego_into_opponent")).sum()),
        "over05": float(over.sum()) / samples if over.notna().all() else float("nan"),
        "progress": float(g["progress"].mean()),
        "solved": statuses.get("solved", 0) / max(1, sum(statuses.values())),
        "reactions": int(g["plan_reactions"].sum()),
        "guards": int(g["a_lat_guards"].sum()),
    }


def _broken(f: dict) -> bool:
    """A cell's figures miss the targets: a collision the ego caused, or the a_lat excess above ``A_LAT_SHARE``."""
    return f["ego"] > 0 or (f["over05"] == f["over05"] and f["over05"] > A_LAT_SHARE)


def section(df: pd.DataFrame) -> list[str]:
    """The markdown lines of the section; none for results without perturbed rows."""
    if "plant" not in df.columns or df["plant"].isna().all():
        return []
    df = split_keys(df)
    lines = [
        "## Robustness",
        "",
        "Per configuration and perturbation: colliding runs the ego caused (`ego_into_opponent`) and the others, the "
        "share of samples where the plant's |a_lat| exceeds its bound + 0.5 m/s^2 (- for the unperturbed runs, whose "
        "plant is the model), mean progress and its change against the unperturbed runs, the share of QPs solved, "
        "plan-check reactions and a_lat guard actions.",
        "",
        "| configuration | axis | magnitude | runs | ego caused | others | a_lat > bound+0.5 | progress [m] | "
        "vs unperturbed | QP solved | plan reactions | guards |",
        "|---|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    order = {(c.axis, c.magnitude): i for i, c in enumerate(cells())}
    breaks = []
    for base, gb in df.groupby("base", sort=True):
        ref = float(gb[gb["axis"] == "none"]["progress"].mean()) if (gb["axis"] == "none").any() else float("nan")
        first: dict = {}
        groups = sorted(gb.groupby(["axis", "magnitude"]), key=lambda t: order[t[0]])
        for (axis, mag), g in groups:
            f = _cell_figures(g)
            over = "-" if f["over05"] != f["over05"] else f"{100 * f['over05']:.2f} %"
            lines.append(
                f"| {base} | {axis} | {mag} | {f['runs']} | {f['ego']} | {f['others']} | {over} | "
                f"{f['progress']:.1f} | {100 * (f['progress'] / ref - 1):+.1f} % | {100 * f['solved']:.1f} % | "
                f"{f['reactions']} | {f['guards']} |"
            )
            if _broken(f) and axis not in first:
                first[axis] = mag
        breaks.append(f"- {base}: " + (", ".join(f"{a} at {m}" for a, m in first.items()) or "holds in every cell"))
    lines += [
        "",
        f"Where each axis first breaks (a collision the ego causes, or |a_lat| above bound + 0.5 in more than "
        f"{100 * A_LAT_SHARE:g} % of the samples):",
        "",
        *breaks,
        "",
        *_ended_early(df),
        *envelope(df),
    ]
    return lines


def _ended_early(df: pd.DataFrame) -> list[str]:
    """The runs that ended before their samples because the ego left the road (``ended_early_sample``), a line
    each; none without such runs."""
    if "ended_early_sample" not in df.columns or df["ended_early_sample"].isna().all():
        return []
    ended = df[df["ended_early_sample"].notna()].sort_values(["config", "seed"])
    return [
        "Runs that ended early, the ego off the road (their figures are those of the samples before):",
        "",
        *(
            f"- {r.config} seed {int(r.seed)}: after {int(r.ended_early_sample)} of {int(r.samples)} samples"
            for r in ended.itertuples()
        ),
        "",
    ]


#: the envelope's rows: (label, axis, whether a magnitude belongs to the row); latency split by compensation
ENVELOPE_ROWS = (
    ("latency [samples], without compensation", "latency", lambda m: "+comp" not in m),
    ("latency [samples], compensated", "latency", lambda m: "+comp" in m),
    ("noise [x the default stds]", "noise", None),
    ("steering lag [s]", "steer-lag", None),
    ("prediction, the fixed margin", "prediction", lambda m: "+margin" not in m),
    ("prediction, margins from its error", "prediction", lambda m: "+margin" in m),
    ("plant", "plant", None),
    ("combined, the fixed margin", "combined", lambda m: "+margin" not in m),
    ("combined, margins from the prediction's error", "combined", lambda m: "+margin" in m),
)


def _why(f: dict) -> str:
    parts = [f"{f['ego']} of {f['runs']} runs ego-caused"] if f["ego"] else []
    if f["over05"] == f["over05"] and f["over05"] > A_LAT_SHARE:
        parts.append(f"a_lat {100 * f['over05']:.2f} %")
    return ", ".join(parts)


def _breaking(df: pd.DataFrame, axis: str, mag: str) -> tuple[list[str], int]:
    """The configurations that miss the targets in a cell (with why), and the fewest runs of a configuration there."""
    g = df[(df["axis"] == axis) & (df["magnitude"] == mag)]
    figs = {base: _cell_figures(gb) for base, gb in g.groupby("base", sort=True)}
    return [f"{b} ({_why(f)})" for b, f in figs.items() if _broken(f)], min(f["runs"] for f in figs.values())


def envelope(df: pd.DataFrame) -> list[str]:
    """The recommended operating envelope: per axis the largest magnitude up to which every configuration holds the
    targets at every magnitude measured, and the first where one misses them (which, and why). ``df`` split."""
    lines = [
        "### Recommended operating envelope",
        "",
        f"Per axis, the largest magnitude up to which every configuration measured holds the targets (no collision the "
        f"ego causes, the plant's |a_lat| above bound + 0.5 in at most {100 * A_LAT_SHARE:g} % of the samples) at "
        "that magnitude and every smaller one, and the first magnitude where one misses them.",
        "",
        "| axis | magnitudes measured | holds up to | first breaks at | configurations that break there | "
        "fewest runs a configuration |",
        "|---|---|---|---|---|---|",
    ]
    bad, _ = _breaking(df, "none", "0") if (df["axis"] == "none").any() else ([], 0)
    if bad:
        lines.append(f"| unperturbed | 0 | - | 0 | {'; '.join(bad)} | - |")
    order = [(c.axis, c.magnitude) for c in cells()]
    for label, axis, keep in ENVELOPE_ROWS:
        present = set(zip(df["axis"], df["magnitude"]))
        mags = [m for a, m in order if a == axis and (a, m) in present and (keep is None or keep(m))]
        if not mags:
            continue
        found = [_breaking(df, axis, m) for m in mags]
        k = next((i for i, (broken, _) in enumerate(found) if broken), None)
        held = "-" if bad else ("0" if k == 0 else mags[(len(mags) if k is None else k) - 1])
        first, who = ("-", "none") if k is None else (mags[k], "; ".join(found[k][0]))
        lines.append(f"| {label} | {', '.join(mags)} | {held} | {first} | {who} | {min(n for _, n in found)} |")
    return [*lines, ""]


def _shares(g: pd.DataFrame) -> tuple[float, float]:
    """The share of runs with a collision the ego caused, and of samples with the plant's |a_lat| above bound+0.5."""
    f = _cell_figures(g)
    return f["ego"] / max(1, f["runs"]), (0.0 if f["over05"] != f["over05"] else f["over05"])


TICK_WORDS = (
    ("st+lat1comp+noise+", "st+lat1c+noise+"),
    ("constant-velocity", "CV"),
    ("constant-acceleration", "CA"),
    ("lane-following", "LF"),
    ("+margin1", "+m1"),
)
"""The plot's short tick labels of the magnitudes (the tables keep the full names)."""


def _tick(magnitude: str) -> str:
    for long, short in TICK_WORDS:
        magnitude = magnitude.replace(long, short)
    return magnitude


def plot(df: pd.DataFrame, out_dir) -> list:
    """``robustness.png``/``.svg``: per axis, the ego's collisions and the a_lat excess against the magnitude (the
    unperturbed cell first; ``TICK_WORDS`` shorten the ticks), one line per configuration (the legend below), the
    magnitude where it first breaks circled."""
    if "plant" not in df.columns or df["plant"].isna().all():
        return []
    from pathlib import Path

    from .figures import Figure, FigureCanvasAgg, _save

    df = split_keys(df)
    axes = [a for a in dict.fromkeys(c.axis for c in cells()) if a != "none" and (df["axis"] == a).any()]
    fig = Figure(figsize=(3.2 * len(axes), 6.4))
    FigureCanvasAgg(fig)
    grid = fig.subplots(2, len(axes), squeeze=False)
    for i, axis in enumerate(axes):
        mags = ["0"] + [c.magnitude for c in cells((axis,)) if c.axis == axis]
        for base, gb in df.groupby("base", sort=True):
            pts = [
                (k, m, _shares(gb[(gb["axis"] == ("none" if k == 0 else axis)) & (gb["magnitude"] == m)]))
                for k, m in enumerate(mags)
                if ((gb["axis"] == ("none" if k == 0 else axis)) & (gb["magnitude"] == m)).any()
            ]
            for row in (0, 1):
                xs, ys = [k for k, _, _ in pts], [100 * s[row] for _, _, s in pts]
                line = grid[row][i].plot(xs, ys, marker=".", label=base)[0]
                br = next((k for k, _, s in pts if s[0] > 0 or s[1] > A_LAT_SHARE), None)
                if br is not None:
                    grid[row][i].plot([br], [ys[xs.index(br)]], "o", mfc="none", ms=10, color=line.get_color())
        for row, label in ((0, "ego-caused collisions [% of runs]"), (1, "|a_lat| > bound + 0.5 [% of samples]")):
            ax = grid[row][i]
            ax.set_xticks(range(len(mags)), [_tick(m) for m in mags], rotation=60, fontsize=6)
            ax.set_ylabel(label if i == 0 else "", fontsize=7)
        grid[0][i].set_title(axis, fontsize=9)
    handles, labels = grid[0][0].get_legend_handles_labels()
    fig.legend(handles, labels, loc="lower center", ncol=4, fontsize=7, frameon=False)
    fig.tight_layout(rect=(0.0, 0.08, 1.0, 1.0))
    return _save(fig, Path(out_dir) / "robustness")
