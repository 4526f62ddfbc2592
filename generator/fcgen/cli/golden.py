"""``fcgen record`` and ``regress``: golden suites of a compiled solver's run logs, and the comparison of new run
logs, suites or a solver folder with them."""

from __future__ import annotations

import sys
from pathlib import Path

import click

from .commonroad import traffic_option
from .options import (
    cc_option,
    cflags_option,
    fail,
    force_option,
    out_dir_option,
    plant_options,
    plant_options_given,
    plant_spec,
    samples_option,
    scenario_option,
    solver_dir_argument,
)


@click.command()
@solver_dir_argument(exists=False, required=False)
@out_dir_option("suite folder to write (default: SOLVER_DIR/golden)")
@scenario_option()
@click.option("--seeds", default="0-19", show_default=True, help="a range A-B, a list A,B,C, or both")
@samples_option()
@click.option(
    "--plan",
    type=click.Choice(("none", "controls", "full")),
    default="none",
    show_default=True,
    help="also log each sample's planned controls (controls, +~130 KiB per log) or controls and states "
    "(full, +~650 KiB per log) for replay",
)
@click.option("--verify", is_flag=True, help="use the verification build (no floating-point contraction)")
@click.option("--timing/--no-timing", default=True, show_default=True, help="keep the timing fields (else zeros)")
@cc_option()
@cflags_option("C flags (default: $CFLAGS or the Makefile's -O2)")
@click.option(
    "--golden-for",
    "golden_root",
    type=click.Path(file_okay=False),
    default=None,
    help="re-record ROOT/<solver>/golden of every solver folder under ROOT with the checked-in goldens' "
    "settings (2 seeds x 200 samples, verification build, planned controls, no timing) and each suite's plant "
    "and perturbations, or the ones the plant options give",
)
@force_option("replace an existing golden suite in the output folder")
@click.option(
    "--commonroad",
    "cr_file",
    type=click.Path(dir_okay=False, exists=True),
    default=None,
    help="record the run on this CommonRoad scenario instead of the seeds (the suite keeps a copy of the "
    "file; `fcgen regress` runs it again)",
)
@click.option("--planning-problem", "cr_pp", type=int, default=None, help="with --commonroad: the planning problem")
@plant_options
@traffic_option()
def record(
    solver_dir,
    out_dir,
    scenario,
    seeds,
    samples,
    plan,
    verify,
    timing,
    cc,
    cflags,
    golden_root,
    force,
    cr_file,
    cr_pp,
    traffic,
):
    """Record a golden suite: the C controller's run logs on seeded scenarios plus a manifest."""
    from ..build import BuildError
    from ..suite import SuiteSettings, parse_seeds, record_goldens, record_suite

    spec = plant_spec()
    if spec.params == "matched":
        fail("--plant-params matched sets the controller's wheelbase and mass: generate the solver from that problem")
    if not spec.is_default and cr_file:
        fail("--commonroad records fcgen's own plant (no --plant, --latency, --steer-lag, --noise)")
    try:
        if golden_root is not None:
            if solver_dir is not None or out_dir is not None:
                fail("--golden-for ROOT records every folder under ROOT: give no SOLVER_DIR and no -o")
            given = spec if plant_options_given() else None  # None: each suite keeps its own
            for path in record_goldens(golden_root, echo=click.echo, force=force, plant=given):
                click.echo(f"golden suite written to {path}")
            return
        if traffic != "recorded" and not cr_file:
            fail("--traffic goes with --commonroad")
        if solver_dir is None:
            fail("give SOLVER_DIR (a folder written by `fcgen generate`) or --golden-for ROOT")
        st = SuiteSettings(
            scenario=scenario,
            seeds=parse_seeds(seeds),
            samples=samples,
            plan=plan,
            verify=verify,
            cc=cc,
            cflags=cflags,
            timing=timing,
            commonroad=cr_file,
            planning_problem=cr_pp,
            traffic=traffic,
            plant=spec,
        )
        out = Path(out_dir) if out_dir else Path(solver_dir) / "golden"
        man = record_suite(solver_dir, out, st, progress=sys.stderr.isatty(), force=force)  # read once there
    except BuildError as exc:
        fail(str(exc))
    except ValueError as exc:  # a CommonRoad scenario refused: one line
        if type(exc).__name__ != "ScenarioRefused":
            raise
        fail(f"refused: {exc}")
    size = sum(p.stat().st_size for p in out.iterdir() if p.is_file())
    what = f"CommonRoad {cr_file}" if cr_file else f"seeds {seeds}"
    click.echo(
        f"{man['solver']}: {len(man['logs'])} run logs x {man['settings']['samples']} samples "
        f"({man['settings']['scenario']}, {what}, plan {plan}) written to {out}: {size / 1024:.1f} KiB"
    )


@click.command()
@click.argument("new", type=click.Path())
@click.argument("golden", type=click.Path())
@click.option(
    "--mode",
    type=click.Choice(("replay", "closed-loop")),
    default=None,
    help="for a solver folder NEW: replay the golden inputs or run the closed loop again [default: replay; a "
    "golden log of a perturbed run: closed-loop, with its recorded plant and perturbations]",
)
@click.option(
    "--preset",
    default=None,
    help="tolerances: same-build, other-flags, other-compiler, host-vs-target, float-vs-double [default: by precision]",
)
@click.option("--tol", "tols", multiple=True, metavar="FIELD=ABS,REL", help="override one field's tolerance")
@click.option("--timing", is_flag=True, help="also compare the timing fields")
@click.option(
    "--controller",
    type=click.Choice(("c", "python")),
    default="c",
    show_default=True,
    help="for a solver folder NEW: its compiled C or its Python reference",
)
@click.option(
    "--verify/--no-verify",
    default=None,
    help="build NEW without floating-point contraction or not [default: as the golden suite was built]",
)
@cc_option("C compiler for NEW (default: $CC or cc)")
@cflags_option("C flags for NEW (default: $CFLAGS or the Makefile's -O2)")
@click.option("--json", "json_out", type=click.Path(dir_okay=False), default=None, help="write the report (JSON)")
@click.option("--plot", type=click.Path(dir_okay=False), default=None, help="plot the divergence over time (PNG)")
@plant_options
@traffic_option(None, " [default: as the golden log was recorded]")
def regress(
    new,
    golden,
    mode,
    preset,
    tols,
    timing,
    controller,
    verify,
    cc,
    cflags,
    json_out,
    plot,
    traffic,
):
    """Compare NEW (run log, suite or solver folder) with GOLDEN (run log or suite).

    Exit code 0: within tolerance, 1: out of tolerance, 2: unusable input. With ``--mode closed-loop`` the plant
    options give the plant and perturbations (default: what each golden log records).
    """
    from ..build import BuildError
    from ..regress import UnusableInput, parse_tol
    from ..regress import regress as run

    spec = plant_spec()
    if not spec.is_default and mode != "closed-loop":
        fail("--plant, --latency, --steer-lag and --noise go with --mode closed-loop")
    if spec.params == "matched":
        fail("--plant-params matched sets the controller's wheelbase and mass: generate the solver from that problem")
    try:
        overrides = dict(parse_tol(t) for t in tols)
        rep = run(
            Path(new),
            Path(golden),
            mode=mode,
            preset=preset,
            tol=overrides,
            timing=timing,
            controller=controller,
            build_kw={"verify": verify, "cc": cc, "cflags": cflags},
            progress=sys.stderr.isatty(),
            plant=None if spec.is_default else spec,
            traffic=traffic,
        )
    except (UnusableInput, BuildError) as exc:
        click.echo(f"Error: {str(exc).splitlines()[0]}", err=True)
        sys.exit(2)
    click.echo(rep.format())
    if json_out:
        rep.to_json(json_out)
        click.echo(f"report written to {json_out}")
    if plot:
        rep.plot(plot)
        click.echo(f"plot written to {plot}")
    sys.exit(rep.exit_code)
