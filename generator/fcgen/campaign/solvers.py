"""Compiled solvers for the campaign: generated and built once per configuration, cached by a content hash.

The cache folder of a problem is ``<cache>/<name>-<hash>``, where the hash covers the problem record (the
``problem.py`` source that ``fcgen generate`` writes), the precision, the fcgen version and a fingerprint of the
generator's own files (Python modules and templates), so a changed generator never reuses a stale solver. Building
is guarded by a file lock, so parallel workers (processes, Dask workers) build each solver once.
"""

from __future__ import annotations

import fcntl
import hashlib
from functools import lru_cache
from pathlib import Path

from .. import __version__
from ..dsl import Problem
from ..testhook import pause_point

READY = ".fcgen-ready"
#: package parts that do not decide the generated C (the fingerprint leaves them out)
NOT_GENERATOR = ("campaign", "report", "sim", "wcet", "cli.py", "bench.py", "verify.py", "demo.py", "firmware_sim")


@lru_cache(maxsize=1)
def generator_fingerprint() -> str:
    """sha256 over the package's modules and templates that decide the generated C."""
    root = Path(__file__).resolve().parent.parent
    h = hashlib.sha256()
    for p in sorted(root.rglob("*")):
        rel = p.relative_to(root)
        if (
            p.is_file()
            and (p.suffix in (".py", ".j2", ".c", ".h") or p.name == "Makefile")
            and "__pycache__" not in rel.parts
            and rel.parts[0] not in NOT_GENERATOR
        ):
            h.update(str(p.relative_to(root)).encode())
            h.update(p.read_bytes())
    return h.hexdigest()


def solver_hash(problem: Problem, use_float: bool = False, cflags: str | None = None) -> str:
    """16 hex digits identifying the generated solver of ``problem`` with this generator (and these C flags)."""
    from ..codegen.generate import problem_source

    h = hashlib.sha256()
    parts = [problem_source(problem), f"float={use_float}", __version__, generator_fingerprint()]
    if cflags is not None:  # the default build keeps the hash it always had
        parts.append(f"cflags={cflags}")
    for part in parts:
        h.update(part.encode())
        h.update(b"\0")
    return h.hexdigest()[:16]


def ensure_solver(problem: Problem, cache_dir: str | Path, use_float: bool = False, cflags: str | None = None) -> Path:
    """The shared library of ``problem``'s solver: generated and built (with ``cflags``, default the build's) into
    the cache unless already there."""
    from ..build import build
    from ..codegen.generate import generate

    cache = Path(cache_dir)
    cache.mkdir(parents=True, exist_ok=True)
    folder = cache / f"{problem.name}-{solver_hash(problem, use_float, cflags)}"
    lib = folder / "build" / f"lib{problem.name}.so"
    if _ready(folder, lib):
        return lib
    with open(cache / f"{folder.name}.lock", "w") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)
        try:
            if not _ready(folder, lib):
                if not (folder / READY).is_file():
                    generate(problem, folder, use_float=use_float)
                pause_point("solvers:generated")  # the kill test's moment: holding the lock, not built yet
                built = build(folder, jobs=1, cflags=cflags)  # make rebuilds what other flags compiled
                assert built == lib, (built, lib)
                (folder / READY).write_text(_flags_line(folder))
        finally:
            fcntl.flock(lock, fcntl.LOCK_UN)
    return lib


def _flags_line(folder: Path) -> str:
    """The compile line the folder's Makefile recorded for its last build (``build/flags.txt``; '' if none)."""
    f = folder / "build" / "flags.txt"
    return f.read_text() if f.is_file() else ""


def _ready(folder: Path, lib: Path) -> bool:
    """Built by the cache and not rebuilt since with other flags (e.g. ``fcgen simulate --solver-dir`` on a cache
    folder builds it with ``$CFLAGS`` or -O2): the flags recorded at READY are still the build's."""
    ready = folder / READY
    return ready.is_file() and lib.is_file() and ready.read_text() == _flags_line(folder)
