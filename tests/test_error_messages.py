"""Errors that say the fix: a misspelled DSL field names the allowed fields and the nearest one (every DSL class), every
folder error names the command that makes a good folder, the preset grammar the unknown-preset message states is the
one the parser accepts."""

from __future__ import annotations

import dataclasses
import importlib
import itertools
import re
from pathlib import Path

import pytest
from click.testing import CliRunner

import fcgen.dsl
from fcgen.cli import main
from fcgen.dsl import Bounds, ProblemError
from fcgen.dsl.validation import UnknownFieldError
from fcgen.presets import preset

DSL_DIR = Path(fcgen.dsl.__file__).parent
GOLDEN = Path(__file__).resolve().parents[1] / "generated" / "truck_lifted_ellipse" / "golden"


def _dsl_dataclasses() -> list[type]:
    """Every dataclass defined in a module of fcgen.dsl (found by walking the package's files, not its exports)."""
    out = []
    for f in sorted(DSL_DIR.glob("*.py")):
        mod = importlib.import_module(f"fcgen.dsl.{f.stem}") if f.stem != "__init__" else fcgen.dsl
        out += [
            c
            for c in vars(mod).values()
            if isinstance(c, type) and dataclasses.is_dataclass(c) and c.__module__ == mod.__name__
        ]
    return out


def test_the_issue_example():
    with pytest.raises(ProblemError) as e:
        Bounds(vmax=30)
    assert str(e.value).startswith("Bounds has no field 'vmax'; did you mean 'v_max'? Allowed: F_d_max, r_max, ")
    assert isinstance(e.value, TypeError)  # as Python's own error for a bad keyword: `except TypeError` still works


def test_every_dsl_dataclass_refuses_an_unknown_field_naming_the_allowed_and_the_nearest():
    classes = _dsl_dataclasses()
    assert len(classes) >= 18 and {"Problem", "Bounds", "QpOptions", "Lifted"} <= {c.__name__ for c in classes}
    for cls in classes:
        allowed = [f.name for f in dataclasses.fields(cls) if f.init]
        with pytest.raises(UnknownFieldError) as e:
            cls(no_such_field_xyz=1)
        msg = str(e.value)
        assert msg.startswith(f"{cls.__name__} has no field 'no_such_field_xyz';"), msg
        assert msg.endswith("Allowed: " + (", ".join(allowed) or f"none ({cls.__name__} takes no fields)")), msg
        for name in allowed:  # each field misspelled (its first underscore dropped or a letter added, upper case)
            typo = (name.replace("_", "", 1) if "_" in name else name + "x").upper()
            if typo.lower() in (a.lower() for a in allowed):
                continue
            with pytest.raises(UnknownFieldError) as e:
                cls(**{typo: 1})
            assert f"did you mean {name!r}?" in str(e.value), (cls.__name__, typo, str(e.value))


def test_the_fields_still_work_by_keyword_and_position():
    assert Bounds(v_max=30.0).v_max == 30.0
    assert Bounds(1e4, 0.3).r_max == 0.3
    assert fcgen.dsl.Horizon(N=20).N == 20


@pytest.fixture(scope="module")
def bad_folders(tmp_path_factory) -> dict[str, Path]:
    base = tmp_path_factory.mktemp("folders")
    (base / "empty").mkdir()
    (base / "other").mkdir()
    (base / "other" / "notes.txt").write_text("x")
    (base / "two").mkdir()
    for n in ("a", "b"):
        (base / "two" / f"{n}_solver.h").write_text("")
    return {"empty": base / "empty", "other": base / "other", "two": base / "two", "missing": base / "nope"}


COMMANDS = [
    ["build"],
    ["verify"],
    ["bench"],
    ["firmware-sim"],
    ["footprint"],
    ["wcet", "--target", "cortex-m7"],
    ["record"],
    ["fmu", "-o", "x.fmu"],
    ["simulate", "--controller", "c", "--solver-dir"],
    ["regress"],
]


@pytest.mark.parametrize("cmd", COMMANDS, ids=lambda c: c[0])
def test_every_folder_error_says_the_command_that_makes_a_good_folder(cmd, bad_folders, tmp_path):
    for kind, folder in bad_folders.items():
        args = [*cmd, str(folder)] if cmd[0] != "regress" else [cmd[0], str(folder), str(GOLDEN)]
        res = CliRunner().invoke(main, args)
        lines = res.output.strip().splitlines()
        assert res.exit_code in (1, 2) and len(lines) == 1 and lines[0].startswith("Error: "), (kind, res.output)
        assert "`fcgen generate " in lines[0], (cmd[0], kind, lines[0])


def _grammar_parts(msg: str) -> dict[str, list[str]]:
    m = re.search(
        r"a preset is SCENARIO_FORMULATION_OBSTACLES\[_BACKEND\]\[_(\w+)\] with SCENARIO one of ([\w, ]+); "
        r"FORMULATION one of ([\w, ]+); OBSTACLES one of ([\w, ]+); BACKEND one of ([\w, ]+) \(",
        msg,
    )
    assert m, msg
    safe, *lists = m.groups()
    sc, form, obs, backends = ([w.strip() for w in g.split(",")] for g in lists)
    return {"safe": [safe], "scenario": sc, "formulation": form, "obstacles": obs, "backend": backends}


def test_the_preset_grammar_the_message_states_is_the_one_the_parser_accepts():
    with pytest.raises(ProblemError) as e:
        preset("truck_lifted_elipse_ipm")
    msg = str(e.value)
    assert "did you mean 'truck_lifted_ellipse_ipm'?" in msg
    g = _grammar_parts(msg)
    names = []
    for sc, f, o in itertools.product(g["scenario"], g["formulation"], g["obstacles"]):
        for b in ["", *(f"_{x}" for x in g["backend"])]:
            names += [f"{sc}_{f}_{o}{b}", f"{sc}_{f}_{o}{b}_{g['safe'][0]}"]
    assert len(names) == 2 * 3 * 3 * 2 * 2
    for n in names:  # every name of the stated grammar is accepted, and is the problem it names
        pb = preset(n)
        assert pb.qp.backend == ("ipm" if "_ipm" in n else "osqp"), n
        assert pb.name.endswith("_safe") == n.endswith("_safe"), n
    assert preset("truck_lifted_ellipse_safe").qp.backend == "osqp"  # the safe profile with OSQP: documented
    for bad in (
        "truck_lifted_ellipse_safe_ipm",
        "truck_lifted_ellipse_ipm_ipm",
        "truck_lifted_ellipse_safe_safe",
        "truck_lifted_ellipse_osqp",
        "truck_lifted_ellipse_ipm_safe_safe",
        "lifted_ellipse",
    ):
        with pytest.raises(ProblemError, match="is unknown"):
            preset(bad)


def test_every_message_of_the_troubleshooting_page_has_what_to_do_beside_it():
    page = (Path(__file__).resolve().parents[1] / "docs" / "troubleshooting.md").read_text()
    rows = [
        ln for ln in page.splitlines() if ln.startswith("| ") and not ln.startswith("| message") and "---" not in ln
    ]
    rows = [r for r in rows if not r.startswith(("| outcome", "| message starts with"))]
    assert len(rows) >= 30
    for r in rows:
        cells = [c.strip() for c in r.strip("|").split(" | ")]
        assert len(cells) == 3 and all(cells), f"a row without its cause or fix: {r}"
