"""What the solver looks ahead over: the shooting grid in time (``Horizon``) and the road window in space."""

from __future__ import annotations

import math
from dataclasses import dataclass

from .validation import check, finite, known_fields


@known_fields
@dataclass(frozen=True)
class Horizon:
    """N shooting intervals; the controller runs once a sample of ``dt``.

    The first ``fine`` intervals are one sample long, the others ``stride`` samples (default: every interval one
    sample, the paper's 40 x 0.1 s). A stride looks further ahead with the same QP size (``Horizon(stride=3,
    fine=20)``: 2 s + 6 s = 8 s); each sample the plan is shifted by one sample (a coarse stage 1 / stride of the way
    to the next, interpolated) and the opponents are predicted at the nodes' samples (``offsets``). Obstacle rows
    hold at the nodes only: measured on the campaign's grid it collides more (docs/collisions.md).
    """

    N: int = 40
    dt: float = 0.1
    stride: int = 1
    fine: int = 0

    def __post_init__(self) -> None:
        check(
            isinstance(self.N, int) and not isinstance(self.N, bool) and 1 <= self.N <= 500,
            "horizon.N",
            self.N,
            "an integer in [1, 500]",
        )
        check(finite("horizon.dt", self.dt) > 0 and self.dt <= 10, "horizon.dt", self.dt, "(0, 10] s")
        check(
            isinstance(self.stride, int) and not isinstance(self.stride, bool) and 1 <= self.stride <= 10,
            "horizon.stride",
            self.stride,
            "an integer in [1, 10] (samples per coarse shooting interval)",
        )
        check(
            self.dt * self.stride <= 10,
            "horizon.stride",
            self.stride,
            f"at most {int(10 // self.dt)} (dt * stride <= 10 s)",
        )
        check(
            isinstance(self.fine, int) and not isinstance(self.fine, bool) and self.fine >= 0,
            "horizon.fine",
            self.fine,
            "an integer >= 0 (intervals of one sample before the coarse ones)",
        )

    @property
    def n_fine(self) -> int:
        """Intervals of one sample (all of them for stride 1)."""
        return self.N if self.stride == 1 else min(self.fine, self.N)

    @property
    def uniform(self) -> bool:
        """Every interval equally long (stride 1, no fine intervals, or only fine ones)."""
        return self.n_fine in (0, self.N)

    @property
    def interval(self) -> float:
        """The first interval's length (s), which weighs every stage's costs: ``dt``, or ``dt * stride`` where all
        intervals are coarse; the uniform grid's interval."""
        return self.dt if self.n_fine > 0 else self.dt * self.stride

    @property
    def stage_samples(self) -> tuple[int, ...]:
        """Samples per interval, k = 0..N-1."""
        return (1,) * self.n_fine + (self.stride,) * (self.N - self.n_fine)

    @property
    def offsets(self) -> tuple[int, ...]:
        """The sample of node k = 0..N, counted from the current one."""
        out = [0]
        for m in self.stage_samples:
            out.append(out[-1] + m)
        return tuple(out)

    @property
    def times(self) -> tuple[float, ...]:
        """The time of node k = 0..N (s): ``k interval`` on a uniform grid, else ``offsets[k] dt``."""
        if self.uniform:
            return tuple(k * self.interval for k in range(self.N + 1))
        return tuple(o * self.dt for o in self.offsets)

    @property
    def max_interval(self) -> float:
        """The longest interval (s)."""
        return self.dt * max(self.stage_samples)

    @property
    def length(self) -> float:
        """The time the horizon covers (s)."""
        return self.dt * self.offsets[-1]


@known_fields
@dataclass(frozen=True)
class RoadWindow:
    """The road the solver sees at run time: samples with spacing ds, at most ``samples`` of them."""

    ds: float = 2.0
    length: float = 280.0

    def __post_init__(self) -> None:
        check(0.1 <= finite("road.ds", self.ds) <= 20, "road.ds", self.ds, "[0.1, 20] m")
        check(
            finite("road.length", self.length) >= 4 * self.ds, "road.length", self.length, f">= 4 ds = {4 * self.ds} m"
        )

    @property
    def samples(self) -> int:
        return math.ceil(self.length / self.ds) + 1
