"""The contract fuzzer (tests/c/fuzz_contract.c) on one solver of each backend and precision and one with delay
compensation, under ASan + UBSan (clang: float-cast-overflow too): a short seeded run here; the long run and
libFuzzer: scripts/fuzz_contract.py (docs/verification.md)."""

from __future__ import annotations

import os
import re
import shutil
from pathlib import Path

import pytest
from fuzzbuild import CC, CLANG, FUZZ_DIR, REPORT, SANITIZE, SOLVERS, build_fuzzer, counts, defines, run

from fcgen.build import run_make
from fcgen.contract import EXIT_CODES

pytestmark = pytest.mark.skipif(any(shutil.which(t) is None for t in (CC, "make")), reason="needs a C compiler, make")

TRIALS = {"osqp_conventional": 4}  # x 200 calls; 10 for the others (OSQP's capped QPs are slow under ASan)
SEED = os.environ.get("FCGEN_FUZZ_SEED", "1")
_BUILT: dict[str, Path] = {}


@pytest.fixture(scope="module")
def fuzzer(tmp_path_factory):
    def get(key: str) -> Path:
        if key not in _BUILT:
            _BUILT[key] = build_fuzzer(key, tmp_path_factory.mktemp(key))
        return _BUILT[key]

    return get


@pytest.mark.parametrize("key", sorted(SOLVERS))
def test_random_calls_keep_the_contract(fuzzer, key):
    trials = TRIALS.get(key, 10)
    res = run([str(fuzzer(key)), SEED, str(trials)], timeout=900)
    assert not REPORT.search(res.stderr), res.stderr[-4000:]
    c = counts(res.stdout)
    assert res.returncode == 0 and c["violations"] == 0, res.stdout + res.stderr[-3000:]
    assert c["calls"] == trials * 200 and c["compared"] == c["calls"], c
    assert f"progress trials {trials} calls {trials * 200} " in res.stderr, res.stderr[-2000:]
    assert all(v == 0 for k, v in c.items() if k.startswith("violation_")), c
    # every entry was called; calls refused, NULL given to getters refused, samples solved
    kinds = ("set_state", "set_road", "set_road_bounds", "set_opponents", "set_opponent_shapes", "set_reference")
    assert all(c[f"kind_{k}"] > 0 for k in (*kinds, "set_clock", "prepare", "feedback", "reset", "init", "getter")), c
    assert c["refused"] > 200 and c["null_getters"] > 10 and c["feedback_ok"] > 5, c
    for name in ("ERR_NOT_PREPARED", "ERR_NO_STATE", "ERR_ROAD_WINDOW", "ERR_ROAD_SIZE", "ERR_OPP_SHAPE"):
        assert c.get(f"rc_{EXIT_CODES.index(name)}", 0) > 0, (key, name)


def test_the_fuzzer_is_reproducible_by_seed(fuzzer):
    exe = str(fuzzer("ipm_double"))
    a, b, other = (run([exe, s, "2"], timeout=300).stdout for s in ("7", "7", "8"))
    assert a == b and a != other


def test_the_call_mix_is_the_one_given(fuzzer):
    """The weights on the command line decide the kinds drawn (the kinds not named keep the driver's)."""
    res = run([str(fuzzer("ipm_double")), "3", "2", "100", "prepare=0,feedback=0,getter=200"], timeout=300)
    c = counts(res.stdout)
    assert res.returncode == 0 and c["calls"] == 200, res.stdout + res.stderr[-2000:]
    assert c["kind_prepare"] == 0 and c["kind_feedback"] == 0 and c["kind_getter"] > 100 and c["kind_set_state"] > 0, c
    bad = run([str(fuzzer("ipm_double")), "3", "2", "100", "feedbak=2"], timeout=60)
    assert bad.returncode == 2 and "WEIGHTS" in bad.stderr


def test_the_fuzzer_reports_a_broken_expectation(fuzzer, tmp_path):
    """The checks can fail: told that the force bound is 1 N, the driver flags the solver's controls."""
    folder = fuzzer("ipm_double").parent / "solver"
    defs = re.sub(r"-DFUZZ_F_D_MAX=\S+", "-DFUZZ_F_D_MAX=1.0", defines(folder))
    variables = [f"SOLVER_DIR={folder}", f"SOLVER_BUILD={folder / 'build'}", f"BUILD={tmp_path}", f"FUZZDEFS={defs}"]
    run_make(FUZZ_DIR, [*variables, "fuzz_contract"], cc=CC, cflags=SANITIZE)
    res = run([str(tmp_path / "fuzz_contract"), "1", "3"])
    c = counts(res.stdout)
    assert res.returncode == 1 and c["violation_output"] > 0, res.stdout


@pytest.mark.skipif(not CLANG, reason="libFuzzer is clang's")
def test_the_libfuzzer_entry_runs(tmp_path):
    """The libFuzzer build of the driver (the input's bytes drive one trial) runs clean for a few hundred inputs."""
    exe = build_fuzzer("ipm_double", tmp_path, libfuzzer=True)
    (tmp_path / "corpus").mkdir()
    res = run([str(exe), str(tmp_path / "corpus"), "-runs=300", "-seed=1", "-max_len=2048"], timeout=900)
    assert res.returncode == 0 and not REPORT.search(res.stderr), res.stderr[-4000:]
    assert "Done 300 runs" in res.stderr, res.stderr[-2000:]
