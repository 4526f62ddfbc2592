"""Writing results so that nothing is lost: whole files and folders appear in one rename, paths are checked first.

* ``write_text`` / ``write_bytes``: a temporary file beside the target, then ``os.replace`` (a reader, or a kill at
  any moment, sees the old file or the new one, never half of it);
* ``staged_folder``: a temporary folder beside the target, swapped in when complete. On Linux the swap is one
  ``renameat2(RENAME_EXCHANGE)`` (the path always names a whole folder, old or new); elsewhere two renames (a kill
  between them leaves the old folder intact under a hidden ``.<name>.fcgen-old-*`` name beside it);
* ``check_file_target`` / ``check_folder_target``: fail before any work when a path cannot be written (a parent is
  a file, the target is of the other kind, or it exists and ``force`` is not given), naming the path.

Leftovers of a killed call are hidden folders/files named ``.<name>.fcgen-new-*`` / ``.<name>.fcgen-old-*`` /
``.<name>.*.tmp`` beside the target: never read by fcgen, safe to delete.
"""

from __future__ import annotations

import contextlib
import ctypes
import errno
import os
import shutil
import signal
import tempfile
import threading
from collections.abc import Iterator
from pathlib import Path

_RENAME_EXCHANGE = 2
_AT_FDCWD = -100


def _libc():
    try:
        lib = ctypes.CDLL(None, use_errno=True)
        fn = lib.renameat2
    except (OSError, AttributeError):
        return None
    fn.argtypes = (ctypes.c_int, ctypes.c_char_p, ctypes.c_int, ctypes.c_char_p, ctypes.c_uint)
    fn.restype = ctypes.c_int
    return fn


_renameat2 = _libc()


def exchange(a: Path | str, b: Path | str) -> bool:
    """Swap two existing paths in one step (Linux ``renameat2``); False where the system cannot (then nothing moved)."""
    if _renameat2 is None:
        return False
    if _renameat2(_AT_FDCWD, os.fsencode(str(a)), _AT_FDCWD, os.fsencode(str(b)), _RENAME_EXCHANGE) == 0:
        return True
    err = ctypes.get_errno()
    if err in (errno.ENOSYS, errno.EINVAL, errno.EOPNOTSUPP):
        return False
    raise OSError(err, os.strerror(err), str(b))


def _fsync_dir(folder: Path) -> None:
    try:
        fd = os.open(folder, os.O_RDONLY)
    except OSError:
        return
    try:
        os.fsync(fd)
    except OSError:
        pass
    finally:
        os.close(fd)


def write_bytes(path: Path | str, data: bytes) -> Path:
    """Write ``data`` to ``path`` atomically (a temporary file beside it, flushed to disk, then renamed)."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
    try:
        with os.fdopen(fd, "wb") as f:
            f.write(data)
            f.flush()
            os.fsync(f.fileno())
        os.chmod(tmp, 0o644)
        os.replace(tmp, path)
    except BaseException:
        with contextlib.suppress(OSError):
            os.unlink(tmp)
        raise
    _fsync_dir(path.parent)
    return path


def write_text(path: Path | str, text: str, encoding: str = "utf-8") -> Path:
    """Write ``text`` to ``path`` atomically (see ``write_bytes``)."""
    return write_bytes(path, text.encode(encoding))


def _first_file_parent(path: Path) -> Path | None:
    """The first of ``path``'s parents that exists and is not a folder (None if all existing ones are folders)."""
    for p in path.parents:
        if p.exists():
            return None if p.is_dir() else p
    return None


def check_file_target(path: Path | str, what: str, force: bool = False, option: str = "--out") -> Path:
    """Fail (ValueError, one line naming the path) unless ``path`` can become a file written by this call: no parent
    is a file, it is not a folder, and it does not exist yet unless ``force``."""
    path = Path(path)
    bad = _first_file_parent(path)
    if bad is not None:
        raise ValueError(f"{option} {path}: {bad} is a file, not a folder; nothing computed")
    if path.is_dir():
        raise ValueError(f"{option} {path}: is a folder; allowed a file path ({what}); nothing computed")
    if path.exists() and not force:
        raise ValueError(
            f"{option} {path}: exists ({what} of an earlier call, {path.stat().st_size} bytes) and "
            f"would be replaced; nothing computed: choose another path or add --force"
        )
    return path


def check_folder_target(path: Path | str, what: str, option: str = "--out") -> Path:
    """Fail (ValueError, one line naming the path) unless ``path`` can be a folder: no parent is a file, it is not a
    file, and it does not hold the current directory (the folder is replaced as a whole)."""
    path = Path(path)
    bad = _first_file_parent(path)
    if bad is not None:
        raise ValueError(f"{option} {path}: {bad} is a file, not a folder; nothing computed")
    if path.exists() and not path.is_dir():
        raise ValueError(f"{option} {path}: is a file; allowed a folder ({what}); nothing computed")
    if path.is_dir():
        here, target = Path.cwd().resolve(), path.resolve()
        if here == target or target in here.parents:
            raise ValueError(
                f"{option} {path}: holds the current directory; the folder is replaced as a whole: "
                f"run fcgen from outside it"
            )
    return path


def describe(folder: Path, limit: int = 4) -> str:
    """``'a, b, c, ... (7 entries)'``: what a folder holds, for a refusal."""
    names = sorted(p.name + ("/" if p.is_dir() else "") for p in folder.iterdir())
    shown = ", ".join(names[:limit]) + (", ..." if len(names) > limit else "")
    return f"{shown} ({len(names)} entr{'y' if len(names) == 1 else 'ies'})"


def _link(src: str | Path, dst: str | Path) -> None:
    try:
        os.link(src, dst)
    except OSError:
        shutil.copy2(src, dst)


def carry(src: Path, dst: Path) -> None:
    """``dst`` as a copy of ``src`` (a file, a folder or a link) made of hard links where possible: the original
    stays intact until a swap replaces it, and nothing is copied twice."""
    if src.is_symlink():
        os.symlink(os.readlink(src), dst)
    elif src.is_dir():
        shutil.copytree(src, dst, symlinks=True, copy_function=_link)
    else:
        _link(src, dst)


def replace_folder(new: Path, out: Path) -> None:
    """Put the complete folder ``new`` at ``out`` (replacing a folder there) and remove the old one."""
    if not out.exists() and not out.is_symlink():
        os.replace(new, out)
        _fsync_dir(out.parent)
        return
    if exchange(new, out):  # ``new`` now names the old folder
        _fsync_dir(out.parent)
        shutil.rmtree(new, ignore_errors=True)
        return
    old = Path(tempfile.mkdtemp(prefix=f".{out.name}.fcgen-old-", dir=out.parent))
    os.replace(out, old / "x")
    try:
        os.replace(new, out)
    except BaseException:
        os.replace(old / "x", out)
        raise
    _fsync_dir(out.parent)
    shutil.rmtree(old, ignore_errors=True)


@contextlib.contextmanager
def staged_folder(out: Path | str) -> Iterator[Path]:
    """A temporary folder beside ``out`` to write into; it replaces ``out`` when the block ends without an
    exception. On an exception or interrupt it is removed and ``out`` is untouched."""
    out = Path(os.path.realpath(out))  # a symlinked folder: its target is replaced, the link stays
    out.parent.mkdir(parents=True, exist_ok=True)
    tmp = Path(tempfile.mkdtemp(prefix=f".{out.name}.fcgen-new-", dir=out.parent))
    try:
        yield tmp
        os.chmod(tmp, 0o755)
        replace_folder(tmp, out)
    finally:
        if tmp.exists():
            shutil.rmtree(tmp, ignore_errors=True)


class TimeLimit(BaseException):
    """Raised by ``time_limit`` when its block runs out of time (a BaseException, like KeyboardInterrupt: the
    ``except Exception`` of a problem file or of a loader does not swallow it)."""


@contextlib.contextmanager
def time_limit(seconds: float | None, message: str) -> Iterator[None]:
    """Raise ``TimeLimit(message)`` in the block after ``seconds`` of wall time (None: no limit). A real-time timer
    signal (SIGALRM) interrupts Python code, including a problem file stuck in a loop or a sleep; the main thread
    only."""
    if not seconds:
        yield
        return
    if threading.current_thread() is not threading.main_thread():
        raise RuntimeError("time_limit: only in the main thread")

    def _expired(signum, frame):
        raise TimeLimit(message)

    old = signal.signal(signal.SIGALRM, _expired)
    signal.setitimer(signal.ITIMER_REAL, seconds)
    try:
        yield
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0)
        signal.signal(signal.SIGALRM, old)
