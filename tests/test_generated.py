"""The checked-in solvers of generated/: complete, and they compute what the Python reference computes.

(Byte-identical regeneration is checked by `fcgen regenerate --check generated` in scripts/test.sh, the CI command,
and by `test_regenerate_detects_a_changed_byte` below for the mechanism itself.)
"""

from pathlib import Path

import pytest

from fcgen.codegen.regenerate import compare, regenerate
from fcgen.presets import load_problem, preset
from fcgen.verify import verify

ROOT = Path(__file__).resolve().parents[1] / "generated"
FOLDERS = sorted(p.name for p in ROOT.iterdir() if p.is_dir())


def test_generated_holds_the_default_and_every_formulation():
    assert "truck_lifted_ellipse" in FOLDERS
    kinds = {load_problem(str(ROOT / f / "problem.py")).formulation.kind for f in FOLDERS}
    assert kinds == {"conventional", "direct_elimination", "lifted"}


@pytest.mark.parametrize("folder", FOLDERS)
def test_generated_folder_records_its_preset(folder):
    assert load_problem(str(ROOT / folder / "problem.py")) == preset(folder)


@pytest.mark.parametrize("folder", FOLDERS)
def test_generated_folder_builds_and_verifies(folder):
    rep = verify(ROOT / folder, seed=2, samples=40)
    assert rep.passed, rep.format()


def test_regenerate_detects_a_changed_byte(tmp_path):
    regenerate(tmp_path, ["truck_lifted_ellipse"])
    assert regenerate(tmp_path, check=True) == {"truck_lifted_ellipse": []}
    f = tmp_path / "truck_lifted_ellipse" / "truck_lift_el_solver.c"
    f.write_bytes(f.read_bytes().replace(b"prepare", b"prepar3", 1))
    (tmp_path / "truck_lifted_ellipse" / "stray.txt").write_text("x")
    assert compare(tmp_path / "truck_lifted_ellipse", tmp_path / "truck_lifted_ellipse") == []
    assert regenerate(tmp_path, check=True)["truck_lifted_ellipse"] == [
        "unexpected stray.txt",
        "differs truck_lift_el_solver.c",
    ]
