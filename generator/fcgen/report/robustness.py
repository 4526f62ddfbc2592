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
            broken = f["ego"] > 0 or (f["over05"] == f["over05"] and f["over05"] > A_LAT_SHARE)
            if broken and axis not in first:
                first[axis] = mag
        breaks.append(f"- {base}: " + (", ".join(f"{a} at {m}" for a, m in first.items()) or "holds in every cell"))
    lines += [
        "",
        f"Where each axis first breaks (a collision the ego causes, or |a_lat| above bound + 0.5 in more than "
        f"{100 * A_LAT_SHARE:g} % of the samples):",
        "",
        *breaks,
        "",
    ]
    return lines
