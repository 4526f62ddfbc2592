"""C literals of Python values: exact reals, brace-initializer bodies, macro lists.

A low module (it imports nothing of fcgen): the generator and the QP backends' C emission write their tables with it.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterable, Sequence


def c_real(x: float) -> str:
    """An exact C double literal (shortest round-trip repr)."""
    x = float(x)
    if not math.isfinite(x):
        raise ValueError(f"non-finite constant {x!r} cannot be emitted")
    return repr(x)


def c_real_literal(x: float, use_float: bool) -> str:
    """A C literal of the solver's real type: ``0.05`` (double) or ``0.05f`` (float, rounded by the compiler)."""
    return c_real(x) + ("f" if use_float else "")


def c_macro_list(values: Sequence, per_line: int = 20) -> str:
    """A brace initializer as a macro's body, continued over lines of ``per_line`` values."""
    items = [str(v) for v in values]
    lines = [", ".join(items[i : i + per_line]) for i in range(0, len(items), per_line)]
    return "{" + ", \\\n  ".join(lines) + "}"


def c_list(values: Iterable, fmt: Callable[..., str] = str, per_line: int = 12) -> str:
    """Comma-separated initializer body, ``per_line`` values a line; ``0`` for an empty table (length 1)."""
    items = [fmt(v) for v in values] or ["0"]
    lines = [", ".join(items[i : i + per_line]) for i in range(0, len(items), per_line)]
    return ",\n  ".join(lines)
