"""``fcgen report RESULTS -o DIR``: tables, box plots, a Fig. 1-like run and a markdown page beside the paper's."""
from __future__ import annotations

from pathlib import Path

import pandas as pd

from ..campaign.store import read_results
from . import figures, findings, tables

PAPER_RUNS_PER_CONFIG = 500


def scale_rows(df: pd.DataFrame) -> list[dict]:
    """Runs per second per core per obstacle model (1 / mean wall time of a run, one process = one core)."""
    rows = []
    for (sc, model), sub in df.groupby(["scenario", "model"], sort=False):
        rows.append({"scenario": sc, "model": model, "runs": len(sub), "wall_mean_s": float(sub["wall_s"].mean()),
                     "runs_per_s_core": 1.0 / float(sub["wall_s"].mean())})
    return rows


def grid_estimate(df: pd.DataFrame, cores: int = 2) -> dict:
    """The paper's full grid (500 runs per configuration present) on ``cores`` cores, from the measured wall times."""
    per_cfg = df.groupby("config")["wall_s"].mean()
    runs = PAPER_RUNS_PER_CONFIG * len(per_cfg)
    core_s = PAPER_RUNS_PER_CONFIG * float(per_cfg.sum())
    span = float(df["t_end"].max() - df["t_start"].min())
    return {"configs": len(per_cfg), "runs": runs, "core_s": core_s, "wall_min": core_s / cores / 60.0,
            "cores": cores, "measured_runs": len(df), "measured_span_s": span,
            "measured_rate": len(df) / span if span > 0 else float("nan"), "workers": int(df["worker"].nunique())}


def write_report(results: str | Path, out_dir: str | Path, example: bool = True) -> Path:
    """Write every artefact into ``out_dir``; returns the markdown page."""
    df = read_results(results)
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    t_rows, p_rows, a_rows = tables.time_table(df), tables.progress_table(df), tables.alat_table(df)
    figs = figures.box_plots(df, out)
    if example:
        figs += figures.example_run(df, out)
    fs = findings.judge(t_rows, p_rows)
    est = grid_estimate(df)
    conv_fit = df[df["formulation"] == "conventional"]["n_opp_par"]
    conv_note = ("" if conv_fit.empty else
                 "The conventional solver takes the opponents' Cartesian poses and fits their Frenet boxes itself: its "
                 "time per RTI includes the fitting." if int(conv_fit.iloc[0]) == 3 else
                 "Note: the conventional solver here still takes the opponents' Frenet boxes fitted in Python, outside "
                 "the timed solver, so its time per RTI is understated.")
    grid = df.groupby(["scenario", "samples"]).agg(configs=("config", "nunique"), runs=("seed", "size"),
                                                   seeds=("seed", "nunique")).reset_index()
    lines = [
        "# Campaign report", "",
        "Results: " + ", ".join(f"{r.scenario}: {r.configs} configurations x {r.seeds} seeds x {r.samples} samples "
                                f"({r.runs} runs)" for r in grid.itertuples()) + ".",
        f"Controllers: {', '.join(sorted(df['controller'].unique()))}; QP backend: "
        f"{', '.join(sorted(df['backend'].unique()))}; fcgen solver hashes: {df['solver_hash'].nunique()}.", "",
        "## Table III: time per RTI (ms, mean ± std over every RTI), beside the paper's", "",
        tables.md_time_table(t_rows), "", conv_note, "",
        "Where the time goes:", "", tables.md_time_detail(t_rows), "",
        "## Progress and collisions", "", tables.md_progress_table(p_rows), "",
        "## The paper's findings", "", findings.md_findings(fs), "",
        "## Soft constraint: |a_lat| above its bound", "", tables.md_alat_table(a_rows), "",
        "## Figures", "",
        *[f"![{p.stem}]({p.name})" for p in figs if p.suffix == ".png"], "",
        "## Rate and the full grid", "",
        "| scenario | model | runs | mean wall per run s | runs/s per core |", "|---|---|---|---|---|",
        *[f"| {r['scenario']} | {r['model']} | {r['runs']} | {r['wall_mean_s']:.3f} | {r['runs_per_s_core']:.2f} |"
          for r in scale_rows(df)], "",
        f"Measured: {est['measured_runs']} runs in {est['measured_span_s']:.0f} s on {est['workers']} worker "
        f"processes ({est['measured_rate']:.2f} runs/s). The paper's grid ({PAPER_RUNS_PER_CONFIG} runs x "
        f"{est['configs']} configurations = {est['runs']} runs) needs {est['core_s'] / 3600:.2f} core-hours: "
        f"{est['wall_min']:.1f} min on {est['cores']} cores (run wall times only; worker start and solver builds "
        f"add seconds).", "",
    ]
    page = out / "README.md"
    page.write_text("\n".join(lines))
    return page
