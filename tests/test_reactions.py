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

from fcgen.reactions import braking_force, guard_steering_rate, lateral_acceleration

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


def _c_function(source: str, name: str) -> str:
    """The definition of the static function ``name`` in a rendered solver file (it must be there once)."""
    found = re.findall(rf"^static {NAME}_real_t {name}\(.*?^}}\n", source, re.M | re.S)
    assert len(found) == 1, f"{name}: {len(found)} definitions in {SOLVER.name}"
    return found[0]


def _bits(x: float) -> str:
    return f"{struct.unpack('<Q', struct.pack('<d', x))[0]:016x}"


@pytest.mark.skipif(shutil.which("gcc") is None, reason="needs gcc")
def test_the_c_functions_give_the_same_bits(tmp_path):
    """Every case above through the C's braking_force, guard_steering_rate and lateral_acceleration of the rendered
    double solver (compiled as the verification build compiles it: no FP contraction), against Python's."""
    src = SOLVER.read_text()
    real_0 = re.search(r"^#define REAL_0 .*$", src, re.M)
    assert real_0 is not None
    calls = [f"braking_force({v0!r}, {M / dt!r}, 1e4)" for v0, dt, _ in BRAKE]
    calls += [f"guard_steering_rate({', '.join(map(repr, case[:-1]))})" for case in RATE]
    calls += [f"lateral_acceleration({v!r}, {delta!r}, {l!r})" for v, delta, l, _ in A_LAT]
    calls = [c.replace("nan", "NAN") for c in calls]
    body = "\n".join(f"  put({c});" for c in calls)
    test_c = tmp_path / "reactions_test.c"
    test_c.write_text(f"""#include <inttypes.h>
#include <math.h>
#include <stdio.h>
#include <string.h>
#include "{NAME}_solver.h"
{real_0.group(0)}
{_c_function(src, "braking_force")}
{_c_function(src, "lateral_acceleration")}
{_c_function(src, "guard_steering_rate")}
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
    exe = tmp_path / "reactions_test"
    subprocess.run(
        [
            "gcc",
            "-std=c99",
            "-O2",
            "-Wall",
            "-Wextra",
            "-Werror",
            "-ffp-contract=off",
            f"-I{SOLVER.parent}",
            str(test_c),
            "-o",
            str(exe),
            "-lm",
        ],
        check=True,
        capture_output=True,
        text=True,
    )
    got = subprocess.run([str(exe)], check=True, capture_output=True, text=True).stdout.split()
    want = [braking_force(v0, M / dt, 1e4) for v0, dt, _ in BRAKE]
    want += [guard_steering_rate(*case[:-1]) for case in RATE]
    want += [lateral_acceleration(v, delta, l) for v, delta, l, _ in A_LAT]
    assert len(got) == len(want) == len(calls)
    for call, g, w in zip(calls, got, want):
        assert g == _bits(w), f"{call}: C {g}, Python {_bits(w)} ({w!r})"
