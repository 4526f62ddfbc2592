"""``fcgen wcet``: the probe's events on a real build, the bound's arithmetic, the example's bound computed and
validated under QEMU, and a bound too low that the validation refuses."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

from fcgen.cli import main
from fcgen.wcet import (
    BoundError,
    Caps,
    ProbeError,
    compute_bound,
    exceedances,
    ipm_feedback,
    osqp_feedback,
    phase_stats,
    read_probe,
)
from fcgen.wcet.probe import SampleProbe
from fcgen.wcet.run import RESET_EVERY, validate

ROOT = Path(__file__).resolve().parent.parent
EXAMPLE = ROOT / "generated" / "truck_lifted_ellipse_ipm"
TOOLS = ("arm-none-eabi-gcc", "qemu-system-arm", "make")
needs_toolchain = pytest.mark.skipif(
    any(shutil.which(t) is None for t in TOOLS), reason="needs the arm-none-eabi toolchain and QEMU (setup.sh)"
)
SAMPLES = 12  # a reset before sample 10 (RESET_EVERY): two cold starts a run


# ----------------------------------------------------------------------------- arithmetic (made-up numbers)


def _sample(
    j: int, prepare: int, head: int, checks: list[int], steps: list[int], qp_tail: int, tail: int, scan: list[int] = ()
) -> SampleProbe:
    feedback = head + sum(checks) + sum(steps) + qp_tail + tail
    ph = {"head": [head], "check": checks, "step": steps, "qp_tail": [qp_tail], "feedback_tail": [tail]}
    if scan:
        ph["fit_scan_step"] = list(scan)
    return SampleProbe(j, False, prepare, feedback, prepare - sum(scan), ph)


def test_ipm_bound_is_the_caps_times_the_phase_maxima():
    m = {"head": 100, "check": 10, "step": 50, "qp_tail": 5, "feedback_tail": 7}
    assert ipm_feedback(m, 3, tick=0) == 100 + 4 * 10 + 3 * 50 + 5 + 7
    assert ipm_feedback(m, 3, tick=2) == 102 + 4 * 12 + 3 * 52 + 7 + 9  # a tick per phase instance
    samples = [_sample(0, 300, 90, [10, 9], [50], 5, 7), _sample(1, 280, 100, [8, 9, 10], [40, 45], 4, 6)]
    caps = Caps(rti_budget=3, warm=2, cold=3, qp_iterations=3)
    b = compute_bound(samples, [1, 2], caps, "ipm", tick=0)
    assert b == {"prepare": 300, "feedback": 100 + 4 * 10 + 3 * 50 + 5 + 7, "rti": 300 + 302, "per_iteration": 60}
    st = phase_stats(samples)
    assert (st["check"].min, st["check"].max, st["check"].count) == (8, 10, 5)
    assert "prepare_rest" not in st  # no fit: prepare is prepare
    with pytest.raises(BoundError, match="step"):
        compute_bound([_sample(0, 300, 90, [10], [], 5, 7)], [0], caps, "ipm", tick=0)


def test_osqp_bound_spreads_fixed_cost_and_checks_over_the_iterations():
    """Per iteration: the largest (QP + tick) / iterations; charged for the budget rounded up to check_termination."""
    samples = [
        SampleProbe(0, False, 50, 1000, 50, {"head": [20], "qp": [900], "feedback_tail": [30]}),
        SampleProbe(1, False, 60, 560, 60, {"head": [25], "qp": [500], "feedback_tail": [35]}),
    ]
    caps = Caps(rti_budget=50, warm=40, cold=50, qp_iterations=80, check_termination=40)
    b = compute_bound(samples, [60, 40], caps, "osqp", tick=0)
    assert b["per_iteration"] == 15  # max(900 / 60, 500 / 40 = 12.5)
    assert b["feedback"] == osqp_feedback({"head": 25, "feedback_tail": 35}, 15, 80, 0) == 25 + 80 * 15 + 35
    assert b["prepare"] == 60


def test_fit_scans_are_charged_at_their_cap():
    s = _sample(0, 1000, 1, [1], [1], 1, 1, scan=[3, 4, 5])  # prepare_rest 988
    caps = Caps(rti_budget=1, warm=1, cold=1, qp_iterations=1, fit_scans=6, fit_scan_cap=100)
    assert compute_bound([s], [1], caps, "ipm", tick=0)["prepare"] == 988 + 6 * 100 * 5
    assert compute_bound([s], [1], caps, "ipm", tick=1)["prepare"] == (988 + 4) + 6 * 100 * 6


def test_validation_flags_samples_above_the_bound():
    bound = {"prepare": 10, "feedback": 100, "rti": 110}
    obs = {"prepare": np.array([9, 10, 11]), "feedback": np.array([50, 100, 90]), "rti": np.array([59, 110, 101])}
    assert exceedances(obs, bound) == {"prepare": [2], "feedback": [], "rti": []}
    v = validate(obs, bound, 1, 3)
    assert v["passed"] is False and v["exceeding_samples"] == {"prepare": 1, "feedback": 0, "rti": 0}
    assert v["observed_max"] == {"prepare": 11, "feedback": 100, "rti": 110}
    assert validate(obs, {**bound, "prepare": 11}, 1, 3)["passed"] is True


def test_caps_are_consistent():
    with pytest.raises(ValueError, match="warm <= cold"):
        Caps(rti_budget=10, warm=20, cold=10, qp_iterations=10)


def test_probe_reader(tmp_path):
    p = tmp_path / "run.json.probe"
    # prepare 10..11, feedback 12: START, CHECK, STEP, CHECK, END, 13 (ticks of 40 instructions at 25 MHz)
    p.write_text("fcgen-probe/1 25000000 10\ns 0 0 9 10 100 11 110 12 111 0 113 1 120 2 140 1 147 3 148 13 150\n")
    (sp,) = read_probe(p)
    assert sp.prepare == 400 and sp.feedback == 1560
    assert sp.phases == {"head": [80], "check": [280, 280], "step": [800], "qp_tail": [40], "feedback_tail": [80]}
    p.write_text("fcgen-probe/1 25000000 10\ns 0 0 4 12 1 0 2 2 3 13 4\n")  # a step straight after the start
    with pytest.raises(ProbeError, match="event 2 after 0"):
        read_probe(p)
    p.write_text("fcgen-probe/1 25000000 10\ns 0 0 4 12 1 0 2\n")
    with pytest.raises(ProbeError, match="truncated"):
        read_probe(p)


# ----------------------------------------------------------------------------- the example under QEMU


@pytest.fixture(scope="module")
def example(tmp_path_factory) -> Path:
    """A copy of the example folder (its own build/: no race with other tests building the committed folder)."""
    d = tmp_path_factory.mktemp("wcet") / EXAMPLE.name
    shutil.copytree(EXAMPLE, d, ignore=shutil.ignore_patterns("build", "golden"))
    return d


@pytest.fixture(scope="module")
def computed(example, tmp_path_factory) -> dict:
    """``fcgen wcet`` of the example on the Cortex-M7: 1 probe seed, validated on 2 seeds, SAMPLES samples each."""
    out = tmp_path_factory.mktemp("wcet_out") / "wcet.json"
    res = CliRunner().invoke(
        main,
        [
            "wcet",
            str(example),
            "--target",
            "cortex-m7",
            "--seeds",
            "1",
            "--samples",
            str(SAMPLES),
            "--validate-seeds",
            "2",
            "--out",
            str(out),
        ],
    )
    assert res.exit_code == 0, res.output
    assert "bound Minstr" in res.output and "every sample within the bound" in res.output
    return json.loads(out.read_text())


@needs_toolchain
def test_probe_events_of_a_real_build(example, computed):
    """The probe build's side file: per sample one START and END, n + 1 checks and n steps for a QP of n iterations
    (the run log's), resets (cold starts) every RESET_EVERY samples."""
    run = example / "build" / "cortex-m7" / "wcet_probe" / "firmware_sim" / f"probe_truck_seed0_{SAMPLES}.json"
    log = json.loads(run.read_text())
    samples = read_probe(f"{run}.probe")
    assert [s.sample for s in samples] == list(range(SAMPLES))
    assert [s.reset for s in samples] == [j > 0 and j % RESET_EVERY == 0 for j in range(SAMPLES)]
    for s, n in zip(samples, log["samples"]["qp_iter"]):
        ph = s.phases
        assert len(ph["head"]) == len(ph["qp_tail"]) == len(ph["feedback_tail"]) == 1
        assert len(ph["check"]) == n + 1 and len(ph["step"]) == n
        assert s.feedback == sum(sum(v) for v in ph.values())  # the phases tile feedback
    cold = [log["samples"]["qp_iter"][j] for j in (0, RESET_EVERY)]
    assert min(cold) > np.median(log["samples"]["qp_iter"])  # cold starts: the longest QPs


@needs_toolchain
def test_example_bound_is_computed_and_validated(computed):
    b, caps, ph = computed["bound"], computed["caps"], computed["phases"]
    assert computed["target"] == "cortex-m7" and computed["cflags"].startswith("-O2 -mcpu=cortex-m7")
    assert caps["rti_budget"] == caps["cold"] == caps["qp_iterations"] and caps["warm"] <= caps["cold"]
    tick = computed["tick_instructions"]
    assert tick == 40
    m = {k: v["max"] for k, v in ph.items()}
    assert b["feedback"] == ipm_feedback(m, caps["qp_iterations"], tick)
    assert b["prepare"] == m["prepare"] + tick and b["rti"] == b["prepare"] + b["feedback"]
    assert computed["per_iteration"] == m["check"] + m["step"] + 2 * tick
    for k in ("check", "step", "head"):  # the phases vary little: their max is the worst path
        assert ph[k]["max"] <= 1.05 * ph[k]["min"]
    v = computed["validated"]
    assert v["seeds"] == [0, 1] and v["samples"] == SAMPLES and v["passed"] is True
    assert all(0 < v["observed_max"][k] <= b[k] for k in b)
    assert all(isinstance(x, int) for x in (*b.values(), computed["per_iteration"]))


@needs_toolchain
def test_a_bound_too_low_fails_the_validation(example, computed, tmp_path):
    res = CliRunner().invoke(
        main,
        [
            "wcet",
            str(example),
            "--target",
            "cortex-m7",
            "--seeds",
            "1",
            "--samples",
            str(SAMPLES),
            "--validate-seeds",
            "1",
            "--bound-scale",
            "0.01",
            "--out",
            str(tmp_path / "low.json"),
        ],
    )
    assert res.exit_code == 1, res.output
    assert "validation failed: samples above the bound" in res.output
    low = json.loads((tmp_path / "low.json").read_text())
    assert low["validated"]["passed"] is False and low["validated"]["exceeding_samples"]["rti"] == SAMPLES
