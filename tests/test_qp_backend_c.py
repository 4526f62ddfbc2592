"""Each QP backend has its C side in codegen (the context of its template, its files), and backends/ never imports
codegen/ (the layers: backends below codegen)."""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

import fcgen.backends
from fcgen.codegen.qp_backend import C_SIDES, backend_c
from fcgen.dsl import BACKENDS


def test_every_backend_has_its_c_side():
    assert set(C_SIDES) == set(BACKENDS)
    for name in BACKENDS:
        mod = backend_c(name)
        assert callable(mod.codegen_context) and callable(mod.write_files)


def test_an_unknown_backend_is_refused_with_the_list():
    with pytest.raises(ValueError, match=r"qp.backend: 'hpipm' is not a QP backend; allowed: osqp, ipm"):
        backend_c("hpipm")


def test_backends_import_nothing_of_codegen():
    """Every import of backends/ (at any depth of a module, relative or absolute) stays below codegen."""
    up = []
    for path in Path(fcgen.backends.__file__).parent.glob("*.py"):
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.ImportFrom):
                target = ("." * node.level) + (node.module or "")
            elif isinstance(node, ast.Import):
                target = ",".join(a.name for a in node.names)
            else:
                continue
            if "codegen" in target or "build" in target.split(".") or target.startswith(("fcgen.sim", "..sim")):
                up.append(f"{path.name}: {target}")
    assert up == []
