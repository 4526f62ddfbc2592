"""The OSQP backend's C side of one problem: the context of ``templates/backends/osqp.c.j2`` and the folder's OSQP
files (its workspace exported by ``backends/osqp_export.py``, its library), with their README notes."""

from __future__ import annotations

import re
from pathlib import Path
from typing import TYPE_CHECKING, Any

from ..backends import QP_STATUSES, BackendFiles, BackendLibrary
from ..backends.osqp import RAW_STATUS, osqp_settings, osqp_sigma, setup_data
from ..backends.osqp_export import export_osqp

if TYPE_CHECKING:  # pragma: no cover
    from ..dsl import QpOptions
    from ..ocp import Ocp
    from ..qp import QpLayout

OSQP_STRUCT_BYTES = {False: 1808, True: 1668}
"""OSQP's bookkeeping structs in a workspace (solver, settings, info, vectors, matrices, ...): a fixed set whose size
does not depend on the problem (with the alignment padding between the mutable arrays); measured for osqp 1.1.3
with gcc 12 on x86-64 (LP64), double / float, truck_lifted_ellipse."""

_OSQP_ARRAY = re.compile(r"^(OSQPFloat|OSQPInt|QDLDL_int|QDLDL_bool|QDLDL_float)\s+\w+\[(\d+)\]", re.M)


def codegen_context(ocp: Ocp, layout: QpLayout, opts: QpOptions) -> dict[str, Any]:
    """What ``templates/backends/osqp.c.j2`` needs (rendered under the key ``backend``)."""
    prefix = f"{ocp.problem.name}_"
    settings = osqp_settings(opts)
    raw = [(k, QP_STATUSES[v - 1]) for k, v in sorted(RAW_STATUS.items())]
    return {
        "workspace_header": f"{prefix}workspace.h",
        "solver_name": f"{prefix}solver",
        "workspace_reset": f"{prefix}workspace_reset",
        "max_iter": settings["max_iter"],
        "raw_status": raw,
        "n_raw": max(RAW_STATUS) + 1,
    }


def _array_bytes(workspace_c: str, real_size: int) -> int:
    sizes = {"OSQPFloat": real_size, "QDLDL_float": real_size, "OSQPInt": 4, "QDLDL_int": 4, "QDLDL_bool": 4}
    return sum(sizes[t] * int(n) for t, n in _OSQP_ARRAY.findall(workspace_c))


FLOAT_LIBRARY_CFLAGS = ("-fsingle-precision-constant",)
"""Extra flags of OSQP's library sources in a float build: their unsuffixed literals (``1.0 / OSQP_INFTY``,
``sca == 1.``, ``? 1.0 : v``) would otherwise make the compiler compute those expressions in double (software
routines on a single-precision FPU)."""
FLOAT_LIBRARY_REASON = "float build: OSQP's unsuffixed literals as float, no double arithmetic"


def write_files(ocp: Ocp, layout: QpLayout, opts: QpOptions, out_dir: Path, use_float: bool) -> BackendFiles:
    """Export OSQP's workspace (problem-specific) and library into ``out_dir/osqp``; returns the folder's files."""
    out_dir = Path(out_dir)
    P, q, A, l, u = setup_data(layout)
    name = ocp.problem.name
    exp = export_osqp(P, A, q, l, u, osqp_settings(opts, use_float), out_dir, f"{name}_", use_float)
    private = ", ".join(f"`{d}`" for d in exp.private_include_dirs)
    lib_flags = FLOAT_LIBRARY_CFLAGS if use_float else ()
    library = BackendLibrary(
        suffix="osqp",
        label="OSQP",
        opt_var="OSQP_OPTFLAGS",
        opt_flags="-O3",
        opt_reason="the ADMM iterations are most of the run time",
        cflags=lib_flags,
        cflags_reason=FLOAT_LIBRARY_REASON if use_float else "",
        sources_note=f"OSQP's own files get `{' '.join(exp.cflags)}` and the private include folder {private}"
        + (f"; its library sources also `{' '.join(lib_flags)}` ({FLOAT_LIBRARY_REASON})" if lib_flags else "")
        + ".\n"
        "The OSQP library sources in `osqp/lib/` are not committed: `fcgen build` restores them from the "
        "installed osqp package.",
        symbols_note=f"OSQP's and QDLDL's included (`{name}_osqp_solve`, ...:\n`osqp/{name}_osqp_rename.h`, included "
        "by `osqp_configure.h`, renames them in every file that includes an OSQP\nheader)",
    )
    sigma = osqp_sigma(opts, use_float)
    precision = (
        ""
        if sigma == opts.sigma
        else (
            f"**Single precision.** This float build runs OSQP with `sigma = {sigma:g}` (`qp.sigma` = {opts.sigma:g}, "
            "which the double build\nand the Python reference use): with a smaller sigma the float factorization of "
            "OSQP's KKT matrix is\nunstable (tiny pivots), which kept the capped ADMM about 8e-3 (scaled step, median) "
            "from the double solve on\ntruck_lifted_ellipse (fcgen's docs/performance.md); with it, about 4e-4."
        )
    )
    return BackendFiles(
        sources=exp.workspace_sources,
        headers=exp.workspace_headers,
        library_sources=exp.library_sources,
        library_headers=exp.library_headers,
        include_dirs=exp.include_dirs,
        private_include_dirs=exp.private_include_dirs,
        cflags=exp.cflags,
        link_libs=exp.link_libs,
        array_bytes=_array_bytes((out_dir / exp.workspace_sources[0]).read_text(), 4 if use_float else 8),
        struct_bytes=OSQP_STRUCT_BYTES[use_float],
        memory_note="the arrays OSQP only\n  reads (matrix patterns, KKT maps, permutation, elimination tree, "
        "the factor's "
        "pattern) are `const` (flash) and\n  have no RAM copy",
        library=library,
        memory_init_note="; its initial values are `static const` copies in flash",
        reset_note=f"The QP backend's workspace is restored from constant data (OSQP: `{name}_workspace_reset()` from "
        "`static const`\ncopies) before its next use. A QP's scaling is computed from that sample's data: "
        "OSQP recomputes it inside\n`osqp_update_data_mat` from the `q` it holds, so this sample's `q` is "
        "loaded first (the only trace of the previous\nsample left is one scale/unscale rounding of `q`: the "
        "step then differs by about 1e-11, where the previous order\nleft up to 0.3).",
        precision_note=precision,
    )
