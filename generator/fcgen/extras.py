"""The optional parts of fcgen and the pip extra that brings each. Every import of an extra's package goes through
``require``: a command whose extra is missing fails with one line that names the pip command, not a traceback."""

from __future__ import annotations

import importlib.util
from collections.abc import Iterable, Iterator
from contextlib import contextmanager
from typing import Any, TypeVar

EXTRAS: dict[str, str] = {
    "campaign": "the paper's campaign and its report (tqdm, dask[distributed], pandas, pyarrow)",
    "plot": "figures (matplotlib)",
    "commonroad": "CommonRoad scenarios (commonroad-io, commonroad-drivability-checker; the criticality measures' "
    "commonroad-crime is installed by scripts/setup.sh: docs/commonroad.md)",
    "fmu": "the FMU and its co-simulation (fmpy)",
    "plants": "CommonRoad's vehicle models as closed-loop plants (commonroad-vehicle-models)",
}
"""Extra -> what it brings (pyproject.toml's [project.optional-dependencies] lists its packages)."""

T = TypeVar("T")


class MissingExtra(ImportError):
    """A package of an extra is not installed; the message is the one line a command prints."""


def install_hint(extra: str) -> str:
    """The pip command that installs ``extra``."""
    return f"pip install 'fcgen[{extra}]'"


@contextmanager
def require(extra: str, what: str = "this command") -> Iterator[None]:
    """Import an extra's packages inside: an ImportError becomes ``MissingExtra`` naming the package and the pip
    command (``what``: what needs it, for the message)."""
    if extra not in EXTRAS:
        raise ValueError(f"extra = {extra!r} is not an extra of fcgen; allowed: {', '.join(EXTRAS)}")
    try:
        yield
    except MissingExtra:
        raise
    except ImportError as exc:
        missing = exc.name or str(exc)
        raise MissingExtra(
            f"{what} needs the '{extra}' extra ({missing} is not installed): {install_hint(extra)}"
        ) from None


def progress(iterable: Iterable[T], **tqdm_kw: Any) -> Iterable[T]:
    """``iterable`` with a tqdm progress bar (the campaign extra), or as it is where tqdm is not installed: a bar is
    a convenience, never a reason to fail a closed loop."""
    if importlib.util.find_spec("tqdm") is None:
        return iterable
    with require("campaign", "a progress bar"):
        from tqdm import tqdm
    return tqdm(iterable, **tqdm_kw)
