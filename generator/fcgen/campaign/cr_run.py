"""Run ``campaign --commonroad``: the tasks of a scenario folder or of a scenario list (its files in a cache folder,
each checked against the list's hash by the worker that runs it) on a local process pool or a Dask cluster
(``runner.executor``), the rows written as runs finish, so that a campaign stopped part-way resumes where it
stopped: a run already in the results folder (ran, or refused for a reason of the scenario's) is not run again; one
refused because its file was missing or had another hash is.
"""

from __future__ import annotations

import concurrent.futures as cf
import functools
import time
from pathlib import Path

from ..commonroad.catalog import ListedScenario, dataset_of, read_list
from ..extras import require
from .commonroad import ROW_KEYS, CrTask, run_cr_task, scenario_files, write_results
from .grid import Config

RETRIED = ("hash differs", "not in the cache", "error")  # the file's refusals and the runs that raised: run again
FLUSH_ROWS = 20  # rows written at least every this many runs ...
FLUSH_SECONDS = 60.0  # ... or this many seconds


def cr_tasks(
    configs: list[Config],
    folder: str | Path,
    cache_dir: str,
    traffic: str,
    scenario_list: str | Path | None = None,
    criticality: bool = True,
) -> list[CrTask]:
    """Every scenario (the folder's ``*.xml``, or the list's files looked up in the folder) in every configuration."""
    files: list[tuple[str, ListedScenario | None]]
    if scenario_list is None:
        files = [(str(f), None) for f in scenario_files(folder)]
    else:
        files = [(str(Path(folder) / r.file), r) for r in read_list(scenario_list)]
    return [CrTask(cfg, f, cache_dir, traffic, row, criticality) for cfg in configs for f, row in files]


def done_keys(out: str | Path) -> set[tuple[str, str, str, str, str]]:
    """The (scenario, problem, controller, traffic, prediction) of the runs already in ``out`` not run again."""
    p = Path(out) / "commonroad.parquet"
    if not p.is_file():
        return set()
    with require("campaign", "the CommonRoad campaign's results"):
        import pandas as pd

    df = pd.read_parquet(p)
    if "refusal" in df.columns:
        df = df[~df.refusal.isin(RETRIED)]
    traffic = df.traffic.fillna("recorded") if "traffic" in df.columns else ["recorded"] * len(df)
    pred = df.prediction.fillna("oracle") if "prediction" in df.columns else ["oracle"] * len(df)
    return set(zip(df.scenario, df.problem, df.controller, traffic, pred, strict=True))


def task_key(task: CrTask) -> tuple[str, str, str, str, str]:
    """A task's key in the results (the row's scenario, problem, controller, traffic, prediction)."""
    cfg = task.config
    return (Path(task.path).stem, _problem_name(cfg), cfg.controller, task.traffic, cfg.plant.prediction)


@functools.cache
def _problem_name(cfg: Config) -> str:
    return cfg.problem().name


def run_cr_campaign(
    configs: list[Config],
    folder: str | Path,
    out: str | Path,
    cache_dir: str,
    jobs: int = 2,
    echo=print,
    traffic: str = "recorded",
    scenario_list: str | Path | None = None,
    scheduler: str | None = None,
    criticality: bool = True,
) -> list[dict]:
    """Every scenario of ``folder`` (or of ``scenario_list``, its files in ``folder``) in every configuration in
    ``traffic``; the runs not yet in ``out`` are run and written as they finish; returns every row of this call's
    tasks (those resumed included) and writes the summary."""
    from ..commonroad.reactive import check_traffic
    from .runner import executor
    from .task import build_solver

    check_traffic(traffic)
    tasks = cr_tasks(configs, folder, cache_dir, traffic, scenario_list, criticality)
    done = done_keys(out)
    todo = [t for t in tasks if task_key(t) not in done]
    for cfg in {t.config for t in todo if t.config.controller == "c"}:  # compiled once, before the workers share it
        build_solver(cfg, cache_dir)
    where = f"Dask {scheduler}" if scheduler else f"{jobs} processes"
    echo(f"{len(tasks)} runs, {len(tasks) - len(todo)} already in {out}, {len(todo)} to run ({where})")
    t0 = time.perf_counter()
    if todo:
        if jobs > 1 or scheduler:
            with executor(jobs, scheduler) as (ex, _):
                futs = {ex.submit(run_cr_task, t): t for t in todo}
                failed = _collect(((futs[f], f) for f in cf.as_completed(list(futs))), len(todo), out, echo, futs)
        else:  # one process: each run when its turn comes, its row written as the others' are
            failed = _collect(((t, _run_inline(t)) for t in todo), len(todo), out, echo, {})
        wall = time.perf_counter() - t0
        echo(f"{len(todo)} runs in {wall:.0f} s wall, {failed} failed (written; run again to retry)")
    p = Path(out) / "commonroad.parquet"
    if not p.is_file():
        return []
    with require("campaign", "the CommonRoad campaign's results"):
        import pandas as pd

    keys = {task_key(t) for t in tasks}
    rows = pd.read_parquet(p).to_dict("records")
    return [r for r in rows if (r["scenario"], r["problem"], r["controller"], r["traffic"], _pred(r)) in keys]


def _pred(row: dict) -> str:
    """A row's prediction (``oracle`` in rows written before the column)."""
    p = row.get("prediction")
    return p if isinstance(p, str) else "oracle"


def failed_row(task: CrTask, error: str) -> dict:
    """The row of a run that raised ``error``: status ``failed``, refusal kind ``error``, the error in ``reason``."""
    row = dict.fromkeys(ROW_KEYS)
    row.update(
        scenario=Path(task.path).stem,
        dataset=dataset_of(task.path),
        file=Path(task.path).name,
        problem=_problem_name(task.config),
        profile=task.config.profile,
        controller=task.config.controller,
        traffic=task.traffic,
        prediction=task.config.plant.prediction,
        status="failed",
        refusal="error",
        reason=error,
    )
    return row


def _run_inline(task: CrTask) -> cf.Future:
    """One task run in this process: a finished future holding its row or its exception."""
    fut: cf.Future = cf.Future()
    try:
        fut.set_result(run_cr_task(task))
    except Exception as exc:  # noqa: BLE001 - kept in the future, as a pool's worker would
        fut.set_exception(exc)
    return fut


def _collect(done, total: int, out: str | Path, echo, futs: dict) -> int:
    """Write the finished runs' rows (``done``: (task, finished future) as they finish) in batches (``FLUSH_ROWS`` /
    ``FLUSH_SECONDS``); an interruption keeps them and cancels ``futs``. A run that raises is named and written as
    ``failed`` (kind ``error``; the next call runs it again); returns how many did."""
    buf: list[dict] = []
    last = time.monotonic()
    n = failed = 0
    try:
        for task, fut in done:
            n += 1
            try:
                row = fut.result()
            except Exception as exc:  # noqa: BLE001 - any error of one run: named, counted, the campaign goes on
                row = failed_row(task, f"{type(exc).__name__}: {str(exc).splitlines()[0] if str(exc) else ''}")
                echo(f"failed {row['file']} ({task.traffic}): {row['reason']}")
                failed += 1
            buf.append(row)
            if row["status"] == "refused":
                echo(f"refused {row['file']} ({row['refusal']}): {row['reason']}")
            if len(buf) >= FLUSH_ROWS or time.monotonic() - last > FLUSH_SECONDS:
                write_results(buf, out)
                echo(f"{n} of {total} runs done")
                buf.clear()
                last = time.monotonic()
    except BaseException:
        for f in futs:
            f.cancel()
        raise
    finally:
        if buf:
            write_results(buf, out)
    return failed
