"""CommonRoad scenarios in, CommonRoad solutions out (docs/commonroad.md): a scenario's lanelet network becomes fcgen's
road with its drivable band, its recorded traffic the opponents' predictions, its planning problem the ego's start;
a run is judged by the drivability checker beside fcgen's own check and written as a solution file."""

import warnings

# commonroad-io's generated protobuf modules warn on import (deprecated descriptor calls)
# (not about fcgen's use)
warnings.filterwarnings("ignore", category=DeprecationWarning, module=r"commonroad(\.|$)")
warnings.filterwarnings("ignore", category=DeprecationWarning, message=r"Call to deprecated create function")

from .judge import drivability_verdict, fcgen_collisions
from .plot import plot_run
from .scenario import CrScenario, load_scenario
from .solution import solution_verdict, write_solution
from .traffic import CrObstacle, ScenarioRefused, opponent_horizon, select_opponents

__all__ = [
    "CrObstacle",
    "CrScenario",
    "ScenarioRefused",
    "drivability_verdict",
    "fcgen_collisions",
    "load_scenario",
    "opponent_horizon",
    "plot_run",
    "select_opponents",
    "solution_verdict",
    "write_solution",
]
