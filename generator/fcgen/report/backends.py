"""Two QP backends in one campaign: time per RTI ratio, progress paired by seed, collisions, per configuration.

Rows of the two backends are matched on (scenario, model, formulation) and, for progress, on the seed; only seeds
run with both backends are paired.
"""

from __future__ import annotations

import math

import numpy as np

from ..extras import require
from .tables import FORMS, _cell, _rti_times, groups

with require("campaign", "the campaign's report"):
    import pandas as pd


def backends_of(df: pd.DataFrame) -> list[str]:
    """The QP backends in the rows, OSQP (the default) first."""
    return sorted(df["backend"].unique(), key=lambda b: (b != "osqp", b))


def compare(df: pd.DataFrame, base: str, other: str) -> list[dict]:
    """Per configuration: mean time per RTI of each backend and their ratio (other / base), QP iterations, the
    progress difference (other - base) on the same seeds, and the runs with a collision under each."""
    a, b = df[df["backend"] == base], df[df["backend"] == other]
    rows = []
    for sc, model in groups(df):
        for form in FORMS:
            ca, cb = _cell(a, sc, model, form), _cell(b, sc, model, form)
            if not (len(ca) and len(cb)):
                continue
            ta, tb = _rti_times(ca), _rti_times(cb)
            pa, pb = ca.set_index("seed")["progress"], cb.set_index("seed")["progress"]
            common = pa.index.intersection(pb.index)
            d = (pb.loc[common] - pa.loc[common]).to_numpy()
            rows.append(
                {
                    "scenario": sc,
                    "model": model,
                    "formulation": form,
                    "time_base": float(np.mean(ta)),
                    "time_other": float(np.mean(tb)),
                    "ratio": float(np.mean(tb) / np.mean(ta)),
                    "median_ratio": float(np.median(tb) / np.median(ta)),
                    "iter_base": float(np.average(ca["qp_iter_mean"], weights=ca["n_controls"])),
                    "iter_other": float(np.average(cb["qp_iter_mean"], weights=cb["n_controls"])),
                    "paired": len(common),
                    "dprog_mean": float(d.mean()) if d.size else math.nan,
                    "dprog_absmax": float(np.abs(d).max()) if d.size else math.nan,
                    "other_better": int((d > 0).sum()),
                    "other_worse": int((d < 0).sum()),
                    "coll_base": int(ca["collision"].sum()),
                    "coll_other": int(cb["collision"].sum()),
                    "runs_base": len(ca),
                    "runs_other": len(cb),
                }
            )
    return rows


def summary(rows: list[dict]) -> dict:
    """Over all configurations: the geometric mean and range of the time ratio, the mean paired progress
    difference (per run), the collisions under each backend."""
    if not rows:
        return {}
    r = np.array([x["ratio"] for x in rows])
    n = sum(x["paired"] for x in rows)
    return {
        "configs": len(rows),
        "ratio_geo": float(np.exp(np.mean(np.log(r)))),
        "ratio_min": float(r.min()),
        "ratio_max": float(r.max()),
        "paired": n,
        "dprog_mean": sum(x["dprog_mean"] * x["paired"] for x in rows if x["paired"]) / n if n else math.nan,
        "other_better": sum(x["other_better"] for x in rows),
        "other_worse": sum(x["other_worse"] for x in rows),
        "coll_base": sum(x["coll_base"] for x in rows),
        "coll_other": sum(x["coll_other"] for x in rows),
        "runs_base": sum(x["runs_base"] for x in rows),
        "runs_other": sum(x["runs_other"] for x in rows),
    }


def md_compare(rows: list[dict], base: str, other: str) -> str:
    out = [
        f"| scenario | model | formulation | {base} ms | {other} ms | {other} / {base} (mean) | (median) "
        f"| QP iter {base} | QP iter {other} | progress {other} - {base} (same seeds) | max abs. difference "
        f"| {other} better / worse | collisions {base} | collisions {other} |",
        "|" + "---|" * 14,
    ]
    for x in rows:
        out.append(
            f"| {x['scenario']} | {x['model']} | {x['formulation']} | {x['time_base']:.2f} "
            f"| {x['time_other']:.2f} | {x['ratio']:.2f} | {x['median_ratio']:.2f} | {x['iter_base']:.0f} "
            f"| {x['iter_other']:.1f} | {x['dprog_mean']:+.1f} m | {x['dprog_absmax']:.1f} m "
            f"| {x['other_better']}/{x['other_worse']} of {x['paired']} | {x['coll_base']}/{x['runs_base']} "
            f"| {x['coll_other']}/{x['runs_other']} |"
        )
    return "\n".join(out)


def md_summary(s: dict, base: str, other: str) -> str:
    if not s:
        return f"No configuration was run with both {base} and {other}."
    speed = (
        f"{other} takes {s['ratio_geo']:.2f} x {base}'s time per RTI (geometric mean over {s['configs']} "
        f"configurations; {s['ratio_min']:.2f} .. {s['ratio_max']:.2f} x"
        + (f", i.e. {1 / s['ratio_geo']:.1f} x faster)" if s["ratio_geo"] < 1 else ")")
    )
    return (
        f"{speed}. Progress, paired by seed over {s['paired']} runs: {other} - {base} = {s['dprog_mean']:+.1f} m "
        f"on average ({other} further in {s['other_better']} runs, shorter in {s['other_worse']}). Runs with a "
        f"collision: {s['coll_base']} of {s['runs_base']} ({base}), {s['coll_other']} of {s['runs_other']} "
        f"({other})."
    )
