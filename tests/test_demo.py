"""`fcgen demo` (the README's main job) end to end on a short run: generate, build, C harness vs Python."""

import json

from click.testing import CliRunner

from fcgen.cli import main
from fcgen.sim.runlog import RunLog


def test_demo_runs_c_and_python_and_they_match(tmp_path):
    out = tmp_path / "demo"
    res = CliRunner().invoke(main, ["demo", "--samples", "12", "--seed", "1", "--out", str(out), "--no-plot"])
    assert res.exit_code == 0, res.output
    assert "MATCH" in res.output and "MISMATCH" not in res.output
    c = RunLog.from_json(out / "run_c.json")
    py = RunLog.from_json(out / "run_python.json")
    assert c.meta["controller"] == "c-firmware_sim" and py.meta["controller"] == "python-reference"
    assert c.n_controls == py.n_controls == 12
    # the harness's plant moved the ego: progress is physical (about v * t for v in [15, 40] m/s over 1.2 s)
    progress = c.ego_frenet[-1, 0] - c.ego_frenet[0, 0]
    assert 15 * 1.2 * 0.9 < progress < 40 * 1.2
    assert json.loads((out / "run_c.json").read_text())["meta"]["seed"] == 1


def test_demo_shows_the_ipm_beside_osqp_on_the_same_scenario(tmp_path):
    out = tmp_path / "demo"
    res = CliRunner().invoke(main, ["demo", "--samples", "8", "--seed", "2", "--out", str(out), "--no-plot"])
    assert res.exit_code == 0, res.output
    header = next(line for line in res.output.splitlines() if "C, OSQP (asked for)" in line)
    assert "Python reference, OSQP" in header and "C, IPM" in header and "C, IPM, safe profile" in header
    c, ipm = RunLog.from_json(out / "run_c.json"), RunLog.from_json(out / "run_c_ipm.json")
    # the same scenario: the same start and the same opponents' initial poses, then each controller's own plan
    assert (c.ego_frenet[0] == ipm.ego_frenet[0]).all()
    assert ipm.meta["problem"] == "truck_lift_el_ipm" and c.meta["problem"] == "truck_lift_el"
    # every status printed as a row of counts that add up to the samples, each explained once under the table
    for st in ("solved",):
        row = next(line for line in res.output.splitlines() if line.startswith(f"QP status {st} "))
        counts = [int(x) for x in row.split("|")[1:]]
        assert counts[2] == int((ipm.qp_status == 1).sum())
        assert any(line.strip().startswith(f"{st}: ") for line in res.output.splitlines())
    assert "which to pick" in res.output


def test_demo_shows_the_safe_profile_beside_the_papers_settings(tmp_path):
    """The recommended settings on the same scenario: the safe profile's IPM preset of the problem, in C. Over the
    default run's first 120 samples (the ego enters the first bends) the paper's settings exceed the a_lat bound and
    the safe profile keeps it."""
    out = tmp_path / "demo"
    res = CliRunner().invoke(main, ["demo", "--samples", "120", "--out", str(out), "--no-plot", "--no-ipm"])
    assert res.exit_code == 0, res.output
    c, safe = RunLog.from_json(out / "run_c.json"), RunLog.from_json(out / "run_c_safe.json")
    assert safe.meta["problem"] == "truck_lift_el_ipm_safe" and (c.ego_frenet[0] == safe.ego_frenet[0]).all()
    assert abs(c.a_lat).max() > 5.5 and abs(safe.a_lat).max() <= 5.0
    assert not safe.collision.any()
    assert "for an actuator: the safe profile" in res.output
