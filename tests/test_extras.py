"""A command whose extra is missing fails with one line naming the pip command (fcgen.extras): the extra's package is
made unimportable by a None in sys.modules, the module that needs it imported afresh."""

from __future__ import annotations

import ast
import importlib
import sys
import tomllib
from pathlib import Path

import pytest
from click.testing import CliRunner

from fcgen.extras import EXTRAS, MissingExtra, install_hint, require

ROOT = Path(__file__).resolve().parents[1]


def _block(monkeypatch, *packages: str) -> None:
    """Make ``packages`` (and their submodules already imported) unimportable for this test."""
    for name in list(sys.modules):
        if name.split(".")[0] in packages:
            monkeypatch.delitem(sys.modules, name)
    for p in packages:
        monkeypatch.setitem(sys.modules, p, None)


def _fresh(monkeypatch, module: str):
    """Import ``module`` again (its cached copy and its fcgen submodules put back after the test)."""
    for name in list(sys.modules):
        if name == module or name.startswith(module + "."):
            monkeypatch.delitem(sys.modules, name)
    return importlib.import_module(module)


def test_require_turns_a_missing_package_into_one_line_naming_the_extra(monkeypatch):
    _block(monkeypatch, "pandas")
    with pytest.raises(MissingExtra) as err, require("campaign", "the report"):
        import pandas  # noqa: F401
    msg = str(err.value)
    assert msg == "the report needs the 'campaign' extra (pandas is not installed): pip install 'fcgen[campaign]'"
    assert "\n" not in msg


def test_require_refuses_an_unknown_extra_and_passes_other_errors():
    with (
        pytest.raises(ValueError, match=r"extra = 'plots' is not an extra of fcgen; allowed: campaign, plot"),
        require("plots"),
    ):
        pass
    with pytest.raises(KeyError), require("plot"):  # not an import: untouched
        raise KeyError("x")


@pytest.mark.parametrize(
    ("module", "packages", "extra"),
    [
        ("fcgen.campaign.store", ("pandas", "pyarrow"), "campaign"),
        ("fcgen.report.tables", ("pandas",), "campaign"),
        ("fcgen.sim.plots", ("matplotlib",), "plot"),
    ],
)
def test_a_module_of_an_extra_says_which_to_install(monkeypatch, module, packages, extra):
    _block(monkeypatch, *packages)
    with pytest.raises(MissingExtra, match=rf"needs the '{extra}' extra .*: pip install 'fcgen\[{extra}\]'$"):
        _fresh(monkeypatch, module)


def test_the_fmu_and_commonroad_entry_points_name_their_extra(monkeypatch, tmp_path):
    from fcgen import fmu
    from fcgen.commonroad import scenario

    _block(monkeypatch, "fmpy", "commonroad")
    with pytest.raises(MissingExtra, match=r"pip install 'fcgen\[fmu\]'$"):
        fmu.fmi_headers()
    with pytest.raises(MissingExtra, match=r"pip install 'fcgen\[commonroad\]'$"):
        scenario.load_scenario(tmp_path / "none.xml", ego=None)


def test_the_command_prints_one_line_and_exits_1(monkeypatch, tmp_path):
    """``fcgen report`` without the campaign extra: ``Error: ...`` on one line, exit 1, no traceback."""
    from fcgen.cli import main

    _block(monkeypatch, "pandas", "pyarrow")
    for name in [m for m in sys.modules if m.startswith(("fcgen.report", "fcgen.campaign"))]:
        monkeypatch.delitem(sys.modules, name)
    (tmp_path / "results").mkdir()
    res = CliRunner().invoke(main, ["report", str(tmp_path / "results"), "--out", str(tmp_path / "rep")])
    assert res.exit_code == 1, res.output
    lines = res.output.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("Error: "), res.output
    assert lines[0].endswith(install_hint("campaign")), res.output
    assert res.exception is None or isinstance(res.exception, SystemExit)


def test_every_extra_is_declared_in_pyproject_and_the_core_is_lean():
    project = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]
    declared = project["optional-dependencies"]
    assert set(EXTRAS) <= set(declared)
    core = {d.split("=")[0].split(">")[0].split("[")[0] for d in project["dependencies"]}
    assert core == {"casadi", "osqp", "numpy", "scipy", "jinja2", "click"}


EXTRA_PACKAGES = (
    "pandas",
    "pyarrow",
    "dask",
    "distributed",
    "tqdm",
    "matplotlib",
    "fmpy",
    "commonroad",
    "commonroad_dc",
    "commonroad_crime",
)


def _imports_outside_require(tree: ast.AST) -> list[tuple[int, str]]:
    """(line, package) of each import of an extra's package that is not inside ``with require(...)``."""
    out: list[tuple[int, str]] = []

    def visit(node: ast.AST, guarded: bool) -> None:
        if isinstance(node, ast.With):
            guarded = guarded or any(
                isinstance(i.context_expr, ast.Call) and getattr(i.context_expr.func, "id", "") == "require"
                for i in node.items
            )
        if isinstance(node, ast.If) and getattr(node.test, "id", "") == "TYPE_CHECKING":
            guarded = True  # read by the type checker only, never imported at run time
        names = []
        if isinstance(node, ast.Import):
            names = [a.name for a in node.names]
        elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
            names = [node.module]
        out.extend((node.lineno, n) for n in names if n.split(".")[0] in EXTRA_PACKAGES and not guarded)
        for child in ast.iter_child_nodes(node):
            visit(child, guarded)

    visit(tree, False)
    return out


def test_every_import_of_an_extras_package_goes_through_require():
    package = ROOT / "generator" / "fcgen"
    found = [
        f"{p.relative_to(ROOT)}:{line} imports {name}"
        for p in sorted(package.rglob("*.py"))
        if "templates" not in p.parts and p.name != "extras.py"
        for line, name in _imports_outside_require(ast.parse(p.read_text()))
    ]
    assert not found, "import outside `with require(...)`:\n" + "\n".join(found)
    # the check finds what it looks for
    assert _imports_outside_require(ast.parse("import pandas\nwith require('plot'):\n    import matplotlib\n")) == [
        (1, "pandas")
    ]
    assert _imports_outside_require(ast.parse("if TYPE_CHECKING:\n    import pandas\nif x:\n    import dask\n")) == [
        (4, "dask")
    ]
