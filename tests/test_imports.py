"""The house's imports run one way: no module of fcgen imports, directly or through others, a module that imports it
back, and none imports a module of a higher layer (the layers declared once, in pyproject.toml's
``[tool.importlinter]``, checked by ``lint-imports``). Function-level imports included: a lazy import hides a circle
or an arrow up, it does not remove it."""

from __future__ import annotations

import ast
import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

import fcgen

ROOT = Path(fcgen.__file__).resolve().parent
PYPROJECT = Path(__file__).resolve().parents[1] / "pyproject.toml"


def module_imports(root: Path = ROOT) -> dict[str, set[str]]:
    """fcgen's modules and, for each, the fcgen modules it imports anywhere in its source (``from . import x``
    counts as importing ``x`` when ``x`` is a module, else its package)."""
    mods: dict[str, tuple[Path, bool]] = {}
    for p in root.rglob("*.py"):
        parts = list(p.relative_to(root.parent).with_suffix("").parts)
        is_pkg = parts[-1] == "__init__"
        mods[".".join(parts[:-1] if is_pkg else parts)] = (p, is_pkg)
    edges: dict[str, set[str]] = {m: set() for m in mods}
    for m, (p, is_pkg) in mods.items():
        pkg = m if is_pkg else m.rsplit(".", 1)[0]
        for node in ast.walk(ast.parse(p.read_text())):
            if isinstance(node, ast.ImportFrom):
                base = node.module or ""
                if node.level:
                    up = pkg.split(".")[: len(pkg.split(".")) - node.level + 1]
                    base = ".".join(up + ([node.module] if node.module else []))
                names = [f"{base}.{a.name}" for a in node.names] + [base]
            elif isinstance(node, ast.Import):
                names = [a.name for a in node.names]
            else:
                continue
            hit = next((n for n in names if n in mods and n != m), None)
            if hit:
                edges[m].add(hit)
    return edges


def circles(edges: dict[str, set[str]]) -> list[list[str]]:
    """The strongly connected components of more than one module (Tarjan), each sorted."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    found: list[list[str]] = []

    def visit(v: str) -> None:
        index[v] = low[v] = len(index)
        stack.append(v)
        for w in sorted(edges[v]):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in stack:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            comp = []
            while True:
                w = stack.pop()
                comp.append(w)
                if w == v:
                    break
            if len(comp) > 1:
                found.append(sorted(comp))

    for v in sorted(edges):
        if v not in index:
            visit(v)
    return found


def test_circle_finder_finds_a_planted_circle(tmp_path):
    pkg = tmp_path / "fcgen"
    (pkg / "sub").mkdir(parents=True)
    (pkg / "__init__.py").write_text("")
    (pkg / "a.py").write_text("from . import b\n")
    (pkg / "b.py").write_text("def f():\n    from .sub.c import g\n")
    (pkg / "sub" / "__init__.py").write_text("")
    (pkg / "sub" / "c.py").write_text("from ..a import x\nimport os\n")
    (pkg / "d.py").write_text("from .a import y\n")
    assert circles(module_imports(pkg)) == [["fcgen.a", "fcgen.b", "fcgen.sub.c"]]


def test_fcgen_has_no_import_circles():
    edges = module_imports()
    assert "fcgen.dsl" in edges and "fcgen.codegen.generate" in edges  # the walk saw the package
    assert circles(edges) == []


def test_lower_layers_import_no_higher_ones():
    edges = module_imports()
    dsl = {m for m in edges if m == "fcgen.dsl" or m.startswith("fcgen.dsl.")}  # the DSL package and its modules
    assert not set().union(*(edges[m] for m in dsl)) - dsl - {"fcgen.cnames"}
    assert "fcgen.codegen.generate" not in edges["fcgen.targets"]
    assert "fcgen.build" not in edges["fcgen.codegen.consistency"]


def lint_imports(python_path: Path | None = None) -> subprocess.CompletedProcess:
    """``lint-imports`` with the repository's contracts on the installed fcgen, or on the one under ``python_path``."""
    exe = shutil.which("lint-imports", path=str(Path(sys.executable).parent)) or shutil.which("lint-imports")
    assert exe, "lint-imports not found: install the test extra (pip install -e .[test])"
    env = dict(os.environ)
    if python_path is not None:
        env["PYTHONPATH"] = os.pathsep.join([str(python_path), *filter(None, [env.get("PYTHONPATH")])])
    return subprocess.run(
        [exe, "--config", str(PYPROJECT), "--no-cache"], capture_output=True, text=True, env=env, timeout=300
    )


def test_fcgen_keeps_its_layers():
    res = lint_imports()
    assert res.returncode == 0, res.stdout + res.stderr
    assert "1 kept, 0 broken" in res.stdout, res.stdout


@pytest.mark.parametrize(
    "module, planted, arrow",
    [
        # a lazy import from the bottom layer to the top one
        ("dsl/problem.py", "def _planted():\n    from ..cli import main\n", "fcgen.dsl.problem -> fcgen.cli"),
        # the targets (data) rendering with the code generator: the arrow up this layering took out
        ("targets.py", "from .codegen.render import render_template\n", "fcgen.targets -> fcgen.codegen.render"),
        # the C binding reaching up into the closed loop for its result type (now fcgen.contract's)
        ("csolver.py", "from .sim.closedloop import run_closed_loop\n", "fcgen.csolver -> fcgen.sim.closedloop"),
        # a backend's exemption covers codegen only
        ("backends/osqp.py", "from ..reference import QP_EXIT\n", "fcgen.backends.osqp -> fcgen.reference"),
    ],
)
def test_the_layer_check_fails_on_an_import_up(tmp_path, module, planted, arrow):
    """A copy of fcgen with one import up planted: ``lint-imports`` fails and names that arrow."""
    copy = tmp_path / "fcgen"
    shutil.copytree(ROOT, copy, ignore=shutil.ignore_patterns("templates", "firmware_sim", "__pycache__"))
    f = copy / module
    f.write_text(f.read_text() + "\n\n" + planted)
    res = lint_imports(tmp_path)
    assert res.returncode != 0 and "0 kept, 1 broken" in res.stdout, res.stdout + res.stderr
    assert arrow in res.stdout, res.stdout  # only the copy has it: the copy was checked
