"""The documentation site: it builds with warnings as errors, its DSL page is what the code says, and its C API page
names everything a generated header declares."""

from __future__ import annotations

import dataclasses
import re
import subprocess
import sys
from pathlib import Path

import pytest

from fcgen import dsl
from fcgen.dsl_reference import CLASSES, FIELDS, documented_fields, render

ROOT = Path(__file__).resolve().parent.parent
DOCS = ROOT / "docs"


def test_site_builds_strict(tmp_path):
    res = subprocess.run(
        [sys.executable, "-m", "mkdocs", "build", "--strict", "-d", str(tmp_path / "site")],
        cwd=ROOT,
        capture_output=True,
        text=True,
        env={"NO_MKDOCS_2_WARNING": "1", "PATH": "/usr/bin:/bin"},
    )
    assert res.returncode == 0, res.stdout + res.stderr
    assert (tmp_path / "site" / "c_api" / "index.html").is_file()


def test_strict_build_fails_on_a_broken_link(tmp_path):
    """The guard above is real: a page linking to a missing page fails the strict build."""
    docs = tmp_path / "docs"
    docs.mkdir()
    (docs / "index.md").write_text("# x\n\n[gone](missing.md)\n")
    (tmp_path / "mkdocs.yml").write_text(
        (ROOT / "mkdocs.yml").read_text().split("nav:")[0] + "nav:\n  - Home: index.md\n"
    )
    res = subprocess.run(
        [sys.executable, "-m", "mkdocs", "build", "--strict", "-d", str(tmp_path / "site")],
        cwd=tmp_path,
        capture_output=True,
        text=True,
        env={"NO_MKDOCS_2_WARNING": "1", "PATH": "/usr/bin:/bin"},
    )
    assert res.returncode != 0 and "missing.md" in res.stdout + res.stderr


def test_every_dsl_field_is_documented_and_nothing_else():
    have = {(c, f.name) for c in CLASSES for f in documented_fields(getattr(dsl, c))}
    classes = {
        n
        for n in dir(dsl)
        if isinstance(getattr(dsl, n), type)
        and dataclasses.is_dataclass(getattr(dsl, n))
        and getattr(dsl, n).__module__.startswith("fcgen.dsl.")
    }
    assert classes == set(CLASSES)
    assert set(FIELDS) == have


def test_problem_reference_page_is_current():
    assert (DOCS / "problem_reference.md").read_text() == render(), (
        "run: python -m fcgen.dsl_reference > docs/problem_reference.md"
    )


_SIMPLE = {"> 0": [0.0, -1.0], ">= 0": [-1e-9, -1.0]}


@pytest.mark.parametrize(
    "key",
    [k for k, v in FIELDS.items() if v[1] in _SIMPLE or re.match(r"^(integer in )?\[[-0-9.e]+, [-0-9.e]+\]", v[1])],
)
def test_documented_range_is_the_validated_one(key):
    """Just outside the documented range the constructor raises ProblemError naming the field; at its edges it
    does not (an independent reading of the page against the validation code)."""
    cls_name, field = key
    cls = getattr(dsl, cls_name)
    allowed = FIELDS[key][1]
    if allowed in _SIMPLE:
        bad = _SIMPLE[allowed]
        good = [1.0] + ([0.0] if allowed == ">= 0" else [])
    else:
        lo, hi = (float(x) for x in re.match(r"^(?:integer in )?\[([-0-9.e]+), ([-0-9.e]+)\]", allowed).groups())
        integer = allowed.startswith("integer")
        step = 1 if integer else 1e-6 * max(1.0, abs(hi))
        cast = int if integer else float
        bad = [cast(lo - step), cast(hi + step)]
        good = [cast(lo), cast(hi)]
    base = {"name": "p"} if cls is dsl.Problem else {}  # a Problem's one required field
    for v in bad:
        with pytest.raises(dsl.ProblemError, match=re.escape(field)):
            cls(**base, **{field: v})
    for v in good:
        cls(**base, **{field: v})


def _header_symbols(header: Path, name: str) -> set[str]:
    text = header.read_text()
    NAME = name.upper()
    funcs = {m.replace(name, "<name>", 1) for m in re.findall(rf"\b({name}_[a-z0-9_]+)\s*\(", text)}
    consts = {
        m.replace(NAME, "<NAME>", 1) for m in re.findall(rf"\b({NAME}_[A-Z0-9_]+)\b", text) if not m.endswith("_H")
    }
    status = re.search(r"typedef struct \{(.*?)\} " + name + r"_status_t;", text, re.S).group(1)
    fields = set(re.findall(rf"^\s+(?:int|uint32_t|{name}_real_t)\s+(\w+);", status, re.M))
    return funcs | consts | fields


@pytest.mark.parametrize("folder", ["truck_lifted_ellipse", "truck_lifted_ellipse_ipm", "truck_conventional_ellipse"])
def test_c_api_page_names_every_symbol_of_the_header(folder):
    gen = ROOT / "generated" / folder
    header = next(gen.glob("*_solver.h"))
    name = header.name[: -len("_solver.h")]
    page = (DOCS / "c_api.md").read_text()
    missing = sorted(
        s for s in _header_symbols(header, name) if f"`{s}" not in page and f" {s}" not in page and f"{s}(" not in page
    )
    assert not missing, f"docs/c_api.md does not name: {missing}"


def test_header_symbol_reader_sees_the_api():
    """The check above reads what it should: the known API is among what it finds."""
    syms = _header_symbols(ROOT / "generated/truck_lifted_ellipse/truck_lift_el_solver.h", "truck_lift_el")
    assert {
        "<name>_feedback",
        "<NAME>_ERR_QP_INPUT_BOUNDS",
        "<NAME>_QP_OTHER",
        "<NAME>_NX",
        "qp_unusable_run",
        "u_violation",
        "ticks_feedback",
    } <= syms
