"""The output folder of ``fcgen generate``: whose it is, and replacing it in one move.

A solver is written into a temporary folder beside the target and moved into place when complete, so an interrupted
or failed generation leaves the target as it was. A folder that holds a different solver (or files that are no
solver's) is refused unless ``force``; with ``force`` the old solver's files go, the others stay. Regenerating the
same solver keeps its ``build/`` and the modification times of unchanged files (``make`` rebuilds only what changed).

What a generation wrote is recorded in ``.fcgen-generated.json`` (SHA-256 per file; git-ignored in generated/ and
left out by ``regenerate --check``: it is not generator output). Regenerating the same solver refuses, unless
``force``, when a recorded file was changed since (a hand edit of ``main.c``, say): it would be lost. A folder
without the record (a fresh checkout) is regenerated as before.
"""

from __future__ import annotations

import contextlib
import hashlib
import json
import os
import shutil
import tempfile
from collections.abc import Iterator
from datetime import UTC, datetime
from pathlib import Path

from ..atomic import replace_folder, write_text
from ..testhook import pause_point

SHARED_FILES = ("main.c", "CMakeLists.txt", "Makefile", "README.md", "problem.py")
"""Files of a solver folder that carry no solver name."""
OWNED_DIRS = ("osqp", "build")
"""Folders of a solver folder that belong to its solver (OSQP workspace and library copy, build products)."""


RECORD = Path(".fcgen-generated.json")
"""What the last generation wrote: ``{relative path: sha256}`` of every file outside build/ (a hidden file, not
generator output: git-ignored in generated/, left out by ``regenerate --check``)."""


def write_if_changed(path: Path, text: str) -> None:
    """Write ``text`` to ``path`` (folders made) unless it holds exactly that already."""
    data = text.encode()
    if not path.is_file() or path.read_bytes() != data:
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_bytes(data)


class FolderError(ValueError):
    """The output folder cannot take the solver (one line: names the folder, what is there and ``--force``)."""


def solvers_in(folder: Path) -> list[str]:
    """Names of the solvers whose ``<name>_solver.h`` is in ``folder`` (sorted)."""
    return sorted(p.name[: -len("_solver.h")] for p in folder.glob("*_solver.h") if p.is_file())


def _owned(entry: Path, names: list[str]) -> bool:
    """True if ``entry`` (directly in a solver folder) belongs to one of the solvers ``names``."""
    if entry.name in SHARED_FILES or entry.name in OWNED_DIRS:
        return True
    return any(entry.name.startswith(f"{n}_") for n in names)


def check_target(out_dir: Path, name: str, force: bool) -> None:
    """Raise :class:`FolderError` if ``out_dir`` cannot become the folder of solver ``name``."""
    for p in (out_dir, *out_dir.parents):
        if p.exists() and not p.is_dir():
            what = "the output folder" if p == out_dir else f"a parent of {out_dir}"
            raise FolderError(f"{out_dir}: {p} is a file, not a folder ({what}); choose a folder path")
        if p.is_dir():
            break
    if not out_dir.is_dir():
        return
    here, target = Path.cwd().resolve(), out_dir.resolve()
    if here == target or target in here.parents:
        raise FolderError(
            f"{out_dir} holds the current directory; the folder is replaced as a whole: run fcgen from "
            f"outside it (e.g. cd ..)"
        )
    if force:
        return
    names = solvers_in(out_dir)
    if names and names != [name]:
        raise FolderError(
            f"{out_dir} holds the solver {', '.join(repr(n) for n in names)}, not {name!r}: nothing "
            f"written; use another folder or --force to replace it (its files are removed)"
        )
    if not names:
        other = sorted(p.name for p in out_dir.iterdir())
        if other:
            raise FolderError(
                f"{out_dir} is not empty and holds no fcgen solver ({', '.join(other[:3])}"
                f"{', ...' if len(other) > 3 else ''}): nothing written; use an empty or new folder "
                f"or --force to write the solver beside these files"
            )


def _sha256(p: Path) -> str:
    return hashlib.sha256(p.read_bytes()).hexdigest()


def file_record(folder: Path) -> dict[str, str]:
    """``{relative path: sha256}`` of the files of ``folder`` outside build/ (the record itself left out)."""
    return {
        p.relative_to(folder).as_posix(): _sha256(p)
        for p in sorted(folder.rglob("*"))
        if p.is_file()
        and not p.is_symlink()
        and p.relative_to(folder).parts[0] != "build"
        and p.relative_to(folder) != RECORD
    }


def hand_edited(folder: Path) -> list[str]:
    """Files of ``folder`` changed since fcgen generated them (from its record; [] without a record)."""
    try:
        rec = json.loads((folder / RECORD).read_text())
    except (OSError, ValueError):
        return []
    return [rel for rel, sha in sorted(rec.items()) if (folder / rel).is_file() and _sha256(folder / rel) != sha]


def _utc(t: float) -> str:
    return datetime.fromtimestamp(t, UTC).strftime("%Y-%m-%d %H:%M UTC")


def edits_note(folder: Path | str) -> str | None:
    """One line naming the files of ``folder`` that differ from what ``fcgen generate`` wrote, when it wrote them and
    when each was last changed; None when none does (or the folder has no record: a fresh checkout). The OSQP
    library copy is left out: ``fcgen build`` restores it."""
    folder = Path(folder)
    edited = [rel for rel in hand_edited(folder) if not rel.startswith("osqp/lib/")]
    if not edited:
        return None
    shown = ", ".join(f"{rel} (changed {_utc((folder / rel).stat().st_mtime)})" for rel in edited[:3])
    more = f" and {len(edited) - 3} more" if len(edited) > 3 else ""
    return (
        f"{shown}{more} differ{'s' if len(edited) == 1 else ''} from what `fcgen generate` wrote at "
        f"{_utc((folder / RECORD).stat().st_mtime)} (hand edit?); `fcgen generate {folder / 'problem.py'} -o {folder} "
        f"--force` restores the generated files"
    )


def _write_record(folder: Path, record: dict[str, str]) -> None:
    """Write ``record`` into ``folder`` unless it holds the same already (regenerating an unchanged solver keeps every
    file, its time included)."""
    text = json.dumps(record, indent=0, sort_keys=True) + "\n"
    path = folder / RECORD
    if path.is_file() and path.read_text() == text:
        return
    if path.exists():
        path.unlink()  # a hard link into the old folder (``_carry``): never written through
    write_text(path, text)


def _same(a: Path, b: Path) -> bool:
    return a.is_file() and b.is_file() and a.stat().st_size == b.stat().st_size and a.read_bytes() == b.read_bytes()


def _link(src: str | Path, dst: str | Path) -> None:
    """``dst`` as a hard link of ``src`` (a copy where links are not possible); the original stays."""
    try:
        os.link(src, dst)
    except OSError:
        shutil.copy2(src, dst)


def _carry(src: Path, dst: Path) -> None:
    if src.is_dir() and not src.is_symlink():
        shutil.copytree(src, dst, symlinks=True, copy_function=_link)
    elif src.is_symlink():
        os.symlink(os.readlink(src), dst)
    else:
        _link(src, dst)


def _adopt(old: Path, new: Path, name: str) -> None:
    """Carry into ``new`` what of ``old`` survives (linked, so ``old`` stays intact until the swap): files that are
    no solver's, and for the same solver its build/ and the times of unchanged files."""
    names = solvers_in(old)
    same = names == [name]
    for entry in sorted(old.iterdir()):
        if not _owned(entry, names) and not (new / entry.name).exists():
            _carry(entry, new / entry.name)
    if not same:
        return
    if (old / "build").is_dir() and not (new / "build").exists():
        _carry(old / "build", new / "build")
    for f in new.rglob("*"):
        rel = f.relative_to(new)
        if rel.parts[0] != "build" and _same(f, old / rel):
            shutil.copystat(old / rel, f)


@contextlib.contextmanager
def staged(out_dir: Path | str, name: str, force: bool = False, check_edits: bool = True) -> Iterator[Path]:
    """A temporary folder beside ``out_dir`` to write solver ``name`` into; moved onto ``out_dir`` on success.

    On any exception (or interrupt) the temporary folder is removed and ``out_dir`` is untouched. ``check_edits``:
    refuse (unless ``force``) to replace files of the same solver changed since they were generated.
    """
    check_target(Path(out_dir), name, force)
    out_dir = Path(os.path.realpath(out_dir))  # a symlinked folder: its target is replaced, the link stays
    out_dir.parent.mkdir(parents=True, exist_ok=True)
    tmp = Path(tempfile.mkdtemp(prefix=f".{out_dir.name}.fcgen-new-", dir=out_dir.parent))
    try:
        yield tmp
        record = file_record(tmp)  # what this generation wrote (before the old folder's files are carried)
        if out_dir.is_dir():
            if check_edits and not force and solvers_in(out_dir) == [name]:
                edited = hand_edited(out_dir)
                if edited:
                    raise FolderError(
                        f"{out_dir}: {', '.join(edited[:3])}{', ...' if len(edited) > 3 else ''} "
                        f"changed since fcgen generated {'it' if len(edited) == 1 else 'them'} (hand "
                        f"edit?) and would be replaced: nothing written; copy your changes elsewhere "
                        f"or use --force"
                    )
            _adopt(out_dir, tmp, name)
        _write_record(tmp, record)
        pause_point("generate:before-swap")
        replace_folder(tmp, out_dir)  # one renameat2(RENAME_EXCHANGE) on Linux: DIR is old or new, never absent
    finally:
        if tmp.exists():
            shutil.rmtree(tmp, ignore_errors=True)
