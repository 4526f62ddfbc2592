"""The complete problem that composes the parts; what ``fcgen generate`` turns into a C solver."""

from __future__ import annotations

import math
import re
import warnings
from dataclasses import dataclass, field, fields, replace
from typing import Any

from ..cnames import name_clash
from .bounds import Bounds
from .costs import SoftPenalties, Weights
from .formulations import Conventional, DirectElimination, Formulation, Lifted
from .horizon import Horizon, RoadWindow
from .obstacle_models import CoveringCircles, Ellipse, ObstacleModel, SeparatingHyperplane, circles_cover
from .plan_check import PlanCheck
from .qp_options import QpOptions
from .tracking import Reference
from .validation import ProblemError, check, known_fields, real_in
from .vehicle import Opponents, Vehicle, Wind

_NAME = re.compile(r"^[a-z][a-z0-9_]{0,30}$")

#: the largest ``Problem.delay`` (samples): the controls kept for the delay compensation's prediction
MAX_DELAY = 8
#: the largest ``Problem.steer_lag`` (s), the closed loop's steering actuator's
MAX_STEER_LAG = 2.0
#: the largest ``Problem.obstacle_margin`` (m): ``set_obstacle_margins``' range (``contract.INPUT_RANGES.margin_max``)
MAX_OBSTACLE_MARGIN = 10.0


@known_fields
@dataclass(frozen=True)
class Problem:
    """A complete NMPC problem: what ``fcgen generate`` turns into a C solver."""

    name: str
    formulation: Formulation = Lifted()
    obstacles: ObstacleModel = Ellipse()
    ego: Vehicle = Vehicle()
    opponents: Opponents = Opponents()
    wind: Wind = Wind()
    horizon: Horizon = Horizon()
    weights: Weights = Weights()
    reference: Reference = Reference()
    bounds: Bounds = Bounds()
    soft: SoftPenalties = SoftPenalties()
    qp: QpOptions = QpOptions()
    road: RoadWindow = RoadWindow()
    plan_check: PlanCheck = PlanCheck()
    #: samples between measurement and actuation that the solver compensates (docs/plants.md); a folder's problem.py
    #: names it only when it is not 0
    delay: int = field(default=0, metadata={"omit_default": True})
    #: s, the time constant of a first-order steering actuator that the delay compensation's prediction and the a_lat
    #: guard's plant step model (docs/plants.md); 0: none
    steer_lag: float = field(default=0.0, metadata={"omit_default": True})
    #: m, the obstacle margin of every stage from ``init`` on (``set_obstacle_margins`` replaces it; reset keeps the
    #: margins): an extra distance from every opponent for a vehicle that leaves its plan (docs/plants.md); 0: none
    obstacle_margin: float = field(default=0.0, metadata={"omit_default": True})

    def __post_init__(self) -> None:
        check(
            isinstance(self.name, str) and bool(_NAME.match(self.name)),
            "name",
            self.name,
            "a C identifier prefix: lower case letter, then [a-z0-9_], at most 31 characters",
        )
        clash = name_clash(self.name)
        if clash:
            raise ProblemError(
                f"name = {self.name!r} is invalid: it is {clash}; allowed a prefix of C symbols that "
                f"is no C keyword or reserved name and clashes with no OSQP, CasADi or C library symbol"
            )
        check(
            isinstance(self.formulation, (Conventional, DirectElimination, Lifted)),
            "formulation",
            self.formulation,
            "Conventional(), DirectElimination() or Lifted()",
        )
        check(
            isinstance(self.obstacles, (Ellipse, CoveringCircles, SeparatingHyperplane)),
            "obstacles",
            self.obstacles,
            "Ellipse(), CoveringCircles(n) or SeparatingHyperplane()",
        )
        for f, t in (
            ("ego", Vehicle),
            ("opponents", Opponents),
            ("wind", Wind),
            ("horizon", Horizon),
            ("weights", Weights),
            ("reference", Reference),
            ("bounds", Bounds),
            ("soft", SoftPenalties),
            ("qp", QpOptions),
            ("road", RoadWindow),
            ("plan_check", PlanCheck),
        ):
            check(isinstance(getattr(self, f), t), f, getattr(self, f), f"a {t.__name__}")
        self._check_across_fields()
        if isinstance(self.obstacles, CoveringCircles) and self.obstacles.radius == "paper":
            for who, veh, n in (
                ("opponents", self.opponents.vehicle, self.obstacles.n),
                ("ego", self.ego, self.obstacles.ego_circles),
            ):
                if not circles_cover(veh.l_ch, veh.w_ch, n):
                    need = math.ceil((veh.l_ch - veh.w_ch) / veh.w_ch) + 1
                    warnings.warn(
                        f"obstacles: {n} circles of radius w/sqrt(2) do not cover the {who} chassis "
                        f"({veh.l_ch:g} x {veh.w_ch:g} m); at least {need} are needed",
                        stacklevel=4,  # the caller of Problem(...): past __post_init__, __init__, known_fields
                    )

    def _check_across_fields(self) -> None:
        """The checks that tie one field to another (guard margin, tyre load, delay, lag, road length)."""
        check(
            not self.plan_check.a_lat_guard or self.bounds.a_lat_margin > 0,
            "bounds.a_lat_margin",
            self.bounds.a_lat_margin,
            f"(0, a_lat_max = {self.bounds.a_lat_max}) m/s^2 with plan_check.a_lat_guard "
            "(the guard steers to a_lat_max - a_lat_margin; False allows 0)",
        )
        pc, lim = self.plan_check, 9.81 * min(self.ego.l_f, self.ego.l_r)
        check(
            pc.tyre_stiffness == 0 or self.bounds.F_d_max / self.ego.m * pc.h_cg < lim,
            "plan_check.h_cg",
            pc.h_cg,
            f"[0, {lim * self.ego.m / self.bounds.F_d_max:.4g}) m with plan_check.tyre_stiffness > 0 (full braking "
            "moves at most an axle's whole load: F_d_max / m h_cg < g min(l_f, l_r))",
        )
        check(
            isinstance(self.delay, int) and not isinstance(self.delay, bool) and 0 <= self.delay <= MAX_DELAY,
            "delay",
            self.delay,
            f"an integer in [0, {MAX_DELAY}] samples",
        )
        real_in("steer_lag", self.steer_lag, 0.0, MAX_STEER_LAG, f"[0, {MAX_STEER_LAG:g}] s (0: no steering lag)")
        real_in(
            "obstacle_margin",
            self.obstacle_margin,
            0.0,
            MAX_OBSTACLE_MARGIN,
            f"[0, {MAX_OBSTACLE_MARGIN:g}] m (0: none)",
        )
        reach = self.bounds.v_max * self.horizon.length
        check(
            self.road.length >= reach + 4 * self.road.ds,
            "road.length",
            self.road.length,
            f">= v_max * horizon.length + 4 ds = {reach + 4 * self.road.ds:g} m (the window must cover the horizon)",
        )

    def with_(self, **changes) -> Problem:
        """A copy with some fields replaced (validated again)."""
        return replace(self, **changes)


def describe(obj) -> Any:
    """A plain, JSON-able description of a DSL object (for run logs and generated READMEs)."""
    if hasattr(obj, "__dataclass_fields__"):
        return {f.name: describe(getattr(obj, f.name)) for f in fields(obj)}
    if isinstance(obj, tuple):
        return [describe(v) for v in obj]
    return obj
