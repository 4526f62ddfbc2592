"""The CommonRoad campaign's report (fcgen.report.commonroad), the rows kept across traffic modes
(fcgen.campaign.commonroad.write_results) and the --traffic option's errors."""

from __future__ import annotations

import pandas as pd
import pytest
from click.testing import CliRunner
from crrows import cr_row as _row

from fcgen.campaign.commonroad import ROW_KEYS, write_results
from fcgen.cli import main
from fcgen.report.commonroad import commonroad_markdown, is_commonroad, write_cr_report

ROWS = [
    _row("A", "recorded", solution_valid=True, ttc_ahead_min_s=0.8, ttc_ahead_obstacle=7, ttc_behind_min_s=3.0),
    _row(
        "B",
        "recorded",
        collision_fcgen=True,
        responsibility="opponent_from_behind",
        goal_reached=False,
        solution_valid=False,
        ttc_ahead_min_s=4.0,
        ttc_behind_min_s=0.4,
        ttc_behind_obstacle=9,
    ),
    _row("A", "reactive", solution_valid=True, ttc_ahead_min_s=1.5, reacted=5, reacted_to_ego=2),
    _row("B", "reactive", solution_valid=True, road_departure=True, reacted=3, reacted_to_ego=1, ttc_ahead_min_s=None),
    _row("C", "reactive", "refused", refusal="no planning problem", reason="C: no planning problem"),
]


def test_the_report_counts_by_traffic_mode_and_names_the_worst_runs():
    md = commonroad_markdown(pd.DataFrame(ROWS, columns=list(ROW_KEYS)))
    assert "3 scenarios, 1 configurations, traffic reactive, recorded: 4 runs, 1 refused or failed." in md
    assert "| no planning problem | reactive | 1 | C: C: no planning problem |" in md
    # recorded: one collision, an opponent from behind; reactive: one departure, 8 vehicles reacted, 3 to the ego
    assert "| car_lifted_ellipse_ipm_safe | recorded | 2 | 0 / 1 / 0 | 0 | 1 | 1 | 0 (0) |" in md
    assert "| car_lifted_ellipse_ipm_safe | reactive | 2 | 0 / 0 / 0 | 1 | 2 | 2 | 8 (3) |" in md
    # TTC ahead, recorded: runs 0.8 and 4.0: min 0.8, median 2.4, one below 1 s and 2 s
    assert "| recorded | TTC ahead | 2 | 0 | 0.80 | 0.96 | 2.40 | 3.84 | 1 | 1 |" in md
    # reactive: one run without anybody closing in ahead
    assert "| reactive | TTC ahead | 2 | 1 | 1.50 | 1.50 | 1.50 | 1.50 | 0 | 1 |" in md
    assert "| A | car_lifted_ellipse_ipm_safe | recorded | 0.80 | 7 | - |" in md
    assert "| B | car_lifted_ellipse_ipm_safe | recorded | 0.40 | 9 | opponent_from_behind |" in md


def test_rows_of_another_traffic_mode_are_kept_and_the_same_run_replaced(tmp_path):
    write_results(ROWS[:2], tmp_path)
    write_results(ROWS[2:], tmp_path)
    write_results([_row("A", "recorded", ttc_ahead_min_s=2.5)], tmp_path)
    df = pd.read_parquet(tmp_path / "commonroad.parquet")
    assert sorted(zip(df.scenario, df.traffic)) == [
        ("A", "reactive"),
        ("A", "recorded"),
        ("B", "reactive"),
        ("B", "recorded"),
        ("C", "reactive"),
    ]
    assert df[(df.scenario == "A") & (df.traffic == "recorded")].ttc_ahead_min_s.item() == 2.5
    assert is_commonroad(tmp_path)
    page = write_cr_report(tmp_path, tmp_path / "report")
    assert "3 scenarios" in page.read_text()
    res = CliRunner().invoke(main, ["report", str(tmp_path), "-o", str(tmp_path / "r2")])
    assert res.exit_code == 0, res.output
    assert (tmp_path / "r2" / "README.md").read_text() == page.read_text()


@pytest.mark.parametrize("command", ["simulate", "campaign", "record", "regress"])
def test_an_unknown_traffic_mode_is_one_line_naming_the_allowed_ones(command, tmp_path):
    args = {"record": [str(tmp_path)], "regress": [str(tmp_path), str(tmp_path)]}.get(command, [])
    res = CliRunner().invoke(main, [command, *args, "--traffic", "replay"])
    assert res.exit_code == 2
    assert "Invalid value for '--traffic': traffic 'replay' is not a traffic mode: allowed recorded, reactive" in (
        res.output
    )


def test_reactive_traffic_without_a_commonroad_scenario_is_refused():
    res = CliRunner().invoke(main, ["simulate", "--traffic", "reactive", "--samples", "2"])
    assert res.exit_code == 1
    assert "--planning-problem, --solution, --animate and --traffic go with --commonroad" in res.output
