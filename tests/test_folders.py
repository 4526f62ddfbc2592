"""``fcgen generate``'s output folder: another solver is refused (or replaced with --force, not mixed), a failed or
interrupted generation leaves nothing half-written, regeneration in place keeps build/ and unchanged files."""

from __future__ import annotations

import shutil
import subprocess
from pathlib import Path

import pytest
from click.testing import CliRunner

import fcgen.codegen.generate as generate_mod
from fcgen.cli import main
from fcgen.codegen.folder import FolderError
from fcgen.codegen.generate import generate
from fcgen.dsl import Horizon, Opponents, Problem

needs_cc = pytest.mark.skipif(any(shutil.which(t) is None for t in ("cc", "make")), reason="needs cc and make")


def small(name: str, N: int = 4) -> Problem:
    return Problem(name=name, horizon=Horizon(N=N), opponents=Opponents(count=1))


def snapshot(folder: Path) -> dict[str, tuple[bytes, int]]:
    """Every file under ``folder`` (contents and mtime in ns), and the sibling entries of ``folder``."""
    out = {
        p.relative_to(folder).as_posix(): (p.read_bytes(), p.stat().st_mtime_ns)
        for p in folder.rglob("*")
        if p.is_file()
    }
    out["<siblings>"] = (" ".join(sorted(p.name for p in folder.parent.iterdir())).encode(), 0)
    return out


def write_problem(tmp_path: Path, name: str, N: int = 4) -> str:
    (tmp_path / "problems").mkdir(exist_ok=True)
    f = tmp_path / "problems" / f"{name}.py"
    f.write_text(
        f"from fcgen.dsl import *\nproblem = Problem(name={name!r}, horizon=Horizon(N={N}), "
        f"opponents=Opponents(count=1))\n"
    )
    return str(f)


def test_a_folder_with_another_solver_is_refused_and_nothing_is_written(tmp_path):
    out = tmp_path / "out"
    generate(small("alpha"), out)
    (out / "notes.txt").write_text("mine")
    problem = write_problem(tmp_path, "beta")
    before = snapshot(out)
    res = CliRunner().invoke(main, ["generate", problem, "-o", str(out)])
    assert res.exit_code == 1, res.output
    assert isinstance(res.exception, SystemExit)
    line = res.output.strip()
    assert "\n" not in line and "'alpha'" in line and "--force" in line and "nothing written" in line, line
    assert snapshot(out) == before  # byte for byte and mtime for mtime
    with pytest.raises(FolderError, match="holds the solver 'alpha'"):
        generate(small("beta"), out)
    assert snapshot(out) == before


@needs_cc
def test_force_replaces_the_old_solver_without_mixing(tmp_path):
    out = tmp_path / "out"
    generate(small("alpha"), out)
    subprocess.run(["make", "-C", str(out), "-j2", "lib"], check=True, capture_output=True)
    (out / "notes.txt").write_text("mine")
    res = CliRunner().invoke(main, ["generate", write_problem(tmp_path, "beta"), "-o", str(out), "--force"])
    assert res.exit_code == 0, res.output
    names = sorted(
        p.relative_to(out).as_posix()
        for p in out.rglob("*")
        if p.is_file() and not p.relative_to(out).as_posix().startswith("osqp/lib/")
    )
    assert not [n for n in names if "alpha" in n], names  # no file of the old solver, not even its build products
    assert not (out / "build").exists()
    assert "notes.txt" in names and "beta_solver.c" in names and "osqp/beta_workspace.c" in names
    assert "alpha" not in (out / "Makefile").read_text() and "beta" in (out / "problem.py").read_text()
    subprocess.run(["make", "-C", str(out), "-j2", "lib"], check=True, capture_output=True)  # the new one builds


def test_a_non_empty_folder_without_a_solver_is_refused_unless_forced(tmp_path):
    out = tmp_path / "src"
    out.mkdir()
    (out / "app.c").write_text("int x;\n")
    with pytest.raises(FolderError, match=r"holds no fcgen solver \(app.c\).*--force"):
        generate(small("alpha"), out)
    assert sorted(p.name for p in out.iterdir()) == ["app.c"]
    generate(small("alpha"), out, force=True)
    assert (out / "app.c").read_text() == "int x;\n" and (out / "alpha_solver.h").is_file()


@pytest.mark.parametrize("exc", [RuntimeError("disk full"), KeyboardInterrupt()], ids=["error", "interrupt"])
def test_a_failed_or_interrupted_generation_leaves_the_folder_as_it_was(tmp_path, monkeypatch, exc):
    out = tmp_path / "out"
    generate(small("alpha", N=4), out)
    before = snapshot(out)
    seen = []

    def broken(obj, indent=0):  # problem.py is the last file: every other file is written by now
        seen.append(sorted(p.name for p in Path(tmp_path).glob(".out.fcgen-new-*/*")))
        raise exc

    monkeypatch.setattr(generate_mod, "problem_source", broken)
    with pytest.raises(type(exc)):
        generate(small("alpha", N=6), out)  # a changed problem: every file would change
    assert "alpha_solver.c" in seen[0]  # the failure came late, with the new files written (elsewhere)
    assert snapshot(out) == before
    with pytest.raises(type(exc)):
        generate(small("gamma"), tmp_path / "new")
    assert len(seen) == 2
    assert not (tmp_path / "new").exists()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out"]  # no temporary folder left


@needs_cc
def test_regenerating_the_same_solver_is_in_place_friendly(tmp_path):
    out = tmp_path / "out"
    generate(small("alpha"), out)
    subprocess.run(["make", "-C", str(out), "-j2", "lib"], check=True, capture_output=True)
    (out / "scenario.txt").write_text("data")
    before = snapshot(out)
    generate(small("alpha"), out)
    assert snapshot(out) == before  # same bytes, same times, build/ and the user's file kept
    res = subprocess.run(["make", "-C", str(out), "-q", "lib"], capture_output=True)
    assert res.returncode == 0  # make: nothing to rebuild
    generate(small("alpha", N=5), out)  # a changed problem: the solver changes, the build is kept and refreshed
    assert (out / "build").is_dir() and (out / "scenario.txt").read_text() == "data"
    assert subprocess.run(["make", "-C", str(out), "-q", "lib"], capture_output=True).returncode != 0


@pytest.mark.parametrize("path", ["afile/sub", "afile/sub/deeper", "afile"])
def test_an_output_path_under_a_file_gives_one_line(tmp_path, path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    Path("afile").write_text("x")
    res = CliRunner().invoke(main, ["generate", "truck_lifted_ellipse", "-o", path])
    assert res.exit_code != 0 and isinstance(res.exception, SystemExit), res.output
    msg = [ln for ln in res.output.splitlines() if ln.startswith("Error")]
    assert len(msg) == 1 and "afile" in msg[0] and "Traceback" not in res.output, res.output
    assert Path("afile").read_text() == "x" and sorted(p.name for p in tmp_path.iterdir()) == ["afile"]


def test_the_current_directory_is_not_replaced_under_the_caller(tmp_path, monkeypatch):
    out = tmp_path / "out"
    generate(small("alpha"), out)
    monkeypatch.chdir(out)
    with pytest.raises(FolderError, match="current directory"):
        generate(small("alpha"), ".")
    assert Path.cwd() == out.resolve() and (out / "alpha_solver.h").is_file()


def test_a_symlinked_folder_keeps_its_link(tmp_path):
    real = tmp_path / "real"
    generate(small("alpha"), real)
    (tmp_path / "link").symlink_to(real)
    generate(small("alpha", N=5), tmp_path / "link")
    assert (tmp_path / "link").is_symlink() and "N=5" in (real / "problem.py").read_text()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["link", "real"]
