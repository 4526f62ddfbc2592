"""The formulas the Python reference and the generated C both write (``fcgen.reactions``): the braking control of the
plan check and the a_lat guard, the guard's steering rate, the lateral acceleration. Each gives hand-derived values in
Python, and the C function of the same name, cut out of a rendered solver and compiled around a small main, gives the
same bits on the same inputs (signed zeros included)."""

from __future__ import annotations

import math
import re
import shutil
import struct
import subprocess
from pathlib import Path

import pytest

from fcgen.reactions import (
    GAIN_MIN,
    bend_brake_limit,
    braking_force,
    drive_limit,
    guard_steering_rate,
    lag_command,
    lag_error,
    lagged_rate,
    lateral_acceleration,
    load_transfer_gain,
    understeer_drive_limit,
)

SOLVER = Path(__file__).resolve().parents[1] / "generated" / "truck_lifted_ellipse" / "truck_lift_el_solver.c"
NAME = "truck_lift_el"
M = 1160.0  # kg; F_d_max 1e4 N
QUARTER_PI = 0.7853981633974483
TAN_005 = 0.05 + 0.05**3 / 3 + 2 * 0.05**5 / 15 + 17 * 0.05**7 / 315 + 62 * 0.05**9 / 2835  # tan's series, to 1e-16

# (v0, dt, expected F_d): F_d = -min(F_d_max, m max(v0, 0) / dt), worked out by hand
BRAKE = [
    (-3.0, 0.1, -0.0),  # rolling backwards: no braking force (a negative zero, as the C gives it)
    (-0.0, 0.1, -0.0),
    (0.0, 0.1, -0.0),
    (0.5, 0.1, -5800.0),  # m / dt = 11600: stops within the sample with 5800 N
    (0.25, 0.05, -5800.0),  # m / dt = 23200
    (1.5, 0.2, -8700.0),  # m / dt = 5800
    (1.0, 0.3, -3866.666666666667),  # m / dt = 3866.67 (rounded)
    (0.862, 0.1, -9999.2),  # just below F_d_max
    (20.0, 0.1, -1e4),  # saturates at F_d_max
    (3.0, 0.3, -1e4),
    (2.0, 0.232, -1e4),  # m / dt = 5000: exactly F_d_max
    (float("nan"), 0.1, -0.0),  # a NaN speed brakes with nothing (the state check refuses NaN before)
]

# (v, delta, delta0, a_to, l, dt, lo, hi, expected rate)
RATE = [
    (4.0, 0.2, 0.5, 4.0, 4.0, 0.1, -5.0, 5.0, (QUARTER_PI - 0.5) / 0.1),  # a_to l / v^2 = 1: atan 1 = pi/4
    (4.0, -0.2, 0.5, 4.0, 4.0, 0.1, -5.0, 5.0, -5.0),  # -12.85 rad/s: clipped at the bound
    (4.0, -0.2, 0.0, 4.0, 4.0, 0.5, -5.0, 5.0, -QUARTER_PI / 0.5),  # the left side: -pi/4 in 0.5 s
    (2.0, -0.0, 0.0, 1.0, 4.0, 0.05, -20.0, 20.0, -QUARTER_PI / 0.05),  # delta = -0.0 is the left side
    (-2.0, 0.3, 0.0, 1.0, 4.0, 0.1, -20.0, 20.0, QUARTER_PI / 0.1),  # backwards: v^2 is the same
    (0.0, 0.3, 0.1, 4.0, 4.0, 0.1, -5.0, 5.0, 0.0),  # standing: no rate
    (1e-3, 0.3, 0.0, 4.0, 4.0, 0.1, -5.0, 5.0, 5.0),  # slow: ~pi/2 in 0.1 s, clipped
    (
        4.9,
        0.1,
        0.02,
        4.75,
        3.4,
        0.1,
        -20.0,
        20.0,  # every operation rounds
        (math.atan(16.15 / 24.01) - 0.02) / 0.1,
    ),
]

# (v, delta, l, expected a_lat)
A_LAT = [
    (10.0, 0.0, 3.4, 0.0),
    (2.0, QUARTER_PI, 2.0, 2.0),  # tan(pi/4) = 1 (up to its rounding)
    (-3.0, -0.1, 3.4, 9.0 * math.tan(-0.1) / 3.4),
    (20.0, 0.05, 3.4, 400.0 * TAN_005 / 3.4),
]

# (v, a_x, k, l_f, l_r, h, expected divisor) of the tyre-aware a_lat, worked out by hand with g = 9.81. With
# l_f = l_r = 1 and a_x h = -g / 2: K = k (1 / (1.5 g) - 1 / (0.5 g)) = -4 k / (3 g); k = 1 / (l c) = 1 / 20 for c = 10,
# so K v^2 = -1/2 at v^2 = 3 g 10 / 4 = 73.575: the divisor 1/2
G_HALF = 9.81 / 2
LOAD = [
    (math.sqrt(73.575), -G_HALF, 0.05, 1.0, 1.0, 1.0, 0.5),  # braking: turns twice as much as the formula
    (math.sqrt(73.575), -G_HALF / 2, 0.05, 1.0, 1.0, 2.0, 0.5),  # the same a_x h
    (20.0, 0.0, 0.05, 1.0, 1.0, 1.0, 1.0),  # no load transfer, equal tyres: neutral
    (20.0, -G_HALF, 0.0, 1.0, 1.0, 1.0, 1.0),  # no tyres: the formula
    (20.0, G_HALF, 0.05, 1.0, 1.0, 1.0, 1.0),  # accelerating: understeer, never more than the formula allows
    (20.0, -G_HALF, 0.05, 1.0, 1.0, 1.0, GAIN_MIN),  # K v^2 = -0.2 / (3 g) 400 = -2.7: beyond the critical speed
    (math.sqrt(73.575), -G_HALF, 0.05, 1.0, 1.0, 0.0, 1.0),  # no height: no load transfer
]

# (a_lat, a_max, f_max, expected drive force limit): f_max sqrt(1 - (a_lat / a_max)^2), by hand
DRIVE = [
    (0.0, 5.0, 1e4, 1e4),  # straight ahead: the whole drive force
    (3.0, 5.0, 1e4, 8000.0),  # sqrt(1 - 0.36) = 0.8
    (-4.0, 5.0, 1e4, 6000.0),  # either side
    (5.0, 5.0, 1e4, 0.0),  # at the bound: no drive force
    (6.0, 5.0, 1e4, 0.0),  # beyond it: none either (not a NaN)
]

# (a_lat, v, k, l_f, l_r, h, slack, f_max, m, expected): m slack g^2 l_f l_r / (k l h v^2 (a_lat - slack)), by hand:
# with k = 0.05, l_f = l_r = h = 1, slack 0.5, a_lat 1.5, v = 10, m = 1: 0.5 * 96.2361 / (0.1 * 100) = 4.811805
UNDER = [
    (1.5, 10.0, 0.05, 1.0, 1.0, 1.0, 0.5, 1e4, 1.0, 4.811805),
    (2.5, 10.0, 0.05, 1.0, 1.0, 1.0, 0.5, 1e4, 1.0, 4.811805 / 2),  # twice the excess: half the force
    (1.5, 10.0, 0.05, 1.0, 1.0, 1.0, 0.5, 1e4, 1000.0, 4811.805),  # per kg
    (1.5, 10.0, 0.05, 1.0, 1.0, 1.0, 0.5, 4000.0, 1000.0, 4000.0),  # at most f_max
    (0.5, 10.0, 0.05, 1.0, 1.0, 1.0, 0.5, 1e4, 1.0, 1e4),  # within the slack: no limit
    (1.5, 0.0, 0.05, 1.0, 1.0, 1.0, 0.5, 1e4, 1.0, 1e4),  # standing
    (1.5, 10.0, 0.0, 1.0, 1.0, 1.0, 0.5, 1e4, 1.0, 1e4),  # no tyres
]

# (v, delta, a_to, a_brake, f_max, expected) with l = 3.4, m = 1160, dt = 0.1 (the C's L_WHEELBASE, EGO_M, SAMPLE_DT):
# the path's curvature |tan(delta)| / l, its speed v_bend = sqrt(a_to / curvature), by hand
D55 = math.atan(5.5 * 3.4 / 400.0)  # at 20 m/s the formula's 5.5 m/s^2: v_bend = 20 sqrt(4.95 / 5.5) = 20 sqrt(0.9)
D50 = math.atan(5.0 * 3.4 / 400.0)  # 5.0 m/s^2: v_bend = 20 sqrt(0.99), 0.1 m/s below 20
BEND = [
    (20.0, D55, 4.95, 2.0, 1e4, -2320.0),  # (20 - 18.97) / 0.1 = 10.3 m/s^2: at most 2, -2 m
    (20.0, -D55, 4.95, 2.0, 1e4, -2320.0),  # either side
    (20.0, D50, 4.95, 2.0, 1e4, -1160.0 * 20.0 * (1.0 - math.sqrt(0.99)) / 0.1),  # 1.0025 m/s^2 takes it to v_bend
    (20.0, D55, 4.95, 10.0, 1e4, -1e4),  # -11,600 N: at most F_d_max
    (20.0, math.atan(4.9 * 3.4 / 400.0), 4.95, 2.0, 1e4, 1e4),  # within the path's speed: no cap
    (20.0, 0.0, 4.95, 2.0, 1e4, 1e4),  # straight ahead
    (20.0, D55, 4.95, 0.0, 1e4, 1e4),  # off
]

E1, E2 = math.exp(-1.0), math.exp(-0.5)  # tau = dt, tau = 2 dt
# (r, e, tau, decay, dt, expected lag e1, expected lagged rate) of the first-order steering actuator, by hand:
# e1 = r tau + (e - r tau) decay, the rate r + (e - e1) / dt
LAG = [
    (0.2, 0.01, 0.1, 0.5, 0.1, 0.015, 0.15),  # rt = 0.02: e1 = 0.02 - 0.005
    (0.3, 0.0, 0.1, E1, 0.1, 0.03 * (1.0 - E1), 0.3 * E1),  # from rest: the angle moves r (h - tau (1 - e^-1))
    (0.0, 0.02, 0.1, E1, 0.1, 0.02 * E1, 0.2 * (1.0 - E1)),  # no command: the angle catches up with the lag
    (-0.39, -0.01, 0.2, E2, 0.1, -0.078 + 0.068 * E2, -0.39 + (0.068 - 0.068 * E2) / 0.1),  # rt = -0.078
]


@pytest.mark.parametrize("r, e, tau, decay, dt, e1, rate", LAG)
def test_lag_by_hand(r, e, tau, decay, dt, e1, rate):
    assert lag_error(r, e, tau, decay) == pytest.approx(e1, rel=1e-13, abs=1e-17)
    assert lagged_rate(r, e, tau, decay, dt) == pytest.approx(rate, rel=1e-13, abs=1e-16)
    assert lag_command(lagged_rate(r, e, tau, decay, dt), e, tau, decay, dt) == pytest.approx(r, rel=1e-12, abs=1e-15)


def test_lagged_rate_is_the_closed_loops_actuator():
    """A second method: the closed loop's first-order steering actuator (``sim.plants.actuation``, which integrates
    the commanded angle and takes the actual one from the plant) gives the same rates over a run of commands."""
    from fcgen.sim.plants import PlantSpec
    from fcgen.sim.plants.actuation import Actuation

    tau, dt = 0.1, 0.1
    act, delta, e = Actuation(PlantSpec(steer_lag=tau), 0, dt), 0.05, 0.0
    for r in (0.39, 0.39, -0.2, 0.0, 0.1, -0.39, 0.0, 0.0):
        got = float(act.actuate([0.0, r], delta)[1])
        assert got == pytest.approx(lagged_rate(r, e, tau, math.exp(-dt / tau), dt), rel=1e-12, abs=1e-15)
        delta, e = delta + got * dt, lag_error(r, e, tau, math.exp(-dt / tau))


@pytest.mark.parametrize("v0, dt, expected", BRAKE)
def test_braking_force_by_hand(v0, dt, expected):
    f = braking_force(v0, M / dt, 1e4)
    assert f == pytest.approx(expected, rel=1e-15)
    assert math.copysign(1.0, f) == -1.0  # never a forward force, not even a positive zero


@pytest.mark.parametrize("v, delta, delta0, a_to, l, dt, lo, hi, expected", RATE)
def test_guard_steering_rate_by_hand(v, delta, delta0, a_to, l, dt, lo, hi, expected):
    assert guard_steering_rate(v, delta, delta0, a_to, l, dt, lo, hi) == pytest.approx(expected, rel=1e-15)


@pytest.mark.parametrize("v, delta, l, expected", A_LAT)
def test_lateral_acceleration_by_hand(v, delta, l, expected):
    assert lateral_acceleration(v, delta, l) == pytest.approx(expected, rel=1e-14, abs=0.0)


@pytest.mark.parametrize("v, a_x, k, l_f, l_r, h, expected", LOAD)
def test_load_transfer_gain_by_hand(v, a_x, k, l_f, l_r, h, expected):
    assert load_transfer_gain(v, a_x, k, l_f, l_r, h) == pytest.approx(expected, rel=1e-14)


@pytest.mark.parametrize("a_lat, a_max, f_max, expected", DRIVE)
def test_drive_limit_by_hand(a_lat, a_max, f_max, expected):
    assert drive_limit(a_lat, a_max, f_max) == pytest.approx(expected, rel=1e-15, abs=0.0)


@pytest.mark.parametrize("a_lat, v, k, l_f, l_r, h, slack, f_max, m, expected", UNDER)
def test_understeer_drive_limit_by_hand(a_lat, v, k, l_f, l_r, h, slack, f_max, m, expected):
    assert understeer_drive_limit(a_lat, v, k, l_f, l_r, h, slack, f_max, m) == pytest.approx(expected, rel=1e-6)


@pytest.mark.parametrize("v, delta, a_to, a_brake, f_max, expected", BEND)
def test_bend_brake_limit_by_hand(v, delta, a_to, a_brake, f_max, expected):
    assert bend_brake_limit(v, delta, 3.4, a_to, a_brake, 1160.0, 0.1, f_max) == pytest.approx(expected, rel=1e-9)


def test_understeer_drive_limit_keeps_the_deficit_near_its_slack():
    """A second method: at the limit's drive force, the single-track model's exact yaw divisor (unclamped K, not the
    linearization) turns the car within 10 % of ``slack`` less than the formula (fcgen's car at 15 m/s, 4.95 m/s^2)."""
    g, c, l_f, l_r, h, m, v, a, slack = 9.81, 21.92, 1.7, 1.7, 0.614, 1160.0, 15.0, 4.95, 0.25
    k = 1.0 / ((l_f + l_r) * c)
    a_x = understeer_drive_limit(a, v, k, l_f, l_r, h, slack, 1e6, m) / m
    d = 1.0 + k * (l_r / (g * l_r - a_x * h) - l_f / (g * l_f + a_x * h)) * v * v
    assert a * (1.0 - 1.0 / d) == pytest.approx(slack, rel=0.1)


def test_load_transfer_gain_is_the_single_track_yaw_gain():
    """A second method: the steady-state yaw rate of the linear single-track model (cornering stiffness per unit load c
    on both axles, axle loads m (g l_r - a_x h) / l and m (g l_f + a_x h) / l), solved from its two equilibrium
    equations, over the kinematic v delta / l, equals 1 / divisor (a car braking at 4 m/s^2 at 18 m/s)."""
    g, c, l_f, l_r, h, a_x, v, delta = 9.81, 21.92, 1.2, 1.5, 0.6, -4.0, 18.0, 0.01
    l = l_f + l_r
    cf, cr = c * (g * l_r - a_x * h) / l, c * (g * l_f + a_x * h) / l  # per unit mass
    # lateral: cf af + cr ar = v r; yaw (per unit mass): l_f cf af - l_r cr ar = 0; af = delta - beta - l_f r / v,
    # ar = -beta + l_r r / v: linear in (beta, r)
    a = [[-cf - cr, -(cf * l_f - cr * l_r) / v - v], [-l_f * cf + l_r * cr, -(l_f * l_f * cf + l_r * l_r * cr) / v]]
    rhs = [-cf * delta, -l_f * cf * delta]
    det = a[0][0] * a[1][1] - a[0][1] * a[1][0]
    r = (a[0][0] * rhs[1] - a[1][0] * rhs[0]) / det
    assert (v * delta / l) / r == pytest.approx(load_transfer_gain(v, a_x, 1.0 / (l * c), l_f, l_r, h), rel=1e-12)


def _c_function(source: str, name: str) -> str:
    """The definition of the static function ``name`` in a rendered solver file (it must be there once)."""
    found = re.findall(rf"^static {NAME}_real_t {name}\(.*?^}}\n", source, re.M | re.S)
    assert len(found) == 1, f"{name}: {len(found)} definitions in {SOLVER.name}"
    return found[0]


def _c_bits(tmp_path, prelude: str, calls: list[str]) -> list[str]:
    """Each call's double result as hex bits, from a C program of ``prelude`` (the solver's functions) compiled as the
    verification build compiles (no FP contraction)."""
    body = "\n".join(f"  put({c});" for c in calls)
    test_c = tmp_path / "bits_test.c"
    test_c.write_text(f"""#include <inttypes.h>
#include <math.h>
#include <stdio.h>
#include <string.h>
#include "{NAME}_solver.h"
{prelude}
static void put(double x) {{
  uint64_t b;
  memcpy(&b, &x, sizeof b);
  printf("%016" PRIx64 "\\n", b);
}}

int main(void) {{
{body}
  return 0;
}}
""")
    exe = tmp_path / "bits_test"
    flags = ["-std=c99", "-O2", "-Wall", "-Wextra", "-Werror", "-ffp-contract=off", f"-I{SOLVER.parent}"]
    subprocess.run(["gcc", *flags, str(test_c), "-o", str(exe), "-lm"], check=True, capture_output=True, text=True)
    return subprocess.run([str(exe)], check=True, capture_output=True, text=True).stdout.split()


@pytest.mark.skipif(shutil.which("gcc") is None, reason="needs gcc")
def test_the_c_lag_functions_give_the_same_bits(tmp_path):
    """The C's lag_error, lagged_rate and lag_command (templates/actuator.c.j2, rendered with a steering lag) give
    Python's bits on the cases above."""
    from fcgen.codegen.render import environment

    ctx = {"name": NAME, "NAME": NAME.upper(), "steer_lag": True, "lag_tau": "0.1", "lag_decay": "0.5", "delay": 0}
    src = environment().get_template("actuator.c.j2").render(**ctx, x_plan="ws.x0", x_plan_doc="x0", f_last=False)
    calls = [f"lag_error({r!r}, {e!r}, {t!r}, {d!r})" for r, e, t, d, *_ in LAG]
    calls += [f"lagged_rate({r!r}, {e!r}, {t!r}, {d!r}, {h!r})" for r, e, t, d, h, *_ in LAG]
    calls += [f"lag_command({r!r}, {e!r}, {t!r}, {d!r}, {h!r})" for r, e, t, d, h, *_ in LAG]
    prelude = "\n".join(
        ["#define TYRE_ONE ((" + NAME + "_real_t)1.0)"]
        + [_c_function(src, f) for f in ("lag_error", "lagged_rate", "lag_command")]
    )
    got = _c_bits(tmp_path, prelude, calls)
    want = [lag_error(r, e, t, d) for r, e, t, d, *_ in LAG]
    want += [lagged_rate(r, e, t, d, h) for r, e, t, d, h, *_ in LAG]
    want += [lag_command(r, e, t, d, h) for r, e, t, d, h, *_ in LAG]
    assert len(got) == len(want) == len(calls)
    for call, g, w in zip(calls, got, want):
        assert g == _bits(w), f"{call}: C {g}, Python {_bits(w)} ({w!r})"


def _bits(x: float) -> str:
    return f"{struct.unpack('<Q', struct.pack('<d', x))[0]:016x}"


@pytest.mark.skipif(shutil.which("gcc") is None, reason="needs gcc")
def test_the_c_functions_give_the_same_bits(tmp_path):
    """Every case above through the C's braking_force, guard_steering_rate and lateral_acceleration of the rendered
    double solver (compiled as the verification build compiles it: no FP contraction), against Python's."""
    src = SOLVER.read_text()
    real_0 = re.search(r"^#define REAL_0 .*$", src, re.M)
    assert real_0 is not None
    tyre = "\n".join(re.findall(r"^#define (?:TYRE_(?:G|GAIN_MIN|ONE)|L_WHEELBASE|EGO_M|SAMPLE_DT) .*$", src, re.M))
    assert tyre.count("#define") == 6
    calls = [f"braking_force({v0!r}, {M / dt!r}, 1e4)" for v0, dt, _ in BRAKE]
    calls += [f"guard_steering_rate({', '.join(map(repr, case[:-1]))})" for case in RATE]
    calls += [f"lateral_acceleration({v!r}, {delta!r}, {l!r})" for v, delta, l, _ in A_LAT]
    calls += [f"load_transfer_gain({', '.join(map(repr, case[:-1]))})" for case in LOAD]
    calls += [f"drive_limit({', '.join(map(repr, case[:-1]))})" for case in DRIVE]
    calls += [f"understeer_drive_limit({', '.join(map(repr, case[:-1]))})" for case in UNDER]
    calls += [f"bend_brake_limit({', '.join(map(repr, case[:-1]))})" for case in BEND]
    calls = [c.replace("nan", "NAN") for c in calls]
    fns = (
        "braking_force",
        "load_transfer_gain",
        "drive_limit",
        "understeer_drive_limit",
        "lateral_acceleration",
        "guard_steering_rate",
        "bend_brake_limit",
    )
    got = _c_bits(tmp_path, "\n".join([real_0.group(0), tyre] + [_c_function(src, f) for f in fns]), calls)
    want = [braking_force(v0, M / dt, 1e4) for v0, dt, _ in BRAKE]
    want += [guard_steering_rate(*case[:-1]) for case in RATE]
    want += [lateral_acceleration(v, delta, l) for v, delta, l, _ in A_LAT]
    want += [load_transfer_gain(*case[:-1]) for case in LOAD]
    want += [drive_limit(*case[:-1]) for case in DRIVE]
    want += [understeer_drive_limit(*case[:-1]) for case in UNDER]
    want += [bend_brake_limit(v, d, 3.4, a, ab, 1160.0, 0.1, f) for v, d, a, ab, f, _ in BEND]
    assert len(got) == len(want) == len(calls)
    for call, g, w in zip(calls, got, want):
        assert g == _bits(w), f"{call}: C {g}, Python {_bits(w)} ({w!r})"
