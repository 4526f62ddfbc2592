"""The DSL's reference page (docs/problem_reference.md): every field of every DSL class with unit, range, default.

Defaults are read from the dataclasses themselves, so the page cannot drift from the code; units, ranges and
meanings are written here once. ``tests/test_docs.py`` checks that every field has an entry and that the committed
page is what ``render()`` writes (``python -m fcgen.dsl_reference > docs/problem_reference.md`` rewrites it).
"""

from __future__ import annotations

import dataclasses
import math

from . import dsl

#: (class, field) -> (unit, allowed range as validated, meaning)
FIELDS: dict[tuple[str, str], tuple[str, str, str]] = {
    ("Problem", "name"): (
        "-",
        "C identifier prefix: [a-z][a-z0-9_]*, <= 31 characters, no clash with C/OSQP/CasADi names",
        "prefix of every C symbol (`<name>_*`, `<NAME>_*`)",
    ),
    ("Problem", "formulation"): ("-", "`Conventional()`, `DirectElimination()`, `Lifted()`", "the NMPC formulation"),
    ("Problem", "obstacles"): (
        "-",
        "`Ellipse()`, `CoveringCircles(n)`, `SeparatingHyperplane()`",
        "the obstacle model",
    ),
    ("Problem", "ego"): ("-", "a `Vehicle`", "the controlled vehicle"),
    ("Problem", "opponents"): ("-", "an `Opponents`", "number and size of the other vehicles"),
    ("Problem", "wind"): ("-", "a `Wind`", "wind in the ego's drag model"),
    ("Problem", "horizon"): ("-", "a `Horizon`", "prediction horizon"),
    ("Problem", "weights"): ("-", "a `Weights`", "least-squares weights"),
    ("Problem", "reference"): ("-", "a `Reference`", "tracking reference"),
    ("Problem", "bounds"): ("-", "a `Bounds`", "box bounds of states and inputs"),
    ("Problem", "soft"): ("-", "a `SoftPenalties`", "slack penalties of the soft rows"),
    ("Problem", "qp"): ("-", "a `QpOptions`", "QP backend and its settings"),
    ("Problem", "road"): ("-", "a `RoadWindow`; length >= v_max horizon.length + 4 ds", "the road the solver sees"),
    ("Problem", "plan_check"): ("-", "a `PlanCheck`", "the plan's clearance check after each feedback, its reaction"),
    ("Problem", "delay"): (
        "samples",
        "integer in [0, 8]",
        "delay compensation: the solver plans from the measured state predicted over this many samples with the "
        "controls it handed out last (the plant applies each control this many samples after its measurement)",
    ),
    ("Problem", "steer_lag"): (
        "s",
        "[0, 2]; 0: none",
        "a first-order steering actuator's time constant that the delay compensation's prediction and the a_lat "
        "guard's plant step model (the lag of the angle behind the commanded rates is kept in the workspace)",
    ),
    ("Problem", "obstacle_margin"): (
        "m",
        "[0, 10]; 0: none",
        "the obstacle margin of every stage from init on (set_obstacle_margins replaces it, reset keeps it): an "
        "extra distance from every opponent (the safe profile's with a delay: presets.SAFE_DELAY_MARGIN)",
    ),
    ("PlanCheck", "react_stages"): (
        "-",
        "integer in [0, 500]; 0: report only; 500: the whole horizon",
        "brake where an opponent's first overlap with the plan among stages "
        "1..min(this, N) is ahead of the ego there or now",
    ),
    ("PlanCheck", "a_lat_guard"): (
        "-",
        "True or False",
        "the applied control keeps the next sample's lateral "
        "acceleration within +-bounds.a_lat_max (steering rate, else braking; needs "
        "bounds.a_lat_margin > 0)",
    ),
    ("PlanCheck", "tyre_stiffness"): (
        "1/rad",
        "[0, 100]; 0: the kinematic formula",
        "the tyres' cornering stiffness per unit normal load (mu C_S): the a_lat guard tests the formula's a_lat "
        "divided by a single-track model's yaw gain under the control's braking (default: CommonRoad's BMW 320i)",
    ),
    ("PlanCheck", "h_cg"): (
        "m",
        "[0, 3], F_d_max / m h_cg < g min(l_f, l_r)",
        "the centre of gravity's height: the load braking moves onto the front axle (the tyre-aware a_lat guard)",
    ),
    ("PlanCheck", "drive_limit"): (
        "-",
        "True or False",
        "the a_lat guard also limits a positive drive force: where it steers, to a friction ellipse with the next "
        "sample's lateral acceleration, elsewhere to where the tyres turn at most 0.25 m/s^2 less than the formula",
    ),
    ("PlanCheck", "drive_rows"): (
        "-",
        "True or False, False without drive_limit",
        "the plan keeps the drive limit's second part too: a hard row on u_0 and soft rows on the a_lat slack at "
        "stages 1..N-1 (off in the safe profile: docs/safe_profile.md)",
    ),
    ("PlanCheck", "bend_brake"): (
        "m/s^2",
        "[0, 10], 0 without drive_limit; 0: off (the default)",
        "where the a_lat guard steers and the plan holds a slack above 1, the ego is too fast for the path the plan "
        "turns onto: the drive force is capped to brake towards that path's speed at the guard's target, at most at "
        "this deceleration (off in the safe profile: docs/safe_profile.md)",
    ),
    ("PlanCheck", "brake_memory"): (
        "-",
        "True or False",
        "the tyre-aware a_lat guard takes the load transfer of the harder of the control's and the last handed-out "
        "control's braking (the tyres still carry the braking of the sample before)",
    ),
    ("PlanCheck", "drive_rise"): (
        "m/s^2 per sample",
        "[0, 100], 0 without drive_limit; 0: off",
        "the drive force rises by at most m times this above the last handed-out one per sample (braking is never "
        "limited): a switch from braking to driving in one sample turns a vehicle with tyres more than the formula",
    ),
    ("Ellipse", "shape"): (
        "-",
        "`minkowski` or `paper`",
        "the ellipse containing the opponent grown by the ego's "
        "circle (smallest area), or the paper's sqrt(2) L + r, sqrt(2) W + r",
    ),
    ("Ellipse", "n_ego"): (
        "-",
        "integer in [1, 5]",
        "circles covering the ego along its axis, one row each (CoveringCircles' cover radius); the opponent's "
        "ellipse grows by their radius (the paper car: 2.21 m with 1, 1.42 m with 2)",
    ),
    ("CoveringCircles", "radius"): (
        "-",
        "`cover` or `paper`",
        "circles just large enough to cover the rectangle, or the paper's w / sqrt(2)",
    ),
    ("SeparatingHyperplane", "anchor"): (
        "-",
        "[0, 1]",
        "weight pulling the planes toward the midpoint plane (makes them unique: C = Python over whole runs)",
    ),
    ("Vehicle", "l_f"): ("m", "> 0", "front part of the wheelbase l = l_f + l_r (reference point: rear axle)"),
    ("Vehicle", "l_r"): (
        "m",
        "> 0",
        "rear part of the wheelbase; the chassis is centred at l/2 ahead of the rear axle",
    ),
    ("Vehicle", "l_f_ch"): ("m", "> 0", "chassis length ahead of its centre"),
    ("Vehicle", "l_r_ch"): ("m", "> 0", "chassis length behind its centre"),
    ("Vehicle", "w_ch"): ("m", "> 0", "chassis width"),
    ("Vehicle", "m"): ("kg", "> 0", "mass"),
    ("Vehicle", "c_air"): ("kg/m", ">= 0", "air drag coefficient 0.5 c_w A rho"),
    ("Vehicle", "c_roll"): ("N", ">= 0", "rolling resistance force"),
    ("Wind", "v"): ("m/s", ">= 0", "wind speed"),
    ("Wind", "phi"): ("rad", "finite", "direction the wind comes from"),
    ("Horizon", "N"): ("-", "integer in [1, 500]", "shooting intervals"),
    ("Horizon", "dt"): ("s", "(0, 10]", "the sample time of the closed loop, and the length of a fine interval"),
    ("Horizon", "stride"): (
        "-",
        "integer in [1, 10], dt * stride <= 10 s",
        "samples per coarse interval (1: every interval one sample, the paper's grid)",
    ),
    ("Horizon", "fine"): (
        "-",
        "integer >= 0",
        "intervals of one sample before the coarse ones (stride 3, fine 20: "
        "2 s of 0.1 s, then 6 s of 0.3 s, 8 s ahead with the paper's QP size; the plan is shifted "
        "one sample, a coarse stage interpolated; opponents predicted at the nodes' samples, "
        "`<NAME>_STAGE_OFFSETS`; neither profile uses it: docs/collisions.md)",
    ),
    ("Weights", "q"): ("-", "5 numbers >= 0", "stage weights of (s, n, alpha, v, delta), times dt"),
    ("Weights", "q_N"): ("-", "5 numbers >= 0", "terminal weights of (s, n, alpha, v, delta)"),
    ("Weights", "r"): ("-", "2 numbers >= 0", "input weights of (F_d, r), times dt"),
    ("Reference", "v_ref"): (
        "m/s",
        ">= 0",
        "reference speed: s_ref,k = s0 + t_k v_ref (t_k: node k's time, k dt on "
        "the paper's grid); with the curve speed capped per node",
    ),
    ("Reference", "n_ref"): ("m", "finite", "reference lateral offset"),
    ("Reference", "curve_a_lat"): (
        "m/s^2",
        "[0, 50]",
        "the curve speed: v_ref,k capped at s_ref,k so that braking "
        "at curve_decel reaches every road sample ahead no faster than "
        "sqrt(curve_a_lat / abs(kappa)) (0: off, the paper's presets)",
    ),
    ("Reference", "curve_decel"): ("m/s^2", "(0, 50]", "the curve speed's deceleration"),
    ("Reference", "curve_a_lat_traffic"): (
        "m/s^2",
        "(0, 50]",
        "the curve speed's lateral acceleration with traffic near the plan (instead of curve_a_lat)",
    ),
    ("Reference", "curve_traffic_clearance"): (
        "m",
        "[0, 100]",
        "traffic near the plan: the last plan check's clearance to an opponent below this (0: never)",
    ),
    ("Reference", "curve_along_horizon"): (
        "-",
        "True or False",
        "the curve speed at every node's reference position (False: at the plan's start, for the whole horizon)",
    ),
    ("Bounds", "F_d_max"): ("N", "> 0", "|F_d| bound (drive/brake force)"),
    ("Bounds", "r_max"): ("rad/s", "> 0", "|r| bound (steering rate)"),
    ("Bounds", "delta_max"): ("rad", "> 0", "|delta| bound (steering angle)"),
    ("Bounds", "v_min"): ("m/s", "0 <= v_min < v_max", "speed lower bound"),
    ("Bounds", "v_max"): ("m/s", "> v_min", "speed upper bound"),
    ("Bounds", "alpha_max"): ("rad", "(0, pi/2)", "|alpha| bound (heading relative to the road)"),
    ("Bounds", "n_min"): ("m", "< n_max", "road bound on the ego's n (right; road_bound says which point)"),
    ("Bounds", "n_max"): ("m", "> n_min", "road bound on the ego's n (left; road_bound says which point)"),
    ("Bounds", "a_lat_max"): ("m/s^2", "> 0", "|a_lat| bound (a soft row)"),
    ("Bounds", "v_N_max"): ("m/s", "[v_min, v_max]", "terminal speed bound"),
    ("Bounds", "a_lat_margin"): (
        "m/s^2",
        "[0, a_lat_max)",
        "the plan keeps abs(a_lat) this far inside a_lat_max "
        "(a real-time iteration's linearization and coarse intervals overshoot it; the "
        "paper's presets: 0)",
    ),
    ("Bounds", "road_bound"): (
        "-",
        "'rear_axle' or 'corners'",
        "what n_min/n_max and the road's band bound: the rear axle's n (a box bound), or the chassis' four corners "
        "(one row each, n + x_c sin(alpha) +- (w_ch/2) cos(alpha) with the road's curvature over the chassis; each "
        "takes the road's band at its own s; 4 rows per stage, about 1.1x the instructions per RTI)",
    ),
    ("Bounds", "P_d_max"): (
        "W",
        "None or > 0",
        "the drive's power: one row F_d v <= P_d_max per stage 0..N-1 (None: no row; CommonRoad runs of the safe "
        "profile: the solution's vehicle's m a_max v_switch, 97.6 kW for the BMW 320i at 1160 kg)",
    ),
    ("SoftPenalties", "obstacle_l1"): ("-", ">= 0", "L1 weight of the obstacle rows' slacks (times dt)"),
    ("SoftPenalties", "obstacle_l2"): ("-", ">= 0", "L2 weight of the obstacle rows' slacks (times dt)"),
    ("SoftPenalties", "a_lat_l1"): ("-", ">= 0", "L1 weight of the a_lat rows' slacks (times dt)"),
    ("SoftPenalties", "a_lat_l2"): ("-", ">= 0", "L2 weight of the a_lat rows' slacks (times dt)"),
    ("SoftPenalties", "soft_road"): ("-", "True or False", "soften the road bounds too"),
    ("SoftPenalties", "road_l1"): ("-", ">= 0", "L1 weight of the road rows' slacks (with soft_road)"),
    ("SoftPenalties", "road_l2"): ("-", ">= 0", "L2 weight of the road rows' slacks (with soft_road)"),
    ("QpOptions", "max_iter"): ("-", "integer in [1, 1e6]", "QP iteration cap per RTI (OSQP; the IPM's own cap)"),
    ("QpOptions", "eps_abs"): ("-", "[0, 1); eps_abs or eps_rel > 0", "OSQP absolute tolerance"),
    ("QpOptions", "eps_rel"): ("-", "[0, 1)", "OSQP relative tolerance"),
    ("QpOptions", "rho"): ("-", "> 0", "OSQP ADMM step size"),
    ("QpOptions", "sigma"): ("-", "> 0", "OSQP regularization (raised to 1e-3 in a float build)"),
    ("QpOptions", "alpha"): ("-", "(0, 2)", "OSQP relaxation"),
    ("QpOptions", "adaptive_rho"): ("-", "True or False", "OSQP adaptive rho"),
    ("QpOptions", "scaling"): ("-", "integer in [0, 100]", "OSQP Ruiz scaling passes"),
    ("QpOptions", "check_termination"): ("-", "integer in [1, 1000]", "OSQP: iterations between termination checks"),
    ("QpOptions", "warm_start"): ("-", "True or False", "warm-start the QP from the shifted plan"),
    ("QpOptions", "max_iter_cold"): (
        "-",
        "integer in [1, 1e6]",
        "iteration cap of a cold-started QP (at least max_iter is used)",
    ),
    ("QpOptions", "cold_restart_after"): (
        "-",
        "integer in [0, 1e6]; 0: never",
        "unusable QPs in a row after which prepare cold-starts",
    ),
    ("QpOptions", "rti_budget"): (
        "-",
        "integer in [1, 1e6], or None (the backend's default)",
        "QP iterations any feedback may run, cold starts included: caps max_iter and max_iter_cold (docs/wcet.md)",
    ),
    ("QpOptions", "backend"): ("-", "one of " + ", ".join(f"`{b}`" for b in dsl.BACKENDS), "the QP backend"),
    ("QpOptions", "ipm_tol"): ("-", "(0, 1)", "IPM tolerance: stationarity, primal residuals, each t lam (scaled)"),
    ("QpOptions", "ipm_scaled_start"): (
        "-",
        "True / False",
        "IPM: every side's lam starts at max(lw, lam_min / max(1, -b)), the soft rows' slack bounds' t at "
        "max(-b, t_min / max(1, lam)); a slack's bound without a warm lam (a cold start) at its slack's cost "
        "(paper presets: False)",
    ),
    ("RoadWindow", "ds"): ("m", "[0.1, 20]", "road sample spacing"),
    ("RoadWindow", "length"): ("m", ">= 4 ds and >= v_max N dt + 4 ds", "road length the solver accepts"),
    ("Opponents", "count"): ("-", "integer in [0, 10]", "number of opponents"),
    ("Opponents", "vehicle"): ("-", "a `Vehicle`", "their common size"),
    ("Conventional", "overapprox"): ("-", "`fit` or `none`", "over-approximation of the opponents in (s, n)"),
    ("Conventional", "margin"): ("m", ">= 0", "extra margin of the fitted box"),
    ("Conventional", "points_per_metre"): (
        "1/m",
        "[0.25, 20]",
        "points per metre of the opponent's edges mapped into (s, n)",
    ),
    ("CoveringCircles", "n"): ("-", "integer in [1, 20]", "circles covering each opponent"),
    ("CoveringCircles", "n_ego"): ("-", "integer in [1, 20], or None (= n)", "circles covering the ego"),
    ("SeparatingHyperplane", "margin"): ("m", "[0, 2]", "distance the ego's vertices keep from the plane"),
}

CLASSES = (
    "Problem",
    "Vehicle",
    "Opponents",
    "Wind",
    "Horizon",
    "Weights",
    "Reference",
    "Bounds",
    "SoftPenalties",
    "QpOptions",
    "RoadWindow",
    "PlanCheck",
    "Conventional",
    "DirectElimination",
    "Lifted",
    "Ellipse",
    "CoveringCircles",
    "SeparatingHyperplane",
)


def documented_fields(cls: type) -> list[dataclasses.Field]:
    """The fields a user sets (``kind`` tags, not in ``__init__``, are left out)."""
    return [f for f in dataclasses.fields(cls) if f.init]


def _default(f: dataclasses.Field) -> str:
    if f.default is not dataclasses.MISSING:
        v = f.default
    elif f.default_factory is not dataclasses.MISSING:
        v = f.default_factory()
    else:
        return "required"
    if dataclasses.is_dataclass(v) and not isinstance(v, type):
        return f"`{type(v).__name__}()`" + (" (its defaults)" if v == type(v)() else " (see below)")
    if isinstance(v, float):
        return f"{v:.6g}" if not math.isclose(v, math.pi / 4) else "pi/4"
    if isinstance(v, str):
        return f"`{v}`"
    return f"{v}"


def render() -> str:
    """The page, Markdown."""
    out = [
        "# Describing a problem: every field",
        "",
        "Every DSL object is a frozen dataclass validated when it is built: a value outside its range raises",
        "`fcgen.dsl.ProblemError` naming the field and the allowed range (`fcgen generate` prints it in one line).",
        "Defaults below are read from the code (`fcgen.dsl_reference` writes this page; a test keeps it current).",
        "Units: SI; `-` for none. Stage weights and penalties are multiplied by `dt` per stage.",
        "",
    ]
    for name in CLASSES:
        cls = getattr(dsl, name)
        doc = (cls.__doc__ or "").strip().splitlines()[0]
        out += [f"## `{name}`", "", doc, ""]
        fs = documented_fields(cls)
        if not fs:
            out += ["No fields.", ""]
            continue
        out += ["| field | unit | allowed | default | meaning |", "|---|---|---|---|---|"]
        for f in fs:
            unit, allowed, meaning = FIELDS[(name, f.name)]
            out.append(f"| `{f.name}` | {unit} | {allowed} | {_default(f)} | {meaning} |")
        out.append("")
    return "\n".join(out)


if __name__ == "__main__":  # pragma: no cover
    print(render(), end="")
