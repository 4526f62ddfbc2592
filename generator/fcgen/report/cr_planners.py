"""The CommonRoad report's planners side by side: per data set and traffic mode one table whose columns are fcgen's
safe and paper profiles, the reactive planner (``benchmarks/reactive_planner_peer.py``'s rows, controller ``peer``)
and the recorded human driver, whose rows are the runs, the refusals, the collisions by responsibility, the road
departures, the goal, the valid solutions, the time-to-collision ahead and the time per cycle (docs/commonroad.md)."""

from __future__ import annotations

import re

from ..campaign.commonroad import departed_on_road

PLANNERS = ("fcgen safe", "fcgen paper", "reactive planner", "recorded human driver")
WHO = ("ego_into_opponent", "opponent_from_behind", "opponent_from_side")
HUMAN = "not in the files"  # the CommonRoad files keep no trajectory of the vehicle the planning problem starts from
NOT_RUN = "not run"
SAMPLED_OUT = "sampled out"  # a row's status: a run the planner's sample left out (the peer's ``--sample``)
MEASURES = (
    "runs",
    "refused or failed (why)",
    "collisions: ego into opponent / opponent from behind / from the side",
    "road departures after the ego was on the road",
    "goal reached",
    "valid solutions",
    "TTC ahead: min over the runs, s",
    "runs with TTC ahead < 1 s (runs measured)",
    "time per cycle: median of the runs' medians, ms",
)


def planner_of(problem: str, controller: str, profile: object = None) -> str:
    """A row's planner: ``reactive planner`` for the peer's rows (controller ``peer``), else fcgen's profile, the
    row's ``profile`` (``safe`` or ``paper``); rows written before that column by the problem's name: the safe
    profile's problems end in ``_safe`` (``presets.preset``), or have it before a campaign's variant suffix (``_cb``
    the corners' band, ``_e<N>`` ego circles, ``_d<N>`` delay compensation); the paper profile's do not."""
    if controller == "peer":
        return PLANNERS[2]
    if profile in ("safe", "paper"):
        return PLANNERS[0] if profile == "safe" else PLANNERS[1]
    return PLANNERS[0] if re.search(r"_safe(_(cb|e\d|d\d))*$", str(problem)) else PLANNERS[1]


def column(g) -> list[str]:
    """One planner's cells (``MEASURES``' order) from its rows ``g`` of one data set and traffic mode."""
    ran, left = g[g.status == "ran"], int((g.status == SAMPLED_OUT).sum())
    refused = g[(g.status != "ran") & (g.status != SAMPLED_OUT)]
    counts = refused.refusal.fillna("other").value_counts().items()
    why = ", ".join(f"{k} {v}" for k, v in sorted(counts, key=lambda kv: (-kv[1], kv[0])))  # most first, then by name
    hit = ran[ran.collision_fcgen.fillna(False).astype(bool)]
    measured = ran[ran.criticality_error.fillna("") == ""]
    ttc = measured.ttc_ahead_min_s.dropna().astype(float)
    rti = ran.rti_ms_median.dropna().astype(float)
    return [
        f"{len(ran)}" + (f" (a sample: {left} more not run)" if left else ""),
        f"{len(refused)}" + (f" ({why})" if why else ""),
        " / ".join(str(int((hit.responsibility == w).sum())) for w in WHO),
        str(int(departed_on_road(ran).sum())) if len(ran) else "0",
        str(int(ran.goal_reached.fillna(False).astype(bool).sum())),
        str(int(ran.solution_valid.fillna(False).astype(bool).sum())),
        f"{ttc.min():.2f}" if len(ttc) else "-",
        f"{int((ttc < 1.0).sum())} ({len(measured)})",
        f"{rti.median():.3g}" if len(rti) else "-",
    ]


def side_by_side(df, dataset: str, traffic: str) -> list[str]:
    """The table of one data set (``all``: every one) and traffic mode; a planner without rows there: ``not run``,
    the human driver: ``not in the files``."""
    g = df[df.traffic == traffic]
    if dataset != "all":
        g = g[g.dataset == dataset]
    cols = []
    for name in PLANNERS:
        mine = g[g.planner == name]
        cols.append([HUMAN] * len(MEASURES) if name == PLANNERS[3] else column(mine) if len(mine) else None)
    lines = [f"| {dataset}, {traffic} | " + " | ".join(PLANNERS) + " |", "|---|" + "---|" * len(PLANNERS)]
    for i, label in enumerate(MEASURES):
        cells = [NOT_RUN if c is None else c[i] for c in cols]
        lines.append(f"| {label} | " + " | ".join(cells) + " |")
    return [*lines, ""]


def planner_section(df) -> list[str]:
    """The report's section: per traffic mode every data set's table, then all data sets'; other planners' rows
    (another configuration than a profile's) are counted under their own ``fcgen NAME`` and not shown here."""
    prof = df.profile if "profile" in df else [None] * len(df)
    df = df.assign(planner=[planner_of(*r) for r in zip(df.problem, df.controller, prof, strict=True)])
    lines = [
        "## Planners side by side",
        "",
        "Per data set and traffic mode; the reactive planner's rows are `benchmarks/reactive_planner_peer.py`'s (its "
        "time per cycle is its plan's CPU time in Python, fcgen's the RTI's). The recorded human driver is "
        f"{HUMAN}: a CommonRoad scenario keeps no trajectory of the vehicle its planning problem starts from.",
        "",
    ]
    for traffic in sorted(df.traffic.unique()):
        for dataset in [*sorted(df[df.traffic == traffic].dataset.unique()), "all"]:
            lines += side_by_side(df, dataset, traffic)
    return lines
