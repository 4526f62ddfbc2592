"""One builder of a folder at a time: ``folder_lock(path)``, an exclusive ``flock`` keyed by the folder's real path.

Two processes that build one solver folder at once (two test workers, a campaign beside a ``verify``) would run two
``make`` in one ``build/``: one removes and re-archives a library while the other links against it (``undefined
reference``), or rewrites a source file the other compiles. The lock file lives outside the folder (in the system's
temporary folder, per user) so ``make clean`` or ``rm -r build`` never removes a lock that another process holds.
Nested ``folder_lock`` of one folder in one process (a harness build that builds its solver first) re-enters.
"""

from __future__ import annotations

import contextlib
import fcntl
import hashlib
import os
import tempfile
import threading
from collections.abc import Iterator
from pathlib import Path

_GUARD = threading.Lock()
_HELD: dict[str, tuple[threading.RLock, list[int]]] = {}
"""Per lock file: a thread lock (one thread of this process at a time) and ``[fd, depth]`` of the flock held."""


def lock_path(folder: Path | str) -> Path:
    """The lock file of ``folder``: ``<tmp>/fcgen-locks-<uid>/<sha256 of its real path>.lock`` (outside it)."""
    real = os.path.realpath(folder)
    base = Path(tempfile.gettempdir()) / f"fcgen-locks-{os.getuid()}"
    base.mkdir(mode=0o700, parents=True, exist_ok=True)
    return base / f"{hashlib.sha256(real.encode()).hexdigest()[:24]}.lock"


@contextlib.contextmanager
def folder_lock(folder: Path | str) -> Iterator[Path]:
    """Hold the exclusive lock of ``folder`` (waiting for another holder to finish); yields the lock file's path."""
    path = lock_path(folder)
    with _GUARD:
        rlock, state = _HELD.setdefault(str(path), (threading.RLock(), [-1, 0]))
    with rlock:
        if state[1] == 0:
            fd = os.open(path, os.O_RDWR | os.O_CREAT, 0o600)
            try:
                fcntl.flock(fd, fcntl.LOCK_EX)
            except BaseException:
                os.close(fd)
                raise
            state[0] = fd
        state[1] += 1
        try:
            yield path
        finally:
            state[1] -= 1
            if state[1] == 0:
                fd, state[0] = state[0], -1
                fcntl.flock(fd, fcntl.LOCK_UN)
                os.close(fd)
