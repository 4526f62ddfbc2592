"""Tests of the versioned JSON run log (fcgen.sim.runlog)."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from fcgen.sim.runlog import (
    CONTROL_FIELDS,
    FORMAT_VERSION,
    QP_STATUS_NAMES,
    STATE_FIELDS,
    RunLog,
    compare,
    make_meta,
    qp_status_name,
    summary,
)

CAR = {"l_f": 1.7, "l_r": 1.7, "l_r_ch": 2.0, "l_f_ch": 2.0, "w_ch": 1.9}
TRUCK = {"l_f": 10.0, "l_r": 10.0, "l_r_ch": 13.0, "l_f_ch": 13.0, "w_ch": 4.0, "m": 3000.0}


def make_fields(k: int = 20, n_opp: int = 2, seed: int = 0) -> dict:
    """Keyword arguments of a random but well-formed RunLog with k controls and n_opp opponents."""
    rng = np.random.default_rng(seed)
    s_road = np.arange(0.0, 200.0 + 1e-9, 2.0)
    fields = dict(
        meta=make_meta(
            problem="truck_lifted_el",
            formulation="lifted",
            obstacle_model="EL",
            scenario="truck",
            seed=seed,
            N=40,
            dt=0.1,
            controller="python-reference",
            n_bound=10.0,
            extra={"note": "unit test", "rho": 1.0},
        ),
        road={
            "s": s_road,
            "kappa": 0.01 * np.sin(s_road / 30),
            "gamma_x": s_road,
            "gamma_y": 0 * s_road,
            "phi_gamma": rng.normal(size=s_road.size),
            "ds": 2.0,
        },
        opponents=[dict(TRUCK) for _ in range(n_opp)],
        ego=dict(CAR),
        t=0.1 * np.arange(k + 1),
        ego_frenet=rng.normal(size=(k + 1, 5)),
        ego_cartesian=rng.normal(size=(k + 1, 3)),
        opp_cartesian=rng.normal(size=(k + 1, n_opp, 3)),
        opp_frenet=rng.normal(size=(k + 1, n_opp, 3)),
        collision=rng.random(k + 1) < 0.2,
        a_lat=rng.normal(size=k + 1),
        control=rng.normal(size=(k, 2)) * [1e4, 0.39],
        time_prepare=rng.random(k) * 1e-3,
        time_feedback=rng.random(k) * 1e-3,
        time_total=rng.random(k) * 2e-3,
        qp_iter=rng.integers(1, 200, size=k),
        qp_status=rng.choice([1, 2, 3], size=k),
        max_slack=rng.random(k) * 1e-3,
    )
    return fields


def bits_equal(a: np.ndarray, b: np.ndarray) -> bool:
    a, b = np.asarray(a), np.asarray(b)
    if a.dtype != b.dtype or a.shape != b.shape:
        return False
    return a.tobytes() == b.tobytes()


def test_round_trip_is_bit_exact(tmp_path):
    f = make_fields()
    # awkward floats: shortest-repr round trip, subnormal, signed zero, non-finite values
    ef = f["ego_frenet"].copy()
    ef[0, :] = [0.1, 1 / 3, 5e-324, -0.0, 1.7976931348623157e308]
    ef[1, :] = [np.nan, np.inf, -np.inf, 1e-300, -2.5e-17]
    f["ego_frenet"] = ef
    f["road"]["kappa"][3] = np.nan
    log = RunLog(**f)
    path = log.to_json(tmp_path / "run.json")
    back = RunLog.from_json(path)
    for name in list(STATE_FIELDS) + list(CONTROL_FIELDS):
        assert bits_equal(getattr(log, name), getattr(back, name)), name
    for key in ("s", "kappa", "gamma_x", "gamma_y", "phi_gamma"):
        assert bits_equal(log.road[key], back.road[key]), key
    assert back.road["ds"] == 2.0
    assert back.meta == log.meta and back.opponents == log.opponents and back.ego == log.ego
    assert back.opponents[0]["m"] == 3000.0  # extra keys preserved
    assert all(v == 0.0 for v in compare(log, back).values())
    # second generation is byte-identical
    assert back.to_json_string() == path.read_text(encoding="utf-8")


def test_json_is_deterministic_and_strict():
    f = make_fields()
    text = RunLog(**f).to_json_string()
    # same content, meta built in another insertion order -> identical bytes
    f2 = make_fields()
    f2["meta"] = dict(reversed(list(f2["meta"].items())))
    assert RunLog(**f2).to_json_string() == text
    data = json.loads(text, parse_constant=lambda c: pytest.fail(f"bare {c} in JSON"))
    assert data["format"] == FORMAT_VERSION
    assert list(data) == sorted(data)
    assert list(data["samples"]) == sorted(data["samples"])
    assert text.endswith("}\n") and "\r" not in text
    # one row per line for 2-D sample arrays
    assert len(data["samples"]["ego_frenet"]) == 21


def test_nonfinite_written_as_strings():
    f = make_fields(k=2)
    f["max_slack"] = np.array([np.nan, np.inf])
    text = RunLog(**f).to_json_string()
    data = json.loads(text)
    assert data["samples"]["max_slack"] == ["NaN", "Infinity"]
    back = RunLog.from_json_string(text)
    assert math.isnan(back.max_slack[0]) and back.max_slack[1] == math.inf


def test_version_is_checked():
    data = RunLog(**make_fields()).to_dict()
    data["format"] = "fcgen-runlog/2"
    with pytest.raises(ValueError, match="format"):
        RunLog.from_dict(data)
    del data["format"]
    with pytest.raises(ValueError, match="format"):
        RunLog.from_dict(data)


@pytest.mark.parametrize("name", list(STATE_FIELDS) + list(CONTROL_FIELDS))
def test_shape_errors_name_the_field(name):
    data = json.loads(RunLog(**make_fields(k=5)).to_json_string())
    data["samples"][name] = data["samples"][name][:-1] if name != "t" else [[0.0]]
    with pytest.raises(ValueError, match=name if name != "t" else "'t'"):
        RunLog.from_json_string(json.dumps(data))


def test_missing_and_unknown_fields():
    base = RunLog(**make_fields(k=3)).to_dict()
    data = json.loads(json.dumps(base))
    del data["samples"]["qp_iter"]
    with pytest.raises(ValueError, match="qp_iter"):
        RunLog.from_dict(data)
    data = json.loads(json.dumps(base))
    data["samples"]["bogus"] = [1]
    with pytest.raises(ValueError, match="bogus"):
        RunLog.from_dict(data)
    data = json.loads(json.dumps(base))
    del data["meta"]["scenario"]
    with pytest.raises(ValueError, match="scenario"):
        RunLog.from_dict(data)
    data = json.loads(json.dumps(base))
    data["meta"]["controller"] = "matlab"
    with pytest.raises(ValueError, match="controller"):
        RunLog.from_dict(data)
    data = json.loads(json.dumps(base))
    del data["opponents"][1]["w_ch"]
    with pytest.raises(ValueError, match=r"opponents\[1\]"):
        RunLog.from_dict(data)
    data = json.loads(json.dumps(base))
    data["road"]["gamma_y"] = data["road"]["gamma_y"][:-1]
    with pytest.raises(ValueError, match=r"road.gamma_y"):
        RunLog.from_dict(data)
    data = json.loads(json.dumps(base))
    data["samples"]["qp_iter"][0] = 1.5
    with pytest.raises(ValueError, match="qp_iter"):
        RunLog.from_dict(data)


def test_constructor_validates_and_freezes():
    f = make_fields(k=4)
    f["control"] = np.zeros((5, 2))  # one row too many: controls are K, states K + 1
    with pytest.raises(ValueError, match="control"):
        RunLog(**f)
    log = RunLog(**make_fields(k=4))
    with pytest.raises(ValueError):
        log.ego_frenet[0, 0] = 1.0  # read-only
    with pytest.raises(AttributeError):
        log.t = np.zeros(5)  # frozen dataclass
    assert log.n_states == 5 and log.n_controls == 4
    assert log.qp_iter.dtype == np.int64 and log.collision.dtype == np.bool_


def test_empty_edge_cases_round_trip():
    f = make_fields(k=0, n_opp=0)
    f["ego"] = None
    log = RunLog(**f)
    assert log.opp_cartesian.shape == (1, 0, 3) and log.control.shape == (0, 2)
    back = RunLog.from_json_string(log.to_json_string())
    assert back.opp_frenet.shape == (1, 0, 3) and back.control.shape == (0, 2) and back.ego is None
    s = summary(back)
    assert s["n_controls"] == 0 and math.isnan(s["time_total_ms"]["mean"]) and s["qp_status_counts"] == {}


def test_qp_status_codes_are_the_generic_ones():
    from fcgen.backends import QP_MAX_ITER, QP_SOLVED, QP_STATUSES

    assert {i + 1: n[3:].lower() for i, n in enumerate(QP_STATUSES)} == QP_STATUS_NAMES
    assert qp_status_name(QP_SOLVED) == "solved" and qp_status_name(QP_MAX_ITER) == "max_iter"
    assert qp_status_name(7) == "nonfinite" and qp_status_name(0) == "unknown_0"
    assert qp_status_name(-2) == "unknown_-2"


def test_summary_hand_values():
    f = make_fields(k=4, n_opp=1)
    f["ego_frenet"][:, 0] = [5.0, 6.0, 7.5, 9.0, 12.0]
    f["collision"] = np.array([False, True, True, False, False])
    f["time_total"] = np.array([1e-3, 2e-3, 3e-3, 10e-3])
    f["qp_iter"] = np.array([10, 20, 30, 41])
    f["qp_status"] = np.array([1, 1, 3, 2])
    f["max_slack"] = np.array([0.0, 0.5, 0.25, 0.0])
    f["a_lat"] = np.array([0.0, -4.5, 3.0, 1.0, 0.0])
    s = summary(RunLog(**f))
    assert s["progress"] == 7.0 and s["s_final"] == 12.0
    assert s["n_collision_samples"] == 2
    assert s["time_total_ms"]["mean"] == pytest.approx(4.0)
    assert s["time_total_ms"]["median"] == pytest.approx(2.5)
    assert s["time_total_ms"]["max"] == pytest.approx(10.0)
    assert s["time_total_ms"]["p99"] == pytest.approx(np.percentile([1, 2, 3, 10], 99))
    assert s["qp_iter_mean"] == pytest.approx(25.25) and s["qp_iter_max"] == 41
    assert s["qp_status_counts"] == {"solved": 2, "max_iter": 1, "solved_inaccurate": 1}
    assert s["max_slack"] == 0.5 and s["max_abs_a_lat"] == 4.5
    json.dumps(s)  # plain data


def test_summary_timing_stats_are_numpys_per_array():
    """summary's timing statistics (computed on the three timing arrays at once) are numpy's mean, median, percentile
    and max of each array, bit for bit; and the status counts those of every sample."""
    for seed in range(40):
        f = make_fields(k=1 + 17 * seed, n_opp=1, seed=seed)
        rng = np.random.default_rng(seed)
        for key in ("time_total", "time_prepare", "time_feedback"):
            f[key] = np.abs(rng.standard_cauchy(f[key].size)) * 1e-3
        if seed % 5 == 0:
            f["time_prepare"][-1] = math.nan
        f["qp_status"] = rng.choice([0, 1, 2, 3, 99], size=f["qp_status"].size)
        log = RunLog(**f)
        s = summary(log)
        for key in ("time_total", "time_prepare", "time_feedback"):
            ms = 1e3 * getattr(log, key)
            want = [float(np.mean(ms)), float(np.median(ms)), float(np.percentile(ms, 99)), float(np.max(ms))]
            got = [s[f"{key}_ms"][q] for q in ("mean", "median", "p99", "max")]
            assert np.array(got).tobytes() == np.array(want).tobytes(), (seed, key)
        names = [qp_status_name(c) for c in log.qp_status.tolist()]
        assert s["qp_status_counts"] == {n: names.count(n) for n in sorted(set(names))}
        assert all(type(v) is int for v in s["qp_status_counts"].values())


def test_compare():
    a = RunLog(**make_fields(k=6))
    f = make_fields(k=6)
    f["ego_frenet"][3, 1] += 1e-9
    f["qp_iter"][2] += 3
    f["collision"][0] = not f["collision"][0]
    f["time_total"][:] = np.nan
    b = RunLog(**f)
    d = compare(a, b)
    assert set(d) == set(STATE_FIELDS) | set(CONTROL_FIELDS)
    assert d["ego_frenet"] == pytest.approx(1e-9, rel=1e-6)
    assert d["qp_iter"] == 3.0 and d["collision"] == 1.0 and d["time_total"] == math.inf
    assert d["ego_cartesian"] == 0.0 and d["control"] == 0.0
    assert compare(b, b)["time_total"] == 0.0  # NaN at the same place counts as equal
    with pytest.raises(ValueError, match="t"):
        compare(a, RunLog(**make_fields(k=5)))


# ----------------------------------------------------------------------------- optional fields, compression


def _with_plan(k: int = 6, nx: int = 8, seed: int = 1) -> dict:
    rng = np.random.default_rng(seed)
    f = make_fields(k=k)
    f["exit_code"] = np.array([0, 0, 8, 0, 0, 0][:k])
    f["plan_states"] = rng.normal(size=(k, 41, nx))
    f["plan_controls"] = rng.normal(size=(k, 40, 2))
    f["plan_controls"][2] = np.nan  # a failed call: no plan
    return f


@pytest.mark.parametrize("suffix", [".json", ".json.xz", ".json.gz"])
def test_optional_fields_round_trip_bit_exact(tmp_path, suffix):
    log = RunLog(**_with_plan())
    assert log.optional_fields() == ("exit_code", "plan_states", "plan_controls")
    path = log.to_json(tmp_path / f"run{suffix}")
    magic = path.read_bytes()[:6]
    assert magic.startswith({".json": b"{", ".json.xz": b"\xfd7zXZ", ".json.gz": b"\x1f\x8b"}[suffix])
    back = RunLog.from_json(path)
    for name in ("exit_code", "plan_states", "plan_controls", "control"):
        assert bits_equal(getattr(back, name), getattr(log, name)), name
    assert back.to_json_string() == log.to_json_string()
    if suffix != ".json":  # compressed bytes are deterministic too (no time stamp in the gzip header)
        assert log.to_json(tmp_path / f"again{suffix}").read_bytes() == path.read_bytes()


def test_optional_fields_absent_and_compared_only_when_both_have_them():
    plain = RunLog(**make_fields(k=6))
    assert plain.optional_fields() == () and "exit_code" not in plain.to_dict()["samples"]
    full = RunLog(**_with_plan())
    d = compare(full, plain)
    assert set(d) == set(STATE_FIELDS) | set(CONTROL_FIELDS)
    other = _with_plan(seed=2)
    other["plan_controls"][2] = np.nan
    d2 = compare(full, RunLog(**other))
    assert d2["plan_states"] > 0 and d2["exit_code"] == 0 and math.isfinite(d2["plan_controls"])


@pytest.mark.parametrize(
    "name, shape, msg",
    [
        ("plan_states", (6, 40, 8), "plan_states"),  # N + 1 = 41 rows expected
        ("plan_controls", (5, 40, 2), "plan_controls"),  # K = 6 rows expected
        ("exit_code", (6, 1), "exit_code"),
    ],
)
def test_optional_field_shapes_are_validated(name, shape, msg):
    f = _with_plan()
    f[name] = np.zeros(shape)
    with pytest.raises(ValueError, match=msg):
        RunLog(**f)


def test_unknown_samples_field_still_rejected():
    d = RunLog(**_with_plan()).to_dict()
    d["samples"]["plan_duals"] = [[0.0]] * 6
    with pytest.raises(ValueError, match="unknown field"):
        RunLog.from_dict(d)
