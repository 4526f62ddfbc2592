"""The paper's grid (Table III): scenario x formulation x obstacle model, each a ``Config``; a task = (config, seed)."""

from __future__ import annotations

import warnings
from dataclasses import asdict, dataclass, field, fields, replace
from typing import Any

from ..dsl import BACKENDS, Ellipse, Problem, ProblemError, QpOptions
from ..dsl.bounds import ROAD_BOUNDS
from ..presets import FORMULATIONS, PROFILES, SCENARIOS, paper_problem, preset_qp, safe_delay_margin
from ..sim.plants import PlantSpec

#: the paper's obstacle models per scenario: EL, C5/C7 (trucks) or C1/C3 (cars), HP
PAPER_CIRCLES = {"truck": (5, 7), "car": (1, 3)}
OBSTACLE_NAMES = ("ellipse", "circles", "hyperplane")
CONTROLLERS = ("c", "python")
CLOCKS = ("cpu", "wall")


@dataclass(frozen=True)
class Config:
    """One configuration of the grid: a paper problem, the controller that runs it and the QP backend."""

    scenario: str
    formulation: str
    obstacles: str  # ellipse | circles | hyperplane
    circles: int = 0  # the number of covering circles (circles only)
    controller: str = "c"
    backend: str = "osqp"
    profile: str = "paper"  # paper | safe (fcgen.presets.PROFILES): the same seed's scenario in both
    plant: PlantSpec = field(default_factory=PlantSpec)  # the plant, its perturbations (docs/plants.md)
    delay: int = 0  # the solvers' delay compensation (Problem.delay), samples
    road_bound: str = "rear_axle"  # what the road band bounds (Bounds.road_bound): rear_axle | corners
    ego_circles: int = 1  # the circles covering the ego in the ellipse's rows (Ellipse.n_ego), ellipse only
    drive_power: float = 0.0  # the drive's power row (Bounds.P_d_max), W; 0: none

    def __post_init__(self) -> None:
        if not isinstance(self.plant, PlantSpec):
            raise ProblemError(f"plant = {self.plant!r} is invalid: allowed a PlantSpec")
        _one_of("profile", self.profile, PROFILES)
        _one_of("scenario", self.scenario, SCENARIOS)
        _one_of("formulation", self.formulation, tuple(FORMULATIONS))
        _one_of("obstacles", self.obstacles, OBSTACLE_NAMES)
        _one_of("controller", self.controller, CONTROLLERS)
        _one_of("backend", self.backend, BACKENDS)
        _one_of("road_bound", self.road_bound, ROAD_BOUNDS)
        if not (isinstance(self.ego_circles, int) and 1 <= self.ego_circles <= 5):
            raise ProblemError(f"ego_circles = {self.ego_circles!r} is invalid: allowed an integer in [1, 5]")
        if not (isinstance(self.drive_power, float) and 0.0 <= self.drive_power < float("inf")):
            raise ProblemError(
                f"drive_power = {self.drive_power!r} is invalid: allowed a finite float >= 0 W (0: none)"
            )
        if self.ego_circles != 1 and self.obstacles != "ellipse":
            raise ProblemError(f"ego_circles = {self.ego_circles} is invalid: allowed 1 unless obstacles = 'ellipse'")
        if (self.obstacles == "circles") != (self.circles > 0):
            raise ProblemError(
                f"circles = {self.circles} is invalid: allowed >= 1 with obstacles = 'circles', 0 otherwise"
            )

    @property
    def model(self) -> str:
        """The paper's label of the obstacle model: EL, C<n>, HP."""
        return {"ellipse": "EL", "hyperplane": "HP"}.get(self.obstacles, f"C{self.circles}")

    @property
    def key(self) -> str:
        """Identifies the configuration in the results (with the seed and the sample count: one run)."""
        key = f"{self.scenario}/{self.formulation}/{self.model}/{self.controller}/{self.backend}"
        key = key if self.profile == "paper" else f"{key}/{self.profile}"  # paper keys as before the profiles
        key = key if self.plant.is_default else f"{key}/{self.plant.label()}"  # as before the plants
        key = key if not self.delay else f"{key}/comp{self.delay}"
        key = key if self.road_bound == "rear_axle" else f"{key}/{self.road_bound}"  # as before the corners
        key = key if self.ego_circles == 1 else f"{key}/ego{self.ego_circles}"  # as before the ego's circles
        return key if not self.drive_power else f"{key}/power{self.drive_power / 1e3:.1f}kW"  # as before the power

    def problem(self) -> Problem:
        """The paper problem of this configuration (the QP backend set when the DSL has the field)."""
        over: dict[str, Any] = {}
        has_backend = "backend" in {f.name for f in fields(QpOptions)}
        if has_backend:
            over["qp"] = preset_qp(self.backend, self.formulation, self.obstacles, self.profile)
        elif self.backend != "osqp":
            raise ProblemError(
                f"backend = {self.backend!r} is not available in this fcgen: QpOptions has no "
                f"'backend' field yet (allowed: 'osqp')"
            )
        with warnings.catch_warnings():  # C5 does not cover a truck: the paper's choice, warned about once in presets
            warnings.simplefilter("ignore", UserWarning)
            pb = paper_problem(
                self.scenario, self.formulation, self.obstacles, self.circles or None, profile=self.profile, **over
            )
        pb = pb if self.profile == "paper" else pb.with_(name=f"{pb.name}_{self.profile}")
        if self.plant.params == "matched":
            from ..sim.plants.commonroad_vm import matched_problem

            pb = matched_problem(pb, "matched")
        if self.road_bound != "rear_axle":
            pb = pb.with_(bounds=replace(pb.bounds, road_bound=self.road_bound), name=f"{pb.name}_cb"[:31])
        if self.drive_power:  # the name's last letter: car_lifted_ellipse_ipm_safe_cbp
            name = f"{pb.name}p" if pb.name.endswith("_cb") else f"{pb.name}_p"
            pb = pb.with_(bounds=replace(pb.bounds, P_d_max=self.drive_power), name=name[:31])
        if self.ego_circles != 1:
            n, ob = self.ego_circles, pb.obstacles
            assert isinstance(ob, Ellipse)  # __post_init__: ego circles with the ellipse only
            pb = pb.with_(obstacles=replace(ob, n_ego=n), name=f"{pb.name}_e{n}"[:31])
        if not self.delay:
            return pb
        margin = safe_delay_margin(self.profile, self.delay)  # the safe profile's margin under latency
        return pb.with_(delay=self.delay, obstacle_margin=margin, name=f"{pb.name}_d{self.delay}"[:31])

    def as_dict(self) -> dict:
        """The row's configuration columns; a perturbed run's plant as columns ``plant``, ``plant_params``,
        ``latency``, ``steer_lag``, ``noise`` and ``prediction`` when predicted (a default run's row has none
        of them, as before the plants)."""
        skip = ("plant", "delay", "road_bound", "ego_circles", "drive_power")
        d = {f.name: getattr(self, f.name) for f in fields(self) if f.name not in skip}
        if self.delay:
            d["delay"] = self.delay
        if self.road_bound != "rear_axle":  # the rows of the rear axle's bound: as before the corners
            d["road_bound"] = self.road_bound
        if self.ego_circles != 1:  # the rows of the ego's one circle: as before n_ego
            d["ego_circles"] = self.ego_circles
        if self.drive_power:  # the rows without a power row: as before it
            d["drive_power"] = self.drive_power
        if not self.plant.is_default:
            p = asdict(self.plant)
            d.update(
                plant=p["kind"],
                plant_params=p["params"],
                latency=p["latency"],
                steer_lag=float(p["steer_lag"]),
                noise=",".join(f"{v:g}" for v in self.plant.noise),
            )
            if self.plant.prediction != "oracle":  # the rows of perturbations without prediction: as before it
                d["prediction"] = self.plant.prediction
            if self.plant.prediction_margin:
                d["prediction_margin"] = float(self.plant.prediction_margin)
        return d


def default_road_bound(commonroad: bool, profile: str) -> str:
    """A campaign's road bound without ``--road-bound``: the chassis' corners for the safe profile on CommonRoad
    scenarios (docs/commonroad.md, "The corners' band, the safe profile's on CommonRoad"), else the presets' own."""
    return "corners" if commonroad and profile == "safe" else "rear_axle"


def grid_extras(spec: PlantSpec, delay: int, road_bound: str | None, ego_circles: int, commonroad: bool, profile: str):
    """``paper_grid``'s arguments after the profile: the plant, the delay, the road bound (None: its default), the
    ego's circles and the drive power (``default_road_bound``, ``default_drive_power``)."""
    bound = road_bound or default_road_bound(commonroad, profile)
    return spec, delay, bound, ego_circles, default_drive_power(commonroad, profile)


def default_drive_power(commonroad: bool, profile: str) -> float:
    """A campaign's drive power (W): on CommonRoad scenarios the safe profile's plan keeps the acceleration the
    solution's vehicle model allows (``commonroad.solution.drive_power``; docs/commonroad.md), else none (0)."""
    if not (commonroad and profile == "safe"):
        return 0.0
    from ..commonroad.solution import drive_power
    from ..dsl import Vehicle

    return drive_power(Vehicle().m)


def _one_of(field: str, value, allowed: tuple) -> None:
    if value not in allowed:
        raise ProblemError(f"{field} = {value!r} is invalid: allowed one of {', '.join(map(str, allowed))}")


def obstacle_variants(scenario: str, name: str) -> list[tuple[str, int]]:
    """``ellipse`` / ``hyperplane`` -> one model; ``circles`` -> the paper's two counts; ``c<n>`` -> n circles."""
    name = name.strip().lower()
    if name in ("ellipse", "el"):
        return [("ellipse", 0)]
    if name in ("hyperplane", "hp"):
        return [("hyperplane", 0)]
    if name == "circles":
        return [("circles", n) for n in PAPER_CIRCLES[scenario]]
    if name.startswith("c") and name[1:].isdigit() and 1 <= int(name[1:]) <= 20:
        return [("circles", int(name[1:]))]
    raise ProblemError(
        f"obstacles: {name!r} is invalid: allowed ellipse, circles (the paper's counts), hyperplane "
        f"or c<n> with 1 <= n <= 20"
    )


def paper_grid(
    scenarios=SCENARIOS,
    formulations=tuple(FORMULATIONS),
    obstacles=OBSTACLE_NAMES,
    controller: str = "c",
    backend: str = "osqp",
    profile: str = "paper",
    plant: PlantSpec | None = None,
    delay: int = 0,
    road_bound: str = "rear_axle",
    ego_circles: int = 1,
    drive_power: float = 0.0,
) -> list[Config]:
    """The configurations, scenario-major (the full paper grid: 2 x 3 x 4 = 24)."""
    out = []
    for sc in scenarios:
        _one_of("scenario", sc, SCENARIOS)
        for ob in obstacles:
            for kind, n in obstacle_variants(sc, ob):
                for form in formulations:
                    spec = plant or PlantSpec()
                    circ = ego_circles if kind == "ellipse" else 1  # the ego's circles: the ellipse's rows only
                    cfg = (controller, backend, profile, spec, delay, road_bound, circ, drive_power)
                    out.append(Config(sc, form, kind, n, *cfg))
    if ego_circles != 1 and not any(c.ego_circles != 1 for c in out):
        raise ProblemError(f"ego_circles = {ego_circles} is invalid: allowed 1 unless the grid has the ellipse")
    return out


@dataclass(frozen=True)
class Task:
    """One closed-loop run: a configuration, a seed, the sample count, where compiled solvers are cached, and the
    clock that times the C solver (``cpu``: unaffected by other processes on a shared machine)."""

    config: Config
    seed: int
    samples: int
    cache_dir: str
    clock: str = "cpu"  # the C solver's clock: "cpu" (its thread's CPU time) or "wall" (monotonic)
    cflags: str | None = None  # the C solvers' compiler flags (None: the build's default, $CFLAGS or -O2)

    @property
    def timed_by(self) -> str:
        """The clock of the row's solver times (the Python reference is always timed by the wall clock)."""
        return self.clock if self.config.controller == "c" else "wall"

    @property
    def run_id(self) -> tuple[str, int, int, str]:
        return (self.config.key, self.samples, self.seed, self.timed_by)


#: seeds per block of ``make_tasks``: the grid is covered evenly every SEED_BLOCK seeds
SEED_BLOCK = 8


def make_tasks(
    configs: list[Config],
    seeds: range,
    samples: int,
    cache_dir: str,
    clock: str = "cpu",
    block: int = SEED_BLOCK,
    cflags: str | None = None,
) -> list[Task]:
    """Blocks of ``block`` seeds, configuration-major inside a block: partial results cover the whole grid evenly
    (every configuration has the block's seeds before any has the next block's), and a worker runs one solver for
    several runs in a row instead of switching between all of them at every run (its workspace stays in cache)."""
    _one_of("clock", clock, CLOCKS)
    if block < 1:
        raise ProblemError(f"block = {block} is invalid: allowed >= 1")
    seed_list = list(seeds)
    return [
        Task(c, s, samples, cache_dir, clock, cflags)
        for b in range(0, len(seed_list), block)
        for c in configs
        for s in seed_list[b : b + block]
    ]
