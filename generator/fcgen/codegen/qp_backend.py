"""The QP backend's share of a generated solver, by backend: its template ``templates/backends/<b>.c.j2``'s context
(``codegen_context``) and its files in the folder (``write_files``). The backend's Python side (the reference's
solver, its label, its library's restore for ``fcgen build``) is ``fcgen.backends.<b>``."""

from __future__ import annotations

from types import ModuleType

from ..backends import backend_module
from . import ipm_header, osqp_files

C_SIDES: dict[str, ModuleType] = {"osqp": osqp_files, "ipm": ipm_header}
"""The module that writes each backend's C (one for every name of ``fcgen.dsl.BACKENDS``)."""


def backend_c(name: str) -> ModuleType:
    """The module that writes backend ``name``'s C: ``codegen_context(ocp, layout, opts)``, ``write_files(ocp, layout,
    opts, out_dir, use_float)``."""
    backend_module(name)  # an unknown name: the one error that lists the backends
    return C_SIDES[name]
