"""``fcgen report RESULTS -o DIR``: tables, box plots, a Fig. 1-like run and a markdown page beside the paper's."""

from __future__ import annotations

from pathlib import Path

from ..atomic import carry, check_folder_target, describe, staged_folder
from ..campaign.store import read_results
from ..extras import require
from ..testhook import pause_point
from . import backends, figures, findings, robustness, tables

with require("campaign", "the campaign's report"):
    import pandas as pd

PAPER_RUNS_PER_CONFIG = 500
CLOCK_TEXT = {
    "cpu": "thread's CPU time (`--clock cpu`: other processes on the machine do not count)",
    "wall": "monotonic wall clock (`--clock wall`)",
}


def scale_rows(df: pd.DataFrame) -> list[dict]:
    """Runs per second per core per obstacle model: 1 / mean CPU time of a run (one worker process = one core),
    and 1 / mean wall time (which a loaded machine inflates)."""
    rows = []
    for (sc, model), sub in df.groupby(["scenario", "model"], sort=False):
        rows.append(
            {
                "scenario": sc,
                "model": model,
                "runs": len(sub),
                "cpu_mean_s": float(sub["cpu_s"].mean()),
                "wall_mean_s": float(sub["wall_s"].mean()),
                "runs_per_s_core": 1.0 / float(sub["cpu_s"].mean()),
                "runs_per_s_core_wall": 1.0 / float(sub["wall_s"].mean()),
            }
        )
    return rows


def busy_seconds(start, end) -> float:
    """Length of the union of the runs' [start, end] intervals: the time some worker was running a run (the gaps
    between two campaign calls, e.g. a resume, do not count)."""
    total, cur_s, cur_e = 0.0, None, None
    for s, e in sorted(zip(start, end)):
        if cur_e is None or s > cur_e:
            total += 0.0 if cur_e is None else cur_e - cur_s
            cur_s, cur_e = s, e
        else:
            cur_e = max(cur_e, e)
    return float(total + (0.0 if cur_e is None else cur_e - cur_s))


def grid_estimate(df: pd.DataFrame, cores: int = 2) -> dict:
    """The paper's full grid (500 runs per configuration present) on ``cores`` cores, from the measured CPU and wall
    times of a run, and the part of it the solver itself takes (its time per RTI x RTIs)."""
    g = df.groupby("config")
    runs = PAPER_RUNS_PER_CONFIG * g.ngroups
    cpu = PAPER_RUNS_PER_CONFIG * float(g["cpu_s"].mean().sum())
    wall = PAPER_RUNS_PER_CONFIG * float(g["wall_s"].mean().sum())
    solver = PAPER_RUNS_PER_CONFIG * float(
        (df["time_total_ms_mean"] * df["n_controls"] / 1e3).groupby(df["config"]).mean().sum()
    )
    span = busy_seconds(df["t_start"].to_numpy(), df["t_end"].to_numpy())
    return {
        "configs": g.ngroups,
        "runs": runs,
        "core_s": cpu,
        "core_s_wall": wall,
        "solver_core_s": solver,
        "wall_min": cpu / cores / 60.0,
        "wall_min_loaded": wall / cores / 60.0,
        "solver_min": solver / cores / 60.0,
        "cores": cores,
        "measured_runs": len(df),
        "measured_span_s": span,
        "measured_rate": len(df) / span if span > 0 else float("nan"),
        "workers": int(df["worker"].nunique()),
        "load": float(df["load_1min"].mean()) if "load_1min" in df else float("nan"),
    }


def _conv_note(df: pd.DataFrame) -> str:
    conv_fit = df[df["formulation"] == "conventional"]["n_opp_par"]
    if conv_fit.empty:
        return ""
    if int(conv_fit.iloc[0]) == 3:
        return (
            "The conventional solver takes the opponents' Cartesian poses and fits their Frenet boxes itself: its "
            "time per RTI includes the fitting."
        )
    return (
        "Note: the conventional solver here still takes the opponents' Frenet boxes fitted in Python, outside "
        "the timed solver, so its time per RTI is understated."
    )


def _tables(df: pd.DataFrame, tag: str = "", backend: str = "osqp") -> list[str]:
    """Table III, where the time goes, progress, findings and the soft constraint of rows of one QP backend;
    ``tag`` ends every heading (e.g. `` — QP backend ipm``)."""
    t_rows, p_rows, a_rows = tables.time_table(df), tables.progress_table(df), tables.alat_table(df)
    fs = findings.judge(t_rows, p_rows, backend=backend)
    return [
        f"## Table III: time per RTI (ms, mean ± std over every RTI), beside the paper's{tag}",
        "",
        tables.md_time_table(t_rows),
        "",
        _conv_note(df),
        "",
        "Where the time goes:",
        "",
        tables.md_time_detail(t_rows),
        "",
        f"## Progress and collisions{tag}",
        "",
        tables.md_progress_table(p_rows),
        "",
        f"## The paper's findings{tag}",
        "",
        findings.md_findings(fs),
        "",
        f"## Soft constraint: |a_lat| above its bound{tag}",
        "",
        tables.md_alat_table(a_rows),
        "",
    ]


def _rates(df: pd.DataFrame, tag: str = "") -> list[str]:
    """Runs per second per core per obstacle model and the full grid's estimate, of rows of one QP backend."""
    est = grid_estimate(df)
    return [
        f"## Rate and the full grid{tag}",
        "",
        "| scenario | model | runs | CPU per run s | runs/s per core (CPU) | wall per run s | runs/s per core (wall) |",
        "|---|---|---|---|---|---|---|",
        *[
            f"| {r['scenario']} | {r['model']} | {r['runs']} | {r['cpu_mean_s']:.3f} | {r['runs_per_s_core']:.2f} "
            f"| {r['wall_mean_s']:.3f} | {r['runs_per_s_core_wall']:.2f} |"
            for r in scale_rows(df)
        ],
        "",
        f"Measured: {est['measured_runs']} runs in {est['measured_span_s']:.0f} s of running time "
        f"({est['measured_rate']:.2f} runs/s; {est['workers']} worker processes over all campaign calls; the "
        f"machine's load average {est['load']:.1f}). "
        f"The paper's grid ({PAPER_RUNS_PER_CONFIG} runs x {est['configs']} configurations = {est['runs']} runs) "
        f"needs {est['core_s'] / 3600:.2f} CPU core-hours: **{est['wall_min']:.0f} min on {est['cores']} free "
        f"cores** ({est['wall_min_loaded']:.0f} min at the wall times measured here). Of that, the solver itself "
        f"(time per RTI x RTIs, by its {'/'.join(sorted(df['clock'].unique()))} clock) takes "
        f"{est['solver_min']:.0f} min.",
        "",
    ]


def _backend_comparison(df: pd.DataFrame, names: list[str]) -> list[str]:
    base = names[0]
    lines = ["## QP backend against QP backend", ""]
    for other in names[1:]:
        rows = backends.compare(df, base, other)
        lines += [
            backends.md_summary(backends.summary(rows), base, other),
            "",
            backends.md_compare(rows, base, other),
            "",
        ]
    return lines


def check_report_target(out_dir: str | Path, force: bool = False) -> None:
    """Fail (ValueError, one line) unless ``out_dir`` is a new or empty folder, or ``force`` (the report then
    replaces the files it writes; the folder's other files are kept)."""
    out = check_folder_target(out_dir, "a report folder", option="-o")
    if out.is_dir() and any(out.iterdir()) and not force:
        raise ValueError(
            f"-o {out}: holds {describe(out)}; a report would replace its README.md and figures; nothing "
            f"written: add --force (files the report does not write are kept) or choose a new folder"
        )


def write_report(results: str | Path, out_dir: str | Path, example: bool = True, force: bool = False) -> Path:
    """Write every artefact into ``out_dir``; returns the markdown page. Rows of several QP backends get every
    table, finding and figure per backend, and a backend-against-backend comparison.

    Written into a temporary folder swapped in when complete (``fcgen.atomic``); an existing non-empty ``out_dir``
    only with ``force``, and then its files that the report does not write are carried over."""
    check_report_target(out_dir, force)
    df = read_results(results)
    if "profile" in df.columns and df["profile"].fillna("paper").nunique() > 1:
        raise ValueError(
            f"results {str(results)!r} hold runs of several profiles "
            f"({', '.join(sorted(df['profile'].fillna('paper').unique()))}): a report is of one profile; "
            f"give each profile its own campaign --out, and compare them with `fcgen profiles`"
        )
    with staged_folder(out_dir) as tmp:
        _write_report(df, tmp, example)
        if Path(out_dir).is_dir():
            for p in Path(out_dir).iterdir():
                if not (tmp / p.name).exists():
                    carry(p, tmp / p.name)
        pause_point("report:before-swap")
    return Path(out_dir) / "README.md"


def _write_report(df: pd.DataFrame, out: Path, example: bool) -> Path:
    names = backends.backends_of(df)
    split = [(b, df[df["backend"] == b]) for b in names]
    many = len(names) > 1
    figs = []
    for b, sub in split:
        figs += figures.box_plots(sub, out, suffix=f"_{b}" if many else "")
    if example:
        figs += figures.example_run(df, out)
    grid = (
        df.groupby(["backend", "scenario", "samples"])
        .agg(configs=("config", "nunique"), runs=("seed", "size"), seeds=("seed", "nunique"))
        .reset_index()
    )
    grid = grid.sort_values("backend", key=lambda col: col.map(names.index), kind="stable")
    lines = [
        "# Campaign report",
        "",
        "Results: "
        + ", ".join(
            (f"{r.backend} " if many else "") + f"{r.scenario}: {r.configs} configurations x "
            f"{r.seeds} seeds x {r.samples} samples ({r.runs} runs)"
            for r in grid.itertuples()
        )
        + ".",
        f"Controllers: {', '.join(sorted(df['controller'].unique()))}; QP backend: "
        f"{', '.join(names)}; fcgen solver hashes: {df['solver_hash'].nunique()}; the "
        f"solver timed by its {' and '.join(CLOCK_TEXT[c] for c in sorted(df['clock'].unique()))}.",
        "",
    ]
    if many:
        lines += _backend_comparison(df, names)
    for b, sub in split:
        lines += _tables(sub, f" — QP backend {b}" if many else "", backend=b)
    lines += robustness.section(df)  # results of `fcgen campaign --robustness`: its section and plot
    figs += robustness.plot(df, out)
    lines += ["## Figures", "", *[f"![{p.stem}]({p.name})" for p in figs if p.suffix == ".png"], ""]
    for b, sub in split:
        lines += _rates(sub, f" — QP backend {b}" if many else "")
    page = out / "README.md"
    page.write_text("\n".join(lines))
    return page
