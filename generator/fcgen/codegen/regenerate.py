"""Keep checked-in solver folders (``generated/<preset>/``) equal to what the generator writes today."""

from __future__ import annotations

import filecmp
import tempfile
from pathlib import Path

from ..presets import is_preset, preset, preset_names
from .generate import generate

IGNORED = ("build", "osqp/lib", "golden", ".fcgen-generated.json")
"""Sub-folders that are not generator output (build products, OSQP's restorable library copy, golden suites) and
the record of what the last generation wrote (``folder.RECORD``)."""


def tracked_files(folder: Path) -> set[str]:
    """Files of a solver folder that the generator owns (relative paths)."""
    out = set()
    for p in folder.rglob("*"):
        rel = p.relative_to(folder).as_posix()
        if p.is_file() and not any(rel == d or rel.startswith(d + "/") for d in IGNORED):
            out.add(rel)
    return out


def compare(expected: Path, actual: Path) -> list[str]:
    """Differences between two solver folders: missing, extra and differing files."""
    exp, act = tracked_files(expected), tracked_files(actual)
    diffs = [f"missing {f}" for f in sorted(exp - act)] + [f"unexpected {f}" for f in sorted(act - exp)]
    diffs += [f"differs {f}" for f in sorted(exp & act) if not filecmp.cmp(expected / f, actual / f, shallow=False)]
    return diffs


def regenerate(root: Path | str, names: list[str] | None = None, check: bool = False) -> dict[str, list[str]]:
    """Regenerate ``root/<preset>`` for every preset folder in ``root`` (plus ``names``).

    With ``check`` nothing is written and the differences are returned per folder (empty lists: byte-identical).
    """
    root = Path(root)
    found = sorted(p.name for p in root.iterdir() if p.is_dir()) if root.is_dir() else []
    unknown = [n for n in found if not is_preset(n)]
    if unknown:
        raise ValueError(f"{root}: folders {unknown} are not preset names; allowed: {', '.join(preset_names())}")
    result = {}
    for name in sorted(set(found) | set(names or [])):
        target = root / name
        if check:
            with tempfile.TemporaryDirectory() as tmp:
                generate(preset(name), tmp)
                result[name] = compare(Path(tmp), target)
        else:
            generate(preset(name), target, check_edits=False)  # checked-in folders: git holds any edit
            result[name] = []
    return result
