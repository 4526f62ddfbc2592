"""The obstacle models: an ellipse, covering circles, a separating hyperplane per opponent and stage."""

from __future__ import annotations

from dataclasses import dataclass, field

from .validation import check, finite, known_fields

ELLIPSE_SHAPES = ("minkowski", "paper")


@known_fields
@dataclass(frozen=True)
class Ellipse:
    """Opponent covered by an ellipse, ego by ``n_ego`` circles along its axis (one row per ego circle).

    ``shape``: ``minkowski`` (default) the smallest-area ellipse that contains the opponent's rectangle grown by the
    ego's circle (``fcgen.obstacles.containing_ellipse_axes``); ``paper``: the paper's semi-axes sqrt(2) L + r,
    sqrt(2) W + r, which leave up to 0.34 m of that grown rectangle uncovered near a truck's corners.
    ``n_ego``: 1 (the paper's) one circle of the chassis' half diagonal; n > 1 circles placed and sized as
    ``CoveringCircles``' radius ``cover`` places them (``fcgen.obstacles.ego_radius``): a smaller r, a narrower ellipse.
    """

    shape: str = "minkowski"
    n_ego: int = field(default=1, metadata={"omit_default": True})  # problem.py omits it at 1
    kind: str = field(default="ellipse", init=False, repr=False)

    def __post_init__(self) -> None:
        check(self.shape in ELLIPSE_SHAPES, "obstacles.shape", self.shape, f"one of {ELLIPSE_SHAPES}")
        check(
            isinstance(self.n_ego, int) and not isinstance(self.n_ego, bool) and 1 <= self.n_ego <= 5,
            "obstacles.n_ego",
            self.n_ego,
            "an integer in [1, 5]",
        )


CIRCLE_RADII = ("cover", "paper")


@known_fields
@dataclass(frozen=True)
class CoveringCircles:
    """n circles along each vehicle's axis (ego uses n_ego, default n)."""

    n: int = 3
    n_ego: int | None = None
    # ``cover`` (default): every circle just large enough that the n circles cover the rectangle; ``paper``: radius
    # w / sqrt(2) (SPEC section 4), which leaves the rectangle's sides uncovered when the spacing exceeds w
    # (a truck with 5 circles); the conventional formulation's fitted boxes always use ``cover``
    radius: str = "cover"
    kind: str = field(default="covering_circles", init=False, repr=False)

    def __post_init__(self) -> None:
        check(self.radius in CIRCLE_RADII, "obstacles.radius", self.radius, f"one of {CIRCLE_RADII}")
        check(isinstance(self.n, int) and 1 <= self.n <= 20, "obstacles.n", self.n, "an integer in [1, 20]")
        if self.n_ego is not None:
            check(
                isinstance(self.n_ego, int) and 1 <= self.n_ego <= 20,
                "obstacles.n_ego",
                self.n_ego,
                "an integer in [1, 20]",
            )

    @property
    def ego_circles(self) -> int:
        return self.n if self.n_ego is None else self.n_ego


@known_fields
@dataclass(frozen=True)
class SeparatingHyperplane:
    """Per opponent and stage a hyperplane theta = [t1, t2, t3], t1^2 + t2^2 = 1, separating the vertices.

    ``margin``: distance [m] the ego's vertices keep from the plane. The paper's exact form (0) lets the one-step
    RTI linearization graze opponents (3-62 mm deep in 8 of 10 truck runs); 0.1 m left 1 of 10, 0.2 m none.
    ``anchor``: weight w of 1/2 w |theta - theta_mid|^2 in the scaled QP (its largest Hessian entry is 1), theta_mid
    the plane halfway between the two centres (the initial guess's), evaluated at the linearization point: the plane
    is not unique where the vehicles are apart, so without it (0, the paper's presets) each real-time iteration moves
    the free planes by rounding-level amounts that grow, and C and Python closed loops part after ~50 samples. It is
    no vanishing regularization: where the rows are active it trades the cost against a plane nearer the midpoint
    one, so the converged solution differs from the paper's NLP's (the paper's presets keep it at 0).
    """

    margin: float = 0.2
    anchor: float = 1e-2
    kind: str = field(default="separating_hyperplane", init=False, repr=False)

    def __post_init__(self) -> None:
        check(0.0 <= finite("obstacles.margin", self.margin) <= 2.0, "obstacles.margin", self.margin, "[0, 2] m")
        check(0.0 <= finite("obstacles.anchor", self.anchor) <= 1.0, "obstacles.anchor", self.anchor, "[0, 1]")


ObstacleModel = Ellipse | CoveringCircles | SeparatingHyperplane


def circles_cover(l_ch: float, w_ch: float, n: int) -> bool:
    """True if n circles of radius w/sqrt(2) spread over the axis cover an l x w rectangle (SPEC section 4)."""
    if n == 1:
        return True
    spacing = (l_ch - w_ch) / (n - 1)
    return spacing <= w_ch + 1e-12
