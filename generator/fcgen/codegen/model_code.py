"""The CasADi C code of a problem's model functions (``<name>_model.c/.h``): every symbol prefixed with the solver's
name, CasADi's runtime helpers file-local, single precision where the solver is generated for float."""

from __future__ import annotations

import re
import tempfile
from pathlib import Path
from typing import Any

import casadi as ca

from ..ocp import Ocp
from ..plant import plant_function
from ..reference import theta_init
from .folder import write_if_changed

MODEL_CFLAGS = ("-Wno-unused-parameter",)
"""Extra flags for the CasADi-generated model file (its functions ignore iw/w/mem) with -Wall -Wextra -Werror."""

MODEL_FUNCTIONS = ("stage_first", "stage_middle", "stage_last", "init_state", "theta_init", "plant")
FIT_FUNCTIONS = ("opp_points", "opp_box")
"""The conventional formulation's opponent fit (``fcgen.oppfit``), generated only for it (``opp_box`` only for the
naive ``overapprox="none"``: the fitted box is plain C)."""
_HELPER_DEF = re.compile(r"^(casadi_real|casadi_int|void|int) (casadi_[a-z0-9_]+)\(", re.M)


def _renamed(f: ca.Function, name: str) -> ca.Function:
    """The same SX algorithm under a new name (checked: identical instruction count)."""
    x = f.sx_in()
    g = ca.Function(name, x, f.call(x), f.name_in(), f.name_out())
    if g.n_instructions() != f.n_instructions():
        raise AssertionError(f"renaming {f.name()} changed its algorithm")
    return g


def model_functions(ocp: Ocp) -> dict[str, ca.Function]:
    """The CasADi functions the C solver (and its harness) calls, by unprefixed name."""
    funs = {
        "stage_first": ocp.first.fun,
        "stage_middle": ocp.middle.fun,
        "stage_last": ocp.last.fun,
        "init_state": ocp.init_state,
        "theta_init": theta_init(ocp),
        "plan_clearance": ocp.plan_clearance,
        "plant": plant_function(ocp.problem, ocp.road_params.samples),
    }
    if ocp.fit is not None:
        funs.update(opp_points=ocp.fit.points)
        if not ocp.fit.n_edge:  # the fitted box is plain C (opp_fit.c: fit_box); the naive one's CasADi
            funs.update(opp_box=ocp.fit.box)
    return funs


C_MATH = (
    "sin",
    "cos",
    "tan",
    "asin",
    "acos",
    "atan",
    "atan2",
    "sinh",
    "cosh",
    "tanh",
    "asinh",
    "acosh",
    "atanh",
    "exp",
    "expm1",
    "log",
    "log1p",
    "log10",
    "log2",
    "pow",
    "sqrt",
    "cbrt",
    "hypot",
    "fabs",
    "fmin",
    "fmax",
    "floor",
    "ceil",
    "round",
    "trunc",
    "fmod",
    "remainder",
    "copysign",
    "erf",
    "erfc",
    "fma",
    "lgamma",
    "tgamma",
)
"""The double functions of <math.h> (C99) that have a float counterpart ``<name>f``."""
_C_MATH_CALL = re.compile(r"\b(" + "|".join(C_MATH) + r")(\s*\()")
_C_DOUBLE_LITERAL = re.compile(r"(?<![\w.])((?:\d+\.\d*|\.\d+)(?:[eE][-+]?\d+)?|\d+[eE][-+]?\d+)(?![\w.])")


def float_math(src: str) -> str:
    """CasADi's C code in single precision: ``sin`` -> ``sinf``, ... and ``2.`` -> ``2.f`` (CasADi has no option for it;
    with ``casadi_real = float`` alone it computes in double: every literal and math call promotes).

    Comments are left as they are (a version number like ``3.8.2`` is no literal: the pattern needs a number that
    neither follows nor precedes a word character or a dot).
    """
    out = []
    for part in re.split(r"(/\*.*?\*/|//[^\n]*)", src, flags=re.S):  # odd parts: comments
        if part.startswith(("/*", "//")):
            out.append(part)
        else:
            out.append(_C_DOUBLE_LITERAL.sub(r"\1f", _C_MATH_CALL.sub(r"\1f\2", part)))
    return "".join(out)


def write_model(ocp: Ocp, out_dir: Path, name: str, real: str) -> dict[str, Any]:
    """Emit ``<name>_model.c/.h``; returns the generated code's work sizes (max over functions) for static buffers."""
    funs = {k: _renamed(f, f"{name}_{k}") for k, f in model_functions(ocp).items()}
    opts: dict[str, Any] = {
        "with_header": True,
        "casadi_real": real,
        "casadi_int": "int",
        "prefix": f"{name}_",
        "with_export": False,
        "verbose": False,
        "include_math": True,
    }
    with tempfile.TemporaryDirectory() as tmp:
        cg = ca.CodeGenerator(f"{name}_model.c", opts)
        for f in funs.values():
            cg.add(f)
        cg.generate(str(Path(tmp)) + "/")
        src = (Path(tmp) / f"{name}_model.c").read_text()
        hdr = (Path(tmp) / f"{name}_model.h").read_text()
    # CasADi's runtime helpers (casadi_fmin, casadi_sq, ...) are emitted non-static: make them file-local
    src = _HELPER_DEF.sub(r"static \1 \2(", src)
    if real == "float":
        src = float_math(src)
    for text in (src, hdr):
        if tmp in text or "/tmp" in text:
            raise AssertionError("CasADi wrote a path into the model code")
    write_if_changed(out_dir / f"{name}_model.c", src)
    write_if_changed(out_dir / f"{name}_model.h", hdr)
    # the generated code's own work sizes (SX code keeps its work in locals: sz_w there is 0, not f.sz_w())
    found = re.findall(rf"^#define {name}_(\w+)_SZ_(ARG|RES|IW|W) (\d+)$", hdr, re.M)
    sz = {(fn, key): int(v) for fn, key, v in found}
    if {fn for fn, _ in sz} != set(funs):
        raise AssertionError("CasADi header without the expected work-size macros")

    def most(key: str, least: int) -> int:
        return max(least, *(v for (_, k), v in sz.items() if k == key))

    return {
        "sz_arg": most("ARG", 3),
        "sz_res": most("RES", 3),
        "sz_iw": most("IW", 1),
        "sz_w": most("W", 1),
        "functions": [f"{name}_{k}" for k in funs],
    }
