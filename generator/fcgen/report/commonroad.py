"""``fcgen report`` of a CommonRoad campaign (a results folder holding ``commonroad.parquet``): per configuration and
traffic mode the runs, the scenarios refused, the collisions by responsibility, the road departures after an on-road
start, the goal, the valid solutions, the vehicles that reacted, and the criticality measures' distributions with the
worst runs named; per data set (the scenarios' location, ``USA_US101``) and traffic mode the same with the refusals by
reason and the time per cycle (docs/commonroad.md)."""

from __future__ import annotations

from pathlib import Path

from ..campaign.commonroad import departed_on_road
from ..extras import require
from .cr_planners import SAMPLED_OUT, planner_section

WHO = ("ego_into_opponent", "opponent_from_behind", "opponent_from_side")
MEASURES = (
    ("ttc_ahead_min_s", "TTC ahead"),
    ("ttc_behind_min_s", "TTC behind"),
    ("thw_ahead_min_s", "THW ahead"),
    ("thw_behind_min_s", "THW behind"),
)
WORST = 5  # runs named per measure


def is_commonroad(results: str | Path) -> bool:
    """Whether ``results`` is a CommonRoad campaign's folder (or its ``commonroad.parquet``)."""
    p = Path(results)
    return (p / "commonroad.parquet").is_file() or p.name == "commonroad.parquet"


def _count(col) -> int:
    return int(col.fillna(False).astype(bool).sum())


def _fmt(v) -> str:
    return "-" if v is None or v != v else f"{v:.2f}"


def outcome_table(ran) -> list[str]:
    """Per configuration and traffic mode: runs, collisions by responsibility, departures, goal, valid, reactions."""
    lines = [
        "| configuration | traffic | runs | collisions: ego into opponent / opponent from behind / from the side | "
        "road departures after the ego was on the road | goal reached | valid solutions | "
        "vehicles reacted (to the ego) |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for (name, traffic), g in ran.groupby(["problem", "traffic"], sort=True):
        hit = g[g.collision_fcgen.fillna(False).astype(bool)]
        who = " / ".join(str(int((hit.responsibility == w).sum())) for w in WHO)
        dep = _count(departed_on_road(g))
        lines.append(
            f"| {name} | {traffic} | {len(g)} | {who} | {dep} | {_count(g.goal_reached)} | "
            f"{_count(g.solution_valid)} | {int(g.reacted.fillna(0).sum())} ({int(g.reacted_to_ego.fillna(0).sum())}) |"
        )
    return [*lines, ""]


def dataset_table(df) -> list[str]:
    """Per data set and traffic mode: runs, refused (by reason), collisions by responsibility, departures after the
    ego was on the road, goal reached, valid solutions, the smallest and the median TTC ahead, the median time per
    cycle (RTI) and the mean CPU time per run (its wall time for rows without it)."""
    lines = [
        "| data set | traffic | scenarios | runs | refused or failed (why) | collisions: ego into opponent / opponent "
        "from behind / from the side | road departures | goal reached | valid solutions | TTC ahead: min / median, s | "
        "RTI median, ms | CPU per run, s |",
        "|---|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    groups = list(df.groupby(["dataset", "traffic"], sort=True))
    for (dataset, traffic), g in [*groups, (("all", "all"), df)]:
        ran, refused = g[g.status == "ran"], g[g.status != "ran"]
        why = ", ".join(f"{k} {v}" for k, v in refused.refusal.fillna("other").value_counts().items())
        hit = ran[ran.collision_fcgen.fillna(False).astype(bool)]
        who = " / ".join(str(int((hit.responsibility == w).sum())) for w in WHO)
        ttc = ran.ttc_ahead_min_s.dropna().astype(float)
        ttc_s = f"{ttc.min():.2f} / {ttc.median():.2f}" if len(ttc) else "-"
        rti = f"{ran.rti_ms_median.astype(float).median():.3f}" if len(ran) else "-"
        cpu = ran.cpu_s.fillna(ran.wall_s).astype(float)
        wall = f"{cpu.mean():.1f}" if len(ran) else "-"
        lines.append(
            f"| {dataset} | {traffic} | {g.scenario.nunique()} | {len(ran)} | {len(refused)}"
            + (f" ({why})" if why else "")
            + f" | {who} | {_count(departed_on_road(ran)) if len(ran) else 0} | {_count(ran.goal_reached)} | "
            f"{_count(ran.solution_valid)} | {ttc_s} | {rti} | {wall} |"
        )
    return [*lines, ""]


def refusal_table(refused) -> list[str]:
    """Refused runs per reason (``refusal``) and traffic mode, with an example."""
    lines = ["| reason | traffic | runs | example |", "|---|---|---|---|"]
    kinds = refused.assign(refusal=refused.refusal.fillna("other"))
    for (kind, traffic), g in kinds.groupby(["refusal", "traffic"], sort=True):
        r = g.iloc[0]
        lines.append(f"| {kind} | {traffic} | {len(g)} | {r.scenario}: {r.reason} |")
    return [*lines, ""]


def criticality_table(ran) -> list[str]:
    """Per traffic mode and measure: runs measured, runs where nobody closed in, the distribution of the run minima
    (s) and how many lie below 1 s and 2 s."""
    lines = [
        "| traffic | measure | runs measured | none closing in | min | 5 % | median | 95 % | below 1 s | below 2 s |",
        "|---|---|---|---|---|---|---|---|---|---|",
    ]
    for traffic, g in ran.groupby("traffic", sort=True):
        ok = g[g.criticality_error.fillna("") == ""]
        for col, label in MEASURES:
            v = ok[col].dropna().astype(float)
            q = v.quantile([0.0, 0.05, 0.5, 0.95]).tolist() if len(v) else [None] * 4
            lines.append(
                f"| {traffic} | {label} | {len(ok)} | {len(ok) - len(v)} | "
                + " | ".join(_fmt(x) for x in q)
                + f" | {int((v < 1.0).sum())} | {int((v < 2.0).sum())} |"
            )
    bad = ran[ran.criticality_error.fillna("") != ""]
    if len(bad):
        lines += ["", f"Not measured: {len(bad)} runs ({'; '.join(sorted(set(bad.criticality_error)))})."]
    return [*lines, ""]


def worst_runs(ran) -> list[str]:
    """The ``WORST`` runs with the smallest time-to-collision ahead and behind, named."""
    lines = []
    for col, label in MEASURES[:2]:
        obst = col.replace("_min_s", "_obstacle")
        w = ran[ran[col].notna()].sort_values(col).head(WORST)
        lines += [f"**Smallest {label}**", "", "| scenario | configuration | traffic | s | vehicle | collision |"]
        lines.append("|---|---|---|---|---|---|")
        lines += [
            f"| {r.scenario} | {r.problem} | {r.traffic} | {getattr(r, col):.2f} | {_int(getattr(r, obst))} | "
            f"{r.responsibility or '-'} |"
            for r in w.itertuples()
        ]
        lines.append("")
    return lines


def _int(v) -> str:
    return "-" if v is None or v != v else str(int(v))


def commonroad_markdown(df) -> str:
    """The report's page."""
    df = with_defaults(df.copy())
    every, df = df, df[df.status != SAMPLED_OUT]  # a sample's left-out runs: counted in the planners' section only
    ran, refused = df[df.status == "ran"], df[df.status != "ran"]
    lines = [
        "# CommonRoad campaign report",
        "",
        f"{df.scenario.nunique()} scenarios, {df.problem.nunique()} configurations, traffic "
        f"{', '.join(sorted(df.traffic.fillna('recorded').unique()))}: {len(ran)} runs, {len(refused)} refused or "
        "failed.",
        "",
    ]
    lines += ["## Per data set", "", *dataset_table(df)]
    lines += planner_section(every)
    if len(refused):
        lines += ["## Refused", "", *refusal_table(refused)]
    if len(ran):
        lines += ["## Outcomes", "", *outcome_table(ran)]
        lines += ["## Criticality (commonroad-crime, minimum per run)", "", *criticality_table(ran)]
        lines += ["## Worst runs", "", *worst_runs(ran)]
    return "\n".join(lines) + "\n"


def write_cr_report(results: str | Path, out_dir: str | Path, force: bool = False, more: tuple = ()) -> Path:
    """The CommonRoad report of ``results`` and the folders ``more`` (another profile's campaign, the peer planner's
    rows) into ``out_dir`` (``README.md``)."""
    with require("campaign", "the CommonRoad report"):
        import pandas as pd
    from .page import check_report_target

    check_report_target(out_dir, force)
    frames = []
    for p in map(Path, (results, *more)):
        if not is_commonroad(p):
            raise ValueError(f"{p}: not a CommonRoad campaign's folder (no commonroad.parquet in it)")
        frames.append(with_defaults(pd.read_parquet(p / "commonroad.parquet" if p.is_dir() else p)))
    df = pd.concat(frames, ignore_index=True) if len(frames) > 1 else frames[0]
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    (out / "README.md").write_text(commonroad_markdown(df))
    return out / "README.md"


def with_defaults(df):
    """The columns an older campaign's rows lack, filled: the traffic mode (recorded; with a prediction its name
    after it), the data set (from the scenario's name), the refusal kind (other), the criticality columns (none)."""
    from ..commonroad.catalog import dataset_of

    if "traffic" not in df.columns:
        df["traffic"] = "recorded"
    df["traffic"] = df["traffic"].fillna("recorded")
    if "prediction" in df.columns:  # predicted traffic in rows of its own: "recorded, lane-following"
        pred = df["prediction"].fillna("oracle")
        df["traffic"] = df["traffic"].where(pred == "oracle", df["traffic"] + ", " + pred)
    if "dataset" not in df.columns:
        df["dataset"] = None
    df["dataset"] = df["dataset"].fillna(df["scenario"].map(dataset_of))
    if "refusal" not in df.columns:
        df["refusal"] = None
    df.loc[(df.status != "ran") & df.refusal.isna(), "refusal"] = "other"
    for col, _ in MEASURES:
        if col not in df.columns:
            df[col] = None
    for col in ("criticality_error", "reacted", "reacted_to_ego", "ttc_ahead_obstacle", "ttc_behind_obstacle"):
        if col not in df.columns:
            df[col] = "" if col == "criticality_error" else None
    for col in ("rti_ms_median", "wall_s", "cpu_s"):
        if col not in df.columns:
            df[col] = None
    return df
