"""Turn a problem into a complete, static-memory C solver folder.

Steps: build the OCP and its QP layout; emit CasADi C code of the functions the solver needs (every symbol prefixed
with the problem name, :mod:`.model_code`); write the QP backend's files (OSQP: its embedded workspace, prefix
``<name>_``; :mod:`.qp_backend`); render ``templates/`` with every index table computed here and in :mod:`.tables`.
Same problem -> byte-identical files (no time stamps, no absolute paths).
"""

from __future__ import annotations

import dataclasses
import textwrap
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from .. import __version__, reactions
from .. import obstacles as obs
from ..backends import QP_STATUSES, QP_USABLE, BackendFiles, backend_module
from ..c_literals import c_list, c_macro_list, c_real, c_real_literal
from ..contract import HOST_TICKS_PER_SECOND, INPUT_RANGES
from ..dsl import Problem
from ..ocp import INF, Ocp, build_ocp
from ..plan_check import has_f_last, lag_constants, tyre_k
from ..qp import QpLayout, build_layout
from ..reference import (
    COLD_RESTART_NOTE,
    EXIT_CODES,
    MAX_INPUT_VIOLATION,
    QP_CONTRACT,
    QP_EXIT,
    cold_max_iter,
    input_box,
    warm_max_iter,
)
from ..stage_inputs import margin_meaning, margin_terms
from ..targets import README_BEGIN, README_END, cross_targets
from .folder import staged, write_if_changed
from .misra import MISRA_DEVIATIONS
from .model_code import MODEL_CFLAGS, write_model
from .qp_backend import backend_c
from .render import environment, render_template
from .tables import curve_speed_constants, far_opponent_row, fit_context, permutation_cycles, slack_vars, stage_table
from .workspace import FIRST_STATE_MEMBER, workspace_members

MACRO_DOC = {
    "NX": "states per stage",
    "NU": "controls per stage [F_d, r]",
    "N": "shooting intervals",
    "NOPP": "opponents",
    "NOPP_PAR": "parameters per opponent and stage (set_opponents: the pose x, y, phi)",
    "NOPP_STAGE": "parameters per opponent in a stage's parameters (its pose and shape; "
    "conventional: the fitted Frenet box)",
    "NOPP_SHAPE": "shape values per opponent (set_opponent_shapes: length, width, centre offset; "
    "containing ellipse: + semi-axes a, b)",
    "ROAD_MAX": "road samples set_road accepts at most",
    "ROAD_WINDOW": "road samples in a stage's local window",
    "NP": "parameters per stage",
    "NTHETA": "hyperplane variables per stage",
    "NSIGMA": "slacks per stage",
    "QP_N": "QP variables",
    "QP_M": "QP rows",
    "QP_NNZ_A": "nonzeros of the QP constraint matrix",
    "NNZ_J": "stacked stage-Jacobian nonzeros",
    "COLD_RESTART_AFTER": "unusable QPs in a row after which prepare cold-starts (qp.cold_restart_after; 0: never)",
    "RTI_BUDGET": "the most QP iterations one feedback runs, cold starts included "
    "(qp.rti_budget or the backend's default)",
    "WORKSPACE_BYTES": "static RAM on an LP64 target: solver + QP backend workspaces (+ alignment padding)",
    "USE_FLOAT": "1: generated for float",
}


@dataclass(frozen=True)
class GenerateInfo:
    """What :func:`generate` wrote; paths are relative to ``out_dir``."""

    name: str
    out_dir: Path
    use_float: bool
    sizes: dict[str, int]  # the size macros of <name>_solver.h (without the NAME_ prefix)
    workspace_bytes: int  # static RAM (LP64): solver workspace + backend arrays + backend structs
    solver_workspace_bytes: int  # sizeof(<name>_workspace_t) on an LP64 target
    qp_array_bytes: int  # the QP backend's arrays (OSQP: its workspace arrays)
    qp_struct_bytes: int  # the QP backend's structs (OSQP: OSQP_STRUCT_BYTES)
    const_bytes: int  # our static const index tables
    files: tuple[str, ...]  # our files and the backend's problem-specific files (committed)
    library_files: tuple[str, ...]  # the backend's library copy (git-ignored, restorable)
    qp_files: BackendFiles


# --- sizes -------------------------------------------------------------------------------------------------------


def size_macros(ocp: Ocp, lay: QpLayout) -> dict[str, int]:
    """The size macros of ``<name>_solver.h`` (keys without the ``NAME_`` prefix), in header order."""
    pb = ocp.problem
    return {
        "NX": ocp.nx,
        "NU": ocp.nu,
        "N": ocp.N,
        "NOPP": pb.opponents.count,
        "NOPP_PAR": ocp.n_opp_par,
        "NOPP_STAGE": ocp.n_opp_stage,
        "NOPP_SHAPE": ocp.n_opp_shape,
        "ROAD_MAX": pb.road.samples,
        "ROAD_WINDOW": ocp.road_params.samples,
        "NP": ocp.np_stage,
        "NTHETA": ocp.n_theta,
        "NSIGMA": ocp.n_sigma,
        "QP_N": lay.n,
        "QP_M": lay.m,
        "QP_NNZ_A": lay.nnz_A,
        "NNZ_J": int(lay.jac_off[-1]),
        "COLD_RESTART_AFTER": pb.qp.cold_restart_after,
        "RTI_BUDGET": cold_max_iter(pb.qp),
    }


def problem_sizes(problem: Problem) -> dict[str, int]:
    """The size macros a solver generated from ``problem`` has (builds the OCP and its layout)."""
    ocp = build_ocp(problem)
    return size_macros(ocp, build_layout(ocp))


def problem_source(obj: Any, indent: int = 0) -> str:
    """Python source that rebuilds a DSL object: one init field per line, so the folder records its problem."""
    if not dataclasses.is_dataclass(obj):
        return repr(obj)
    pad = " " * (indent + 4)
    args = [
        f"{pad}{f.name}={problem_source(getattr(obj, f.name), indent + 4)}"
        for f in dataclasses.fields(obj)
        if f.init and not (f.metadata.get("omit_default") and getattr(obj, f.name) == f.default)
    ]
    if not args:
        return f"{type(obj).__name__}()"
    return f"{type(obj).__name__}(\n" + ",\n".join(args) + ")"


def shift_statement(dst: str, src: str, table: str, fraction: float, split: int, name: str) -> str:
    """The C statement that shifts entry i of a plan or its duals by one sample (``qp.shifted``: the next stage's
    entry, or beyond ``split`` a ``fraction`` of the way to it where an interval is several samples)."""
    exact = f"{src}[{table}[i]]"
    if fraction == 1.0:
        return f"{dst}[i] = {exact};"
    moved = f"{src}[i] + ((({name}_real_t){c_real(fraction)}) * ({src}[{table}[i]] - {src}[i]))"
    return f"{dst}[i] = {moved};" if split == 0 else f"{dst}[i] = (i < {split}) ? {exact} : ({moved});"


def _wrap_comment(text: str, width: int) -> list[str]:
    """A paragraph as C comment lines: the first ``width`` wide, the rest 2 narrower (the template indents them)."""
    first, *rest = textwrap.wrap(text, width)
    return [first, *textwrap.wrap(" ".join(rest), width - 2)]


def toolchain_files(use_float: bool) -> dict[str, str]:
    """The CMake toolchain files a folder ships: one per bare-metal target that can run its precision."""
    return {
        f"cmake/arm-none-eabi-{t.name}.cmake": render_template("targets/toolchain.cmake.j2", target=t)
        for t in cross_targets(use_float)
    }


def generate(
    problem: Problem, out_dir: Path | str, use_float: bool = False, force: bool = False, check_edits: bool = True
) -> GenerateInfo:
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
    ocp = build_ocp(problem)
    lay = build_layout(ocp)
    work = write_model(ocp, out_dir, name, "float" if use_float else "double")
    qp_c = backend_c(problem.qp.backend)
    qp_files = qp_c.write_files(ocp, lay, problem.qp, out_dir, use_float)
    tab = _tables(problem, ocp, lay)
    mem = _memory(problem, ocp, lay, tab, work, qp_files, use_float)
    ctx = {
        **_solver_context(problem, ocp, tab, mem, qp_files, use_float),
        **_problem_context(problem, ocp, lay),
        "backend": qp_c.codegen_context(ocp, lay, problem.qp),
        "backend_template": f"backends/{problem.qp.backend}.c.j2",
        "backend_label": backend_module(problem.qp.backend).LABEL,
    }
    written = _write_folder(out_dir, problem, ctx, use_float)
    lib_files = (*qp_files.library_sources, *qp_files.library_headers)
    files = tuple(sorted([*written, f"{name}_model.c", f"{name}_model.h", *qp_files.sources, *qp_files.headers]))
    return GenerateInfo(
        name=name,
        out_dir=out_dir,
        use_float=use_float,
        sizes=tab["sizes"],
        workspace_bytes=mem["workspace_bytes"],
        solver_workspace_bytes=mem["solver_workspace_bytes"],
        qp_array_bytes=qp_files.array_bytes,
        qp_struct_bytes=qp_files.struct_bytes,
        const_bytes=mem["const_bytes"],
        files=files,
        library_files=lib_files,
        qp_files=qp_files,
    )


def _tables(problem: Problem, ocp: Ocp, lay: QpLayout) -> dict[str, Any]:
    """The size macros and the solver's constant tables (index tables in the smallest unsigned type that holds them,
    real tables, stage descriptors); checks what the C's in-place updates assume of the layout."""
    sizes = size_macros(ocp, lay)
    slacks = slack_vars(ocp, lay)
    if sizes["NNZ_J"] != sizes["QP_NNZ_A"]:
        raise AssertionError("stacked Jacobian and A differ in size: A_x cannot share the Jacobian's memory")
    if np.any(lay.row_shift < np.arange(lay.m)):
        raise AssertionError("a row's shifted dual comes from an earlier row: feedback cannot shift y in place")
    a_cycles = permutation_cycles(lay.a_src)
    index_tables = {
        "A_SRC": lay.a_src,
        "A_CYCLES": a_cycles,
        "VAR_SHIFT": lay.var_shift,
        "ROW_SHIFT": lay.row_shift,
        "INIT_ROWS": lay.init_rows,
        "SLACK_VARS": slacks,
        "BAND_ROW": lay.band_rows[:, 0],
        "BAND_STAGE": lay.band_rows[:, 1],
        "BAND_SIDE": lay.band_rows[:, 2],
    }
    top = max(int(np.max(t, initial=0)) for t in index_tables.values())
    index_ctype, index_size = ("uint16_t", 2) if top < 2**16 else ("uint32_t", 4)
    u_lo, u_hi, u_lim = input_box(problem)
    real_tables: dict[str, Sequence[float] | np.ndarray] = {
        "P_DIAG": lay.P_diag,
        "L": lay.L,
        "U": lay.U,
        "D": lay.D,
        "Q_DS0": lay.q_ds0,
        "INIT_D": lay.D[: ocp.nx],
        "U_LO": u_lo,
        "U_HI": u_hi,
        "U_LIM": u_lim,
        "SHAPE_DEFAULT": ocp.default_shapes().ravel(),
    }
    if ocp.p_dt is not None:  # unequal intervals: each stage's length is a parameter (Ocp.stage_dt)
        real_tables["STAGE_DT"] = ocp.stage_dt()
    if np.any(lay.band_ds != 0.0):  # corners' rows: each takes the band at its own s (QpLayout.band_ds)
        real_tables["BAND_DS"] = lay.band_ds
    for t in (lay.L, lay.U):
        if np.any(np.abs(t) > INF):
            raise AssertionError("bounds beyond the QP infinity INF")
    return {
        "sizes": sizes,
        "slacks": slacks,
        "a_cycles": a_cycles,
        "index_tables": index_tables,
        "index_ctype": index_ctype,
        "index_size": index_size,
        "real_tables": real_tables,
        "stages": stage_table(ocp, lay),
    }


def _memory(
    problem: Problem, ocp: Ocp, lay: QpLayout, tab: dict[str, Any], work: dict, qp_files: BackendFiles, use_float: bool
) -> dict[str, Any]:
    """The solver's workspace struct and its static memory (RAM: the workspaces; flash: our const tables), the
    opponent fit's and the curve speed's constants it depends on, and the header's size macros."""
    real_size = 4 if use_float else 8
    n_opp_all = max(1, problem.opponents.count * ocp.n_opp_par)
    fit = fit_context(ocp)
    curve = curve_speed_constants(problem)
    ws_members, ws_bytes = workspace_members(
        problem.name,
        tab["sizes"],
        work,
        real_size,
        n_opp_all,
        fit,
        len(lay.band_rows),
        curve=curve is not None,
        delay=problem.delay,
        f_last=has_f_last(problem),
        steer_lag=problem.steer_lag > 0,
    )
    const_bytes = (
        sum(len(t) for t in tab["index_tables"].values()) * tab["index_size"]
        + sum(len(t) for t in tab["real_tables"].values()) * real_size
        + len(tab["stages"]) * (8 * 4 + real_size * (1 if curve is not None else 2))
    )  # stage_t
    workspace_bytes = ws_bytes + qp_files.array_bytes + qp_files.struct_bytes
    values = {**tab["sizes"], "WORKSPACE_BYTES": workspace_bytes, "USE_FLOAT": int(use_float)}
    macro_doc = {**MACRO_DOC, "NX": f"states per stage ({', '.join(ocp.first.var_names[: ocp.nx])})"}
    return {
        "fit": fit,
        "curve": curve,
        "work": work,
        "ws_members": ws_members,
        "solver_workspace_bytes": ws_bytes,
        "const_bytes": const_bytes,
        "workspace_bytes": workspace_bytes,
        "opp_dim": n_opp_all,
        "macros": [{"key": k, "value": v, "doc": macro_doc[k]} for k, v in values.items()],
    }


def _math_names(use_float: bool) -> dict[str, str]:
    """The <math.h> functions of the real type (``c_sqrt``: ``sqrtf`` in float, ...)."""
    return {
        f"c_{f}": f + ("f" if use_float else "")
        for f in ("floor", "cos", "sin", "sqrt", "fabs", "fmin", "atan2", "tan", "atan", "copysign")
    }


def _solver_context(
    problem: Problem, ocp: Ocp, tab: dict[str, Any], mem: dict[str, Any], qp_files: BackendFiles, use_float: bool
) -> dict[str, Any]:
    """The templates' context of the solver's API, contract, memory, tables and build."""
    name, NAME = problem.name, problem.name.upper()
    lib = qp_files.library
    cold_note = COLD_RESTART_NOTE.replace("COLD_RESTART_AFTER", f"{NAME}_COLD_RESTART_AFTER")
    return {
        "name": name,
        "NAME": NAME,
        "version": __version__,
        "real": "float" if use_float else "double",
        "use_float": use_float,
        "sizes": tab["sizes"],
        "macros": mem["macros"],
        "exit_codes": list(enumerate(EXIT_CODES)),
        "qp_statuses": list(enumerate(QP_STATUSES, start=1)),
        "n_qp_statuses": len(QP_STATUSES),
        "qp_usable": [QP_STATUSES[s - 1] for s in QP_USABLE],
        "qp_exit": [(0, QP_EXIT[0])]
        + [(f"{NAME}_{QP_STATUSES[s - 1]}", QP_EXIT[s]) for s in range(1, len(QP_STATUSES) + 1)],
        "qp_contract": QP_CONTRACT,
        "max_input_violation": c_real(MAX_INPUT_VIOLATION),
        "max_input_violation_c": c_real_literal(MAX_INPUT_VIOLATION, use_float),
        "cold_restart_note": cold_note,
        "cold_restart_lines": _wrap_comment(f"Cold restart: {cold_note}.", 114),
        "first_state_member": FIRST_STATE_MEMBER,
        "delay": problem.delay,
        "x_plan": "ws.x_plan" if problem.delay else "ws.x0",  # where the plan starts (delay compensation)
        "x_plan_doc": "the plan's start (x0 predicted over the delay)" if problem.delay else "x0",
        "host_ticks_per_second": HOST_TICKS_PER_SECOND,
        "problem": problem,
        "formulation": problem.formulation.kind,
        "obstacles": problem.obstacles.kind,
        "opp_params": ", ".join(obs.CARTESIAN_POSE),
        "workspace_bytes": mem["workspace_bytes"],
        "solver_workspace_bytes": mem["solver_workspace_bytes"],
        "qp_array_bytes": qp_files.array_bytes,
        "qp_struct_bytes": qp_files.struct_bytes,
        "const_bytes": mem["const_bytes"],
        "ws_members": mem["ws_members"],
        "work": mem["work"],
        "misra_deviations": MISRA_DEVIATIONS,
        **_math_names(use_float),
        "index_ctype": tab["index_ctype"],
        "opp_dim": mem["opp_dim"],
        "n_a_cycles": len(tab["a_cycles"]),
        "fit": mem["fit"],
        "curve": mem["curve"],
        "index_tables": {
            k: {"len": max(1, len(v)), "body": c_list([int(x) for x in v])} for k, v in tab["index_tables"].items()
        },
        "real_tables": {
            k: {"len": max(1, len(v)), "body": c_list(v, c_real, 6)} for k, v in tab["real_tables"].items()
        },
        "n_slack": len(tab["slacks"]),
        "stages": tab["stages"],
        "qp_files": qp_files,
        "qp_lib": lib,
        "static_libs": [f"lib{name}.a", *([f"lib{name}_{lib.suffix}.a"] if lib else [])],
        "make_products": ", ".join(
            ["static library", *([f"{lib.label} library"] if lib else []), "shared library", "example"]
        ),
        "model_cflags": MODEL_CFLAGS,
        "cross_targets": cross_targets(use_float),
        "footprint_marker_begin": README_BEGIN,
        "footprint_marker_end": README_END,
    }


def _problem_context(problem: Problem, ocp: Ocp, lay: QpLayout) -> dict[str, Any]:
    """The templates' context of the problem's constants: opponents, road, reference, horizon, shift, plan check."""
    name, rp = problem.name, ocp.road_params
    n_opp = problem.opponents.count
    return {
        "n_opp_stage": n_opp * ocp.n_opp_stage,
        "stage_opp": "ws.opp_stage" if ocp.fit is not None else None,
        "shape_dim": max(1, n_opp * ocp.n_opp_shape),
        "n_band": len(lay.band_rows),
        "band_s": " + BAND_DS[i]" if np.any(lay.band_ds != 0.0) else "",
        "band_scale": c_real(lay.band_scale),
        "n_min": c_real(problem.bounds.n_min),
        "n_max": c_real(problem.bounds.n_max),
        "shape_axes": ocp.n_opp_shape > len(obs.OPP_SHAPE),
        "ego_radius": c_real(obs.ego_radius(problem.obstacles, problem.ego)),
        "ranges": {k: c_real(v) for k, v in dataclasses.asdict(INPUT_RANGES).items()},
        "p_road": {
            "S0": 0,
            "DS": 1,
            "KAPPA": 2,
            "PHI": 2 + rp.samples,
            "GX": 2 + 2 * rp.samples,
            "GY": 2 + 3 * rp.samples,
        },
        "p_ref": ocp.p_ref.start,
        "p_opp": ocp.p_opp.start,
        "n_ref": c_real(problem.reference.n_ref),
        "v_ref": c_real(problem.reference.v_ref),
        "dt": c_real(problem.horizon.interval),
        "p_dt": ocp.p_dt,
        "stage_offsets": c_macro_list(problem.horizon.offsets),
        # node k's time in set_reference's s_ref,k: k DT on a uniform grid (the same rounding as k * interval)
        "ref_time": f"(({name}_real_t)k * DT)" if ocp.p_dt is None else "STAGES[k].t",
        "ref_time_i": f"(({name}_real_t)i * DT)" if ocp.p_dt is None else "STAGES[i].t",
        "margin_terms": [(i, c_real(f)) for i, f in margin_terms(ocp)],
        "margin_doc": margin_meaning(ocp),
        "init_margin": c_real(problem.obstacle_margin) if problem.obstacle_margin else None,  # init's margins
        "shift_vars": shift_statement("ws.w_tmp", "ws.w", "VAR_SHIFT", lay.shift_fraction, lay.shift_split_var, name),
        "shift_duals": shift_statement("ws.y", "ws.y", "ROW_SHIFT", lay.shift_fraction, lay.shift_split_row, name),
        "max_iter": warm_max_iter(problem.qp),
        "max_iter_cold": cold_max_iter(problem.qp),
        "qp_infty": c_real(INF),
        "react_stages": min(problem.plan_check.react_stages, problem.horizon.N),
        "brake_m_per_dt": c_real(problem.ego.m / problem.horizon.dt),
        "a_lat_guard": int(problem.plan_check.a_lat_guard),
        "sample_dt": c_real(problem.horizon.dt),
        "wheelbase": c_real(problem.ego.l),
        "a_lat_max": c_real(problem.bounds.a_lat_max),
        "a_lat_guard_to": c_real(problem.bounds.a_lat_max - problem.bounds.a_lat_margin),
        "tyre_k": c_real(tyre_k(problem)),
        "tyre_l_f": c_real(problem.ego.l_f),
        "tyre_l_r": c_real(problem.ego.l_r),
        "tyre_h_cg": c_real(problem.plan_check.h_cg),
        "tyre_g": c_real(reactions.G),
        "tyre_gain_min": c_real(reactions.GAIN_MIN),
        "ego_m": c_real(problem.ego.m),
        "drive_limit": int(problem.plan_check.drive_limit),
        "drive_slack": c_real(reactions.DRIVE_SLACK),
        "bend_brake": c_real(problem.plan_check.bend_brake),
        "bend_slack": c_real(reactions.BEND_SLACK),
        "brake_memory": int(problem.plan_check.brake_memory),
        "drive_rise": c_real(problem.ego.m * problem.plan_check.drive_rise),
        "f_last": has_f_last(problem),
        "steer_lag": problem.steer_lag > 0,
        "lag_tau": c_real(problem.steer_lag),
        "lag_decay": c_real((lag_constants(problem) or (0.0, 0.0))[1]),
        "far_opp": c_list(far_opponent_row(ocp), c_real),
        "road_ds": c_real(problem.road.ds),
    }


def _write_folder(out_dir: Path, problem: Problem, ctx: dict[str, Any], use_float: bool) -> list[str]:
    """Render the templates, the toolchain files and ``problem.py`` into ``out_dir``; returns the files written."""
    env = environment()
    outputs = {
        f"{problem.name}_solver.h": "solver.h.j2",
        f"{problem.name}_solver.c": "solver.c.j2",
        f"{problem.name}_host.h": "host.h.j2",
        f"{problem.name}_host.c": "host.c.j2",
        "main.c": "main.c.j2",
        "CMakeLists.txt": "CMakeLists.txt.j2",
        "Makefile": "Makefile.j2",
        "README.md": "README.md.j2",
    }
    for fname, tpl in outputs.items():
        write_if_changed(out_dir / fname, env.get_template(tpl).render(**ctx))
    toolchains = toolchain_files(use_float)
    for fname, text in toolchains.items():
        write_if_changed(out_dir / fname, text)
    write_if_changed(
        out_dir / "problem.py",
        f'"""The problem of solver {problem.name!r}, written by fcgen {__version__}: `fcgen verify` and '
        f'`fcgen bench` load it."""\nfrom fcgen.dsl import *  # noqa: F401,F403\n\n'
        f"problem = {problem_source(problem)}\n",
    )
    return [*outputs, *toolchains, "problem.py"]
