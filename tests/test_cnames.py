"""Problem names that would clash in C are refused (fcgen.cnames), and the refusal is real: such names break the build.

The reserved sets are derived again here from the real artefacts (``nm`` of a built OSQP library and its headers,
the C99 headers through ``cc``, CasADi's generated code) and must be covered by fcgen.cnames.
"""

from __future__ import annotations

import re
import shutil
import subprocess
from pathlib import Path

import pytest

from fcgen.build import BuildError, build, run_make
from fcgen.cnames import (
    C99_KEYWORDS,
    C_LIBRARY,
    C_LIBRARY_NAMESPACES,
    C_RESERVED_START,
    CASADI_NAMESPACES,
    OSQP_NAMESPACES,
    name_clash,
)
from fcgen.codegen.generate import generate
from fcgen.dsl import Horizon, Opponents, Problem, ProblemError
from fcgen.presets import preset, preset_names

needs_cc = pytest.mark.skipif(any(shutil.which(t) is None for t in ("cc", "make", "nm")), reason="needs cc, make, nm")

REFUSED = [  # (name, words the message must hold)
    ("osqp", "OSQP's namespace: osqp_solve"),
    ("qdldl", "OSQP's namespace"),
    ("csc", "csc_Axpy"),
    ("osqp_truck", "osqp_"),
    ("update", "update_info"),
    ("reset", "reset_info"),
    ("c", "c_absval"),
    ("casadi", "CasADi's namespace"),
    ("casadi_x", "casadi_"),
    ("sin", "C standard library"),
    ("exp", "C standard library"),
    ("sqrtf", "C standard library"),
    ("main", "C standard library"),
    ("errno", "C standard library"),
    ("printf", "C standard library"),
    ("int", "C keyword"),
    ("while", "C keyword"),
    ("restrict", "C keyword"),
    ("bool", "C keyword"),
    ("string", "'str'"),
    ("memo", "'mem'"),
    ("island", "'is'"),
    ("tokyo", "'to'"),
    ("size", "size_t"),
    ("uint8", "uint8_t"),
    ("flt", "FLT_MAX"),
    ("va", "va_list"),
    ("int_mpc", "int_fast16_t"),
    ("a_", "'__'"),
    ("a__b", "'__'"),
]


@pytest.mark.parametrize("name, words", REFUSED, ids=[r[0] for r in REFUSED])
def test_clashing_names_are_refused_with_a_one_line_message(name, words):
    with pytest.raises(ProblemError) as ei:
        Problem(name=name)
    msg = str(ei.value)
    assert msg.startswith(f"name = {name!r} is invalid: "), msg
    assert words in msg and "allowed" in msg and "\n" not in msg, msg


@pytest.mark.parametrize(
    "name",
    [
        "p",
        "a",
        "m",
        "to",
        "st",
        "truck_nmpc",
        "my_nmpc",
        "x1_2",
        "ego",
        "e1",
        "car_lift_el",
        "solver",
        "mpc_osqp",
        "nmpc_update",
    ],
)
def test_names_that_clash_with_nothing_are_accepted(name):
    assert name_clash(name) is None
    assert Problem(name=name).name == name


def test_every_preset_name_is_accepted():
    for p in preset_names():
        assert name_clash(preset(p).name) is None


def _small(name: str) -> Problem:
    """A small valid problem, then renamed past validation (what fcgen accepted before the check)."""
    pb = Problem(name="probe", horizon=Horizon(N=4), opponents=Opponents(count=1))
    object.__setattr__(pb, "name", name)
    return pb


@needs_cc
@pytest.mark.parametrize("name", ["osqp", "qdldl", "update", "reset", "casadi"])
def test_the_refused_names_really_break_the_build(name, tmp_path):
    with pytest.raises(ProblemError):
        Problem(name=name)
    generate(_small(name), tmp_path / name)
    with pytest.raises(BuildError) as ei:  # make itself (fcgen build refuses the folder earlier: its problem.py)
        run_make(tmp_path / name, ["-j2"])
    assert "error" in str(ei.value)
    if name in ("update", "reset"):  # OSQP's function <name>_info vs the workspace's OSQPInfo <prefix>info
        # (with OSQP's symbols prefixed both names are renamed alike, to <name>_<name>_info: still one clash)
        assert re.search(rf"multiple definition of `({name}_)?{name}_info'", str(ei.value))
    with pytest.raises(ProblemError, match=f"name = '{name}'"):
        build(tmp_path / name)


@pytest.fixture(scope="module")
def built(tmp_path_factory) -> Path:
    d = tmp_path_factory.mktemp("names") / "probe"
    generate(_small("probe"), d)
    build(d)  # the control: the same problem under a free name builds
    return d


def _heads(identifiers) -> set[str]:
    """First words of identifiers that can equal ours (all lower or all upper case first word)."""
    out = set()
    for i in identifiers:
        if i.startswith("_") or "_" not in i:
            continue
        h = i.split("_")[0]
        if h.islower() or h.isupper():
            out.add(h)
    return out


@needs_cc
def test_osqp_namespaces_cover_what_the_built_library_exports_and_its_headers_define(built):
    ids = set()
    for h in (built / "osqp" / "lib").rglob("*.h"):
        t = h.read_text()
        ids |= set(re.findall(r"^\s*#\s*define\s+(\w+)", t, re.M))
        ids |= set(re.findall(r"}\s*(\w+)\s*;", t))
        ids |= set(re.findall(r"typedef\s+[\w\s*]+?\b(\w+)\s*;", t))
        for body in re.findall(r"enum\s*\w*\s*{([^}]*)}", t):
            ids |= set(re.findall(r"^\s*(\w+)", body, re.M))
    nm = subprocess.run(
        ["nm", "-g", "--defined-only", str(built / "build" / "libprobe_osqp.a")],
        capture_output=True,
        text=True,
        check=True,
    ).stdout
    # OSQP's own names: the library's symbols carry the solver's prefix (probe_), the headers' names do not
    exported = {ln.split()[-1].removeprefix("probe_") for ln in nm.splitlines() if len(ln.split()) == 3}
    assert {"osqp_solve", "csc_Axpy", "QDLDL_factor", "update_info"} <= exported  # the derivation sees real symbols
    heads = _heads(ids | exported)
    assert heads - set(OSQP_NAMESPACES) == set()
    for h in heads:
        assert name_clash(h.lower()) is not None, h


@needs_cc
def test_casadi_names_are_covered(built):
    text = (built / "probe_model.c").read_text() + (built / "probe_model.h").read_text()
    ids = set(re.findall(r"^\s*#\s*(?:define|ifdef|ifndef)\s+(\w+)", text, re.M))  # macros CasADi defines or reads
    ids |= set(re.findall(r"\bCASADI_NAMESPACE_CONCAT\((\w+)", text))
    foreign = {i for i in ids if not i.startswith(("probe_", "PROBE_"))}
    heads = _heads(foreign) - set(C_LIBRARY_NAMESPACES)
    assert "casadi" in heads and heads - set(CASADI_NAMESPACES) == set()


C99_HEADERS = (
    "assert complex ctype errno fenv float inttypes iso646 limits locale math setjmp signal stdarg stdbool "
    "stddef stdint stdio stdlib string tgmath time wchar wctype"
).split()


@needs_cc
def test_c_library_sets_cover_the_c99_headers(tmp_path):
    src = tmp_path / "all.c"
    src.write_text("".join(f"#include <{h}.h>\n" for h in C99_HEADERS))
    aux = tmp_path / "aux.txt"
    subprocess.run(["cc", "-std=c99", f"-aux-info={aux}", "-fsyntax-only", str(src)], check=True)
    funcs = set(re.findall(r"\b([a-z][a-z0-9_]*) \(", aux.read_text()))
    macros = subprocess.run(
        ["cc", "-std=c99", "-E", "-dM", str(src)], capture_output=True, text=True, check=True
    ).stdout
    macro_names = {ln.split()[1].split("(")[0] for ln in macros.splitlines() if ln.startswith("#define ")}
    text = subprocess.run(["cc", "-std=c99", "-E", str(src)], capture_output=True, text=True, check=True).stdout
    types = set(re.findall(r"\b([a-z][a-z0-9]*_[a-z0-9_]*_t|[a-z][a-z0-9]*_t)\b", text))
    assert {"sin", "exp", "printf", "memcpy"} <= funcs and {"INT_MAX", "errno"} <= macro_names
    plain = {n for n in funcs | macro_names if re.fullmatch(r"[a-z][a-z0-9]*", n)}
    assert {n for n in plain if not C_RESERVED_START.match(n)} - C_LIBRARY - C99_KEYWORDS == set()
    heads = _heads({n for n in macro_names | types if re.fullmatch(r"[A-Za-z]\w*", n)})
    assert heads - set(C_LIBRARY_NAMESPACES) == set()
