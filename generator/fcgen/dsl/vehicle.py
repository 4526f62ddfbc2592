"""The vehicles and the air around them: the ego's and the opponents' dimensions and drag, the wind."""

from __future__ import annotations

import math
from dataclasses import dataclass

from .validation import check, finite, known_fields, nonneg, positive


@known_fields
@dataclass(frozen=True)
class Vehicle:
    """Kinematic single-track vehicle; reference point is the rear axle (SPEC section 1)."""

    l_f: float = 1.7
    l_r: float = 1.7
    l_f_ch: float = 2.0
    l_r_ch: float = 2.0
    w_ch: float = 1.9
    m: float = 1160.0
    c_air: float = 0.5 * 0.29 * 2.07 * 1.29
    c_roll: float = 0.015 * 1160.0 * 9.81

    def __post_init__(self) -> None:
        for f in ("l_f", "l_r", "l_f_ch", "l_r_ch", "w_ch", "m"):
            positive(f"vehicle.{f}", getattr(self, f))
        nonneg("vehicle.c_air", self.c_air)
        nonneg("vehicle.c_roll", self.c_roll)

    @property
    def l(self) -> float:
        """Wheelbase."""
        return self.l_f + self.l_r

    @property
    def l_ch(self) -> float:
        """Chassis length."""
        return self.l_f_ch + self.l_r_ch

    @property
    def r_cover(self) -> float:
        """Radius of the one circle covering the chassis."""
        return math.hypot(self.l_ch / 2, self.w_ch / 2)


@known_fields
@dataclass(frozen=True)
class Wind:
    """Wind speed and the direction it comes from."""

    v: float = 20.0
    phi: float = 0.0

    def __post_init__(self) -> None:
        nonneg("wind.v", self.v)
        finite("wind.phi", self.phi)


@known_fields
@dataclass(frozen=True)
class Opponents:
    """Number of opponents and their (common) dimensions."""

    count: int = 3
    vehicle: Vehicle = Vehicle()

    def __post_init__(self) -> None:
        check(
            isinstance(self.count, int) and 0 <= self.count <= 10,
            "opponents.count",
            self.count,
            "an integer in [0, 10]",
        )
        check(isinstance(self.vehicle, Vehicle), "opponents.vehicle", self.vehicle, "a Vehicle")
