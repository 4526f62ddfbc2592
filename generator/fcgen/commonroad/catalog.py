"""A checked-in list of public CommonRoad scenario files (name, data set, SHA-256, where to get them), the cache that
holds them, and the hash check a run makes before it reads one (docs/commonroad.md, "At scale").

A list is a CSV with the columns ``LIST_COLUMNS``; the files are third-party data and not in the repository:
``fetch`` copies them into a cache folder from GitHub raw at the pinned commit, from a local clone or mirror of the
source repository, or from a folder, and keeps a file only when its SHA-256 is the list's.
"""

from __future__ import annotations

import csv
import hashlib
import subprocess
import urllib.request
from dataclasses import dataclass
from pathlib import Path

LIST_COLUMNS = ("file", "dataset", "sha256", "git_blob", "source_repository", "source_commit", "source_path")
RAW_URL = "https://raw.githubusercontent.com/{repo}/{commit}/{path}"


class HashMismatch(ValueError):
    """A scenario file whose SHA-256 differs from its list's; the message is one line naming it and both hashes."""


@dataclass(frozen=True)
class ListedScenario:
    """One row of a scenario list."""

    file: str
    dataset: str
    sha256: str  # "" where the list could not be made with it: then the git blob id checks the file
    git_blob: str  # the file's git object id at the source commit (SHA-1 of "blob SIZE\0" + its bytes)
    source_repository: str
    source_commit: str
    source_path: str

    def __post_init__(self) -> None:
        if Path(self.file).name != self.file or not self.file.lower().endswith(".xml"):
            raise ValueError(f"scenario list: file {self.file!r} must be a bare *.xml file name")
        for col, n in (("sha256", 64), ("git_blob", 40)):
            v = getattr(self, col)
            if (v or col == "git_blob") and (len(v) != n or any(c not in "0123456789abcdef" for c in v)):
                raise ValueError(f"scenario list: {self.file}: {col} {v!r} is not {n} lower-case hex digits")
        if self.dataset != dataset_of(self.file):
            raise ValueError(f"scenario list: {self.file}: dataset {self.dataset!r} is not {dataset_of(self.file)!r}")


def dataset_of(name: str) -> str:
    """The data set of a CommonRoad scenario (its id or file name): the location before the first ``-``
    (``USA_US101-7_1_T-1`` -> ``USA_US101``, ``DEU_Muc-3_1_T-1.xml`` -> ``DEU_Muc``)."""
    return Path(name).stem.split("-", 1)[0]


def sha256_of(path: str | Path) -> str:
    """The SHA-256 of a file's bytes (hex)."""
    return hashlib.sha256(Path(path).read_bytes()).hexdigest()


def git_blob_of(data: bytes) -> str:
    """Git's object id of a blob holding ``data``."""
    return hashlib.sha1(b"blob %d\0" % len(data) + data, usedforsecurity=False).hexdigest()


def mismatch(row: ListedScenario, data: bytes) -> str:
    """ "" when ``data`` is the listed file (its SHA-256, or its git blob id where the list has no SHA-256), else one
    line naming the file and both hashes."""
    col, want = ("sha256", row.sha256) if row.sha256 else ("git blob", row.git_blob)
    got = hashlib.sha256(data).hexdigest() if row.sha256 else git_blob_of(data)
    if got == want:
        return ""
    return f"{row.file}: {col} {got[:12]}... differs from the list's {want[:12]}..."


def read_list(path: str | Path) -> list[ListedScenario]:
    """The rows of a scenario list (CSV with ``LIST_COLUMNS``); a missing column or a bad row: ``ValueError``."""
    with open(path, newline="") as f:
        reader = csv.DictReader(f)
        missing = [c for c in LIST_COLUMNS if c not in (reader.fieldnames or [])]
        if missing:
            raise ValueError(f"scenario list {path}: no column {', '.join(missing)} (needs {', '.join(LIST_COLUMNS)})")
        rows = [ListedScenario(**{c: r[c].strip() for c in LIST_COLUMNS}) for r in reader]
    names = [r.file for r in rows]
    if len(set(names)) != len(names):
        raise ValueError(f"scenario list {path}: a file is listed twice")
    if not rows:
        raise ValueError(f"scenario list {path}: no scenario in it")
    return rows


def write_list(rows: list[ListedScenario], path: str | Path) -> None:
    """Write a scenario list (sorted by file name)."""
    with open(path, "w", newline="") as f:
        w = csv.writer(f, lineterminator="\n")
        w.writerow(LIST_COLUMNS)
        for r in sorted(rows, key=lambda r: r.file):
            w.writerow([getattr(r, c) for c in LIST_COLUMNS])


def check_file(path: str | Path, row: ListedScenario) -> None:
    """Raise ``HashMismatch`` unless the file is the listed one (``mismatch``)."""
    msg = mismatch(row, Path(path).read_bytes())
    if msg:
        raise HashMismatch(msg)


def source_bytes(row: ListedScenario, source: str) -> bytes:
    """The file's bytes from ``source``: ``github`` (raw at the pinned commit), a git directory (a clone or a bare
    mirror of the source repository: the pinned commit's blob), or a folder holding the file by name."""
    if source == "github":
        url = RAW_URL.format(repo=row.source_repository, commit=row.source_commit, path=row.source_path)
        with urllib.request.urlopen(url, timeout=60) as resp:
            return resp.read()
    src = Path(source)
    if (src / "HEAD").is_file() or (src / ".git").exists():
        return subprocess.run(
            ["git", "-C", str(src), "show", f"{row.source_commit}:{row.source_path}"],
            check=True,
            capture_output=True,
        ).stdout
    return (src / row.file).read_bytes()


def fetch(rows: list[ListedScenario], cache: str | Path, source: str = "github", echo=print) -> dict[str, int]:
    """Copy the listed files into ``cache`` (a file already there with the list's hash is kept); a file whose bytes
    have another hash is not written: one line naming it. Returns the counts ``fetched``, ``cached``, ``mismatch``
    and ``failed``."""
    out = Path(cache)
    out.mkdir(parents=True, exist_ok=True)
    counts = dict.fromkeys(("fetched", "cached", "mismatch", "failed"), 0)
    for row in rows:
        dest = out / row.file
        if dest.is_file() and not mismatch(row, dest.read_bytes()):
            counts["cached"] += 1
            continue
        try:
            data = source_bytes(row, source)
        except (OSError, subprocess.CalledProcessError) as exc:
            echo(f"{row.file}: not fetched from {source} ({type(exc).__name__}: {exc})")
            counts["failed"] += 1
            continue
        msg = mismatch(row, data)
        if msg:
            echo(f"{msg} (from {source}): not kept")
            counts["mismatch"] += 1
            continue
        tmp = dest.with_suffix(".part")
        tmp.write_bytes(data)
        tmp.replace(dest)
        counts["fetched"] += 1
    return counts
