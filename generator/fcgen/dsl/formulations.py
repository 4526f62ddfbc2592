"""The three NMPC formulations of the paper (Table III): conventional, direct elimination, lifted."""

from __future__ import annotations

from dataclasses import dataclass, field

from .validation import check, finite, known_fields, nonneg

OVERAPPROX = ("fit", "none")


@known_fields
@dataclass(frozen=True)
class Conventional:
    """5-state Frenet ODE; obstacles over-approximated in (s, n) outside the NLP (``none``: naive, unsafe)."""

    overapprox: str = "fit"
    margin: float = 0.0
    # points per metre of the opponent rectangle's edges that the solver's fit maps into (s, n); the chord sag
    # between them pads the box (1 per m: about 1 cm on a 26 m truck at |kappa| = 0.05; 4 per m costs 4x the time)
    points_per_metre: float = 1.0
    kind: str = field(default="conventional", init=False, repr=False)

    def __post_init__(self) -> None:
        check(self.overapprox in OVERAPPROX, "formulation.overapprox", self.overapprox, f"one of {OVERAPPROX}")
        nonneg("formulation.margin", self.margin)
        check(
            0.25 <= finite("formulation.points_per_metre", self.points_per_metre) <= 20,
            "formulation.points_per_metre",
            self.points_per_metre,
            "[0.25, 20] per m",
        )

    @property
    def frenet_obstacles(self) -> bool:
        return True


@known_fields
@dataclass(frozen=True)
class DirectElimination:
    """5-state Frenet ODE; obstacle constraints on F^-1(s, n, alpha)."""

    kind: str = field(default="direct_elimination", init=False, repr=False)

    @property
    def frenet_obstacles(self) -> bool:
        return False


@known_fields
@dataclass(frozen=True)
class Lifted:
    """8-state lifted ODE; obstacle constraints on the Cartesian states."""

    kind: str = field(default="lifted", init=False, repr=False)

    @property
    def frenet_obstacles(self) -> bool:
        return False


Formulation = Conventional | DirectElimination | Lifted
