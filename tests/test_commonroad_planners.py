"""The CommonRoad report's planners side by side (fcgen.report.cr_planners) on hand-made rows, ``fcgen report
--with``, and how the peer planner's script (benchmarks/reactive_planner_peer.py) picks the scenarios fcgen drove."""

from __future__ import annotations

import importlib.util
from pathlib import Path

import pandas as pd
from click.testing import CliRunner
from crrows import cr_row

from fcgen.campaign.commonroad import ROW_KEYS, write_results
from fcgen.cli import main
from fcgen.report.commonroad import commonroad_markdown

PEER = "commonroad-reactive-planner 2025.1"
US, MUC = "USA_US101-1_1_T-1", "DEU_Muc-1_1_T-1"
PAPER = "car_lift_el_ipm"  # the paper profile's names have no suffix


def _peer(scenario, traffic, status="ran", **kw):
    return cr_row(scenario, traffic, status, problem=PEER, controller="peer", **kw)


SAFE = [
    cr_row(US, "recorded", ttc_ahead_min_s=0.5, solution_valid=True, rti_ms_median=0.2),
    cr_row(
        "USA_US101-2_1_T-1",
        "recorded",
        collision_fcgen=True,
        responsibility="opponent_from_behind",
        road_departure=True,
        goal_reached=False,
        ttc_ahead_min_s=1.5,
        rti_ms_median=0.4,
    ),
    cr_row(MUC, "recorded", "refused", refusal="intersection", reason="an intersection"),
]
OTHERS = [
    cr_row(US, "recorded", problem=PAPER, criticality_error="not measured (criticality off)", rti_ms_median=0.25),
    _peer(
        US,
        "recorded",
        collision_fcgen=True,
        responsibility="ego_into_opponent",
        ttc_ahead_min_s=0.08,
        rti_ms_median=86.0,
    ),
    _peer("USA_US101-2_1_T-1", "recorded", "failed", refusal="peer could not start", reason="its frame"),
    _peer("USA_US101-3_1_T-1", "recorded", "sampled out", reason="not in the sample (--sample)"),
    _peer(MUC, "recorded", "refused", refusal="intersection", reason="fcgen refused: an intersection"),
]


def _table(md: str, title: str) -> list[str]:
    lines = md.splitlines()
    i = lines.index(f"| {title} | fcgen safe | fcgen paper | reactive planner | recorded human driver |")
    return lines[i + 2 : i + 11]


def test_the_four_planners_side_by_side_per_data_set_and_traffic_mode():
    md = commonroad_markdown(pd.DataFrame(SAFE + OTHERS, columns=list(ROW_KEYS)))
    h = "not in the files"
    assert _table(md, "USA_US101, recorded") == [
        f"| runs | 2 | 1 | 1 (a sample: 1 more not run) | {h} |",
        f"| refused or failed (why) | 0 | 0 | 1 (peer could not start 1) | {h} |",
        "| collisions: ego into opponent / opponent from behind / from the side | "
        f"0 / 1 / 0 | 0 / 0 / 0 | 1 / 0 / 0 | {h} |",
        f"| road departures after the ego was on the road | 1 | 0 | 0 | {h} |",
        f"| goal reached | 1 | 1 | 1 | {h} |",
        f"| valid solutions | 1 | 0 | 0 | {h} |",
        # the paper's run was not measured: no TTC, 0 runs measured
        f"| TTC ahead: min over the runs, s | 0.50 | - | 0.08 | {h} |",
        f"| runs with TTC ahead < 1 s (runs measured) | 1 (2) | 0 (0) | 1 (1) | {h} |",
        f"| time per cycle: median of the runs' medians, ms | 0.3 | 0.25 | 86 | {h} |",
    ]
    # Munich: fcgen's paper profile has no row there
    muc = _table(md, "DEU_Muc, recorded")
    assert muc[0] == f"| runs | 0 | not run | 0 | {h} |"
    assert muc[1] == f"| refused or failed (why) | 1 (intersection 1) | not run | 1 (intersection 1) | {h} |"
    every = _table(md, "all, recorded")
    assert every[0] == f"| runs | 2 | 1 | 1 (a sample: 1 more not run) | {h} |"
    assert (
        every[1]
        == f"| refused or failed (why) | 1 (intersection 1) | 0 | 2 (intersection 1, peer could not start 1) | {h} |"
    )
    # the left-out sample is not a refusal in the page's other tables: 7 rows, 6 of them runs or refusals
    assert "3 scenarios, 3 configurations, traffic recorded: 4 runs, 3 refused or failed." in md


def test_report_with_another_folder_puts_its_rows_beside(tmp_path):
    write_results(SAFE, tmp_path / "safe")
    write_results(OTHERS, tmp_path / "more")
    res = CliRunner().invoke(
        main, ["report", str(tmp_path / "safe"), "--with", str(tmp_path / "more"), "-o", str(tmp_path / "r")]
    )
    assert res.exit_code == 0, res.output
    md = (tmp_path / "r" / "README.md").read_text()
    assert _table(md, "USA_US101, recorded")[0] == "| runs | 2 | 1 | 1 (a sample: 1 more not run) | not in the files |"
    res = CliRunner().invoke(
        main, ["report", str(tmp_path / "safe"), "--with", str(tmp_path), "-o", str(tmp_path / "r2")]
    )
    assert res.exit_code == 1
    assert f"report: {tmp_path}: not a CommonRoad campaign's folder (no commonroad.parquet in it)" in res.output


def _peer_script():
    path = Path(__file__).resolve().parents[1] / "benchmarks" / "reactive_planner_peer.py"
    spec = importlib.util.spec_from_file_location("reactive_planner_peer", path)
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def test_the_peer_drives_a_stratified_sample_of_what_fcgen_drove_and_copies_its_refusals():
    peer = _peer_script()
    us = [f"USA_US101-{i}_1_T-1" for i in range(1, 6)]
    # 5 names, 2 picked: index floor((i + 0.5) * 5 / 2) = 1, 3; 1 name: it
    assert peer.stratified([*us, MUC], 2) == {us[1], us[3], MUC}
    assert peer.stratified([*us, MUC], 0) == {*us, MUC}
    why = {"refused": "fcgen refused: an intersection", "refusal": "intersection"}
    like = {(s, "recorded"): None for s in us} | {(MUC, "recorded"): why}
    files = [Path(f"{s}.xml") for s in [*us, MUC, "DEU_Muc-9_1_T-1"]]
    tasks = peer.select(files, ["recorded"], like, 2, {})
    got = {f.stem: w for f, _, w in tasks}
    assert [s for s in us if got[s] is None] == [us[1], us[3]]  # driven
    assert [s for s in us if got[s] == peer.SAMPLED_OUT] == [us[0], us[2], us[4]]
    assert got[MUC] == why  # fcgen's refusal copied
    assert got["DEU_Muc-9_1_T-1"]["refusal"] == "not run by fcgen"
    rows = peer.campaign_rows(
        [
            {"scenario": us[0], "traffic": "recorded", "sampled_out": True},
            {"scenario": MUC, "traffic": "recorded", **why},
            {"scenario": us[1], "traffic": "reactive", "error": "CartesianProjectionDomainError: x"},
        ]
    )
    assert [(r["status"], r["refusal"], r["controller"]) for r in rows] == [
        ("sampled out", None, "peer"),
        ("refused", "intersection", "peer"),
        ("failed", "peer could not start", "peer"),
    ]


def test_a_rows_planner_by_its_problems_name():
    """The safe profile's problem names end in ``_safe`` or carry it before a campaign's variant suffix (the corners'
    band ``_cb``, ego circles ``_e2``, delay compensation ``_d1``): all fcgen safe; the paper profile's (also with
    ``_cb``) fcgen paper; the peer's rows by their controller."""
    from fcgen.report.cr_planners import planner_of

    for name in (
        "car_lift_el_ipm_safe",
        "car_lift_el_ipm_safe_cb",
        "car_lift_el_ipm_safe_cb_e2",
        "car_lift_hp_safe_d1",
    ):
        assert planner_of(name, "c") == "fcgen safe", name
    for name in (PAPER, "car_lift_el_ipm_cb", "car_lift_el_ipm_e2"):
        assert planner_of(name, "c") == "fcgen paper", name
    assert planner_of(PEER, "peer") == "reactive planner"


def test_a_rows_planner_by_its_profile_column():
    """A row that names its profile is counted by it whatever its problem's name (a problem of the user's own, a
    variant suffix the name rule does not know); a row without one (written before the column) by its name."""
    from fcgen.report.cr_planners import planner_of

    assert planner_of("my_problem_x7", "c", "safe") == "fcgen safe"
    assert planner_of("car_lift_el_ipm_safe_x7", "c", "paper") == "fcgen paper"
    assert planner_of("car_lift_el_ipm_safe", "c", None) == "fcgen safe"
    assert planner_of("car_lift_el_ipm_safe", "c", float("nan")) == "fcgen safe"  # a missing cell read back
    assert planner_of(PEER, "peer", "safe") == "reactive planner"
