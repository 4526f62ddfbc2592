"""The DSL's one error and its checks: a bad value fails at construction, naming the field and the allowed range."""

from __future__ import annotations

import difflib
import functools
import math
from dataclasses import fields
from typing import TypeVar

T = TypeVar("T")


class ProblemError(ValueError):
    """An invalid problem description: names the field and the allowed range."""


class UnknownFieldError(ProblemError, TypeError):
    """A keyword that is no field of the DSL class (a ``TypeError`` too, as Python's own for a bad keyword)."""


def unknown_field_message(cls_name: str, name: str, allowed: list[str]) -> str:
    """``Bounds has no field 'vmax'; did you mean 'v_max'? Allowed: ...`` (the nearest field, case ignored)."""
    lower = {a.lower(): a for a in allowed}
    near = difflib.get_close_matches(name.lower(), list(lower), n=1, cutoff=0.6)
    hint = f"; did you mean {lower[near[0]]!r}?" if near else ";"
    return (
        f"{cls_name} has no field {name!r}{hint} Allowed: {', '.join(allowed) or f'none ({cls_name} takes no fields)'}"
    )


def known_fields(cls: type[T]) -> type[T]:
    """Class decorator (above ``@dataclass``): a keyword that is no field raises :class:`UnknownFieldError` naming the
    allowed fields and the nearest one, instead of Python's bare ``unexpected keyword argument``."""
    init = cls.__init__
    allowed = [f.name for f in fields(cls) if f.init]  # type: ignore[arg-type]

    @functools.wraps(init)
    def __init__(self, *args, **kwargs) -> None:
        for k in kwargs:
            if k not in allowed:
                raise UnknownFieldError(unknown_field_message(cls.__name__, k, allowed))
        init(self, *args, **kwargs)

    setattr(cls, "__init__", __init__)  # noqa: B010 (mypy: no assignment to a method)
    return cls


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


def real_in(name: str, value, lo: float, hi: float, allowed: str) -> None:
    """``value`` is a real number (not a bool) in [lo, hi], else ``ProblemError`` naming ``allowed``."""
    ok = isinstance(value, (int, float)) and not isinstance(value, bool)
    check(ok and math.isfinite(value) and lo <= value <= hi, name, value, allowed)


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
