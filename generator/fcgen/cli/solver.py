"""The commands on a generated solver folder: ``build``, ``verify``, ``bench``, ``wcet``, ``firmware-sim``,
``footprint``, ``fmu``. Each reads SOLVER_DIR once (``fcgen.solver_folder.read_folder``) and hands the folder on."""

from __future__ import annotations

import sys
from pathlib import Path

import click
from click.core import ParameterSource

from ..targets import get_target
from .options import (
    TARGET,
    cc_option,
    cflags_option,
    fail,
    fmt_summary,
    force_option,
    out_file_option,
    plant_line,
    plant_options,
    plant_options_given,
    plant_spec,
    samples_option,
    scenario_option,
    seed_option,
    seeds_option,
    solver_dir_argument,
    target_option,
)


@click.command(name="build")
@solver_dir_argument()
@click.option("--verify", is_flag=True, help="verification build: no floating-point contraction (-ffp-contract=off)")
@cc_option()
@cflags_option("C flags (default: $CFLAGS or -O2; a target's CPU flags are appended)")
@TARGET
def build_cmd(solver_dir, verify, cc, cflags, target):
    """Compile a generated folder: static libraries for firmware, a shared library for Python and the harness.

    With a bare-metal --target: the two static libraries alone, cross-compiled, in SOLVER_DIR/build/<target>."""
    from ..build import BuildError, build
    from ..codegen.folder import edits_note
    from ..solver_folder import read_folder

    try:
        lib = build(read_folder(solver_dir), verify=verify, cc=cc, cflags=cflags, target=target)
    except BuildError as exc:
        fail(str(exc))
    products = sorted(
        p.name
        for p in lib.parent.iterdir()
        if p.is_file() and (p.suffix in (".a", ".so") or p.name.endswith("_example"))
    )
    click.echo(f"built {lib.parent}: {', '.join(products)}")
    edits = edits_note(solver_dir)
    if edits:
        click.echo(f"warning: {edits}", err=True)


@click.command(name="verify")
@solver_dir_argument(exists=False)
@scenario_option()
@seed_option()
@samples_option()
@out_file_option("write the report (JSON)")
@plant_options
def verify_cmd(solver_dir, scenario, seed, samples, out):
    """Compare a generated solver (verification build) with the Python reference, sample by sample."""
    from ..build import BuildError
    from ..solver_folder import read_folder
    from ..verify import verify

    spec = plant_spec()
    if spec.params == "matched":
        fail("--plant-params matched sets the controller's wheelbase and mass: generate the solver from that problem")
    try:  # its sizes are compared in the lockstep's terms first, the rest of the folder checked by the build
        rep = verify(read_folder(solver_dir, check=False), scenario=scenario, seed=seed, samples=samples, plant=spec)
    except BuildError as exc:
        fail(str(exc))
    click.echo(rep.format())
    if out:
        rep.to_json(out)
        click.echo(f"report written to {out}")
    if not rep.passed:
        fail(f"verification failed: {len(rep.failures)} tolerance(s) broken")


@click.command(name="bench")
@solver_dir_argument(exists=False)
@scenario_option()
@seeds_option(10000, 3, "seeds 0 .. SEEDS-1")
@samples_option()
@click.option(
    "--python/--no-python",
    "python",
    default=True,
    show_default=True,
    help="also run the Python reference for the same figures",
)
@click.option(
    "--python-seeds",
    type=click.IntRange(1, 10000),
    default=None,
    help="run the Python reference on fewer seeds (default: all)",
)
@cc_option()
@cflags_option("C flags (default: the Makefile's)")
@out_file_option("results file [default: results/bench_<name>[_<target>].json]")
@TARGET
@click.option(
    "--backends",
    default=None,
    help="compare QP backends in one run instead, e.g. osqp,osqp-converged,ipm (OSQP real-time, OSQP "
    "converged, IPM): the folder's problem regenerated per backend under <dir>/build/variants",
)
@click.option(
    "--clock",
    type=click.Choice(["wall", "cpu"]),
    default="wall",
    show_default=True,
    help="with --backends: time with the monotonic clock or the solver thread's CPU time (no preemption)",
)
@force_option("replace an existing results file")
def bench_cmd(
    solver_dir, scenario, seeds, samples, python, python_seeds, cc, cflags, out, target, backends, clock, force
):
    """Closed-loop timing and quality of a generated solver (optimized build) and of the Python reference.

    With an emulated --target: instructions per prepare and feedback (median / max) from QEMU -icount; the default
    then is 1 seed (use --seeds, --samples). With --backends: several QP backends timed in one run."""
    from .. import bench as b
    from ..atomic import check_file_target
    from ..build import BuildError
    from ..sim.harness import HarnessError
    from ..solver_folder import read_folder

    folder = read_folder(solver_dir)
    bare_metal = get_target(target).bare_metal
    if out is None:
        out = (
            f"results/bench_{folder.name}_{target}.json"
            if bare_metal
            else f"results/bench_backends_{folder.name}.json"
            if backends is not None
            else f"results/bench_{folder.name}.json"
        )
    check_file_target(out, "a bench results file", force)
    click.echo(f"bench: results will be written to {out} (--out to choose)", err=True)
    try:
        if bare_metal:
            if backends is not None:
                fail("--backends: not with an emulated --target (generate a folder per backend and bench each)")
            seeds_given = click.get_current_context().get_parameter_source("seeds") != ParameterSource.DEFAULT
            res = b.bench_target(
                folder, target, scenario=scenario, seeds=seeds if seeds_given else 1, samples=samples, cflags=cflags
            )
            text = b.format_bench_target(res)
        elif backends is not None:
            res = b.bench_backends(
                folder,
                b.parse_backends(backends),
                scenario=scenario,
                seeds=seeds,
                samples=samples,
                cc=cc,
                cflags=cflags,
                progress=sys.stderr.isatty(),
                clock=clock,
            )
            text = b.format_backends(res)
        else:
            res = b.bench(
                folder,
                scenario=scenario,
                seeds=seeds,
                samples=samples,
                python=python,
                python_seeds=python_seeds,
                cc=cc,
                cflags=cflags,
                progress=sys.stderr.isatty(),
            )
            text = b.format_bench(res)
    except (HarnessError, BuildError) as exc:
        fail(str(exc))
    click.echo(text)
    click.echo(f"results written to {b.write_results(res, out)}")


@click.command(name="wcet")
@solver_dir_argument()
@target_option(None, bare_metal_only=True, help="the emulated Cortex-M (QEMU -icount shift=0: one instruction per ns)")
@seeds_option(1000, 3, "probe runs: seeds 0 .. SEEDS-1 of the problem's scenario")
@samples_option(20000, help="samples of every probe and validation run")
@click.option(
    "--validate-seeds",
    type=click.IntRange(0, 1000),
    default=0,
    show_default=True,
    help="check the bound on the normal build's closed loops, seeds 0 .. K-1 (exit 1 if a sample exceeds it)",
)
@cflags_option("C optimization flags (default -O2; the target's CPU flags are added)")
@click.option("--jobs", type=click.IntRange(1, 64), default=1, show_default=True, help="QEMU runs at a time")
@click.option("--timeout", type=click.FloatRange(min=1), default=None, help="seconds per QEMU run")
@out_file_option("results file [default: results/wcet_<name>_<target>.json]")
@force_option("replace an existing results file")
@click.option(
    "--bound-scale",
    type=float,
    default=1.0,
    hidden=True,
    help="multiply the bound before the validation (tests: a bound too low must fail)",
)
def wcet_cmd(solver_dir, target, seeds, samples, validate_seeds, cflags, jobs, timeout, out, force, bound_scale):
    """Worst-case instructions of prepare, feedback and one RTI of SOLVER_DIR's build on an emulated --target.

    The bound: the solver's caps (the RTI budget's QP iterations, OSQP's termination checks, the conventional fit's
    scans) times each phase's worst path, measured by a probe build under QEMU (docs/wcet.md)."""
    from ..atomic import check_file_target
    from ..bench import write_results
    from ..build import BuildError
    from ..sim.harness import HarnessError
    from ..solver_folder import read_folder
    from ..wcet import BoundError, ProbeError, WcetError, format_wcet, wcet

    folder = read_folder(solver_dir)
    out = out or f"results/wcet_{folder.name}_{target}.json"
    check_file_target(out, "a wcet results file", force)
    click.echo(f"wcet: results will be written to {out} (--out to choose)", err=True)
    try:
        res = wcet(
            folder,
            target,
            seeds=seeds,
            samples=samples,
            validate_seeds=validate_seeds,
            cflags=cflags,
            timeout=timeout,
            jobs=jobs,
            bound_scale=bound_scale,
        )
    except (HarnessError, BuildError, WcetError, BoundError, ProbeError) as exc:
        fail(str(exc))
    click.echo(format_wcet(res))
    path = write_results(res, out)
    click.echo(f"results written to {path}")
    if res["validated"]["passed"] is False:
        over = res["validated"]["exceeding_samples"]
        fail(
            "validation failed: samples above the bound ("
            + ", ".join(f"{k} {v}" for k, v in over.items() if v)
            + f"); the bound is not an upper bound for this build: see {path}"
        )


@click.command(name="firmware-sim")
@solver_dir_argument()
@scenario_option("truck")
@seed_option()
@samples_option(20000)
@out_file_option("run log (JSON) the C harness writes", default="run.json")
@click.option("--verify", is_flag=True, help="use the verification build (bit-exact with the Python reference)")
@cc_option()
@cflags_option("C flags (default: $CFLAGS or -O2)")
@TARGET
@click.option(
    "--compare-host",
    is_flag=True,
    help="also run the host harness on the same scenario and print the largest differences",
)
@plant_options
def firmware_sim_cmd(solver_dir, scenario, seed, samples, out, verify, cc, cflags, target, compare_host):
    """Closed loop in C (firmware_sim/): build SOLVER_DIR and the harness, export the scenario, run, summarize.

    With a bare-metal --target the harness is a semihosting image run under QEMU (-icount shift=0). --latency,
    --steer-lag, --noise and --prediction put the perturbations between solver and plant (default: the latency a
    delay-compensated solver compensates); the plant is fcgen's own."""
    from ..sim.export import HarnessPlantError
    from ..sim.harness import HarnessError, firmware_sim
    from ..sim.runlog import compare, summary
    from ..solver_folder import read_folder

    spec = plant_spec() if plant_options_given() else None
    folder = read_folder(solver_dir)
    kw = {"verify": verify, "plant": spec}
    try:
        log = firmware_sim(folder, scenario, seed, samples, out, cc=cc, cflags=cflags, target=target, **kw)
        host = None
        if compare_host:
            host_out = str(Path(out).with_suffix("")) + ".host.json"
            host = firmware_sim(folder, scenario, seed, samples, host_out, **kw)
    except (HarnessError, HarnessPlantError) as exc:
        fail(str(exc))
    click.echo(
        f"{log.meta['problem']} | {scenario} seed {seed} | C firmware_sim on {target} | {fmt_summary(summary(log))}"
    )
    if "plant" in log.meta.get("extra", {}):  # a perturbed run: the plant's a_lat beside the formula's, the cuts
        from ..sim.plants import plant_of

        click.echo(plant_line(plant_of(log), log, folder.problem.bounds.a_lat_max))
    if get_target(target).qemu_machine:
        click.echo(f"(solver times on {target}: QEMU's virtual clock under -icount shift=0, 1 ns per instruction)")
    click.echo(f"run log written to {out}")
    if host is not None:
        d = {k: v for k, v in compare(log, host).items() if not k.startswith("time")}
        click.echo(
            f"{target} vs host (run log {host_out}), max abs differences: "
            + ", ".join(f"{k} {v:.3g}" for k, v in d.items())
        )


@click.command(name="footprint")
@solver_dir_argument()
@target_option("cortex-m7")
@out_file_option("JSON result [default: SOLVER_DIR/build/<target>/footprint/footprint.json]")
@click.option("--readme", is_flag=True, help="also write the figures into SOLVER_DIR/README.md (its Footprint section)")
def footprint_cmd(solver_dir, target, out, readme):
    """Flash, RAM and worst stack of the solver's libraries on a target, per object and in total."""
    from ..build import BuildError
    from ..footprint import FOOTPRINT_VARIANT, fill_readme, footprint, format_footprint, write_footprint
    from ..solver_folder import read_folder

    folder = read_folder(solver_dir)
    try:
        res = footprint(folder, target)
    except BuildError as exc:
        fail(str(exc))
    click.echo(format_footprint(res))
    path = write_footprint(res, out or folder.build_dir(target=target, variant=FOOTPRINT_VARIANT) / "footprint.json")
    click.echo(f"results written to {path}")
    if readme:
        click.echo(f"figures written to {fill_readme(folder.path, res)}")


@click.command(name="fmu")
@solver_dir_argument()
@click.option("-o", "--out", required=True, type=click.Path(dir_okay=False), help="the FMU file to write (.fmu)")
@click.option("--fmi", type=click.Choice(["3", "2"]), default="3", show_default=True, help="FMI version")
@force_option("replace an existing file")
def fmu_cmd(solver_dir, out, fmi, force):
    """Package a generated solver folder as a co-simulation FMU (sources, a binary for this platform, docs)."""
    from ..atomic import check_file_target
    from ..build import BuildError
    from ..fmu import FmuError, build_fmu
    from ..solver_folder import read_folder

    check_file_target(out, "an FMU", force, option="-o")
    try:
        path = build_fmu(read_folder(solver_dir), Path(out), int(fmi))
    except (FmuError, BuildError) as exc:
        fail(str(exc))
    click.echo(f"FMU (FMI {fmi}.0, co-simulation) written to {path} ({Path(path).stat().st_size:,} bytes)")
