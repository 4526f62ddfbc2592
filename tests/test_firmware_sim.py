"""The C closed-loop harness firmware_sim/: same run as the Python reference, same run-log format, clean CLI."""

from __future__ import annotations

import json
import shutil
import subprocess
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

from fcgen.cli import main
from fcgen.codegen.generate import GenerateInfo, generate
from fcgen.presets import load_problem, preset
from fcgen.sim.closedloop import run_closed_loop
from fcgen.sim.export import FORMAT, export_scenario
from fcgen.sim.harness import build_harness, harness_source_dir, run_harness
from fcgen.sim.runlog import RunLog, compare
from fcgen.sim.scenario import make_scenario

pytestmark = pytest.mark.skipif(any(shutil.which(t) is None for t in ("gcc", "make")), reason="needs gcc and make")

PRESET = "truck_lifted_ellipse"
SEED = 3
SAMPLES = 40


@pytest.fixture(scope="module")
def gen(tmp_path_factory) -> GenerateInfo:
    return generate(preset(PRESET), tmp_path_factory.mktemp("fw") / "solver")


@pytest.fixture(scope="module")
def exe(gen: GenerateInfo) -> Path:
    return build_harness(gen.out_dir, verify=True)


@pytest.fixture(scope="module")
def runs(gen: GenerateInfo, exe: Path) -> tuple[RunLog, RunLog, Path]:
    pb = load_problem(str(gen.out_dir / "problem.py"))
    sc = make_scenario("truck", SEED, n_opp=pb.opponents.count, samples=SAMPLES, dt=pb.horizon.dt)
    data = export_scenario(pb, sc, gen.out_dir / "scenario.txt")
    log_c = run_harness(exe, data, gen.out_dir / "run_c.json")
    log_py = run_closed_loop(pb, sc)
    return log_c, log_py, gen.out_dir / "run_c.json"


def _keys(d: dict, prefix: str = "") -> set[str]:
    out = set()
    for k, v in d.items():
        out.add(prefix + k)
        if isinstance(v, dict) and k not in ("versions", "extra"):
            out |= _keys(v, prefix + k + ".")
    return out


def test_harness_matches_python_reference(runs) -> None:
    log_c, log_py, _ = runs
    d = compare(log_c, log_py)
    print("C harness vs Python reference, max abs differences:", d)
    assert log_c.n_controls == SAMPLES
    np.testing.assert_allclose(log_c.ego_frenet, log_py.ego_frenet, rtol=0, atol=1e-6)
    np.testing.assert_allclose(log_c.ego_cartesian, log_py.ego_cartesian, rtol=0, atol=1e-6)
    np.testing.assert_allclose(log_c.control, log_py.control, rtol=1e-6, atol=1e-6)
    np.testing.assert_allclose(log_c.a_lat, log_py.a_lat, rtol=0, atol=1e-6)
    np.testing.assert_allclose(log_c.max_slack, log_py.max_slack, rtol=1e-6, atol=1e-6)
    assert np.array_equal(log_c.collision, log_py.collision)
    assert np.array_equal(log_c.qp_status, log_py.qp_status)
    assert np.array_equal(log_c.qp_iter, log_py.qp_iter)
    assert d["t"] == 0.0 and d["opp_cartesian"] == 0.0 and d["opp_frenet"] == 0.0
    assert np.all(log_c.time_feedback > 0) and np.all(log_c.time_prepare > 0)
    np.testing.assert_allclose(log_c.time_total, log_c.time_prepare + log_c.time_feedback, rtol=1e-12, atol=0)


def test_same_log_format(runs) -> None:
    log_c, log_py, path = runs
    text = path.read_text()
    raw = json.loads(text)
    assert raw["format"] == "fcgen-runlog/1"
    assert _keys(raw) == _keys(log_py.to_dict())
    assert log_c.meta["controller"] in ("c", "c-firmware_sim")
    assert log_c.meta["extra"]["harness"] == "c-firmware_sim"
    assert log_c.meta["extra"]["exit_codes_nonzero"] == 0
    for key in ("problem", "formulation", "obstacle_model", "scenario", "seed", "N", "dt", "n_bound"):
        assert log_c.meta[key] == log_py.meta[key], key
    assert log_c.ego == log_py.ego and log_c.opponents == log_py.opponents
    for key in ("s", "kappa", "gamma_x", "gamma_y", "phi_gamma", "ds"):
        assert np.array_equal(log_c.road[key], log_py.road[key]), key
    # written exactly like the Python writer: re-emitting the parsed log reproduces the file byte for byte
    assert RunLog.from_json_string(text).to_json_string() == text


def test_collision_flags_port(gen: GenerateInfo, exe: Path, tmp_path: Path) -> None:
    """An opponent parked on the ego's path: the C SAT test flags the same samples as Python's."""
    pb = load_problem(str(gen.out_dir / "problem.py"))
    sc = make_scenario("truck", SEED, n_opp=pb.opponents.count, samples=12, dt=pb.horizon.dt)
    # opponent 0 starts overlapping the ego in its lane: the run must contain overlapping samples
    sc = type(sc)(
        sc.name,
        sc.seed,
        sc.road,
        sc.x0,
        np.array([2.0, 100.0, 150.0]),
        np.array([sc.x0[1], *sc.opp_n[1:]]),
        sc.samples,
        sc.dt,
    )
    log_c = run_harness(exe, export_scenario(pb, sc, tmp_path / "sc.txt"), tmp_path / "c.json")
    log_py = run_closed_loop(pb, sc)
    np.testing.assert_allclose(log_c.ego_frenet, log_py.ego_frenet, rtol=0, atol=1e-6)
    assert log_py.collision.any()
    assert np.array_equal(log_c.collision, log_py.collision)


def test_scenario_file_round_trips(gen: GenerateInfo, tmp_path: Path) -> None:
    pb = load_problem(str(gen.out_dir / "problem.py"))
    sc = make_scenario("truck", SEED, n_opp=pb.opponents.count, samples=3, dt=pb.horizon.dt)
    path = export_scenario(pb, sc, tmp_path / "sc.txt")
    lines = path.read_text().splitlines()
    assert lines[0] == FORMAT and lines[-1] == "end"
    kappa = next(ln for ln in lines if ln.startswith("kappa ")).split()[1:]
    assert np.array_equal(np.array(kappa, dtype=float), sc.road.kappa)  # %.17g round-trips
    assert sum(ln.startswith("opp_params ") for ln in lines) == 3
    assert sum(ln.startswith("sample ") for ln in lines) == 4


def test_bad_scenario_file(exe: Path, tmp_path: Path) -> None:
    bad = tmp_path / "bad.txt"
    bad.write_text("fcgen-scenario/0\n")
    res = subprocess.run([str(exe), str(bad), str(tmp_path / "x.json")], capture_output=True, text=True)
    assert res.returncode == 2 and "fcgen-scenario/1" in res.stderr
    res = subprocess.run([str(exe)], capture_output=True, text=True)
    assert res.returncode == 1 and "usage" in res.stderr


def test_harness_compiles_warning_free(gen: GenerateInfo, tmp_path: Path) -> None:
    """The default (non-verify) build links the release libraries with -std=c99 -Wall -Wextra -Werror."""
    exe = build_harness(gen.out_dir)
    assert exe.is_file() and exe.parent == gen.out_dir / "build" / "firmware_sim"
    assert (harness_source_dir() / "closed_loop.c").is_file()


def test_cli(gen: GenerateInfo, tmp_path: Path) -> None:
    out = tmp_path / "run.json"
    res = CliRunner().invoke(
        main, ["firmware-sim", str(gen.out_dir), "--seed", str(SEED), "--samples", "5", "--out", str(out), "--verify"]
    )
    assert res.exit_code == 0, res.output
    assert "progress" in res.output and "collisions" in res.output and "C firmware_sim" in res.output
    assert RunLog.from_json(out).n_controls == 5
    res = CliRunner().invoke(main, ["firmware-sim", str(tmp_path)])
    assert res.exit_code != 0 and "Traceback" not in res.output and "_solver.h" in res.output


def test_harness_with_unequal_intervals_matches_python_reference(tmp_path: Path) -> None:
    """The ECU harness on a grid of fine then coarse intervals (its data file carries each stage's opponents at the
    node's sample): the same closed loop as the Python reference's."""
    from fcgen.dsl import Horizon, RoadWindow

    pb = preset(PRESET).with_(name="fw_grid", horizon=Horizon(N=40, stride=3, fine=20), road=RoadWindow(length=340.0))
    gen = generate(pb, tmp_path / "solver")
    exe = build_harness(gen.out_dir, verify=True)
    sc = make_scenario("truck", SEED, n_opp=pb.opponents.count, samples=SAMPLES, dt=pb.horizon.dt)
    log_c = run_harness(exe, export_scenario(pb, sc, gen.out_dir / "scenario.txt"), gen.out_dir / "run_c.json")
    log_py = run_closed_loop(pb, sc)
    np.testing.assert_allclose(log_c.ego_frenet, log_py.ego_frenet, rtol=0, atol=1e-6)
    np.testing.assert_allclose(log_c.control, log_py.control, rtol=1e-6, atol=1e-6)
    assert np.array_equal(log_c.qp_iter, log_py.qp_iter) and np.array_equal(log_c.qp_status, log_py.qp_status)
    assert log_py.ego_frenet[-1, 0] - log_py.ego_frenet[0, 0] > 40 * 0.1 * 10.0  # it drives (progress > 40 m)
