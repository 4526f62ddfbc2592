"""Each guard shown to fail when what it guards breaks: ``verify`` on a C constant changed by one part in a million,
``regenerate --check``'s exit code on a changed, missing or extra file, the solver cache's file lock between two real
processes (one SIGKILLed while it holds the lock)."""

from __future__ import annotations

import dataclasses
import os
import re
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
SOLVER = ROOT / "generated" / "truck_lifted_ellipse"
FCGEN = str(Path(sys.executable).with_name("fcgen"))


def fcgen(*args, timeout=300) -> subprocess.CompletedProcess:
    return subprocess.run([FCGEN, *map(str, args)], capture_output=True, text=True, timeout=timeout)


def _copy_solver(dst: Path) -> Path:
    """A copy of the checked-in solver at a new path (so its library is a new file: ctypes never reuses a library
    loaded from the same path, and each ``fcgen`` below is its own process anyway)."""
    shutil.copytree(SOLVER, dst, ignore=shutil.ignore_patterns("build", "golden"))
    shutil.rmtree(dst / "osqp" / "lib", ignore_errors=True)
    return dst


def test_verify_fails_on_a_model_constant_changed_by_one_part_in_a_million(tmp_path):
    ok = _copy_solver(tmp_path / "ok")
    res = fcgen("verify", ok, "--samples", "20")
    assert res.returncode == 0 and "PASS" in res.stdout, res.stdout + res.stderr  # the unchanged copy passes
    bad = _copy_solver(tmp_path / "bad")
    model = bad / "truck_lift_el_model.c"
    text = model.read_text()
    m = re.search(r"=(3\.3999999999999999e\+00);", text)  # a parameter of the stage's dynamics
    assert m, "the constant moved; pick another literal of the model"
    changed = float(m.group(1)) * (1 + 1e-6)
    model.write_text(text[: m.start(1)] + repr(changed) + text[m.end(1) :])
    res = fcgen("verify", bad, "--samples", "20")
    assert res.returncode == 1 and "verification failed" in res.stderr, res.stdout + res.stderr
    assert "FAIL" in res.stdout and "feedback/first control u0" in res.stdout


@pytest.mark.parametrize("damage", ["changed", "missing", "extra"])
def test_regenerate_check_exits_non_zero_on_any_difference(tmp_path, damage):
    root = tmp_path / "generated"
    _copy_solver(root / "truck_lifted_ellipse")
    res = fcgen("regenerate", "--check", root)
    assert res.returncode == 0 and "identical" in res.stdout, res.stdout + res.stderr
    d = root / "truck_lifted_ellipse"
    if damage == "changed":
        f = d / "truck_lift_el_solver.c"
        f.write_bytes(f.read_bytes().replace(b"\n", b" \n", 1))  # one byte more, nothing else
        want = "differs truck_lift_el_solver.c"
    elif damage == "missing":
        (d / "truck_lift_el_host.h").unlink()
        want = "missing truck_lift_el_host.h"
    else:
        (d / "notes.txt").write_text("x")
        want = "unexpected notes.txt"
    res = fcgen("regenerate", "--check", root)
    assert res.returncode == 1 and want in res.stdout and "differ from what fcgen generates" in res.stderr, (
        res.stdout + res.stderr
    )


_ENSURE = (
    "import sys; from fcgen.campaign.solvers import ensure_solver; from fcgen.presets import preset; "
    "print(ensure_solver(preset('truck_lifted_ellipse'), sys.argv[1]))"
)


def _blocked_on_flock(pid: int) -> bool:
    """True if ``pid`` waits for a flock (a ``->`` line of /proc/locks names the blocked requests)."""
    for line in Path("/proc/locks").read_text().splitlines():
        f = line.split()
        if "->" in f and "FLOCK" in f and str(pid) in f[f.index("->") + 4 : f.index("->") + 5]:
            return True
    return False


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="reads /proc/locks")
def test_the_solver_cache_lock_holds_a_second_process_and_survives_a_killed_builder(tmp_path):
    """Process A generates the solver into an empty cache and stops (holding the lock) before building; process B
    asks for the same solver and must wait on the lock (seen in /proc/locks), not build beside A. A is SIGKILLed
    there: the kernel drops its lock, B goes on, finds the folder unbuilt (no ready mark) and builds it."""
    cache = tmp_path / "cache"
    flag = tmp_path / "paused"
    env_a = {**os.environ, "FCGEN_PAUSE_AT": "solvers:generated", "FCGEN_PAUSE_FLAG": str(flag)}
    a = subprocess.Popen(
        [sys.executable, "-c", _ENSURE, str(cache)],
        env=env_a,
        start_new_session=True,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    b = None
    try:
        deadline = time.monotonic() + 120
        while not flag.exists():
            assert a.poll() is None, a.communicate()
            assert time.monotonic() < deadline
            time.sleep(0.05)
        (folder,) = [p for p in cache.iterdir() if p.is_dir()]
        assert not (folder / ".fcgen-ready").exists() and not (folder / "build").exists()
        b = subprocess.Popen(
            [sys.executable, "-c", _ENSURE, str(cache)],
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            text=True,
            start_new_session=True,
        )
        deadline = time.monotonic() + 60
        while not _blocked_on_flock(b.pid):
            assert b.poll() is None, ("B did not wait for A's lock", b.communicate())
            assert time.monotonic() < deadline, "B never blocked on the lock"
            time.sleep(0.05)
        time.sleep(1.0)
        assert b.poll() is None and not (folder / "build").exists()  # still waiting; nothing built beside A
        os.killpg(a.pid, signal.SIGKILL)
        a.wait()
        out, err = b.communicate(timeout=240)
        assert b.returncode == 0, err
        lib = Path(out.strip())
        assert lib.is_file() and lib.parent.parent == folder and (folder / ".fcgen-ready").is_file()
    finally:
        for p in (a, b):
            if p is not None and p.poll() is None:
                os.killpg(p.pid, signal.SIGKILL)
                p.wait()


# ----------------------------------------------------------------------------- README: float OSQP vs double

FLOAT_SEEDS = range(20)


def _progress(tmp: Path, tag: str, use_float: bool, seeds, max_iter: int | None = None) -> list[float]:
    """Closed-loop progress (m) of truck_lifted_ellipse's C build on truck seeds x 200 samples (max_iter: its ADMM
    cap instead of the preset's)."""
    from fcgen.build import build
    from fcgen.codegen.generate import generate
    from fcgen.csolver import CSolver
    from fcgen.presets import preset
    from fcgen.sim.closedloop import run_closed_loop
    from fcgen.sim.runlog import summary
    from fcgen.sim.scenario import make_scenario

    pb = preset("truck_lifted_ellipse").with_(name=f"fvd_{tag}")  # a new library name per build
    if max_iter is not None:
        pb = pb.with_(qp=dataclasses.replace(pb.qp, max_iter=max_iter))
    cs = CSolver(build(generate(pb, tmp / tag, use_float=use_float).out_dir))
    out = []
    for seed in seeds:
        cs.init()
        sc = make_scenario("truck", seed, n_opp=pb.opponents.count, samples=200, dt=pb.horizon.dt)
        out.append(summary(run_closed_loop(pb, sc, controller=cs))["progress"])
    return out


def test_float_osqp_closed_loop_within_the_readmes_bounds_of_double(tmp_path, monkeypatch):
    """docs/c_api.md: a float OSQP build (sigma raised to 1e-3) keeps the mean progress of 20 truck seeds within
    0.05 % of double, every seed within 0.5 % (measured with the ellipse presets' cap of 35 ADMM iterations: mean
    -0.003 %, worst seed 18, -0.07 %; at 40: +0.017 %, -0.36 %; at 60: -0.005 %, -0.15 %). With the double build's
    sigma (1e-6) in float at the cap of 60, seed 10 ends 12.6 % apart: the bound can fail (at 35 every seed of the 20
    stays within 0.31 %, so the check runs at 60)."""
    import numpy as np

    from fcgen.backends import osqp as osqp_backend

    dbl = np.array(_progress(tmp_path, "d", False, FLOAT_SEEDS))
    flt = np.array(_progress(tmp_path, "f", True, FLOAT_SEEDS))
    rel = flt / dbl - 1
    assert abs(flt.mean() / dbl.mean() - 1) < 5e-4, flt.mean() / dbl.mean() - 1
    assert np.max(np.abs(rel)) < 5e-3, rel
    (ref,) = _progress(tmp_path, "d60", False, [10], max_iter=60)
    monkeypatch.setattr(osqp_backend, "FLOAT_SIGMA_MIN", 1e-6)
    (bad,) = _progress(tmp_path, "f6", True, [10], max_iter=60)
    assert abs(bad / ref - 1) > 5e-3, bad / ref - 1
