"""Box bounds of the states and inputs, the road band and the lateral acceleration (paper Table I)."""

from __future__ import annotations

import math
from dataclasses import dataclass, field

from .validation import check, finite, known_fields, positive

ROAD_BOUNDS = ("rear_axle", "corners")
"""What ``Bounds.n_min``/``n_max`` bound: the rear axle's n, or the chassis' four corners' n."""


@known_fields
@dataclass(frozen=True)
class Bounds:
    """Box bounds (paper Table I); the road bounds ``n_min``/``n_max`` are on the ego's n (``road_bound``).

    ``road_bound``: what the road band bounds. ``"rear_axle"`` (the paper's, the default): the reference point's n, a
    box bound. ``"corners"``: the chassis' four corners, ``n + x_c sin(alpha) +- (w_ch/2) cos(alpha)`` with the front
    and rear of the chassis at ``x_c`` from the rear axle (``models.corner_n``), one linearised row per corner, each
    taking the road's band at its own ``s`` (docs/problem_reference.md).

    ``a_lat_margin``: the plan keeps |a_lat| this far inside ``a_lat_max``. The default (the safe profile's, 0.05 m/s^2)
    absorbs what one real-time iteration's linearization leaves where the plan holds the bound: on the safe grid it
    takes the samples above 5.05 m/s^2 from 1.03 % to 0.45 % (docs/safe_profile.md); the paper's presets keep 0. With
    intervals of several samples the plant's samples between the nodes overshoot more (0.15 m/s^2 kept 0.2 s
    intervals within 5.05 m/s^2 in all but 4 of 3,600 samples, docs/collisions.md).

    ``P_d_max``: the drive's power, a row ``F_d v <= P_d_max`` per stage 0..N-1 (None, the presets': no row). A vehicle
    model whose acceleration falls as ``a_max v_switch / v`` above ``v_switch`` (CommonRoad's) has the power
    ``m a_max v_switch``: CommonRoad runs of the safe profile take it from the solution's vehicle
    (``commonroad.solution.drive_power``).
    """

    F_d_max: float = 1e4
    r_max: float = 0.39
    delta_max: float = 0.3
    v_min: float = 0.0
    v_max: float = 40.0
    alpha_max: float = math.pi / 4
    n_min: float = -10.0
    n_max: float = 10.0
    a_lat_max: float = 5.0
    v_N_max: float = 15.0
    a_lat_margin: float = 0.05
    road_bound: str = "rear_axle"
    P_d_max: float | None = field(default=None, metadata={"omit_default": True})

    def __post_init__(self) -> None:
        for f in ("F_d_max", "r_max", "delta_max", "a_lat_max"):
            positive(f"bounds.{f}", getattr(self, f))
        check(
            0 <= finite("bounds.a_lat_margin", self.a_lat_margin) < self.a_lat_max,
            "bounds.a_lat_margin",
            self.a_lat_margin,
            f"[0, a_lat_max = {self.a_lat_max}) m/s^2",
        )
        check(
            0 < finite("bounds.alpha_max", self.alpha_max) < math.pi / 2,
            "bounds.alpha_max",
            self.alpha_max,
            "(0, pi/2)",
        )
        check(
            0 <= finite("bounds.v_min", self.v_min) < finite("bounds.v_max", self.v_max),
            "bounds.v_min",
            self.v_min,
            f"0 <= v_min < v_max = {self.v_max}",
        )
        check(
            self.v_min <= finite("bounds.v_N_max", self.v_N_max) <= self.v_max,
            "bounds.v_N_max",
            self.v_N_max,
            f"[v_min, v_max] = [{self.v_min}, {self.v_max}]",
        )
        check(
            finite("bounds.n_min", self.n_min) < finite("bounds.n_max", self.n_max),
            "bounds.n_min",
            self.n_min,
            f"< n_max = {self.n_max}",
        )
        check(
            self.P_d_max is None or finite("bounds.P_d_max", self.P_d_max) > 0,
            "bounds.P_d_max",
            self.P_d_max,
            "None (no power row) or > 0 W",
        )
        check(
            self.road_bound in ROAD_BOUNDS,
            "bounds.road_bound",
            self.road_bound,
            " or ".join(repr(b) for b in ROAD_BOUNDS),
        )
