"""ASan + UBSan (clang: float-cast-overflow too): a generated solver and the firmware_sim harness run a closed loop
without a report, and the C fuzz harness (tests/c/fuzz_api.c) drives the API with seeded random valid and invalid
call sequences (the contract fuzzer of every entry: tests/test_fuzz_contract.py)."""

from __future__ import annotations

import os
import re
import shutil
import subprocess
from pathlib import Path

import numpy as np
import pytest
from fuzzbuild import CC, CLANG, REPORT, SAN_ENV, SANITIZE

from fcgen.build import build, run_make
from fcgen.codegen.generate import generate
from fcgen.presets import load_problem, preset
from fcgen.sim.export import export_scenario
from fcgen.sim.harness import build_harness
from fcgen.sim.runlog import RunLog, summary
from fcgen.sim.scenario import make_scenario

pytestmark = pytest.mark.skipif(any(shutil.which(t) is None for t in (CC, "make")), reason="needs a C compiler, make")

FUZZ_DIR = Path(__file__).parent / "c"
SAMPLES = 50


def run_sanitized_raw(cmd: list[str]) -> subprocess.CompletedProcess:
    return subprocess.run(cmd, capture_output=True, text=True, env={**os.environ, **SAN_ENV})


def run_sanitized(cmd: list[str], **kw) -> subprocess.CompletedProcess:
    res = subprocess.run(cmd, capture_output=True, text=True, env={**os.environ, **SAN_ENV}, **kw)
    assert not REPORT.search(res.stderr), res.stderr[-4000:]
    return res


@pytest.fixture(scope="module")
def solver(tmp_path_factory) -> Path:
    """truck_lifted_ellipse built with the sanitizers (the flags are in the build's flags stamp)."""
    d = tmp_path_factory.mktemp("san") / "solver"
    generate(preset("truck_lifted_ellipse"), d)
    build(d, cc=CC, cflags=SANITIZE)
    assert SANITIZE in (d / "build" / "flags.txt").read_text()
    return d


def test_sanitized_solver_example_and_firmware_closed_loop(solver, tmp_path):
    name = next(solver.glob("*_solver.h")).name[: -len("_solver.h")]
    ex = run_sanitized([str(solver / "build" / f"{name}_example")])
    assert ex.returncode == 0 and "exit 0" in ex.stdout, ex.stdout + ex.stderr
    exe = build_harness(solver, cc=CC, cflags=SANITIZE)
    assert SANITIZE in (exe.parent / "flags.txt").read_text()
    pb = load_problem(str(solver / "problem.py"))
    sc = make_scenario("truck", 3, n_opp=pb.opponents.count, samples=SAMPLES, dt=pb.horizon.dt)
    data = export_scenario(pb, sc, tmp_path / "scenario.txt")
    res = run_sanitized([str(exe), str(data), str(tmp_path / "run.json")])
    assert res.returncode == 0, res.stderr[-4000:]
    log = RunLog.from_json(tmp_path / "run.json")
    s = summary(log)
    assert s["n_controls"] == SAMPLES and s["n_collision_samples"] == 0, s
    assert log.meta["extra"]["exit_codes_nonzero"] == 0 and np.all(np.isfinite(log.control))
    assert s["progress"] > 50.0, s  # it drove (> 10 m/s over 5 s)


def test_sanitized_firmware_closed_loop_with_perturbations(solver, tmp_path):
    """The harness's latency queue (3 samples: it wraps), steering lag and measurement errors under the sanitizers."""
    from fcgen.sim.plants import DEFAULT_NOISE, PlantSpec

    exe = build_harness(solver, cc=CC, cflags=SANITIZE)
    pb = load_problem(str(solver / "problem.py"))
    sc = make_scenario("truck", 3, n_opp=pb.opponents.count, samples=SAMPLES, dt=pb.horizon.dt)
    spec = PlantSpec(latency=3, steer_lag=0.1, noise=DEFAULT_NOISE)
    data = export_scenario(pb, sc, tmp_path / "scenario.txt", plant=spec)
    res = run_sanitized([str(exe), str(data), str(tmp_path / "run.json")])
    assert res.returncode == 0, res.stderr[-4000:]
    log = RunLog.from_json(tmp_path / "run.json")
    assert log.meta["extra"]["plant"] == spec.as_meta() and np.all(np.isfinite(log.control_applied))
    np.testing.assert_array_equal(np.asarray(log.control_applied)[3:, 0], np.asarray(log.control)[:-3, 0])


def fuzz_exe(solver: Path, out: Path, f_d_max: float | None = None) -> Path:
    pb = load_problem(str(solver / "problem.py"))
    defs = (
        f"-DFUZZ_F_D_MAX={f_d_max if f_d_max is not None else pb.bounds.F_d_max!r} "
        f"-DFUZZ_R_MAX={pb.bounds.r_max!r} -DFUZZ_DS={pb.road.ds!r}"
    )
    run_make(
        FUZZ_DIR,
        [f"SOLVER_DIR={solver}", f"SOLVER_BUILD={solver / 'build'}", f"BUILD={out}", f"FUZZDEFS={defs}"],
        cc=CC,
        cflags=SANITIZE,
    )
    return out / "fuzz_api"


def counts(stdout: str) -> dict[str, float]:
    out = {}
    for line in stdout.splitlines():
        parts = line.split()
        if len(parts) == 2 and re.fullmatch(r"-?[\d.e+-]+|nan|inf", parts[1]):
            out[parts[0]] = float(parts[1])
        elif len(parts) == 3 and parts[0] == "rc":
            out[f"rc_{parts[1]}"] = float(parts[2])
    return out


@pytest.fixture(scope="module")
def fuzz(solver, tmp_path_factory) -> Path:
    return fuzz_exe(solver, tmp_path_factory.mktemp("fuzz"))


def test_fuzz_random_call_sequences(fuzz):
    """Seed 1, 30 episodes (about 4,800 calls); FCGEN_FUZZ_SEED picks another seed (seeds 1-5 checked)."""
    res = run_sanitized([str(fuzz), os.environ.get("FCGEN_FUZZ_SEED", "1"), "30"], timeout=600)
    print(res.stdout)
    c = counts(res.stdout)
    assert res.returncode == 0, res.stdout + res.stderr[-3000:]
    assert c["violations"] == 0 and c["calls"] >= 3000 and c["invalid_calls"] >= 500, c
    assert c["rejected_with_expected_code"] == c["invalid_calls"]
    assert all(v == 0 for k, v in c.items() if k.startswith("violation_")), c
    for code in (
        "ERR_NOT_PREPARED",
        "ERR_NO_STATE",
        "ERR_NONFINITE_STATE",
        "ERR_NONFINITE_OPPONENTS",
        "ERR_NONFINITE_ROAD",
        "ERR_ROAD_WINDOW",
        "ERR_ROAD_SIZE",
    ):
        assert c.get(f"rc_{code}", 0) > 10, code  # every rejection path is exercised
    # the contract paths are exercised too: unusable QPs (with their fallback checked), projected controls
    assert c["feedback_ok"] > 100 and c["feedback_unusable_qp"] > 0 and c["fallbacks_checked"] > 0, c
    assert c["feedback_u_projected"] > 0 and c["restarts_init"] > 0 and c["restarts_reset"] > 0, c
    # capped QPs on absurd states with a step far outside the input box: refused (the harness checks that no OK
    # leaves the box by more than MAX_INPUT_VIOLATION), with the fallback checked like every unusable QP
    assert c["feedback_input_bounds"] == c.get("rc_ERR_QP_INPUT_BOUNDS", 0) > 0, c
    # the good sequence after every restart (init or reset) and among rejected calls is the fresh solver's, bitwise
    assert c["bitwise_checked"] == (30 + 1) * 8 and c["bitwise_equal"] == c["bitwise_checked"], c


def test_fuzz_is_reproducible_by_seed(fuzz):
    a, b, other = (run_sanitized([str(fuzz), s, "3"]).stdout for s in ("7", "7", "8"))
    assert a == b and a != other


def test_fuzz_reports_a_broken_expectation(solver, tmp_path):
    """The checks can fail: told that the force bound is 1 N, the harness flags the solver's controls."""
    exe = fuzz_exe(solver, tmp_path, f_d_max=1.0)
    res = run_sanitized([str(exe), "1", "2"])
    c = counts(res.stdout)
    assert res.returncode == 1 and c["violations"] > 0 and c["violation_u_outside_box"] > 0, res.stdout


@pytest.mark.skipif(not CLANG, reason="float-cast-overflow is clang's (gcc: the solver's own range checks)")
def test_the_sanitizer_flags_catch_a_float_to_int_overflow(tmp_path):
    """The class of the conventional fit's floor on accepted extreme input (an int conversion of 2.5e307): the
    project's sanitizer flags report it, so a solver with such a conversion fails the tests above."""
    src = tmp_path / "cast.c"
    src.write_text(
        "#include <stdlib.h>\nint main(int argc, char **argv) {\n"
        '  double v = strtod(argc > 1 ? argv[1] : "0", NULL);\n  return (int)v == 7;\n}\n'
    )
    subprocess.run([CC, *SANITIZE.split(), str(src), "-o", str(tmp_path / "cast")], check=True)
    fine = subprocess.run(
        [str(tmp_path / "cast"), "7.5"], capture_output=True, text=True, env={**os.environ, **SAN_ENV}
    )
    assert fine.returncode == 1 and not REPORT.search(fine.stderr), fine.stderr
    bad = subprocess.run(
        [str(tmp_path / "cast"), "2.5e307"], capture_output=True, text=True, env={**os.environ, **SAN_ENV}
    )
    assert bad.returncode != 0 and "outside the range of representable values" in bad.stderr, bad.stderr
