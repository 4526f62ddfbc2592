"""The ``fcgen`` command: thin wrappers over the modules; bad input gives a one-line error, never a traceback."""
from __future__ import annotations

import sys
import warnings
from pathlib import Path

import click

from .dsl import ProblemError
from .presets import FORMULATIONS, OBSTACLES, SCENARIOS, load_problem, paper_problem, preset_names
from .targets import TARGETS, get_target

_TARGET = click.option("--target", type=click.Choice(tuple(TARGETS)), default="host", show_default=True,
                       help="compilation target (fcgen.targets): host or an emulated Cortex-M")


def _fail(msg: str) -> None:
    raise click.ClickException(msg)


class _Group(click.Group):
    """Turn the errors a user can cause into clean CLI errors."""

    def invoke(self, ctx):
        try:
            return super().invoke(ctx)
        except (ProblemError, ValueError, OSError) as exc:
            raise click.ClickException(str(exc)) from None


@click.group(cls=_Group)
@click.version_option(package_name="fcgen")
def main() -> None:
    """fcgen: Frenet-Cartesian obstacle-avoidance NMPC -> static-memory embedded C solver."""
    warnings.simplefilter("default")


def _fmt_summary(s: dict) -> str:
    t = s["time_total_ms"]
    return (f"progress {s['progress']:.2f} m | collisions {s['n_collision_samples']} samples | "
            f"solver time mean {t['mean']:.2f} ms, median {t['median']:.2f} ms, max {t['max']:.2f} ms | "
            f"QP iterations mean {s['qp_iter_mean']:.0f}, max {s['qp_iter_max']} | "
            f"QP status {s['qp_status_counts']} | max slack {s['max_slack']:.3g} | "
            f"max |a_lat| {s['max_abs_a_lat']:.2f} m/s^2")


@main.command()
@click.option("--scenario", type=click.Choice(SCENARIOS), default="truck", show_default=True)
@click.option("--formulation", type=click.Choice(tuple(FORMULATIONS)), default="lifted", show_default=True)
@click.option("--obstacles", type=click.Choice(OBSTACLES), default="ellipse", show_default=True)
@click.option("--circles", type=click.IntRange(1, 20), default=None, help="number of covering circles")
@click.option("--problem", "problem_spec", default=None, help="a preset name or a Python file (overrides the three above)")
@click.option("--seed", type=click.IntRange(0), default=0, show_default=True)
@click.option("--samples", type=click.IntRange(1, 100000), default=200, show_default=True)
@click.option("--controller", type=click.Choice(["python", "c", "fmu"]), default="python", show_default=True,
              help="the Python reference, the compiled C library (--solver-dir) or an FMU through FMPy (--fmu)")
@click.option("--solver-dir", type=click.Path(file_okay=False), default=None,
              help="generated solver folder (with --controller c)")
@click.option("--fmu", "fmu_path", type=click.Path(dir_okay=False, exists=True), default=None,
              help="an FMU written by `fcgen fmu` (with --controller fmu; its problem unless --problem)")
@click.option("--out", type=click.Path(dir_okay=False), default=None, help="write the run log (JSON)")
@click.option("--plot", type=click.Path(dir_okay=False), default=None, help="write a picture of the run (PNG)")
@click.option("--commonroad", "cr_file", type=click.Path(dir_okay=False, exists=True), default=None,
              help="a CommonRoad scenario (XML): its road, recorded traffic and ego start instead of the paper's random "
              "scenario (docs/commonroad.md); --samples then caps the scenario's own length")
@click.option("--planning-problem", "cr_pp", type=int, default=None,
              help="with --commonroad: the planning problem's id (default: the file's first)")
@click.option("--solution", "cr_solution", type=click.Path(dir_okay=False), default=None,
              help="with --commonroad: write the ego's trajectory as a CommonRoad solution file (XML)")
def simulate(scenario, formulation, obstacles, circles, problem_spec, seed, samples, controller, solver_dir, fmu_path,
             out, plot, cr_file, cr_pp, cr_solution):
    """Run one randomized closed-loop scenario (paper section V), or a CommonRoad scenario, and print its summary."""
    from .sim.closedloop import run_closed_loop
    from .sim.runlog import summary
    from .sim.scenario import make_scenario

    if cr_file and controller == "fmu":
        _fail("--commonroad runs the Python reference or the C controller (--controller python|c), not an FMU")
    if controller == "fmu" and fmu_path is None:
        _fail("--controller fmu needs --fmu (a file written by `fcgen fmu`)")
    if controller == "fmu" and not problem_spec:
        from .fmu import fmu_problem
        pb = fmu_problem(fmu_path)
    else:
        pb = load_problem(problem_spec) if problem_spec else paper_problem(scenario, formulation, obstacles, circles)
    ctrl = None
    if controller == "fmu":
        from .fmu import FmuController, FmuError
        try:
            ctrl = FmuController(fmu_path, pb)
        except FmuError as exc:
            _fail(str(exc))
    if controller == "c":
        from .build import CSolver, build
        if solver_dir is None:
            _fail("--controller c needs --solver-dir (a folder written by `fcgen generate`)")
        ctrl = CSolver(build(Path(solver_dir)))
    if cr_file:
        _simulate_commonroad(pb, cr_file, cr_pp, samples, ctrl, out, plot, cr_solution)
        return
    if cr_pp is not None or cr_solution:
        _fail("--planning-problem and --solution go with --commonroad")
    sc = make_scenario(scenario, seed, n_opp=pb.opponents.count, samples=samples, dt=pb.horizon.dt)
    log = run_closed_loop(pb, sc, controller=ctrl, progress=sys.stderr.isatty())
    s = summary(log)
    click.echo(f"{pb.name} | {scenario} seed {seed} | {_fmt_summary(s)}")
    if out:
        log.to_json(out)
        click.echo(f"run log written to {out}")
    if plot:
        from .sim.plots import plot_run
        plot_run(log, plot)
        click.echo(f"plot written to {plot}")


def _simulate_commonroad(pb, cr_file, cr_pp, samples, ctrl, out, plot, solution) -> None:
    """``simulate --commonroad``: one CommonRoad scenario; its verdicts printed; a refused scenario: one line, exit 1."""
    from dataclasses import replace as dc_replace

    from .campaign.commonroad import load_for
    from .commonroad import ScenarioRefused, plot_run, write_solution
    from .sim.commonroad_run import run_commonroad
    from .sim.runlog import summary
    try:
        sc = load_for(pb, cr_file, cr_pp)
        if samples < sc.samples:
            sc = dc_replace(sc, samples=samples)
        run = run_commonroad(pb, sc, controller=ctrl, progress=sys.stderr.isatty())
    except ScenarioRefused as exc:
        _fail(f"refused: {exc}")
    log = run.log
    click.echo(f"{pb.name} | CommonRoad {sc.name} ({sc.samples} samples, v_ref {sc.v_ref:.1f} m/s) | "
               f"{_fmt_summary(summary(log))}")
    ck, own = run.checker, run.fcgen
    click.echo(f"collision: fcgen {_verdict(own)}, drivability checker {_verdict(ck)}"
               f"{'' if run.agree else ' (DISAGREE)'}; road departure (checker): "
               f"{_verdict({'collision': ck.get('road_departure'), 'collision_step': ck.get('departure_step')})}"
               + (f"; responsibility: {run.responsibility}" if run.responsibility else ""))
    if out:
        log.to_json(out)
        click.echo(f"run log written to {out}")
    if solution:
        write_solution(sc, run.ego_states, solution)
        click.echo(f"CommonRoad solution written to {solution}")
    if plot:
        plot_run(sc, run.ego_centres, plot)
        click.echo(f"plot written to {plot}")


def _verdict(v: dict) -> str:
    return f"yes (step {v.get('collision_step')})" if v.get("collision") else "none"


def _names(text: str) -> list[str]:
    return [x.strip() for x in text.split(",") if x.strip()]


@main.command()
@click.option("--scenarios", default="truck,car", show_default=True, help="comma-separated: truck, car")
@click.option("--formulations", default="conventional,direct_elimination,lifted", show_default=True)
@click.option("--obstacles", "obstacle_list", default="ellipse,circles,hyperplane", show_default=True,
              help="comma-separated: ellipse, circles (the paper's C5/C7 trucks, C1/C3 cars), hyperplane, c<n>")
@click.option("--seeds", type=click.IntRange(1, 100000), default=20, show_default=True,
              help="seeds FIRST .. FIRST+SEEDS-1")
@click.option("--first-seed", type=click.IntRange(0), default=0, show_default=True)
@click.option("--samples", type=click.IntRange(1, 100000), default=200, show_default=True)
@click.option("--controller", type=click.Choice(["c", "python"]), default="c", show_default=True,
              help="compiled C solvers, or the Python reference SQP-RTI")
@click.option("--backend", type=click.Choice(["osqp", "ipm"]), default="osqp", show_default=True,
              help="QP backend (QpOptions.backend)")
@click.option("--clock", type=click.Choice(["cpu", "wall"]), default="cpu", show_default=True,
              help="what times the C solver: its thread's CPU time (unaffected by other processes on a shared "
              "machine) or the monotonic wall clock of its host hook")
@click.option("--jobs", type=click.IntRange(1, 1024), default=2, show_default=True,
              help="local worker processes (or the workers of --scheduler local)")
@click.option("--scheduler", default=None, help="a Dask scheduler address (tcp://host:8786), or 'local' for a "
              "LocalCluster of --jobs workers; default: a local process pool")
@click.option("--cache", "cache_dir", type=click.Path(file_okay=False), default=".fcgen-cache/solvers",
              show_default=True, help="compiled solvers, one folder per problem hash")
@click.option("--out", type=click.Path(), default="results/campaign", show_default=True,
              help="results: a Parquet dataset folder (runs already in it are not recomputed)")
@click.option("--report", "report_dir", type=click.Path(file_okay=False), default=None,
              help="also write `fcgen report` into this folder")
@click.option("--cflags", default=None, help="C flags of the compiled solvers (default: $CFLAGS or -O2), e.g. "
              "'-O3 -march=native' (then every worker must be the build machine's CPU: use one cache per machine)")
@click.option("--force-report", is_flag=True, help="replace an existing report in the --report folder")
@click.option("--profile", type=click.Choice(["paper", "safe"]), default="paper", show_default=True,
              help="the paper's settings (Table III) or the safe profile (docs/safe_profile.md); a seed's scenario "
              "is the same in both, so the two compare seed by seed (the same --out may hold both)")
@click.option("--commonroad", "cr_dir", type=click.Path(file_okay=False, exists=True), default=None,
              help="run every CommonRoad scenario (*.xml) of this folder in every configuration instead of the seeds "
              "(rows, agreement of the collision checks and a summary into --out: docs/commonroad.md)")
def campaign(scenarios, formulations, obstacle_list, seeds, first_seed, samples, controller, backend, clock, jobs,
             scheduler, cache_dir, out, report_dir, cflags, force_report, profile, cr_dir):
    """The paper's grid of randomized closed loops (Table III, Fig. 3), in parallel, resumable, into Parquet."""
    from .campaign.grid import make_tasks, paper_grid
    from .campaign.runner import run_campaign
    from .campaign.store import ResultStore

    for f in _names(formulations):
        if f not in FORMULATIONS:
            _fail(f"--formulations: {f!r} is invalid: allowed {', '.join(FORMULATIONS)}")
    for s in _names(scenarios):
        if s not in SCENARIOS:
            _fail(f"--scenarios: {s!r} is invalid: allowed {', '.join(SCENARIOS)}")
    try:
        configs = paper_grid(_names(scenarios), _names(formulations), _names(obstacle_list), controller, backend,
                             profile)
        for c in configs:
            c.problem()  # a backend this fcgen lacks fails here, before any worker starts
    except ProblemError as exc:
        _fail(f"--obstacles/--backend: {exc}")
    from .atomic import check_folder_target
    check_folder_target(out, "a campaign results folder")
    check_folder_target(cache_dir, "the compiled solvers' cache", option="--cache")
    if cr_dir:
        from .campaign.commonroad import run_cr_campaign
        try:
            rows = run_cr_campaign(configs, cr_dir, out, str(Path(cache_dir).resolve()), jobs=jobs, echo=click.echo)
        except ValueError as exc:
            _fail(str(exc))
        ran = [r for r in rows if r["status"] == "ran"]
        click.echo(f"{len(ran)} runs, {len(rows) - len(ran)} refused; collisions fcgen {sum(r['collision_fcgen'] for r in ran)}, "
                   f"checker {sum(r['collision_checker'] for r in ran)}, agreement {sum(r['agree'] for r in ran)} of "
                   f"{len(ran)}; summary {Path(out) / 'commonroad.md'}")
        return
    if report_dir:
        from .report.page import check_report_target
        check_report_target(report_dir, force_report)
    store = ResultStore(out)
    tasks = make_tasks(configs, range(first_seed, first_seed + seeds), samples, str(Path(cache_dir).resolve()), clock,
                       cflags=cflags)
    click.echo(f"{len(configs)} configurations x {seeds} seeds x {samples} samples = {len(tasks)} runs "
               f"({'Dask ' + scheduler if scheduler else f'{jobs} local processes'}) -> {out}")
    import signal

    def _stop(signum, frame):  # SIGTERM (a batch system, kill): stop like Ctrl-C, keeping the finished runs
        raise KeyboardInterrupt
    signal.signal(signal.SIGTERM, _stop)
    try:
        res = run_campaign(tasks, out, jobs=jobs, scheduler=scheduler, progress=True)
    except KeyboardInterrupt:
        _fail(f"interrupted: the finished runs are in {out}; run the same command again to resume")
    rate = res.computed / res.wall_s if res.wall_s > 0 else 0.0
    click.echo(f"{res.computed} runs computed, {res.skipped} already done, {len(res.failed)} failed; "
               f"{res.wall_s:.1f} s wall, {rate:.2f} runs/s on {res.workers or jobs} workers")
    for run_id, msg in res.failed[:5]:
        click.echo(f"failed {run_id}: {msg}", err=True)
    if res.failed:
        _fail(f"{len(res.failed)} run(s) failed; run the same command again to retry them")
    if {t.run_id for t in tasks} <= store.done() and store.needs_compact():
        store.compact()
    if report_dir:
        from .report.page import write_report
        click.echo(f"report written to {write_report(out, report_dir, force=force_report)}")


@main.command()
@click.argument("paper", type=click.Path(exists=True, file_okay=False))
@click.argument("safe", type=click.Path(exists=True, file_okay=False))
@click.option("--out", type=click.Path(dir_okay=False), default=None, help="also write the table (Markdown) here")
def profiles(paper, safe, out):
    """The paper profile's campaign results (PAPER) against the safe profile's (SAFE), seed by seed."""
    from .campaign.store import read_results
    from .report.profiles import compare, markdown

    try:
        text = markdown(compare(read_results(paper), read_results(safe)))
    except (ValueError, KeyError) as exc:
        _fail(f"profiles: {exc}")
    click.echo(text, nl=False)
    if out:
        from .atomic import write_text
        write_text(out, text)
        click.echo(f"written to {out}")


@main.command()
@click.argument("results", type=click.Path(exists=True))
@click.option("-o", "--out", "out_dir", type=click.Path(file_okay=False), required=True, help="report folder")
@click.option("--no-example", is_flag=True, help="skip the Fig. 1-like picture (it re-simulates one run)")
@click.option("--force", is_flag=True, help="replace an existing report in OUT")
def report(results, out_dir, no_example, force):
    """The paper's artefacts from campaign RESULTS: Table III, progress, box plots, Fig. 1, findings page."""
    from .report.page import write_report

    path = write_report(results, out_dir, example=not no_example, force=force)
    click.echo(f"report written to {path}")


@main.command()
@click.argument("problem_spec", metavar="PROBLEM")
@click.option("-o", "--out", "out_dir", type=click.Path(file_okay=False), required=True,
              help="folder to write the solver into (created)")
@click.option("--float", "use_float", is_flag=True, help="single precision (float) instead of double")
@click.option("--force", is_flag=True, help="replace a different solver in OUT (its files are removed), or files of "
              "this solver edited since they were generated")
@click.option("--timeout", type=click.FloatRange(0, min_open=True), default=None, metavar="SECONDS",
              help="give up (exit 1, OUT untouched) if loading PROBLEM and generating take longer [default: no limit]")
def generate(problem_spec, out_dir, use_float, force, timeout):
    """Write the C solver of PROBLEM (a preset name or a Python file) into a self-contained folder."""
    from .atomic import TimeLimit, check_folder_target, time_limit
    from .codegen.generate import generate as gen

    check_folder_target(out_dir, "a solver folder", option="-o")
    try:
        with time_limit(timeout, f"{problem_spec}: loading the problem and generating took longer than --timeout "
                                 f"{timeout:g} s; nothing written to {out_dir}" if timeout else ""):
            pb = load_problem(problem_spec)
            info = gen(pb, out_dir, use_float=use_float, force=force)
    except TimeLimit as exc:
        _fail(str(exc))
    s = info.sizes
    click.echo(f"{info.name}: {pb.formulation.kind}, {pb.obstacles.kind}, N = {s['N']}, NX = {s['NX']}, "
               f"QP {s['QP_N']} variables x {s['QP_M']} rows, {s['QP_NNZ_A']} nonzeros in A")
    click.echo(f"workspace {info.workspace_bytes} bytes ({info.workspace_bytes / 1024:.1f} KiB; solver "
               f"{info.solver_workspace_bytes}, QP backend arrays {info.qp_array_bytes}, "
               f"structs {info.qp_struct_bytes}), const tables {info.const_bytes} bytes")
    click.echo(f"{len(info.files)} files written to {out_dir} (+ {len(info.library_files)} QP backend library files)")


@main.command()
@click.argument("root", type=click.Path(file_okay=False), default="generated")
@click.option("--check", is_flag=True, help="write nothing; fail if any file would change")
@click.option("--add", "add", default="", help="comma-separated preset names to add as new folders")
def regenerate(root, check, add):
    """Regenerate the checked-in solver folders ROOT/<preset> (byte-for-byte; --check compares only)."""
    from .codegen.regenerate import regenerate as regen

    names = [n.strip() for n in add.split(",") if n.strip()]
    res = regen(root, names, check=check)
    bad = {k: v for k, v in res.items() if v}
    for name, diffs in res.items():
        click.echo(f"{name}: " + ("; ".join(diffs[:10]) if diffs else ("identical" if check else "written")))
    if not res:
        _fail(f"{root}: no solver folders found")
    if bad:
        _fail(f"{len(bad)} folder(s) differ from what fcgen generates; run `fcgen regenerate {root}` and commit")


@main.command(name="build")
@click.argument("solver_dir", type=click.Path(file_okay=False, exists=True))
@click.option("--verify", is_flag=True, help="verification build: no floating-point contraction (-ffp-contract=off)")
@click.option("--cc", default=None, help="C compiler (default: $CC or cc)")
@click.option("--cflags", default=None, help="C flags (default: $CFLAGS or -O2; a target's CPU flags are appended)")
@_TARGET
def build_cmd(solver_dir, verify, cc, cflags, target):
    """Compile a generated folder: static libraries for firmware, a shared library for Python and the harness.

    With a bare-metal --target: the two static libraries alone, cross-compiled, in SOLVER_DIR/build/<target>."""
    from .build import BuildError, build

    try:
        lib = build(Path(solver_dir), verify=verify, cc=cc, cflags=cflags, target=target)
    except BuildError as exc:
        _fail(str(exc))
    products = sorted(p.name for p in lib.parent.iterdir()
                      if p.is_file() and (p.suffix in (".a", ".so") or p.name.endswith("_example")))
    click.echo(f"built {lib.parent}: {', '.join(products)}")


@main.command(name="verify")
@click.argument("solver_dir", type=click.Path(file_okay=False))
@click.option("--scenario", type=click.Choice(SCENARIOS), default=None,
              help="default: the problem's own (from its opponent vehicle)")
@click.option("--seed", type=click.IntRange(0), default=0, show_default=True)
@click.option("--samples", type=click.IntRange(1, 100000), default=200, show_default=True)
@click.option("--out", type=click.Path(dir_okay=False), default=None, help="write the report (JSON)")
def verify_cmd(solver_dir, scenario, seed, samples, out):
    """Compare a generated solver (verification build) with the Python reference, sample by sample."""
    from .build import BuildError
    from .verify import verify

    try:
        rep = verify(Path(solver_dir), scenario=scenario, seed=seed, samples=samples)
    except BuildError as exc:
        _fail(str(exc))
    click.echo(rep.format())
    if out:
        rep.to_json(out)
        click.echo(f"report written to {out}")
    if not rep.passed:
        _fail(f"verification failed: {len(rep.failures)} tolerance(s) broken")


@main.command(name="bench")
@click.argument("solver_dir", type=click.Path(file_okay=False))
@click.option("--scenario", type=click.Choice(SCENARIOS), default=None,
              help="default: the problem's own (from its opponent vehicle)")
@click.option("--seeds", type=click.IntRange(1, 10000), default=3, show_default=True, help="seeds 0 .. SEEDS-1")
@click.option("--samples", type=click.IntRange(1, 100000), default=200, show_default=True)
@click.option("--python/--no-python", "python", default=True, show_default=True,
              help="also run the Python reference for the same figures")
@click.option("--python-seeds", type=click.IntRange(1, 10000), default=None,
              help="run the Python reference on fewer seeds (default: all)")
@click.option("--cc", default=None, help="C compiler (default: $CC or cc)")
@click.option("--cflags", default=None, help="C flags (default: the Makefile's)")
@click.option("--out", type=click.Path(dir_okay=False), default=None,
              help="results file [default: results/bench_<name>[_<target>].json]")
@_TARGET
@click.option("--backends", default=None,
              help="compare QP backends in one run instead, e.g. osqp,osqp-converged,ipm (OSQP real-time, OSQP "
                   "converged, IPM): the folder's problem regenerated per backend under <dir>/build/variants")
@click.option("--clock", type=click.Choice(["wall", "cpu"]), default="wall", show_default=True,
              help="with --backends: time with the monotonic clock or the solver thread's CPU time (no preemption)")
@click.option("--force", is_flag=True, help="replace an existing results file")
def bench_cmd(solver_dir, scenario, seeds, samples, python, python_seeds, cc, cflags, out, target, backends, clock,
              force):
    """Closed-loop timing and quality of a generated solver (optimized build) and of the Python reference.

    With an emulated --target: instructions per prepare and feedback (median / max) from QEMU -icount; the default
    then is 1 seed (use --seeds, --samples). With --backends: several QP backends timed in one run."""
    from .bench import (BACKEND_VARIANTS, bench, bench_backends, bench_target, format_backends, format_bench,
                        format_bench_target, write_results)
    from .atomic import check_file_target
    from .build import BuildError, solver_name
    from .sim.export import HarnessError

    name = solver_name(Path(solver_dir))
    if out is None:
        out = (f"results/bench_{name}_{target}.json" if get_target(target).bare_metal else
               f"results/bench_backends_{name}.json" if backends is not None else f"results/bench_{name}.json")
    check_file_target(out, "a bench results file", force)
    click.echo(f"bench: results will be written to {out} (--out to choose)", err=True)
    if get_target(target).bare_metal:
        if backends is not None:
            _fail("--backends: not with an emulated --target (generate a folder per backend and bench each)")
        ctx = click.get_current_context()
        n_seeds = seeds if ctx.get_parameter_source("seeds").name != "DEFAULT" else 1
        try:
            res = bench_target(Path(solver_dir), target, scenario=scenario, seeds=n_seeds, samples=samples,
                               cflags=cflags)
        except HarnessError as exc:
            _fail(str(exc))
        click.echo(format_bench_target(res))
        path = write_results(res, out)
        click.echo(f"results written to {path}")
        return
    if backends is not None:
        variants = [v.strip() for v in backends.split(",") if v.strip()]
        bad = [v for v in variants if v not in BACKEND_VARIANTS]
        if bad or not variants:
            _fail(f"--backends: {', '.join(bad) or 'empty'} invalid; allowed a comma list of "
                  f"{', '.join(BACKEND_VARIANTS)}")
        try:
            res = bench_backends(Path(solver_dir), variants, scenario=scenario, seeds=seeds, samples=samples,
                                 cc=cc, cflags=cflags, progress=sys.stderr.isatty(), clock=clock)
        except BuildError as exc:
            _fail(str(exc))
        click.echo(format_backends(res))
        path = write_results(res, out)
        click.echo(f"results written to {path}")
        return
    try:
        res = bench(Path(solver_dir), scenario=scenario, seeds=seeds, samples=samples, python=python,
                    python_seeds=python_seeds, cc=cc, cflags=cflags, progress=sys.stderr.isatty())
    except BuildError as exc:
        _fail(str(exc))
    click.echo(format_bench(res))
    path = write_results(res, out)
    click.echo(f"results written to {path}")


@main.command(name="wcet")
@click.argument("solver_dir", type=click.Path(file_okay=False, exists=True))
@click.option("--target", type=click.Choice(tuple(t for t, v in TARGETS.items() if v.bare_metal)), required=True,
              help="the emulated Cortex-M (QEMU -icount shift=0: one instruction per ns)")
@click.option("--seeds", type=click.IntRange(1, 1000), default=3, show_default=True,
              help="probe runs: seeds 0 .. SEEDS-1 of the problem's scenario")
@click.option("--samples", type=click.IntRange(1, 20000), default=200, show_default=True,
              help="samples of every probe and validation run")
@click.option("--validate-seeds", type=click.IntRange(0, 1000), default=0, show_default=True,
              help="check the bound on the normal build's closed loops, seeds 0 .. K-1 (exit 1 if a sample exceeds it)")
@click.option("--cflags", default=None, help="C optimization flags (default -O2; the target's CPU flags are added)")
@click.option("--jobs", type=click.IntRange(1, 64), default=1, show_default=True, help="QEMU runs at a time")
@click.option("--timeout", type=click.FloatRange(min=1), default=None, help="seconds per QEMU run")
@click.option("--out", type=click.Path(dir_okay=False), default=None,
              help="results file [default: results/wcet_<name>_<target>.json]")
@click.option("--force", is_flag=True, help="replace an existing results file")
@click.option("--bound-scale", type=float, default=1.0, hidden=True,
              help="multiply the bound before the validation (tests: a bound too low must fail)")
def wcet_cmd(solver_dir, target, seeds, samples, validate_seeds, cflags, jobs, timeout, out, force, bound_scale):
    """Worst-case instructions of prepare, feedback and one RTI of SOLVER_DIR's build on an emulated --target.

    The bound: the solver's caps (the RTI budget's QP iterations, OSQP's termination checks, the conventional fit's
    scans) times each phase's worst path, measured by a probe build under QEMU (docs/wcet.md)."""
    from .atomic import check_file_target
    from .bench import write_results
    from .build import BuildError, solver_name
    from .sim.export import HarnessError
    from .wcet import BoundError, ProbeError, WcetError, format_wcet, wcet

    name = solver_name(Path(solver_dir))
    out = out or f"results/wcet_{name}_{target}.json"
    check_file_target(out, "a wcet results file", force)
    click.echo(f"wcet: results will be written to {out} (--out to choose)", err=True)
    try:
        res = wcet(Path(solver_dir), target, seeds=seeds, samples=samples, validate_seeds=validate_seeds,
                   cflags=cflags, timeout=timeout, jobs=jobs, bound_scale=bound_scale)
    except (HarnessError, BuildError, WcetError, BoundError, ProbeError) as exc:
        _fail(str(exc))
    click.echo(format_wcet(res))
    path = write_results(res, out)
    click.echo(f"results written to {path}")
    if res["validated"]["passed"] is False:
        over = res["validated"]["exceeding_samples"]
        _fail("validation failed: samples above the bound (" + ", ".join(f"{k} {v}" for k, v in over.items() if v)
              + f"); the bound is not an upper bound for this build: see {path}")


@main.command(name="firmware-sim")
@click.argument("solver_dir", type=click.Path(file_okay=False, exists=True))
@click.option("--scenario", type=click.Choice(SCENARIOS), default="truck", show_default=True)
@click.option("--seed", type=click.IntRange(0), default=0, show_default=True)
@click.option("--samples", type=click.IntRange(1, 20000), default=200, show_default=True)
@click.option("--out", type=click.Path(dir_okay=False), default="run.json", show_default=True,
              help="run log (JSON) the C harness writes")
@click.option("--verify", is_flag=True, help="use the verification build (bit-exact with the Python reference)")
@click.option("--cc", default=None, help="C compiler (default: $CC or cc)")
@click.option("--cflags", default=None, help="C flags (default: $CFLAGS or -O2)")
@_TARGET
@click.option("--compare-host", is_flag=True,
              help="also run the host harness on the same scenario and print the largest differences")
def firmware_sim_cmd(solver_dir, scenario, seed, samples, out, verify, cc, cflags, target, compare_host):
    """Closed loop in C (firmware_sim/): build SOLVER_DIR and the harness, export the scenario, run, summarize.

    With a bare-metal --target the harness is a semihosting image run under QEMU (-icount shift=0)."""
    from .sim.export import HarnessError, firmware_sim
    from .sim.runlog import compare, summary

    try:
        log = firmware_sim(Path(solver_dir), scenario, seed, samples, out, verify=verify, cc=cc, cflags=cflags,
                           target=target)
        host = None
        if compare_host:
            host_out = str(Path(out).with_suffix("")) + ".host.json"
            host = firmware_sim(Path(solver_dir), scenario, seed, samples, host_out, verify=verify)
    except HarnessError as exc:
        _fail(str(exc))
    click.echo(f"{log.meta['problem']} | {scenario} seed {seed} | C firmware_sim on {target} | "
               f"{_fmt_summary(summary(log))}")
    if get_target(target).qemu_machine:
        click.echo(f"(solver times on {target}: QEMU's virtual clock under -icount shift=0, 1 ns per instruction)")
    click.echo(f"run log written to {out}")
    if host is not None:
        d = {k: v for k, v in compare(log, host).items() if not k.startswith("time")}
        click.echo(f"{target} vs host (run log {host_out}), max abs differences: "
                   + ", ".join(f"{k} {v:.3g}" for k, v in d.items()))


@main.command(name="footprint")
@click.argument("solver_dir", type=click.Path(file_okay=False, exists=True))
@click.option("--target", type=click.Choice(tuple(TARGETS)), default="cortex-m7", show_default=True)
@click.option("--out", type=click.Path(dir_okay=False), default=None,
              help="JSON result [default: SOLVER_DIR/build/<target>/footprint/footprint.json]")
@click.option("--readme", is_flag=True, help="also write the figures into SOLVER_DIR/README.md (its Footprint section)")
def footprint_cmd(solver_dir, target, out, readme):
    """Flash, RAM and worst stack of the solver's libraries on a target, per object and in total."""
    from .build import BuildError
    from .footprint import fill_readme, footprint, format_footprint, write_footprint

    try:
        res = footprint(Path(solver_dir), target)
    except BuildError as exc:
        _fail(str(exc))
    click.echo(format_footprint(res))
    from .build import build_dir
    path = write_footprint(res, out or build_dir(Path(solver_dir), target=target, variant="footprint")
                           / "footprint.json")
    click.echo(f"results written to {path}")
    if readme:
        click.echo(f"figures written to {fill_readme(Path(solver_dir), res)}")


@main.command()
@click.option("--problem", "problem_name", default="truck_lifted_ellipse", show_default=True,
              help="a preset name (scenario from its prefix)")
@click.option("--seed", type=click.IntRange(0), default=3, show_default=True)
@click.option("--samples", type=click.IntRange(1, 100000), default=200, show_default=True)
@click.option("--out", "out_dir", type=click.Path(file_okay=False), default="runs/demo", show_default=True)
@click.option("--plot/--no-plot", default=True, show_default=True)
@click.option("--ipm/--no-ipm", default=True, show_default=True,
              help="also run the same problem with the IPM backend in C (one more column)")
@click.option("--safe/--no-safe", default=True, show_default=True,
              help="also run the same problem in the safe profile with the IPM in C, our recommended settings "
                   "(one more column)")
def demo(problem_name, seed, samples, out_dir, plot, ipm, safe):
    """The main job: generate, build, closed loop in the C harness vs the Python reference, summary."""
    from .demo import run_demo

    res = run_demo(out_dir, problem_name, seed, samples, plot, echo=click.echo, ipm=ipm, safe=safe)
    click.echo(res.format())
    if not res.matches:
        _fail("the generated C does not reproduce the Python reference within the tolerance")


@main.command(name="fmu")
@click.argument("solver_dir", type=click.Path(file_okay=False, exists=True))
@click.option("-o", "--out", required=True, type=click.Path(dir_okay=False), help="the FMU file to write (.fmu)")
@click.option("--fmi", type=click.Choice(["3", "2"]), default="3", show_default=True, help="FMI version")
@click.option("--force", is_flag=True, help="replace an existing file")
def fmu_cmd(solver_dir, out, fmi, force):
    """Package a generated solver folder as a co-simulation FMU (sources, a binary for this platform, docs)."""
    from .atomic import check_file_target
    from .build import BuildError
    from .fmu import FmuError, build_fmu

    check_file_target(out, "an FMU", force, option="-o")
    try:
        path = build_fmu(Path(solver_dir), Path(out), int(fmi))
    except (FmuError, BuildError) as exc:
        _fail(str(exc))
    click.echo(f"FMU (FMI {fmi}.0, co-simulation) written to {path} ({Path(path).stat().st_size:,} bytes)")


@main.command()
@click.argument("solver_dir", type=click.Path(file_okay=False), required=False)
@click.option("-o", "--out", "out_dir", type=click.Path(file_okay=False), default=None,
              help="suite folder to write (default: SOLVER_DIR/golden)")
@click.option("--scenario", type=click.Choice(SCENARIOS), default=None,
              help="default: the problem's own (from its opponent vehicle)")
@click.option("--seeds", default="0-19", show_default=True, help="a range A-B, a list A,B,C, or both")
@click.option("--samples", type=click.IntRange(1, 100000), default=200, show_default=True)
@click.option("--plan", type=click.Choice(("none", "controls", "full")), default="none", show_default=True,
              help="also log each sample's planned controls (controls, +~130 KiB per log) or controls and states "
                   "(full, +~650 KiB per log) for replay")
@click.option("--verify", is_flag=True, help="use the verification build (no floating-point contraction)")
@click.option("--timing/--no-timing", default=True, show_default=True, help="keep the timing fields (else zeros)")
@click.option("--cc", default=None, help="C compiler (default: $CC or cc)")
@click.option("--cflags", default=None, help="C flags (default: $CFLAGS or the Makefile's -O2)")
@click.option("--golden-for", "golden_root", type=click.Path(file_okay=False), default=None,
              help="re-record ROOT/<solver>/golden of every solver folder under ROOT with the checked-in goldens' "
                   "settings (2 seeds x 200 samples, verification build, planned controls, no timing)")
@click.option("--force", is_flag=True, help="replace an existing golden suite in the output folder")
@click.option("--commonroad", "cr_file", type=click.Path(dir_okay=False, exists=True), default=None,
              help="record the run on this CommonRoad scenario instead of the seeds (the suite keeps a copy of the "
              "file; `fcgen regress` runs it again)")
@click.option("--planning-problem", "cr_pp", type=int, default=None, help="with --commonroad: the planning problem")
def record(solver_dir, out_dir, scenario, seeds, samples, plan, verify, timing, cc, cflags, golden_root, force,
           cr_file, cr_pp):
    """Record a golden suite: the C controller's run logs on seeded scenarios plus a manifest."""
    from .build import BuildError
    from .suite import SuiteSettings, parse_seeds, record_goldens, record_suite

    try:
        if golden_root is not None:
            if solver_dir is not None or out_dir is not None:
                _fail("--golden-for ROOT records every folder under ROOT: give no SOLVER_DIR and no -o")
            for path in record_goldens(golden_root, echo=click.echo, force=force):
                click.echo(f"golden suite written to {path}")
            return
        if solver_dir is None:
            _fail("give SOLVER_DIR (a folder written by `fcgen generate`) or --golden-for ROOT")
        st = SuiteSettings(scenario=scenario, seeds=parse_seeds(seeds), samples=samples, plan=plan, verify=verify,
                           cc=cc, cflags=cflags, timing=timing, commonroad=cr_file, planning_problem=cr_pp)
        out = Path(out_dir) if out_dir else Path(solver_dir) / "golden"
        man = record_suite(Path(solver_dir), out, st, progress=sys.stderr.isatty(), force=force)
    except BuildError as exc:
        _fail(str(exc))
    except ValueError as exc:   # a CommonRoad scenario refused: one line
        if type(exc).__name__ != "ScenarioRefused":
            raise
        _fail(f"refused: {exc}")
    size = sum(p.stat().st_size for p in out.iterdir() if p.is_file())
    what = f"CommonRoad {cr_file}" if cr_file else f"seeds {seeds}"
    click.echo(f"{man['solver']}: {len(man['logs'])} run logs x {man['settings']['samples']} samples "
               f"({man['settings']['scenario']}, {what}, plan {plan}) written to {out}: {size / 1024:.1f} KiB")


@main.command()
@click.argument("new", type=click.Path())
@click.argument("golden", type=click.Path())
@click.option("--mode", type=click.Choice(("replay", "closed-loop")), default=None,
              help="for a solver folder NEW: replay the golden inputs (default) or run the closed loop again")
@click.option("--preset", default=None,
              help="tolerances: same-build, other-flags, other-compiler, host-vs-target, float-vs-double "
                   "[default: by precision]")
@click.option("--tol", "tols", multiple=True, metavar="FIELD=ABS,REL", help="override one field's tolerance")
@click.option("--timing", is_flag=True, help="also compare the timing fields")
@click.option("--controller", type=click.Choice(("c", "python")), default="c", show_default=True,
              help="for a solver folder NEW: its compiled C or its Python reference")
@click.option("--verify/--no-verify", default=None,
              help="build NEW without floating-point contraction or not [default: as the golden suite was built]")
@click.option("--cc", default=None, help="C compiler for NEW (default: $CC or cc)")
@click.option("--cflags", default=None, help="C flags for NEW (default: $CFLAGS or the Makefile's -O2)")
@click.option("--json", "json_out", type=click.Path(dir_okay=False), default=None, help="write the report (JSON)")
@click.option("--plot", type=click.Path(dir_okay=False), default=None, help="plot the divergence over time (PNG)")
def regress(new, golden, mode, preset, tols, timing, controller, verify, cc, cflags, json_out, plot):
    """Compare NEW (run log, suite or solver folder) with GOLDEN (run log or suite).

    Exit code 0: within tolerance, 1: out of tolerance, 2: unusable input.
    """
    from .build import BuildError
    from .regress import UnusableInput, parse_tol, regress as run

    try:
        overrides = dict(parse_tol(t) for t in tols)
        rep = run(Path(new), Path(golden), mode=mode, preset=preset, tol=overrides, timing=timing,
                  controller=controller, build_kw={"verify": verify, "cc": cc, "cflags": cflags},
                  progress=sys.stderr.isatty())
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


@main.command(name="presets")
def list_presets() -> None:
    """List the preset problems (one name a line on stdout; what the names mean on stderr)."""
    for n in preset_names():
        click.echo(n)
    click.echo("Each is the paper's configuration <scenario>_<formulation>_<obstacle model> with the paper's settings, "
               "with OSQP. Append _ipm for the same problem with the IPM backend (truck_lifted_ellipse_ipm), then "
               "_safe for our safe profile (truck_lifted_ellipse_ipm_safe: obstacle shapes that contain the true "
               "rectangles, exact penalties, the plan check's braking; docs/safe_profile.md). A problem of your own "
               "(Problem(...)) gets the safe profile's settings by default.", err=True)


if __name__ == "__main__":  # pragma: no cover
    main()
