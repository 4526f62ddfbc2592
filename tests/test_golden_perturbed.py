"""A golden suite of a perturbed closed loop (`fcgen record --golden-for ROOT` with plant options, docs/plants.md):
the perturbations are stored in the manifest and in each log's metadata, `fcgen regress` runs them again (closed
loop, by default) and reproduces the suite, a changed perturbation is noticed, and a plain re-record keeps them."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

from fcgen.cli import main
from fcgen.regress import regress
from fcgen.sim.plants import DEFAULT_NOISE, PlantSpec, plant_of
from fcgen.suite import GOLDEN_DIR, GOLDEN_SETTINGS, MANIFEST, load_suite, suite_plant

SOLVER = Path(__file__).resolve().parents[1] / "generated" / "truck_lifted_ellipse"
SPEC = PlantSpec(latency=1, steer_lag=0.1, noise=DEFAULT_NOISE)
PERTURB = ["--latency", "1", "--steer-lag", "0.1", "--noise", "default"]


def _cli(*args):
    return CliRunner().invoke(main, [str(a) for a in args])


@pytest.fixture(scope="module")
def root(tmp_path_factory) -> Path:
    """A root with one solver folder (a copy of a checked-in one) and its golden suite recorded perturbed."""
    r = tmp_path_factory.mktemp("goldens")
    shutil.copytree(SOLVER, r / SOLVER.name, ignore=shutil.ignore_patterns("build", GOLDEN_DIR))
    res = _cli("record", "--golden-for", r, *PERTURB)
    assert res.exit_code == 0, res.output
    return r


def test_golden_for_records_the_perturbations(root):
    man, logs = load_suite(root / SOLVER.name / GOLDEN_DIR)
    assert man["settings"]["plant"] == SPEC.as_meta()
    assert man["settings"]["seeds"] == list(GOLDEN_SETTINGS.seeds) and man["build"]["verify"] is True
    assert [plant_of(lg) for lg in logs] == [SPEC, SPEC]
    for lg in logs:  # the plant got the controls one sample late, zeros first (the lag keeps a zero rate zero)
        assert np.array_equal(lg.control_applied[0], [0.0, 0.0])
        np.testing.assert_array_equal(np.asarray(lg.control_applied)[1:, 0], np.asarray(lg.control)[:-1, 0])


def test_regress_reproduces_a_perturbed_golden(root):
    """By default a perturbed golden log runs in closed loop again with its recorded perturbations: the same run."""
    folder = root / SOLVER.name
    rep = regress(folder, folder / GOLDEN_DIR, preset="same-build")
    assert rep.passed, rep.format()
    assert rep.mode == "closed-loop" and any("run in closed loop again" in n for n in rep.notes)
    worst = max(f.max_abs for lg in rep.logs for f in lg.fields if f.field in ("ego_frenet", "control"))
    assert worst == 0.0  # same build, same seeded draws: bit for bit
    res = _cli("regress", folder, folder / GOLDEN_DIR, "--preset", "same-build")
    assert res.exit_code == 0, res.output


def test_regress_notices_a_changed_perturbation(root):
    """Another noise, or no latency: out of tolerance (exit 1), and the report says which plant each side had."""
    folder = root / SOLVER.name
    for opts, label in (
        (
            ["--latency", "1", "--steer-lag", "0.1", "--noise", "0.1,0.1,0.01,0.1,0.004"],
            "model+lat1+lag0.1+noise0.1:0.1:0.01:0.1:0.004",
        ),
        (["--latency", "0", "--steer-lag", "0.1", "--noise", "default"], "model+lag0.1+noise"),
    ):
        args = ["regress", folder, folder / GOLDEN_DIR, "--mode", "closed-loop", "--preset", "same-build"]
        res = _cli(*args, *opts)
        assert res.exit_code == 1, res.output
        assert f"run with the plant {label}, the golden log was recorded with model+lat1+lag0.1+noise" in res.output


def test_plain_re_record_keeps_the_perturbations(root, tmp_path):
    """`--golden-for ROOT --force` without plant options keeps each suite's own; with them it records those."""
    r = tmp_path / "r"
    shutil.copytree(root, r)
    gold = r / SOLVER.name / GOLDEN_DIR
    before = json.loads((gold / MANIFEST).read_text())["logs"]
    assert _cli("record", "--golden-for", r, "--force").exit_code == 0
    assert suite_plant(gold) == SPEC
    assert [e["sha256"] for e in json.loads((gold / MANIFEST).read_text())["logs"]] == [e["sha256"] for e in before]
    assert _cli("record", "--golden-for", r, "--force", "--latency", "0").exit_code == 0
    assert suite_plant(gold) == PlantSpec() and "plant" not in json.loads((gold / MANIFEST).read_text())["settings"]
