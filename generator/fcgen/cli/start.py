"""``fcgen demo`` and ``presets``: the main job in one command, and the problems it can start from."""

from __future__ import annotations

import click

from ..presets import preset_names
from .options import fail, samples_option, seed_option


@click.command()
@click.option(
    "--problem",
    "problem_name",
    default="truck_lifted_ellipse",
    show_default=True,
    help="a preset name (scenario from its prefix)",
)
@seed_option(3)
@samples_option()
@click.option("--out", "out_dir", type=click.Path(file_okay=False), default="runs/demo", show_default=True)
@click.option("--plot/--no-plot", default=True, show_default=True)
@click.option(
    "--ipm/--no-ipm",
    default=True,
    show_default=True,
    help="also run the same problem with the IPM backend in C (one more column)",
)
@click.option(
    "--safe/--no-safe",
    default=True,
    show_default=True,
    help="also run the same problem in the safe profile with the IPM in C, our recommended settings (one more column)",
)
def demo(problem_name, seed, samples, out_dir, plot, ipm, safe):
    """The main job: generate, build, closed loop in the C harness vs the Python reference, summary."""
    from ..demo import run_demo

    res = run_demo(out_dir, problem_name, seed, samples, plot, echo=click.echo, ipm=ipm, safe=safe)
    click.echo(res.format())
    if not res.matches:
        fail("the generated C does not reproduce the Python reference within the tolerance")


@click.command(name="presets")
def list_presets() -> None:
    """List the preset problems (one name a line on stdout; what the names mean on stderr)."""
    for n in preset_names():
        click.echo(n)
    click.echo(
        "Each is the paper's configuration <scenario>_<formulation>_<obstacle model> with the paper's settings, "
        "with OSQP. Append _ipm for the same problem with the IPM backend (truck_lifted_ellipse_ipm), and "
        "_safe (after _ipm, if any) for our safe profile (truck_lifted_ellipse_ipm_safe, with OSQP "
        "truck_lifted_ellipse_safe: obstacle shapes that contain the true rectangles, exact penalties, the plan "
        "check's braking; docs/safe_profile.md). A problem of your own (Problem(...)) gets the safe profile's "
        "settings by default.",
        err=True,
    )
