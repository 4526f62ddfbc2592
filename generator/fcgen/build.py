"""Compile a generated solver folder: ``build()`` runs its Makefile for a target and returns the main product.

The folder is a :class:`~.solver_folder.SolverFolder` (or its path, then read and checked once); the library is
loaded by ``fcgen.csolver.CSolver``.
"""

from __future__ import annotations

import os
import subprocess
from pathlib import Path

from .backends import backend_module
from .codegen.consistency import check_folder
from .locks import folder_lock
from .solver_folder import FolderLike, as_folder
from .targets import get_target

VERIFY_BUILD = "build/verify"
DEFAULT_BUILD = "build"


class BuildError(RuntimeError):
    """``make`` failed; the message holds its output."""


def run_make(
    folder: Path | str,
    variables: list[str],
    cc: str | None = None,
    cflags: str | None = None,
    error: type[Exception] | None = None,
) -> None:
    """``make -C folder VAR=value ...`` (plus CC/CFLAGS when given); raises ``error`` with make's output."""
    cmd = ["make", "-C", str(folder), *variables]
    if cc:
        cmd.append(f"CC={cc}")
    if cflags is not None:
        cmd.append(f"CFLAGS={cflags}")
    res = subprocess.run(cmd, capture_output=True, text=True)
    if res.returncode != 0:
        raise (error or BuildError)(f"{' '.join(cmd)} failed:\n{res.stdout[-4000:]}\n{res.stderr[-4000:]}")


def build(
    folder: FolderLike,
    verify: bool = False,
    cc: str | None = None,
    cflags: str | None = None,
    jobs: int | None = None,
    target: str = "host",
    extra_cflags: str = "",
    variant: str | None = None,
) -> Path:
    """Run ``make`` in a generated folder (syncing the QP backend's library copy); returns the main product.

    A path is read and checked first (:func:`~.solver_folder.read_folder`: a missing file or a header whose sizes
    differ from ``problem.py`` raises :class:`~.codegen.consistency.FolderMismatch` in one line).

    Host: everything, returns the shared library. A bare-metal target (``fcgen.targets``): the two static libraries
    alone, cross-compiled with the target's compiler and CPU flags into ``build/<target>``; returns ``lib<name>.a``.
    ``verify`` (``VERIFY=1``: no FP contraction, bit-exact with the reference) builds into ``.../verify``, so both
    variants coexist. ``extra_cflags`` are appended to the flags (e.g. ``-fstack-usage`` for ``footprint``, built
    apart as ``variant="footprint"``). The folder's lock (:func:`~.locks.folder_lock`) is held over the library sync
    and ``make``: concurrent builds of one folder, from any process, run one after the other.
    """
    folder = as_folder(folder)
    if not folder.checked:
        check_folder(folder.path)  # one solver, every generated file there, header sizes = problem.py's
    tgt = get_target(target)
    tgt.check_precision(folder.use_float)
    tgt.check_tools()
    out = folder.build_dir(verify, target, variant).relative_to(folder.path).as_posix()
    if tgt.bare_metal:
        cc = cc or tgt.cc
        cflags = tgt.cflags(cflags if cflags is not None else "-O2")
    if extra_cflags:
        cflags = f"{cflags if cflags is not None else '-O2'} {extra_cflags}"
    with folder_lock(folder.path):  # one make per folder at a time (another process may be building it)
        backend_module(folder.backend).restore_library(folder.path, folder.use_float)  # its git-ignored library
        run_make(
            folder.path,
            [f"-j{jobs or os.cpu_count() or 1}", f"BUILD={out}", f"VERIFY={int(verify)}", *tgt.make_variables()],
            cc,
            cflags,
        )
    return folder.lib(verify, target, variant)
