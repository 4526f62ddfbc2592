"""Non-finite values are statuses, never silent: a sample without a solution (its slack is NaN, its exit code says
why) is counted by the run's summary, the CommonRoad run log, the campaign's row and its report."""

from __future__ import annotations

import math

import numpy as np
import pandas as pd
from test_runlog import make_fields

from fcgen.campaign.commonroad import ROW_KEYS, nonfinite_fields, slack_fields, summary_markdown
from fcgen.cli.options import fmt_summary
from fcgen.contract import EXIT_CODES, StepResult
from fcgen.sim.commonroad_run import unsolved_status
from fcgen.sim.runlog import RunLog, summary

INFEASIBLE = EXIT_CODES.index("ERR_QP_INFEASIBLE")
NUMERICAL = EXIT_CODES.index("ERR_QP_NUMERICAL")


def test_the_summary_counts_samples_without_a_solution_and_takes_the_slack_over_the_others():
    """Slacks [0.1, NaN, 0.3, NaN] with exit codes [OK, infeasible, OK, numerical]: the largest slack is 0.3 (not NaN),
    2 samples without a solution, one of each code; the printed line names them."""
    f = make_fields(k=4, n_opp=1)
    f["max_slack"] = np.array([0.1, math.nan, 0.3, math.nan])
    f["exit_code"] = np.array([0, INFEASIBLE, 0, NUMERICAL])
    s = summary(RunLog(**f))
    assert s["max_slack"] == 0.3
    assert s["samples_unsolved"] == 2
    assert s["unsolved_exit_codes"] == {"ERR_QP_INFEASIBLE": 1, "ERR_QP_NUMERICAL": 1}
    want = "max slack 0.3 over the solved samples (2 without a solution: ERR_QP_INFEASIBLE x1, ERR_QP_NUMERICAL x1)"
    assert want in fmt_summary(s)
    f["max_slack"] = np.array([0.1, 0.2, 0.3, 0.0])
    f["exit_code"] = np.zeros(4, dtype=np.int64)
    s = summary(RunLog(**f))
    assert (s["max_slack"], s["samples_unsolved"], s["unsolved_exit_codes"]) == (0.3, 0, {})
    assert "without a solution" not in fmt_summary(s)


def test_a_run_without_any_solution_has_no_largest_slack_rather_than_nan():
    """Every sample infeasible (a start whose band leaves the chassis no room): the summary's largest slack is
    None, printed ``none``, never ``nan``."""
    f = make_fields(k=3, n_opp=1)
    f["max_slack"] = np.full(3, math.nan)
    f["exit_code"] = np.full(3, INFEASIBLE)
    s = summary(RunLog(**f))
    assert s["max_slack"] is None and s["samples_unsolved"] == 3
    line = fmt_summary(s)
    assert "max slack none over the solved samples (3 without a solution: ERR_QP_INFEASIBLE x3)" in line
    assert "nan" not in line


def _result(code: int, slack: float) -> StepResult:
    return StepResult(np.zeros(2), code, 0, 0, 0.0, 0.0, slack)


def test_the_run_logs_status_of_samples_without_a_solution():
    res = [_result(0, 0.0), _result(INFEASIBLE, math.nan), _result(INFEASIBLE, math.nan), _result(0, 0.2)]
    assert unsolved_status(res) == {"samples": 2, "first_sample": 1, "exit_codes": {"ERR_QP_INFEASIBLE": 2}}
    assert unsolved_status(res[:1]) == {"samples": 0, "first_sample": None, "exit_codes": {}}
    # a slack that is not finite although the call returned OK is a status too
    assert unsolved_status([_result(0, math.inf)])["exit_codes"] == {"OK but non-finite slack": 1}


def _row(**kw) -> dict:
    row = dict.fromkeys(ROW_KEYS)
    row.update(
        scenario="s",
        problem="p",
        status="ran",
        collision_fcgen=False,
        collision_checker=False,
        road_departure=False,
        start_off_road=False,
        progress_m=10.0,
        rti_ms_median=0.5,
        max_abs_a_lat=1.0,
        unsolved_samples=0,
        unsolved_codes="",
        nonfinite="",
    )
    row.update(kw)
    return row


def test_a_campaign_row_and_its_report_state_the_samples_without_a_solution():
    fields = slack_fields(np.array([0.1, math.nan, 0.4]), {"samples": 1, "exit_codes": {"ERR_QP_INFEASIBLE": 1}})
    assert fields == {"max_slack": 0.4, "unsolved_samples": 1, "unsolved_codes": "ERR_QP_INFEASIBLE x1"}
    assert nonfinite_fields({"a": 1.0, "b": math.nan, "c": "x", "d": np.float64(math.inf), "e": True}) == "b, d"
    bad = _row(scenario="t", **fields)
    report = summary_markdown(pd.DataFrame([_row(), bad], columns=list(ROW_KEYS)))
    assert "1 of 2 runs, 1 samples without a solution." in report
    assert "| t | p | 1 | ERR_QP_INFEASIBLE x1 | - |" in report
    off = _row(scenario="u", road_departure=True, start_off_road=True)
    late = _row(scenario="w", road_departure=True, start_off_road=False)
    report = summary_markdown(pd.DataFrame([off, late, _row()], columns=list(ROW_KEYS)))
    assert "Road departures (checker): 2, of which 1 start off the road" in report
    assert "and 1 after the ego was on the road (an on-road start, or back from a start off it)." in report
    again = _row(scenario="v", road_departure=True, start_off_road=True, departure_again_step=70)
    report = summary_markdown(pd.DataFrame([off, late, again, _row()], columns=list(ROW_KEYS)))
    assert "Road departures (checker): 3, of which 2 start off the road" in report
    assert "and 2 after the ego was on the road" in report
    clean = summary_markdown(pd.DataFrame([_row()], columns=list(ROW_KEYS)))
    assert "## Samples without a solution, non-finite values\n\nNone." in clean
