"""fcgen report: Table III, progress, a_lat outcome and the findings from hand-made campaign rows."""

from __future__ import annotations

import math

import numpy as np
import pandas as pd
import pytest
from click.testing import CliRunner

from fcgen.campaign.store import REQUIRED_COLUMNS, ResultStore
from fcgen.cli import main
from fcgen.report import backends, findings, tables
from fcgen.report.page import busy_seconds, grid_estimate, write_report

# per formulation: (time per RTI of seed 0, of seed 1) in ms, progress of seeds 0 and 1, collision of seed 1
HAND = {
    "conventional": (([1.0, 3.0], [2.0, 2.0]), (100.0, 110.0), False),
    "direct_elimination": (([2.0, 4.0], [2.0, 4.0]), (104.0, 108.0), False),
    "lifted": (([2.0, 2.0], [2.0, 2.0]), (106.0, 116.0), True),
}


def hand_rows() -> pd.DataFrame:
    rows = []
    for form, (times, prog, hit) in HAND.items():
        for seed in (0, 1):
            t = np.array(times[seed])
            rows.append(
                {
                    "config": f"truck/{form}/EL/c/osqp",
                    "scenario": "truck",
                    "formulation": form,
                    "obstacles": "ellipse",
                    "circles": 0,
                    "model": "EL",
                    "seed": seed,
                    "samples": 2,
                    "progress": prog[seed],
                    "collision": bool(hit and seed == 1),
                    "n_collision_samples": 3 if hit and seed == 1 else 0,
                    "time_rti_ms": t.tolist(),
                    "time_total_ms_mean": t.mean(),
                    "time_prepare_ms_mean": 0.25 * t.mean(),
                    "time_feedback_ms_mean": 0.75 * t.mean(),
                    "qp_iter_mean": 60.0,
                    "qp_n": 568 if form == "lifted" else 445,
                    "qp_m": 900,
                    "qp_nnz_a": 3000,
                    "n_opp_par": 3,
                    "n_controls": 2,
                    "n_states": 3,
                    "max_slack": 0.0,
                    "a_lat_bound": 5.0,
                    "a_lat_over_samples": seed,
                    "a_lat_excess_max": 0.5 * seed,
                    "a_lat_excess_mean": 0.5 * seed,
                    "wall_s": 0.5 if seed else 1.5,
                    "cpu_s": 0.25 if seed else 0.75,
                    "t_start": 10.0 * seed,
                    "t_end": 10.0 * seed + 1.0,
                    "worker": f"w{seed}",
                    "solver_hash": "h",
                    "clock": "cpu",
                    "controller": "c",
                    "backend": "osqp",
                }
            )
    return pd.DataFrame(rows)


def test_table3_pools_every_rti_and_compares_with_conventional():
    rows = {r["formulation"]: r for r in tables.time_table(hand_rows())}
    assert rows["conventional"]["mean"] == 2.0 and math.isclose(rows["conventional"]["std"], math.sqrt(0.5))
    assert rows["direct_elimination"]["mean"] == 3.0 and rows["direct_elimination"]["std"] == 1.0
    assert rows["direct_elimination"]["vs_conv_pct"] == pytest.approx(50.0)
    assert rows["lifted"]["vs_conv_pct"] == pytest.approx(0.0) and rows["lifted"]["rtis"] == 4
    md = tables.md_time_table(list(rows.values()))
    assert "| truck | EL | 2.00 ± 0.71 | 3.00 ± 1.00 | +50.0 % | 2.00 ± 0.00 | +0.0 % |" in md
    assert "1.5 ± 0.4 | 1.9 ± 0.2 | +28.9 % | 1.4 ± 0.3 | -6.6 %" in md  # the paper's, beside


def test_progress_is_paired_by_seed_and_collisions_counted():
    rows = {r["formulation"]: r for r in tables.progress_table(hand_rows())}
    assert rows["lifted"]["vs_conv_m"] == 6.0 and rows["lifted"]["better_seeds"] == 2
    assert rows["direct_elimination"]["vs_conv_m"] == 1.0 and rows["direct_elimination"]["better_seeds"] == 1
    assert rows["lifted"]["runs_with_collision"] == 1 and rows["conventional"]["runs_with_collision"] == 0
    a = {r["formulation"]: r for r in tables.alat_table(hand_rows())}["lifted"]
    assert a["share_pct"] == pytest.approx(100 / 6) and a["runs_over"] == 1 and a["excess_max"] == 0.5


def test_findings_are_judged_on_the_rows():
    fs = findings.judge(tables.time_table(hand_rows()), tables.progress_table(hand_rows()))
    v = {f.claim.split(" (")[0]: f.verdict for f in fs}
    assert v["lifted ODE no slower than conventional"] == "holds"  # +0.0 %
    assert v["direct elimination about +30 % with EL"] == "fails"  # +50 %
    assert v["trucks: lifted and direct elimination progress further than conventional"] == "holds"
    assert v["zero collisions"] == "fails"
    de = next(f for f in fs if f.claim.startswith("direct"))
    assert "truck EL: 445 vs 445 QP variables, 60 vs 60 iterations" in de.why


def test_findings_name_the_conventional_fit_where_its_prepare_phase_dominates():
    df = hand_rows()
    conv = df["formulation"] == "conventional"
    df.loc[conv, "time_prepare_ms_mean"] = 1.8  # of 2.0 ms: the fit; DE's prepare is 0.75 ms, lifted's 0.5 ms
    fs = {f.claim.split(" (")[0]: f for f in findings.judge(tables.time_table(df), tables.progress_table(df))}
    assert "opponent fit" not in fs["direct elimination about +30 % with EL"].why  # DE (3 ms) is the slower one
    assert "opponent fit" not in fs["lifted ODE no slower than conventional"].why  # 2.0 ms both: not slower
    for i in df.index[conv]:
        df.at[i, "time_rti_ms"] = [4.0, 4.0]
    fs = {f.claim.split(" (")[0]: f for f in findings.judge(tables.time_table(df), tables.progress_table(df))}
    assert "truck EL: prepare 1.80 vs 0.50 ms" in fs["lifted ODE no slower than conventional"].why
    assert "truck EL: prepare 1.80 vs 0.75 ms" in fs["direct elimination about +30 % with EL"].why


def test_grid_estimate_scales_the_measured_wall_times():
    est = grid_estimate(hand_rows(), cores=2)
    # 3 configurations, mean CPU 0.5 s (wall 1.0 s) a run: 500 x 3 x 0.5 s on 2 cores
    assert est["runs"] == 1500 and est["core_s"] == 750.0 and est["wall_min"] == pytest.approx(6.25)
    assert est["core_s_wall"] == 1500.0
    # the solver: per configuration 2 RTIs of 2, 3 and 2 ms (mean), 500 runs each
    assert est["solver_core_s"] == pytest.approx(500 * 2 * (2.0 + 3.0 + 2.0) / 1e3)
    # runs in [0, 1] (seed 0) and [10, 11] (seed 1): 2 s of running time, the gap between does not count
    assert est["measured_span_s"] == 2.0 and est["measured_rate"] == 3.0 and est["workers"] == 2


def test_busy_seconds_is_the_union_of_the_run_intervals():
    assert busy_seconds([0, 1, 5, 5.5], [2, 3, 6, 7]) == 5.0  # [0, 3] and [5, 7]
    assert busy_seconds([], []) == 0.0


def test_write_report_writes_page_tables_and_figures(tmp_path):
    ResultStore(tmp_path / "res").write(hand_rows().to_dict("records"))
    page = write_report(tmp_path / "res", tmp_path / "rep", example=False)
    text = page.read_text()
    assert "## Table III" in text and "+50.0 %" in text and "**fails**" in text and "boxplots_truck.png" in text
    for ext in ("png", "svg"):
        assert (tmp_path / "rep" / f"boxplots_truck.{ext}").stat().st_size > 5000


def test_boxplot_outliers_are_pixels_in_the_svg(tmp_path):
    """12,000 runs have tens of thousands of outlying RTI times: drawn as one raster image, not one SVG path each."""
    df = hand_rows()
    rng = np.random.default_rng(0)
    df["time_rti_ms"] = [np.r_[np.ones(3000), 1.0 + rng.exponential(50.0, 3000)].tolist() for _ in range(len(df))]
    ResultStore(tmp_path / "res").write(df.to_dict("records"))
    write_report(tmp_path / "res", tmp_path / "rep", example=False)
    svg = (tmp_path / "rep" / "boxplots_truck.svg").read_text()
    # ~250 <use> are the text glyphs; drawn one by one, the ~9000 outliers (3 boxes x ~3000) would add 9000 more
    assert "<image" in svg and svg.count("<use") < 1000


def test_report_cli_errors_are_one_line(tmp_path):
    res = CliRunner().invoke(main, ["report", str(tmp_path), "-o", str(tmp_path / "rep")])
    assert res.exit_code == 1 and "holds no runs" in res.output and "Traceback" not in res.output
    ResultStore(tmp_path / "old").write([{"config": "x", "seed": 0, "samples": 1}])
    res = CliRunner().invoke(main, ["report", str(tmp_path / "old"), "-o", str(tmp_path / "rep")])
    assert res.exit_code == 1 and "lacks the column(s)" in res.output
    assert set(REQUIRED_COLUMNS) <= set(hand_rows().columns)


def two_backend_rows() -> pd.DataFrame:
    """hand_rows() under OSQP and again under the IPM: half the time per RTI, progress +2 m (seed 0) / -1 m (seed 1),
    10 QP iterations, no collision; seed 1 of the IPM's conventional configuration not run."""
    osqp = hand_rows()
    ipm = osqp.copy()
    ipm["backend"] = "ipm"
    ipm["config"] = ipm["config"].str.replace("/osqp", "/ipm")
    ipm["time_rti_ms"] = [list(0.5 * np.asarray(t)) for t in ipm["time_rti_ms"]]
    ipm["progress"] = ipm["progress"] + np.where(ipm["seed"] == 0, 2.0, -1.0)
    ipm["qp_iter_mean"], ipm["collision"], ipm["n_collision_samples"] = 10.0, False, 0
    ipm = ipm[~((ipm["formulation"] == "conventional") & (ipm["seed"] == 1))]
    return pd.concat([ipm, osqp], ignore_index=True)  # IPM rows first: the report still puts OSQP first


def test_two_backends_are_compared_per_configuration_and_paired_by_seed():
    df = two_backend_rows()
    assert backends.backends_of(df) == ["osqp", "ipm"]
    rows = {r["formulation"]: r for r in backends.compare(df, "osqp", "ipm")}
    de = rows["direct_elimination"]
    assert de["time_base"] == 3.0 and de["time_other"] == 1.5 and de["ratio"] == pytest.approx(0.5)
    assert de["dprog_mean"] == pytest.approx(0.5) and de["dprog_absmax"] == 2.0 and de["paired"] == 2
    assert (de["other_better"], de["other_worse"]) == (1, 1) and (de["iter_base"], de["iter_other"]) == (60, 10)
    conv = rows["conventional"]  # only seed 0 under both: paired once; times pooled per backend
    assert conv["paired"] == 1 and conv["dprog_mean"] == 2.0 and conv["time_other"] == pytest.approx(1.0)
    assert conv["ratio"] == pytest.approx(0.5)  # IPM seed 0: 0.5, 1.5 (mean 1.0) against OSQP 2.0
    assert rows["lifted"]["coll_base"] == 1 and rows["lifted"]["coll_other"] == 0
    s = backends.summary(list(rows.values()))
    assert s["ratio_geo"] == pytest.approx(0.5) and s["paired"] == 5 and s["coll_base"] == 1
    assert s["dprog_mean"] == pytest.approx((2 + (2 - 1) + (2 - 1)) / 5)  # per paired run, not per config


def test_report_of_two_backends_has_every_table_per_backend(tmp_path):
    ResultStore(tmp_path / "res").write(two_backend_rows().to_dict("records"))
    text = write_report(tmp_path / "res", tmp_path / "rep", example=False).read_text()
    for b in ("osqp", "ipm"):
        for head in (
            "Table III: time per RTI",
            "Progress and collisions",
            "The paper's findings",
            "Soft constraint",
            "Rate and the full grid",
        ):
            assert text.count(f"## {head}") == 2 and f"{head}" in text
            assert f"— QP backend {b}" in text
        for ext in ("png", "svg"):
            assert (tmp_path / "rep" / f"boxplots_truck_{b}.{ext}").stat().st_size > 5000
    assert text.index("QP backend osqp") < text.index("QP backend ipm") and "osqp truck: 3 configurations" in text
    assert text.index("osqp truck: 3 configurations x 2 seeds") < text.index("ipm truck: 3 configurations x 2 seeds")
    # OSQP's Table III is the single-backend one (+50 % for DE); the IPM's halves every time, same percentages
    assert "| truck | EL | 2.00 ± 0.71 | 3.00 ± 1.00 | +50.0 % |" in text
    assert "| truck | EL | 1.00 ± 0.50 | 1.50 ± 0.50 | +50.0 % |" in text  # conventional: IPM seed 0 only
    assert "ipm takes 0.50 x osqp's time per RTI" in text and "2.0 x faster" in text
    assert "Runs with a collision: 1 of 6 (osqp), 0 of 5 (ipm)" in text
    # the IPM's zero-collision finding holds, OSQP's fails
    fz = [line for line in text.splitlines() if line.startswith("| zero collisions")]
    assert [("**fails**" in f, "**holds**" in f) for f in fz] == [(True, False), (False, True)]


def hp_rows(kinds: bool) -> pd.DataFrame:
    """The hand rows as the hyperplane model; with ``kinds``, the collision columns of ``campaign.task``."""
    df = hand_rows()
    df["obstacles"], df["model"] = "hyperplane", "HP"
    df["config"] = df["config"].str.replace("/EL/", "/HP/")
    if kinds:
        df["collision_kind"] = np.where(df["collision"], "rear_corner", "")
        df["collision_depth_m"] = np.where(df["collision"], 0.3, 0.0)
        df["collision_sweep_m"] = 0.0
    return df


def test_the_collision_finding_explains_by_kind_of_contact():
    df = pd.concat([hp_rows(True), hp_rows(True).assign(seed=lambda d: d["seed"] + 2)], ignore_index=True)
    i = df.index[(df["formulation"] == "conventional") & (df["seed"] == 3)][0]  # a second collision: swept front
    df.loc[i, ["collision", "collision_kind", "collision_depth_m", "collision_sweep_m"]] = [
        True,
        "swept_front",
        1.1,
        7.0,
    ]
    p = tables.progress_table(df)
    lifted = next(r for r in p if r["formulation"] == "lifted")
    assert lifted["collision_kinds"] == {"rear_corner": 2} and lifted["collision_depths_m"] == [0.3, 0.3]
    f = findings.judge(tables.time_table(df), p)[-1]
    assert f.verdict == "fails" and f.evidence.startswith("3 of 12 runs collide")
    # 3 runs: depths 0.3, 0.3, 1.1 (median 0.3); 1 swept (7.0 m), 2 rear corners
    assert "of the 3 colliding runs without EL (penetration median 0.30 m, deepest 1.10 m)" in f.why
    assert "1 (33 %) touch the front corner of a truck that the road's bend swept 7.0 m (median)" in f.why
    assert "2 (67 %) clip an opponent's rear corner" in f.why
    assert "EL" not in f.why.split("without EL")[1]  # no EL row collides: no ellipse sentence


def test_the_collision_finding_without_kinds_names_the_mechanisms():
    f = findings.judge(tables.time_table(hp_rows(False)), tables.progress_table(hp_rows(False)))[-1]
    assert f.why == findings.GENERIC
    assert (
        findings.judge(
            tables.time_table(hp_rows(True).assign(collision=False)),
            tables.progress_table(hp_rows(True).assign(collision=False)),
        )[-1].why
        == ""
    )


def test_the_ellipse_collisions_are_compared_with_its_shortfall():
    df = hand_rows()  # truck EL: lifted seed 1 collides
    df["collision_kind"] = np.where(df["collision"], "rear_corner", "")
    df["collision_depth_m"] = np.where(df["collision"], 0.11, 0.0)
    df["collision_sweep_m"] = 0.0
    why = findings.judge(tables.time_table(df), tables.progress_table(df))[-1].why
    # the truck rectangle (26 x 4 m) grown by the ego's circle (r = 2.21 m) sticks out of the ellipse by 0.34 m
    assert "truck EL (1 runs)" in why and "by up to 0.34 m while the ellipse constraint holds" in why
    assert "all within it (deepest 0.11 m)" in why and "without EL" not in why
    df.loc[df["collision"], "collision_depth_m"] = 0.5
    assert "holds (deepest 0.50 m)" in findings.judge(tables.time_table(df), tables.progress_table(df))[-1].why
