"""Fig. 3-style box plots (time per RTI, progress) per obstacle model and formulation, and a Fig. 1-like run.

matplotlib's object API on the Agg canvas (no pyplot), each figure written as PNG and SVG.
"""

from __future__ import annotations

from pathlib import Path

from ..extras import require
from .tables import FORM_LABEL, FORMS, _rti_times, groups

with require("plot", "the campaign's figures"):
    from matplotlib import rc_context
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure
    from matplotlib.patches import Patch

with require("campaign", "the campaign's report"):
    import pandas as pd

COLORS = {"conventional": "tab:gray", "direct_elimination": "tab:orange", "lifted": "tab:blue"}


def _save(fig: Figure, stem: Path) -> list[Path]:
    out = []
    for ext in ("png", "svg"):
        p = stem.with_suffix(f".{ext}")
        with rc_context({"svg.hashsalt": "fcgen"}):  # fixed SVG element ids: the same rows give the same files
            fig.savefig(p, dpi=120, metadata={"Date": None} if ext == "svg" else None)
        out.append(p)
    return out


def box_plots(df: pd.DataFrame, out_dir: Path, suffix: str = "") -> list[Path]:
    """One figure per scenario: time per RTI (every RTI) and final progress (every run), boxes per model x form;
    ``suffix`` (e.g. ``_ipm``) ends the file names and names the QP backend in the titles."""
    written = []
    for sc in dict.fromkeys(df["scenario"]):
        models = [m for s, m in groups(df) if s == sc]
        fig = Figure(figsize=(max(6.0, 2.2 * len(models)), 6.5), layout="constrained")
        FigureCanvasAgg(fig)
        ax_t, ax_p = fig.subplots(2, 1)
        width = 0.8 / len(FORMS)
        for j, form in enumerate(FORMS):
            pos, times, progs = [], [], []
            for i, model in enumerate(models):
                sub = df[(df["scenario"] == sc) & (df["model"] == model) & (df["formulation"] == form)]
                if not len(sub):
                    continue
                pos.append(i + (j - 1) * width)
                times.append(_rti_times(sub))
                progs.append(sub["progress"].to_numpy())
            if not pos:
                continue
            style = dict(
                positions=pos,
                widths=width * 0.9,
                patch_artist=True,
                manage_ticks=False,
                boxprops={"facecolor": COLORS[form], "alpha": 0.8},
                medianprops={"color": "k"},
            )
            parts = [
                ax_t.boxplot(times, showfliers=True, flierprops={"markersize": 2, "alpha": 0.3}, **style),
                ax_p.boxplot(progs, **style),
            ]
            for line in (f for b in parts for f in b["fliers"]):  # thousands of outliers: pixels, not SVG paths
                line.set_rasterized(True)
        for ax, label in ((ax_t, "time per RTI [ms]"), (ax_p, "progress after the run [m]")):
            ax.set_xticks(range(len(models)), models)
            ax.set_ylabel(label)
            ax.grid(True, axis="y", lw=0.3)
        ax_t.set_yscale("log")
        ctrl = "/".join(sorted(df[df["scenario"] == sc]["controller"].unique()))
        qp = f", QP backend {suffix.lstrip('_')}" if suffix else ""
        ax_t.set_title(f"{sc}-sized opponents: time per RTI ({ctrl} controller{qp})")
        ax_p.set_title(f"{sc}-sized opponents: final progress{qp}")
        ax_t.legend(handles=[Patch(color=COLORS[f], label=FORM_LABEL[f]) for f in FORMS], fontsize=8, loc="best")
        written += _save(fig, out_dir / f"boxplots_{sc}{suffix}")
    return written


def example_run(df: pd.DataFrame, out_dir: Path) -> list[Path]:
    """Fig. 1-like: the first run of the lifted ellipse configuration (else the first row), re-simulated with the
    Python reference (the same closed loop as the C solver), in both frames."""
    from ..campaign.grid import Config
    from ..sim.closedloop import run_closed_loop
    from ..sim.plots import plot_run
    from ..sim.scenario import make_scenario

    pick = df[(df["formulation"] == "lifted") & (df["model"] == "EL")]
    r = (pick if len(pick) else df).sort_values(["scenario", "seed"], ascending=[False, True]).iloc[0]
    cfg = Config(r["scenario"], r["formulation"], r["obstacles"], int(r["circles"]), "python", "osqp")
    pb = cfg.problem()
    log = run_closed_loop(
        pb,
        make_scenario(
            cfg.scenario, int(r["seed"]), n_opp=pb.opponents.count, samples=int(r["samples"]), dt=pb.horizon.dt
        ),
    )
    stem = out_dir / f"run_{cfg.scenario}_{cfg.formulation}_{cfg.model}_seed{int(r['seed'])}"
    return [plot_run(log, stem.with_suffix(ext), a_lat_max=pb.bounds.a_lat_max) for ext in (".png", ".svg")]
