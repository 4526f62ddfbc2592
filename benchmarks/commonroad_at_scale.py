"""Where the time of a CommonRoad campaign goes (docs/commonroad.md, "At scale"): per traffic mode the runs and
refusals, the workers' CPU time (the rows' ``cpu_s``), its split into the runs and the refusals, and what it means on
a machine of N cores not shared with other work (CPU / N); with a second results folder of the same scenarios run with
the criticality measures, their cost per closed-loop sample.

    python benchmarks/commonroad_at_scale.py results/cr_all [--with-criticality results/cr_crit] [--cores 2]

Prints a Markdown table and writes it to ``RESULTS/time_budget.md``.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import pandas as pd


def budget(df: pd.DataFrame, cores: int) -> list[str]:
    """Per traffic mode: runs, refused, CPU of the runs and of the refusals, mean CPU a run and a sample, and the
    campaign's time on ``cores`` unshared cores."""
    lines = [
        "| traffic | runs | refused | closed-loop samples | CPU of the runs, s | CPU of the refusals, s | "
        f"CPU a run, s | CPU a sample, ms | on {cores} unshared cores, min |",
        "|---|---|---|---|---|---|---|---|---|",
    ]
    for traffic, g in [*df.groupby("traffic", sort=True), ("all", df)]:
        ran, ref = g[g.status == "ran"], g[g.status != "ran"]
        cpu_ran, cpu_ref = float(ran.cpu_s.sum()), float(ref.cpu_s.sum())
        samples = int(ran.samples.sum())
        lines.append(
            f"| {traffic} | {len(ran)} | {len(ref)} | {samples} | {cpu_ran:.0f} | {cpu_ref:.0f} | "
            f"{cpu_ran / max(len(ran), 1):.2f} | {1e3 * cpu_ran / max(samples, 1):.1f} | "
            f"{(cpu_ran + cpu_ref) / cores / 60:.1f} |"
        )
    return lines


def criticality_cost(plain: pd.DataFrame, crit: pd.DataFrame) -> tuple[list[str], float]:
    """The criticality measures' CPU per run and per sample (s): the same runs with and without them."""
    key = ["scenario", "problem", "traffic"]
    m = plain[plain.status == "ran"].merge(crit[crit.status == "ran"], on=key, suffixes=("", "_crit"))
    extra = m.cpu_s_crit - m.cpu_s
    per_sample = extra.sum() / max(int(m.samples.sum()), 1)
    return [
        "",
        f"Criticality measures, {len(m)} runs measured both ways: {extra.mean():.2f} s of CPU a run more "
        f"({1e3 * per_sample:.1f} ms a closed-loop sample; runs {m.cpu_s.sum():.0f} s without, "
        f"{m.cpu_s_crit.sum():.0f} s with).",
    ], per_sample


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("results", help="a CommonRoad campaign's --out folder")
    ap.add_argument("--with-criticality", default=None, help="the same runs with the criticality measures")
    ap.add_argument("--cores", type=int, default=2)
    a = ap.parse_args()
    df = pd.read_parquet(Path(a.results) / "commonroad.parquet")
    lines = budget(df, a.cores)
    if a.with_criticality:
        more, per_sample = criticality_cost(df, pd.read_parquet(Path(a.with_criticality) / "commonroad.parquet"))
        lines += more
        total = float(df.cpu_s.sum()) + per_sample * float(df[df.status == "ran"].samples.sum())
        lines.append(f"With them: about {total / a.cores / 60:.1f} min on {a.cores} unshared cores.")
    text = "\n".join(lines) + "\n"
    print(text)
    (Path(a.results) / "time_budget.md").write_text(text)


if __name__ == "__main__":
    main()
