"""scripts/setup.sh waits its turn: for another install's package-manager lock (bounded, with a clear message when it
gives up), and for another set-up of the same clone. Its functions (scripts/setup_lib.sh) run here against a
stand-in ``apt-get`` that reports the lock error a real one prints while another install runs."""

from __future__ import annotations

import os
import subprocess
import time
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
LIB = ROOT / "scripts" / "setup_lib.sh"
LOCK_ERROR = "E: Could not get lock /var/lib/dpkg/lock-frontend. It is held by process 4242 (apt-get)"


def _fake_apt(tmp: Path, busy_calls: int, error: str = LOCK_ERROR) -> Path:
    """A bin folder whose ``apt-get`` logs its arguments and fails with ``error`` on its first ``busy_calls`` calls."""
    bin_ = tmp / "bin"
    bin_.mkdir()
    (bin_ / "apt-get").write_text(
        "#!/usr/bin/env bash\n"
        f"n=$(cat {tmp}/calls 2>/dev/null || echo 0); echo $((n + 1)) > {tmp}/calls\n"
        f'echo "$*" >> {tmp}/args\n'
        f'if [ "$n" -lt {busy_calls} ]; then echo "{error}" >&2; exit 100; fi\n'
    )
    (bin_ / "sudo").write_text('#!/usr/bin/env bash\nexec "$@"\n')
    for f in bin_.iterdir():
        f.chmod(0o755)
    return bin_


def _source(cmd: str, cwd: Path, **env: str) -> subprocess.CompletedProcess:
    return subprocess.run(
        ["bash", "-c", f"set -euo pipefail; source {LIB}; {cmd}"],
        cwd=cwd,
        capture_output=True,
        text=True,
        env={**os.environ, **env},
        timeout=60,
    )


def test_apt_waits_for_the_lock_of_another_install_then_installs(tmp_path):
    bin_ = _fake_apt(tmp_path, busy_calls=2)
    res = _source("apt_install gcc make", tmp_path, PATH=f"{bin_}:{os.environ['PATH']}", FCGEN_APT_RETRY="0")
    assert res.returncode == 0, res.stderr
    calls = (tmp_path / "args").read_text().splitlines()
    # update refused twice (the lock), then update and install, each asking apt itself to wait for dpkg's lock
    assert [c.split()[-1] for c in calls] == ["-qq", "-qq", "-qq", "make"]
    assert all(c.startswith("-o DPkg::Lock::Timeout=600 ") for c in calls)
    assert res.stderr.count("another apt-get or dpkg is running; waiting for it (at most 600 s)") == 1
    assert "Could not get lock" not in res.stderr  # the retried attempts' errors are not shown


def test_apt_gives_up_after_the_bounded_wait_saying_what_to_do(tmp_path):
    bin_ = _fake_apt(tmp_path, busy_calls=10**6)
    res = _source("apt_install gcc", tmp_path, PATH=f"{bin_}:{os.environ['PATH']}", FCGEN_APT_WAIT="0")
    assert res.returncode == 100
    assert LOCK_ERROR in res.stderr
    assert "the package manager is still busy after 0 s" in res.stderr
    assert "then run 'bash scripts/setup.sh' again (FCGEN_APT_WAIT=SECONDS waits longer)" in res.stderr
    assert "install" not in (tmp_path / "args").read_text()


def test_apt_fails_at_once_on_another_error(tmp_path):
    bin_ = _fake_apt(tmp_path, busy_calls=1, error="E: Unable to locate package gcc-arm-none-eabi")
    res = _source("apt_install gcc-arm-none-eabi", tmp_path, PATH=f"{bin_}:{os.environ['PATH']}")
    assert res.returncode == 100 and "Unable to locate package" in res.stderr
    assert (tmp_path / "calls").read_text().strip() == "1" and "waiting" not in res.stderr


def _dir_lock_waiters(folder: Path) -> int:
    """How many processes wait for a flock of ``folder`` (``/proc/locks``: ``-> FLOCK ... dev:inode``)."""
    ino = str(folder.stat().st_ino)
    lines = Path("/proc/locks").read_text().splitlines()
    return sum(1 for ln in lines if " -> FLOCK " in f" {ln} " and ln.split()[6].split(":")[-1] == ino)


@pytest.mark.skipif(not Path("/proc/locks").is_file(), reason="needs /proc/locks")
def test_a_second_setup_of_a_clone_waits_for_the_first(tmp_path):
    clone = tmp_path / "clone"
    clone.mkdir()
    hold = "setup_lock; echo {0} >> order; while [ ! -e release ]; do sleep 0.05; done; echo {0}-done >> order"
    first = subprocess.Popen(["bash", "-c", f"set -e; source {LIB}; {hold.format('first')}"], cwd=clone)
    deadline = time.monotonic() + 60  # failure guards only: the order is what is checked
    while not (clone / "order").exists():
        assert time.monotonic() < deadline and first.poll() is None
        time.sleep(0.05)
    second = subprocess.Popen(
        ["bash", "-c", f"set -e; source {LIB}; {hold.format('second')}"], cwd=clone, stderr=subprocess.PIPE, text=True
    )
    while _dir_lock_waiters(clone) == 0:
        assert time.monotonic() < deadline and second.poll() is None
        time.sleep(0.05)
    # a third one that will not wait: gives up at once, saying so
    res = _source("setup_lock", clone, FCGEN_SETUP_WAIT="0")
    assert res.returncode == 1 and "let it finish, then run 'bash scripts/setup.sh' again" in res.stderr
    (clone / "release").touch()
    assert first.wait(60) == 0 and second.wait(60) == 0
    assert (clone / "order").read_text().split() == ["first", "first-done", "second", "second-done"]
    assert "another scripts/setup.sh of" in second.stderr.read()
