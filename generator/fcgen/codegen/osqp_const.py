"""OSQP workspace arrays that embedded mode 2 never writes, emitted ``const`` (flash instead of RAM).

OSQP emits every workspace array mutable. The index arrays of the data and KKT matrices, the KKT maps, the
permutation and the elimination tree are computed at setup (in Python) and only read by the embedded code:
``osqp_update_data_mat`` / ``osqp_update_data_vec`` / ``osqp_solve`` write values (``x``), never a sparsity
pattern, and ``QDLDL_factor`` takes ``Lnz`` and ``etree`` as ``const`` (``L``'s own pattern ``L_p`` / ``L_i`` is
rewritten by every factorization and stays mutable). The structs that point to them get a cast (OSQP's types have
no ``const`` members). A write to one of them would fault on a host (read-only pages), so the host tests prove it.
"""
from __future__ import annotations

import re

CONST_ARRAYS = (
    "data_P_csc_p", "data_P_csc_i", "data_A_csc_p", "data_A_csc_i",
    "linsys_KKT_p", "linsys_KKT_i", "linsys_PtoKKT", "linsys_AtoKKT", "linsys_rhotoKKT",
    "linsys_P", "linsys_etree", "linsys_Lnz",
)
"""Arrays (without the prefix) that OSQP 1.1.3's embedded mode 2 only reads; all of type ``OSQPInt``."""


def constant_arrays(workspace_c: bytes, prefix: str) -> bytes:
    """``const`` definitions of :data:`CONST_ARRAYS` in OSQP's emitted workspace, casts where structs point to them."""
    out = workspace_c
    for short in CONST_ARRAYS:
        name = (prefix + short).encode()
        definition = re.compile(rb"^OSQPInt (" + name + rb"\[\d+\] = \{)$", re.M)
        out, found = definition.subn(rb"const OSQPInt \1", out)
        if found != 1:
            raise RuntimeError(f"OSQP's workspace without the array {prefix + short} (another OSQP version?)")
        out, used = re.subn(rb"^(\s+)" + name + rb"(,?)$", rb"\1(OSQPInt *)" + name + rb"\2", out, flags=re.M)
        if used < 1:
            raise RuntimeError(f"no struct of OSQP's workspace points to {prefix + short}")
    return out
