"""CommonRoad at scale: the scenario list and its hash check (fcgen.commonroad.catalog), the refusals by kind
(fcgen.commonroad.drivable, on scenarios the tests write with commonroad-io), the campaign counting them and resuming
(fcgen.campaign.cr_run), and the report's page per data set (fcgen.report.commonroad)."""

from __future__ import annotations

import hashlib
import math
import subprocess
import warnings
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from click.testing import CliRunner
from crrows import cr_row as _row
from crscenes import write_scenario

from fcgen.campaign.commonroad import ROW_KEYS, load_for
from fcgen.campaign.cr_run import run_cr_campaign
from fcgen.campaign.grid import paper_grid
from fcgen.commonroad import ScenarioRefused
from fcgen.commonroad.catalog import (
    ListedScenario,
    dataset_of,
    fetch,
    git_blob_of,
    mismatch,
    read_list,
    write_list,
)
from fcgen.presets import preset
from fcgen.report.commonroad import commonroad_markdown

PB = preset("car_lifted_ellipse_ipm_safe")
LISTED = "docs/commonroad/commonroad_search_scenarios.csv"


def _listed(name: str, data: bytes, sha: bool = True) -> ListedScenario:
    return ListedScenario(
        name,
        dataset_of(name),
        hashlib.sha256(data).hexdigest() if sha else "",
        git_blob_of(data),
        "owner/repo",
        "0" * 40,
        f"scenarios/{name}",
    )


def test_the_checked_in_list_names_every_scenario_of_the_course_repository(request):
    rows = read_list(request.config.rootpath / LISTED)
    assert len(rows) == 296  # scenarios/exercise (294) and scenarios/tutorial (2) at the pinned commit
    assert {r.source_commit for r in rows} == {"f555cef2ec8530e0f6f58bffce780a1e6c86c3ff"}
    sets = {r.dataset for r in rows}
    assert {"USA_US101", "USA_Lanker", "USA_Peach", "DEU_Muc", "CHN_Sha", "RUS_Bicycle", "ZAM_Tutorial"} <= sets
    # the 30 US-101 files of the earlier list, with the same hashes
    us101 = pd.read_csv(request.config.rootpath / "docs/commonroad/us101_scenarios.csv")
    by_name = {r.file: r.sha256 for r in rows}
    assert all(by_name[f] == h for f, h in zip(us101.file, us101.sha256, strict=True))


def test_data_sets_and_list_rows_are_validated():
    assert dataset_of("USA_US101-7_1_T-1.xml") == "USA_US101"
    assert dataset_of("DEU_Hhr-1_1") == "DEU_Hhr"
    with pytest.raises(ValueError, match="sha256 'abc' is not 64"):
        ListedScenario("A-1.xml", "A", "abc", "0" * 40, "o/r", "0" * 40, "p")
    with pytest.raises(ValueError, match="dataset 'B' is not 'A'"):
        ListedScenario("A-1.xml", "B", "", "0" * 40, "o/r", "0" * 40, "p")
    with pytest.raises(ValueError, match="bare"):
        ListedScenario("x/A-1.xml", "A", "", "0" * 40, "o/r", "0" * 40, "p")


def test_the_git_blob_id_is_gits_own(tmp_path):
    data = b"<commonRoad/>\n"
    (tmp_path / "f.xml").write_bytes(data)
    got = subprocess.run(["git", "hash-object", str(tmp_path / "f.xml")], capture_output=True, text=True, check=True)
    assert git_blob_of(data) == got.stdout.strip()


def test_fetch_keeps_only_files_with_the_lists_hash(tmp_path):
    src, cache = tmp_path / "src", tmp_path / "cache"
    src.mkdir()
    good, bad, blob = b"<a/>", b"<b/>", b"<c/>"
    (src / "A-1.xml").write_bytes(good)
    (src / "B-1.xml").write_bytes(bad + b" tampered")
    (src / "C-1.xml").write_bytes(blob)
    rows = [
        _listed("A-1.xml", good),
        _listed("B-1.xml", bad),
        _listed("C-1.xml", blob, sha=False),
        _listed("D-1.xml", b""),
    ]
    write_list(rows, tmp_path / "list.csv")
    assert read_list(tmp_path / "list.csv") == rows
    lines: list[str] = []
    counts = fetch(rows, cache, str(src), echo=lines.append)
    assert counts == {"fetched": 2, "cached": 0, "mismatch": 1, "failed": 1}
    assert sorted(p.name for p in cache.iterdir()) == ["A-1.xml", "C-1.xml"]
    assert any(line.startswith("B-1.xml: sha256 ") and "differs from the list's" in line for line in lines)
    assert fetch(rows[:1], cache, str(src), echo=lines.append)["cached"] == 1
    assert mismatch(rows[2], blob) == "" and "git blob" in mismatch(rows[2], bad)


def test_fetch_from_a_git_clone_at_the_pinned_commit(tmp_path):
    repo = tmp_path / "repo"
    git = ["git", "-C", str(repo), "-c", "user.name=t", "-c", "user.email=t@t"]
    subprocess.run(["git", "init", "-q", str(repo)], check=True)
    (repo / "scenarios").mkdir()
    (repo / "scenarios" / "A-1.xml").write_bytes(b"<v1/>")
    subprocess.run([*git, "add", "."], check=True)
    subprocess.run([*git, "commit", "-qm", "v1"], check=True)
    commit = subprocess.run([*git, "rev-parse", "HEAD"], capture_output=True, text=True, check=True).stdout.strip()
    (repo / "scenarios" / "A-1.xml").write_bytes(b"<v2/>")  # the work tree moved on: the pinned commit's bytes count
    row = ListedScenario(
        "A-1.xml", "A", hashlib.sha256(b"<v1/>").hexdigest(), git_blob_of(b"<v1/>"), "o/r", commit, "scenarios/A-1.xml"
    )
    assert fetch([row], tmp_path / "cache", str(repo), echo=print)["fetched"] == 1
    assert (tmp_path / "cache" / "A-1.xml").read_bytes() == b"<v1/>"


# --- refusals by kind, on scenarios written with commonroad-io ---------------------------------------------------


def _edit(path, *, lanelet=None, obstacle=None, drop_problem=False):
    """Rewrite a scenario with one more lanelet (its id and centre vertices; 3.5 m wide), one more obstacle, or
    without its planning problem."""
    from commonroad.common.file_reader import CommonRoadFileReader
    from commonroad.common.file_writer import CommonRoadFileWriter, OverwriteExistingFile
    from commonroad.planning.planning_problem import PlanningProblemSet
    from commonroad.scenario.lanelet import Lanelet

    sc, pps = CommonRoadFileReader(str(path)).open()
    if lanelet is not None:
        lid, centre = lanelet
        d = np.diff(centre, axis=0)[0]
        nrm = np.array([-d[1], d[0]]) / np.hypot(*d)
        sc.lanelet_network.add_lanelet(Lanelet(centre + 1.75 * nrm, centre, centre - 1.75 * nrm, lid))
    if obstacle is not None:
        sc.add_objects(obstacle)
    if drop_problem:
        pps = PlanningProblemSet([])
    CommonRoadFileWriter(sc, pps, "fcgen tests", "fcgen", "written by the tests", set()).write_to_file(
        str(path), OverwriteExistingFile.ALWAYS
    )
    return path


def _goal_on_lanelet(path, lid: int):
    """The goal's position as a lanelet reference (as CommonRoad files give it), in place of its rectangle."""
    import re

    text = path.read_text()
    text = re.sub(
        r"(<goalState>.*?<position>).*?(</position>)", rf'\1<lanelet ref="{lid}"/>\2', text, count=1, flags=re.S
    )
    path.write_text(text)
    return path


def _vehicle(oid: int, xy0, heading: float, v: float, steps: int, shape=None):
    from commonroad.geometry.shape import Rectangle
    from commonroad.prediction.prediction import TrajectoryPrediction
    from commonroad.scenario.obstacle import DynamicObstacle, ObstacleType
    from commonroad.scenario.state import InitialState, KSState
    from commonroad.scenario.trajectory import Trajectory

    shp = shape or Rectangle(4.5, 1.8)
    d = np.array([math.cos(heading), math.sin(heading)])
    pts = [np.asarray(xy0, float) + v * 0.1 * k * d for k in range(steps)]
    init = InitialState(
        position=pts[0], orientation=heading, velocity=v, time_step=0, yaw_rate=0.0, slip_angle=0.0, acceleration=0.0
    )
    traj = [
        KSState(position=p, orientation=heading, velocity=v, steering_angle=0.0, time_step=k)
        for k, p in enumerate(pts)
        if k
    ]
    return DynamicObstacle(oid, ObstacleType.CAR, shp, init, TrajectoryPrediction(Trajectory(1, traj), shp))


def _line(x0, y0, x1, y1, n=31):
    return np.stack([np.linspace(x0, x1, n), np.linspace(y0, y1, n)], axis=1)


def _polygon():
    from commonroad.geometry.shape import Polygon

    return Polygon(np.array([[-2.0, -1.0], [2.0, -1.0], [2.5, 0.0], [2.0, 1.0], [-2.0, 1.0]]))


def scenario_cases(folder):
    """One scenario per kind of refusal (file name -> kind) and one fcgen drives, written into ``folder``."""
    w = lambda name, **kw: write_scenario(folder / name, **kw)
    cases = {
        # a lane crossing the ego's at right angles 70 m ahead (within the 40 samples at 20 m/s plus the horizon)
        "ZAM_Cross-1_1_T-1.xml": (
            _edit(w("ZAM_Cross-1_1_T-1.xml"), lanelet=(900, _line(120.0, -30.0, 120.0, 30.0))),
            "intersection",
        ),
        # a lane against the ego's direction over its own lane 100-150 m ahead
        "ZAM_TwoWay-1_1_T-1.xml": (
            _edit(w("ZAM_TwoWay-1_1_T-1.xml"), lanelet=(901, _line(200.0, 0.0, 150.0, 0.0))),
            "oncoming traffic",
        ),
        # a vehicle driving against the road in the ego's lane
        "ZAM_Ghost-1_1_T-1.xml": (
            _edit(w("ZAM_Ghost-1_1_T-1.xml"), obstacle=_vehicle(7, (180.0, 0.0), math.pi, 10.0, 40)),
            "oncoming traffic",
        ),
        "ZAM_Poly-1_1_T-1.xml": (
            _edit(w("ZAM_Poly-1_1_T-1.xml"), obstacle=_vehicle(8, (120.0, 3.5), 0.0, 15.0, 40, _polygon())),
            "non-rectangular obstacle",
        ),
        # the goal on a lane that no successor or neighbour of the ego's leads to
        "ZAM_Island-1_1_T-1.xml": (
            _goal_on_lanelet(
                _edit(
                    w("ZAM_Island-1_1_T-1.xml", goal={"lane": 144, "s": 50.0}),
                    lanelet=(902, _line(0.0, 500.0, 100.0, 500.0)),
                ),
                902,
            ),
            "goal unreachable",
        ),
        "ZAM_NoProblem-1_1_T-1.xml": (_edit(w("ZAM_NoProblem-1_1_T-1.xml"), drop_problem=True), "no planning problem"),
        "ZAM_Short-1_1_T-1.xml": (w("ZAM_Short-1_1_T-1.xml", length=80.0, ego_x=40.0), "path shorter than the horizon"),
    }
    return cases


def test_each_refusal_names_its_kind_in_one_line(tmp_path):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        for name, (path, kind) in scenario_cases(tmp_path).items():
            with pytest.raises(ScenarioRefused) as e:
                load_for(PB, path)
            assert e.value.kind == kind, (name, str(e.value))
            assert "\n" not in str(e.value)
        # the plain three-lane road is driven: none of the checks refuses it
        assert load_for(PB, write_scenario(tmp_path / "ZAM_Plain-1_1_T-1.xml")).samples == 40


def _net(exit_connected: bool, angle: float = 0.7):
    """A lane along x split at x = 100 into a lane straight on and an exit lane at ``angle`` (rad; a successor of the
    first lane, or, unconnected, a lane that only crosses the route there)."""
    from commonroad.scenario.lanelet import Lanelet, LaneletNetwork

    def lane(lid, centre, **kw):
        d = np.diff(centre, axis=0)[0]
        nrm = np.array([-d[1], d[0]]) / np.hypot(*d)
        return Lanelet(centre + 1.75 * nrm, centre, centre - 1.75 * nrm, lid, **kw)

    exit_line = _line(100.0, 0.0, 100.0 + 60.0 * math.cos(angle), 60.0 * math.sin(angle))
    lls = [
        lane(1, _line(0.0, 0.0, 100.0, 0.0), successor=[2, 3] if exit_connected else [2]),
        lane(2, _line(100.0, 0.0, 400.0, 0.0), predecessor=[1]),
        lane(3, exit_line, predecessor=[1] if exit_connected else None),
    ]
    return LaneletNetwork.create_from_lanelet_list(lls)


def test_a_lane_that_forks_off_is_not_a_crossing_one_that_crosses_is():
    from fcgen.commonroad.drivable import check_route
    from fcgen.road import straight_road

    road = straight_road(400.0)
    check_route(_net(True), road, 50.0, 200.0)  # the exit forks off lane 1: driven
    with pytest.raises(ScenarioRefused, match=r"lanelet 3 crosses the route 5\d m ahead at 40 degrees") as e:
        check_route(_net(False), road, 50.0, 200.0)
    assert e.value.kind == "intersection"
    check_route(_net(False), road, 50.0, 40.0)  # the crossing lies beyond what the run can reach
    with pytest.raises(ScenarioRefused, match="at 80 degrees"):  # a turning lane off the route's lane crosses it
        check_route(_net(True, math.radians(80.0)), road, 50.0, 200.0)


def test_the_campaign_counts_refusals_by_kind_refuses_a_changed_file_and_resumes(tmp_path):
    folder = tmp_path / "cache"
    folder.mkdir()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        cases = scenario_cases(folder)
    rows = [_listed(p.name, p.read_bytes()) for p, _ in cases.values()]
    rows.append(_listed("ZAM_Missing-1_1_T-1.xml", b"<gone/>"))
    changed = cases["ZAM_Short-1_1_T-1.xml"][0]
    changed.write_bytes(changed.read_bytes() + b"<!-- changed -->")
    write_list(rows, tmp_path / "list.csv")
    configs = paper_grid(["car"], ["lifted"], ["ellipse"], "python", "ipm", "safe")
    lines: list[str] = []
    out = tmp_path / "res"

    def campaign():
        return run_cr_campaign(
            configs,
            folder,
            out,
            str(tmp_path / "solvers"),
            jobs=1,
            echo=lines.append,
            scenario_list=tmp_path / "list.csv",
            criticality=False,
        )

    got = campaign()
    kinds = {r["file"]: r["refusal"] for r in got}
    want = {name: kind for name, (_, kind) in cases.items()}
    want["ZAM_Short-1_1_T-1.xml"] = "hash differs"
    want["ZAM_Missing-1_1_T-1.xml"] = "not in the cache"
    assert kinds == want
    assert all(r["status"] == "refused" and r["dataset"] == r["file"].split("-")[0] for r in got)
    assert "refused ZAM_Short-1_1_T-1.xml (hash differs): ZAM_Short-1_1_T-1.xml: sha256 " in "\n".join(lines)
    # the file put right: a second call runs again only the runs refused for their file
    changed.write_bytes(changed.read_bytes().replace(b"<!-- changed -->", b""))
    lines.clear()
    got = campaign()
    assert lines[0] == f"8 runs, 6 already in {out}, 2 to run (1 processes)"
    assert {r["file"]: r["refusal"] for r in got}["ZAM_Short-1_1_T-1.xml"] == "path shorter than the horizon"
    assert len(pd.read_parquet(out / "commonroad.parquet")) == 8


def test_an_unknown_traffic_mode_is_one_line_naming_the_allowed_ones(tmp_path):
    from fcgen.cli import main

    r = CliRunner().invoke(main, ["campaign", "--commonroad", str(tmp_path), "--traffic", "polite"])
    assert r.exit_code == 2 and "recorded" in r.output and "reactive" in r.output and "polite" in r.output


# --- the report's page per data set -------------------------------------------------------------------------------


def test_the_report_groups_by_data_set_and_traffic_mode_with_refusals_by_reason():
    rows = [
        _row("USA_US101-1_1_T-1", "recorded", ttc_ahead_min_s=0.5, solution_valid=True, rti_ms_median=0.2),
        _row(
            "USA_US101-2_1_T-1",
            "recorded",
            collision_fcgen=True,
            responsibility="ego_into_opponent",
            goal_reached=False,
            ttc_ahead_min_s=1.5,
            rti_ms_median=0.4,
            wall_s=4.0,
        ),
        _row("USA_US101-2_1_T-1", "reactive", road_departure=True, ttc_ahead_min_s=3.0),
        _row("DEU_Muc-1_1_T-1", "recorded", "refused", refusal="intersection", reason="an intersection: lanelet 3"),
        _row("DEU_Muc-2_1_T-1", "recorded", "refused", refusal="intersection", reason="an intersection: lanelet 4"),
        _row("DEU_Muc-3_1_T-1", "recorded", "refused", refusal="oncoming traffic", reason="oncoming traffic: v 5"),
        _row("DEU_Muc-4_1_T-1", "recorded", status="ran", dataset=None),  # an older row: the data set from the name
    ]
    md = commonroad_markdown(pd.DataFrame(rows, columns=list(ROW_KEYS)))
    # US-101 recorded: 2 runs, one the ego into an opponent, goal 1, valid 1, TTC ahead min 0.5 / median 1.0,
    # RTI median of the runs' medians 0.3 ms, wall 3.0 s a run
    assert "| USA_US101 | recorded | 2 | 2 | 0 | 1 / 0 / 0 | 0 | 1 | 1 | 0.50 / 1.00 | 0.300 | 3.0 |" in md
    assert "| USA_US101 | reactive | 1 | 1 | 0 | 0 / 0 / 0 | 1 | 1 | 0 | 3.00 / 3.00 | 0.300 | 2.0 |" in md
    assert "| DEU_Muc | recorded | 4 | 1 | 3 (intersection 2, oncoming traffic 1) | 0 / 0 / 0 | 0 | 1 | 0 | - |" in md
    assert "| all | all | 6 | 4 | 3 (intersection 2, oncoming traffic 1) |" in md
    assert "| intersection | recorded | 2 | DEU_Muc-1_1_T-1: an intersection: lanelet 3 |" in md
    assert "| oncoming traffic | recorded | 1 | DEU_Muc-3_1_T-1: oncoming traffic: v 5 |" in md


def test_a_run_that_raises_is_written_as_failed_and_run_again(tmp_path, monkeypatch):
    import fcgen.campaign.cr_run as cr_run

    folder = tmp_path / "cache"
    folder.mkdir()
    write_scenario(folder / "ZAM_Plain-1_1_T-1.xml")
    configs = paper_grid(["car"], ["lifted"], ["ellipse"], "python", "ipm", "safe")

    def boom(task):
        raise RuntimeError("the loop broke\nsecond line")

    monkeypatch.setattr(cr_run, "run_cr_task", boom)
    lines: list[str] = []
    rows = run_cr_campaign(configs, folder, tmp_path / "res", str(tmp_path / "s"), jobs=1, echo=lines.append)
    assert [(r["status"], r["refusal"], r["reason"]) for r in rows] == [
        ("failed", "error", "RuntimeError: the loop broke")
    ]
    assert "failed ZAM_Plain-1_1_T-1.xml (recorded): RuntimeError: the loop broke" in lines
    lines.clear()
    run_cr_campaign(configs, folder, tmp_path / "res", str(tmp_path / "s"), jobs=1, echo=lines.append)
    assert lines[0].startswith("1 runs, 0 already in")  # a failed run is run again


def test_a_run_without_the_criticality_measures_says_so(tmp_path):
    from fcgen.sim.commonroad_judge import NOT_MEASURED
    from fcgen.sim.commonroad_run import run_commonroad

    pb = preset("car_lifted_ellipse_ipm")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        sc = load_for(pb, write_scenario(tmp_path / "ZAM_Plain-1_1_T-1.xml", goal_steps=(4, 5)))
        c = run_commonroad(pb, sc, criticality=False).log.meta["extra"]["commonroad"]["criticality"]
    assert c["error"] == NOT_MEASURED
    assert all(c[m]["min"] is None and c["series"][m] == [] for m in ("ttc_ahead", "ttc_behind"))


def test_one_process_writes_each_run_as_it_finishes_so_a_stopped_campaign_resumes(tmp_path, monkeypatch):
    import fcgen.campaign.cr_run as cr_run

    folder = tmp_path / "cache"
    folder.mkdir()
    for i in range(3):
        write_scenario(folder / f"ZAM_Plain-{i}_1_T-1.xml")
    configs = paper_grid(["car"], ["lifted"], ["ellipse"], "python", "ipm", "safe")
    out = tmp_path / "res"
    seen: list[int] = []

    def one(task):  # the third run stops the campaign (as a kill would); before it, what is on disk
        p = out / "commonroad.parquet"
        seen.append(len(pd.read_parquet(p)) if p.is_file() else 0)
        if len(seen) == 3:
            raise KeyboardInterrupt
        name = cr_run._problem_name(task.config)
        return _row(Path(task.path).stem, task.traffic, problem=name, controller=task.config.controller)

    monkeypatch.setattr(cr_run, "run_cr_task", one)
    monkeypatch.setattr(cr_run, "FLUSH_ROWS", 1)
    with pytest.raises(KeyboardInterrupt):
        run_cr_campaign(configs, folder, out, str(tmp_path / "s"), jobs=1, echo=lambda _: None)
    assert seen == [0, 1, 2]  # each row written before the next run starts
    lines: list[str] = []
    run_cr_campaign(configs, folder, out, str(tmp_path / "s"), jobs=1, echo=lines.append)
    assert lines[0] == f"3 runs, 2 already in {out}, 1 to run (1 processes)"


def test_a_reference_the_solver_refuses_is_a_refusal_of_its_own_kind(tmp_path):
    """A controller that refuses the reference (exit code 18, what the C solver returns for an n_ref outside the
    problem's band): the run is refused with the kind ``reference refused`` and a line naming the reference and the
    band, not an error."""
    from fcgen.ocp import build_ocp
    from fcgen.sim.closedloop import ReferenceController
    from fcgen.sim.commonroad_run import run_commonroad

    class Refusing(ReferenceController):
        def set_reference(self, v_ref, n_ref) -> int:
            return 18

    sc = load_for(PB, write_scenario(tmp_path / "r.xml"))
    line = r"refuses the reference v_ref 20.00 m/s, n_ref 0.00 m \(exit code 18"
    with pytest.raises(ScenarioRefused, match=line) as e:
        run_commonroad(PB, sc, controller=Refusing(build_ocp(PB)), criticality=False)
    assert e.value.kind == "reference refused"


def _turn_road(radius: float, at: float = 60.0, angle: float = math.pi / 2, half: float = 1.75):
    """A straight road with one left turn of ``radius`` through ``angle`` starting ``at`` metres along it (grid
    0.5 m), its band ``half`` metres to each side."""
    import dataclasses

    from fcgen.road import Road

    ds = 0.5
    s = np.arange(0.0, 300.0, ds)
    kappa = np.where((s >= at) & (s < at + radius * angle), 1.0 / radius, 0.0)
    road = Road.from_curvature(kappa, ds)
    return dataclasses.replace(road, n_min=np.full(s.size, -half), n_max=np.full(s.size, half))


def test_a_turn_tighter_than_the_car_is_refused_with_the_room_it_needs():
    """The paper's car turns no tighter than R = 3.4 / tan(0.3) = 10.99 m. A quarter turn of 5 m radius on a 3.5 m
    band: on the 0.5 m grid its 16 samples of 0.2 / m integrate by trapezoids to 1.60 rad, all within 10 m (r =
    10 / 1.6 = 6.25 m), and the car's arc between the same tangents lies (10.99 - 6.25)(1 / cos(0.8) - 1) = 2.06 m
    inside it, more than the 3.5 - 2.46 = 1.04 m beside the chassis' swept width at R (test below): refused.
    Driven: the same turn on a 10.5 m band (8.0 m free), a turn of 8 m (1.25 rad in 10 m: 0.70 m), one of 15 m (no
    window turns tighter than R) and the 5 m turn beyond the run's reach."""
    from fcgen.commonroad.drivable import check_turns

    kappa_max, width, front = math.tan(PB.bounds.delta_max) / PB.ego.l, PB.ego.w_ch, PB.ego.l / 2 + PB.ego.l_ch / 2
    assert (1.0 / kappa_max, width, front) == (pytest.approx(10.99, abs=0.005), 1.9, 3.7)
    line = r"turns 1\.60 rad within 10 m, 5\d m ahead; .* no tighter than 11\.0 m .* needs 2\.1 m of the band's 1\.0 m"
    with pytest.raises(ScenarioRefused, match=line) as e:
        check_turns(_turn_road(5.0), 0.0, 200.0, kappa_max, width, front)
    assert e.value.kind == "turn tighter than the car"
    check_turns(_turn_road(5.0, half=5.25), 0.0, 200.0, kappa_max, width, front)
    check_turns(_turn_road(8.0), 0.0, 200.0, kappa_max, width, front)
    check_turns(_turn_road(15.0), 0.0, 200.0, kappa_max, width, front)
    check_turns(_turn_road(5.0, at=150.0), 0.0, 100.0, kappa_max, width, front)  # beyond what the run can reach


def test_a_turn_the_chassis_sweeps_wider_than_its_lane_is_refused():
    """The chassis' swept width on an arc of radius rho through the rear axle: sqrt((rho + w/2)^2 + f^2) - (rho -
    w/2), for the paper's car (w 1.9 m, f 3.7 m) at R = 10.99 m sqrt(11.94^2 + 3.7^2) - 10.04 = 2.46 m, 1.9 m on a
    straight. A turn of 10 m radius (1.0 rad within 10 m: 0.14 m to cut) on a 2.3 m band: 0.4 m beside the chassis'
    width (driven, as a junction's turn in CHN_Sha-12_1 was, its front corner then over the edge), none beside its
    swept width: refused. Straight, the same band is driven."""
    from fcgen.commonroad.drivable import check_turns, swept_width

    r_car = PB.ego.l / math.tan(PB.bounds.delta_max)
    expect = math.sqrt((r_car + 0.95) ** 2 + 3.7**2) - (r_car - 0.95)
    assert float(swept_width(r_car, 1.9, 3.7)) == pytest.approx(expect, rel=1e-12)
    assert expect == pytest.approx(2.46, abs=0.005)
    assert float(swept_width(1e15, 1.9, 3.7)) == pytest.approx(1.9, abs=1e-9)
    assert float(swept_width(r_car, 1.9, 0.0)) == pytest.approx(1.9, abs=1e-12)
    kappa_max = 1.0 / r_car
    check_turns(_turn_road(10.0, half=1.15), 0.0, 200.0, kappa_max, 1.9)  # the chassis' width alone
    with pytest.raises(ScenarioRefused, match=r"turns 1\.0\d rad within 10 m") as e:
        check_turns(_turn_road(10.0, half=1.15), 0.0, 200.0, kappa_max, 1.9, 3.7)
    assert e.value.kind == "turn tighter than the car"
    check_turns(_turn_road(10.0, angle=0.0, half=1.15), 0.0, 200.0, kappa_max, 1.9, 3.7)


def test_the_cut_a_turn_needs_by_hand():
    """(R - r)(1 / cos(theta / 2) - 1): a right angle over 10 m (r = 6.37 m) for R = 11 m needs 4.63 (sqrt 2 - 1) =
    1.92 m; a path that turns wider than the car needs none; a half turn cannot be cut."""
    from fcgen.commonroad.drivable import cut_needed

    r = 10.0 / (math.pi / 2)
    assert float(cut_needed(math.pi / 2, 10.0, 11.0)) == pytest.approx((11.0 - r) * (math.sqrt(2.0) - 1.0), rel=1e-12)
    assert float(cut_needed(0.5, 10.0, 11.0)) == 0.0
    assert math.isinf(float(cut_needed(math.pi, 10.0, 11.0)))


def test_a_standing_ego_without_a_speed_to_reach_is_loaded_not_crashed(tmp_path):
    """An ego at 0 m/s whose goal asks no speed can drive 0 m: the route is checked at its start (commonroad-io's
    look-up of no points raised a TypeError)."""
    sc = load_for(PB, write_scenario(tmp_path / "stand.xml", ego_v=0.0))
    assert sc.x0[3] == 0.0 and sc.samples == 40
