"""The short results table ``fcgen campaign`` prints at its end: per configuration its runs, collisions, mean progress
and time per RTI (the runs of this call's grid, those of an earlier call that it resumed included)."""

from __future__ import annotations

from typing import TYPE_CHECKING

from .grid import Task

if TYPE_CHECKING:  # the table's rows come from the campaign's store (the 'campaign' extra)
    import pandas as pd

COLUMNS = ("configuration", "runs", "collisions", "progress [m]", "time per RTI [ms]")


def results_table(df: pd.DataFrame, tasks: list[Task]) -> str:
    """The table of the runs of ``tasks`` found in ``df`` (a results frame): per configuration the number of runs,
    of colliding runs, the mean progress and the median over runs of each run's median time per RTI."""
    ids = {t.run_id for t in tasks}
    rows = df[
        [
            (c, int(n), int(s), k) in ids
            for c, n, s, k in zip(df["config"], df["samples"], df["seed"], df["clock"], strict=True)
        ]
    ]
    order = list(dict.fromkeys(t.config.key for t in tasks))
    table = [COLUMNS]
    for key in order:
        r = rows[rows["config"] == key]
        if r.empty:
            continue
        table.append(
            (
                key,
                str(len(r)),
                str(int(r["collision"].sum())),
                f"{r['progress'].mean():.1f}",
                f"{r['time_total_ms_median'].median():.3f}",
            )
        )
    w = [max(len(row[i]) for row in table) for i in range(len(COLUMNS))]
    lines = ["  ".join(s.ljust(w[j]) if j == 0 else s.rjust(w[j]) for j, s in enumerate(row)) for row in table]
    lines.insert(1, "  ".join("-" * x for x in w))
    return "\n".join(lines)
