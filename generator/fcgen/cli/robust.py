"""``fcgen campaign --robustness``: its options and the grid it runs instead of the configurations (docs/plants.md,
"The robustness campaign"), refused above a time budget without ``--yes``."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import click

from .options import fail, names


def robustness_options(f: Callable[..., Any]) -> Callable[..., Any]:
    """``--robustness``, ``--axes``, ``--budget``, ``--yes``."""
    from ..campaign.robustness import AXES

    opts = [
        click.option(
            "--robustness",
            is_flag=True,
            help="run every configuration unperturbed and under each perturbation of --axes at growing magnitudes "
            "(plant st/std, latency 1-3 with and without compensation, noise 1x/2x/4x, steering lag 0.1/0.2 s, "
            "predictions, the combined worst cases)",
        ),
        click.option(
            "--axes",
            default=",".join(AXES),
            show_default=True,
            help=f"the robustness grid's axes: comma-separated of {', '.join(AXES)}",
        ),
        click.option(
            "--budget",
            type=click.FloatRange(0.0, min_open=True),
            default=60.0,
            show_default=True,
            help="minutes: a robustness grid estimated to take longer needs --yes",
        ),
        click.option("--yes", is_flag=True, help="run a robustness grid estimated to take longer than --budget"),
    ]
    for o in reversed(opts):
        f = o(f)
    return f


def _done(grid: list, seeds: range, samples: int, out: str, clock: str) -> set:
    """The (config key, seed) pairs of the grid whose runs are already in the results folder ``out``."""
    from pathlib import Path

    from ..campaign.grid import Task
    from ..campaign.store import ResultStore

    if not Path(out).is_dir():
        return set()
    ids = ResultStore(out).done()
    return {(c.key, s) for c in grid for s in seeds if Task(c, s, samples, "", clock).run_id in ids}


def robust_configs(configs: list, spec, delay: int, seeds: range, samples: int, jobs: int, run: tuple, **robust):
    """``configs`` (no ``--robustness``) or the robustness grid over them; bad axes, plant options given beside
    ``--robustness`` or an estimate above ``--budget`` without ``--yes``: one line, exit 1. The estimate counts the
    runs not yet in the results folder (``run``: its path and the clock)."""
    if not robust["robustness"]:
        return configs
    from ..campaign.robustness import AXES, estimated_minutes, robustness_grid
    from ..dsl import ProblemError

    if not spec.is_default or delay:
        fail("--robustness sets the plant, latency, noise, steering lag, prediction and --delay itself: leave them out")
    try:
        grid = robustness_grid(configs, tuple(names(robust["axes"])))
    except ProblemError:
        fail(f"--axes: {robust['axes']!r} is invalid: allowed comma-separated of {', '.join(AXES)}")
    done = _done(grid, seeds, samples, *run)
    left = len(grid) * len(seeds) - len(done)
    est = estimated_minutes(grid, seeds, samples, jobs, done)
    what = f"{len(grid)} configurations x {len(seeds)} seeds ({left} runs not yet in --out)"
    if est > robust["budget"] and not robust["yes"]:
        fail(
            f"--robustness: {what} are estimated at {est:.0f} min on {jobs} jobs, above --budget "
            f"{robust['budget']:g} min: pass --yes, or fewer --seeds, --axes or configurations"
        )
    click.echo(f"robustness grid: {what}, estimated {est:.1f} min on {jobs} jobs")
    return grid
