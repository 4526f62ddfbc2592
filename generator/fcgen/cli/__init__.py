"""The ``fcgen`` command: thin wrappers over the modules; bad input gives a one-line error, never a traceback.

One file per group of commands (each command a ``click.command`` added to ``main`` here); the options several
commands share are defined once in ``options``."""

from __future__ import annotations

import warnings

import click

from ..dsl import ProblemError
from ..extras import MissingExtra
from .generate import generate, regenerate
from .golden import record, regress
from .runs import campaign, profiles, report, simulate
from .solver import bench_cmd, build_cmd, firmware_sim_cmd, fmu_cmd, footprint_cmd, verify_cmd, wcet_cmd
from .start import demo, list_presets


class _Group(click.Group):
    """Turn the errors a user can cause into clean CLI errors."""

    def invoke(self, ctx):
        try:
            return super().invoke(ctx)
        except (ProblemError, ValueError, OSError, MissingExtra) as exc:
            raise click.ClickException(str(exc)) from None


@click.group(cls=_Group)
@click.version_option(package_name="fcgen")
def main() -> None:
    """fcgen: Frenet-Cartesian obstacle-avoidance NMPC -> static-memory embedded C solver."""
    warnings.simplefilter("default")


for _command in (
    simulate,
    campaign,
    profiles,
    report,
    generate,
    regenerate,
    build_cmd,
    verify_cmd,
    bench_cmd,
    wcet_cmd,
    firmware_sim_cmd,
    footprint_cmd,
    demo,
    fmu_cmd,
    record,
    regress,
    list_presets,
):
    main.add_command(_command)
