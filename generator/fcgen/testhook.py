"""A pause point for the kill tests: with ``FCGEN_PAUSE_AT=<name>`` a process stops at the named point of a write
(after announcing it in the file ``FCGEN_PAUSE_FLAG``) until it is killed, so a test can SIGKILL it exactly there.

Without the variable (every normal run) ``pause_point`` returns at once. The points are listed in
docs/data_integrity.md.
"""

from __future__ import annotations

import os
import time


def pause_point(name: str) -> None:
    """Stop here forever if ``$FCGEN_PAUSE_AT`` is ``name`` (the test then kills the process)."""
    if os.environ.get("FCGEN_PAUSE_AT") != name:
        return
    flag = os.environ.get("FCGEN_PAUSE_FLAG")
    if flag:
        with open(flag, "w") as f:
            f.write(f"{os.getpid()} {name}\n")
    while True:
        time.sleep(60)
