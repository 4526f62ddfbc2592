"""One builder of a solver folder at a time (``fcgen.locks.folder_lock``): two processes that build the same folder
(two test workers on a checked-in folder of generated/) ran two ``make`` in one ``build/``, and one linked against a
library the other was re-archiving (``undefined reference to 'truck_lift_el_osqp_update_data_vec'``)."""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
import time
from pathlib import Path

import pytest

from fcgen.locks import folder_lock, lock_path

ROOT = Path(__file__).resolve().parents[1]
SOLVER = ROOT / "generated" / "truck_lifted_ellipse"
FCGEN = str(Path(sys.executable).with_name("fcgen"))
needs_make = pytest.mark.skipif(any(shutil.which(t) is None for t in ("cc", "make")), reason="needs cc and make")


def _fresh_copy(tmp_path: Path) -> Path:
    """The checked-in folder as a fresh clone has it: no build/, no OSQP library copy (both git-ignored)."""
    return shutil.copytree(SOLVER, tmp_path / "s", ignore=shutil.ignore_patterns("build", "golden", "lib"))


def _waiters(lock: Path) -> set[int]:
    """Pids of the processes blocked on the flock of file ``lock`` (``/proc/locks``: ``-> FLOCK ... pid dev:inode``)."""
    ino = lock.stat().st_ino
    out = set()
    for line in Path("/proc/locks").read_text().splitlines():
        f = line.split()
        if len(f) > 6 and f[1] == "->" and f[2] == "FLOCK" and f[6].split(":")[-1] == str(ino):
            out.add(int(f[5]))
    return out


def test_the_lock_file_is_outside_the_folder_and_keyed_by_its_real_path(tmp_path):
    folder = tmp_path / "solver"
    folder.mkdir()
    (tmp_path / "link").symlink_to(folder)
    assert lock_path(folder) == lock_path(tmp_path / "link") == lock_path(str(folder) + "/.")
    assert lock_path(folder) != lock_path(tmp_path)
    assert folder not in lock_path(folder).parents  # `rm -r build` or `make clean` cannot remove a held lock
    with folder_lock(folder), folder_lock(tmp_path / "link"):  # nested in one process: re-entered, no self-deadlock
        pass


@pytest.mark.skipif(not Path("/proc/locks").is_file(), reason="needs /proc/locks")
@needs_make
def test_a_second_build_of_a_folder_waits_until_the_first_is_done(tmp_path):
    s = _fresh_copy(tmp_path)
    with folder_lock(s) as lock:  # this test is the first builder
        proc = subprocess.Popen([FCGEN, "build", str(s), "--verify"], stdout=subprocess.PIPE, stderr=subprocess.STDOUT)
        deadline = time.monotonic() + 120  # a failure guard only: the wait is seen in /proc/locks
        while proc.pid not in _waiters(lock):
            assert proc.poll() is None, f"the second build did not wait: {proc.communicate()[0].decode()}"
            assert time.monotonic() < deadline, "the second build never blocked on the folder's lock"
            time.sleep(0.05)
        assert not (s / "build").exists() and not (s / "osqp" / "lib").exists()  # nothing written while it waits
    out = proc.communicate(timeout=600)[0].decode()
    assert proc.returncode == 0, out
    assert (s / "build" / "verify" / "truck_lift_el_example").is_file()


@needs_make
def test_two_concurrent_builds_of_one_folder_both_succeed(tmp_path):
    s = _fresh_copy(tmp_path)
    code = "import sys; from fcgen.build import build; build(sys.argv[1], verify=True)"
    procs = [
        subprocess.Popen([sys.executable, "-c", code, str(s)], stdout=subprocess.PIPE, stderr=subprocess.STDOUT)
        for _ in range(2)
    ]
    outs = [p.communicate(timeout=600)[0].decode() for p in procs]
    assert [p.returncode for p in procs] == [0, 0], "\n".join(outs)
    exe = s / "build" / "verify" / "truck_lift_el_example"
    assert subprocess.run([str(exe)], capture_output=True, cwd=s, env={**os.environ}).returncode == 0
