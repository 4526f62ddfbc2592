"""The robustness campaign (``fcgen campaign --robustness``, docs/plants.md): its cells, a tiny grid into Parquet and
resumed, the budget guard and the one-line errors."""

from __future__ import annotations

from dataclasses import replace

import pytest
from click.testing import CliRunner

from fcgen.campaign.grid import Config
from fcgen.campaign.robustness import (
    AXES,
    IPM_RUN_SECONDS,
    LANE_SECONDS,
    MARGIN_C,
    RUN_SECONDS,
    cells,
    estimated_minutes,
    robustness_grid,
)
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
    # the margins from the prediction's error beside the fixed margin: c = MARGIN_C, the straight line and the lane
    margins = [(c.spec.prediction, c.spec.prediction_margin) for c in cs if c.spec.prediction_margin]
    assert margins == [
        ("constant-velocity", MARGIN_C),
        ("lane-following", MARGIN_C),
        ("constant-velocity", MARGIN_C),
    ]
    grid = robustness_grid(configs, ("prediction",))
    assert len(grid) == 2 * 6 and len({c.key for c in grid}) == len(grid)  # every cell its own key
    with pytest.raises(ProblemError, match="axes"):
        cells(("gravity",))
    # the estimate: the sum of the runs' estimated seconds over the jobs
    per_seed = 12 * RUN_SECONDS["model"] + 4 * LANE_SECONDS  # two configurations' two lane-following cells
    assert estimated_minutes(grid, 100, 200, 2) == pytest.approx(per_seed * 100 / 2 / 60)
    assert estimated_minutes(grid, 100, 100, 1) == pytest.approx(per_seed * 100 / 2 / 60)
    # on resume only the runs not in the results count: half the seeds of every configuration done, half the time
    done = {(c.key, s) for c in grid for s in range(50)}
    assert estimated_minutes(grid, range(100), 200, 2, done) == pytest.approx(per_seed * 50 / 2 / 60)
    ipm = [replace(c, backend="ipm") for c in grid]  # the IPM's per-run seconds
    per_ipm = 12 * IPM_RUN_SECONDS["model"] + 4 * LANE_SECONDS
    assert estimated_minutes(ipm, 100, 200, 2) == pytest.approx(per_ipm * 100 / 2 / 60)
    lane = {(c.key, s) for c in grid for s in range(100) if c.plant.prediction == "lane-following"}
    assert estimated_minutes(grid, range(100), 200, 2, lane) == pytest.approx(8 * RUN_SECONDS["model"] * 100 / 2 / 60)


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
    assert len(df) == 6 and df["config"].nunique() == 6
    assert sorted(df["prediction"].dropna()) == [
        "constant-acceleration",
        "constant-velocity",
        "constant-velocity",
        "lane-following",
        "lane-following",
    ]
    assert sorted(df["prediction_margin"].dropna()) == [MARGIN_C, MARGIN_C]  # the two cells with the margins
    again = CliRunner().invoke(main, _args(out, "--axes", "prediction", "--seeds", "2"))
    assert again.exit_code == 0, again.output
    assert "6 configurations x 2 seeds (6 runs not yet in --out)" in again.output  # the estimate: seed 1 only
    df = ResultStore(out).read()
    assert len(df) == 12 and not df.duplicated(["config", "seed"]).any()  # the new seed only, nothing twice
    # every run done: an estimate of 0 min, so even a tiny --budget passes without --yes (8 samples: 0.2 s est.)
    done = CliRunner().invoke(main, _args(out, "--axes", "prediction", "--seeds", "2", "--budget", "0.0001"))
    assert done.exit_code == 0 and "(0 runs not yet in --out), estimated 0.0 min" in done.output
    fresh = CliRunner().invoke(
        main, _args(tmp_path / "new", "--axes", "prediction", "--seeds", "2", "--budget", "0.0001")
    )
    assert fresh.exit_code == 1 and "pass --yes" in fresh.output  # the same grid into an empty folder: refused


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


def test_report_section_counts_by_cell_and_names_where_each_axis_first_breaks(tmp_path):
    import json

    import pandas as pd

    from fcgen.report.robustness import plot, section, split_keys

    base = "car/lifted/EL/c/osqp/safe"
    qp = json.dumps({"solved": 9, "max_iter": 1})

    def row(sfx, seed, coll=False, resp="", over=None, progress=100.0):
        r = {"config": base + sfx, "seed": seed, "samples": 200, "collision": coll, "progress": progress}
        r.update(collision_responsibility=resp, qp_status_counts=qp, plan_reactions=1, a_lat_guards=0)
        if sfx:
            r.update(plant="model", a_lat_over05_samples=over or 0)
        return r

    rows = [row("", s) for s in range(2)]
    rows += [row("/model+lat1", s) for s in range(2)]
    rows += [row("/model+lat2", 0, over=1), row("/model+lat2", 1, over=0)]  # 1 of 400 samples: 0.25 % > 0.1 %
    rows += [row("/model+lat1/comp1", s, progress=90.0) for s in range(2)]
    rows += [row("/model+cv", 0, True, "ego_into_opponent"), row("/model+cv", 1, True, "opponent_from_behind")]
    df = pd.DataFrame(rows)
    sp = split_keys(df)
    assert set(sp["base"]) == {base}
    assert list(sp["magnitude"][sp["axis"] == "latency"]) == ["1", "1", "2", "2", "1+comp", "1+comp"]
    text = "\n".join(section(df))
    assert f"| {base} | prediction | constant-velocity | 2 | 1 | 1 | 0.00 % |" in text
    assert f"| {base} | latency | 1+comp | 2 | 0 | 0 | 0.00 % | 90.0 | -10.0 % | 90.0 % | 2 | 0 |" in text
    assert f"- {base}: latency at 2, prediction at constant-velocity" in text
    assert "ended early" not in text  # no run left the road
    df.loc[df["config"] == base + "/model+lat2", "ended_early_sample"] = [166.0, None]
    text = "\n".join(section(df))
    assert f"- {base}/model+lat2 seed 0: after 166 of 200 samples" in text.split("ended early")[1]
    assert f"{base}/model+lat2 seed 1: after" not in text
    assert section(df[df["config"] == base]) == []  # no perturbed rows: no section
    assert [p.name for p in plot(df, tmp_path)] == ["robustness.png", "robustness.svg"]
    assert plot(df[df["config"] == base], tmp_path / "none") == []


def test_envelope_states_per_axis_where_every_configuration_holds_and_what_breaks_first():
    """Hand-built rows of two configurations; the expected table read off the rows by hand."""
    import json

    import pandas as pd

    from fcgen.report.robustness import envelope, section, split_keys, suffix

    noise2x = suffix(next(c for c in cells() if c.magnitude == "2x"))
    cv_margin = suffix(next(c for c in cells() if c.magnitude == "constant-velocity+margin1"))
    a, b = "car/lifted/EL/c/osqp/safe", "truck/direct_elimination/HP/c/osqp/safe"
    qp = json.dumps({"solved": 10})

    def row(base, sfx, seed, resp="", over=0):
        r = {"config": base + sfx, "seed": seed, "samples": 200, "collision": bool(resp), "progress": 100.0}
        r.update(collision_responsibility=resp, qp_status_counts=qp, plan_reactions=0, a_lat_guards=0)
        return r | ({"plant": "model", "a_lat_over05_samples": over} if sfx else {})

    rows = []
    for base in (a, b):
        rows += [row(base, "", s) for s in range(2)]
        rows += [row(base, "/model+lat1", s) for s in range(2)]
        rows += [row(base, "/model+lat1/comp1", s) for s in range(2)]
        rows += [row(base, "/model+lat3", s) for s in range(2)]  # breaks nothing, but after the break at 2
        rows += [row(base, noise2x, s) for s in range(3)]  # 1x not measured
        rows += [row(base, cv_margin, s) for s in range(2)]  # the margins from the error: holds, a row of its own
    rows += [row(a, "/model+lat2", s) for s in range(2)]
    rows += [row(b, "/model+lat2", 0, over=1), row(b, "/model+lat2", 1)]  # 1 of 400 samples: 0.25 %
    rows += [row(a, "/model+cv", 0, resp="ego_into_opponent"), row(a, "/model+cv", 1)]
    rows += [row(b, "/model+cv", 0, resp="opponent_from_behind"), row(b, "/model+cv", 1)]  # not the ego's: holds
    df = pd.DataFrame(rows)
    text = "\n".join(envelope(split_keys(df)))
    assert f"| latency [samples], without compensation | 1, 2, 3 | 1 | 2 | {b} (a_lat 0.25 %) | 2 |" in text
    assert "| latency [samples], compensated | 1+comp | 1+comp | - | none | 2 |" in text
    assert "| noise [x the default stds] | 2x | 2x | - | none | 3 |" in text
    cv_row = f"| constant-velocity | 0 | constant-velocity | {a} (1 of 2 runs ego-caused) | 2 |"
    assert f"| prediction, the fixed margin {cv_row}" in text
    assert (
        "| prediction, margins from its error | constant-velocity+margin1 | constant-velocity+margin1 | - | none | 2 |"
        in text
    )
    assert "steering lag" not in text and "| plant |" not in text and "unperturbed" not in text.split("|---|")[1]
    assert "### Recommended operating envelope" in "\n".join(section(df))
    # an unperturbed configuration that misses the targets: nothing holds, named in its own row
    broken = pd.DataFrame([*rows, row(a, "", 2, resp="ego_into_opponent")])
    text = "\n".join(envelope(split_keys(broken)))
    assert f"| unperturbed | 0 | - | 0 | {a} (1 of 3 runs ego-caused) | - |" in text
    assert "| latency [samples], compensated | 1+comp | - | - | none | 2 |" in text
