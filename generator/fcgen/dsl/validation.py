"""The DSL's one error and its checks: a bad value fails at construction, naming the field and the allowed range."""

from __future__ import annotations

import math


class ProblemError(ValueError):
    """An invalid problem description: names the field and the allowed range."""


def check(ok: bool, name: str, value, allowed: str) -> None:
    """Raise ``ProblemError`` naming ``name``, its ``value`` and the ``allowed`` range unless ``ok``."""
    if not ok:
        raise ProblemError(f"{name} = {value!r} is invalid: allowed {allowed}")


def finite(name: str, value) -> float:
    """``value`` as a finite float, else ``ProblemError``."""
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise ProblemError(f"{name} = {value!r} is invalid: allowed a finite real number") from None
    check(math.isfinite(v), name, value, "a finite real number")
    return v


def positive(name: str, value) -> None:
    """``value`` is a finite real number > 0."""
    check(finite(name, value) > 0, name, value, "> 0")


def nonneg(name: str, value) -> None:
    """``value`` is a finite real number >= 0."""
    check(finite(name, value) >= 0, name, value, ">= 0")


def vector(name: str, value, n: int, each=nonneg) -> None:
    """``value`` is a tuple of ``n`` numbers, each passing ``each``."""
    check(isinstance(value, tuple) and len(value) == n, name, value, f"a tuple of {n} numbers")
    for i, v in enumerate(value):
        each(f"{name}[{i}]", v)
