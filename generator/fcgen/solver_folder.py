"""A generated solver folder, read once: :func:`read_folder` checks it and gives a :class:`SolverFolder` (name, real
type, sizes, problem, QP backend, build paths) that the build, the C binding, the firmware harness, verify, bench,
footprint, wcet, fmu, the golden suites and the demo are handed instead of each reading the folder again.

A folder that is not a good one is refused in one line that says which command writes a good one.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

from .codegen.consistency import WRITE_ONE, check_folder, read_macros, the_solver
from .dsl import Problem
from .presets import load_problem
from .targets import get_target

HEADER_SUFFIX = "_solver.h"


def build_dir(gen_dir: Path | str, verify: bool = False, target: str = "host", variant: str | None = None) -> Path:
    """Where ``build`` puts the products of a target: ``build[/<target>][/<variant>][/verify]``."""
    sub = get_target(target).build_subdir + (f"/{variant}" if variant else "")
    return Path(gen_dir) / (f"{sub}/verify" if verify else sub)


def solver_name(gen_dir: Path | str) -> str:
    """The problem name of a generated folder (from its single ``<name>_solver.h``), without reading the rest."""
    heads = sorted(Path(gen_dir).glob(f"*{HEADER_SUFFIX}"))
    if len(heads) != 1:
        raise FileNotFoundError(f"{gen_dir}: expected exactly one *{HEADER_SUFFIX}, found {len(heads)}; {WRITE_ONE}")
    return heads[0].name[: -len(HEADER_SUFFIX)]


@dataclass(frozen=True)
class SolverFolder:
    """One generated solver folder as read by :func:`read_folder` (``checked``: its files belong together)."""

    path: Path
    name: str
    sizes: dict[str, int] = field(repr=False, hash=False)  # every integer macro of <name>_solver.h, by key
    problem: Problem = field(repr=False, hash=False, compare=False)
    checked: bool = True

    @property
    def header(self) -> Path:
        return self.path / f"{self.name}{HEADER_SUFFIX}"

    @property
    def problem_file(self) -> Path:
        return self.path / "problem.py"

    @property
    def use_float(self) -> bool:
        """Generated with ``--float`` (its ``<NAME>_USE_FLOAT`` macro)."""
        return bool(self.sizes.get("USE_FLOAT", 0))

    @property
    def precision(self) -> str:
        """The real type: ``"float"`` or ``"double"`` (the run logs' ``meta.precision``)."""
        return "float" if self.use_float else "double"

    @property
    def backend(self) -> str:
        """The QP backend the solver was generated with (``QpOptions.backend``)."""
        return self.problem.qp.backend

    def build_dir(self, verify: bool = False, target: str = "host", variant: str | None = None) -> Path:
        """Where ``build`` puts the products of a target (see :func:`build_dir`)."""
        return build_dir(self.path, verify, target, variant)

    def lib(self, verify: bool = False, target: str = "host", variant: str | None = None) -> Path:
        """The build's main product: the shared library on the host, ``lib<name>.a`` on a bare-metal target."""
        ext = "a" if get_target(target).bare_metal else "so"
        return self.build_dir(verify, target, variant) / f"lib{self.name}.{ext}"


FolderLike = SolverFolder | Path | str


def read_folder(path: Path | str, check: bool = True) -> SolverFolder:
    """Read a generated folder once: its solver's name, the sizes of its header and the problem of ``problem.py``.

    ``check``: every file ``make`` needs there and the header's sizes those of ``problem.py``
    (:func:`~.codegen.consistency.check_folder`, raising :class:`~.codegen.consistency.FolderMismatch` in one line).
    A missing folder or one without a solver header raises ``FileNotFoundError`` naming the command that writes one.
    """
    path = Path(path)
    if not path.is_dir():
        raise FileNotFoundError(f"{path}: no such solver folder ({WRITE_ONE})")
    if not any(path.glob(f"*{HEADER_SUFFIX}")):
        raise FileNotFoundError(f"{path} is not a generated solver folder (no <name>{HEADER_SUFFIX}; {WRITE_ONE})")
    if check:
        name = check_folder(path)
    else:
        name = the_solver(path)
        if not (path / "problem.py").is_file():
            raise FileNotFoundError(
                f"{path} is not a generated solver folder (no problem.py; regenerate it: "
                f"`fcgen generate PRESET -o {path} --force`)"
            )
    sizes = read_macros(path / f"{name}{HEADER_SUFFIX}", name)
    return SolverFolder(path, name, sizes, load_problem(str(path / "problem.py")), check)


def as_folder(folder: FolderLike, check: bool = True) -> SolverFolder:
    """``folder`` itself if it is a :class:`SolverFolder` already, else the folder at that path read once."""
    return folder if isinstance(folder, SolverFolder) else read_folder(folder, check)
