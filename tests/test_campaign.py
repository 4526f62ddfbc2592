"""fcgen campaign: the paper's grid, cached compiled solvers, the one task function on a process pool and on a local
Dask cluster (2 worker processes), Parquet rows written as runs finish, resume after partial results or a kill."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import textwrap
import time
from dataclasses import replace
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from fcgen.campaign.grid import Config, make_tasks, paper_grid
from fcgen.campaign.runner import run_campaign
from fcgen.campaign.solvers import ensure_solver, solver_hash
from fcgen.campaign.store import ResultStore
from fcgen.campaign.task import _alat_outcome, run_task
from fcgen.dsl import ProblemError
from fcgen.presets import paper_problem

SAMPLES = 6
CONFIGS = paper_grid(["truck"], ["direct_elimination", "lifted"], ["ellipse"])
# columns that depend on timing, the worker, when the run happened and how loaded the machine was
TIMING = ("time_", "wall_s", "cpu_s", "t_start", "t_end", "worker", "load_1min")


@pytest.fixture(scope="module")
def cache(tmp_path_factory):
    return str(tmp_path_factory.mktemp("solvers"))


def stable(df):
    cols = [c for c in df.columns if not c.startswith(TIMING)]
    return df[cols].sort_values(["config", "seed"]).reset_index(drop=True)


def test_the_paper_grid_has_24_configurations_with_the_papers_obstacle_models():
    grid = paper_grid()
    assert len(grid) == 24 and len({c.key for c in grid}) == 24
    models = {sc: sorted({c.model for c in grid if c.scenario == sc}) for sc in ("truck", "car")}
    assert models == {"truck": ["C5", "C7", "EL", "HP"], "car": ["C1", "C3", "EL", "HP"]}
    c7 = next(c for c in grid if c.model == "C7" and c.formulation == "lifted")
    assert c7.problem().obstacles.n == 7 and c7.problem().opponents.vehicle.l_f_ch == 13.0
    with pytest.raises(ProblemError, match="obstacles: 'square' is invalid"):
        paper_grid(["car"], ["lifted"], ["square"])
    with pytest.raises(ProblemError, match="controller = 'matlab' is invalid"):
        Config("car", "lifted", "ellipse", controller="matlab")


def test_a_corners_configuration_has_its_own_key_problem_and_row_column():
    rear, corners = Config("car", "lifted", "ellipse"), Config("car", "lifted", "ellipse", road_bound="corners")
    assert rear.key == "car/lifted/EL/c/osqp" and corners.key == "car/lifted/EL/c/osqp/corners"
    assert rear.problem().bounds.road_bound == "rear_axle" and "road_bound" not in rear.as_dict()
    pb = corners.problem()
    assert pb.bounds.road_bound == "corners" and corners.as_dict()["road_bound"] == "corners"
    assert pb.name != rear.problem().name and replace(pb.bounds, road_bound="rear_axle") == rear.problem().bounds
    grid = paper_grid(["truck"], ["lifted"], ["ellipse"], road_bound="corners")
    assert [c.road_bound for c in grid] == ["corners"]
    with pytest.raises(ProblemError, match="road_bound = 'front' is invalid: allowed one of rear_axle, corners"):
        Config("car", "lifted", "ellipse", road_bound="front")


def test_solver_cache_is_keyed_by_the_problem_and_built_once(cache):
    a, b = paper_problem("truck", "lifted", "ellipse"), paper_problem("truck", "direct_elimination", "ellipse")
    assert solver_hash(a) == solver_hash(paper_problem("truck", "lifted", "ellipse"))
    assert solver_hash(a) != solver_hash(b)
    assert solver_hash(a) != solver_hash(replace(a, horizon=replace(a.horizon, N=30)))
    lib = ensure_solver(a, cache)
    assert lib.is_file() and solver_hash(a) in lib.parent.parent.name
    mtime = lib.stat().st_mtime_ns
    assert ensure_solver(a, cache) == lib and lib.stat().st_mtime_ns == mtime  # not rebuilt


def test_solver_cache_rebuilds_a_folder_built_since_with_other_flags(cache):
    """A cache folder rebuilt by hand with other flags (as `fcgen simulate --solver-dir` does with $CFLAGS) is
    built again with the cache's flags before it is used: the rows' cflags say how their solver was compiled."""
    from fcgen.build import build

    pb = CONFIGS[1].problem()
    lib = ensure_solver(pb, cache, cflags="-O1")
    flags = lib.parent / "flags.txt"
    assert " -O1 " in flags.read_text()
    build(lib.parent.parent, cflags="-O0")  # someone else's build of the cache folder
    assert " -O0 " in flags.read_text()
    assert ensure_solver(pb, cache, cflags="-O1") == lib
    assert " -O1 " in flags.read_text() and " -O0 " not in flags.read_text()
    mtime = lib.stat().st_mtime_ns
    assert ensure_solver(pb, cache, cflags="-O1") == lib and lib.stat().st_mtime_ns == mtime  # then kept


def test_campaign_cflags_build_their_own_cached_solver_and_are_recorded(cache):
    """--cflags: a second cache folder (the default's hash unchanged), the flags in the row, the same closed loop
    (-O1 and -O2 give bit-identical run logs on this solver, see docs/regression.md)."""
    pb = CONFIGS[1].problem()
    assert solver_hash(pb, cflags=None) == solver_hash(pb) != solver_hash(pb, cflags="-O1")
    default, o1 = (run_task(make_tasks(CONFIGS[1:], range(1), SAMPLES, cache, cflags=f)[0]) for f in (None, "-O1"))
    assert (default["cflags"], o1["cflags"]) == ("default", "-O1")
    assert default["solver_hash"] != o1["solver_hash"]
    assert ensure_solver(pb, cache, cflags="-O1").parent.parent.name.endswith(solver_hash(pb, cflags="-O1"))
    same = [k for k in default if not k.startswith(TIMING) and k not in ("cflags", "solver_hash")]
    assert [default[k] for k in same] == [o1[k] for k in same]


def test_alat_outcome_counts_samples_above_the_bound():
    out = _alat_outcome(np.array([1.0, -5.5, 5.0, 6.0, -4.9]), 5.0)
    assert out == {"a_lat_bound": 5.0, "a_lat_over_samples": 2, "a_lat_excess_max": 1.0, "a_lat_excess_mean": 0.75}


@pytest.mark.parametrize("clock", ["cpu", "wall"])
def test_solver_time_fits_inside_the_runs_cpu_or_wall_time(cache, clock):
    task = make_tasks(CONFIGS[1:], range(1), 20, cache, clock)[0]
    row = run_task(task)
    solver_s = sum(row["time_rti_ms"]) / 1e3
    assert row["clock"] == clock and solver_s > 0
    # the solver's share of a run: its CPU time fits in the run's process CPU time, its wall time in the run's wall
    assert solver_s <= (row["cpu_s"] if clock == "cpu" else row["wall_s"])
    assert row["cpu_s"] > 0 and row["wall_s"] > 0
    # no contact in these 20 samples: the collision columns say so (sim.collision_kind on the run log)
    assert not row["collision"] and (row["collision_kind"], row["collision_depth_m"]) == ("", 0.0)


def test_dask_cluster_and_process_pool_give_the_same_rows(cache, tmp_path):
    from distributed import LocalCluster

    tasks = make_tasks(CONFIGS, range(2), SAMPLES, cache)
    with LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None) as cluster:
        res = run_campaign(tasks, tmp_path / "dask", scheduler=cluster.scheduler_address, flush_every=1)
    assert (res.computed, res.skipped, res.failed, res.workers) == (4, 0, [], 2)
    dask_rows = ResultStore(tmp_path / "dask").read()
    assert len(ResultStore(tmp_path / "dask").parts()) == 4  # written run by run
    pool = run_campaign(tasks, tmp_path / "pool", jobs=2)
    assert pool.computed == 4 and not pool.failed
    pool_rows = ResultStore(tmp_path / "pool").read()
    a, b = stable(dask_rows), stable(pool_rows)
    assert list(a["config"]) == sorted(c.key for c in CONFIGS for _ in range(2))
    pd.testing.assert_frame_equal(a, b)  # on a difference: the column, the rows and both values
    # every row: the run's figures, its collision verdict (true rectangles), wall time, per-RTI times
    for r in dask_rows.to_dict("records"):
        assert r["n_controls"] == SAMPLES and len(r["time_rti_ms"]) == SAMPLES
        assert r["collision"] == (r["n_collision_samples"] > 0)
        assert 0 < r["progress"] < 40.0 * SAMPLES * 0.1 and r["wall_s"] > 0
        assert np.isclose(np.mean(r["time_rti_ms"]), r["time_total_ms_mean"], rtol=1e-5)


def test_resume_computes_only_the_missing_runs(cache, tmp_path):
    out = tmp_path / "res"
    first = run_campaign(make_tasks(CONFIGS, range(2), SAMPLES, cache), out, jobs=1, flush_every=1)
    assert first.computed == 4
    store = ResultStore(out)
    lost = store.parts()[1]
    lost_run = pd.read_parquet(lost)[["config", "seed"]].iloc[0]
    lost.unlink()  # partial results: one run missing
    (out / ".part-x.tmp").write_bytes(b"half a file")  # a write cut short is ignored
    tasks = make_tasks(CONFIGS, range(3), SAMPLES, cache)  # and one more seed
    again = run_campaign(tasks, out, jobs=1, flush_every=1)
    assert (again.computed, again.skipped) == (3, 3)
    done = store.done()
    assert {t.run_id for t in tasks} == done and (lost_run["config"], SAMPLES, int(lost_run["seed"]), "cpu") in done
    assert run_campaign(tasks, out, jobs=1).computed == 0  # finished: nothing recomputed
    assert store.compact() is not None and len(store.parts()) == 1 and len(store.read()) == 6


def test_a_killed_campaign_resumes_where_it_stopped(cache, tmp_path):
    out = tmp_path / "killed"
    script = textwrap.dedent(f"""
        from fcgen.campaign.grid import make_tasks, paper_grid
        from fcgen.campaign.runner import run_campaign
        cfgs = paper_grid(["truck"], ["direct_elimination", "lifted"], ["ellipse"])
        run_campaign(make_tasks(cfgs, range(10), 60, {cache!r}), {str(out)!r}, jobs=1, flush_every=1)
    """)
    proc = subprocess.Popen([sys.executable, "-c", script], start_new_session=True)
    try:
        deadline = time.monotonic() + 120
        while len(ResultStore(out).parts()) < 2 and time.monotonic() < deadline and proc.poll() is None:
            time.sleep(0.02)
    finally:
        os.killpg(proc.pid, signal.SIGKILL)
        proc.wait()
    before = len(ResultStore(out).done())
    assert 2 <= before < 20, before  # killed part-way through
    res = run_campaign(make_tasks(CONFIGS, range(10), 60, cache), out, jobs=2)
    assert (res.computed, res.skipped) == (20 - before, before)
    assert len(ResultStore(out).read()) == 20


def test_cli_campaign_then_report(cache, tmp_path):
    from click.testing import CliRunner

    from fcgen.cli import main

    out, rep = tmp_path / "res", tmp_path / "rep"
    args = [
        "campaign",
        "--scenarios",
        "truck",
        "--formulations",
        "lifted",
        "--obstacles",
        "ellipse",
        "--seeds",
        "2",
        "--samples",
        "4",
        "--jobs",
        "1",
        "--cache",
        cache,
        "--out",
        str(out),
    ]
    res = CliRunner().invoke(main, [*args, "--report", str(rep)])
    assert res.exit_code == 0, res.output
    assert "1 configurations x 2 seeds x 4 samples = 2 runs" in res.output
    assert "2 runs computed, 0 already done" in res.output
    assert len(ResultStore(out).parts()) == 1  # finished: compacted into one file
    assert "## Table III" in (rep / "README.md").read_text() and (rep / "boxplots_truck.svg").is_file()
    res = CliRunner().invoke(main, args)
    assert res.exit_code == 0 and "0 runs computed, 2 already done" in res.output


def _worker_threads() -> dict:
    return {v: os.environ.get(v) for v in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS")}


def test_local_pool_workers_run_single_threaded_blas(monkeypatch):
    """The pool's workers get one BLAS/OpenMP thread each (idle BLAS threads spin on the other workers' cores); a
    value the user set is kept."""
    from fcgen.campaign.runner import executor

    for v in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
        monkeypatch.delenv(v, raising=False)
    monkeypatch.setenv("MKL_NUM_THREADS", "3")
    with executor(1) as (ex, workers):
        env = ex.submit(_worker_threads).result()
    assert workers == 1
    assert env == {"OMP_NUM_THREADS": "1", "OPENBLAS_NUM_THREADS": "1", "MKL_NUM_THREADS": "3"}


def test_solvers_are_built_before_the_runs_one_per_configuration(cache):
    """run_campaign builds each configuration's solver once, up front (every worker building at the same time),
    whatever the number of its runs."""
    import concurrent.futures as cf

    from fcgen.campaign.runner import Outcome, _build_solvers

    tasks = make_tasks(CONFIGS, range(3), SAMPLES, cache)
    calls = []
    with cf.ThreadPoolExecutor(2) as ex:
        real_submit = ex.submit
        ex.submit = lambda fn, *a: (calls.append(a[1].key), real_submit(fn, *a))[1]  # capturing(build_solver, ...)
        _build_solvers(ex, tasks, Outcome(len(tasks), 0))
    assert sorted(calls) == sorted(c.key for c in CONFIGS)
    for c in CONFIGS:
        assert ensure_solver(c.problem(), cache).is_file()


def test_cli_campaign_prints_its_warnings_once_after_the_runs_then_a_results_table(cache, tmp_path):
    """The truck's paper covering circles C5 do not cover its chassis by the paper's radius: the workers warn while
    they generate the solver; the warning is printed once, after the progress bar (before: once per process, into
    it); then a results table whose figures are the results store's."""
    fcgen = str(Path(sys.executable).with_name("fcgen"))
    args = ["campaign", "--scenarios", "truck", "--formulations", "lifted", "--obstacles", "c5", "--cache", cache]
    args += ["--seeds", "2", "--samples", "3", "--jobs", "2", "--out", str(tmp_path / "r")]
    res = subprocess.run([fcgen, *args], capture_output=True, text=True, timeout=600)
    assert res.returncode == 0, res.stderr
    warn = [ln for ln in res.stderr.splitlines() if "do not cover" in ln]
    assert len(warn) == 1, res.stderr
    assert warn[0].startswith("warning: UserWarning: obstacles: 5 circles of radius w/sqrt(2) do not cover"), warn
    assert res.stderr.index("do not cover") > res.stderr.rindex("campaign (0 done before)")  # after the bar
    lines = res.stdout.splitlines()
    table = lines[next(i for i, ln in enumerate(lines) if ln.startswith("configuration ")) :]
    assert table[0].split() == ["configuration", "runs", "collisions", "progress", "[m]", "time", "per", "RTI", "[ms]"]
    rows = {ln.split()[0]: ln.split()[1:] for ln in table[2:]}
    assert set(rows) == {"truck/lifted/C5/c/osqp"}
    df = ResultStore(tmp_path / "r").read()
    for key, (runs, coll, prog, t_rti) in rows.items():
        r = df[df["config"] == key]
        assert int(runs) == len(r) == 2 and int(coll) == int(r["collision"].sum())
        assert float(prog) == pytest.approx(r["progress"].mean(), abs=0.05)
        assert float(t_rti) == pytest.approx(r["time_total_ms_median"].median(), abs=5e-4)


def test_the_commonroad_campaign_of_the_safe_profile_bounds_the_chassis_corners_by_default(tmp_path, monkeypatch):
    """``campaign --commonroad`` without ``--road-bound``: the corners for ``--profile safe``, the presets' rear axle
    for ``--profile paper`` and for the paper's road; ``--road-bound`` overrides either."""
    from click.testing import CliRunner

    import fcgen.cli.runs as runs
    from fcgen.cli import main

    got = {}
    monkeypatch.setattr(runs, "commonroad_campaign", lambda configs, *a, **k: got.update(cr=configs))
    monkeypatch.setattr(runs, "_seeded_campaign", lambda configs, *a, **k: got.update(seeded=configs))
    base = ["campaign", "--scenarios", "car", "--formulations", "lifted", "--obstacles", "ellipse", "--seeds", "1"]
    cases = [
        (["--commonroad", str(tmp_path), "--profile", "safe"], "cr", "corners"),
        (["--commonroad", str(tmp_path), "--profile", "paper"], "cr", "rear_axle"),
        (["--commonroad", str(tmp_path), "--profile", "safe", "--road-bound", "rear_axle"], "cr", "rear_axle"),
        (["--profile", "safe"], "seeded", "rear_axle"),
        (["--profile", "paper", "--road-bound", "corners"], "seeded", "corners"),
    ]
    for i, (extra, kind, bound) in enumerate(cases):
        got.clear()
        out = ["--out", str(tmp_path / f"o{i}"), "--cache", str(tmp_path / "c")]
        r = CliRunner().invoke(main, base + extra + out)
        assert r.exit_code == 0, r.output
        assert [c.road_bound for c in got[kind]] == [bound], extra
