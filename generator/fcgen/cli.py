"""The ``fcgen`` command: thin wrappers over the modules; bad input gives a one-line error, never a traceback."""
from __future__ import annotations

import json
import sys
import warnings
from pathlib import Path

import click

from .dsl import ProblemError
from .presets import FORMULATIONS, OBSTACLES, SCENARIOS, load_problem, paper_problem, preset_names


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
@click.option("--controller", type=click.Choice(["python", "c"]), default="python", show_default=True)
@click.option("--solver-dir", type=click.Path(file_okay=False), default=None,
              help="generated solver folder (with --controller c)")
@click.option("--out", type=click.Path(dir_okay=False), default=None, help="write the run log (JSON)")
@click.option("--plot", type=click.Path(dir_okay=False), default=None, help="write a picture of the run (PNG)")
def simulate(scenario, formulation, obstacles, circles, problem_spec, seed, samples, controller, solver_dir, out, plot):
    """Run one randomized closed-loop scenario (paper section V) and print its summary."""
    from .sim.closedloop import run_closed_loop
    from .sim.runlog import summary
    from .sim.scenario import make_scenario

    pb = load_problem(problem_spec) if problem_spec else paper_problem(scenario, formulation, obstacles, circles)
    sc = make_scenario(scenario, seed, n_opp=pb.opponents.count, samples=samples, dt=pb.horizon.dt)
    ctrl = None
    if controller == "c":
        from .build import CSolver, build
        if solver_dir is None:
            _fail("--controller c needs --solver-dir (a folder written by `fcgen generate`)")
        ctrl = CSolver(build(Path(solver_dir)))
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


@main.command()
@click.option("--scenario", type=click.Choice(SCENARIOS), default="truck", show_default=True)
@click.option("--formulations", default="conventional,direct_elimination,lifted", show_default=True)
@click.option("--obstacles", "obstacle_list", default="ellipse", show_default=True,
              help="comma-separated: ellipse, circles, hyperplane")
@click.option("--circles", type=click.IntRange(1, 20), default=None)
@click.option("--seeds", type=click.IntRange(1, 10000), default=20, show_default=True)
@click.option("--samples", type=click.IntRange(1, 100000), default=200, show_default=True)
@click.option("--out", type=click.Path(dir_okay=False), default="results/campaign.json", show_default=True)
def campaign(scenario, formulations, obstacle_list, circles, seeds, samples, out):
    """Randomized runs per (formulation, obstacle model): the paper's Table III and progress, as a table."""
    from .sim.campaign import format_table, run_campaign

    forms = [f.strip() for f in formulations.split(",") if f.strip()]
    obsl = [o.strip() for o in obstacle_list.split(",") if o.strip()]
    for f in forms:
        if f not in FORMULATIONS:
            _fail(f"--formulations: {f!r} is invalid: allowed {', '.join(FORMULATIONS)}")
    for o in obsl:
        if o not in OBSTACLES:
            _fail(f"--obstacles: {o!r} is invalid: allowed {', '.join(OBSTACLES)}")
    res = run_campaign(scenario, forms, obsl, seeds, samples, circles=circles, progress=True)
    Path(out).parent.mkdir(parents=True, exist_ok=True)
    Path(out).write_text(json.dumps(res, indent=1, sort_keys=True))
    click.echo(format_table(res))
    click.echo(f"results written to {out}")


@main.command()
@click.argument("problem_spec", metavar="PROBLEM")
@click.option("-o", "--out", "out_dir", type=click.Path(file_okay=False), required=True,
              help="folder to write the solver into (created)")
@click.option("--float", "use_float", is_flag=True, help="single precision (float) instead of double")
@click.option("--force", is_flag=True, help="replace a different solver in OUT (its files are removed)")
def generate(problem_spec, out_dir, use_float, force):
    """Write the C solver of PROBLEM (a preset name or a Python file) into a self-contained folder."""
    from .codegen.generate import generate as gen

    pb = load_problem(problem_spec)
    info = gen(pb, out_dir, use_float=use_float, force=force)
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
@click.option("--cflags", default=None, help="C flags (default: $CFLAGS or -O2)")
def build_cmd(solver_dir, verify, cc, cflags):
    """Compile a generated folder: static libraries for firmware, a shared library for Python and the harness."""
    from .build import BuildError, build

    try:
        lib = build(Path(solver_dir), verify=verify, cc=cc, cflags=cflags)
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
              help="results file [default: results/bench_<name>.json]")
def bench_cmd(solver_dir, scenario, seeds, samples, python, python_seeds, cc, cflags, out):
    """Closed-loop timing and quality of a generated solver (optimized build) and of the Python reference."""
    from .bench import bench, format_bench, write_results
    from .build import BuildError

    try:
        res = bench(Path(solver_dir), scenario=scenario, seeds=seeds, samples=samples, python=python,
                    python_seeds=python_seeds, cc=cc, cflags=cflags, progress=sys.stderr.isatty())
    except BuildError as exc:
        _fail(str(exc))
    click.echo(format_bench(res))
    path = write_results(res, out or f"results/bench_{res['solver']}.json")
    click.echo(f"results written to {path}")


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
def firmware_sim_cmd(solver_dir, scenario, seed, samples, out, verify, cc, cflags):
    """Closed loop in C (firmware_sim/): build SOLVER_DIR and the harness, export the scenario, run, summarize."""
    from .sim.export import HarnessError, firmware_sim
    from .sim.runlog import summary

    try:
        log = firmware_sim(Path(solver_dir), scenario, seed, samples, out, verify=verify, cc=cc, cflags=cflags)
    except HarnessError as exc:
        _fail(str(exc))
    click.echo(f"{log.meta['problem']} | {scenario} seed {seed} | C firmware_sim | {_fmt_summary(summary(log))}")
    click.echo(f"run log written to {out}")


@main.command()
@click.option("--problem", "problem_name", default="truck_lifted_ellipse", show_default=True,
              help="a preset name (scenario from its prefix)")
@click.option("--seed", type=click.IntRange(0), default=3, show_default=True)
@click.option("--samples", type=click.IntRange(1, 100000), default=200, show_default=True)
@click.option("--out", "out_dir", type=click.Path(file_okay=False), default="runs/demo", show_default=True)
@click.option("--plot/--no-plot", default=True, show_default=True)
def demo(problem_name, seed, samples, out_dir, plot):
    """The main job: generate, build, closed loop in the C harness vs the Python reference, summary."""
    from .demo import run_demo

    res = run_demo(out_dir, problem_name, seed, samples, plot, echo=click.echo)
    click.echo(res.format())
    if not res.matches:
        _fail("the generated C does not reproduce the Python reference within the tolerance")


@main.command(name="presets")
def list_presets() -> None:
    """List the preset problems."""
    for n in preset_names():
        click.echo(n)


if __name__ == "__main__":  # pragma: no cover
    main()
