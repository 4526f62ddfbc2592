"""What several ``fcgen`` commands share: their common options (defined once), the one-line failure, the summary
line of a closed loop."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any, NoReturn

import click

from ..presets import SCENARIOS
from ..targets import TARGETS

OWN_SCENARIO = "default: the problem's own (from its opponent vehicle)"
CC_HELP = "C compiler (default: $CC or cc)"

Decorator = Callable[[Callable[..., Any]], Callable[..., Any]]


def fail(msg: str) -> NoReturn:
    """End the command with ``Error: msg`` (exit 1), never a traceback."""
    raise click.ClickException(msg)


def _option(*decls: str, **attrs: Any) -> Decorator:
    """``click.option`` without the attributes left at None (so that each option is declared exactly as before)."""
    return click.option(*decls, **{k: v for k, v in attrs.items() if v is not None})


def solver_dir_argument(exists: bool = False, required: bool = True) -> Decorator:
    """SOLVER_DIR: a folder written by ``fcgen generate`` (a missing one is refused by ``read_folder``, which says
    the command that writes one)."""
    return click.argument("solver_dir", type=click.Path(file_okay=False, exists=exists), required=required)


def target_option(default: str | None = "host", bare_metal_only: bool = False, help: str | None = None) -> Decorator:
    """``--target``: a name of ``fcgen.targets`` (host or an emulated Cortex-M); ``default=None``: required."""
    names = tuple(t for t, v in TARGETS.items() if v.bare_metal or not bare_metal_only)
    if default is None:
        return _option("--target", type=click.Choice(names), required=True, help=help)
    return _option("--target", type=click.Choice(names), default=default, show_default=True, help=help)


TARGET = target_option(help="compilation target (fcgen.targets): host or an emulated Cortex-M")


def scenario_option(default: str | None = None) -> Decorator:
    """``--scenario``: truck or car; without a default, the problem's own."""
    if default is None:
        return click.option("--scenario", type=click.Choice(SCENARIOS), default=None, help=OWN_SCENARIO)
    return click.option("--scenario", type=click.Choice(SCENARIOS), default=default, show_default=True)


def seed_option(default: int = 0) -> Decorator:
    return click.option("--seed", type=click.IntRange(0), default=default, show_default=True)


def seeds_option(most: int, default: int, help: str) -> Decorator:
    """``--seeds``: how many seeds (from 0, or from ``--first-seed``)."""
    return click.option("--seeds", type=click.IntRange(1, most), default=default, show_default=True, help=help)


def samples_option(most: int = 100000, help: str | None = None) -> Decorator:
    return _option("--samples", type=click.IntRange(1, most), default=200, show_default=True, help=help)


def cc_option(help: str = CC_HELP) -> Decorator:
    return click.option("--cc", default=None, help=help)


def cflags_option(help: str) -> Decorator:
    return click.option("--cflags", default=None, help=help)


def force_option(help: str) -> Decorator:
    return click.option("--force", is_flag=True, help=help)


def out_file_option(help: str, default: str | None = None) -> Decorator:
    """``--out FILE`` (a result written by the command)."""
    return _option(
        "--out", type=click.Path(dir_okay=False), default=default, show_default=True if default else None, help=help
    )


def out_dir_option(help: str, required: bool = False) -> Decorator:
    """``-o/--out DIR`` (the folder a command writes)."""
    return _option("-o", "--out", "out_dir", type=click.Path(file_okay=False), required=required or None, help=help)


def fmt_summary(s: dict) -> str:
    """One line of a run log's summary (``fcgen.sim.runlog.summary``)."""
    t = s["time_total_ms"]
    return (
        f"progress {s['progress']:.2f} m | collisions {s['n_collision_samples']} samples | "
        f"solver time mean {t['mean']:.2f} ms, median {t['median']:.2f} ms, max {t['max']:.2f} ms | "
        f"QP iterations mean {s['qp_iter_mean']:.0f}, max {s['qp_iter_max']} | "
        f"QP status {s['qp_status_counts']} | max slack {s['max_slack']:.3g}{_unsolved(s)} | "
        f"max |a_lat| {s['max_abs_a_lat']:.2f} m/s^2"
    )


def _unsolved(s: dict) -> str:
    """`` (N samples without a solution: CODE xM, ...)`` when the run has such samples (their slack is not finite)."""
    n = s.get("samples_unsolved", 0)
    if not n:
        return ""
    codes = ", ".join(f"{k} x{v}" for k, v in s.get("unsolved_exit_codes", {}).items())
    return f" over the solved samples ({n} without a solution: {codes})"


def names(text: str) -> list[str]:
    """The names of a comma-separated option value."""
    return [x.strip() for x in text.split(",") if x.strip()]
