"""Problem description: frozen dataclasses, validated on construction.

Every value is checked in ``__post_init__`` so a bad problem fails at the earliest layer with one
:class:`ProblemError` that names the field and the allowed range.
"""
from __future__ import annotations

import math
import re
import warnings
from dataclasses import dataclass, field, fields, replace
from typing import Union

from .cnames import name_clash

BACKENDS = ("osqp", "ipm")
"""Names ``QpOptions.backend`` accepts; each is a module of ``fcgen.backends`` (the DSL owns the names, the backends
import them: imports run one way)."""

RTI_BUDGET_DEFAULT: dict[str, int | None] = {"osqp": None, "ipm": 60}
"""The RTI budget of ``QpOptions.rti_budget = None``, per backend (None: no cap beyond ``max_iter`` and
``max_iter_cold``). IPM 60: no IPM QP of the committed paper grid (12,000 runs) ran more than 60 iterations, 3 of the
safe grid's 12,000 runs had one (two unconverged cold starts at 400, one solved at 118); on 20 truck seeds x 200
samples of six presets (``scripts/rti_budget.py``) 60 is identical to no budget, 40 moves a seed's progress by up to
0.08 %, 25-30 up to 9.5 %, 20 up to 19 % (docs/wcet.md, "The RTI budget"). OSQP: no extra cap (its cold starts keep
``max_iter_cold``). Presets of configurations measured to afford less set it (``fcgen.presets.IPM_RTI_BUDGET``)."""


class ProblemError(ValueError):
    """An invalid problem description: names the field and the allowed range."""


def _check(ok: bool, name: str, value, allowed: str) -> None:
    if not ok:
        raise ProblemError(f"{name} = {value!r} is invalid: allowed {allowed}")


def _finite(name: str, value) -> float:
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise ProblemError(f"{name} = {value!r} is invalid: allowed a finite real number") from None
    _check(math.isfinite(v), name, value, "a finite real number")
    return v


def _positive(name: str, value) -> None:
    _check(_finite(name, value) > 0, name, value, "> 0")


def _nonneg(name: str, value) -> None:
    _check(_finite(name, value) >= 0, name, value, ">= 0")


def _vec(name: str, value, n: int, check=_nonneg) -> None:
    _check(isinstance(value, tuple) and len(value) == n, name, value, f"a tuple of {n} numbers")
    for i, v in enumerate(value):
        check(f"{name}[{i}]", v)


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
            _positive(f"vehicle.{f}", getattr(self, f))
        _nonneg("vehicle.c_air", self.c_air)
        _nonneg("vehicle.c_roll", self.c_roll)

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


@dataclass(frozen=True)
class Wind:
    """Wind speed and the direction it comes from."""

    v: float = 20.0
    phi: float = 0.0

    def __post_init__(self) -> None:
        _nonneg("wind.v", self.v)
        _finite("wind.phi", self.phi)


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
        _check(isinstance(self.N, int) and not isinstance(self.N, bool) and 1 <= self.N <= 500,
               "horizon.N", self.N, "an integer in [1, 500]")
        _check(_finite("horizon.dt", self.dt) > 0 and self.dt <= 10, "horizon.dt", self.dt, "(0, 10] s")
        _check(isinstance(self.stride, int) and not isinstance(self.stride, bool) and 1 <= self.stride <= 10,
               "horizon.stride", self.stride, "an integer in [1, 10] (samples per coarse shooting interval)")
        _check(self.dt * self.stride <= 10, "horizon.stride", self.stride,
               f"at most {int(10 // self.dt)} (dt * stride <= 10 s)")
        _check(isinstance(self.fine, int) and not isinstance(self.fine, bool) and 0 <= self.fine,
               "horizon.fine", self.fine, "an integer >= 0 (intervals of one sample before the coarse ones)")

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


@dataclass(frozen=True)
class Weights:
    """Least-squares weights (paper Table II); stage weights ``q`` and ``r`` are multiplied by dt once."""

    q: tuple[float, ...] = (1.0, 500.0, 1e3, 1e3, 1e4)
    q_N: tuple[float, ...] = (10.0, 90.0, 100.0, 10.0, 10.0)
    r: tuple[float, ...] = (1e-3, 2e6)

    def __post_init__(self) -> None:
        _vec("weights.q", self.q, 5)
        _vec("weights.q_N", self.q_N, 5)
        _vec("weights.r", self.r, 2)


@dataclass(frozen=True)
class Reference:
    """Tracking reference per node k: s_ref,k, v_ref,k (v_ref, capped by the curve speed), n_ref, alpha = delta = 0.

    Without the curve speed s_ref,k = s0 + t_k v_ref and v_ref,k = v_ref; with it v_ref,k = min(v_ref, curve speed at
    s_ref,k) and s_ref,k = s_ref,k-1 + (t_k - t_k-1) v_ref,k-1 (s_ref,0 = s0); with ``curve_along_horizon = False``
    the curve speed at the plan's start only, v_ref,k = min(v_ref, curve speed at s0) and s_ref,k = s0 + t_k v_ref,k
    (the safe profile's conventional formulation, stop 38's rule for every formulation). t_k is node k's time (k dt
    on the paper's grid).

    The **curve speed** of the road ahead (the safe profile's; ``curve_a_lat = 0`` turns it off, as the paper's
    presets do) is the largest speed from which the ego, decelerating at ``curve_decel``, reaches every road sample
    ahead no faster than ``sqrt(curve_a_lat / |kappa|)``, so that following the centre line needs at most
    ``curve_a_lat``. Without it the reference asks for 40 m/s into a hairpin, and the plan accelerates towards a bend
    and then pays the a_lat slack or brakes into trouble (docs/safe_profile.md "The curve speed"); taken at each
    node's own s the reference itself brakes for the bend (docs/safe_profile.md "The curve reference along the
    horizon").

    ``curve_a_lat`` above the a_lat bound counts on a line straighter than the centre line across the road's width;
    with traffic near the plan (the last plan check's clearance to an opponent below ``curve_traffic_clearance``)
    that line may not be free, and the cap uses ``curve_a_lat_traffic`` instead (``curve_traffic_clearance = 0``:
    never; docs/safe_profile.md "The curve speed in traffic").
    """

    v_ref: float = 40.0
    n_ref: float = 0.0
    curve_a_lat: float = 8.0
    curve_decel: float = 7.0
    curve_a_lat_traffic: float = 6.5
    curve_traffic_clearance: float = 6.0
    curve_along_horizon: bool = True

    def __post_init__(self) -> None:
        _nonneg("reference.v_ref", self.v_ref)
        _finite("reference.n_ref", self.n_ref)
        _check(0 <= _finite("reference.curve_a_lat", self.curve_a_lat) <= 50, "reference.curve_a_lat",
               self.curve_a_lat, "[0, 50] m/s^2 (0: no curve speed)")
        _check(0 < _finite("reference.curve_decel", self.curve_decel) <= 50, "reference.curve_decel",
               self.curve_decel, "(0, 50] m/s^2")
        _check(0 < _finite("reference.curve_a_lat_traffic", self.curve_a_lat_traffic) <= 50,
               "reference.curve_a_lat_traffic", self.curve_a_lat_traffic, "(0, 50] m/s^2")
        _check(0 <= _finite("reference.curve_traffic_clearance", self.curve_traffic_clearance) <= 100,
               "reference.curve_traffic_clearance", self.curve_traffic_clearance, "[0, 100] m (0: never)")
        _check(isinstance(self.curve_along_horizon, bool), "reference.curve_along_horizon", self.curve_along_horizon,
               "True or False")


@dataclass(frozen=True)
class Bounds:
    """Box bounds (paper Table I); the road bounds are on the ego's n.

    ``a_lat_margin``: the plan keeps |a_lat| this far inside ``a_lat_max``. The default (the safe profile's, 0.05 m/s^2)
    absorbs what one real-time iteration's linearization leaves where the plan holds the bound: on the safe grid it
    takes the samples above 5.05 m/s^2 from 1.03 % to 0.45 % (docs/safe_profile.md); the paper's presets keep 0. With
    intervals of several samples the plant's samples between the nodes overshoot more (0.15 m/s^2 kept 0.2 s
    intervals within 5.05 m/s^2 in all but 4 of 3,600 samples, docs/collisions.md).
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

    def __post_init__(self) -> None:
        for f in ("F_d_max", "r_max", "delta_max", "a_lat_max"):
            _positive(f"bounds.{f}", getattr(self, f))
        _check(0 <= _finite("bounds.a_lat_margin", self.a_lat_margin) < self.a_lat_max, "bounds.a_lat_margin",
               self.a_lat_margin, f"[0, a_lat_max = {self.a_lat_max}) m/s^2")
        _check(0 < _finite("bounds.alpha_max", self.alpha_max) < math.pi / 2,
               "bounds.alpha_max", self.alpha_max, "(0, pi/2)")
        _check(0 <= _finite("bounds.v_min", self.v_min) < _finite("bounds.v_max", self.v_max),
               "bounds.v_min", self.v_min, f"0 <= v_min < v_max = {self.v_max}")
        _check(self.v_min <= _finite("bounds.v_N_max", self.v_N_max) <= self.v_max,
               "bounds.v_N_max", self.v_N_max, f"[v_min, v_max] = [{self.v_min}, {self.v_max}]")
        _check(_finite("bounds.n_min", self.n_min) < _finite("bounds.n_max", self.n_max),
               "bounds.n_min", self.n_min, f"< n_max = {self.n_max}")


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
            _nonneg(f"soft.{f}", getattr(self, f))
        _check(isinstance(self.soft_road, bool), "soft.soft_road", self.soft_road, "True or False")


# --- formulations (paper Table III) -------------------------------------------------------------

OVERAPPROX = ("fit", "none")


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
        _check(self.overapprox in OVERAPPROX, "formulation.overapprox", self.overapprox, f"one of {OVERAPPROX}")
        _nonneg("formulation.margin", self.margin)
        _check(0.25 <= _finite("formulation.points_per_metre", self.points_per_metre) <= 20,
               "formulation.points_per_metre", self.points_per_metre, "[0.25, 20] per m")

    @property
    def frenet_obstacles(self) -> bool:
        return True


@dataclass(frozen=True)
class DirectElimination:
    """5-state Frenet ODE; obstacle constraints on F^-1(s, n, alpha)."""

    kind: str = field(default="direct_elimination", init=False, repr=False)

    @property
    def frenet_obstacles(self) -> bool:
        return False


@dataclass(frozen=True)
class Lifted:
    """8-state lifted ODE; obstacle constraints on the Cartesian states."""

    kind: str = field(default="lifted", init=False, repr=False)

    @property
    def frenet_obstacles(self) -> bool:
        return False


Formulation = Union[Conventional, DirectElimination, Lifted]


# --- obstacle models ----------------------------------------------------------------------------

ELLIPSE_SHAPES = ("minkowski", "paper")


@dataclass(frozen=True)
class Ellipse:
    """Opponent covered by an ellipse, ego by one circle.

    ``shape``: ``minkowski`` (default) the smallest-area ellipse that contains the opponent's rectangle grown by the
    ego's circle (``fcgen.obstacles.containing_ellipse_axes``); ``paper``: the paper's semi-axes sqrt(2) L + r,
    sqrt(2) W + r, which leave up to 0.34 m of that grown rectangle uncovered near a truck's corners.
    """

    shape: str = "minkowski"
    kind: str = field(default="ellipse", init=False, repr=False)

    def __post_init__(self) -> None:
        _check(self.shape in ELLIPSE_SHAPES, "obstacles.shape", self.shape, f"one of {ELLIPSE_SHAPES}")


CIRCLE_RADII = ("cover", "paper")


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
        _check(self.radius in CIRCLE_RADII, "obstacles.radius", self.radius, f"one of {CIRCLE_RADII}")
        _check(isinstance(self.n, int) and 1 <= self.n <= 20, "obstacles.n", self.n, "an integer in [1, 20]")
        if self.n_ego is not None:
            _check(isinstance(self.n_ego, int) and 1 <= self.n_ego <= 20, "obstacles.n_ego", self.n_ego,
                   "an integer in [1, 20]")

    @property
    def ego_circles(self) -> int:
        return self.n if self.n_ego is None else self.n_ego


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
        _check(0.0 <= _finite("obstacles.margin", self.margin) <= 2.0, "obstacles.margin", self.margin,
               "[0, 2] m")
        _check(0.0 <= _finite("obstacles.anchor", self.anchor) <= 1.0, "obstacles.anchor", self.anchor, "[0, 1]")


ObstacleModel = Union[Ellipse, CoveringCircles, SeparatingHyperplane]


def circles_cover(l_ch: float, w_ch: float, n: int) -> bool:
    """True if n circles of radius w/sqrt(2) spread over the axis cover an l x w rectangle (SPEC section 4)."""
    if n == 1:
        return True
    spacing = (l_ch - w_ch) / (n - 1)
    return spacing <= w_ch + 1e-12


@dataclass(frozen=True)
class Opponents:
    """Number of opponents and their (common) dimensions."""

    count: int = 3
    vehicle: Vehicle = Vehicle()

    def __post_init__(self) -> None:
        _check(isinstance(self.count, int) and 0 <= self.count <= 10, "opponents.count", self.count,
               "an integer in [0, 10]")
        _check(isinstance(self.vehicle, Vehicle), "opponents.vehicle", self.vehicle, "a Vehicle")


@dataclass(frozen=True)
class QpOptions:
    """QP backend and its settings (OSQP's names), used identically by the Python reference and the generated C.

    ``max_iter_cold``: the budget of a cold-started QP (the first after init/reset, no shifted guess; at least
    ``max_iter``): capped at 60 it left |r| up to 1.6 % beyond its bound at sample 0.
    ``cold_restart_after``: after this many feedbacks in a row whose QP was unusable (any ERR_QP_* outcome), the next
    prepare builds the cold-start guess from the state instead of shifting the kept plan (zero duals, a reset QP
    backend, ``max_iter_cold``): what reset() would give, without the caller; 0: never. A kept plan that no longer
    meets the state is refused sample after sample (truck conventional hyperplane, seed 6, OSQP capped at 60: 113
    refusals in a row from sample 14, then the plan shifted past its end braked the ego into reverse); with 3 it
    cold-starts at samples 17 and 34 and finishes its 200 samples at 396.7 m.
    Defaults are the real-time mode (a fixed iteration budget, as RTI uses it): ``max_iter = 60``,
    ``rho = 0.2``, ``check_termination = 40`` (a check costs about one iteration), ``scaling = 1`` (one Ruiz
    pass: prepare 0.4 -> 0.15 ms, same convergence as 10 here). ``QpOptions.converged()`` is the quality reference.
    rho is what decides how good a capped solve is: on truck_lifted_ellipse (20 seeds, cap 60) rho = 1 left the
    closed loop 3.7 % (up to 14 % per seed) behind the converged progress, rho = 0.2 within 0.15 % (at most 1 %),
    with no larger slacks or lateral accelerations; rho <= 0.15 undershoots the soft constraints (larger slacks).
    ``sigma``: a float build raises it to ``fcgen.backends.osqp.FLOAT_SIGMA_MIN`` (1e-3): with 1e-6 float's
    factorization of OSQP's KKT matrix is unstable (docs/performance.md, "Single precision in closed loop").
    ``rti_budget``: the most QP iterations any feedback runs, cold starts included (the caps are
    ``min(max_iter, budget)`` warm, ``min(max(max_iter, max_iter_cold), budget)`` cold): what `fcgen wcet`'s bound
    multiplies. Reaching it is QP_MAX_ITER (a finite step inside the input box's margin is taken, else the fallback).
    None: the backend's ``RTI_BUDGET_DEFAULT``.
    ``ipm_scaled_start``: the IPM starts each soft row's slack bound at ``t = max(-b, t_min / max(1, lam))`` from its
    warm multiplier lam (every other side at ``max(-b, t_min)``), so that no such initial product t lam exceeds
    t_min: the bound carries a multiplier near its row's L1 weight, and starting it at t_min cost the safe profile's
    large weights ~0.9 iterations a QP (docs/safe_profile.md). The paper's presets keep ``False`` (their results as
    published here before).
    """

    max_iter: int = 60
    eps_abs: float = 1e-3
    eps_rel: float = 1e-3
    rho: float = 0.2
    sigma: float = 1e-6
    alpha: float = 1.6
    adaptive_rho: bool = False
    scaling: int = 1
    check_termination: int = 40
    warm_start: bool = True
    max_iter_cold: int = 400
    cold_restart_after: int = 3
    rti_budget: int | None = None  # QP iterations any feedback may run (None: the backend's RTI_BUDGET_DEFAULT)
    backend: str = "osqp"  # the QP backend (BACKENDS)
    ipm_tol: float = 1e-4  # backend "ipm": stationarity, primal residuals, each t*lam (scaled QP)
    ipm_scaled_start: bool = True  # backend "ipm": slack bounds start at t = max(-b, t_min / max(1, lam))

    @property
    def budget(self) -> int | None:
        """The RTI budget in force: ``rti_budget``, or the backend's default (None: no cap beyond the two caps)."""
        return self.rti_budget if self.rti_budget is not None else RTI_BUDGET_DEFAULT.get(self.backend)

    @property
    def caps(self) -> tuple[int, int]:
        """(warm, cold) QP iteration caps: ``min(max_iter, budget)``, ``min(max(max_iter, max_iter_cold), budget)``."""
        b = self.budget if self.budget is not None else 1_000_000
        return min(self.max_iter, b), min(max(self.max_iter, self.max_iter_cold), b)

    @classmethod
    def converged(cls) -> "QpOptions":
        """Solve every QP to eps = 1e-5 (up to 4000 iterations): the quality reference for the real-time mode."""
        return cls(max_iter=4000, eps_abs=1e-5, eps_rel=1e-5, rho=1.0, check_termination=5)

    def __post_init__(self) -> None:
        _check(isinstance(self.max_iter, int) and 1 <= self.max_iter <= 1_000_000, "qp.max_iter", self.max_iter,
               "an integer in [1, 1e6]")
        _check(isinstance(self.max_iter_cold, int) and 1 <= self.max_iter_cold <= 1_000_000, "qp.max_iter_cold",
               self.max_iter_cold, "an integer in [1, 1e6]")
        _check(type(self.cold_restart_after) is int and 0 <= self.cold_restart_after <= 1_000_000,
               "qp.cold_restart_after", self.cold_restart_after, "an integer in [0, 1e6] (0: never)")
        _check(self.rti_budget is None or (type(self.rti_budget) is int and 1 <= self.rti_budget <= 1_000_000),
               "qp.rti_budget", self.rti_budget, "an integer in [1, 1e6], or None (the backend's default)")
        for f in ("eps_abs", "eps_rel"):
            _check(0 <= _finite(f"qp.{f}", getattr(self, f)) < 1, f"qp.{f}", getattr(self, f), "[0, 1)")
        _check(self.eps_abs > 0 or self.eps_rel > 0, "qp.eps_abs", self.eps_abs, "> 0 when eps_rel = 0")
        _positive("qp.rho", self.rho)
        _positive("qp.sigma", self.sigma)
        _check(0 < _finite("qp.alpha", self.alpha) < 2, "qp.alpha", self.alpha, "(0, 2)")
        _check(isinstance(self.scaling, int) and 0 <= self.scaling <= 100, "qp.scaling", self.scaling,
               "an integer in [0, 100]")
        _check(isinstance(self.check_termination, int) and 1 <= self.check_termination <= 1000,
               "qp.check_termination", self.check_termination, "an integer in [1, 1000]")
        _check(0 < _finite("qp.ipm_tol", self.ipm_tol) < 1, "qp.ipm_tol", self.ipm_tol, "(0, 1)")
        _check(self.backend in BACKENDS, "qp.backend", self.backend, "one of " + ", ".join(BACKENDS))
        _check(isinstance(self.ipm_scaled_start, bool), "qp.ipm_scaled_start", self.ipm_scaled_start, "True or False")


@dataclass(frozen=True)
class RoadWindow:
    """The road the solver sees at run time: samples with spacing ds, at most ``samples`` of them."""

    ds: float = 2.0
    length: float = 280.0

    def __post_init__(self) -> None:
        _check(0.1 <= _finite("road.ds", self.ds) <= 20, "road.ds", self.ds, "[0.1, 20] m")
        _check(_finite("road.length", self.length) >= 4 * self.ds, "road.length", self.length, f">= 4 ds = {4*self.ds} m")

    @property
    def samples(self) -> int:
        return int(math.ceil(self.length / self.ds)) + 1


@dataclass(frozen=True)
class PlanCheck:
    """After each feedback: the plan's clearance to every opponent's true rectangle (separating axes), and a reaction.

    ``react_stages``: where an opponent's first overlap among stages 1..min(react_stages, N) has its centre ahead of
    the ego's there or now (stage 0), the solver brakes instead of applying the plan's u0 (status.plan_reaction = 1;
    F_d = -min(F_d_max, m v0 / dt), the plan's steering rate); 0: report only (the paper's presets); the default, 500, is the whole
    horizon of any problem (measured on the full grid: docs/safe_profile.md).

    ``a_lat_guard``: the control to apply keeps the next sample's |a_lat| within ``bounds.a_lat_max``: where the plant's
    step with it would exceed the bound, the steering rate is the one that ends at ``a_lat_max - a_lat_margin``
    (status.a_lat_guard = 1), and where the step with that rate still exceeds the bound (the rate bound cut it short),
    the solver brakes as above too (2). The plan is not changed. It needs ``bounds.a_lat_margin > 0``: with wind the
    speed, and so the end, moves a little with the steering rate (the scenarios' 20 m/s wind: up to 4e-5 m/s^2). A guarantee at
    the actuator behind the plan's soft a_lat rows (docs/safe_profile.md "The a_lat guard"). False: the paper's
    presets, and the conventional formulation's safe ones (``presets.SAFE_PLAN_CHECK_CONVENTIONAL``).
    """

    react_stages: int = 500
    a_lat_guard: bool = True

    def __post_init__(self) -> None:
        _check(type(self.react_stages) is int and 0 <= self.react_stages <= 500, "plan_check.react_stages",
               self.react_stages, "an integer in [0, 500] (0: report only)")
        _check(type(self.a_lat_guard) is bool, "plan_check.a_lat_guard", self.a_lat_guard, "True or False")


_NAME = re.compile(r"^[a-z][a-z0-9_]{0,30}$")


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

    def __post_init__(self) -> None:
        _check(isinstance(self.name, str) and bool(_NAME.match(self.name)), "name", self.name,
               "a C identifier prefix: lower case letter, then [a-z0-9_], at most 31 characters")
        clash = name_clash(self.name)
        if clash:
            raise ProblemError(f"name = {self.name!r} is invalid: it is {clash}; allowed a prefix of C symbols that "
                               f"is no C keyword or reserved name and clashes with no OSQP, CasADi or C library symbol")
        _check(isinstance(self.formulation, (Conventional, DirectElimination, Lifted)), "formulation",
               self.formulation, "Conventional(), DirectElimination() or Lifted()")
        _check(isinstance(self.obstacles, (Ellipse, CoveringCircles, SeparatingHyperplane)), "obstacles",
               self.obstacles, "Ellipse(), CoveringCircles(n) or SeparatingHyperplane()")
        for f, t in (("ego", Vehicle), ("opponents", Opponents), ("wind", Wind), ("horizon", Horizon),
                     ("weights", Weights), ("reference", Reference), ("bounds", Bounds),
                     ("soft", SoftPenalties), ("qp", QpOptions), ("road", RoadWindow),
                     ("plan_check", PlanCheck)):
            _check(isinstance(getattr(self, f), t), f, getattr(self, f), f"a {t.__name__}")
        _check(not self.plan_check.a_lat_guard or self.bounds.a_lat_margin > 0, "bounds.a_lat_margin",
               self.bounds.a_lat_margin, f"(0, a_lat_max = {self.bounds.a_lat_max}) m/s^2 with plan_check.a_lat_guard "
               "(the guard steers to a_lat_max - a_lat_margin; False allows 0)")
        reach = self.bounds.v_max * self.horizon.length
        _check(self.road.length >= reach + 4 * self.road.ds, "road.length", self.road.length,
               f">= v_max * horizon.length + 4 ds = {reach + 4 * self.road.ds:g} m (the window must cover the horizon)")
        if isinstance(self.obstacles, CoveringCircles) and self.obstacles.radius == "paper":
            for who, veh, n in (("opponents", self.opponents.vehicle, self.obstacles.n),
                                ("ego", self.ego, self.obstacles.ego_circles)):
                if not circles_cover(veh.l_ch, veh.w_ch, n):
                    need = math.ceil((veh.l_ch - veh.w_ch) / veh.w_ch) + 1
                    warnings.warn(f"obstacles: {n} circles of radius w/sqrt(2) do not cover the {who} chassis "
                                  f"({veh.l_ch:g} x {veh.w_ch:g} m); at least {need} are needed", stacklevel=3)

    def with_(self, **changes) -> "Problem":
        """A copy with some fields replaced (validated again)."""
        return replace(self, **changes)


def describe(obj) -> dict:
    """A plain, JSON-able description of a DSL object (for run logs and generated READMEs)."""
    if hasattr(obj, "__dataclass_fields__"):
        return {f.name: describe(getattr(obj, f.name)) for f in fields(obj)}
    if isinstance(obj, tuple):
        return [describe(v) for v in obj]
    return obj
