"""The one QP layout shared by the Python reference and the generated C, in two views.

``layout``: ``QpLayout``, the CSC view (variables and rows stage after stage, A's fixed pattern, the index maps the C
solver is emitted with) and the shift of a plan by one sample. ``stage_view``: the same QP stage by stage, rows by
class (for the Riccati interior-point backend). ``soft_rows``: the soft rows of a stage view as units of their own.
``from fcgen.qp import X`` is the way to use them.
"""

from __future__ import annotations

from .layout import BAND_ROW_SIDES, BAND_SCALE, QpLayout, assert_finite_bounds, build_layout, shift_fields, shifted
from .soft_rows import SoftRows, split_soft_rows
from .stage_view import StageView, slack_bound_sides, stage_view

__all__ = [
    "BAND_ROW_SIDES",
    "BAND_SCALE",
    "QpLayout",
    "SoftRows",
    "StageView",
    "assert_finite_bounds",
    "build_layout",
    "shift_fields",
    "shifted",
    "slack_bound_sides",
    "split_soft_rows",
    "stage_view",
]
