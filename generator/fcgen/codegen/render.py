"""Rendering of ``templates/`` (Jinja2): one environment for every emitted file, the generator's and the targets'.

A module of its own so that ``fcgen.targets`` (linker scripts) renders without importing the generator.
"""

from __future__ import annotations

import importlib.resources
from pathlib import Path
from typing import Any

import jinja2

from .. import __version__


def templates_dir() -> Path:
    """The ``templates/`` folder shipped inside the package."""
    return Path(str(importlib.resources.files("fcgen") / "templates"))


def csrc_dir() -> Path:
    """The hand-written C (``csrc/``: the IPM's algorithm) shipped inside the package."""
    return Path(str(importlib.resources.files("fcgen") / "csrc"))


def environment() -> jinja2.Environment:
    """The one Jinja2 environment of the templates (strict undefined, no autoescape, trimmed blocks)."""
    env = jinja2.Environment(
        loader=jinja2.FileSystemLoader(str(templates_dir())),
        undefined=jinja2.StrictUndefined,
        keep_trailing_newline=True,
        trim_blocks=True,
        lstrip_blocks=True,
        autoescape=False,
    )
    env.filters["dirname"] = lambda p: str(p).rsplit("/", 1)[0] if "/" in str(p) else "."
    return env


def render_template(template: str, **ctx: Any) -> str:
    """Render one file of ``templates/`` with ``ctx`` (and the fcgen version)."""
    return environment().get_template(template).render(version=__version__, **ctx)
