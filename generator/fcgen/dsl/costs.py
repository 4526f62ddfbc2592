"""The cost's weights: least-squares tracking weights and the soft rows' slack penalties."""

from __future__ import annotations

from dataclasses import dataclass

from .validation import check, known_fields, nonneg, vector


@known_fields
@dataclass(frozen=True)
class Weights:
    """Least-squares weights (paper Table II); stage weights ``q`` and ``r`` are multiplied by dt once."""

    q: tuple[float, ...] = (1.0, 500.0, 1e3, 1e3, 1e4)
    q_N: tuple[float, ...] = (10.0, 90.0, 100.0, 10.0, 10.0)
    r: tuple[float, ...] = (1e-3, 2e6)

    def __post_init__(self) -> None:
        vector("weights.q", self.q, 5)
        vector("weights.q_N", self.q_N, 5)
        vector("weights.r", self.r, 2)


@known_fields
@dataclass(frozen=True)
class SoftPenalties:
    """L1 + L2 slack penalties (multiplied by dt per stage); road bounds may be softened too.

    Defaults: the safe profile (``docs/safe_profile.md``): each L1 weight above the 99th percentile of the multipliers
    its rows take in closed loop with the rows hard (a_lat 5x, obstacles 80x; calibrated: ``python -m fcgen.safety``),
    so a slack is used (almost) only where the hard problem is infeasible; there obstacle / a_lat = 1000 decides: a_lat
    gives way (the other order, a_lat 3e8, kept the bound but had 114 instead of 12 colliding runs on the full grid;
    obstacle / a_lat = 100 left an obstacle slack of 0.5 m cheaper than the swerve that avoids it). With the
    conventional formulation use ``obstacle_l1=1e8, a_lat_l1=3e8`` (its safe presets do,
    ``presets.SAFE_SOFT_CONVENTIONAL``): its fitted boxes leave QPs without a hard solution that 1e9 conditions too
    badly for the IPM, and there the over-approximated box should give way, not a_lat. The paper's
    presets keep ``PAPER_SOFT`` (obstacle 1e7 / 1e6, a_lat 1e5 / 1e4: the a_lat row is then a cost, exceeded in 40-56 %
    of the samples). ``SoftPenalties(obstacle_l1=1e6, obstacle_l2=1e5)``: the acados
    benchmark's values.
    """

    obstacle_l1: float = 1e9
    obstacle_l2: float = 1e6
    a_lat_l1: float = 1e6
    a_lat_l2: float = 1e4
    soft_road: bool = False
    road_l1: float = 1e5
    road_l2: float = 1e4

    def __post_init__(self) -> None:
        for f in ("obstacle_l1", "obstacle_l2", "a_lat_l1", "a_lat_l2", "road_l1", "road_l2"):
            nonneg(f"soft.{f}", getattr(self, f))
        check(isinstance(self.soft_road, bool), "soft.soft_road", self.soft_road, "True or False")
