"""The paper's tables from campaign rows: Table III (time per RTI), progress, collisions, the soft a_lat bound.

Every table is a list of plain dicts (one per configuration) plus a markdown formatter. Times are pooled over every
RTI of every run of a configuration (``time_rti_ms``), like the paper's mean +- std over all real-time iterations.
"""

from __future__ import annotations

import math

import numpy as np

from ..extras import require

with require("campaign", "the campaign's report"):
    import pandas as pd

FORMS = ("conventional", "direct_elimination", "lifted")
FORM_LABEL = {"conventional": "Conventional", "direct_elimination": "Direct Elimination", "lifted": "Lifted ODE"}
MODEL_ORDER = {"truck": ("EL", "C5", "C7", "HP"), "car": ("EL", "C1", "C3", "HP")}
SCENARIO_ORDER = ("truck", "car")

#: the paper's Table III (ms, mean, std; % against conventional), transcribed from its LaTeX source
PAPER_TABLE3 = {
    ("truck", "EL"): ((1.5, 0.4), (1.9, 0.2, 28.9), (1.4, 0.3, -6.6)),
    ("truck", "C5"): ((7.2, 1.9), (7.6, 1.7, 5.5), (7.2, 1.8, -0.0)),
    ("truck", "C7"): ((14.0, 3.2), (14.0, 2.8, -0.1), (13.9, 2.9, -0.4)),
    ("truck", "HP"): ((7.5, 1.5), (7.5, 1.5, -0.1), (7.4, 1.7, -1.6)),
    ("car", "EL"): ((1.5, 0.5), (2.0, 0.4, 29.6), (1.4, 0.4, -5.7)),
    ("car", "C1"): ((1.4, 0.4), (1.9, 0.4, 34.0), (1.4, 0.4, -3.5)),
    ("car", "C3"): ((3.6, 1.1), (4.0, 1.0, 12.4), (3.6, 1.1, 0.6)),
    ("car", "HP"): ((8.0, 2.3), (7.9, 1.9, -0.6), (7.7, 2.0, -4.0)),
}


def groups(df: pd.DataFrame):
    """(scenario, model) pairs present, in the paper's order."""
    have = set(zip(df["scenario"], df["model"]))
    extra = sorted(have - {(s, m) for s in SCENARIO_ORDER for m in MODEL_ORDER[s]})
    return [(s, m) for s in SCENARIO_ORDER for m in MODEL_ORDER[s] if (s, m) in have] + extra


def _cell(df, sc, model, form):
    return df[(df["scenario"] == sc) & (df["model"] == model) & (df["formulation"] == form)]


def _rti_times(sub: pd.DataFrame) -> np.ndarray:
    return np.concatenate([np.asarray(v, dtype=float) for v in sub["time_rti_ms"]]) if len(sub) else np.zeros(0)


def time_table(df: pd.DataFrame) -> list[dict]:
    """Per (scenario, model, formulation): pooled mean/std/median of the time per RTI, % of the mean vs conventional."""
    rows = []
    for sc, model in groups(df):
        base = None
        for form in FORMS:
            sub = _cell(df, sc, model, form)
            if not len(sub):
                continue
            t = _rti_times(sub)
            r = {
                "scenario": sc,
                "model": model,
                "formulation": form,
                "runs": len(sub),
                "rtis": int(t.size),
                "mean": float(np.mean(t)),
                "std": float(np.std(t)),
                "median": float(np.median(t)),
                "p99": float(np.percentile(t, 99)),
                "prepare_mean": float(np.average(sub["time_prepare_ms_mean"], weights=sub["n_controls"])),
                "feedback_mean": float(np.average(sub["time_feedback_ms_mean"], weights=sub["n_controls"])),
                "qp_iter_mean": float(np.average(sub["qp_iter_mean"], weights=sub["n_controls"])),
                "qp_n": int(sub["qp_n"].iloc[0]),
                "qp_m": int(sub["qp_m"].iloc[0]),
                "qp_nnz_a": int(sub["qp_nnz_a"].iloc[0]),
            }
            if form == "conventional":
                base = r["mean"]
            r["vs_conv_pct"] = 100.0 * (r["mean"] / base - 1.0) if base else math.nan
            rows.append(r)
    return rows


def progress_table(df: pd.DataFrame) -> list[dict]:
    """Per configuration: progress mean/std, collisions; and against conventional on the same seeds (paired)."""
    rows = []
    for sc, model in groups(df):
        conv = _cell(df, sc, model, "conventional").set_index("seed")["progress"]
        for form in FORMS:
            sub = _cell(df, sc, model, form)
            if not len(sub):
                continue
            p = sub.set_index("seed")["progress"]
            r = {
                "scenario": sc,
                "model": model,
                "formulation": form,
                "runs": len(sub),
                "mean": float(p.mean()),
                "std": float(p.std(ddof=0)),
                "min": float(p.min()),
                "runs_with_collision": int(sub["collision"].sum()),
                "collision_samples": int(sub["n_collision_samples"].sum()),
                "max_slack": float(sub["max_slack"].max()),
            }
            r.update(_collision_kinds(sub))
            common = p.index.intersection(conv.index)
            if form != "conventional" and len(common):
                d = p.loc[common] - conv.loc[common]
                r.update(vs_conv_m=float(d.mean()), better_seeds=int((d > 0).sum()), paired=len(common))
            rows.append(r)
    return rows


def _collision_kinds(sub: pd.DataFrame) -> dict:
    """Colliding runs per kind of first contact (``sim.collision_kind``) and their depths (m), where the rows have
    them (``campaign.task.collision_columns``; older rows do not)."""
    if "collision_kind" not in sub.columns:
        return {}
    hit = sub[sub["collision"].astype(bool)]
    kinds = hit["collision_kind"].fillna("").astype(str)
    if not len(hit) or (kinds == "").any():
        return {}
    out = {
        "collision_kinds": {k: int(n) for k, n in kinds.value_counts().sort_index().items()},
        "collision_depths_m": [float(v) for v in hit["collision_depth_m"]],
    }
    out["collision_sweeps_m"] = [float(v) for v, k in zip(hit["collision_sweep_m"], kinds) if k == "swept_front"]
    if "collision_responsibility" in hit.columns:  # rows since the responsibility classes (sim.collision_kind)
        who = hit["collision_responsibility"].fillna("").astype(str)
        out["collision_responsibility"] = {k: int(n) for k, n in who.value_counts().sort_index().items() if k}
    return out


def alat_table(df: pd.DataFrame) -> list[dict]:
    """The soft |a_lat| bound per configuration: share of samples above it, runs with any, how far above."""
    rows = []
    for sc, model in groups(df):
        for form in FORMS:
            sub = _cell(df, sc, model, form)
            if not len(sub):
                continue
            over = sub["a_lat_over_samples"].to_numpy()
            ex_sum = float(np.sum(sub["a_lat_excess_mean"].to_numpy() * over))
            rows.append(
                {
                    "scenario": sc,
                    "model": model,
                    "formulation": form,
                    "bound": float(sub["a_lat_bound"].iloc[0]),
                    "share_pct": 100.0 * over.sum() / float(sub["n_states"].sum()),
                    "runs_over": int((over > 0).sum()),
                    "runs": len(sub),
                    "excess_max": float(sub["a_lat_excess_max"].max()),
                    "excess_mean": ex_sum / over.sum() if over.sum() else 0.0,
                }
            )
    return rows


# --- markdown ----------------------------------------------------------------------------------------------------


def _pm(m, s, digits=2):
    return f"{m:.{digits}f} ± {s:.{digits}f}"


def _pct(x):
    return "–" if x is None or (isinstance(x, float) and math.isnan(x)) else f"{x:+.1f} %"


def md_time_table(rows: list[dict], with_paper: bool = True) -> str:
    """Table III: ours (ms) beside the paper's, per scenario and obstacle model."""
    by = {(r["scenario"], r["model"], r["formulation"]): r for r in rows}
    head = "| scenario | model | conventional | direct elim. | vs conv. | lifted | vs conv. |" + (
        " paper: conv. | DE | vs conv. | lifted | vs conv. |" if with_paper else ""
    )
    out = [head, "|" + "---|" * (7 + (5 if with_paper else 0))]
    for sc, model in dict.fromkeys((r["scenario"], r["model"]) for r in rows):
        cells = []
        for form in FORMS:
            r = by.get((sc, model, form))
            cells.append(_pm(r["mean"], r["std"]) if r else "–")
            if form != "conventional":
                cells.append(_pct(r["vs_conv_pct"]) if r else "–")
        line = f"| {sc} | {model} | " + " | ".join(cells) + " |"
        if with_paper:
            p = PAPER_TABLE3.get((sc, model))
            line += (
                (
                    " "
                    + " | ".join([_pm(*p[0], 1), _pm(*p[1][:2], 1), _pct(p[1][2]), _pm(*p[2][:2], 1), _pct(p[2][2])])
                    + " |"
                )
                if p
                else " – | – | – | – | – |"
            )
        out.append(line)
    return "\n".join(out)


def md_time_detail(rows: list[dict]) -> str:
    out = [
        "| scenario | model | formulation | runs | RTIs | median ms | p99 ms | prepare ms | feedback ms "
        "| QP iter | QP variables x rows (nnz A) |",
        "|" + "---|" * 11,
    ]
    for r in rows:
        out.append(
            f"| {r['scenario']} | {r['model']} | {r['formulation']} | {r['runs']} | {r['rtis']} "
            f"| {r['median']:.2f} | {r['p99']:.2f} | {r['prepare_mean']:.3f} | {r['feedback_mean']:.3f} "
            f"| {r['qp_iter_mean']:.0f} | {r['qp_n']} x {r['qp_m']} ({r['qp_nnz_a']}) |"
        )
    return "\n".join(out)


def md_progress_table(rows: list[dict]) -> str:
    out = [
        "| scenario | model | formulation | runs | progress m | min m | vs conv. (same seeds) "
        "| better than conv. | runs with collision | max slack |",
        "|" + "---|" * 10,
    ]
    for r in rows:
        vs = f"{r['vs_conv_m']:+.1f} m" if "vs_conv_m" in r else "–"
        better = f"{r['better_seeds']}/{r['paired']}" if "better_seeds" in r else "–"
        out.append(
            f"| {r['scenario']} | {r['model']} | {r['formulation']} | {r['runs']} "
            f"| {_pm(r['mean'], r['std'], 1)} "
            f"| {r['min']:.1f} | {vs} | {better} | {r['runs_with_collision']} | {r['max_slack']:.3g} |"
        )
    return "\n".join(out)


def md_alat_table(rows: list[dict]) -> str:
    out = [
        "| scenario | model | formulation | samples above the bound | runs with any | max excess m/s² "
        "| mean excess m/s² |",
        "|" + "---|" * 7,
    ]
    for r in rows:
        out.append(
            f"| {r['scenario']} | {r['model']} | {r['formulation']} | {r['share_pct']:.2f} % "
            f"| {r['runs_over']}/{r['runs']} | {r['excess_max']:.3f} | {r['excess_mean']:.3f} |"
        )
    return "\n".join(out)
