"""``fcgen simulate``, ``campaign``, ``profiles``, ``report``: closed-loop runs (one, or the paper's grid) and the
artefacts made from their results."""

from __future__ import annotations

import sys
import warnings
from pathlib import Path

import click

from ..dsl import ProblemError
from ..presets import FORMULATIONS, OBSTACLES, SCENARIOS, load_problem, paper_problem
from .commonroad import campaign_cr_options, commonroad_campaign, simulate_commonroad, traffic_option
from .options import (
    cflags_option,
    delay_option,
    ego_circles_option,
    fail,
    fmt_summary,
    force_option,
    matched_for,
    names,
    out_dir_option,
    out_file_option,
    plant_line,
    plant_options,
    plant_spec,
    road_bound_option,
    same_bounds,
    samples_option,
    scenario_option,
    seed_option,
    seeds_option,
    simulate_chassis_options,
    with_chassis_options,
)
from .robust import robust_configs, robustness_options


@click.command()
@scenario_option("truck")
@click.option("--formulation", type=click.Choice(tuple(FORMULATIONS)), default="lifted", show_default=True)
@click.option("--obstacles", type=click.Choice(OBSTACLES), default="ellipse", show_default=True)
@click.option("--circles", type=click.IntRange(1, 20), default=None, help="number of covering circles")
@click.option(
    "--problem", "problem_spec", default=None, help="a preset name or a Python file (overrides the three above)"
)
@seed_option()
@samples_option()
@click.option(
    "--controller",
    type=click.Choice(["python", "c", "fmu"]),
    default="python",
    show_default=True,
    help="the Python reference, the compiled C library (--solver-dir) or an FMU through FMPy (--fmu)",
)
@click.option(
    "--solver-dir", type=click.Path(file_okay=False), default=None, help="generated solver folder (with --controller c)"
)
@click.option(
    "--fmu",
    "fmu_path",
    type=click.Path(dir_okay=False, exists=True),
    default=None,
    help="an FMU written by `fcgen fmu` (with --controller fmu; its problem unless --problem)",
)
@out_file_option("write the run log (JSON)")
@click.option("--plot", type=click.Path(dir_okay=False), default=None, help="write a picture of the run (PNG)")
@click.option(
    "--commonroad",
    "cr_file",
    type=click.Path(dir_okay=False, exists=True),
    default=None,
    help="a CommonRoad scenario (XML): its road, recorded traffic and ego start instead of the paper's "
    "random scenario (docs/commonroad.md); --samples then caps the scenario's own length",
)
@click.option(
    "--planning-problem",
    "cr_pp",
    type=int,
    default=None,
    help="with --commonroad: the planning problem's id (default: the file's first)",
)
@click.option(
    "--animate",
    type=click.Path(dir_okay=False),
    default=None,
    help="with --commonroad: write an animation of the run (.gif; .mp4 with ffmpeg on PATH)",
)
@click.option(
    "--solution",
    "cr_solution",
    type=click.Path(dir_okay=False),
    default=None,
    help="with --commonroad: write the ego's trajectory as a CommonRoad solution file (XML)",
)
@simulate_chassis_options
@plant_options
@traffic_option()
def simulate(
    scenario,
    formulation,
    obstacles,
    circles,
    problem_spec,
    seed,
    samples,
    controller,
    solver_dir,
    fmu_path,
    out,
    plot,
    cr_file,
    cr_pp,
    animate,
    cr_solution,
    road_bound,
    ego_circles,
    drive_power,
    traffic,
):
    """Run one randomized closed-loop scenario (paper section V), or a CommonRoad scenario, and print its summary."""
    from ..sim.closedloop import run_closed_loop
    from ..sim.runlog import summary
    from ..sim.scenario import make_scenario

    if cr_file and controller == "fmu":
        fail("--commonroad runs the Python reference or the C controller (--controller python|c), not an FMU")
    if controller == "fmu" and fmu_path is None:
        fail("--controller fmu needs --fmu (a file written by `fcgen fmu`)")
    if controller == "fmu" and not problem_spec:
        from ..fmu import fmu_problem

        pb = fmu_problem(fmu_path)
    else:
        pb = load_problem(problem_spec) if problem_spec else paper_problem(scenario, formulation, obstacles, circles)
    spec = plant_spec(commonroad=bool(cr_file), commonroad_plant=True)
    pb = matched_for(pb, spec, controller)
    pb = with_chassis_options(pb, road_bound, ego_circles, drive_power)
    ctrl = _controller(controller, pb, solver_dir, fmu_path)
    if cr_file:
        simulate_commonroad(pb, cr_file, cr_pp, samples, ctrl, out, plot, cr_solution, traffic, animate, spec)
        return
    if cr_pp is not None or cr_solution or animate or traffic != "recorded":
        fail("--planning-problem, --solution, --animate and --traffic go with --commonroad")
    sc = make_scenario(scenario, seed, n_opp=pb.opponents.count, samples=samples, dt=pb.horizon.dt)
    try:
        log = run_closed_loop(pb, sc, controller=ctrl, progress=sys.stderr.isatty(), plant=spec, exit_codes=True)
    except FloatingPointError as exc:  # the plant left its domain (sim.plants.commonroad_vm): a status, not a trace
        fail(f"the run stopped: {exc}")
    s = summary(log)
    click.echo(f"{pb.name} | {scenario} seed {seed} | {fmt_summary(s)}")
    ended = log.meta["extra"].get("ended_early")
    if ended:
        click.echo(f"the run ended after {ended['sample']} of {samples} samples: {ended['reason']}")
    if not spec.is_default:
        click.echo(plant_line(spec, log, pb.bounds.a_lat_max))
    if out:
        log.to_json(out)
        click.echo(f"run log written to {out}")
    if plot:
        from ..sim.plots import plot_run

        plot_run(log, plot, a_lat_max=pb.bounds.a_lat_max)
        click.echo(f"plot written to {plot}")


def _controller(controller: str, pb, solver_dir: str | None, fmu_path: str | None):
    """The C library of ``--solver-dir`` (built), an FMU through FMPy, or None: the Python reference."""
    if controller == "fmu":
        from ..fmu import FmuController, FmuError

        if fmu_path is None:
            fail("--controller fmu needs --fmu (an FMU written by `fcgen fmu`)")
        try:
            return FmuController(fmu_path, pb)
        except FmuError as exc:
            fail(str(exc))
    if controller == "c":
        from ..csolver import CSolver
        from ..solver_folder import read_folder

        if solver_dir is None:
            fail("--controller c needs --solver-dir (a folder written by `fcgen generate`)")
        folder = read_folder(solver_dir)
        if folder.problem.delay != pb.delay:  # the loop hands out the opponents from the plan's start
            fail(
                f"--solver-dir {solver_dir} compensates delay = {folder.problem.delay} samples, the problem "
                f"{pb.name!r} has delay = {pb.delay}: give --problem {Path(solver_dir) / 'problem.py'}"
            )
        same_bounds(folder.problem, pb, solver_dir)
        return CSolver.from_dir(folder)
    return None


@click.command()
@click.option("--scenarios", default="truck,car", show_default=True, help="comma-separated: truck, car")
@click.option("--formulations", default="conventional,direct_elimination,lifted", show_default=True)
@click.option(
    "--obstacles",
    "obstacle_list",
    default="ellipse,circles,hyperplane",
    show_default=True,
    help="comma-separated: ellipse, circles (the paper's C5/C7 trucks, C1/C3 cars), hyperplane, c<n>",
)
@seeds_option(100000, 20, "seeds FIRST .. FIRST+SEEDS-1")
@click.option("--first-seed", type=click.IntRange(0), default=0, show_default=True)
@samples_option()
@click.option(
    "--controller",
    type=click.Choice(["c", "python"]),
    default="c",
    show_default=True,
    help="compiled C solvers, or the Python reference SQP-RTI",
)
@click.option(
    "--backend",
    type=click.Choice(["osqp", "ipm"]),
    default="osqp",
    show_default=True,
    help="QP backend (QpOptions.backend)",
)
@click.option(
    "--clock",
    type=click.Choice(["cpu", "wall"]),
    default="cpu",
    show_default=True,
    help="what times the C solver: its thread's CPU time (unaffected by other processes on a shared "
    "machine) or the monotonic wall clock of its host hook",
)
@click.option(
    "--jobs",
    type=click.IntRange(1, 1024),
    default=2,
    show_default=True,
    help="local worker processes (or the workers of --scheduler local)",
)
@click.option(
    "--scheduler",
    default=None,
    help="a Dask scheduler address (tcp://host:8786), or 'local' for a "
    "LocalCluster of --jobs workers; default: a local process pool",
)
@click.option(
    "--cache",
    "cache_dir",
    type=click.Path(file_okay=False),
    default=".fcgen-cache/solvers",
    show_default=True,
    help="compiled solvers, one folder per problem hash",
)
@click.option(
    "--out",
    type=click.Path(),
    default="results/campaign",
    show_default=True,
    help="results: a Parquet dataset folder (runs already in it are not recomputed)",
)
@click.option(
    "--report",
    "report_dir",
    type=click.Path(file_okay=False),
    default=None,
    help="also write `fcgen report` into this folder",
)
@cflags_option(
    "C flags of the compiled solvers (default: $CFLAGS or -O2), e.g. "
    "'-O3 -march=native' (then every worker must be the build machine's CPU: use one cache per machine)"
)
@click.option("--force-report", is_flag=True, help="replace an existing report in the --report folder")
@click.option(
    "--profile",
    type=click.Choice(["paper", "safe"]),
    default="paper",
    show_default=True,
    help="the paper's settings (Table III) or the safe profile (docs/safe_profile.md); a seed's scenario "
    "is the same in both, so the two compare seed by seed (the same --out may hold both)",
)
@click.option(
    "--commonroad",
    "cr_dir",
    type=click.Path(file_okay=False, exists=True),
    default=None,
    help="run every CommonRoad scenario (*.xml) of this folder in every configuration instead of the seeds "
    "(rows, agreement of the collision checks and a summary into --out: docs/commonroad.md)",
)
@campaign_cr_options
@road_bound_option(
    "what the road band bounds in every configuration (Bounds.road_bound): the rear axle or the chassis' four "
    "corners; default: the presets' (rear_axle), but corners for --commonroad with --profile safe"
)
@ego_circles_option("the circles covering the ego in the ellipse's rows (Ellipse.n_ego) in its configurations")
@plant_options
@traffic_option()
@delay_option
@robustness_options
def campaign(
    scenarios,
    formulations,
    obstacle_list,
    seeds,
    first_seed,
    samples,
    controller,
    backend,
    clock,
    jobs,
    scheduler,
    cache_dir,
    out,
    report_dir,
    cflags,
    force_report,
    profile,
    cr_dir,
    scenario_list,
    criticality,
    road_bound,
    ego_circles,
    traffic,
    delay,
    **robust,
):
    """The paper's grid of randomized closed loops (Table III, Fig. 3), in parallel, resumable, into Parquet."""
    from ..atomic import check_folder_target
    from ..campaign.grid import grid_extras

    spec = plant_spec(commonroad=bool(cr_dir))
    with warnings.catch_warnings(record=True) as caught:  # printed once, after the runs (the workers warn the same)
        warnings.simplefilter("always")
        configs = _grid(
            scenarios,
            formulations,
            obstacle_list,
            controller,
            backend,
            profile,
            grid_extras(spec, delay, road_bound, ego_circles, bool(cr_dir), profile),
        )
    seed_range = range(first_seed, first_seed + seeds)
    configs = robust_configs(configs, spec, delay, seed_range, samples, jobs, (out, clock), **robust)  # its grid
    grid_warnings = [f"{w.category.__name__}: {w.message}" for w in caught]
    check_folder_target(out, "a campaign results folder")
    check_folder_target(cache_dir, "the compiled solvers' cache", option="--cache")
    if cr_dir:
        commonroad_campaign(configs, cr_dir, out, cache_dir, jobs, traffic, scheduler, scenario_list, criticality)
        if report_dir:
            from ..report.commonroad import write_cr_report

            click.echo(f"report written to {write_cr_report(out, report_dir, force=force_report)}")
        return
    if scenario_list or not criticality:
        fail("--scenario-list and --no-criticality go with --commonroad")
    if traffic != "recorded":
        fail("--traffic goes with --commonroad")
    if report_dir:
        from ..report.page import check_report_target

        check_report_target(report_dir, force_report)
    _seeded_campaign(
        configs,
        seed_range,
        samples,
        cache_dir,
        clock,
        cflags,
        out,
        jobs,
        scheduler,
        grid_warnings,
    )
    if report_dir:
        from ..report.page import write_report

        click.echo(f"report written to {write_report(out, report_dir, force=force_report)}")


def _grid(scenarios: str, formulations: str, obstacle_list: str, controller: str, backend: str, profile: str, pd=()):
    """The campaign's configurations; an unknown name or a backend this fcgen lacks fails before any worker starts."""
    from ..campaign.grid import paper_grid

    for f in names(formulations):
        if f not in FORMULATIONS:
            fail(f"--formulations: {f!r} is invalid: allowed {', '.join(FORMULATIONS)}")
    for s in names(scenarios):
        if s not in SCENARIOS:
            fail(f"--scenarios: {s!r} is invalid: allowed {', '.join(SCENARIOS)}")
    try:
        configs = paper_grid(
            names(scenarios), names(formulations), names(obstacle_list), controller, backend, profile, *pd
        )
        for c in configs:
            c.problem()  # a backend this fcgen lacks fails here, before any worker starts
    except ProblemError as exc:
        fail(f"--obstacles/--backend: {exc}")
    return configs


def _seeded_campaign(
    configs: list,
    seeds: range,
    samples: int,
    cache_dir: str,
    clock: str,
    cflags: str | None,
    out: str,
    jobs: int,
    scheduler: str | None,
    grid_warnings: list[str] = (),  # type: ignore[assignment]
) -> None:
    """The seeded runs into the Parquet store (resumable: SIGTERM stops like Ctrl-C, keeping the finished runs); then
    the warnings (each once) and a results table per configuration."""
    import signal

    from ..campaign.grid import make_tasks
    from ..campaign.runner import run_campaign
    from ..campaign.store import ResultStore

    store = ResultStore(out)
    tasks = make_tasks(configs, seeds, samples, str(Path(cache_dir).resolve()), clock, cflags=cflags)
    click.echo(
        f"{len(configs)} configurations x {len(seeds)} seeds x {samples} samples = {len(tasks)} runs "
        f"({'Dask ' + scheduler if scheduler else f'{jobs} local processes'}) -> {out}"
    )

    def _stop(signum, frame):  # SIGTERM (a batch system, kill): stop like Ctrl-C, keeping the finished runs
        raise KeyboardInterrupt

    signal.signal(signal.SIGTERM, _stop)
    try:
        res = run_campaign(tasks, out, jobs=jobs, scheduler=scheduler, progress=True)
    except KeyboardInterrupt:
        fail(f"interrupted: the finished runs are in {out}; run the same command again to resume")
    click.echo(
        f"{res.computed} runs computed, {res.skipped} already done, {len(res.failed)} failed; "
        f"{res.wall_s:.1f} s wall on {res.workers or jobs} workers; {res.time_split()}"
    )
    for msg in dict.fromkeys([*grid_warnings, *res.warnings]):
        click.echo(f"warning: {msg}", err=True)
    for run_id, msg in res.failed[:5]:
        click.echo(f"failed {run_id}: {msg}", err=True)
    if store.done():  # the short results table of the grid's runs (``fcgen report`` makes the full report)
        from ..campaign.summary import results_table

        click.echo(results_table(store.read(), tasks))
    if res.failed:
        fail(f"{len(res.failed)} run(s) failed; run the same command again to retry them")
    if {t.run_id for t in tasks} <= store.done() and store.needs_compact():
        store.compact()


@click.command()
@click.argument("paper", type=click.Path(exists=True, file_okay=False))
@click.argument("safe", type=click.Path(exists=True, file_okay=False))
@out_file_option("also write the table (Markdown) here")
def profiles(paper, safe, out):
    """The paper profile's campaign results (PAPER) against the safe profile's (SAFE), seed by seed."""
    from ..campaign.store import read_results
    from ..report.profiles import compare, markdown

    try:
        text = markdown(compare(read_results(paper), read_results(safe)))
    except (ValueError, KeyError) as exc:
        fail(f"profiles: {exc}")
    click.echo(text, nl=False)
    if out:
        from ..atomic import write_text

        write_text(out, text)
        click.echo(f"written to {out}")


@click.command()
@click.argument("results", type=click.Path(exists=True))
@out_dir_option("report folder", required=True)
@click.option("--no-example", is_flag=True, help="skip the Fig. 1-like picture (it re-simulates one run)")
@force_option("replace an existing report in OUT")
@click.option("--with", "more", multiple=True, type=click.Path(exists=True), help="another CommonRoad folder's rows")
def report(results, out_dir, no_example, force, more):
    """The paper's artefacts from campaign RESULTS: Table III, progress, box plots, Fig. 1, findings page (a
    CommonRoad campaign's folder: its outcomes, criticality, worst runs, planners side by side with --with's)."""
    from ..report.commonroad import is_commonroad, write_cr_report
    from ..report.page import write_report

    if more and not is_commonroad(results):
        fail("report: --with goes with a CommonRoad campaign's folder")
    if is_commonroad(results):
        try:
            path = write_cr_report(results, out_dir, force=force, more=more)
        except ValueError as exc:
            fail(f"report: {exc}")
    else:
        path = write_report(results, out_dir, example=not no_example, force=force)
    click.echo(f"report written to {path}")
