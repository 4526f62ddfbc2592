"""Tests of the ``fcgen`` command line (fcgen.cli) with click's CliRunner."""

from __future__ import annotations

import textwrap

import pytest
from click.testing import CliRunner

from fcgen.cli import main
from fcgen.presets import preset_names
from fcgen.sim.runlog import RunLog, summary


@pytest.fixture
def runner():
    return CliRunner()


def write_problem(path, body):
    path.write_text(textwrap.dedent(body))
    return str(path)


def test_simulate_writes_log_and_plot(runner, tmp_path):
    out, png = tmp_path / "run.json", tmp_path / "run.png"
    res = runner.invoke(main, ["simulate", "--samples", "20", "--seed", "1", "--out", str(out), "--plot", str(png)])
    assert res.exit_code == 0, res.output
    assert res.exception is None
    assert "truck_lift_el | truck seed 1 | progress " in res.output
    assert "collisions 0 samples" in res.output
    assert f"run log written to {out}" in res.output and f"plot written to {png}" in res.output
    log = RunLog.from_json(out)
    assert log.n_controls == 20 and log.meta["seed"] == 1 and log.meta["problem"] == "truck_lift_el"
    # the printed progress is the log's
    s = summary(log)
    assert f"progress {s['progress']:.2f} m" in res.output
    assert 0 < s["progress"] <= 40.0 * 2.0
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" and png.stat().st_size > 10_000


def test_simulate_with_a_problem_file(runner, tmp_path):
    path = write_problem(
        tmp_path / "mine.py",
        """
        from fcgen.presets import paper_problem
        from fcgen.dsl import Horizon
        problem = paper_problem("truck", "direct_elimination", "ellipse", name="mine", horizon=Horizon(N=20))
    """,
    )
    res = runner.invoke(main, ["simulate", "--problem", path, "--samples", "3"])
    assert res.exit_code == 0, res.output
    assert res.output.startswith("mine | truck seed 0 | progress ")


def test_presets_command_lists_all(runner):
    res = runner.invoke(main, ["presets"])
    assert res.exit_code == 0
    assert res.stdout.split() == preset_names()
    assert "_ipm" in res.stderr and "_safe" in res.stderr


def assert_clean_error(res, *words, code=None):
    """Non-zero exit through SystemExit, the words in the message, no traceback."""
    assert res.exit_code != 0
    if code is not None:
        assert res.exit_code == code
    assert isinstance(res.exception, SystemExit), repr(res.exception)
    assert "Traceback" not in res.output
    for w in words:
        assert w in res.output, res.output


def test_negative_seed(runner):
    res = runner.invoke(main, ["simulate", "--seed", "-1", "--samples", "2"])
    assert_clean_error(res, "--seed", "-1", ">=0", code=2)


def test_unknown_formulation(runner):
    res = runner.invoke(main, ["simulate", "--formulation", "foo", "--samples", "2"])
    assert_clean_error(res, "--formulation", "foo", "lifted", code=2)


def test_missing_problem_file(runner, tmp_path):
    res = runner.invoke(main, ["simulate", "--problem", str(tmp_path / "missing.py"), "--samples", "2"])
    assert_clean_error(res, "missing.py", "does not exist", code=1)


def test_unknown_preset(runner):
    res = runner.invoke(main, ["simulate", "--problem", "unknown_preset", "--samples", "2"])
    assert_clean_error(res, "unknown_preset", "truck_lifted_ellipse", code=1)


def test_problem_file_with_an_invalid_value(runner, tmp_path):
    path = write_problem(
        tmp_path / "bad.py",
        """
        from fcgen.dsl import Problem, Bounds
        problem = Problem(name="bad", bounds=Bounds(n_min=3.0, n_max=-3.0))
    """,
    )
    res = runner.invoke(main, ["simulate", "--problem", path, "--samples", "2"])
    assert_clean_error(res, "bounds.n_min", "allowed", "< n_max", code=1)


def test_problem_file_that_raises(runner, tmp_path):
    path = write_problem(tmp_path / "boom.py", "raise RuntimeError('boom')\n")
    res = runner.invoke(main, ["simulate", "--problem", path, "--samples", "2"])
    assert_clean_error(res, "boom.py", "RuntimeError", code=1)


def test_problem_file_whose_make_problem_raises(runner, tmp_path):
    # a user's make_problem() that fails is a user error too: one line, no traceback
    path = write_problem(
        tmp_path / "factory.py",
        """
        def make_problem():
            raise KeyError("no such setting")
    """,
    )
    res = runner.invoke(main, ["simulate", "--problem", path, "--samples", "2"])
    assert_clean_error(res, "factory.py", code=1)


def test_campaign_rejects_unknown_names(runner, tmp_path):
    out = tmp_path / "res"
    res = runner.invoke(main, ["campaign", "--formulations", "lifted,bogus", "--seeds", "1", "--out", str(out)])
    assert_clean_error(res, "bogus", "direct_elimination", code=1)
    res = runner.invoke(main, ["campaign", "--obstacles", "square", "--seeds", "1", "--out", str(out)])
    assert_clean_error(res, "square", "hyperplane", code=1)
    res = runner.invoke(main, ["campaign", "--scenarios", "bus", "--seeds", "1", "--out", str(out)])
    assert_clean_error(res, "bus", "truck", code=1)
    from fcgen.backends import BACKENDS

    if "ipm" not in BACKENDS:  # until the interior-point backend lands: a one-line error naming the field
        res = runner.invoke(main, ["campaign", "--backend", "ipm", "--seeds", "1", "--out", str(out)])
        assert_clean_error(res, "qp.backend = 'ipm' is invalid", "osqp", code=1)
    assert not out.exists()
