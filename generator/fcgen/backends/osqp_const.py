"""OSQP workspace arrays that embedded mode 2 never writes, emitted ``const`` (flash instead of RAM).

OSQP emits every workspace array mutable. The index arrays of the data and KKT matrices, the KKT maps, the
permutation and the elimination tree are computed at setup (in Python) and only read by the embedded code:
``osqp_update_data_mat`` / ``osqp_update_data_vec`` / ``osqp_solve`` write values (``x``), never a sparsity
pattern, and ``QDLDL_factor`` takes ``Lnz`` and ``etree`` as ``const``. ``QDLDL_factor`` does rewrite the pattern
of the factor ``L`` (``L_p``, ``L_i``) at every factorization, with the values it had: they depend only on the KKT
pattern, ``Lnz`` and ``etree``, and OSQP's setup computed them with the same code. :func:`qdldl_keep_pattern` patches
those three assignments of OSQP's ``qdldl.c`` to write only a value that differs (never, so ``L_p`` and ``L_i``
are ``const`` too). The structs that point to the arrays get a cast (OSQP's types have no ``const`` members). A
write to one of them would fault on a host (read-only pages), so the host tests prove it.
"""

from __future__ import annotations

import re

CONST_ARRAYS = (
    "data_P_csc_p",
    "data_P_csc_i",
    "data_A_csc_p",
    "data_A_csc_i",
    "linsys_KKT_p",
    "linsys_KKT_i",
    "linsys_PtoKKT",
    "linsys_AtoKKT",
    "linsys_rhotoKKT",
    "linsys_P",
    "linsys_etree",
    "linsys_Lnz",
    "linsys_L_p",
    "linsys_L_i",
)
"""Arrays (without the prefix) that OSQP 1.1.3's embedded mode 2 only reads (``L_p``, ``L_i``: with
:func:`qdldl_keep_pattern`); all of type ``OSQPInt``."""

QDLDL_SOURCE = "src/qdldl.c"
_QDLDL_PATTERN_WRITES = (
    (
        b"    Lp[0] = 0; // First column starts at index zero\n",
        b"    if (Lp[0] != 0) Lp[0] = 0; // First column starts at index zero (fcgen: L's pattern is const)\n",
    ),
    (
        b"        Lp[i + 1] = Lp[i] + Lnz[i]; // cumsum, total at the end\n",
        b"        if (Lp[i + 1] != Lp[i] + Lnz[i]) Lp[i + 1] = Lp[i] + Lnz[i];"
        b" // cumsum (fcgen: written only if new)\n",
    ),
    (
        b"            Li[tmpIdx] = k;\n",
        b"            if (Li[tmpIdx] != k) Li[tmpIdx] = k; /* fcgen: written only if new */\n",
    ),
)


def qdldl_keep_pattern(qdldl_c: bytes) -> bytes:
    """OSQP's ``qdldl.c`` with the writes of ``L``'s pattern in ``QDLDL_factor`` done only when the value differs."""
    out = qdldl_c
    for old, new in _QDLDL_PATTERN_WRITES:
        if out.count(old) != 1:
            raise RuntimeError(f"{QDLDL_SOURCE}: expected one {old.strip().decode()!r} (another OSQP version?)")
        out = out.replace(old, new)
    return out


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
