"""The paper profile against the safe profile, seed by seed: collisions (by kind and responsibility), |a_lat| above
its bound, progress, time per RTI, plan-check reactions (``fcgen profiles``)."""

from __future__ import annotations

import math

import numpy as np

from ..extras import require

with require("campaign", "the campaign's report"):
    import pandas as pd

#: |a_lat| above the bound by more than this counts as kept-violated (the issue's 5.05 m/s^2 for a 5 m/s^2 bound)
A_LAT_SLACK = 0.05


def _cell_key(df: pd.DataFrame) -> pd.Series:
    return df["scenario"] + " " + df["formulation"] + " " + df["model"]


def _counts(rows: pd.DataFrame, column: str) -> str:
    if column not in rows.columns or not len(rows):
        return ""
    c = rows[column].fillna("").astype(str).value_counts().sort_index()
    return ", ".join(f"{k} {n}" for k, n in c.items() if k)


def compare(paper: pd.DataFrame, safe: pd.DataFrame) -> list[dict]:
    """Per configuration (scenario, formulation, obstacle model) on the seeds both hold: one row."""
    out = []
    if "backend" in paper.columns and "backend" in safe.columns:  # the same QP backends on both sides
        paper = paper[paper["backend"].isin(set(safe["backend"]))]
    paper, safe = paper.assign(cell=_cell_key(paper)), safe.assign(cell=_cell_key(safe))
    for cell in sorted(set(paper["cell"]) & set(safe["cell"])):
        a = paper[paper["cell"] == cell].set_index("seed")
        b = safe[safe["cell"] == cell].set_index("seed")
        seeds = a.index.intersection(b.index)
        a, b = a.loc[seeds], b.loc[seeds]
        row = {"configuration": cell, "seeds": len(seeds)}
        for tag, d in (("paper", a), ("safe", b)):
            hit = d[d["collision"].astype(bool)]
            row[f"{tag}_collisions"] = len(hit)
            row[f"{tag}_kinds"] = _counts(hit, "collision_kind")
            row[f"{tag}_responsibility"] = _counts(hit, "collision_responsibility")
            over = d["a_lat_over_samples"].to_numpy(dtype=float)
            row[f"{tag}_alat_over_pct"] = 100.0 * over.sum() / float(d["n_states"].sum())
            row[f"{tag}_alat_excess_max"] = float(d["a_lat_excess_max"].max()) if len(d) else math.nan
            row[f"{tag}_time_ms"] = float(d["time_total_ms_mean"].mean())
            row[f"{tag}_qp_iter"] = float(d["qp_iter_mean"].mean())
            row[f"{tag}_reactions"] = int(d["plan_reactions"].sum()) if "plan_reactions" in d.columns else 0
        pa, pb = a["progress"].to_numpy(dtype=float), b["progress"].to_numpy(dtype=float)
        row["progress_ratio"] = float(pb.mean() / pa.mean()) if pa.mean() else math.nan
        row["time_ratio"] = row["safe_time_ms"] / row["paper_time_ms"] if row["paper_time_ms"] else math.nan
        out.append(row)
    return out


def markdown(rows: list[dict]) -> str:
    """The comparison as a Markdown table, with totals."""
    head = (
        "| configuration | seeds | collisions paper / safe | safe: kind; responsibility | |a_lat| > bound "
        "paper / safe (% of samples) | max excess paper / safe (m/s^2) | progress safe/paper | time per RTI "
        "paper / safe (ms) | QP iter paper / safe | plan-check reactions (samples) |"
    )
    lines = [head, "|" + "---|" * 10]
    for r in rows:
        lines.append(
            f"| {r['configuration']} | {r['seeds']} | {r['paper_collisions']} / {r['safe_collisions']} | "
            f"{r['safe_kinds'] or '-'}; {r['safe_responsibility'] or '-'} | {r['paper_alat_over_pct']:.1f} / "
            f"{r['safe_alat_over_pct']:.2f} | {r['paper_alat_excess_max']:.2f} / {r['safe_alat_excess_max']:.2f} | "
            f"{r['progress_ratio']:.3f} | {r['paper_time_ms']:.3f} / {r['safe_time_ms']:.3f} | "
            f"{r['paper_qp_iter']:.2f} / {r['safe_qp_iter']:.2f} | {r['safe_reactions']} |"
        )
    if rows:
        n = sum(r["seeds"] for r in rows)
        tr = np.exp(np.mean(np.log([r["time_ratio"] for r in rows])))
        lines.append(
            f"| **all** | {n} runs | {sum(r['paper_collisions'] for r in rows)} / "
            f"{sum(r['safe_collisions'] for r in rows)} | | | max {max(r['paper_alat_excess_max'] for r in rows):.2f}"
            f" / {max(r['safe_alat_excess_max'] for r in rows):.2f} | "
            f"{min(r['progress_ratio'] for r in rows):.3f}-{max(r['progress_ratio'] for r in rows):.3f} | "
            f"ratio {tr:.3f} (geometric mean) | | {sum(r['safe_reactions'] for r in rows)} |"
        )
    return "\n".join(lines) + "\n"
