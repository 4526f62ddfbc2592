"""Build and run the contract fuzzer (tests/c/fuzz_contract.c) on a generated solver: the sanitizer flags (clang's
float-cast-overflow where clang is installed), the driver's defines from the problem, its "key value" counts.
Used by tests/test_fuzz_contract.py and scripts/fuzz_contract.py."""

from __future__ import annotations

import os
import re
import shutil
import subprocess
from pathlib import Path
from typing import NamedTuple
from unittest.mock import patch

from fcgen.build import build, run_make
from fcgen.codegen.generate import generate
from fcgen.plan_check import has_f_last
from fcgen.presets import load_problem, preset

FUZZ_DIR = Path(__file__).parent / "c"
CLANG = shutil.which("clang") is not None
CC = "clang" if CLANG else "gcc"
# gcc has no float-cast-overflow: there the solver's own range checks stand alone
SANITIZE = (
    "-fsanitize=address,undefined" + (",float-cast-overflow" if CLANG else "") + " -fno-sanitize-recover=all -g -O2"
)
LIBFUZZER = "-fsanitize=fuzzer-no-link," + SANITIZE.removeprefix("-fsanitize=")
SAN_ENV = {
    "ASAN_OPTIONS": "detect_leaks=1:halt_on_error=1:abort_on_error=0",
    "UBSAN_OPTIONS": "print_stacktrace=1:halt_on_error=1",
}
REPORT = re.compile(r"AddressSanitizer|LeakSanitizer|UndefinedBehaviorSanitizer|runtime error:")


class Fuzzed(NamedTuple):
    """A solver the contract fuzzer drives: the preset, its precision and delay compensation (Problem.delay)."""

    preset: str
    use_float: bool = False
    delay: int = 0


# one solver of each backend and precision, the hyperplane and the conventional formulation, the delay compensation
SOLVERS = {
    "ipm_double": Fuzzed("truck_lifted_ellipse_ipm_safe"),
    "ipm_float": Fuzzed("truck_lifted_ellipse_ipm_safe", use_float=True),
    "ipm_hyperplane": Fuzzed("car_direct_elimination_hyperplane_ipm_safe"),
    "osqp_conventional": Fuzzed("truck_conventional_circles"),
    "ipm_delay": Fuzzed("truck_lifted_ellipse_ipm_safe", delay=2),
}


def defines(folder: Path) -> str:
    """The driver's -D flags: the input box, the road's spacing, the band, the delay of the folder's problem and
    whether its reset keeps the actuator's memory (the delay line, the last drive force, the steering lag)."""
    pb = load_problem(str(folder / "problem.py"))
    b = pb.bounds
    keeps = int(pb.delay > 0 or has_f_last(pb) or pb.steer_lag > 0)
    return (
        f"-DFUZZ_F_D_MAX={b.F_d_max!r} -DFUZZ_R_MAX={b.r_max!r} -DFUZZ_DS={pb.road.ds!r} "
        f"-DFUZZ_N_MIN={b.n_min!r} -DFUZZ_N_MAX={b.n_max!r} -DFUZZ_DELAY={pb.delay} -DFUZZ_KEEPS={keeps}"
    )


def build_fuzzer(key: str, out: Path, libfuzzer: bool = False, qp_lib_sanitized: bool = True) -> Path:
    """Generate the solver of SOLVERS[key] into out/solver, build it with the sanitizers and the driver against it.

    ``qp_lib_sanitized=False``: OSQP's own library (third-party, the ADMM iterations: most of a feedback's time) is
    built without the sanitizers; the solver, its tables and the driver keep them (the long run's OSQP solver)."""
    fz = SOLVERS[key]
    out = out.resolve()  # make runs in FUZZ_DIR
    folder = out / "solver"
    if not (folder / "problem.py").exists():
        generate(preset(fz.preset).with_(delay=fz.delay), folder, use_float=fz.use_float)
    flags = LIBFUZZER if libfuzzer else SANITIZE
    plain = {} if qp_lib_sanitized else {"OSQP_OPTFLAGS": "-O3 -fno-sanitize=" + flags.split()[0].split("=")[1]}
    with patch.dict(os.environ, plain):  # the solver's Makefile takes OSQP_OPTFLAGS from the environment
        build(folder, cc=CC, cflags=flags)
    target = "fuzz_contract_libfuzzer" if libfuzzer else "fuzz_contract"
    run_make(
        FUZZ_DIR,
        [
            f"SOLVER_DIR={folder}",
            f"SOLVER_BUILD={folder / 'build'}",
            f"BUILD={out}",
            f"FUZZDEFS={defines(folder)}",
            target,
        ],
        cc=CC,
        cflags=flags,
    )
    return out / target


def run(cmd: list[str], **kw) -> subprocess.CompletedProcess:
    """Run under the sanitizers' options; the result, its stderr checked for a report by the caller."""
    return subprocess.run(cmd, capture_output=True, text=True, env={**os.environ, **SAN_ENV}, **kw)


def counts(stdout: str) -> dict[str, float]:
    """The driver's "key value" lines ("rc CODE n" as rc_CODE, "kind NAME n" as kind_NAME, "seconds NAME t")."""
    out: dict[str, float] = {}
    for line in stdout.splitlines():
        parts = line.split()
        if len(parts) == 2:
            out[parts[0]] = float(parts[1])
        elif len(parts) == 3 and parts[0] in ("rc", "kind", "seconds"):
            out[f"{parts[0]}_{parts[1]}"] = float(parts[2])
    return out
