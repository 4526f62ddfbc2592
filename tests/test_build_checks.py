"""``fcgen build`` checks that a folder's files belong together before compiling; the Makefile names missing files."""

from __future__ import annotations

import shutil
import subprocess
from pathlib import Path

import pytest
from click.testing import CliRunner

from fcgen.build import build
from fcgen.cli import main
from fcgen.codegen.consistency import FolderMismatch
from fcgen.codegen.generate import generate
from fcgen.dsl import Horizon, Opponents, Problem

pytestmark = pytest.mark.skipif(any(shutil.which(t) is None for t in ("cc", "make")), reason="needs cc and make")


@pytest.fixture(scope="module")
def pristine(tmp_path_factory) -> Path:
    d = tmp_path_factory.mktemp("checks") / "chk"
    generate(Problem(name="chk", horizon=Horizon(N=6), opponents=Opponents(count=1)), d)
    return d


@pytest.fixture
def folder(pristine: Path, tmp_path: Path) -> Path:
    d = tmp_path / "chk"
    shutil.copytree(pristine, d)
    return d


def one_line_cli_error(args: list[str]) -> str:
    res = CliRunner().invoke(main, args)
    assert res.exit_code == 1 and isinstance(res.exception, SystemExit), res.output
    lines = res.output.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("Error: "), res.output
    return lines[0]


def test_a_hand_edited_size_is_refused_naming_the_macro_and_both_values(folder):
    h = folder / "chk_solver.h"
    text = h.read_text()
    assert "#define CHK_N 6 " in text
    h.write_text(text.replace("#define CHK_N 6 ", "#define CHK_N 7 "))
    msg = one_line_cli_error(["build", str(folder)])
    assert "CHK_N 7" in msg and "problem.py gives 6" in msg, msg
    assert not (folder / "build").exists()  # refused before compiling anything
    h.write_text(text.replace("#define CHK_QP_NNZ_A ", "#define CHK_QP_NNZ_A 1"))  # 1 prepended to the value
    with pytest.raises(FolderMismatch, match="CHK_QP_NNZ_A 1"):
        build(folder)


def test_a_problem_record_of_another_problem_is_refused(folder):
    rec = folder / "problem.py"
    rec.write_text(rec.read_text().replace("N=6", "N=8"))
    msg = one_line_cli_error(["build", str(folder)])
    assert "CHK_N 6" in msg and "problem.py gives 8" in msg, msg
    rec.write_text(rec.read_text().replace("name='chk'", "name='other'"))
    assert "problem 'other'" in one_line_cli_error(["build", str(folder)])


@pytest.mark.parametrize("gone", ["chk_model.c", "chk_solver.c", "chk_host.h", "osqp/chk_workspace.c", "problem.py"])
def test_a_missing_generated_file_is_named_in_one_line(folder, gone):
    (folder / gone).unlink()
    msg = one_line_cli_error(["build", str(folder)])
    assert f"missing {gone}," in msg and "No rule" not in msg, msg


def test_the_makefile_itself_names_missing_files(folder):
    (folder / "chk_model.c").unlink()
    (folder / "osqp/lib/src/osqp_api.c").unlink()
    res = subprocess.run(["make", "-C", str(folder)], capture_output=True, text=True)
    assert res.returncode != 0
    assert "missing source file(s): chk_model.c osqp/lib/src/osqp_api.c" in res.stderr, res.stderr
    assert "No rule to make target" not in res.stderr
    assert subprocess.run(["make", "-C", str(folder), "clean"], capture_output=True).returncode == 0


def test_a_missing_osqp_library_file_is_restored(folder):
    (folder / "osqp/lib/src/osqp_api.c").unlink()
    lib = build(folder)
    assert lib.is_file() and (folder / "osqp/lib/src/osqp_api.c").is_file()


def test_two_solver_headers_are_refused(folder):
    shutil.copy(folder / "chk_solver.h", folder / "old_solver.h")
    msg = one_line_cli_error(["build", str(folder)])
    assert "exactly one solver" in msg and "chk_solver.h, old_solver.h" in msg, msg
