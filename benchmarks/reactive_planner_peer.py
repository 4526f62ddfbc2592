"""A peer planner beside fcgen: TUM's sampling-based Frenet planner ``commonroad-reactive-planner`` 2025.1 in closed
loop on fcgen's CommonRoad scenarios, in recorded or reactive traffic, judged by fcgen's own checks
(``fcgen.sim.commonroad_judge``: collisions by both checks and by responsibility, road departure, goal, the solution's
verdict, criticality) and written as the campaign's rows (``fcgen.campaign.commonroad``'s fields).

    python benchmarks/reactive_planner_peer.py DIR_OR_XML... [--traffic recorded,reactive] \\
        [--problem car_lifted_ellipse_ipm_safe] [--no-criticality] [--out results/peer.json]

**Install** (into the venv that runs this; not a dependency of fcgen): its declared requirements pin
``commonroad-io<2025`` and ``commonroad-drivability-checker<2026`` (fcgen's pins fit) but also ``commonroad-clcs`` and
``commonroad-route-planner``, which ``scripts/setup.sh`` already installs with ``--no-deps`` (``commonroad-clcs`` pins
``osqp~=0.6.5`` against fcgen's ``osqp==1.1.3``), and ``triangle`` (not used here: the road boundary is built with
``obb_rectangles``, commonroad-dc's default). So::

    .venv/bin/pip install --no-deps -r benchmarks/requirements-peer.txt

(``commonroad-reactive-planner==2025.1``, ``methodtools==0.4.7``, ``wirerope==1.0.0`` and the ``six`` it imports).

**The three adaptations** the 2025.1 release needs beside the current CommonRoad packages (written here, not in its
sources): the route planner's API (``RoutePlanner.plan_routes()`` returns a list of lanelet sequences, a
``ReferencePathPlanner`` makes the reference path: ``reference_path``; the example's ``retrieve_first_route()`` is an
AttributeError); the curvilinear frame needs explicit ``CLCSParams()`` (``coordinate_system``; with the default None:
AttributeError on ``processing_option``); ``plan()`` returns three items (trajectory, longitudinal and lateral
states: ``next_state``), where its closed-loop example reads four.

**The loop** (``drive``): at every 0.1 s step the planner replans from the ego's state (its own example's loop with
a replanning period of one step), and the ego moves to its plan's next state (the planner's trajectory is its plant,
as in that example). Reactive traffic is fcgen's (``commonroad.reactive.ReactiveTraffic``, updated from the ego's
state at each step); the planner's collision checker gets the vehicles as fcgen's solver predicts them (a reacting
vehicle at constant speed along the road). Where a plan fails (no feasible trajectory, or an exception) the ego
follows the last plan's next state (``fallback_samples``); when no plan is left the run stops there
(``stopped_early``) and is judged on the steps it drove. The run ends in the goal as fcgen's does
(``commonroad.goal.reached``). The ego is fcgen's car (chassis 4.0 x 1.9 m, wheelbase 3.4 m, the centre half-way
between the axles), so both are judged on the same rectangle. Time per cycle: the thread's CPU time of ``plan()``.
"""

from __future__ import annotations

import argparse
import copy
import json
import logging
import math
import subprocess
import time
from dataclasses import replace
from pathlib import Path

import numpy as np

PEER = "commonroad-reactive-planner 2025.1"
SAMPLED_OUT = {"sampled_out": True}  # a scenario fcgen drove that the sample (--sample) leaves out: not run


def reference_path(scenario, planning_problem) -> np.ndarray:
    """Adaptation 1: the route planner's 2025 API (routes, then a reference path planner)."""
    from commonroad_route_planner.reference_path_planner import ReferencePathPlanner
    from commonroad_route_planner.route_planner import RoutePlanner

    routes = RoutePlanner(scenario.lanelet_network, planning_problem).plan_routes()
    return (
        ReferencePathPlanner(scenario.lanelet_network, planning_problem, routes)
        .plan_shortest_reference_path(retrieve_shortest=True)
        .reference_path
    )


def coordinate_system(path: np.ndarray):
    """Adaptation 2: the curvilinear frame with explicit ``CLCSParams()`` (its default None fails)."""
    from commonroad_clcs.config import CLCSParams
    from commonroad_rp.utility.utils_coordinate_system import CoordinateSystem

    return CoordinateSystem(path, clcs_params=CLCSParams())


def next_state(result) -> tuple:
    """Adaptation 3: ``plan()`` returns (trajectory, lon states, lat states); the plan's next Cartesian state and
    its curvilinear (lon, lat) state."""
    traj, lon, lat = result
    return traj.state_list[1], (lon[1], lat[1]), traj.state_list


def make_planner(problem, sc, scenario):
    """The planner on ``scenario`` (the planning problem copied: the planner edits its initial state) with fcgen's
    car, its release's default configuration (a 3 s horizon, 4 sampling levels, lateral samples within 3 m of its
    reference path), one worker, replanning every step."""
    from commonroad_rp.reactive_planner import ReactivePlanner
    from commonroad_rp.utility.config import (
        PlanningConfiguration,
        ReactivePlannerConfiguration,
        VehicleConfiguration,
    )

    ego = problem.ego
    cfg = ReactivePlannerConfiguration()
    cfg.vehicle = VehicleConfiguration(length=ego.l_ch, width=ego.w_ch, wb_front_axle=ego.l / 2, wb_rear_axle=ego.l / 2)
    # the release's configuration files (configurations/defaults/planning.yaml): a 3 s horizon (the dataclass's
    # default is 6 s); replanning every step
    cfg.planning = PlanningConfiguration(dt=sc.dt, time_steps_computation=30, replanning_frequency=1)
    cfg.debug.multiproc, cfg.debug.logging_level = False, "ERROR"
    pp = copy.deepcopy(sc.planning_problem)
    cfg.update(scenario=scenario, planning_problem=pp)
    planner = ReactivePlanner(cfg)
    planner.set_reference_path(coordinate_system=coordinate_system(reference_path(scenario, pp)))
    planner.reset(
        initial_state_cart=planner.x_0, collision_checker=planner.collision_checker, coordinate_system=planner._co
    )
    return planner


def drive(problem, sc, traffic: str) -> dict:
    """One closed loop of the planner on ``sc`` (module docstring); the ego's rear-axle states [x, y, phi, v, delta]
    per sample, the traffic, the plan times and what failed."""
    from commonroad_dc.boundary.boundary import create_road_boundary_obstacle

    from fcgen.commonroad.goal import reached
    from fcgen.commonroad.reactive import ReactiveTraffic, check_traffic, driven_scenario

    world = ReactiveTraffic(sc, problem.ego.l_ch) if check_traffic(traffic) == "reactive" else None
    planner = make_planner(problem, sc, sc.scenario)
    _, boundary = create_road_boundary_obstacle(sc.scenario, method="obb_rectangles")
    x = planner.x_0
    states, cpu, fails, plan, k = [_row(x)], [], [], None, 0
    half_l, stopped = problem.ego.l / 2, ""
    for j in range(sc.samples):
        centre = (x.position[0] + half_l * math.cos(x.orientation), x.position[1] + half_l * math.sin(x.orientation))
        if j and reached(sc.planning_problem, sc.first_step + j, centre, x.orientation, float(x.velocity)):
            break
        if world is not None:
            s, n, _ = sc.road.to_frenet(x.position[0], x.position[1], x.orientation)
            world.update(j, float(s) + half_l, float(n), float(x.velocity))
            now = world.scenario()
            planner.set_collision_checker(driven_scenario(now, now.obstacles), road_boundary_obstacle=boundary)
        planner.set_desired_velocity(current_speed=x.velocity)
        t0 = time.thread_time()
        try:
            result = planner.plan()
            why = "" if result is not None else "no feasible trajectory"
        except Exception as exc:  # noqa: BLE001 - the planner's own failures (asserts, its frame's errors) end a plan
            result, why = None, f"{type(exc).__name__}: {exc}"[:160]
        cpu.append(time.thread_time() - t0)
        if result is not None:
            nxt, curv, plan = next_state(result)
            k = 1
        else:
            fails.append([j, why])
            k += 1
            if plan is None or k >= len(plan):
                stopped = why
                break
            nxt, curv = plan[k], None  # the last plan's next state
        x = nxt
        states.append(_row(x))
        planner.reset(
            initial_state_cart=x,
            initial_state_curv=curv,
            collision_checker=planner.collision_checker,
            coordinate_system=planner._co,
        )
    return {"states": np.array(states), "world": world, "cpu_s": cpu, "fails": fails, "stopped": stopped}


def _row(x) -> list[float]:
    return [
        float(x.position[0]),
        float(x.position[1]),
        float(x.orientation),
        float(x.velocity),
        float(x.steering_angle),
    ]


def judge(problem, sc, d: dict, traffic: str, criticality: bool) -> dict:
    """The campaign's row of one drive, judged by ``fcgen.sim.commonroad_judge``."""
    import fcgen.commonroad.criticality as crit
    from fcgen.campaign.commonroad import criticality_fields, goal_fields, traffic_fields
    from fcgen.sim.commonroad_judge import driven, judge_drive, states_on_road
    from fcgen.sim.commonroad_run import scenario_road

    if not criticality:
        crit.criticality = lambda *a, **k: {"error": "left out (--no-criticality)", "series": {}}
    road, _ = scenario_road(problem, sc)
    xs, ego_cart = states_on_road(road, d["states"])
    sc = driven(sc, d["world"])
    v = judge_drive(problem, sc, road, xs, ego_cart)
    reactions = {"mode": traffic, "reactions": [] if d["world"] is None else d["world"].reactions}
    cr = {"goal": v.goal, "solution": v.solution, "n_ref": 0.0, "traffic": reactions, "criticality": v.criticality}
    dep = v.checker.get("departure_step")
    a_lat = xs[:, 3] ** 2 * np.tan(xs[:, 4]) / problem.ego.l
    return {
        "scenario": sc.name,
        "traffic": traffic,
        "samples": len(xs) - 1,
        "progress_m": float(xs[-1, 0] - xs[0, 0]),
        "collision_fcgen": bool(v.fcgen["collision"]),
        "collision_step_fcgen": v.fcgen.get("collision_step"),
        "collision_checker": bool(v.checker["collision"]),
        "responsibility": v.responsibility,
        "road_departure": bool(v.checker["road_departure"]),
        "departure_step": dep,
        "start_off_road": dep == 0,
        "departure_again_step": v.checker.get("departure_again_step"),
        "max_abs_a_lat": float(np.max(np.abs(a_lat))),
        "plan_ms_median": 1e3 * float(np.median(d["cpu_s"])) if d["cpu_s"] else None,
        "plan_ms_max": 1e3 * float(np.max(d["cpu_s"])) if d["cpu_s"] else None,
        "fallback_samples": len(d["fails"]),
        "first_failure": d["fails"][0] if d["fails"] else None,
        "stopped_early": d["stopped"],
        **{k: val for k, val in goal_fields(cr).items() if k not in ("v_ref_source", "n_ref")},
        **traffic_fields(cr),
        **criticality_fields(cr),
    }


def runs(tasks: list[tuple[Path, str, dict | None]], pb, criticality: bool, out: Path) -> list[dict]:
    """The rows of ``tasks`` (``select``'s: a file, a traffic mode and fcgen's refusal or None); a task already in
    ``out`` is not run again, and ``out`` is rewritten after every run (resumable)."""
    from fcgen.campaign.commonroad import load_for
    from fcgen.commonroad import ScenarioRefused

    logging.getLogger("RP_LOGGER").setLevel(logging.ERROR)
    rows = json.loads(out.read_text())["rows"] if out.is_file() else []
    done = {(r["scenario"], r.get("traffic")) for r in rows}
    for f, traffic, fcgen_refusal in tasks:
        if (f.stem, traffic) in done:
            continue
        if fcgen_refusal is not None:
            rows.append({"scenario": f.stem, "traffic": traffic, **fcgen_refusal})
            continue
        try:
            sc = load_for(pb, f)
            refusal_checks(pb, sc)
        except ScenarioRefused as exc:
            rows.append({"scenario": f.stem, "traffic": traffic, "refused": str(exc), "refusal": exc.kind})
            print(json.dumps(rows[-1]), flush=True)
            continue
        t0 = time.process_time()
        try:
            d = drive(pb, sc, traffic)
        except Exception as exc:  # noqa: BLE001 - a planner that cannot start (its route, its frame) is counted
            rows.append({"scenario": sc.name, "traffic": traffic, "error": f"{type(exc).__name__}: {exc}"[:200]})
            print(json.dumps(rows[-1]), flush=True)
        else:
            rows.append({"planner": PEER, **judge(pb, sc, d, traffic, criticality), "cpu_s": time.process_time() - t0})
            print(json.dumps(rows[-1], default=str), flush=True)
        save(out, rows, {"partial": True})
    return rows


def refusal_checks(pb, sc) -> None:
    """fcgen's refusals made after loading (``ScenarioRefused``): a time step other than the problem's, a road band
    outside the problem's bounds (``sim.commonroad_run``'s checks, in its order)."""
    from fcgen.commonroad import ScenarioRefused
    from fcgen.sim.commonroad_run import scenario_road

    if not math.isclose(sc.dt, pb.horizon.dt, rel_tol=1e-9):
        raise ScenarioRefused(f"scenario {sc.name}: its time step {sc.dt} s is not {pb.horizon.dt} s", kind="time step")
    scenario_road(pb, sc)


def listed_files(scenario_list: str, cache: str) -> tuple[list[Path], dict[str, dict]]:
    """The files of a scenario list in a cache folder (``fcgen.commonroad.catalog``), and the refusals of those
    missing (``not in the cache``) or with another hash (``hash differs``), as fcgen's campaign refuses them."""
    from fcgen.commonroad.catalog import HashMismatch, check_file, read_list

    files, refused = [], {}
    for r in read_list(scenario_list):
        f = Path(cache) / r.file
        files.append(f)
        if not f.is_file():
            refused[f.stem] = {"refused": f"{r.file}: not in the scenario cache {cache}", "refusal": "not in the cache"}
            continue
        try:
            check_file(f, r)
        except HashMismatch as exc:
            refused[f.stem] = {"refused": str(exc), "refusal": "hash differs"}
    return files, refused


def fcgen_status(folder: str, problem: str) -> dict[tuple[str, str], dict | None]:
    """(scenario, traffic) -> None where fcgen's campaign in ``folder`` drove it with ``problem`` (``Problem.name``;
    or the folder's only configuration), else its refusal (kind and reason) as the peer's row gets it."""
    import pandas as pd

    df = pd.read_parquet(Path(folder) / "commonroad.parquet")
    names = sorted(df.problem.unique())
    if problem not in names and len(names) != 1:
        raise SystemExit(f"--like {folder}: no rows of {problem} in it, but of {names} (give --problem)")
    df = df[df.problem == (problem if problem in names else names[0])]
    out: dict[tuple[str, str], dict | None] = {}
    for r in df.itertuples():
        why = {"refused": f"fcgen {r.status}: {r.reason}", "refusal": r.refusal or "other"}
        out[(r.scenario, r.traffic or "recorded")] = None if r.status == "ran" else why
    return out


def like_road_bound(folder: str) -> str:
    """The road bound of a ``fcgen campaign --commonroad`` folder's runs (``rear_axle`` where its rows have none)."""
    import pandas as pd

    df = pd.read_parquet(Path(folder) / "commonroad.parquet")
    vals = sorted(set(df["road_bound"].dropna())) if "road_bound" in df else []
    return vals[0] if len(vals) == 1 else "rear_axle"


def stratified(names: list[str], per_dataset: int) -> set[str]:
    """Up to ``per_dataset`` names of each data set (``catalog.dataset_of``), evenly spaced in name order (the i-th
    of k from n: index floor((i + 0.5) n / k)); ``per_dataset`` 0: all."""
    from fcgen.commonroad.catalog import dataset_of

    by: dict[str, list[str]] = {}
    for n in sorted(set(names)):
        by.setdefault(dataset_of(n), []).append(n)
    if per_dataset <= 0:
        return set(names)
    pick = set()
    for group in by.values():
        k = min(per_dataset, len(group))
        pick |= {group[int((i + 0.5) * len(group) / k)] for i in range(k)}
    return pick


def select(files: list[Path], modes: list[str], like: dict | None, per_dataset: int, refused: dict) -> list[tuple]:
    """The tasks (file, traffic, fcgen's refusal or None): with ``like`` (``fcgen_status``) the scenarios fcgen
    drove in that traffic mode (a sample of them: ``stratified``) and fcgen's refusals copied; without, every file
    (a sample), refused by fcgen's own checks (``refused``: the list's file checks, ``listed_files``)."""
    if like is None:
        pick = stratified([f.stem for f in files if f.stem not in refused], per_dataset)
        return round_robin(
            [(f, m, refused.get(f.stem)) for f in files for m in modes if f.stem in pick or f.stem in refused]
        )
    drove = [s for (s, m), why in like.items() if why is None and m in modes]
    pick = stratified(drove, per_dataset)
    tasks = []
    for f in files:
        for m in modes:
            why = like.get((f.stem, m), {"refused": "not in fcgen's rows", "refusal": "not run by fcgen"})
            tasks.append((f, m, SAMPLED_OUT if why is None and f.stem not in pick else why))
    return round_robin(tasks)


def round_robin(tasks: list[tuple]) -> list[tuple]:
    """The tasks with the runs last, taken in turn from each data set (its first scenario in both traffic modes, then
    every data set's second, ...): a run stopped part-way holds a sample of every data set."""
    from fcgen.commonroad.catalog import dataset_of

    rank: dict[str, int] = {}
    seen: dict[str, int] = {}
    for f, _, why in tasks:
        if why is None and f.stem not in rank:
            d = dataset_of(f.stem)
            rank[f.stem] = seen.get(d, 0)
            seen[d] = rank[f.stem] + 1
    return sorted(tasks, key=lambda t: (t[2] is None, rank.get(t[0].stem, -1), dataset_of(t[0].stem), t[0].stem))


def campaign_rows(rows: list[dict]) -> list[dict]:
    """The peer's rows in ``fcgen campaign --commonroad``'s fields (``fcgen report`` reads them): problem the
    planner's name, controller ``peer``, time per cycle its plan's CPU time, samples without a solution its samples
    on the last plan; one that could not start is ``failed`` (kind ``peer could not start``)."""
    from fcgen.campaign.commonroad import ROW_KEYS
    from fcgen.commonroad.catalog import dataset_of

    out = []
    for r in rows:
        row = dict.fromkeys(ROW_KEYS)
        row.update({k: v for k, v in r.items() if k in ROW_KEYS})
        row.update(scenario=r["scenario"], dataset=dataset_of(r["scenario"]), problem=PEER, controller="peer")
        row["traffic"] = r.get("traffic") or "recorded"
        if r.get("sampled_out"):
            row.update(status="sampled out", reason="not in the sample (--sample)")
        elif "error" in r:
            row.update(status="failed", refusal="peer could not start", reason=r["error"])
        elif "refused" in r:
            row.update(status="refused", refusal=r.get("refusal") or "other", reason=r["refused"])
        else:
            row.update(status="ran", rti_ms_median=r["plan_ms_median"], unsolved_samples=r["fallback_samples"])
            for k in ("departure_step", "collision_step_fcgen", "departure_again_step", "goal_step"):
                row[k] = -1 if row[k] is None else int(row[k])
        out.append(row)
    return out


def unique(rows: list[dict]) -> list[dict]:
    """The rows with one per (scenario, traffic mode): the first (results of several files, one per traffic mode,
    each resumed from a copy of the same earlier file)."""
    seen: set = set()
    out = []
    for r in rows:
        if (r["scenario"], r.get("traffic")) not in seen:
            seen.add((r["scenario"], r.get("traffic")))
            out.append(r)
    return out


def save(out: Path, rows: list[dict], meta: dict) -> None:
    """The rows (and ``meta``) as JSON, written whole."""
    out.parent.mkdir(parents=True, exist_ok=True)
    tmp = out.with_suffix(".tmp")
    tmp.write_text(json.dumps({"meta": meta, "rows": rows}, indent=1, default=str) + "\n")
    tmp.replace(out)


def fcgen_rows(folder: str) -> list[dict]:
    """fcgen's rows of a ``fcgen campaign --commonroad`` folder in this script's keys (time per cycle: the RTI's)."""
    import pandas as pd

    df = pd.read_parquet(Path(folder) / "commonroad.parquet")
    df = df[df.status == "ran"].astype(object).where(df[df.status == "ran"].notna(), None)
    rows = []
    for r in df.to_dict("records"):
        dep = r["departure_step"]
        again = r.get("departure_again_step")
        rows.append(
            {
                **r,
                "departure_step": None if dep is None or dep < 0 else dep,
                "departure_again_step": None if again is None or again < 0 else again,
                "planner": f"fcgen {r['problem']}",
                "plan_ms_median": r["rti_ms_median"],
                "plan_ms_max": None,
                "fallback_samples": r["unsolved_samples"],
                "stopped_early": "",
            }
        )
    return rows


def markdown(rows: list[dict], modes: list[str]) -> str:
    """Sums per planner and traffic mode."""
    lines = [
        "| planner | traffic | runs | could not start | collisions (ego into opponent / opponent from behind / side) | "
        "departures after an on-road start (after a start off the road) | goal reached | "
        "valid solutions (all but the goal) | stopped early | "
        "samples on the fallback | min TTC ahead (s) | runs TTC ahead < 1 s | plan CPU median / max (ms) |",
        "|---|---|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    for planner, traffic in [(p, m) for p in dict.fromkeys(r.get("planner", PEER) for r in rows) for m in modes]:
        mine = [
            r
            for r in rows
            if r.get("planner", PEER) == planner and r.get("traffic") == traffic and not r.get("sampled_out")
        ]
        rs = [r for r in mine if "error" not in r and "refused" not in r]
        err = [r for r in mine if "error" in r]
        if not mine:
            continue
        resp = [sum(r["responsibility"] == k for r in rs) for k in ("ego_into_opponent", "opponent_from_behind")]
        side = sum(r["collision_fcgen"] for r in rs) - sum(resp)
        dep = sum(bool(r["road_departure"]) and not r["start_off_road"] for r in rs)
        again = sum((r["departure_again_step"] if r["departure_again_step"] is not None else -1) >= 0 for r in rs)
        ttc = [r["ttc_ahead_min_s"] for r in rs if r.get("ttc_ahead_min_s") is not None]
        ms = [r["plan_ms_median"] for r in rs if r["plan_ms_median"] is not None]
        mx = [r["plan_ms_max"] for r in rs if r["plan_ms_max"] is not None]
        lines.append(
            f"| {planner} | {traffic} | {len(rs)} | {len(err)} | {sum(r['collision_fcgen'] for r in rs)} "
            f"({resp[0]} / {resp[1]} / {side}) | {dep} ({again}) | {sum(r['goal_reached'] for r in rs)} | "
            f"{sum(r['solution_valid'] for r in rs)} "
            f"({sum(r['solution_valid_but_goal'] for r in rs)}) | {sum(bool(r['stopped_early']) for r in rs)} | "
            f"{sum(r['fallback_samples'] for r in rs)} | {_num(min(ttc) if ttc else None)} | "
            f"{sum(t < 1 for t in ttc)} | "
            f"{_num(np.median(ms) if ms else None)} / {_num(max(mx) if mx else None)} |"
        )
    return "\n".join(lines) + "\n"


def _num(v) -> str:
    return "-" if v is None else f"{v:.3g}"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("paths", nargs="*", help="scenario files or folders (or --scenario-list with --commonroad)")
    ap.add_argument("--scenario-list", help="a scenario list (docs/commonroad/*.csv): its files in --commonroad")
    ap.add_argument("--commonroad", help="the cache folder of --scenario-list's files")
    ap.add_argument("--like", help="a `fcgen campaign --commonroad` folder: drive what fcgen drove, copy its refusals")
    ap.add_argument("--sample", type=int, default=0, help="up to this many driven scenarios per data set (0: all)")
    ap.add_argument("--exclude", action="append", default=[], help="a scenario left out of the sample (its name)")
    ap.add_argument("--problem", default="car_lifted_ellipse_ipm_safe", help="the ego's size and dt (fcgen preset)")
    ap.add_argument(
        "--road-bound", choices=("rear_axle", "corners"), help="the loader's band (default: the --like folder's)"
    )
    ap.add_argument("--traffic", default="recorded,reactive")
    ap.add_argument("--no-criticality", action="store_true", help="leave out the criticality measures (CriMe)")
    ap.add_argument("--fcgen", action="append", default=[], help="a `fcgen campaign --commonroad` folder to put beside")
    ap.add_argument("--rows", action="append", default=[], help="this script's results (JSON) instead of running")
    ap.add_argument("--campaign-out", help="also write the rows as a campaign folder (fcgen report reads it)")
    ap.add_argument("--out", default="results/peer.json", help="the rows (JSON); a run already in it is not rerun")
    args = ap.parse_args()
    files: list[Path] = []
    file_refusals: dict[str, dict] = {}
    if args.scenario_list:
        if not args.commonroad:
            raise SystemExit("--scenario-list needs --commonroad CACHE (the folder of its files)")
        files, file_refusals = listed_files(args.scenario_list, args.commonroad)
    for p in map(Path, args.paths):
        files += sorted(p.glob("*.xml")) if p.is_dir() else [p]
    modes = args.traffic.split(",")
    t0 = time.time()
    rows = unique([r for f in args.rows for r in json.loads(Path(f).read_text())["rows"]])
    if not rows:
        from fcgen.presets import preset

        pb = preset(args.problem)
        like = fcgen_status(args.like, pb.name) if args.like else None
        bound = args.road_bound or (like_road_bound(args.like) if args.like else None)
        if bound is not None:  # the loader's band as fcgen's (the corners' band refuses fewer scenarios)
            pb = pb.with_(bounds=replace(pb.bounds, road_bound=bound))
        tasks = select(files, modes, like, args.sample, file_refusals)
        tasks = [(f, m, SAMPLED_OUT if f.stem in args.exclude and why is None else why) for f, m, why in tasks]
        rows = runs(tasks, pb, not args.no_criticality, Path(args.out))
    text = markdown(rows + [r for f in args.fcgen for r in fcgen_rows(f)], modes)
    print(text)
    commit = subprocess.run(["git", "rev-parse", "--short", "HEAD"], capture_output=True, text=True).stdout.strip()
    from importlib.metadata import version

    meta = {"commit": commit, "problem": args.problem, "planner": version("commonroad-reactive-planner")}
    meta.update(like=args.like, sample_per_dataset=args.sample, wall_s=time.time() - t0)
    if args.rows:
        out = Path(args.out)
        out.parent.mkdir(parents=True, exist_ok=True)
        out.write_text(json.dumps({"meta": meta, "markdown": text, "rows": rows}, indent=1, default=str) + "\n")
    else:
        save(Path(args.out), rows, meta)
    if args.campaign_out:
        from fcgen.campaign.commonroad import write_results

        write_results(campaign_rows(rows), args.campaign_out)
    print(f"{len(rows)} rows in {meta['wall_s']:.0f} s, written to {args.out}")


if __name__ == "__main__":
    main()
