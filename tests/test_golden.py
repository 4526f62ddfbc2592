"""CI regression of the checked-in solvers: each one, replayed on its golden suite, reproduces the golden outputs.

A generator change that moves any output of a solver fails here with the sample and field named. After an intended
change, re-record all goldens with one command: ``fcgen record --golden-for generated --force`` (and commit them).
"""

import shutil
from pathlib import Path

import pytest

from fcgen.regress import regress
from fcgen.suite import GOLDEN_DIR, GOLDEN_SETTINGS, load_manifest

ROOT = Path(__file__).resolve().parents[1] / "generated"
FOLDERS = sorted(p.name for p in ROOT.iterdir() if p.is_dir())


def test_every_checked_in_solver_has_a_golden_suite():
    for f in FOLDERS:
        man = load_manifest(ROOT / f / GOLDEN_DIR)
        s = GOLDEN_SETTINGS
        assert man["settings"]["seeds"] == list(s.seeds) and man["settings"]["samples"] == s.samples, f
        assert man["settings"]["plan"] == s.plan and man["build"]["verify"] is s.verify, f


@pytest.mark.parametrize("folder", FOLDERS)
def test_generated_solver_reproduces_its_golden(folder, tmp_path):
    # build a copy: other tests build generated/<folder> in place, possibly on another worker at the same time
    solver = tmp_path / folder
    shutil.copytree(ROOT / folder, solver, ignore=shutil.ignore_patterns("build", GOLDEN_DIR))
    rep = regress(  # replay; a golden of a perturbed run (`record --golden-for ... --noise ...`) in closed loop
        solver,
        ROOT / folder / GOLDEN_DIR,
        preset="same-build",
        build_kw={"verify": GOLDEN_SETTINGS.verify},
    )
    assert rep.passed, (
        "outputs moved; if intended, re-record with `fcgen record --golden-for generated --force`\n" + rep.format()
    )
    assert rep.logs and all(lg.fields for lg in rep.logs)
