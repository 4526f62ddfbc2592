"""The paper's configurations as named presets, and loading a problem from a Python file."""

from __future__ import annotations

import difflib
import importlib.util
from dataclasses import replace
from pathlib import Path

from .dsl import (
    Bounds,
    Conventional,
    CoveringCircles,
    DirectElimination,
    Ellipse,
    Lifted,
    Opponents,
    PlanCheck,
    Problem,
    ProblemError,
    QpOptions,
    Reference,
    SeparatingHyperplane,
    SoftPenalties,
    Vehicle,
)

CAR = Vehicle()
TRUCK = Vehicle(l_f=10.0, l_r=10.0, l_f_ch=13.0, l_r_ch=13.0, w_ch=4.0, m=3000.0)

SCENARIOS = ("car", "truck")
FORMULATIONS = {"conventional": Conventional, "direct_elimination": DirectElimination, "lifted": Lifted}
OBSTACLES = ("ellipse", "circles", "hyperplane")
# the paper's circle counts: C1/C3 for cars, C5/C7 for trucks
DEFAULT_CIRCLES = {"car": 3, "truck": 7}
SHORT = {
    "conventional": "conv",
    "direct_elimination": "de",
    "lifted": "lift",
    "ellipse": "el",
    "circles": "c",
    "hyperplane": "hp",
}


PROFILES = ("paper", "safe")
"""``paper``: the paper's settings (its presets, Table III); ``safe``: ours, the DSL's defaults
(docs/safe_profile.md)."""
PAPER_SOFT = SoftPenalties(obstacle_l1=1e7, obstacle_l2=1e6, a_lat_l1=1e5, a_lat_l2=1e4)
PAPER_PLAN_CHECK = PlanCheck(react_stages=0, a_lat_guard=False, tyre_stiffness=0.0, drive_limit=False, bend_brake=0.0)
OSQP_MAX_ITER: dict[str, int] = {"ellipse": 35, "hyperplane": 60, "circles": 60}
"""The ADMM cap of a warm-started QP (``QpOptions.max_iter``) in the OSQP presets and campaign runs, per obstacle model
(the dataclass's default, 60, stays the IPM's own cap). An ADMM iteration costs the same whatever OSQP's embedded
settings (219 k x86 instructions, three quarters of them the two triangular solves with the LDL' factor;
docs/performance.md, "OSQP: the iterations are the cost"), so the iterations a QP are what an RTI costs: 35 instead
of 60 take 37 % off truck_lifted_ellipse's RTI on the Cortex-M7 (16.73 -> 10.56 M instructions).
``benchmarks/osqp_settings.py``, truck, 20 seeds x 200 samples per configuration: 40 against 60, the ellipse's three
formulations +0.54 % mean progress (per seed median -0.04 %; the rest a few seeds changing manoeuvre), the truck
grid's mean +0.15 %, no new collision; 35 against 40, the ellipse's -0.03 % (worst formulation -0.34 %), no new
collision (30: -0.09 %, worst -0.45 %, a seed 21 % apart). The hyperplanes (-1.5 % at 40) and the covering circles
(C7 lifted -8 %) keep 60."""
PAPER_QP = QpOptions(ipm_scaled_start=False)
"""The paper profile's QP options: the defaults but the IPM's start as before the safe profile (no effect on OSQP);
a paper problem gets its model's OSQP cap (``OSQP_MAX_ITER``) on top."""
PAPER_A_LAT_MARGIN = 0.0
"""The paper plans |a_lat| up to its bound (``Bounds.a_lat_margin``; the safe profile keeps the default inside it)."""
PAPER_CURVE_A_LAT = 0.0
"""The paper's reference asks for v_ref everywhere (``Reference.curve_a_lat = 0``: no curve speed)."""
SAFE_SOFT_CONVENTIONAL = SoftPenalties(obstacle_l1=1e8, a_lat_l1=3e8)
"""The safe profile's weights for the conventional formulation: its fitted boxes leave no hard solution in 7.5 % of
the truck HP QPs, and with the obstacle weight 1e9 those QPs are conditioned so badly that the C and the Python IPM
part by up to 2e-5 (``fcgen verify``: 1e-7); 1e8 keeps them within it. Where a box leaves no hard solution the a_lat
row is the dearer one (3e8): the box is an over-approximation, so its slack is mostly margin, not contact (the plan
check judges the true rectangles), while a_lat given way to a box drove |a_lat| to 37 m/s^2 (the safe grid of
commit 78d0f50). 1e9 parts the two IPMs by 5e-6 again; 1e8 (equal) leaves 3 of 50 truck HP runs above the bound by
up to 3 m/s^2 (docs/safe_profile.md "The curve speed")."""


def safe_soft(formulation) -> SoftPenalties:
    """The safe profile's slack penalties of a formulation (the DSL's defaults but for the conventional one)."""
    return SAFE_SOFT_CONVENTIONAL if isinstance(formulation, Conventional) else SoftPenalties()


SAFE_REFERENCE_CONVENTIONAL = Reference(curve_traffic_clearance=0.0, curve_along_horizon=False)
"""The safe profile's reference for the conventional formulation: the curve speed without its traffic rule, at the
plan's start only. Measured on the full grids of commits 3e51e81 and d6dac44, the rule moved the conventional
formulation's two contacts to other seeds and kept its excesses as they were (at most 0.41 m/s^2); the curve speed
along the horizon moved them too (two to one, both "opponent from behind"), and with either its ill-conditioned QPs
(the a_lat rows at 3e8) part the C and the Python IPM by 1.6e-7 .. 1.9e-7 on truck HP seed 0 (``fcgen verify``:
1e-7); without both they stay within (docs/safe_profile.md "The curve speed in traffic", "The curve reference along
the horizon")."""


def safe_reference(formulation) -> Reference:
    """The safe profile's reference of a formulation (the DSL's defaults but for the conventional one)."""
    return SAFE_REFERENCE_CONVENTIONAL if isinstance(formulation, Conventional) else Reference()


SAFE_PLAN_CHECK = PlanCheck(brake_memory=True, drive_rise=4.0)
"""The safe profile's plan check (but for the conventional formulation): the DSL's defaults, and the a_lat guard's
memory of the last drive force, braking (``brake_memory``) and the drive force's rise per sample (``drive_rise``,
m/s^2 per sample; docs/safe_profile.md "The guard's memory of the last force")."""

SAFE_DELAY_MARGIN = 1.5
"""The safe profile's obstacle margin (m, ``Problem.obstacle_margin``) where its solver compensates a latency
(``Problem.delay`` >= 1): with the delay, a single-track plant, noise and a 0.1 s steering lag the plant leaves its
plan wide in the bends after an overtake, into the lane of the truck it passed; 0.5 and 1.0 m left ego-caused
contacts on seeds 0-99, 1.5 m none (docs/plants.md "The margin under latency"). Without a delay: none."""


def safe_delay_margin(profile: str, delay: int) -> float:
    """The obstacle margin (m) of a profile's problem compensating ``delay`` samples (``SAFE_DELAY_MARGIN``)."""
    return SAFE_DELAY_MARGIN if profile != "paper" and delay > 0 else 0.0


SAFE_PLAN_CHECK_CONVENTIONAL = PlanCheck(a_lat_guard=False)
"""The safe profile's plan check for the conventional formulation: without the a_lat guard. Its a_lat rows are the
dearer ones (3e8, ``SAFE_SOFT_CONVENTIONAL``), and its plans keep the bound on their own within 0.37 m/s^2 on the full
grid (commit d6dac44); with the guard (commit 7e4bd04) the guard acted in 144 of its 4,000 runs (200 samples), none
above 0.5 m/s^2 before, and moved one of them, truck HP seed 45, onto a path that ended in a contact the ego caused
(docs/safe_profile.md "The a_lat guard")."""


def safe_plan_check(formulation) -> PlanCheck:
    """The safe profile's plan check of a formulation (the DSL's defaults but for the conventional one)."""
    return SAFE_PLAN_CHECK_CONVENTIONAL if isinstance(formulation, Conventional) else SAFE_PLAN_CHECK


IPM_RTI_BUDGET: dict[tuple[str, str, str], int] = {
    ("paper", "lifted", "ellipse"): 7,
    ("paper", "direct_elimination", "ellipse"): 7,
}
"""The IPM's RTI budget of the configurations (profile, formulation, obstacles) where it was measured to leave the
closed loop where it was (``benchmarks/rti_budget.py``: progress within 0.1 % of the default budget's and no new
collision on 100 seeds x 200 samples of the car and the truck; docs/wcet.md): what their ``_ipm`` presets and the
campaign's IPM runs use. Every other configuration keeps ``QpOptions``' default (``RTI_BUDGET_DEFAULT``)."""


def preset_qp(backend: str, formulation: str, obstacles: str, profile: str = "paper") -> QpOptions:
    """The QP options of a preset or a campaign configuration: the backend, with OSQP's cap or the IPM's measured RTI
    budget."""
    if backend == "osqp":
        return QpOptions(backend=backend, max_iter=OSQP_MAX_ITER[obstacles], ipm_scaled_start=profile != "paper")
    budget = IPM_RTI_BUDGET.get((profile, formulation, obstacles)) if backend == "ipm" else None
    return QpOptions(backend=backend, rti_budget=budget, ipm_scaled_start=profile != "paper")


def obstacle_model(name: str, scenario: str, circles: int | None = None, profile: str = "paper"):
    """Obstacle model by CLI name: ``ellipse``, ``circles`` (paper default count), ``hyperplane``; in a profile."""
    paper = profile == "paper"
    if name == "ellipse":
        return Ellipse(shape="paper") if paper else Ellipse()
    if name == "circles":
        n = circles or DEFAULT_CIRCLES[scenario]
        return CoveringCircles(n, radius="paper") if paper else CoveringCircles(n)
    if name == "hyperplane":
        # the paper's planes are free (anchor 0): the anchor changes the optimum where the rows are active
        return SeparatingHyperplane(anchor=0.0) if paper else SeparatingHyperplane()
    raise ProblemError(f"obstacles = {name!r} is invalid: allowed one of {OBSTACLES}")


def with_profile(pb: Problem, profile: str, scenario: str, obstacles: str, circles: int | None = None) -> Problem:
    """``pb`` with the settings of a profile (the same scenario, formulation, horizon, weights and QP backend)."""
    if profile not in PROFILES:
        raise ProblemError(f"profile = {profile!r} is invalid: allowed one of {PROFILES}")
    if profile == "paper":
        return pb.with_(
            obstacles=obstacle_model(obstacles, scenario, circles, "paper"),
            soft=PAPER_SOFT,
            plan_check=PAPER_PLAN_CHECK,
            qp=replace(pb.qp, ipm_scaled_start=False),
            bounds=replace(pb.bounds, a_lat_margin=PAPER_A_LAT_MARGIN),
            reference=replace(pb.reference, curve_a_lat=PAPER_CURVE_A_LAT),
        )
    ref = safe_reference(pb.formulation)  # its curve speed; the speed and lateral offset stay pb's
    return pb.with_(
        obstacles=obstacle_model(obstacles, scenario, circles, "safe"),
        soft=safe_soft(pb.formulation),
        plan_check=safe_plan_check(pb.formulation),
        qp=replace(pb.qp, ipm_scaled_start=True),
        bounds=replace(pb.bounds, a_lat_margin=Bounds().a_lat_margin),
        reference=replace(ref, v_ref=pb.reference.v_ref, n_ref=pb.reference.n_ref),
    )


def paper_problem(
    scenario: str = "truck",
    formulation: str = "lifted",
    obstacles: str = "ellipse",
    circles: int | None = None,
    name: str | None = None,
    profile: str = "paper",
    **overrides,
) -> Problem:
    """A problem of the paper's experiment (SPEC section 7), with the paper's settings or the safe profile's."""
    if scenario not in SCENARIOS:
        raise ProblemError(f"scenario = {scenario!r} is invalid: allowed one of {SCENARIOS}")
    if formulation not in FORMULATIONS:
        raise ProblemError(f"formulation = {formulation!r} is invalid: allowed one of {tuple(FORMULATIONS)}")
    if profile not in PROFILES:
        raise ProblemError(f"profile = {profile!r} is invalid: allowed one of {PROFILES}")
    model = obstacle_model(obstacles, scenario, circles, profile)
    n_bound = 10.0 if scenario == "truck" else 8.5
    opp = TRUCK if scenario == "truck" else CAR
    if name is None:
        tag = SHORT[obstacles] + (str(model.n) if obstacles == "circles" else "")
        name = f"{scenario}_{SHORT[formulation]}_{tag}"
    form = FORMULATIONS[formulation]()
    profiled = (
        {
            "soft": PAPER_SOFT,
            "plan_check": PAPER_PLAN_CHECK,
            "qp": replace(PAPER_QP, max_iter=OSQP_MAX_ITER[obstacles]),
            "reference": Reference(curve_a_lat=PAPER_CURVE_A_LAT),
        }
        if profile == "paper"
        else {"soft": safe_soft(form), "reference": safe_reference(form), "plan_check": safe_plan_check(form)}
    )
    return Problem(
        name=name,
        formulation=form,
        obstacles=model,
        ego=CAR,
        opponents=Opponents(3, opp),
        bounds=Bounds(
            n_min=-n_bound,
            n_max=n_bound,
            a_lat_margin=PAPER_A_LAT_MARGIN if profile == "paper" else Bounds().a_lat_margin,
        ),
        **{**profiled, **overrides},
    )


def preset_names() -> list[str]:
    """Every preset: ``<scenario>_<formulation>_<obstacles>``."""
    return [f"{sc}_{f}_{o}" for sc in SCENARIOS for f in FORMULATIONS for o in OBSTACLES]


BACKEND_SUFFIXES = ("ipm",)
"""A preset name may end in ``_<backend>`` for a QP backend other than the default OSQP
(``truck_lifted_ellipse_ipm``)."""
SAFE_SUFFIX = "safe"
"""... and then in ``_safe`` for the safe profile (``truck_lifted_hyperplane_ipm_safe``; with OSQP
``truck_lifted_hyperplane_safe``)."""


def preset_grammar() -> str:
    """What a preset name is, in one sentence (the grammar ``preset`` parses; the unknown-preset message)."""
    return (
        f"a preset is SCENARIO_FORMULATION_OBSTACLES[_BACKEND][_{SAFE_SUFFIX}] with SCENARIO one of "
        f"{', '.join(SCENARIOS)}; FORMULATION one of {', '.join(FORMULATIONS)}; OBSTACLES one of "
        f"{', '.join(OBSTACLES)}; BACKEND one of {', '.join(BACKEND_SUFFIXES)} (without it: OSQP); "
        f"_{SAFE_SUFFIX}: the safe profile (e.g. truck_lifted_ellipse_ipm_{SAFE_SUFFIX}, "
        f"truck_lifted_ellipse_{SAFE_SUFFIX})"
    )


def _all_preset_names() -> list[str]:
    """Every name ``preset_grammar`` allows."""
    backends = ["", *(f"_{b}" for b in BACKEND_SUFFIXES)]
    return [f"{n}{b}{s}" for n in preset_names() for b in backends for s in ("", f"_{SAFE_SUFFIX}")]


def preset(name: str) -> Problem:
    """A preset by name, e.g. ``truck_lifted_ellipse`` (OSQP), ``truck_lifted_ellipse_ipm`` (the IPM backend),
    ``truck_lifted_ellipse_ipm_safe`` (the safe profile)."""
    base, _, suffix = name.rpartition("_")
    if suffix == SAFE_SUFFIX and base and not base.endswith("_" + SAFE_SUFFIX) and is_preset(base):
        pb = preset(base)
        sc, f, o = _parts(base)
        return with_profile(pb, "safe", sc, o, getattr(pb.obstacles, "n", None)).with_(
            name=f"{pb.name}_{SAFE_SUFFIX}", qp=preset_qp(pb.qp.backend, f, o, "safe")
        )
    if suffix in BACKEND_SUFFIXES and base in preset_names():
        pb = preset(base)
        _, f, o = _parts(base)
        return pb.with_(name=f"{pb.name}_{suffix}", qp=preset_qp(suffix, f, o))
    for sc in SCENARIOS:
        for f in FORMULATIONS:
            for o in OBSTACLES:
                if name == f"{sc}_{f}_{o}":
                    return paper_problem(sc, f, o)
    near = difflib.get_close_matches(name, _all_preset_names(), n=1)
    hint = f"did you mean {near[0]!r}? " if near else ""
    raise ProblemError(f"preset = {name!r} is unknown: {hint}{preset_grammar()} (`fcgen presets` lists them)")


def _parts(name: str) -> tuple[str, str, str]:
    """(scenario, formulation, obstacles) of a preset name (a backend suffix ignored)."""
    for sc in SCENARIOS:
        for f in FORMULATIONS:
            for o in OBSTACLES:
                if name == f"{sc}_{f}_{o}" or name.startswith(f"{sc}_{f}_{o}_"):
                    return sc, f, o
    raise ProblemError(f"preset = {name!r} is unknown")


def is_preset(name: str) -> bool:
    try:
        preset(name)
    except ProblemError:
        return False
    return True


def load_problem(spec: str) -> Problem:
    """A preset name, or a Python file that defines ``problem`` (a Problem) or ``make_problem()``."""
    path = Path(spec)
    if spec.endswith(".py"):
        if not path.is_file():
            raise ProblemError(f"problem file {spec!r} does not exist")
        mod_spec = importlib.util.spec_from_file_location(f"fcgen_problem_{path.stem}", path)
        if mod_spec is None or mod_spec.loader is None:
            raise ProblemError(f"problem file {spec!r} cannot be loaded as a Python module")
        module = importlib.util.module_from_spec(mod_spec)
        try:
            mod_spec.loader.exec_module(module)
        except ProblemError:
            raise
        except Exception as exc:  # noqa: BLE001 - any error of a user's file: reported in one line
            raise ProblemError(f"problem file {spec!r} failed to load: {type(exc).__name__}: {exc}") from None
        prob = getattr(module, "problem", None)
        if prob is None and hasattr(module, "make_problem"):
            try:
                prob = module.make_problem()
            except ProblemError:
                raise
            except Exception as exc:  # noqa: BLE001 - any error of a user's factory: reported in one line
                raise ProblemError(
                    f"problem file {spec!r}: make_problem() failed: {type(exc).__name__}: {exc}"
                ) from None
        if not isinstance(prob, Problem):
            raise ProblemError(f"problem file {spec!r} must define `problem = Problem(...)` or `make_problem()`")
        return prob
    return preset(spec)
