"""Static analysis of the emitted solver: cppcheck (warning, style, portability) finds nothing in <name>_solver.c/.h;
cppcheck's MISRA C:2012 addon finds exactly the rules of the deviation table (fcgen.codegen.misra), which the
generated README lists."""

from __future__ import annotations

import dataclasses
import re
import shutil
import subprocess
from pathlib import Path

import pytest

from fcgen.codegen.generate import GenerateInfo, generate
from fcgen.codegen.misra import MISRA_DEVIATIONS, deviated_rules
from fcgen.dsl import QpOptions
from fcgen.locks import folder_lock
from fcgen.presets import paper_problem

pytestmark = pytest.mark.skipif(shutil.which("cppcheck") is None, reason="needs cppcheck (Debian: cppcheck)")

ROOT = Path(__file__).resolve().parents[1]
FINDING = re.compile(r"^(?P<file>[^\s:]+):(?P<line>\d+):\d+: (?P<sev>\w+): (?P<msg>.*?) \[(?P<id>[\w.-]+)\]$", re.M)


def _small(
    formulation: str,
    obstacles: str,
    name: str,
    use_float: bool,
    out: Path,
    backend: str = "osqp",
    fine: int | None = None,
    profile: str = "paper",
    delay: int = 0,
    steer_lag: float = 0.0,
    obstacle_margin: float = 0.0,
) -> GenerateInfo:
    """A short horizon (small tables: the analysis takes seconds); the code is the template's all the same.
    ``fine``: that many one-sample intervals, then intervals of three (the safe profile's unequal grid); ``profile``:
    the safe one adds code of its own (the curve reference, the a_lat guard); ``delay``, ``steer_lag``: the delay
    compensation and the steering lag's model (code of their own too); ``obstacle_margin``: init's margins."""
    p = paper_problem("car", formulation, obstacles, name=name, profile=profile)
    hz = dataclasses.replace(p.horizon, N=4)
    if fine is not None:
        hz = dataclasses.replace(hz, stride=3, fine=fine)
    p = dataclasses.replace(p, horizon=hz, qp=QpOptions(backend=backend), delay=delay, steer_lag=steer_lag)
    p = dataclasses.replace(p, obstacle_margin=obstacle_margin)
    return generate(p, out, use_float=use_float)


#: the analysed solvers: both backends, double and float; the IPM with (hyperplane) and without stage equalities (its
#: code differs); the paper profile and the safe one, with the delay compensation, the steering lag's model and the
#: margin init sets (the safe profile's under latency) too.
#: One test per solver, so that the workers share the analysis.
FOLDERS = {
    "sa_d": ("lifted", "ellipse", False, "osqp", None, "paper"),
    "sa_f": ("conventional", "hyperplane", True, "osqp", None, "paper"),
    "sa_id": ("lifted", "ellipse", False, "ipm", None, "paper"),
    "sa_if": ("conventional", "hyperplane", True, "ipm", None, "paper"),
    "sa_g": ("direct_elimination", "ellipse", True, "ipm", 2, "paper"),
    "sa_s": ("direct_elimination", "hyperplane", False, "ipm", None, "safe"),
    "sa_sl": ("lifted", "ellipse", False, "ipm", None, "safe", 1, 0.1, 1.5),
    "sa_sl0": ("lifted", "ellipse", True, "ipm", None, "safe", 0, 0.1),
}


@pytest.fixture(scope="module", params=sorted(FOLDERS))
def folder(request, tmp_path_factory) -> GenerateInfo:
    """One solver of ``FOLDERS``, generated once per module and worker."""
    formulation, obstacles, use_float, backend, fine, profile, *lag = FOLDERS[request.param]
    out = tmp_path_factory.mktemp(request.param)
    return _small(formulation, obstacles, request.param, use_float, out, backend, fine, profile, *lag)


def _expected_misra(info: GenerateInfo) -> set[str]:
    """The deviation table; 20.1 (the backend block's own #include after code) only where the backend has headers."""
    return deviated_rules() if info.qp_files.headers else deviated_rules() - {"20.1"}


def _cppcheck(folder: Path, name: str, *args: str) -> list[dict[str, str]]:
    """cppcheck's findings in <name>_solver.c / <name>_solver.h (the solver's own files)."""
    inc = ["-I.", "-Iosqp", "-Iosqp/lib", "-Iosqp/lib/inc/public"]
    template = "--template={file}:{line}:{column}: {severity}: {message} [{id}]"
    with folder_lock(folder):  # a checked-in folder: no build restores its OSQP headers while cppcheck reads them
        res = subprocess.run(
            ["cppcheck", "-q", "--std=c99", template, *args, *inc, f"{name}_solver.c", f"{name}_solver.h"],
            cwd=folder,
            capture_output=True,
            text=True,
            timeout=600,
        )
    assert res.returncode == 0, res.stderr[-2000:]
    found = [m.groupdict() for m in FINDING.finditer(res.stderr)]
    assert len(found) == len([ln for ln in res.stderr.splitlines() if FINDING.match(ln)])
    return [f for f in found if Path(f["file"]).name in (f"{name}_solver.c", f"{name}_solver.h")]


def test_cppcheck_clean(folder: GenerateInfo) -> None:
    assert _cppcheck(folder.out_dir, folder.name, "--enable=warning,style,portability") == []


def test_cppcheck_clean_on_the_checked_in_default() -> None:
    folder = ROOT / "generated" / "truck_lifted_ellipse"
    assert _cppcheck(folder, "truck_lift_el", "--enable=warning,style,portability") == []


def test_cppcheck_sees_a_defect(tmp_path: Path) -> None:
    """The check can fail: a solver file with a defect cppcheck knows gives a finding."""
    (tmp_path / "bad_solver.c").write_text("int bad_f(void) { int a[2]; a[2] = 0; return a[0]; }\n")
    (tmp_path / "bad_solver.h").write_text("int bad_f(void);\n")
    found = _cppcheck(tmp_path, "bad", "--enable=warning,style,portability")
    assert "arrayIndexOutOfBounds" in {f["id"] for f in found}


def test_misra_findings_are_the_deviations(folder: GenerateInfo) -> None:
    found = _cppcheck(folder.out_dir, folder.name, "--addon=misra")
    rules = {f["id"].removeprefix("misra-c2012-") for f in found}
    assert all(f["id"].startswith("misra-c2012-") for f in found), found
    expected = _expected_misra(folder)
    assert rules == expected, (folder.name, sorted(rules - expected), sorted(expected - rules))
    readme = (folder.out_dir / "README.md").read_text()
    for rule, category, reason in MISRA_DEVIATIONS:
        assert f"| {rule} | {category} | {reason} |" in readme
