"""fcgen profiles: the paper profile's campaign rows against the safe profile's, seed by seed (synthetic rows with
hand-computed expectations), and the campaign's profile in the grid."""

from __future__ import annotations

import pandas as pd
import pytest

from fcgen.campaign.grid import Config, paper_grid
from fcgen.dsl import ProblemError
from fcgen.report.profiles import compare, markdown


def _rows(profile: str, seeds, progress, collide=(), reactions=0, t=1.0) -> pd.DataFrame:
    rows = []
    for s, p in zip(seeds, progress):
        rows.append(
            {
                "scenario": "truck",
                "formulation": "lifted",
                "model": "HP",
                "seed": s,
                "progress": p,
                "collision": s in collide,
                "collision_kind": "rear_corner" if s in collide else "",
                "collision_responsibility": "ego_into_opponent" if s in collide else "",
                "a_lat_bound": 5.0,
                "a_lat_over_samples": 2 if profile == "paper" else 0,
                "n_states": 201,
                "a_lat_excess_max": 1.5 if profile == "paper" else 0.0,
                "time_total_ms_mean": t,
                "qp_iter_mean": 6.0,
                "plan_reactions": reactions,
                "backend": "ipm",
                "profile": profile,
            }
        )
    return pd.DataFrame(rows)


def test_compare_pairs_seeds_and_counts():
    paper = _rows("paper", [0, 1, 2, 3], [400.0, 420.0, 410.0, 999.0], collide={1}, t=1.0)
    safe = _rows("safe", [0, 1, 2], [380.0, 399.0, 389.5], reactions=3, t=1.1)
    (r,) = compare(paper, safe)
    assert r["seeds"] == 3  # seed 3 only in the paper's rows: left out
    assert (r["paper_collisions"], r["safe_collisions"]) == (1, 0)
    assert r["paper_responsibility"] == "ego_into_opponent 1"
    assert r["progress_ratio"] == pytest.approx((380 + 399 + 389.5) / (400 + 420 + 410))
    assert r["paper_alat_over_pct"] == pytest.approx(100 * 6 / 603)
    assert r["time_ratio"] == pytest.approx(1.1)
    assert r["safe_reactions"] == 9
    text = markdown([r])
    assert "| truck lifted HP | 3 | 1 / 0 |" in text and "**all**" in text


def test_compare_keeps_to_the_safe_rows_backends():
    paper = pd.concat([_rows("paper", [0], [400.0]), _rows("paper", [0], [100.0]).assign(backend="osqp")])
    (r,) = compare(paper, _rows("safe", [0], [200.0]))
    assert r["progress_ratio"] == pytest.approx(0.5)  # against the IPM row, not the OSQP one


def test_the_grid_carries_the_profile():
    paper, safe = (
        paper_grid(("truck",), ("lifted",), ("hyperplane",)),
        paper_grid(("truck",), ("lifted",), ("hyperplane",), profile="safe"),
    )
    assert paper[0].key == "truck/lifted/HP/c/osqp"  # the keys of earlier results unchanged
    assert safe[0].key == "truck/lifted/HP/c/osqp/safe"
    assert safe[0].problem().name.endswith("_safe") and safe[0].problem().plan_check.react_stages > 0
    assert paper[0].problem().plan_check.react_stages == 0
    with pytest.raises(ProblemError, match="profile"):
        Config("truck", "lifted", "hyperplane", profile="careful")


def test_a_report_is_of_one_profile(tmp_path):
    """Rows of both profiles in one folder: `fcgen report` refuses them naming the way out (profiles side by side
    go through `fcgen profiles`); each profile's own folder is compared."""
    from click.testing import CliRunner

    from fcgen.campaign.store import REQUIRED_COLUMNS, ResultStore
    from fcgen.cli import main
    from fcgen.report.page import write_report

    def rows(profile: str, seed: int) -> list[dict]:
        r = {c: 0 for c in REQUIRED_COLUMNS}
        r.update(
            config=f"truck/lifted/HP/c/ipm{'/safe' if profile == 'safe' else ''}",
            scenario="truck",
            formulation="lifted",
            obstacles="hyperplane",
            model="HP",
            seed=seed,
            samples=200,
            clock="cpu",
            controller="c",
            backend="ipm",
            profile=profile,
            collision=False,
            progress=400.0 + seed,
            a_lat_bound=5.0,
            n_states=201,
            time_total_ms_mean=1.0,
            qp_iter_mean=6.0,
            time_rti_ms=[1.0],
        )
        return [r]

    ResultStore(tmp_path / "both").write(rows("paper", 0) + rows("safe", 0))
    with pytest.raises(ValueError, match=r"several profiles.*fcgen profiles"):
        write_report(tmp_path / "both", tmp_path / "report")
    ResultStore(tmp_path / "paper").write(rows("paper", 0) + rows("paper", 1))
    ResultStore(tmp_path / "safe").write(rows("safe", 1))
    res = CliRunner().invoke(
        main, ["profiles", str(tmp_path / "paper"), str(tmp_path / "safe"), "--out", str(tmp_path / "cmp.md")]
    )
    assert res.exit_code == 0, res.output
    assert "| truck lifted HP | 1 | 0 / 0 |" in res.output and (tmp_path / "cmp.md").read_text() in res.output


def test_the_report_splits_collisions_by_responsibility():
    from fcgen.report.findings import collision_why

    rows = [
        {
            "model": "HP",
            "runs_with_collision": 2,
            "collision_kinds": {"rear_corner": 1, "swept_front": 1},
            "collision_depths_m": [0.1, 0.3],
            "collision_sweeps_m": [2.0],
            "collision_responsibility": {"ego_into_opponent": 1, "opponent_from_side": 1},
            "scenario": "truck",
        },
        {
            "model": "C5",
            "runs_with_collision": 1,
            "collision_kinds": {"rear_corner": 1},
            "collision_depths_m": [0.2],
            "collision_sweeps_m": [],
            "collision_responsibility": {"ego_into_opponent": 1},
            "scenario": "truck",
        },
    ]
    text = collision_why(rows)
    assert "by responsibility (first contact): ego into opponent 2, opponent from side 1" in text
