"""The closed loop's and the campaign's fast paths give what the plain ones give, bit for bit: the plant through a
CasADi FunctionBuffer vs the Function call, the opponents' poses in one vectorized call vs one call per index, the
unchecked road window vs the checked constructor, ``pack_into`` vs the concatenation formula, the task order, and the
results store at hundreds of parts vs pandas reading each part."""

from __future__ import annotations

import itertools
import math

import numpy as np
import pandas as pd
import pyarrow.parquet as pq
import pytest

from fcgen.campaign.grid import make_tasks, paper_grid
from fcgen.campaign.store import RUN_ID, ResultStore
from fcgen.ocp import road_window_samples
from fcgen.presets import paper_problem
from fcgen.road import Road, RoadWindowParams, random_road
from fcgen.sim.closedloop import Plant, plant_function
from fcgen.sim.scenario import OpponentParams, make_scenario, realistic_road
from fcgen.sim.standstill import rolls_back


def _bits(a) -> bytes:
    return np.ascontiguousarray(a, dtype=np.float64).tobytes()


@pytest.mark.parametrize("scenario", ["truck", "car"])
def test_plant_buffer_equals_the_casadi_call_bit_for_bit(scenario):
    pb = paper_problem(scenario, "lifted", "ellipse")
    samples = road_window_samples(pb)
    f, rp, plant = plant_function(pb, samples), RoadWindowParams(samples), Plant(pb, samples)
    rng = np.random.default_rng(7)
    road = random_road(3, length=400.0, s0=-50.0)
    stood = 0
    for k in range(300):
        s = rng.uniform(-40.0, 300.0) if k % 10 else road.s0 + road.ds * rng.integers(5, 150)  # on a grid point too
        x = np.array([s, rng.uniform(-6, 6), rng.uniform(-0.5, 0.5), rng.uniform(0.0, 40.0), rng.uniform(-0.4, 0.4)])
        u = np.array([rng.uniform(-1e4, 1e4), rng.uniform(-0.4, 0.4)])
        i0 = math.floor((x[0] - road.s0) / road.ds) - 1
        want = np.array(f(x, u, rp.pack(road, i0))).ravel()
        got = plant.step(x, u, road)
        if rolls_back(x, want):  # the plant stands instead (tests/test_plant_standstill.py): v = 0, delta as the call
            stood += 1
            assert got[3] == 0.0 and _bits(got[4]) == _bits(want[4]), (k, got, want)
            continue
        assert _bits(got) == _bits(want), (k, got - want)
    assert 0 < stood < 30  # the draws reach the standstill a few times; every other draw is the call bit for bit
    assert got is not plant.step(x, u, road)  # a fresh array each call (the log keeps them)
    assert plant_function(pb, samples) is f  # built once per problem and window size


def test_pack_into_is_the_concatenated_window_and_checks_the_range():
    road = random_road(5, length=100.0)
    rp = RoadWindowParams(7)
    for i0 in (0, 10, road.size - 7):
        want = np.concatenate(
            [
                [road.s0 + i0 * road.ds, road.ds],
                road.kappa[i0 : i0 + 7],
                road.phi[i0 : i0 + 7],
                road.gx[i0 : i0 + 7],
                road.gy[i0 : i0 + 7],
            ]
        )
        assert _bits(rp.pack(road, i0)) == _bits(want)
    for bad in (-1, road.size - 6):
        with pytest.raises(ValueError, match="outside the road"):
            rp.pack(road, bad)


def test_road_window_equals_the_checked_constructor():
    road = random_road(11, length=300.0, s0=-50.0)
    for s in (-50.0, -49.0, 13.7, 200.0):
        win = road.window(s, 12)
        i0 = math.floor((s - road.s0) / road.ds)
        want = Road(
            road.s0 + i0 * road.ds,
            road.ds,
            road.kappa[i0 : i0 + 12],
            road.phi[i0 : i0 + 12],
            road.gx[i0 : i0 + 12],
            road.gy[i0 : i0 + 12],
        )
        assert (win.s0, win.ds, win.size) == (want.s0, want.ds, 12)
        for name in ("kappa", "phi", "gx", "gy"):
            assert _bits(getattr(win, name)) == _bits(getattr(want, name))
            assert not np.shares_memory(getattr(win, name), getattr(road, name))  # a copy, as before
    with pytest.raises(ValueError, match="outside the road"):
        road.window(-52.0, 12)
    with pytest.raises(ValueError, match="length >= 2"):
        road.window(0.0, 1)


@pytest.mark.parametrize("scenario", ["truck", "car"])
def test_opponent_poses_table_equals_one_call_per_index(scenario):
    pb = paper_problem(scenario, "direct_elimination", "ellipse")
    N = pb.horizon.N
    for seed in (0, 4):
        sc = make_scenario(scenario, seed, n_opp=pb.opponents.count, samples=50, dt=pb.horizon.dt)
        op = OpponentParams(pb, sc)
        for j in range(0, 60):  # past the table (50 + N + 1) too
            want = np.stack([sc.opp_cartesian((j + k) * sc.dt) for k in range(N + 1)])
            got = op.horizon(j)
            assert got.shape == (N + 1, pb.opponents.count, 3) and _bits(got) == _bits(want), j
        assert _bits(op.at_index(200)) == _bits(sc.opp_cartesian(200 * sc.dt))
        with pytest.raises(ValueError, match="read-only"):
            op.horizon(0)[0, 0, 0] = 1.0


def test_realistic_road_is_computed_once_per_seed_and_read_only():
    a, b = realistic_road(9), realistic_road(9)
    assert a is b and not a.kappa.flags.writeable
    assert make_scenario("car", 9).road is make_scenario("truck", 9).road  # every configuration of a seed


def test_tasks_cover_the_grid_block_by_block_and_keep_a_solver_for_a_block():
    configs = paper_grid(backend="ipm")
    tasks = make_tasks(configs, range(3, 23), 200, "/tmp/cache", block=8)
    assert sorted((t.config.key, t.seed) for t in tasks) == sorted((c.key, s) for c in configs for s in range(3, 23))
    first = tasks[: 8 * len(configs)]  # the first block: every configuration, seeds 3..10
    assert {(t.config.key, t.seed) for t in first} == {(c.key, s) for c in configs for s in range(3, 11)}
    switches = sum(a.config != b.config for a, b in itertools.pairwise(tasks))
    assert switches == 3 * len(configs) - 1  # one switch per (block, configuration)
    assert [t.seed for t in tasks[-4:]] == [19, 20, 21, 22]  # the last block holds the 4 seeds left
    seed_major = make_tasks(configs, range(3), 200, "/tmp/cache", block=1)
    assert [(t.seed, t.config) for t in seed_major] == [(s, c) for s in range(3) for c in configs]


def _row(seed: int) -> dict:
    return {
        "config": "truck/lifted/EL/c/ipm",
        "samples": 200,
        "seed": seed,
        "clock": "cpu",
        "progress": 0.5 * seed,
        "collision": seed % 7 == 0,
        "qp_iter_max": seed % 5,
        "time_rti_ms": [0.1 * seed, 0.2, 0.3 + seed],
        "cpu_s": 0.01 * (seed + 1),
    }


def test_store_at_hundreds_of_parts_reads_what_pandas_reads_and_appends_only(tmp_path):
    store = ResultStore(tmp_path / "res")
    first = store.write([_row(0), _row(1)])
    mtime = first.stat().st_mtime_ns
    for p in range(1, 300):  # a long campaign: 300 parts of 2 rows
        store.write([_row(2 * p), _row(2 * p + 1)])
    parts = store.parts()
    assert len(parts) == 300 and first.stat().st_mtime_ns == mtime  # appends never rewrite earlier parts
    want = pd.concat([pd.read_parquet(p) for p in parts], ignore_index=True)
    got = store.read()
    pd.testing.assert_frame_equal(got.drop(columns="time_rti_ms"), want.drop(columns="time_rti_ms"))
    assert all(np.array_equal(a, b) for a, b in zip(got["time_rti_ms"], want["time_rti_ms"]))
    assert store.done() == {("truck/lifted/EL/c/ipm", 200, s, "cpu") for s in range(600)}
    schema = pq.read_schema(first)
    part_compression = pq.ParquetFile(first).metadata.row_group(0).column(0).compression
    store.write([_row(5)])  # a duplicate run: compact keeps its first row
    merged = store.compact()
    assert store.parts() == [merged]
    df = store.read()
    assert list(df["seed"]) == list(range(600))  # one row per run, sorted by run id
    assert pq.read_schema(merged).equals(schema)  # the same schema as the parts
    assert list(pq.read_schema(merged).metadata) == [b"fcgen.merged_parts"]  # no pandas metadata: the merged parts
    meta = pq.ParquetFile(merged).metadata.row_group(0)
    assert {meta.column(i).compression for i in range(meta.num_columns)} == {"ZSTD"}  # the merged file: zstd
    assert part_compression == "SNAPPY"  # the parts: snappy
    np.testing.assert_array_equal(df.set_index("seed").loc[5, "time_rti_ms"], [0.5, 0.2, 5.3])
    assert tuple(RUN_ID) == ("config", "samples", "seed", "clock")


def test_collect_writes_batches_and_keeps_no_finished_future(tmp_path):
    import concurrent.futures as cf

    from fcgen.campaign.runner import Outcome, _collect

    tasks = make_tasks(paper_grid(["truck"], ["lifted"], ["ellipse"]), range(7), 200, "/tmp/cache")
    futs = {}
    for t in tasks:
        f = cf.Future()
        if t.seed == 3:
            f.set_exception(RuntimeError("solver exploded"))
        else:
            f.set_result((_row(t.seed), ["UserWarning: w"] if t.seed % 2 else []))  # capturing(run_task, t)
        futs[f] = t
    out, buf, store = Outcome(total=7, skipped=0), [], ResultStore(tmp_path / "res")
    _collect(futs, out, buf, None, store, flush_every=2, flush_seconds=1e9)
    assert futs == {} and out.computed == 6  # collected futures are let go
    assert out.failed == [(tasks[3].run_id, "RuntimeError: solver exploded")]
    assert out.warnings == ["UserWarning: w"]  # the workers' warnings, each once
    assert len(store.parts()) == 3 and buf == []  # 6 rows in batches of 2, nothing left over
    assert sorted(store.read()["seed"]) == [0, 1, 2, 4, 5, 6]
    # the time split: RTI times (1.1 seed + 0.5) ms and loop CPU 0.01 (seed + 1) s of the six runs, summed by hand
    assert out.solver_s == pytest.approx(1e-3 * (1.1 * 18 + 0.5 * 6)) and out.loop_cpu_s == pytest.approx(0.24)
    out.wall_s, out.workers = 1.2, 2
    assert out.time_split() == (
        "5.00 runs/s; solver 0.0 s = 9.5 % of the closed loops' CPU (0.2 s), the loops 10.0 % of the workers' "
        "wall time (2.4 s)"
    )
