"""The robustness campaign (``fcgen campaign --robustness``, docs/plants.md): its cells, a tiny grid into Parquet and
resumed, the budget guard and the one-line errors."""

from __future__ import annotations

import pytest
from click.testing import CliRunner

from fcgen.campaign.grid import Config
from fcgen.campaign.robustness import AXES, LANE_SECONDS, RUN_SECONDS, cells, estimated_minutes, robustness_grid
from fcgen.campaign.store import ResultStore
from fcgen.cli import main
from fcgen.dsl import ProblemError
from fcgen.sim.plants import DEFAULT_NOISE


def test_cells_grow_per_axis_and_start_unperturbed():
    cs = cells()
    assert cs[0].spec.is_default and cs[0].delay == 0
    lat = [c for c in cs if c.axis == "latency"]
    assert [(c.spec.latency, c.delay) for c in lat] == [(1, 0), (2, 0), (3, 0), (1, 1), (2, 2), (3, 3)]
    assert [c.spec.noise[0] / DEFAULT_NOISE[0] for c in cs if c.axis == "noise"] == [1.0, 2.0, 4.0]
    assert {c.axis for c in cs} == {"none", *AXES}
    worst = next(c for c in cs if c.magnitude == "st+lat1comp+noise+constant-velocity")
    assert (worst.spec.kind, worst.spec.latency, worst.delay, worst.spec.prediction) == (
        "st",
        1,
        1,
        "constant-velocity",
    )
    configs = [
        Config("car", "lifted", "ellipse", profile="safe"),
        Config("car", "lifted", "hyperplane", profile="safe"),
    ]
    grid = robustness_grid(configs, ("prediction",))
    assert len(grid) == 2 * 4 and len({c.key for c in grid}) == len(grid)  # every cell its own key
    with pytest.raises(ProblemError, match="axes"):
        cells(("gravity",))
    # the estimate: the sum of the runs' estimated seconds over the jobs
    per_seed = 8 * RUN_SECONDS["model"] + 2 * LANE_SECONDS  # two configurations' lane-following cells
    assert estimated_minutes(grid, 100, 200, 2) == pytest.approx(per_seed * 100 / 2 / 60)
    assert estimated_minutes(grid, 100, 100, 1) == pytest.approx(per_seed * 100 / 2 / 60)


def _args(out, *more):
    return [
        "campaign",
        "--robustness",
        "--scenarios",
        "car",
        "--formulations",
        "lifted",
        "--obstacles",
        "ellipse",
        "--controller",
        "python",
        "--profile",
        "safe",
        "--samples",
        "8",
        "--jobs",
        "1",
        "--out",
        str(out),
        *more,
    ]


def test_tiny_robustness_grid_into_parquet_and_resumed(tmp_path):
    out = tmp_path / "rob"
    res = CliRunner().invoke(main, _args(out, "--axes", "prediction", "--seeds", "1"))
    assert res.exit_code == 0, res.output
    df = ResultStore(out).read()
    assert len(df) == 4 and df["config"].nunique() == 4
    assert sorted(df["prediction"].dropna()) == ["constant-acceleration", "constant-velocity", "lane-following"]
    again = CliRunner().invoke(main, _args(out, "--axes", "prediction", "--seeds", "2"))
    assert again.exit_code == 0, again.output
    df = ResultStore(out).read()
    assert len(df) == 8 and not df.duplicated(["config", "seed"]).any()  # the new seed only, nothing twice


def test_budget_guard_and_bad_values_are_one_line(tmp_path):
    out = tmp_path / "rob"
    res = CliRunner().invoke(main, _args(out, "--seeds", "100", "--samples", "200", "--budget", "1"))
    assert res.exit_code == 1 and "--budget 1 min: pass --yes" in res.output and not out.exists()
    bad = CliRunner().invoke(main, _args(out, "--axes", "prediction,gravity"))
    assert bad.exit_code == 1 and "--axes" in bad.output and "allowed" in bad.output
    both = CliRunner().invoke(main, _args(out, "--latency", "1"))
    assert both.exit_code == 1 and "--robustness sets" in both.output
    neg = CliRunner().invoke(main, _args(out, "--budget", "-5"))
    assert neg.exit_code == 2 and "--budget" in neg.output


def test_store_keeps_the_columns_of_every_row(tmp_path):
    """A grid's unperturbed rows lack the plant columns its perturbed rows have: both kept, null where absent."""
    store = ResultStore(tmp_path / "s")
    store.write([{"config": "a", "seed": 0}, {"config": "b", "seed": 0, "prediction": "constant-velocity"}])
    df = store.read()
    assert df["prediction"].isna().tolist() == [True, False] and df["prediction"].iloc[1] == "constant-velocity"
