"""The README's front page holds: its command table names every command of ``fcgen --help`` and nothing else, its
shell lines run as written after the set-up (``.venv/bin/fcgen``, with options the command has), its problem
example is a valid problem."""

from __future__ import annotations

import re
import shlex
from pathlib import Path

from click.testing import CliRunner

from fcgen.cli import main

ROOT = Path(__file__).resolve().parents[1]
README = (ROOT / "README.md").read_text()


def _section(title: str) -> str:
    m = re.search(rf"^## {re.escape(title)}\n(.*?)(?=^## |\Z)", README, re.S | re.M)
    assert m, f"README has no section {title!r}"
    return m.group(1)


def _blocks(lang: str) -> list[str]:
    return re.findall(rf"^```{lang}\n(.*?)^```", README, re.S | re.M)


def test_the_command_table_names_every_command_and_no_other():
    table = [ln for ln in _section("Command line").splitlines() if ln.startswith("| `")]
    named = {w for ln in table for w in re.findall(r"`fcgen ([a-z-]+)", ln.split(" | ")[0])}
    assert named == set(main.commands), (
        f"missing from the README's table: {sorted(set(main.commands) - named)}; "
        f"not a command: {sorted(named - set(main.commands))}"
    )


def _commands(block: str) -> list[list[str]]:
    """The commands of a shell block: comments dropped, lines joined at ``&&``."""
    out = []
    for line in block.splitlines():
        line = line.split("#", 1)[0].strip()
        out += [shlex.split(part) for part in line.split("&&") if part.strip()]
    return out


def test_the_shell_lines_run_as_written_after_the_setup():
    cmds = [c for b in _blocks("sh") for c in _commands(b)]
    assert cmds, "README has no shell block"
    runner = CliRunner()
    for argv in cmds:
        prog = argv[0]
        if prog == "bash":
            assert (ROOT / argv[1]).is_file(), argv
            continue
        # the set-up installs fcgen into .venv, not onto PATH: a bare `fcgen` would be "command not found"
        assert prog == ".venv/bin/fcgen", f"{' '.join(argv)}: spell it .venv/bin/fcgen (the set-up's venv)"
        sub = main.commands[argv[1]]
        opts = {o for p in sub.params for o in getattr(p, "opts", [])}
        used = {a.split("=")[0] for a in argv[2:] if a.startswith("-")}
        assert used <= opts, f"{' '.join(argv)}: {sorted(used - opts)} not options of fcgen {argv[1]}"
        assert runner.invoke(main, [argv[1], "--help"]).exit_code == 0


def test_the_problem_example_is_a_valid_problem(tmp_path):
    (code,) = [b for b in _blocks("python") if "my_problem.py" in b]
    ns: dict = {}
    exec(compile(code, "my_problem.py", "exec"), ns)
    pb = ns["problem"]
    assert pb.name == "my_nmpc" and pb.qp.backend == "ipm" and pb.bounds.v_max == 30.0
    assert "my_problem.py -o my_nmpc" in "".join(_blocks("sh"))  # the file the commands generate from
