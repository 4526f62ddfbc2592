"""Problem description: frozen dataclasses, validated on construction.

Every value is checked in ``__post_init__`` so a bad problem fails at the earliest layer with one
:class:`ProblemError` that names the field and the allowed range. The classes live by theme in the modules of this
package (vehicles, horizon and road window, costs, bounds, tracking reference, formulations, obstacle models, QP
options, plan check, the problem); ``from fcgen.dsl import X`` is the way to use them.
"""

from __future__ import annotations

from .bounds import ROAD_BOUNDS, Bounds
from .costs import SoftPenalties, Weights
from .formulations import OVERAPPROX, Conventional, DirectElimination, Formulation, Lifted
from .horizon import Horizon, RoadWindow
from .obstacle_models import (
    CIRCLE_RADII,
    ELLIPSE_SHAPES,
    CoveringCircles,
    Ellipse,
    ObstacleModel,
    SeparatingHyperplane,
    circles_cover,
)
from .plan_check import PlanCheck
from .problem import Problem, describe
from .qp_options import BACKENDS, RTI_BUDGET_DEFAULT, QpOptions
from .tracking import Reference
from .validation import ProblemError
from .vehicle import Opponents, Vehicle, Wind

__all__ = [
    "BACKENDS",
    "CIRCLE_RADII",
    "ELLIPSE_SHAPES",
    "OVERAPPROX",
    "ROAD_BOUNDS",
    "RTI_BUDGET_DEFAULT",
    "Bounds",
    "Conventional",
    "CoveringCircles",
    "DirectElimination",
    "Ellipse",
    "Formulation",
    "Horizon",
    "Lifted",
    "ObstacleModel",
    "Opponents",
    "PlanCheck",
    "Problem",
    "ProblemError",
    "QpOptions",
    "Reference",
    "RoadWindow",
    "SeparatingHyperplane",
    "SoftPenalties",
    "Vehicle",
    "Weights",
    "Wind",
    "circles_cover",
    "describe",
]
