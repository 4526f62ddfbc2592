"""fcgen record / regress: tolerance arithmetic, replay pinning, caught changes, other flags, unusable input."""

from __future__ import annotations

import json
import math
import shutil
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

from fcgen.cli import main
from fcgen.regress import PRESETS, Tol, UnusableInput, compare_field, compare_logs, parse_tol, regress
from fcgen.sim.runlog import RunLog
from fcgen.suite import MANIFEST, SuiteSettings, load_suite, parse_seeds, record_suite, text_sha256

ROOT = Path(__file__).resolve().parents[1]
SOLVER = ROOT / "generated" / "truck_lifted_ellipse"
GOLDEN = SOLVER / "golden"


def _cli(*args: str):
    return CliRunner().invoke(main, [str(a) for a in args])


@pytest.fixture(scope="module")
def golden_logs() -> tuple[dict, list[RunLog]]:
    return load_suite(GOLDEN)


def _copy_suite(dst: Path, change=None) -> Path:
    """A copy of the checked-in golden suite; ``change(log) -> log`` applied to its first log (manifest re-hashed)."""
    shutil.copytree(GOLDEN, dst)
    if change is not None:
        man = json.loads((dst / MANIFEST).read_text())
        e = man["logs"][0]
        log = change(RunLog.from_json(dst / e["file"]))
        log.to_json(dst / e["file"])
        e["sha256"] = text_sha256(log)
        (dst / MANIFEST).write_text(json.dumps(man, indent=1, sort_keys=True) + "\n")
    return dst


# ----------------------------------------------------------------------------- tolerance arithmetic


def test_compare_field_hand_values() -> None:
    gold = np.array([[1.0, 100.0], [2.0, -200.0], [3.0, 50.0]])
    # scale per component: 3 and 200 -> allowed = 0.1 + 0.01 * scale = 0.13 and 2.1
    new = gold + np.array([[0.13, 2.0], [0.0, 2.1], [0.1300001, 0.0]])
    r = compare_field("control", new, gold, Tol(0.1, 0.01))
    assert r.bad_rows == 1 and r.rows == 3
    assert r.first["sample"] == 2 and r.first["index"] == [0]
    assert r.first["golden"] == 3.0 and r.first["new"] == pytest.approx(3.1300001, abs=1e-12)
    assert r.first["allowed"] == pytest.approx(0.13, abs=1e-15)
    assert r.max_abs == pytest.approx(2.1, abs=1e-12) and r.max_at == (1, (1,))
    assert r.ratio[1] == pytest.approx(1.0, rel=1e-12)
    assert r.rel[1] == pytest.approx(2.1 / 200, rel=1e-12) and list(r.bad) == [False, False, True]
    assert r.tol_rel == pytest.approx(0.01 + 0.1 / 200, rel=1e-12)


def test_compare_field_nan_and_ints() -> None:
    gold = np.array([1.0, math.nan, 3.0])
    assert compare_field("max_slack", np.array([1.0, math.nan, 3.0]), gold, Tol(0, 0)).passed
    r = compare_field("max_slack", np.array([1.0, 2.0, 3.0]), gold, Tol(1e9, 1e9))
    assert r.bad_rows == 1 and r.first["sample"] == 1 and r.first["golden"] == "nan"
    r = compare_field("qp_iter", np.array([40, 41, 40]), np.array([40, 40, 42]), Tol(1, 0))
    assert r.bad_rows == 1 and r.first["sample"] == 2 and r.max_abs == 2.0


def test_parse_tol_and_seeds() -> None:
    assert parse_tol("control=1e-3,0.5") == ("control", Tol(1e-3, 0.5))
    for bad in ("control", "nofield=1,1", "control=1", "control=-1,0"):
        with pytest.raises(UnusableInput):
            parse_tol(bad)
    assert parse_seeds("0-3,9,2") == (0, 1, 2, 3, 9)
    for bad in ("3-1", "a", "-1", ""):
        with pytest.raises(ValueError, match="--seeds"):
            parse_seeds(bad)
    assert set(PRESETS) == {"same-build", "other-flags", "other-compiler", "host-vs-target", "float-vs-double"}


def test_timing_ignored_unless_asked(golden_logs) -> None:
    _, logs = golden_logs
    g = logs[0]
    new = replace(g, time_total=g.time_total + 1.0, time_feedback=g.time_feedback + 1.0)
    tols = PRESETS["same-build"]
    assert compare_logs(new, g, tols).passed
    res = compare_logs(new, g, tols, timing=True)
    assert not res.passed and res.first_divergence().field == "time_feedback"


# ----------------------------------------------------------------------------- the checked-in golden, replayed


def test_python_reference_replays_the_c_golden_bit_for_bit() -> None:
    """Second method: the Python reference (same call sequence) reproduces the C verification build's golden."""
    rep = regress(SOLVER, GOLDEN / "truck_seed0.json.xz", controller="python", preset="same-build")
    assert rep.passed, rep.format()
    assert {f.field: f.max_abs for f in rep.logs[0].fields} == {
        "control": 0.0,
        "qp_iter": 0.0,
        "qp_status": 0.0,
        "max_slack": 0.0,
        "exit_code": 0.0,
        "plan_controls": 0.0,
    }


def test_replay_pins_the_first_changed_sample(tmp_path) -> None:
    """A golden whose output is altered at sample 57 only: replay names sample 57, the field and both values."""

    def change(log: RunLog) -> RunLog:
        u = np.array(log.control)
        u[57, 1] += 1e-6
        return replace(log, control=u)

    suite = _copy_suite(tmp_path / "golden", change)
    res = _cli(
        "regress",
        SOLVER,
        suite,
        "--preset",
        "same-build",
        "--verify",
        "--controller",
        "python",
        "--json",
        tmp_path / "r.json",
    )
    assert res.exit_code == 1, res.output + res.stderr
    gold = float(RunLog.from_json(suite / "truck_seed0.json.xz").control[57, 1])
    orig = float(RunLog.from_json(GOLDEN / "truck_seed0.json.xz").control[57, 1])
    assert f"first divergence: truck seed 0, sample 57, field control[1]: new {orig!r}, golden {gold!r}" in res.output
    rep = json.loads((tmp_path / "r.json").read_text())
    assert rep["exit_code"] == 1 and rep["first_divergence"]["sample"] == 57
    assert rep["first_divergence"]["field"] == "control" and rep["first_divergence"]["index"] == [1]
    assert rep["first_divergence"]["golden"] == gold
    assert rep["logs_out_of_tolerance"] == 1 and rep["logs_compared"] == 2
    ctrl = next(f for f in rep["logs"][0]["fields"] if f["field"] == "control")
    assert ctrl["samples_out_of_tolerance"] == 1


@pytest.fixture(scope="module")
def weight_copy(tmp_path_factory) -> Path:
    """The lifted truck preset with one weight changed (q_n x 1.1), generated under the same solver name."""
    from fcgen.codegen.generate import generate
    from fcgen.presets import load_problem

    pb = load_problem(str(SOLVER / "problem.py"))
    w = pb.weights
    pb2 = replace(pb, weights=replace(w, q=(w.q[0], 1.1 * w.q[1], *tuple(w.q[2:]))))
    out = tmp_path_factory.mktemp("weight") / "truck_lifted_ellipse"
    generate(pb2, out)
    return out


def test_regress_catches_a_changed_weight(weight_copy, tmp_path, golden_logs) -> None:
    res = _cli("regress", weight_copy, GOLDEN, "--verify", "--json", tmp_path / "r.json", "--plot", tmp_path / "r.png")
    assert res.exit_code == 1, res.output + res.stderr
    assert "FAIL: 2 of 2 log(s) out of tolerance" in res.output
    rep = json.loads((tmp_path / "r.json").read_text())
    fd = rep["first_divergence"]
    # the weight is in the cost of every sample's QP: the very first solve already moves u0
    assert fd["sample"] == 0 and fd["field"] == "control"
    assert fd["golden"] == golden_logs[1][0].control[0][fd["index"][0]]
    assert f"sample 0, field control[{fd['index'][0]}]" in res.output
    assert "problem.py differs" in res.output
    assert (tmp_path / "r.png").stat().st_size > 10000


REASSOC = "-O2 -fassociative-math -fno-signed-zeros -fno-trapping-math"


@pytest.mark.parametrize("cflags, verify", [("-O1", "--verify"), (REASSOC, "--no-verify")])
def test_regress_passes_a_rebuild_with_other_flags(tmp_path, cflags, verify) -> None:
    """A rebuild with other flags than the golden's (-O2, verification build) passes with the other-flags preset.

    -O1 reproduces the golden bit for bit; reassociation (+ FP contraction allowed) moves the outputs by ~1e-10
    relative, so ``same-build`` fails where ``other-flags`` passes.
    """
    new = tmp_path / "truck_lifted_ellipse"
    shutil.copytree(SOLVER, new, ignore=shutil.ignore_patterns("build", "golden"))
    res = _cli(
        "regress", new, GOLDEN, verify, f"--cflags={cflags}", "--preset", "other-flags", "--json", tmp_path / "r.json"
    )
    assert res.exit_code == 0, res.output + res.stderr
    assert "PASS: 2 log(s) within tolerance" in res.output and "NEW built with: cc" in res.output
    build = "verify" if verify == "--verify" else ""
    assert cflags in (new / "build" / build / "flags.txt").read_text()
    rep = json.loads((tmp_path / "r.json").read_text())
    ctrl = max(f["max_abs_diff"] for lg in rep["logs"] for f in lg["fields"] if f["field"] == "control")
    if cflags == "-O1":
        assert ctrl == 0.0
    else:
        assert 0 < ctrl < 1e-8 * 1e4  # F_d is up to 1e4 N
        res = _cli("regress", new, GOLDEN, verify, f"--cflags={cflags}", "--preset", "same-build")
        assert res.exit_code == 1 and "first divergence" in res.output


# ----------------------------------------------------------------------------- record


def test_record_suite_and_closed_loop_regress(tmp_path) -> None:
    solver = tmp_path / "truck_lifted_ellipse"  # a copy: other tests build generated/ in place, maybe concurrently
    shutil.copytree(SOLVER, solver, ignore=shutil.ignore_patterns("build", "golden"))
    st = SuiteSettings(seeds=(4,), samples=30, plan="full", verify=True)
    man = record_suite(solver, tmp_path / "s", st)
    assert man["settings"]["seeds"] == [4] and man["precision"] == "double" and man["build"]["verify"] is True
    assert "-ffp-contract=off" in man["build"]["compile_line"] and man["qp_backend"] == "osqp"
    _, (log,) = load_suite(tmp_path / "s")
    assert log.plan_states.shape == (30, 41, 8) and log.plan_controls.shape == (30, 40, 2)
    box = np.array([1e4, 0.39])  # Bounds(): F_d_max, r_max
    # the applied control is the plan's first control projected on the input box (the safety contract)
    assert np.array_equal(np.clip(log.plan_controls[:, 0, :], -box, box), log.control)
    assert np.all(log.time_total > 0) and np.array_equal(log.exit_code, np.zeros(30))
    res = _cli("regress", solver, tmp_path / "s", "--mode", "closed-loop", "--verify", "--preset", "same-build")
    assert res.exit_code == 0, res.output + res.stderr
    assert "ego_frenet" in res.output and "plan_states" in res.output


# ----------------------------------------------------------------------------- unusable input: exit 2, one line


def _one_line_exit2(res, *needles: str) -> None:
    assert res.exit_code == 2, res.output + res.stderr
    err = res.stderr.strip()
    assert len(err.splitlines()) == 1 and "Traceback" not in err, err
    for n in needles:
        assert n in err, err


def test_unusable_inputs(tmp_path, golden_logs) -> None:
    g = golden_logs[1][0]
    ok = g.to_json(tmp_path / "ok.json")
    (tmp_path / "text.json").write_text("hello, not JSON\n")
    _one_line_exit2(_cli("regress", tmp_path / "text.json", ok), "text.json: not a run log")
    (tmp_path / "obj.json").write_text('{"a": 1}\n')
    _one_line_exit2(_cli("regress", tmp_path / "obj.json", ok), "obj.json: not a run log")
    d = json.loads(ok.read_text())
    d["format"] = "fcgen-runlog/2"
    (tmp_path / "v2.json").write_text(json.dumps(d))
    _one_line_exit2(_cli("regress", ok, tmp_path / "v2.json"), "format 'fcgen-runlog/2'", "fcgen-runlog/1")
    other = replace(g, meta={**g.meta, "problem": "car_lift_el"}).to_json(tmp_path / "other.json")
    _one_line_exit2(_cli("regress", other, ok), "another problem", "car_lift_el")
    K = 150
    short = replace(
        g,
        **{
            n: getattr(g, n)[: K + 1]
            for n in ("t", "ego_frenet", "ego_cartesian", "opp_cartesian", "opp_frenet", "collision", "a_lat")
        },
        **{
            n: getattr(g, n)[:K]
            for n in (
                "control",
                "time_prepare",
                "time_feedback",
                "time_total",
                "qp_iter",
                "qp_status",
                "max_slack",
                "exit_code",
                "plan_controls",
            )
        },
    )
    short.to_json(tmp_path / "short.json")
    _one_line_exit2(_cli("regress", tmp_path / "short.json", ok), "another length", "150", "200")
    _one_line_exit2(_cli("regress", ok, tmp_path / "missing.json"), "missing.json")
    seed9 = replace(g, meta={**g.meta, "seed": 9}).to_json(tmp_path / "seed9.json")
    _one_line_exit2(_cli("regress", seed9, GOLDEN), "no log of truck seed 9")
    _one_line_exit2(_cli("regress", seed9, ok), "another scenario", "seed")
    assert _cli("regress", ok, GOLDEN, "--preset", "same-build").exit_code == 0  # vs the suite's seed-0 log
    _one_line_exit2(_cli("regress", ok, ok, "--tol", "bogus=1,2"), "--tol")
    # a suite whose log was edited without re-hashing, and a suite of another solver
    bad = tmp_path / "bad"
    shutil.copytree(GOLDEN, bad)
    replace(g, control=np.array(g.control) * 2).to_json(bad / "truck_seed0.json.xz")
    _one_line_exit2(_cli("regress", SOLVER, bad), "checksum")
    other_solver = ROOT / "generated" / "truck_conventional_ellipse"
    _one_line_exit2(_cli("regress", other_solver, GOLDEN), "another problem")
    # and an identical log passes with exit 0
    assert _cli("regress", ok, ok, "--preset", "same-build").exit_code == 0


def test_record_cli_argument_errors(tmp_path) -> None:
    res = _cli("record", SOLVER, "--seeds", "5-2")
    assert res.exit_code == 1 and "--seeds '5-2' is invalid" in res.output and "Traceback" not in res.output
    res = _cli("record", SOLVER, "--golden-for", "generated")
    assert res.exit_code == 1 and "give no SOLVER_DIR" in res.output
    res = _cli("record")
    assert res.exit_code == 1 and "--golden-for ROOT" in res.output
    res = _cli("record", "--golden-for", tmp_path)
    assert res.exit_code == 1 and "no generated solver folders" in res.output
