"""A generated solver folder is read once (``fcgen.solver_folder.read_folder``) into a ``SolverFolder`` that the build,
the C binding and the firmware harness are handed: what it holds, what it refuses, and that nothing on the main job's
path reads the folder again."""

from __future__ import annotations

import pickle
import shutil
from pathlib import Path

import numpy as np
import pytest

from fcgen import build as build_mod
from fcgen import csolver as csolver_mod
from fcgen import solver_folder as folder_mod
from fcgen.build import build
from fcgen.codegen.consistency import FolderMismatch
from fcgen.codegen.generate import generate
from fcgen.csolver import CSolver
from fcgen.dsl import Horizon, Opponents, Problem
from fcgen.sim.harness import firmware_sim
from fcgen.solver_folder import read_folder

needs_cc = pytest.mark.skipif(any(shutil.which(t) is None for t in ("cc", "make")), reason="needs cc and make")
PROBLEM = Problem(name="sfold", horizon=Horizon(N=6), opponents=Opponents(count=1))


@pytest.fixture(scope="module")
def generated(tmp_path_factory):
    root = tmp_path_factory.mktemp("folders")
    return {"double": generate(PROBLEM, root / "d"), "float": generate(PROBLEM, root / "f", use_float=True)}


def test_the_folder_holds_what_generate_wrote(generated):
    info = generated["double"]
    f = read_folder(info.out_dir)
    assert f.path == info.out_dir and f.name == "sfold" and f.checked
    assert f.header == info.out_dir / "sfold_solver.h" and f.problem_file == info.out_dir / "problem.py"
    assert {k: f.sizes[k] for k in info.sizes} == info.sizes  # the header's macros are the generator's sizes
    assert f.sizes["N"] == 6 and f.sizes["NOPP"] == 1
    assert f.problem == PROBLEM  # problem.py gives back the problem generated
    assert (f.precision, f.use_float, f.backend) == ("double", False, "osqp")
    assert read_folder(generated["float"].out_dir).precision == "float"
    assert pickle.loads(pickle.dumps(f)) == f  # it can be handed to a worker process


def test_the_build_paths_per_target_and_variant(generated):
    f = read_folder(generated["double"].out_dir)
    d = f.path
    assert f.lib() == d / "build" / "libsfold.so"
    assert f.lib(verify=True) == d / "build" / "verify" / "libsfold.so"
    assert f.lib(target="cortex-m7") == d / "build" / "cortex-m7" / "libsfold.a"
    assert (
        f.lib(target="cortex-m4f", variant="footprint", verify=True)
        == d / "build" / "cortex-m4f" / "footprint" / "verify" / "libsfold.a"
    )
    assert f.build_dir(target="cortex-m7", variant="wcet_probe") == d / "build" / "cortex-m7" / "wcet_probe"


def test_what_is_not_a_folder_names_the_command_that_writes_one(tmp_path, generated):
    with pytest.raises(FileNotFoundError, match=r"missing: no such solver folder.*fcgen generate"):
        read_folder(tmp_path / "missing")
    (tmp_path / "junk.txt").write_text("x")
    with pytest.raises(FileNotFoundError, match=r"not a generated solver folder.*fcgen generate"):
        read_folder(tmp_path)
    d = tmp_path / "two"
    shutil.copytree(generated["double"].out_dir, d)
    shutil.copy(d / "sfold_solver.h", d / "old_solver.h")
    with pytest.raises(FolderMismatch, match="exactly one solver"):
        read_folder(d)
    assert read_folder(generated["double"].out_dir, check=False).checked is False


@needs_cc
def test_nothing_on_the_main_jobs_path_reads_the_folder_again(generated, tmp_path, monkeypatch):
    """Once read, the folder is built, loaded and run in the C harness without being read again: every reader of a
    folder (the folder reader, the consistency check, the header's macros, problem.py) fails if called."""
    folder = read_folder(generated["double"].out_dir)

    def reads_again(*args, **kw):
        raise AssertionError(f"the folder was read again: {args}")

    for mod, name in (
        (folder_mod, "read_folder"),
        (folder_mod, "check_folder"),
        (folder_mod, "read_macros"),
        (folder_mod, "load_problem"),
        (folder_mod, "the_solver"),
        (build_mod, "check_folder"),
        (csolver_mod, "read_macros"),
        (csolver_mod, "solver_name"),
    ):
        monkeypatch.setattr(mod, name, reads_again)
    cs = CSolver(build(folder), folder=folder)
    assert cs.name == "sfold" and cs.N == 6 and cs.dtype == np.float64
    log = firmware_sim(folder, "truck", 0, 3, tmp_path / "run.json")
    assert log.n_controls == 3 and log.meta["problem"] == "sfold" and log.meta["precision"] == "double"
    assert Path(tmp_path / "run.json").is_file()
