"""Does a solver folder hold one solver whose files belong together? (checked by ``fcgen build`` before ``make``)

Every source and header the Makefile compiles must be there (OSQP's library copy is restorable, the others are
named in one line), and the sizes of ``<name>_solver.h`` must be those of the problem recorded in ``problem.py``:
a header edited by hand (``_N 40`` -> ``41``) would otherwise build and run with other results.
"""

from __future__ import annotations

import re
from pathlib import Path

from ..backends.osqp_export import LIB_DIR
from .folder import solvers_in


def read_macros(header: Path, name: str) -> dict[str, int]:
    """Integer ``#define NAME_KEY value`` macros of a generated header, by KEY."""
    pat = re.compile(rf"^#define {name.upper()}_(\w+) (-?\d+)\b", re.M)
    return {k: int(v) for k, v in pat.findall(Path(header).read_text())}


class FolderMismatch(ValueError):
    """The folder's files do not make one solver (one line: the file or macro and both values)."""


WRITE_ONE = "write one with `fcgen generate PRESET -o DIR`"
"""The command that makes a good solver folder (every folder error says it)."""


def regenerate_command(gen_dir: Path) -> str:
    """The command that rewrites ``gen_dir`` from its own ``problem.py``."""
    return f"`fcgen generate {gen_dir / 'problem.py'} -o {gen_dir} --force`"


def the_solver(gen_dir: Path) -> str:
    """The name of the one solver in ``gen_dir``."""
    names = solvers_in(gen_dir)
    if len(names) != 1:
        found = ", ".join(f"{n}_solver.h" for n in names) or "none"
        fix = WRITE_ONE if not names else "one solver per folder: `fcgen generate PRESET -o DIR` into a folder each"
        raise FolderMismatch(f"{gen_dir}: expected the header of exactly one solver (*_solver.h), found {found}; {fix}")
    return names[0]


SOURCE_VARIABLES = ("SOLVER_SRC", "MODEL_SRC", "WORKSPACE_SRC", "OSQP_SRC", "HOST_SRC", "MAIN_SRC", "HEADERS")
"""The Makefile's variables that list the files it compiles."""


def makefile_files(gen_dir: Path) -> list[str]:
    """Every source and header the folder's Makefile lists (relative paths, in order)."""
    text = (gen_dir / "Makefile").read_text().replace("\\\n", " ")
    out: list[str] = []
    for var in SOURCE_VARIABLES:
        m = re.search(rf"^{var}\s*=(.*)$", text, re.M)
        out += [f for f in (m.group(1).split() if m else []) if f not in out]
    return out


def _is_library(rel: str) -> bool:
    return rel.startswith(LIB_DIR + "/")


def library_files(gen_dir: Path) -> list[str]:
    """OSQP library files the folder's Makefile lists (git-ignored, restorable)."""
    return [f for f in makefile_files(gen_dir) if _is_library(f)] if (gen_dir / "Makefile").is_file() else []


def missing_library(gen_dir: Path) -> list[str]:
    return [f for f in library_files(gen_dir) if not (gen_dir / f).is_file()]


def check_files(gen_dir: Path, name: str) -> None:
    """Raise :class:`FolderMismatch` naming the first generated file ``make`` needs that is missing."""
    need = ["Makefile", "problem.py"]
    if (gen_dir / "Makefile").is_file():
        need += [f for f in makefile_files(gen_dir) if not _is_library(f)]
    missing = [f for f in need if not (gen_dir / f).is_file()]
    if missing:
        more = f" (and {len(missing) - 1} more)" if len(missing) > 1 else ""
        raise FolderMismatch(
            f"{gen_dir}: missing {missing[0]}{more}, a file of solver {name!r}; regenerate the "
            f"folder: {regenerate_command(gen_dir)}"
        )


def check_sizes(gen_dir: Path, name: str) -> None:
    """Raise :class:`FolderMismatch` if a size macro of the header differs from what ``problem.py`` gives."""
    from ..presets import load_problem
    from .generate import problem_sizes

    pb = load_problem(str(gen_dir / "problem.py"))
    if pb.name != name:
        raise FolderMismatch(
            f"{gen_dir}: problem.py is the problem {pb.name!r}, the header is solver {name!r}; regenerate the "
            f"folder: {regenerate_command(gen_dir)}"
        )
    have = read_macros(gen_dir / f"{name}_solver.h", name)
    for key, want in problem_sizes(pb).items():
        got = have.get(key)
        if got != want:
            shown = "missing" if got is None else str(got)
            raise FolderMismatch(
                f"{gen_dir}: {name}_solver.h has {name.upper()}_{key} {shown} but problem.py "
                f"gives {want}: the files do not belong together; regenerate the folder: {regenerate_command(gen_dir)}"
            )


def check_folder(gen_dir: Path | str) -> str:
    """All checks (OSQP's library copy apart, which ``fcgen build`` restores); returns the solver name."""
    gen_dir = Path(gen_dir)
    name = the_solver(gen_dir)
    check_files(gen_dir, name)
    check_sizes(gen_dir, name)
    return name
