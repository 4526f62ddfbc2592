"""``fcgen verify`` and ``fcgen build`` on a folder edited by hand: they name the file that differs from what
``fcgen generate`` wrote (and since when), and verify compares the default reference speed ``V_REF`` on a straight
road, where the safe profile's curve reference cannot hide it (on the scenario's bendy road it caps every node's
speed below 40 m/s, so a changed ``V_REF`` left the QP data equal)."""

from __future__ import annotations

import shutil

import pytest
from click.testing import CliRunner

from fcgen.cli import main
from fcgen.codegen.generate import generate
from fcgen.presets import preset
from fcgen.verify import verify

pytestmark = pytest.mark.skipif(any(shutil.which(t) is None for t in ("gcc", "make")), reason="needs gcc and make")


@pytest.fixture(scope="module")
def edited(tmp_path_factory):
    """The safe IPM example generated into a folder, then its solver's ``#define V_REF 40.0`` changed to 39.0."""
    out = tmp_path_factory.mktemp("edited") / "solver"
    generate(preset("truck_lifted_ellipse_ipm_safe"), out)
    c = next(out.glob("*_solver.c"))
    text = c.read_text()
    assert text.count("#define V_REF 40.0\n") == 1
    c.write_text(text.replace("#define V_REF 40.0\n", "#define V_REF 39.0\n"))
    return out, c.name


def test_verify_fails_on_an_edited_default_reference_speed_and_names_the_file(edited):
    out, cfile = edited
    rep = verify(out, seed=0, samples=20, closed_loop=False)
    assert rep.check("q").passed  # the scenario's road alone does not see it: its curve speeds are all below 39
    assert not rep.check("straight_q").passed and not rep.passed, rep.format()
    note = next(n for n in rep.notes if cfile in n)
    assert "differs from what `fcgen generate` wrote at " in note and "(changed 20" in note and "--force" in note


def test_build_warns_about_the_edited_file(edited):
    out, cfile = edited
    res = CliRunner().invoke(main, ["build", str(out), "--verify"])
    assert res.exit_code == 0, res.output
    warn = [ln for ln in res.output.splitlines() if ln.startswith("warning: ")]
    assert len(warn) == 1 and cfile in warn[0] and "differs from what `fcgen generate` wrote" in warn[0]


def test_an_unedited_folder_passes_the_straight_road_and_says_nothing(tmp_path):
    out = tmp_path / "solver"
    generate(preset("truck_lifted_ellipse_ipm_safe"), out)
    rep = verify(out, seed=0, samples=20, closed_loop=False)
    assert rep.passed and rep.check("straight_q").compared > 0, rep.format()
    assert not any("fcgen generate" in n for n in rep.notes)
