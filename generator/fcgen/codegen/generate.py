"""Turn a problem into a complete, static-memory C solver folder.

Steps: build the OCP and its QP layout; emit CasADi C code of the functions the solver needs (every symbol prefixed
with the problem name); write the QP backend's files (OSQP: its embedded workspace, prefix ``<name>_``); render
``templates/`` with every index table computed here. Same problem -> byte-identical files (no time stamps, no absolute paths).
"""
from __future__ import annotations

import dataclasses

import math
import re
import textwrap
import tempfile
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Sequence

import casadi as ca
import numpy as np

from .. import __version__
from .. import obstacles as obs
from ..dsl import Problem
from ..ocp import INF, Ocp, build_ocp
from ..qp import QpLayout, build_layout
from ..contract import HOST_TICKS_PER_SECOND
from ..backends import QP_STATUSES, QP_USABLE, BackendFiles, backend_module
from ..reference import (COLD_RESTART_NOTE, EXIT_CODES, MAX_INPUT_VIOLATION, QP_CONTRACT, QP_EXIT, cold_max_iter,  # noqa: F401 (re-exported)
                         input_box, theta_init, warm_max_iter)
from ..plant import plant_function
from ..targets import README_BEGIN, README_END, cross_targets
from .misra import MISRA_DEVIATIONS
from .folder import staged
from .render import environment, render_template


MODEL_CFLAGS = ("-Wno-unused-parameter",)
"""Extra flags for the CasADi-generated model file (its functions ignore iw/w/mem) with -Wall -Wextra -Werror."""

MACRO_DOC = {
    "NX": "states per stage", "NU": "controls per stage [F_d, r]", "N": "shooting intervals",
    "NOPP": "opponents", "NOPP_PAR": "parameters per opponent and stage (set_opponents: the pose x, y, phi)",
    "NOPP_STAGE": "parameters per opponent in a stage's parameters (its pose and shape; conventional: the fitted Frenet box)",
    "NOPP_SHAPE": "shape values per opponent (set_opponent_shapes: length, width, centre offset; containing ellipse: + semi-axes a, b)",
    "ROAD_MAX": "road samples set_road accepts at most", "ROAD_WINDOW": "road samples in a stage's local window",
    "NP": "parameters per stage", "NTHETA": "hyperplane variables per stage", "NSIGMA": "slacks per stage",
    "QP_N": "QP variables", "QP_M": "QP rows", "QP_NNZ_A": "nonzeros of the QP constraint matrix",
    "NNZ_J": "stacked stage-Jacobian nonzeros",
    "COLD_RESTART_AFTER": "unusable QPs in a row after which prepare cold-starts (qp.cold_restart_after; 0: never)",
    "RTI_BUDGET": "the most QP iterations one feedback runs, cold starts included (qp.rti_budget or the backend's default)",
    "WORKSPACE_BYTES": "static RAM on an LP64 target: solver + QP backend workspaces (+ alignment padding)", "USE_FLOAT": "1: generated for float",
}
MODEL_FUNCTIONS = ("stage_first", "stage_middle", "stage_last", "init_state", "theta_init", "plant")
FIT_FUNCTIONS = ("opp_points", "opp_box")
"""The conventional formulation's opponent fit (``fcgen.oppfit``), generated only for it (``opp_box`` only for the
naive ``overapprox="none"``: the fitted box is plain C)."""
_HELPER_DEF = re.compile(r"^(casadi_real|casadi_int|void|int) (casadi_[a-z0-9_]+)\(", re.M)


@dataclass(frozen=True)
class GenerateInfo:
    """What :func:`generate` wrote; paths are relative to ``out_dir``."""

    name: str
    out_dir: Path
    use_float: bool
    sizes: dict[str, int]           # the size macros of <name>_solver.h (without the NAME_ prefix)
    workspace_bytes: int            # static RAM (LP64): solver workspace + backend arrays + backend structs
    solver_workspace_bytes: int     # sizeof(<name>_workspace_t) on an LP64 target
    qp_array_bytes: int             # the QP backend's arrays (OSQP: its workspace arrays)
    qp_struct_bytes: int            # the QP backend's structs (OSQP: OSQP_STRUCT_BYTES)
    const_bytes: int                # our static const index tables
    files: tuple[str, ...]          # our files and the backend's problem-specific files (committed)
    library_files: tuple[str, ...]  # the backend's library copy (git-ignored, restorable)
    qp_files: BackendFiles


# --- small helpers --------------------------------------------------------------------------------------------


def _curve_speed_constants(problem: Problem) -> dict | None:
    """The curve speed's literals (``fcgen.road.curve_speed``): a_lat, its value in traffic (a_lat when that is off)
    and the clearance that means traffic, 2 decel, v_max^2; None when it is off."""
    ref, v_max = problem.reference, problem.bounds.v_max
    if ref.curve_a_lat <= 0.0:
        return None
    traffic = ref.curve_traffic_clearance > 0.0
    return {"a_lat": _c_real(ref.curve_a_lat), "two_decel": _c_real(2.0 * ref.curve_decel),
            "a_lat_traffic": _c_real(ref.curve_a_lat_traffic if traffic else ref.curve_a_lat),
            "traffic_clearance": _c_real(ref.curve_traffic_clearance), "v2_max": _c_real(v_max * v_max),
            "along": ref.curve_along_horizon}

def _c_real(x: float) -> str:
    """An exact C double literal (shortest round-trip repr)."""
    x = float(x)
    if not math.isfinite(x):
        raise ValueError(f"non-finite constant {x!r} cannot be emitted")
    return repr(x)


def _c_real_literal(x: float, use_float: bool) -> str:
    """A C literal of the solver's real type: ``0.05`` (double) or ``0.05f`` (float, rounded by the compiler)."""
    return _c_real(x) + ("f" if use_float else "")


def _c_macro_list(values: Sequence, per_line: int = 20) -> str:
    """A brace initializer as a macro's body, continued over lines of ``per_line`` values."""
    items = [str(v) for v in values]
    lines = [", ".join(items[i:i + per_line]) for i in range(0, len(items), per_line)]
    return "{" + ", \\\n  ".join(lines) + "}"


def _c_list(values: Sequence, fmt=str, per_line: int = 12) -> str:
    """Comma-separated initializer body, ``per_line`` values a line; ``0`` for an empty table (length 1)."""
    items = [fmt(v) for v in values] or ["0"]
    lines = [", ".join(items[i:i + per_line]) for i in range(0, len(items), per_line)]
    return ",\n  ".join(lines)


def _write(path: Path, text: str) -> None:
    data = text.encode()
    if not path.is_file() or path.read_bytes() != data:
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_bytes(data)


# --- CasADi model code ---------------------------------------------------------------------------------------

def _renamed(f: ca.Function, name: str) -> ca.Function:
    """The same SX algorithm under a new name (checked: identical instruction count)."""
    x = f.sx_in()
    g = ca.Function(name, x, f.call(x), f.name_in(), f.name_out())
    if g.n_instructions() != f.n_instructions():
        raise AssertionError(f"renaming {f.name()} changed its algorithm")
    return g


def model_functions(ocp: Ocp) -> dict[str, ca.Function]:
    """The CasADi functions the C solver (and its harness) calls, by unprefixed name."""
    funs = {"stage_first": ocp.first.fun, "stage_middle": ocp.middle.fun, "stage_last": ocp.last.fun,
            "init_state": ocp.init_state, "theta_init": theta_init(ocp), "plan_clearance": ocp.plan_clearance,
            "plant": plant_function(ocp.problem, ocp.road_params.samples)}
    if ocp.fit is not None:
        funs.update(opp_points=ocp.fit.points)
        if not ocp.fit.n_edge:  # the fitted box is plain C (opp_fit.c: fit_box); the naive one's CasADi
            funs.update(opp_box=ocp.fit.box)
    return funs


C_MATH = ("sin", "cos", "tan", "asin", "acos", "atan", "atan2", "sinh", "cosh", "tanh", "asinh", "acosh", "atanh",
          "exp", "expm1", "log", "log1p", "log10", "log2", "pow", "sqrt", "cbrt", "hypot", "fabs", "fmin", "fmax",
          "floor", "ceil", "round", "trunc", "fmod", "remainder", "copysign", "erf", "erfc", "fma", "lgamma", "tgamma")
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


def _write_model(ocp: Ocp, out_dir: Path, name: str, real: str) -> dict[str, Any]:
    """Emit ``<name>_model.c/.h``; returns the generated code's work sizes (max over functions) for static buffers."""
    funs = {k: _renamed(f, f"{name}_{k}") for k, f in model_functions(ocp).items()}
    opts = {"with_header": True, "casadi_real": real, "casadi_int": "int", "prefix": f"{name}_",
            "with_export": False, "verbose": False, "include_math": True}
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
    _write(out_dir / f"{name}_model.c", src)
    _write(out_dir / f"{name}_model.h", hdr)
    # the generated code's own work sizes (SX code keeps its work in locals: sz_w there is 0, not f.sz_w())
    found = re.findall(rf"^#define {name}_(\w+)_SZ_(ARG|RES|IW|W) (\d+)$", hdr, re.M)
    sz = {(fn, key): int(v) for fn, key, v in found}
    if {fn for fn, _ in sz} != set(funs):
        raise AssertionError("CasADi header without the expected work-size macros")

    def most(key: str, least: int) -> int:
        return max(least, *(v for (_, k), v in sz.items() if k == key))

    return {"sz_arg": most("ARG", 3), "sz_res": most("RES", 3), "sz_iw": most("IW", 1), "sz_w": most("W", 1),
            "functions": [f"{name}_{k}" for k in funs]}


# --- tables ---------------------------------------------------------------------------------------------------

def stage_table(ocp: Ocp, lay: QpLayout) -> list[dict[str, Any]]:
    """Per-stage descriptors: function kind and the offsets of its variables, rows, Jacobian, successor state."""
    N, nx, nu = ocp.N, ocp.nx, ocp.nu
    v_ref = ocp.problem.reference.v_ref
    times = ocp.problem.horizon.times
    out = []
    for k in range(N + 1):
        st = ocp.stage(k)
        var = int(lay.var_off[k])
        names = st.var_names
        out.append({
            "k": k,
            "kind": "STAGE_" + st.name.upper(),
            "var": var,
            "row": int(lay.row_off[k]),
            "jac": int(lay.jac_off[k]),
            "next": int(lay.var_off[k + 1]) if k < N else -1,
            "s": int(lay.s_vars[k]),
            "u": var + names.index("F_d") if k < N else -1,
            "theta": var + nx + nu * (k < N) if (k >= 1 and ocp.n_theta) else -1,
            "sigma": var + names.index("sigma0") if "sigma0" in names else -1,
            "s_ref": _c_real(times[k] * v_ref),  # the reference's s_ref offset, same rounding
            "t": _c_real(times[k]),  # the node's time (Horizon.times), also the cold-start guess's
        })
        assert names[0] == "s" and out[-1]["s"] == var
        if k < N:
            assert names[nx:nx + nu] == ("F_d", "r") and out[-1]["u"] == var + nx
    return out


def slack_vars(ocp: Ocp, lay: QpLayout) -> np.ndarray:
    """Indices of the slack variables of stages 1..N (the reference's ``slacks()``)."""
    return np.concatenate([np.arange(lay.var_off[k + 1] - ocp.n_sigma, lay.var_off[k + 1])
                           for k in range(1, ocp.N + 1)]).astype(np.int64)


def far_opponent_row(ocp: Ocp) -> np.ndarray:
    """Parameters of one opponent far away from any ego position on the example's straight road."""
    return np.array([-1000.0, 500.0, 0.0])  # every formulation takes poses; the conventional one leaves it out


def fit_context(ocp: Ocp) -> dict[str, Any] | None:
    """Constants of the conventional opponent fit for the template (``None`` for the other formulations)."""
    from .. import oppfit
    f = ocp.fit
    if f is None:
        return None
    if oppfit.FULL_EVALS < 1:
        raise AssertionError("the C fit takes n and phi_gamma from a road evaluation: FULL_EVALS >= 1")
    return {"npt": f.npt, "ref": f.ref_point, "search": oppfit.SEARCH, "window": oppfit.FOOT_WINDOW,
            "nbox": len(oppfit.BOX), "nedge": f.n_edge, "nev": len(oppfit.EVAL), "par": ocp.n_opp_stage,
            "sixth": _c_real(1.0 / 6.0),
            "full": oppfit.FULL_EVALS, "rot_max": _c_real(oppfit.ROT_MAX),
            "sin_c": [_c_real(c) for c in oppfit.SIN_C], "cos_c": [_c_real(c) for c in oppfit.COS_C],
            "dg_min": _c_real(oppfit.NEWTON_DG_MIN), "counts": f.counts, "margin": _c_real(f.margin),
            "reach": _c_real(f.reach), "far_base": _c_real(f.far_base), "sag_safety": _c_real(oppfit.SAG_SAFETY),
            "n_opp_stage": max(1, ocp.problem.opponents.count * ocp.n_opp_stage),
            "stretch_max": _c_real(oppfit.STRETCH_MAX), "n_min": _c_real(f.n_min), "n_max": _c_real(f.n_max),
            "neutral": [_c_real(v) for v in oppfit.neutral(0.0)]}


def permutation_cycles(src: np.ndarray) -> np.ndarray:
    """One start index per non-trivial cycle of the permutation ``i -> src[i]`` (to apply ``v[i] = v[src[i]]`` in
    place: follow each cycle from its start, one saved value per cycle)."""
    src = np.asarray(src, dtype=np.int64)
    if sorted(src.tolist()) != list(range(len(src))):
        raise AssertionError("A_SRC is no permutation of the stacked Jacobian: A_x cannot share its memory")
    seen = np.zeros(len(src), dtype=bool)
    starts = []
    for i0 in range(len(src)):
        if seen[i0] or src[i0] == i0:
            seen[i0] = True
            continue
        starts.append(i0)
        i = i0
        while not seen[i]:
            seen[i] = True
            i = int(src[i])
    return np.array(starts, dtype=np.int64)


# --- sizes -------------------------------------------------------------------------------------------------------

def size_macros(ocp: Ocp, lay: QpLayout) -> dict[str, int]:
    """The size macros of ``<name>_solver.h`` (keys without the ``NAME_`` prefix), in header order."""
    pb = ocp.problem
    return {"NX": ocp.nx, "NU": ocp.nu, "N": ocp.N, "NOPP": pb.opponents.count, "NOPP_PAR": ocp.n_opp_par,
            "NOPP_STAGE": ocp.n_opp_stage, "NOPP_SHAPE": ocp.n_opp_shape, "ROAD_MAX": pb.road.samples, "ROAD_WINDOW": ocp.road_params.samples, "NP": ocp.np_stage,
            "NTHETA": ocp.n_theta, "NSIGMA": ocp.n_sigma, "QP_N": lay.n, "QP_M": lay.m, "QP_NNZ_A": lay.nnz_A,
            "NNZ_J": int(lay.jac_off[-1]), "COLD_RESTART_AFTER": pb.qp.cold_restart_after,
            "RTI_BUDGET": cold_max_iter(pb.qp)}


def problem_sizes(problem: Problem) -> dict[str, int]:
    """The size macros a solver generated from ``problem`` has (builds the OCP and its layout)."""
    ocp = build_ocp(problem)
    return size_macros(ocp, build_layout(ocp))


def _struct_size(members: Sequence[tuple[int, int, int]]) -> int:
    """sizeof a C struct of (size, align, count) members, with natural padding."""
    off, align_max = 0, 1
    for size, align, count in members:
        off = -(-off // align) * align + size * count
        align_max = max(align_max, align)
    return -(-off // align_max) * align_max


def status_layout(real_size: int) -> tuple[int, int]:
    """sizeof and alignment of ``<name>_status_t``: 11 ints, 2 reals (u_violation, plan_clearance), 2 uint32 ticks."""
    members = [(4, 4, 11), (real_size, real_size, 2), (4, 4, 2)]
    return _struct_size(members), max(a for _, a, _ in members)

FIRST_STATE_MEMBER = "w"
"""The first workspace member reset() zeroes (the inputs and the clock come before it)."""


def workspace_members(name: str, sizes: dict[str, int], work: dict, real_size: int,
                      opp_dim: int, fit: dict | None = None, n_band: int = 0,
                      curve: bool = False) -> tuple[list[dict[str, Any]], int]:
    """Members of ``<name>_workspace_t`` for the template, and its sizeof on an LP64 target (natural padding)."""
    NAME = name.upper()
    R, I, P = (real_size, real_size), (4, 4), (8, 8)

    def M(key: str, extra: int = 0):  # a dimension written as the public size macro
        return (f"{NAME}_{key}" + (f" + {extra}" if extra else ""), sizes[key] + extra)

    road, n, m, nnz = M("ROAD_MAX"), M("QP_N"), M("QP_M"), M("QP_NNZ_A")
    members = [  # (C type, name, dims, (size, align)); a dim is an int or (C expression, int)
        # inputs (kept by reset) and the clock ...
        ("NAME_real_t", "x0", [5], R), ("NAME_real_t", "road_s0", [], R), ("NAME_real_t", "road_ds", [], R),
        ("NAME_real_t", "road_kappa", [road], R), ("NAME_real_t", "road_phi", [road], R),
        ("NAME_real_t", "road_gx", [road], R), ("NAME_real_t", "road_gy", [road], R),
        ("NAME_real_t", "road_nmin", [road], R), ("NAME_real_t", "road_nmax", [road], R),
        ("NAME_real_t", "opp", [M("N", 1), ("OPP_DIM", opp_dim)], R),
        ("NAME_real_t", "opp_shape", [("SHAPE_DIM", max(1, sizes["NOPP"] * sizes["NOPP_SHAPE"]))], R),
        ("clock_fn_t", "clock", [], P), ("int", "road_n", [], I), ("int", "road_set", [], I),
        ("NAME_real_t", "ref_v", [], R), ("NAME_real_t", "ref_n", [], R),
        ("int", "road_band", [], I), ("int", "opp_shape_set", [], I), ("int", "ref_set", [], I),
        ("int", "have_x0", [], I),
        # ... then everything reset() zeroes, from FIRST_STATE_MEMBER on
        ("NAME_real_t", "w", [n], R), ("NAME_real_t", "y", [m], R), ("NAME_real_t", "s0_guess", [], R),
        ("NAME_real_t", "w_tmp", [n], R),
        ("NAME_real_t", "p", [M("NP")], R), ("NAME_real_t", "p_fb", [M("NP")], R),
        ("NAME_real_t", "g_init", [M("NX")], R), ("NAME_real_t", "jac", [nnz], R),
        ("NAME_real_t", "q", [n], R), ("NAME_real_t", "q_fb", [n], R),
        ("NAME_real_t", "l", [m], R), ("NAME_real_t", "u", [m], R),
        ("NAME_real_t", "u_applied", [M("NU")], R),
        ("NAME_real_t", "band_val", [("N_BAND", max(1, n_band))], R),
        ("NAME_real_t", "xa", [M("NX")], R),
        ("const casadi_real *", "arg", [("CASADI_SZ_ARG", work["sz_arg"])], P),
        ("casadi_real *", "res", [("CASADI_SZ_RES", work["sz_res"])], P),
        ("casadi_int", "iw", [("CASADI_SZ_IW", work["sz_iw"])], I),
        ("casadi_real", "cw", [("CASADI_SZ_W", work["sz_w"])], R),
        ("const NAME_real_t *", "q_cur", [], P), ("const NAME_real_t *", "qp_z", [], P),
        ("NAME_status_t", "status", [], status_layout(real_size)),
        ("int", "have_guess", [], I), ("int", "prepared", [], I), ("int", "cold", [], I), ("int", "qp_ready", [], I),
        ("int", "fit_outside", [], I),
    ]
    if curve:  # the curve reference per node (Reference.curve_a_lat): a / |kappa| per road sample, s_ref, v_ref
        members += [("NAME_real_t", "curve_c", [road], R),
                    ("NAME_real_t", "curve_s", [M("N", 1)], R), ("NAME_real_t", "curve_v", [M("N", 1)], R)]
    if fit:  # the conventional opponent fit: fitted stage parameters and one opponent's scratch
        members += [("NAME_real_t", "opp_stage", [M("N", 1), fit["n_opp_stage"]], R),
                    ("NAME_real_t", "fit_P", [2 * fit["npt"]], R), ("NAME_real_t", "fit_d", [fit["npt"]], R),
                    ("NAME_real_t", "fit_fr", [3 * fit["npt"]], R),
                    ("NAME_real_t", "fit_box", [fit["nbox"]], R),
                    ("NAME_real_t", "fit_hmax", [], R), ("NAME_real_t", "fit_ihmax", [], R),
                    ("NAME_real_t", "fit_skip", [], R), ("NAME_real_t", "fit_uni", [], R),
                    ("NAME_real_t", "fit_cos", [road], R), ("NAME_real_t", "fit_sin", [road], R)]
        members += [("NAME_real_t", f"fit_{d}_{q}", [road], R) for d in ("dd", "d3") for q in ("phi", "x", "y")]
        wide = (f"{NAME}_ROAD_MAX + {2 * fit['search']}", sizes["ROAD_MAX"] + 2 * fit["search"])
        members += [("NAME_real_t", "fit_rsq", [wide], R), ("NAME_real_t", "fit_beta", [wide], R)]
    size = _struct_size([(sa[0], sa[1], int(np.prod([x[1] if isinstance(x, tuple) else x for x in d])))
                         for _, _, d, sa in members])
    rendered = [{"ctype": t.replace("NAME_", f"{name}_"), "name": nm,
                 "dims": [x[0] if isinstance(x, tuple) else x for x in d]} for t, nm, d, _ in members]
    return rendered, size


# --- the generator -------------------------------------------------------------------------------------------

def problem_source(obj: Any, indent: int = 0) -> str:
    """Python source that rebuilds a DSL object: one init field per line, so the folder records its problem."""
    if not dataclasses.is_dataclass(obj):
        return repr(obj)
    pad = " " * (indent + 4)
    args = [f"{pad}{f.name}={problem_source(getattr(obj, f.name), indent + 4)}"
            for f in dataclasses.fields(obj) if f.init]
    if not args:
        return f"{type(obj).__name__}()"
    return f"{type(obj).__name__}(\n" + ",\n".join(args) + ")"


def shift_statement(dst: str, src: str, table: str, fraction: float, split: int, name: str) -> str:
    """The C statement that shifts entry i of a plan or its duals by one sample (``qp.shifted``: the next stage's
    entry, or beyond ``split`` a ``fraction`` of the way to it where an interval is several samples)."""
    exact = f"{src}[{table}[i]]"
    if fraction == 1.0:
        return f"{dst}[i] = {exact};"
    moved = f"{src}[i] + ((({name}_real_t){_c_real(fraction)}) * ({src}[{table}[i]] - {src}[i]))"
    return f"{dst}[i] = {moved};" if split == 0 else f"{dst}[i] = (i < {split}) ? {exact} : ({moved});"


def _wrap_comment(text: str, width: int) -> list[str]:
    """A paragraph as C comment lines: the first ``width`` wide, the rest 2 narrower (the template indents them)."""
    first, *rest = textwrap.wrap(text, width)
    return [first, *textwrap.wrap(" ".join(rest), width - 2)]


def toolchain_files(use_float: bool) -> dict[str, str]:
    """The CMake toolchain files a folder ships: one per bare-metal target that can run its precision."""
    return {f"cmake/arm-none-eabi-{t.name}.cmake": render_template("targets/toolchain.cmake.j2", target=t)
            for t in cross_targets(use_float)}


def generate(problem: Problem, out_dir: Path | str, use_float: bool = False, force: bool = False,
             check_edits: bool = True) -> GenerateInfo:
    """Write the C solver of ``problem`` into ``out_dir``; returns what was written.

    The folder is written beside ``out_dir`` and moved into place when complete (:mod:`.folder`): a failed or
    interrupted generation leaves ``out_dir`` as it was. A folder holding another solver (or files that are no
    solver's) raises :class:`~.folder.FolderError` unless ``force`` (then the old solver's files are removed), and so
    does a file of the same solver changed since it was generated (``check_edits``; ``fcgen regenerate`` turns it off:
    its folders are under version control, and restoring generator output is its job).
    """
    with staged(out_dir, problem.name, force, check_edits) as tmp:
        info = _generate_into(problem, tmp, use_float)
    return dataclasses.replace(info, out_dir=Path(out_dir))


def _generate_into(problem: Problem, out_dir: Path, use_float: bool) -> GenerateInfo:
    """Write every file of the solver into the (new, empty) folder ``out_dir``."""
    name = problem.name
    NAME = name.upper()
    ocp = build_ocp(problem)
    lay = build_layout(ocp)
    real = "float" if use_float else "double"
    real_size = 4 if use_float else 8
    nx = ocp.nx
    n_opp, n_opp_par = problem.opponents.count, ocp.n_opp_par
    rp = ocp.road_params

    work = _write_model(ocp, out_dir, name, real)

    backend = backend_module(problem.qp.backend)
    qp_files = backend.write_files(ocp, lay, problem.qp, out_dir, use_float)
    static_libs = [f"lib{name}.a", *([f"lib{name}_{qp_files.library.suffix}.a"] if qp_files.library else [])]

    # -- sizes (public macros) and private dimensions -----------------------------------------------------------
    sizes = size_macros(ocp, lay)
    slacks = slack_vars(ocp, lay)
    n_opp_all = max(1, n_opp * n_opp_par)
    if sizes["NNZ_J"] != sizes["QP_NNZ_A"]:
        raise AssertionError("stacked Jacobian and A differ in size: A_x cannot share the Jacobian's memory")
    if np.any(lay.row_shift < np.arange(lay.m)):
        raise AssertionError("a row's shifted dual comes from an earlier row: feedback cannot shift y in place")
    a_cycles = permutation_cycles(lay.a_src)
    index_tables = {"A_SRC": lay.a_src, "A_CYCLES": a_cycles,
                    "VAR_SHIFT": lay.var_shift, "ROW_SHIFT": lay.row_shift,
                    "INIT_ROWS": lay.init_rows, "SLACK_VARS": slacks,
                    "BAND_ROW": lay.band_rows[:, 0], "BAND_STAGE": lay.band_rows[:, 1],
                    "BAND_SIDE": lay.band_rows[:, 2]}
    top = max(int(np.max(t, initial=0)) for t in index_tables.values())
    index_ctype, index_size = ("uint16_t", 2) if top < 2**16 else ("uint32_t", 4)
    u_lo, u_hi, u_lim = input_box(problem)
    real_tables = {"P_DIAG": lay.P_diag, "L": lay.L, "U": lay.U, "D": lay.D, "Q_DS0": lay.q_ds0,
                   "INIT_D": lay.D[:nx], "U_LO": u_lo, "U_HI": u_hi, "U_LIM": u_lim,
                   "SHAPE_DEFAULT": ocp.default_shapes().ravel()}
    if ocp.p_dt is not None:   # unequal intervals: each stage's length is a parameter (Ocp.stage_dt)
        real_tables["STAGE_DT"] = ocp.stage_dt()
    for t in (lay.L, lay.U):
        if np.any(np.abs(t) > INF):
            raise AssertionError("bounds beyond the QP infinity INF")
    stages = stage_table(ocp, lay)

    fit = fit_context(ocp)
    curve = _curve_speed_constants(problem)
    ws_members, ws_bytes = workspace_members(name, sizes, work, real_size, n_opp_all, fit, len(lay.band_rows),
                                             curve=curve is not None)
    const_bytes = (sum(len(t) for t in index_tables.values()) * index_size
                   + sum(len(t) for t in real_tables.values()) * real_size
                   + len(stages) * (8 * 4 + real_size * (1 if curve is not None else 2)))   # stage_t: 8 ints, t, s_ref
    workspace_bytes = ws_bytes + qp_files.array_bytes + qp_files.struct_bytes

    values = {**sizes, "WORKSPACE_BYTES": workspace_bytes, "USE_FLOAT": int(use_float)}
    macro_doc = {**MACRO_DOC, "NX": f"states per stage ({', '.join(ocp.first.var_names[:nx])})"}
    macros = [{"key": k, "value": v, "doc": macro_doc[k]} for k, v in values.items()]
    opp_names = obs.CARTESIAN_POSE
    ctx = {
        "name": name, "NAME": NAME, "version": __version__, "real": real, "use_float": use_float,
        "sizes": sizes, "macros": macros, "exit_codes": list(enumerate(EXIT_CODES)),
        "qp_statuses": list(enumerate(QP_STATUSES, start=1)), "n_qp_statuses": len(QP_STATUSES),
        "qp_usable": [QP_STATUSES[s - 1] for s in QP_USABLE],
        "qp_exit": [(0, QP_EXIT[0])] + [(f"{NAME}_{QP_STATUSES[s - 1]}", QP_EXIT[s])
                                        for s in range(1, len(QP_STATUSES) + 1)],
        "qp_contract": QP_CONTRACT, "max_input_violation": _c_real(MAX_INPUT_VIOLATION),
        "max_input_violation_c": _c_real_literal(MAX_INPUT_VIOLATION, use_float),
        "cold_restart_note": COLD_RESTART_NOTE.replace("COLD_RESTART_AFTER", f"{NAME}_COLD_RESTART_AFTER"),
        "cold_restart_lines": _wrap_comment(f"Cold restart: {COLD_RESTART_NOTE}.".replace(
            "COLD_RESTART_AFTER", f"{NAME}_COLD_RESTART_AFTER"), 114),
        "first_state_member": FIRST_STATE_MEMBER, "host_ticks_per_second": HOST_TICKS_PER_SECOND,
        "problem": problem, "formulation": problem.formulation.kind, "obstacles": problem.obstacles.kind,
        "opp_params": ", ".join(opp_names),
        "workspace_bytes": workspace_bytes, "solver_workspace_bytes": ws_bytes,
        "qp_array_bytes": qp_files.array_bytes, "qp_struct_bytes": qp_files.struct_bytes,
        "const_bytes": const_bytes, "ws_members": ws_members, "work": work,
        "misra_deviations": MISRA_DEVIATIONS, "c_floor": "floorf" if use_float else "floor", "c_cos": "cosf" if use_float else "cos",
        "c_sin": "sinf" if use_float else "sin", "c_sqrt": "sqrtf" if use_float else "sqrt",
        "c_fabs": "fabsf" if use_float else "fabs", "c_fmin": "fminf" if use_float else "fmin", "c_atan2": "atan2f" if use_float else "atan2",
        "c_tan": "tanf" if use_float else "tan", "c_atan": "atanf" if use_float else "atan",
        "c_copysign": "copysignf" if use_float else "copysign",
        "index_ctype": index_ctype, "opp_dim": n_opp_all, "n_a_cycles": len(a_cycles), "fit": fit,
        "n_opp_stage": n_opp * ocp.n_opp_stage, "stage_opp": "ws.opp_stage" if fit else None,
        "shape_dim": max(1, n_opp * ocp.n_opp_shape), "n_band": len(lay.band_rows), "band_scale": _c_real(lay.band_scale),
        "n_min": _c_real(problem.bounds.n_min), "n_max": _c_real(problem.bounds.n_max),
        "shape_axes": ocp.n_opp_shape > len(obs.OPP_SHAPE), "ego_radius": _c_real(obs.ego_radius(problem.ego)),
        "index_tables": {k: {"len": max(1, len(v)), "body": _c_list([int(x) for x in v])}
                         for k, v in index_tables.items()},
        "real_tables": {k: {"len": max(1, len(v)), "body": _c_list(v, _c_real, 6)} for k, v in real_tables.items()},
        "n_slack": len(slacks), "stages": stages,
        "p_road": {"S0": 0, "DS": 1, "KAPPA": 2, "PHI": 2 + rp.samples, "GX": 2 + 2 * rp.samples,
                   "GY": 2 + 3 * rp.samples},
        "p_ref": ocp.p_ref.start, "p_opp": ocp.p_opp.start,
        "n_ref": _c_real(problem.reference.n_ref), "v_ref": _c_real(problem.reference.v_ref),
        "curve": curve,
        "dt": _c_real(problem.horizon.interval),
        "p_dt": ocp.p_dt,
        "stage_offsets": _c_macro_list(problem.horizon.offsets),
        # node k's time in set_reference's s_ref,k: k DT on a uniform grid (the same rounding as k * interval)
        "ref_time": f"(({name}_real_t)k * DT)" if ocp.p_dt is None else "STAGES[k].t",
        "shift_vars": shift_statement("ws.w_tmp", "ws.w", "VAR_SHIFT", lay.shift_fraction, lay.shift_split_var, name),
        "shift_duals": shift_statement("ws.y", "ws.y", "ROW_SHIFT", lay.shift_fraction, lay.shift_split_row, name),
        "max_iter": warm_max_iter(problem.qp), "max_iter_cold": cold_max_iter(problem.qp), "qp_infty": _c_real(INF),
        "react_stages": min(problem.plan_check.react_stages, problem.horizon.N),
        "brake_m_per_dt": _c_real(problem.ego.m / problem.horizon.dt),
        "a_lat_guard": int(problem.plan_check.a_lat_guard), "sample_dt": _c_real(problem.horizon.dt),
        "wheelbase": _c_real(problem.ego.l), "a_lat_max": _c_real(problem.bounds.a_lat_max),
        "a_lat_guard_to": _c_real(problem.bounds.a_lat_max - problem.bounds.a_lat_margin),
        "qp_files": qp_files, "qp_lib": qp_files.library, "static_libs": static_libs,
        "make_products": ", ".join(["static library", *([f"{qp_files.library.label} library"] if qp_files.library
                                                         else []), "shared library", "example"]),
        "model_cflags": MODEL_CFLAGS,
        "backend": backend.codegen_context(ocp, lay, problem.qp),
        "backend_template": f"backends/{problem.qp.backend}.c.j2", "backend_label": backend.LABEL,
        "far_opp": _c_list(far_opponent_row(ocp), _c_real), "road_ds": _c_real(problem.road.ds),
        "cross_targets": cross_targets(use_float),
        "footprint_marker_begin": README_BEGIN, "footprint_marker_end": README_END,
    }
    env = environment()
    outputs = {
        f"{name}_solver.h": "solver.h.j2", f"{name}_solver.c": "solver.c.j2", f"{name}_host.h": "host.h.j2",
        f"{name}_host.c": "host.c.j2", "main.c": "main.c.j2", "CMakeLists.txt": "CMakeLists.txt.j2",
        "Makefile": "Makefile.j2", "README.md": "README.md.j2",
    }
    for fname, tpl in outputs.items():
        _write(out_dir / fname, env.get_template(tpl).render(**ctx))
    toolchains = toolchain_files(use_float)
    for fname, text in toolchains.items():
        _write(out_dir / fname, text)
    _write(out_dir / "problem.py",
           f'"""The problem of solver {name!r}, written by fcgen {__version__}: `fcgen verify` and `fcgen bench` '
           f'load it."""\nfrom fcgen.dsl import *  # noqa: F401,F403\n\nproblem = {problem_source(problem)}\n')
    lib_files = (*qp_files.library_sources, *qp_files.library_headers)
    files = tuple(sorted([*outputs, *toolchains, "problem.py", f"{name}_model.c", f"{name}_model.h",
                          *qp_files.sources, *qp_files.headers]))
    return GenerateInfo(name=name, out_dir=out_dir, use_float=use_float, sizes=sizes,
                        workspace_bytes=workspace_bytes, solver_workspace_bytes=ws_bytes,
                        qp_array_bytes=qp_files.array_bytes, qp_struct_bytes=qp_files.struct_bytes,
                        const_bytes=const_bytes, files=files, library_files=lib_files, qp_files=qp_files)
