"""docs/regression.md's CI example, run exactly as written: the `fcgen record` command, then the pytest file."""

import re
import shlex
import shutil
from pathlib import Path

from click.testing import CliRunner

from fcgen.cli import main
from fcgen.suite import load_suite

ROOT = Path(__file__).resolve().parents[1]
DOC = (ROOT / "docs" / "regression.md").read_text()


def _block(lang: str, needle: str) -> str:
    blocks = [b for b in re.findall(rf"```{lang}\n(.*?)```", DOC, re.S) if needle in b]
    assert len(blocks) == 1, f"docs/regression.md: expected one {lang} block with {needle!r}"
    return blocks[0]


def test_the_documented_ci_example(tmp_path, monkeypatch):
    # the user's repository: generated/my_solver (a copy of a checked-in solver), working directory = repo root
    monkeypatch.chdir(tmp_path)
    shutil.copytree(
        ROOT / "generated" / "truck_lifted_ellipse",
        tmp_path / "generated" / "my_solver",
        ignore=shutil.ignore_patterns("build", "golden"),
    )
    cmd = shlex.split(_block("bash", "fcgen record generated/my_solver").strip())
    assert cmd[0] == "fcgen"
    res = CliRunner().invoke(main, cmd[1:])
    assert res.exit_code == 0, res.output
    _man, logs = load_suite(tmp_path / "generated" / "my_solver" / "golden")
    assert len(logs) == 3 and all(lg.plan_controls is not None for lg in logs)
    # the pytest file, as documented (its defaults point at generated/my_solver)
    ns: dict = {}
    exec(compile(_block("python", "def test_solver_matches_golden"), "test_solver_regression.py", "exec"), ns)
    for mode in ("replay", "closed-loop"):
        out = tmp_path / mode
        out.mkdir()
        ns["test_solver_matches_golden"](mode, out)
        assert (out / f"regress_{mode}.json").is_file()
