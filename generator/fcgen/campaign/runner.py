"""Run a campaign's tasks on an executor: a local process pool, or a Dask cluster through ``Client.get_executor()``.

Both are ``concurrent.futures`` executors running the same task function (``task.run_task``); the executor is the
only difference. Rows are written as runs finish (a part file every ``flush_every`` runs or ``flush_seconds``), and
runs already in the results folder are skipped, so an interrupted campaign resumes where it stopped (a merge killed
part-way is finished first: ``ResultStore.repair``). Local pool workers die with the campaign process, however it
dies (``die_with_parent``: the kernel's parent-death signal); Dask's LocalCluster workers exit when their nanny's
process does.
"""

from __future__ import annotations

import concurrent.futures as cf
import ctypes
import multiprocessing
import os
import signal
import sys
import threading
import time
import warnings
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path

from ..extras import require
from .grid import Task
from .store import ResultStore
from .task import build_solver, run_task


@dataclass
class Outcome:
    """What one call of ``run_campaign`` did."""

    total: int
    skipped: int
    computed: int = 0
    failed: list[tuple[tuple, str]] = field(default_factory=list)
    wall_s: float = 0.0
    workers: int = 0
    warnings: list[str] = field(default_factory=list)  # what the workers warned, each message once
    solver_s: float = 0.0  # the computed runs' time inside the solver (the sum of their RTI times, by --clock)
    loop_cpu_s: float = 0.0  # the computed runs' closed loops' CPU time (solver, plant, the loop's Python)

    def time_split(self) -> str:
        """One line: runs per second, the solver's share of the closed loops' CPU and the loops' share of the
        workers' wall time (the rest: scenarios, run logs, rows, results store, waiting)."""
        rate = self.computed / self.wall_s if self.wall_s > 0 else 0.0
        worker_s = self.wall_s * max(self.workers, 1)
        solver = 100.0 * self.solver_s / self.loop_cpu_s if self.loop_cpu_s > 0 else 0.0
        loops = 100.0 * self.loop_cpu_s / worker_s if worker_s > 0 else 0.0
        return (
            f"{rate:.2f} runs/s; solver {self.solver_s:.1f} s = {solver:.1f} % of the closed loops' CPU "
            f"({self.loop_cpu_s:.1f} s), the loops {loops:.1f} % of the workers' wall time ({worker_s:.1f} s)"
        )


def capturing(fn, *args):
    """``fn(*args)`` with its warnings caught instead of printed: ``(result, messages)``. Run in the workers, so that
    their warnings reach the campaign's process (printed once, after the progress bar) instead of each worker's
    stderr in the middle of the bar."""
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        res = fn(*args)
    return res, [f"{w.category.__name__}: {w.message}" for w in caught]


def _note(out: Outcome, messages: list[str]) -> None:
    for m in messages:
        if m not in out.warnings:
            out.warnings.append(m)


#: one thread per worker for numpy's BLAS and OpenMP: a run's arrays are tiny, and idle BLAS threads spin on the cores
#: the other workers need (Dask's nanny sets the same variables for its workers)
WORKER_THREAD_VARS = ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS")


_PR_SET_PDEATHSIG = 1


def die_with_parent(parent: int) -> None:
    """Worker initializer: the worker is killed (SIGKILL) when its parent process dies, however it dies (a SIGKILLed
    campaign would otherwise leave its workers blocked on the task queue, orphaned, for ever). Linux: the kernel's
    parent-death signal (``prctl(PR_SET_PDEATHSIG)``); elsewhere a thread that watches the parent pid."""
    if sys.platform.startswith("linux"):
        libc = ctypes.CDLL(None, use_errno=True)
        if libc.prctl(_PR_SET_PDEATHSIG, signal.SIGKILL, 0, 0, 0) != 0:
            raise OSError(ctypes.get_errno(), "prctl(PR_SET_PDEATHSIG) failed")
    else:

        def watch() -> None:
            while os.getppid() == parent:
                time.sleep(1.0)
            os._exit(1)

        threading.Thread(target=watch, daemon=True, name="fcgen-parent-watch").start()
    if os.getppid() != parent:  # the parent died before the signal was armed
        os._exit(1)


def single_threaded_workers() -> None:
    """Set ``WORKER_THREAD_VARS`` to 1 (unless the user set them) for the worker processes started after this call."""
    for var in WORKER_THREAD_VARS:
        os.environ.setdefault(var, "1")


@contextmanager
def executor(jobs: int = 2, scheduler: str | None = None):
    """A process pool of ``jobs`` workers, or a Dask cluster's executor: ``scheduler`` = an address
    (``tcp://host:8786``) or ``local`` (a LocalCluster of ``jobs`` single-threaded worker processes)."""
    if scheduler is None:
        single_threaded_workers()
        with cf.ProcessPoolExecutor(
            jobs, mp_context=multiprocessing.get_context("spawn"), initializer=die_with_parent, initargs=(os.getpid(),)
        ) as ex:
            yield ex, jobs
        return
    with require("campaign", "a dask scheduler"):
        from distributed import Client, LocalCluster

    if scheduler == "local":
        with (
            LocalCluster(n_workers=jobs, threads_per_worker=1, processes=True, dashboard_address=None) as cl,
            Client(cl) as client,
        ):
            yield client.get_executor(pure=False), jobs
        return
    with Client(scheduler, timeout="20s") as client:
        yield client.get_executor(pure=False), sum(client.nthreads().values())


def run_campaign(
    tasks: list[Task],
    results: str | Path,
    jobs: int = 2,
    scheduler: str | None = None,
    progress: bool = False,
    flush_every: int = 20,
    flush_seconds: float = 30.0,
) -> Outcome:
    """Run the tasks not yet in ``results``; rows are written as they finish. Failed runs are reported, not written."""
    store = ResultStore(results)
    store.repair()  # a merge killed part-way: its merged parts go (their rows are in the merged file)
    done = store.done()
    todo = [t for t in tasks if t.run_id not in done]
    out = Outcome(total=len(tasks), skipped=len(tasks) - len(todo))
    if not todo:
        return out
    bar = None
    if progress:
        with require("campaign", "the campaign's progress bar"):
            from tqdm import tqdm

        bar = tqdm(total=len(todo), unit="run", desc=f"campaign ({out.skipped} done before)", smoothing=0.05)
    t0 = time.perf_counter()
    buf: list[dict] = []
    try:
        with executor(jobs, scheduler) as (ex, workers):
            out.workers = workers
            _build_solvers(ex, todo, out)
            futs = {ex.submit(capturing, run_task, t): t for t in todo}
            try:
                _collect(futs, out, buf, bar, store, flush_every, flush_seconds)
            except BaseException:  # interrupted: drop the runs not started, keep (flush) the finished ones
                for f in futs:
                    f.cancel()
                raise
    finally:
        store.write(buf)
        if bar is not None:
            bar.close()
        out.wall_s = time.perf_counter() - t0
    return out


def _build_solvers(ex, todo: list[Task], out: Outcome) -> None:
    """Generate and compile the C solvers of the runs' configurations first, all workers at once (built lazily by
    the first run of each, a worker would wait on another's build of the same solver). A failed build is not
    raised here: the configuration's runs report it."""
    keys = sorted(
        {(t.config, t.cache_dir, t.cflags) for t in todo if t.config.controller == "c"}, key=lambda k: k[0].key
    )
    futs = [ex.submit(capturing, build_solver, *k) for k in keys]
    cf.wait(futs)  # a build's exception stays in its future, unraised: the runs of that configuration report it
    for fut in futs:
        if fut.exception() is None:
            _note(out, fut.result()[1])


def _collect(
    futs: dict, out: Outcome, buf: list, bar, store: ResultStore, flush_every: int, flush_seconds: float
) -> None:
    """Gather finished runs into ``buf`` (in place), writing a part whenever enough have piled up. A collected future
    leaves ``futs`` (which then holds the unfinished ones only), so a long campaign does not keep every row twice."""
    last = time.monotonic()
    for fut in cf.as_completed(list(futs)):
        task = futs.pop(fut)
        try:
            row, messages = fut.result()
            buf.append(row)
            _note(out, messages)
            out.computed += 1
            out.solver_s += 1e-3 * float(sum(row["time_rti_ms"]))
            out.loop_cpu_s += float(row["cpu_s"])
        except cf.CancelledError:
            continue
        except Exception as exc:  # noqa: BLE001 - a run that fails (any error) is reported, not written; retried next call
            out.failed.append((task.run_id, f"{type(exc).__name__}: {exc}"))
        if bar is not None:
            bar.update(1)
        if len(buf) >= flush_every or (buf and time.monotonic() - last > flush_seconds):
            store.write(buf)
            buf.clear()
            last = time.monotonic()
