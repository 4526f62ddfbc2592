"""What several ``fcgen`` commands share: their common options (defined once), the one-line failure, the summary
line of a closed loop."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import replace
from typing import Any, NoReturn

import click
from click.core import ParameterSource

from ..presets import SCENARIOS
from ..sim.runlog import fmt_slack
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
        f"QP status {s['qp_status_counts']} | max slack {fmt_slack(s['max_slack'])}{_unsolved(s)} | "
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


#: where the plant options keep their values in the click context (``plant_spec`` reads them)
_PLANT_META = "fcgen.plant_options"


def _keep(ctx: click.Context, param: click.Parameter, value: Any) -> Any:
    ctx.meta.setdefault(_PLANT_META, {})[param.name] = value
    return value


def plant_options(f: Callable[..., Any]) -> Callable[..., Any]:
    """``--plant``, ``--plant-params``, ``--latency``, ``--steer-lag``, ``--noise``, ``--prediction``,
    ``--prediction-margin`` (docs/plants.md): not passed to the command, which gets them as one ``PlantSpec`` from
    ``plant_spec()``."""
    from ..sim.plants import PLANT_KINDS, PLANT_PARAMS, PREDICTIONS
    from ..sim.plants.spec import MAX_LATENCY, MAX_PREDICTION_MARGIN, MAX_STEER_LAG

    opts = [
        click.option(
            "--plant",
            expose_value=False,
            callback=_keep,
            type=click.Choice(PLANT_KINDS),
            default="model",
            show_default=True,
            help="the plant: fcgen's own model, or CommonRoad's kinematic single track (ks), single track (st), "
            "single track drift (std) or multi-body (mb) model (docs/plants.md)",
        ),
        click.option(
            "--plant-params",
            expose_value=False,
            callback=_keep,
            type=click.Choice(PLANT_PARAMS),
            default="paper",
            show_default=True,
            help="the BMW 320i with the paper's ego geometry and mass (paper), or as shipped with the controller's "
            "wheelbase and mass set to it (matched)",
        ),
        click.option(
            "--latency",
            expose_value=False,
            callback=_keep,
            type=click.IntRange(0, MAX_LATENCY),
            default=0,
            show_default=True,
            help="samples between measurement and actuation",
        ),
        click.option(
            "--steer-lag",
            expose_value=False,
            callback=_keep,
            type=click.FloatRange(0.0, MAX_STEER_LAG),
            default=0.0,
            show_default=True,
            help="time constant (s) of a first-order steering actuator",
        ),
        click.option(
            "--noise",
            expose_value=False,
            callback=_keep,
            default=None,
            help="Gaussian noise on the measured (s, n, alpha, v, delta): five stds, or 'default' "
            "(0.05 m, 0.05 m, 0.005 rad, 0.05 m/s, 0.002 rad); seeded from the run's seed",
        ),
        click.option(
            "--prediction",
            expose_value=False,
            callback=_keep,
            type=click.Choice(PREDICTIONS),
            default="oracle",
            show_default=True,
            help="the opponents' futures the solver is given: the true ones (oracle) or predicted at each sample "
            "from their observed poses (with --noise's s, n, alpha stds on x, y, phi); the collision check uses "
            "the true motion",
        ),
        click.option(
            "--prediction-margin",
            expose_value=False,
            callback=_keep,
            type=click.FloatRange(0.0, MAX_PREDICTION_MARGIN),
            default=0.0,
            show_default=True,
            help="c of an obstacle margin per stage growing with the prediction's expected error, "
            "c (tau_k e + tau_k^2 t / 2), t the turn a straight-line prediction misses (docs/plants.md, 'Margins "
            "from the prediction's error'; 0: none; needs --prediction)",
        ),
    ]
    for o in reversed(opts):
        f = o(f)
    return f


def plant_spec(commonroad: bool = False, commonroad_plant: bool = False):
    """The ``PlantSpec`` of the running command's plant options; a bad value, a missing ``[plants]`` extra or
    perturbations with ``--commonroad`` (which runs fcgen's own plant; ``commonroad_plant``: the command runs the
    plant options on a CommonRoad scenario; a campaign: only --prediction): one line, exit 1."""
    from ..dsl import ProblemError
    from ..sim.plants import PlantSpec, parse_noise

    o = click.get_current_context().meta.get(_PLANT_META, {})
    try:
        spec = PlantSpec(
            o.get("plant", "model"),
            o.get("plant_params", "paper"),
            o.get("latency", 0),
            float(o.get("steer_lag", 0.0)),
            parse_noise(o.get("noise")),
            o.get("prediction", "oracle"),
            float(o.get("prediction_margin", 0.0)),
        )
    except ProblemError as exc:
        fail(f"--{str(exc).split(' ', 1)[0].replace('_', '-')}: {exc}")
    if commonroad and spec.prediction_margin:
        fail("--prediction-margin is not for --commonroad (its margins follow the paper road's opponents)")
    if commonroad and not commonroad_plant and not replace(spec, prediction="oracle").is_default:
        fail("--commonroad runs fcgen's own plant without perturbations (no --plant, --latency, --steer-lag, --noise)")
    if spec.kind != "model" or spec.params == "matched":
        from ..extras import MissingExtra
        from ..sim.plants.commonroad_vm import vehicle_models

        try:
            vehicle_models()
        except MissingExtra as exc:
            fail(str(exc))
    return spec


def plant_options_given() -> bool:
    """Whether the command line (or the environment) gave any plant option, even at its default value."""
    ctx = click.get_current_context()
    given = (ParameterSource.COMMANDLINE, ParameterSource.ENVIRONMENT)
    return any(ctx.get_parameter_source(name) in given for name in ctx.meta.get(_PLANT_META, {}))


def plant_line(spec, log, a_lat_max: float) -> str:
    """One line on a perturbed run: the plant, its a_lat beside the model formula's, the cut controls."""
    import numpy as np

    ex = log.meta["extra"]
    bound = a_lat_max + 0.5
    over = float(np.mean(np.abs(np.asarray(log.a_lat)) > bound)) * 100
    return (
        f"plant {spec.label()} | max |a_lat| plant {float(np.max(np.abs(log.a_lat))):.2f}, model formula "
        f"{ex['max_abs_a_lat_model']:.2f} m/s^2 | plant |a_lat| > {bound:g}: {over:.1f} % of samples | "
        f"controls cut by the plant's limits: {ex['plant_cut_samples']} samples (steering rate "
        f"{ex['plant_cut_steer_rate']}, angle {ex['plant_cut_steer_angle']}, acceleration {ex['plant_cut_accel']})"
    )


def matched_for(pb, spec, controller: str):
    """``pb`` with the controller's wheelbase and mass matched to the plant (``--plant-params matched``: the Python
    controller only; a C solver or FMU is generated from the problem it has)."""
    if spec.params != "matched":
        return pb
    if controller != "python":
        fail(
            "--plant-params matched sets the controller's wheelbase and mass: use --controller python, or "
            "`fcgen campaign` (it generates its solvers)"
        )
    from ..sim.plants.commonroad_vm import matched_problem

    return matched_problem(pb, spec.params)


def delay_option(f: Callable[..., Any]) -> Callable[..., Any]:
    """``--delay``: the generated solvers' delay compensation (``Problem.delay``)."""
    return click.option(
        "--delay",
        type=click.IntRange(0, 8),
        default=0,
        show_default=True,
        help="generate the solvers with delay compensation of this many samples (Problem.delay; docs/plants.md)",
    )(f)


def road_bound_option(help: str) -> Decorator:
    """``--road-bound``: what the road band bounds (``Bounds.road_bound``)."""
    from ..dsl.bounds import ROAD_BOUNDS

    return click.option("--road-bound", type=click.Choice(ROAD_BOUNDS), default=None, help=help)


def ego_circles_option(help: str, default: int | None = 1) -> Decorator:
    """``--ego-circles``: the circles covering the ego in the ellipse's rows (``Ellipse.n_ego``)."""
    return click.option("--ego-circles", type=click.IntRange(1, 5), default=default, show_default=True, help=help)


def _drive_power(ctx, param, value: str | None) -> str | float | None:
    """``--drive-power``: None (the problem's own), ``vehicle`` or a power in W (> 0)."""
    if value is None or value == "vehicle":
        return value
    try:
        watts = float(value)
    except ValueError:
        watts = float("nan")
    if not (0.0 < watts < float("inf")):
        raise click.BadParameter(f"{value!r} is invalid: allowed 'vehicle' or a power > 0 W", ctx, param)
    return watts


def simulate_chassis_options(f: Callable[..., Any]) -> Callable[..., Any]:
    """``fcgen simulate``'s ``--road-bound``, ``--ego-circles`` and ``--drive-power`` (each: the problem's own by
    default; with ``--controller c`` the solver folder's problem must have it)."""
    f = click.option(
        "--drive-power",
        default=None,
        metavar="W|vehicle",
        callback=_drive_power,
        help="the drive's power row F_d v <= W (Bounds.P_d_max); 'vehicle': the CommonRoad solution vehicle's "
        "m a_max v_switch (97.6 kW for 1160 kg); default: the problem's own",
    )(f)
    f = ego_circles_option(
        "the circles covering the ego in the ellipse's rows (Ellipse.n_ego); default: the problem's", None
    )(f)
    return road_bound_option(
        "what the road band bounds (Bounds.road_bound): the rear axle or the chassis' four corners; default: the "
        "problem's own (--controller c: the solver folder's must be it)"
    )(f)


def same_bounds(theirs, ours, solver_dir: str) -> None:
    """Fail unless the solver folder's problem ``theirs`` has the road bound and drive power of the problem ``ours``."""
    b, c = theirs.bounds, ours.bounds
    names = [n for n in ("road_bound", "P_d_max") if getattr(b, n) != getattr(c, n)]
    if names:
        differ = "; ".join(
            f"{n} = {getattr(b, n)!r} where the problem {ours.name!r} has {getattr(c, n)!r}" for n in names
        )
        fail(
            f"--solver-dir {solver_dir} has {differ}: generate the solver from the problem, or leave out --road-bound "
            f"and --drive-power"
        )


def with_chassis_options(pb, road_bound: str | None, ego_circles: int | None, drive_power: str | float | None = None):
    """``pb`` with ``--road-bound``, ``--ego-circles`` and ``--drive-power`` (``None``: the problem's own; more than
    one ego circle: an ellipse's rows only)."""
    if road_bound is not None:
        pb = pb.with_(bounds=replace(pb.bounds, road_bound=road_bound))
    if drive_power is not None:
        if drive_power == "vehicle":
            from ..commonroad.solution import drive_power as vehicle_power

            drive_power = vehicle_power(pb.ego.m)
        pb = pb.with_(bounds=replace(pb.bounds, P_d_max=float(drive_power)))
    if ego_circles is not None:
        if pb.obstacles.kind != "ellipse":
            fail(f"--ego-circles {ego_circles}: allowed with the ellipse only (the problem's is {pb.obstacles.kind})")
        pb = pb.with_(obstacles=replace(pb.obstacles, n_ego=ego_circles))
    return pb
