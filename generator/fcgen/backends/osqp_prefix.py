"""Prefix OSQP's external symbols: a rename header that OSQP's ``osqp_configure.h`` includes.

OSQP's library functions (``osqp_solve``, ``QDLDL_factor``, ``csc_*``, ...) and its two message tables are not
static, so two solvers (also one float and one double) would clash in one firmware image. Every OSQP header
includes ``osqp_configure.h`` first; fcgen appends ``#include "<prefix>osqp_rename.h"`` to it, and that header
maps each exported name to ``<prefix><name>``. The list is that of the OSQP version the exporter targets (embedded
mode 2, printing and profiling off, float and double alike: ``nm -g --defined-only`` of its objects); the tests check
with ``nm`` that no unprefixed global symbol is left.
"""

from __future__ import annotations

import re
from pathlib import Path

OSQP_EXPORTED = (
    "OSQPCscMatrix_set_data",
    "OSQPMatrix_AtDA_extract_diag",
    "OSQPMatrix_Atxpy",
    "OSQPMatrix_Axpy",
    "OSQPMatrix_col_norm_inf",
    "OSQPMatrix_extract_diag",
    "OSQPMatrix_get_i",
    "OSQPMatrix_get_m",
    "OSQPMatrix_get_n",
    "OSQPMatrix_get_nz",
    "OSQPMatrix_get_p",
    "OSQPMatrix_get_x",
    "OSQPMatrix_lmult_diag",
    "OSQPMatrix_mult_scalar",
    "OSQPMatrix_rmult_diag",
    "OSQPMatrix_row_norm_inf",
    "OSQPMatrix_update_values",
    "OSQPVectorf_add_scaled",
    "OSQPVectorf_add_scaled3",
    "OSQPVectorf_all_leq",
    "OSQPVectorf_copy",
    "OSQPVectorf_data",
    "OSQPVectorf_dot_prod",
    "OSQPVectorf_dot_prod_signed",
    "OSQPVectorf_ew_bound_vec",
    "OSQPVectorf_ew_bounds_type",
    "OSQPVectorf_ew_max_vec",
    "OSQPVectorf_ew_min_vec",
    "OSQPVectorf_ew_prod",
    "OSQPVectorf_ew_reciprocal",
    "OSQPVectorf_ew_sqrt",
    "OSQPVectorf_from_raw",
    "OSQPVectorf_in_reccone",
    "OSQPVectorf_length",
    "OSQPVectorf_minus",
    "OSQPVectorf_mult_scalar",
    "OSQPVectorf_norm_1",
    "OSQPVectorf_norm_inf",
    "OSQPVectorf_norm_inf_diff",
    "OSQPVectorf_plus",
    "OSQPVectorf_project_polar_reccone",
    "OSQPVectorf_round_to_zero",
    "OSQPVectorf_scaled_norm_inf",
    "OSQPVectorf_set_scalar",
    "OSQPVectorf_set_scalar_conditional",
    "OSQPVectorf_set_scalar_if_gt",
    "OSQPVectorf_set_scalar_if_lt",
    "OSQPVectorf_to_raw",
    "OSQPVectori_from_raw",
    "OSQPVectori_length",
    "OSQPVectori_to_raw",
    "OSQP_ERROR_MESSAGE",
    "OSQP_STATUS_MESSAGE",
    "QDLDL_Lsolve",
    "QDLDL_Ltsolve",
    "QDLDL_etree",
    "QDLDL_factor",
    "QDLDL_solve",
    "_osqp_error",
    "_osqp_error_line",
    "adapt_rho",
    "c_strcpy",
    "check_termination",
    "compute_inf_norm_cols_KKT",
    "compute_obj_val_dual_gap",
    "compute_rho_estimate",
    "csc_AtDA_extract_diag",
    "csc_Atxpy",
    "csc_Axpy",
    "csc_Axpy_sym_triu",
    "csc_col_norm_inf",
    "csc_cumsum",
    "csc_extract_diag",
    "csc_is_eq",
    "csc_lmult_diag",
    "csc_rmult_diag",
    "csc_row_norm_inf",
    "csc_row_norm_inf_sym_triu",
    "csc_scale",
    "csc_update_values",
    "has_solution",
    "is_dual_infeasible",
    "is_primal_infeasible",
    "limit_scaling_scalar",
    "limit_scaling_vector",
    "name_qdldl",
    "osqp_adjoint_derivative_compute",
    "osqp_adjoint_derivative_get_mat",
    "osqp_adjoint_derivative_get_vec",
    "osqp_algebra_default_linsys",
    "osqp_algebra_device_name",
    "osqp_algebra_free_libs",
    "osqp_algebra_init_libs",
    "osqp_algebra_linsys_supported",
    "osqp_algebra_name",
    "osqp_capabilities",
    "osqp_codegen",
    "osqp_cold_start",
    "osqp_error_message",
    "osqp_get_dimensions",
    "osqp_get_solution",
    "osqp_set_default_codegen_defines",
    "osqp_set_default_settings",
    "osqp_solve",
    "osqp_update_data_mat",
    "osqp_update_data_vec",
    "osqp_update_rho",
    "osqp_update_settings",
    "osqp_version",
    "osqp_warm_start",
    "reset_info",
    "scale_data",
    "set_rho_vec",
    "solve_linsys_qdldl",
    "store_solution",
    "swap_vectors",
    "unscale_data",
    "unscale_solution",
    "update_KKT_A",
    "update_KKT_P",
    "update_KKT_param2",
    "update_info",
    "update_linsys_solver_matrices_qdldl",
    "update_linsys_solver_rho_vec_qdldl",
    "update_rho_vec",
    "update_settings_linsys_solver_qdldl",
    "update_status",
    "update_x",
    "update_xz_tilde",
    "update_y",
    "update_z",
    "validate_linsys_solver",
    "validate_settings",
    "vec_mult_scalar",
    "vec_negate",
    "vec_set_scalar",
    "warm_start_linsys_solver_qdldl",
)
"""External symbols of OSQP 1.1.3's embedded mode-2 objects (functions and the two message tables)."""

CONFIGURE_H = "osqp_configure.h"
_GUARD_END = re.compile(rb"\n#endif /\* ifndef OSQP_CONFIGURE_H \*/\s*$")


def rename_header_name(prefix: str) -> str:
    """File name (in ``osqp/``) of the rename header of solver prefix ``prefix``."""
    return f"{prefix}osqp_rename.h"


def rename_header(prefix: str) -> bytes:
    """``#define name <prefix>name`` for every exported OSQP symbol."""
    guard = f"{prefix.upper()}OSQP_RENAME_H"
    lines = [
        f"/* {rename_header_name(prefix)} -- OSQP's external symbols with the solver's prefix, so that several",
        " * solvers link into one image. Included by osqp_configure.h (and so by every OSQP header).",
        " * Generated by fcgen. Do not edit. */",
        f"#ifndef {guard}",
        f"#define {guard}",
        "",
    ]
    lines += [f"#define {s} {prefix}{s}" for s in OSQP_EXPORTED]
    lines += ["", f"#endif /* {guard} */", ""]
    return "\n".join(lines).encode()


def prefixed_configure(data: bytes, prefix: str) -> bytes:
    """OSQP's ``osqp_configure.h`` with the rename header included before its closing guard."""
    if not _GUARD_END.search(data):
        raise RuntimeError("osqp_configure.h without the expected include guard: cannot prefix OSQP's symbols")
    include = f"\n/* fcgen: OSQP's symbols carry the solver's prefix */\n#include \"{rename_header_name(prefix)}\"\n"
    return _GUARD_END.sub(include.encode() + b"\n#endif /* ifndef OSQP_CONFIGURE_H */\n", data)


def prefix_of(out_dir: Path) -> str:
    """The solver prefix of a folder with an exported OSQP workspace (``osqp/<prefix>workspace.h``)."""
    found = sorted(Path(out_dir, "osqp").glob("*workspace.h"))
    if len(found) != 1:
        raise FileNotFoundError(f"{out_dir}/osqp: expected exactly one *workspace.h, found {len(found)}")
    return found[0].name[: -len("workspace.h")]
