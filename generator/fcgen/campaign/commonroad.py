"""``fcgen campaign --commonroad DIR``: every CommonRoad scenario of a folder in every configuration of the grid, with
the compiled C controllers (or the Python reference); one row per (scenario, configuration): ran or refused (with the
reason), fcgen's and the drivability checker's collision verdicts, who moved into whom, progress, time per RTI.

Rows go to ``OUT/commonroad.parquet`` (and ``.csv``) and a summary to ``OUT/commonroad.md``: the scenarios run and
refused, the agreement table of the two collision checks, the collisions by responsibility.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from ..commonroad.catalog import HashMismatch, ListedScenario, check_file, dataset_of, sha256_of
from ..extras import require
from .grid import Config

ROW_KEYS = (
    "scenario",
    "dataset",
    "file",
    "sha256",
    "problem",
    "profile",
    "formulation",
    "obstacle_model",
    "road_bound",
    "controller",
    "traffic",
    "prediction",
    "status",
    "refusal",
    "reason",
    "samples",
    "progress_m",
    "v_ref",
    "band_cut_m",
    "way_back_samples",
    "collision_fcgen",
    "collision_step_fcgen",
    "collision_checker",
    "collision_step_checker",
    "road_departure",
    "departure_step",
    "start_off_road",
    "departure_again_step",
    "agree",
    "responsibility",
    "max_abs_a_lat",
    "rti_ms_median",
    "qp_iter_mean",
    "exit_codes_nonzero",
    "goal_reached",
    "goal_step",
    "v_ref_source",
    "n_ref",
    "solution_valid",
    "solution_valid_but_goal",
    "solution_starts",
    "solution_feasible",
    "max_slack",
    "unsolved_samples",
    "unsolved_codes",
    "nonfinite",
    "reacted",
    "reacted_to_ego",
    "first_reaction_sample",
    "ttc_ahead_min_s",
    "ttc_ahead_obstacle",
    "ttc_behind_min_s",
    "ttc_behind_obstacle",
    "thw_ahead_min_s",
    "thw_behind_min_s",
    "criticality_error",
    "criticality_skipped",
    "wall_s",
    "cpu_s",
)


@dataclass(frozen=True)
class CrTask:
    """One scenario file in one configuration."""

    config: Config
    path: str
    cache_dir: str
    traffic: str = "recorded"  # or "reactive" (commonroad.reactive)
    listed: ListedScenario | None = None  # the scenario list's row: the file must have its hash
    criticality: bool = True  # the criticality measures (commonroad-crime: most of a run's time)


def scenario_files(folder: str | Path) -> list[Path]:
    """The CommonRoad XML files of a folder (sorted by name)."""
    files = sorted(p for p in Path(folder).iterdir() if p.suffix.lower() == ".xml")
    if not files:
        raise ValueError(f"--commonroad {folder}: no CommonRoad scenario (*.xml) in it")
    return files


def load_for(problem, path: str | Path, planning_problem_id: int | None = None):
    """The scenario as ``problem`` drives it (its ego, road grid, horizon); raises ``ScenarioRefused``."""
    from ..commonroad import load_scenario
    from ..sim.closedloop import WINDOW_BEHIND

    pb = problem
    return load_scenario(
        path,
        planning_problem_id,
        ego=pb.ego,
        ds=pb.road.ds,
        horizon_s=pb.horizon.N * pb.horizon.dt,
        v_max=pb.bounds.v_max,
        window_m=(pb.road.samples - 1) * pb.road.ds,
        behind_m=WINDOW_BEHIND + pb.ego.l + 2 * pb.road.ds,
        kappa_max=math.tan(pb.bounds.delta_max) / pb.ego.l,
    )


def run_cr_task(task: CrTask) -> dict:
    """One row (``ROW_KEYS``)."""
    from ..commonroad import ScenarioRefused
    from ..sim.commonroad_run import run_commonroad
    from .task import _ocp, _prepared, _solver

    cfg = task.config
    pb, _, lib = _prepared(cfg, task.cache_dir)
    row = dict.fromkeys(ROW_KEYS)
    row.update(
        scenario=Path(task.path).stem,
        dataset=dataset_of(task.path),
        file=Path(task.path).name,
        problem=pb.name,
        profile=cfg.profile,
        formulation=pb.formulation.kind,
        obstacle_model=pb.obstacles.kind,
        road_bound=pb.bounds.road_bound,
        controller=cfg.controller,
        traffic=task.traffic,
        prediction=cfg.plant.prediction,
        status="refused",
        reason="",
    )
    t0, c0 = time.perf_counter(), time.process_time()
    try:
        _check_listed(task)
        row["sha256"] = sha256_of(task.path)
        sc = load_for(pb, task.path)
        kw: dict[str, Any] = {"traffic": task.traffic, "criticality": task.criticality}
        if cfg.plant.prediction != "oracle":  # the opponents predicted from their observed poses (sim.cr_prediction)
            kw["plant"] = cfg.plant
        if cfg.controller == "c":
            solver, lock = _solver(lib)
            with lock:
                if solver.init():
                    raise RuntimeError(f"{pb.name}_init() failed")
                run = run_commonroad(pb, sc, controller=solver, **kw)
        else:
            run = run_commonroad(pb, sc, ocp=_ocp(pb), **kw)
    except ScenarioRefused as exc:
        row.update(refusal=exc.kind, reason=str(exc), wall_s=time.perf_counter() - t0, cpu_s=time.process_time() - c0)
        return row
    log = run.log
    cr = log.meta["extra"]["commonroad"]
    t_ms = 1e3 * np.asarray(log.time_total)
    row.update(
        status="ran",
        samples=int(log.n_controls),
        progress_m=float(log.ego_frenet[-1, 0] - log.ego_frenet[0, 0]),
        v_ref=float(cr["v_ref"]),
        band_cut_m=float(cr["band_cut"]),
        way_back_samples=len(cr["band"]["way_back_samples"]),
        collision_fcgen=bool(run.fcgen["collision"]),
        collision_step_fcgen=_step(run.fcgen.get("collision_step")),
        collision_checker=bool(run.checker["collision"]),
        collision_step_checker=_step(run.checker.get("collision_step")),
        road_departure=bool(run.checker.get("road_departure", False)),
        departure_step=_step(run.checker.get("departure_step")),
        start_off_road=run.checker.get("departure_step") == 0,
        departure_again_step=_step(run.checker.get("departure_again_step")),
        agree=run.agree,
        responsibility=run.responsibility,
        max_abs_a_lat=float(np.max(np.abs(log.a_lat))),
        rti_ms_median=float(np.median(t_ms)),
        qp_iter_mean=float(np.mean(log.qp_iter)),
        exit_codes_nonzero=int(log.meta["extra"]["exit_codes_nonzero"]),
        **slack_fields(np.asarray(log.max_slack, dtype=float), cr["unsolved"]),
        **goal_fields(cr),
        **traffic_fields(cr),
        **criticality_fields(cr),
        wall_s=time.perf_counter() - t0,
        cpu_s=time.process_time() - c0,  # the worker's CPU: what a run costs on a machine not shared
    )
    row["nonfinite"] = nonfinite_fields(row)
    return row


def _check_listed(task: CrTask) -> None:
    """A listed scenario's file must be in the cache with the list's hash (else ``ScenarioRefused``, kind ``not in
    the cache`` or ``hash differs``)."""
    from ..commonroad import ScenarioRefused

    if task.listed is None:
        return
    if not Path(task.path).is_file():
        where = Path(task.path).parent
        raise ScenarioRefused(f"{task.listed.file}: not in the scenario cache {where}", kind="not in the cache")
    try:
        check_file(task.path, task.listed)
    except HashMismatch as exc:
        raise ScenarioRefused(str(exc), kind="hash differs") from None


def goal_fields(cr: dict) -> dict:
    """The row's goal and solution fields from the run log's ``extra.commonroad``."""
    g, sol = cr["goal"], cr["solution"]
    return {
        "goal_reached": bool(g["reached"]),
        "goal_step": _step(g["step"]),
        "v_ref_source": g["v_ref_source"],
        "n_ref": float(cr["n_ref"]),
        "solution_valid": bool(sol["valid"]),
        "solution_valid_but_goal": bool(sol["valid_but_goal"]),
        "solution_starts": bool(sol["starts_at_initial_state"]),
        "solution_feasible": bool(sol["feasible"]),
    }


def traffic_fields(cr: dict) -> dict:
    """The row's reactive-traffic fields from the run log's ``extra.commonroad.traffic``: how many vehicles reacted,
    how many of them to the ego, the first sample one did (-1: none)."""
    reactions = cr.get("traffic", {}).get("reactions", [])
    return {
        "reacted": len(reactions),
        "reacted_to_ego": sum(r[3] == "ego" for r in reactions),
        "first_reaction_sample": min((int(r[1]) for r in reactions), default=-1),
    }


def criticality_fields(cr: dict) -> dict:
    """The row's criticality fields from the run log's ``extra.commonroad.criticality`` (None: no vehicle closed in,
    or none was measured: ``criticality_error`` says why)."""
    c = cr.get("criticality", {})
    out = {f"{m}_min_s": c.get(m, {}).get("min") for m in ("ttc_ahead", "ttc_behind", "thw_ahead", "thw_behind")}
    out["ttc_ahead_obstacle"] = c.get("ttc_ahead", {}).get("obstacle")
    out["ttc_behind_obstacle"] = c.get("ttc_behind", {}).get("obstacle")
    out["criticality_error"] = c.get("error", "")
    out["criticality_skipped"] = int(sum(c.get("skipped", {}).values()))
    return out


def slack_fields(slack: np.ndarray, unsolved: dict) -> dict:
    """The row's ``max_slack`` (over the samples with a solution, 0 when none has one: ``unsolved_samples`` then says
    so), ``unsolved_samples`` and ``unsolved_codes`` (``"CODE xN, ..."``, "" without)."""
    ok = np.isfinite(slack)
    return {
        "max_slack": float(slack[ok].max()) if ok.any() else 0.0,
        "unsolved_samples": int(unsolved["samples"]),
        "unsolved_codes": ", ".join(f"{k} x{v}" for k, v in unsolved["exit_codes"].items()),
    }


def nonfinite_fields(row: dict) -> str:
    """The names of a row's numeric fields whose value is not finite (comma-separated, "" when every one is): a row
    states such a value instead of hiding it in a NaN."""
    return ", ".join(
        k
        for k, v in row.items()
        if isinstance(v, (float, np.floating)) and not isinstance(v, bool) and not np.isfinite(v)
    )


def _count(col) -> int:
    return int(col.fillna(False).astype(bool).sum())


def departed_on_road(df):
    """Which rows' runs left the road after the ego was on it: a departure after an on-road start, or, after a start
    off the road, a departure once back on it (``departure_again_step``)."""
    on = df.road_departure.astype(bool) & ~df.start_off_road.fillna(False).astype(bool)
    if "departure_again_step" in df:
        on = on | (df.departure_again_step.fillna(-1).astype(int) >= 0)
    return on


def _step(v) -> int:
    return -1 if v is None else int(v)


def write_results(rows: list[dict], out: str | Path) -> Path:
    """``commonroad.parquet``, ``commonroad.csv`` and the summary ``commonroad.md`` into ``out``."""
    with require("campaign", "the CommonRoad campaign's tables"):
        import pandas as pd

    o = Path(out)
    o.mkdir(parents=True, exist_ok=True)
    df = pd.DataFrame(rows, columns=list(ROW_KEYS))
    df["prediction"] = df["prediction"].fillna("oracle")  # rows made without one (as before the column)
    if (o / "commonroad.parquet").is_file():  # runs of other scenarios, configurations or traffic modes are kept
        old = pd.read_parquet(o / "commonroad.parquet")
        key = ["scenario", "problem", "controller", "traffic", "prediction"]
        old = old.reindex(columns=list(ROW_KEYS))
        old["traffic"] = old["traffic"].fillna("recorded")
        old["prediction"] = old["prediction"].fillna("oracle")
        old["dataset"] = old["dataset"].fillna(old["scenario"].map(dataset_of))
        new_keys = set(map(tuple, df[key].astype(str).values))
        old = old[[tuple(k) not in new_keys for k in old[key].astype(str).values]]
        df = pd.concat([old, df], ignore_index=True) if len(old) else df
    for name, write in (
        ("commonroad.parquet", lambda t: df.to_parquet(t, index=False)),
        ("commonroad.csv", lambda t: df.to_csv(t, index=False)),
        ("commonroad.md", lambda t: t.write_text(summary_markdown(df))),
    ):  # each file whole or not at all: a campaign killed while writing resumes from the last complete one
        tmp = o / f".{name}.tmp"
        write(tmp)
        tmp.replace(o / name)
    return o / "commonroad.md"


def unsolved_lines(ran) -> list[str]:
    """The report's section on samples without a solution and on non-finite values in rows ("None." when none)."""
    lines = ["## Samples without a solution, non-finite values", ""]
    bad = ran[(ran.unsolved_samples.fillna(0).astype(int) > 0) | (ran.nonfinite.fillna("") != "")]
    if not len(bad):
        return [*lines, "None.", ""]
    lines += [
        f"{len(bad)} of {len(ran)} runs, {int(bad.unsolved_samples.fillna(0).sum())} samples without a solution.",
        "",
        "| scenario | configuration | samples without a solution | exit codes | non-finite fields |",
        "|---|---|---|---|---|",
    ]
    lines += [
        f"| {r.scenario} | {r.problem} | {r.unsolved_samples} | {r.unsolved_codes or '-'} | {r.nonfinite or '-'} |"
        for r in bad.itertuples()
    ]
    return [*lines, ""]


def summary_markdown(df) -> str:
    """Scenarios run / refused (reasons), the agreement of the two collision checks, collisions by responsibility."""
    ran, refused = df[df.status == "ran"], df[df.status != "ran"]
    lines = [
        "# CommonRoad scenarios",
        "",
        f"{df.scenario.nunique()} scenarios x {df.problem.nunique()} configurations: {len(ran)} runs, "
        f"{len(refused)} refused or failed.",
        "",
    ]
    if len(refused):
        lines += ["## Refused or failed", "", "| scenario | configuration | traffic | kind | reason |"]
        lines.append("|---|---|---|---|---|")
        lines += [
            f"| {r.scenario} | {r.problem} | {r.traffic} | {r.refusal or 'other'} | {r.reason} |"
            for r in refused.itertuples()
        ]
        lines.append("")
    if len(ran):
        a = ran.collision_fcgen.astype(bool)
        b = ran.collision_checker.astype(bool)
        lines += [
            "## The two collision checks",
            "",
            "| | checker: collision | checker: none |",
            "|---|---|---|",
            f"| fcgen: collision | {int((a & b).sum())} | {int((a & ~b).sum())} |",
            f"| fcgen: none | {int((~a & b).sum())} | {int((~a & ~b).sum())} |",
            "",
            f"Agreement: {int((a == b).sum())} of {len(ran)} runs. Road departures (checker): "
            f"{int(ran.road_departure.astype(bool).sum())}, of which {_count(ran.start_off_road)} start off the road "
            "(the scenario's: the recorded ego's chassis crosses the road boundary at the initial state) and "
            f"{_count(departed_on_road(ran))} after the ego was on the road (an on-road start, or back from a start "
            "off it).",
            "",
            f"Goal reached: {_count(ran.goal_reached)} of {len(ran)} runs. Solutions valid by the drivability "
            f"checker: {_count(ran.solution_valid)} (all but the goal: {_count(ran.solution_valid_but_goal)}; "
            f"starting at the initial state: {_count(ran.solution_starts)}; feasible: "
            f"{_count(ran.solution_feasible)}).",
            "",
        ]
        lines += unsolved_lines(ran)
        col = ran[a | b]
        lines += ["## Collisions", ""]
        if len(col):
            lines += [
                "| scenario | configuration | fcgen step | checker step | responsibility |",
                "|---|---|---|---|---|",
            ]
            lines += [
                f"| {r.scenario} | {r.problem} | {r.collision_step_fcgen} | {r.collision_step_checker} | "
                f"{r.responsibility or '-'} |"
                for r in col.itertuples()
            ]
        else:
            lines.append("None.")
        lines += [
            "",
            "## Per configuration",
            "",
            "| configuration | runs | collisions (fcgen) | goal reached | valid solutions | progress mean, m | "
            "RTI median, ms | max abs a_lat |",
            "|---|---|---|---|---|---|---|---|",
        ]
        for name, g in ran.groupby("problem"):
            lines.append(
                f"| {name} | {len(g)} | {int(g.collision_fcgen.astype(bool).sum())} | {_count(g.goal_reached)} | "
                f"{_count(g.solution_valid)} | {g.progress_m.mean():.1f} | {g.rti_ms_median.median():.3f} | "
                f"{g.max_abs_a_lat.max():.2f} |"
            )
    return "\n".join(lines) + "\n"
