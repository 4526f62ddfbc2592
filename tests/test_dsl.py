"""Tests of the problem DSL (fcgen.dsl) and the presets / problem-file loader (fcgen.presets).

Expected values are the paper's (SPEC sections 2, 3, 5, 7), written out here by hand, not read from the code.
"""

from __future__ import annotations

import math
import textwrap
import warnings

import pytest

from fcgen.dsl import (
    Bounds,
    Conventional,
    CoveringCircles,
    DirectElimination,
    Ellipse,
    Horizon,
    Lifted,
    Opponents,
    PlanCheck,
    Problem,
    ProblemError,
    QpOptions,
    Reference,
    RoadWindow,
    SeparatingHyperplane,
    SoftPenalties,
    Vehicle,
    Weights,
    Wind,
    circles_cover,
)
from fcgen.presets import TRUCK, load_problem, paper_problem, preset, preset_names

NAN = float("nan")


# --- defaults: the paper's values ----------------------------------------------------------------


def test_vehicle_defaults_are_the_papers():
    v = Vehicle()
    assert v.m == 1160.0
    assert v.l_f == 1.7 and v.l_r == 1.7
    assert v.l == pytest.approx(3.4, abs=1e-12)
    assert v.l_ch == pytest.approx(4.0, abs=1e-12)
    assert v.w_ch == 1.9
    # c_air = 0.5 * c_w * A * rho = 0.5 * 0.29 * 2.07 * 1.29 = 0.3871935 kg/m (SPEC: 0.3872)
    assert v.c_air == pytest.approx(0.3871935, abs=1e-9)
    assert round(v.c_air, 4) == 0.3872
    assert v.c_air == pytest.approx(0.5 * 0.29 * 2.07 * 1.29, rel=1e-15)
    # c_roll = mu * m * g = 0.015 * 1160 * 9.81 = 170.694 N
    assert v.c_roll == pytest.approx(170.694, abs=1e-9)
    # r_cover: one circle around a 4 x 1.9 chassis
    assert v.r_cover == pytest.approx(math.sqrt(2.0**2 + 0.95**2), abs=1e-12)


def test_wind_horizon_reference_defaults():
    assert (Wind().v, Wind().phi) == (20.0, 0.0)
    assert (Horizon().N, Horizon().dt) == (40, 0.1)
    # the default: the paper's grid, 40 intervals of one sample
    d = Horizon()
    assert (d.stride, d.n_fine, d.uniform, d.interval, d.offsets[-1]) == (1, 40, True, 0.1, 40)
    # an unequal grid: 20 intervals of one 0.1 s sample, then 20 of three: 2 s + 6 s = 8 s ahead
    h = Horizon(stride=3, fine=20)
    assert (h.stride, h.fine, h.n_fine, h.uniform, h.interval, h.length) == (3, 20, 20, False, 0.1, 8.0)
    assert h.stage_samples == (1,) * 20 + (3,) * 20 and h.offsets[:3] == (0, 1, 2) and h.offsets[-2:] == (77, 80)
    assert h.times[20] == pytest.approx(2.0) and h.times[21] == pytest.approx(2.3)
    assert h.max_interval == pytest.approx(0.3)
    # stride 1: the paper's uniform grid, times k dt (the same floats as before the field existed)
    p = Horizon(N=40, dt=0.1, stride=1)
    assert (p.uniform, p.interval, p.n_fine, p.times[7]) == (True, 0.1, 40, 7 * 0.1) and p.length == pytest.approx(4.0)
    # all intervals coarse (fine = 0): uniform, 0.2 s each
    c = Horizon(N=40, dt=0.1, stride=2, fine=0)
    assert (c.uniform, c.interval, c.offsets[-1], c.times[3]) == (True, 0.2, 80, 3 * 0.2)
    assert (Reference().v_ref, Reference().n_ref) == (40.0, 0.0)


def test_weight_defaults_are_table_ii():
    w = Weights()
    assert w.q == (1.0, 500.0, 1e3, 1e3, 1e4)
    assert w.q_N == (10.0, 90.0, 100.0, 10.0, 10.0)
    assert w.r == (1e-3, 2e6)


def test_bound_defaults_are_table_i():
    b = Bounds()
    assert b.F_d_max == 1e4
    assert b.r_max == 0.39
    assert b.delta_max == 0.3
    assert (b.v_min, b.v_max) == (0.0, 40.0)
    assert b.alpha_max == pytest.approx(math.pi / 4, abs=1e-15)
    assert (b.n_min, b.n_max) == (-10.0, 10.0)
    assert b.a_lat_max == 5.0
    assert b.v_N_max == 15.0


def test_soft_penalty_defaults():
    from fcgen.presets import PAPER_SOFT, preset

    s = PAPER_SOFT  # the paper presets' values (10x SPEC's obstacle weights: see SoftPenalties)
    assert (s.obstacle_l1, s.obstacle_l2) == (1e7, 1e6)
    assert (s.a_lat_l1, s.a_lat_l2) == (1e5, 1e4)
    assert s.soft_road is False and SoftPenalties().soft_road is False
    assert preset("truck_lifted_ellipse").soft == PAPER_SOFT


def test_default_problem_is_valid_and_lifted_ellipse():
    p = Problem(name="p")
    assert isinstance(p.formulation, Lifted)
    assert isinstance(p.obstacles, Ellipse)
    assert p.opponents.count == 3


# --- validation: every invalid value raises ProblemError naming the field and the allowed range ----

INVALID = [
    ("N=0", lambda: Horizon(N=0), "horizon.N", "[1, 500]"),
    ("N<0", lambda: Horizon(N=-5), "horizon.N", "[1, 500]"),
    ("N float", lambda: Horizon(N=2.5), "horizon.N", "integer"),
    ("N bool", lambda: Horizon(N=True), "horizon.N", "integer"),
    ("dt=0", lambda: Horizon(dt=0.0), "horizon.dt", "(0, 10]"),
    ("dt<0", lambda: Horizon(dt=-0.1), "horizon.dt", "(0, 10]"),
    ("dt nan", lambda: Horizon(dt=NAN), "horizon.dt", "finite"),
    ("mass<0", lambda: Vehicle(m=-1160.0), "vehicle.m", "> 0"),
    ("mass=0", lambda: Vehicle(m=0.0), "vehicle.m", "> 0"),
    ("mass nan", lambda: Vehicle(m=NAN), "vehicle.m", "finite"),
    ("c_air<0", lambda: Vehicle(c_air=-0.1), "vehicle.c_air", ">= 0"),
    ("wheelbase inf", lambda: Vehicle(l_f=math.inf), "vehicle.l_f", "finite"),
    ("n_min>n_max", lambda: Bounds(n_min=5.0, n_max=-5.0), "bounds.n_min", "< n_max"),
    ("n_min=n_max", lambda: Bounds(n_min=3.0, n_max=3.0), "bounds.n_min", "< n_max"),
    ("v_min=v_max", lambda: Bounds(v_min=40.0, v_max=40.0), "bounds.v_min", "v_min < v_max"),
    ("v_min>v_max", lambda: Bounds(v_min=30.0, v_max=20.0, v_N_max=20.0), "bounds.v_min", "v_min < v_max"),
    ("v_min<0", lambda: Bounds(v_min=-1.0), "bounds.v_min", "0 <= v_min"),
    ("n_max nan", lambda: Bounds(n_max=NAN), "bounds.n_max", "finite"),
    ("alpha_max too big", lambda: Bounds(alpha_max=2.0), "bounds.alpha_max", "(0, pi/2)"),
    ("v_N_max>v_max", lambda: Bounds(v_N_max=50.0), "bounds.v_N_max", "[v_min, v_max]"),
    ("overapprox unknown", lambda: Conventional(overapprox="convexify"), "formulation.overapprox", "'fit'"),
    ("margin<0", lambda: Conventional(margin=-0.5), "formulation.margin", ">= 0"),
    ("circles 0", lambda: CoveringCircles(0), "obstacles.n", "[1, 20]"),
    ("circles 21", lambda: CoveringCircles(21), "obstacles.n", "[1, 20]"),
    ("ego circles 0", lambda: CoveringCircles(3, n_ego=0), "obstacles.n_ego", "[1, 20]"),
    ("name digit", lambda: Problem(name="9abc"), "name", "lower case letter"),
    ("name upper/dash", lambda: Problem(name="A-b"), "name", "lower case letter"),
    ("name dash", lambda: Problem(name="a-b"), "name", "[a-z0-9_]"),
    ("name empty", lambda: Problem(name=""), "name", "lower case letter"),
    ("name too long", lambda: Problem(name="a" * 40), "name", "31 characters"),
    ("weights nan", lambda: Weights(q=(NAN, 500.0, 1e3, 1e3, 1e4)), "weights.q[0]", "finite"),
    ("weights neg", lambda: Weights(r=(1e-3, -1.0)), "weights.r[1]", ">= 0"),
    ("weights length", lambda: Weights(q_N=(1.0, 2.0)), "weights.q_N", "tuple of 5"),
    ("wind nan", lambda: Wind(v=NAN), "wind.v", "finite"),
    ("wind neg", lambda: Wind(v=-3.0), "wind.v", ">= 0"),
    ("v_ref nan", lambda: Reference(v_ref=NAN), "reference.v_ref", "finite"),
    ("curve a_lat < 0", lambda: Reference(curve_a_lat=-1.0), "reference.curve_a_lat", "[0, 50]"),
    ("curve a_lat nan", lambda: Reference(curve_a_lat=NAN), "reference.curve_a_lat", "finite"),
    ("curve decel 0", lambda: Reference(curve_decel=0.0), "reference.curve_decel", "(0, 50]"),
    (
        "curve a_lat in traffic 0",
        lambda: Reference(curve_a_lat_traffic=0.0),
        "reference.curve_a_lat_traffic",
        "(0, 50]",
    ),
    (
        "traffic clearance < 0",
        lambda: Reference(curve_traffic_clearance=-1.0),
        "reference.curve_traffic_clearance",
        "[0, 100]",
    ),
    (
        "traffic clearance inf",
        lambda: Reference(curve_traffic_clearance=math.inf),
        "reference.curve_traffic_clearance",
        "finite",
    ),
    (
        "curve along not a bool",
        lambda: Reference(curve_along_horizon=1),
        "reference.curve_along_horizon",
        "True or False",
    ),
    ("opponents count", lambda: Opponents(count=11), "opponents.count", "[0, 10]"),
    ("qp eps", lambda: QpOptions(eps_abs=1.5), "qp.eps_abs", "[0, 1)"),
    ("qp alpha", lambda: QpOptions(alpha=2.0), "qp.alpha", "(0, 2)"),
    ("qp max_iter", lambda: QpOptions(max_iter=0), "qp.max_iter", "[1, 1e6]"),
    ("qp backend", lambda: QpOptions(backend="cplex"), "qp.backend", "one of osqp"),
    ("road ds", lambda: RoadWindow(ds=0.0), "road.ds", "[0.1, 20]"),
    # the window must cover the horizon: 40 m/s * 40 * 0.1 s + 4 * 2 m = 168 m
    ("road too short", lambda: Problem(name="p", road=RoadWindow(length=100.0)), "road.length", "168"),
    # ... an unequal grid's 8 s: 40 m/s * 8 s + 4 * 2 m = 328 m
    ("road too short, 8 s", lambda: Problem(name="p", horizon=Horizon(stride=3, fine=20)), "road.length", "328"),
    ("stride 0", lambda: Horizon(stride=0), "horizon.stride", "[1, 10]"),
    ("fine < 0", lambda: Horizon(fine=-1), "horizon.fine", ">= 0"),
    ("stride float", lambda: Horizon(stride=1.5), "horizon.stride", "integer"),
    ("stride beyond 10 s", lambda: Horizon(dt=2.0, stride=6), "horizon.stride", "dt * stride <= 10 s"),
    ("a_lat margin < 0", lambda: Bounds(a_lat_margin=-0.1), "bounds.a_lat_margin", "[0, a_lat_max = 5.0)"),
    ("a_lat margin >= bound", lambda: Bounds(a_lat_margin=5.0), "bounds.a_lat_margin", "[0, a_lat_max = 5.0)"),
    ("formulation type", lambda: Problem(name="p", formulation="lifted"), "formulation", "Lifted()"),
    ("a_lat guard not a bool", lambda: PlanCheck(a_lat_guard=1), "plan_check.a_lat_guard", "True or False"),
    ("tyre stiffness < 0", lambda: PlanCheck(tyre_stiffness=-1.0), "plan_check.tyre_stiffness", "[0, 100] 1/rad"),
    ("tyre stiffness NaN", lambda: PlanCheck(tyre_stiffness=math.nan), "plan_check.tyre_stiffness", "finite"),
    ("h_cg > 3 m", lambda: PlanCheck(h_cg=3.5), "plan_check.h_cg", "[0, 3] m"),
    ("drive limit not a bool", lambda: PlanCheck(drive_limit=0), "plan_check.drive_limit", "True or False"),
    (
        "h_cg moving more than an axle's load",  # 1e4 N / 1160 kg * 2.5 m = 21.6 > 9.81 * 1.7 = 16.7 m^2/s^2
        lambda: Problem(name="p", plan_check=PlanCheck(h_cg=2.5)),
        "plan_check.h_cg",
        "[0, 1.935) m with plan_check.tyre_stiffness > 0",
    ),
    (
        "a_lat guard without margin",
        lambda: Problem(name="p", bounds=Bounds(a_lat_margin=0.0)),
        "bounds.a_lat_margin",
        "(0, a_lat_max = 5.0) m/s^2 with plan_check.a_lat_guard",
    ),
]


@pytest.mark.parametrize("make, field, allowed", [c[1:] for c in INVALID], ids=[c[0] for c in INVALID])
def test_invalid_value_raises_problem_error_naming_field_and_range(make, field, allowed):
    with pytest.raises(ProblemError) as ei:
        make()
    msg = str(ei.value)
    assert msg.startswith(field + " = "), msg
    assert "allowed" in msg and allowed in msg, msg


def test_problem_error_is_a_value_error():
    # the CLI catches ValueError-derived user errors
    assert issubclass(ProblemError, ValueError)


def test_valid_names_are_accepted():
    for name in ("a", "truck_lifted_el", "x1_2", "a" * 31):
        assert Problem(name=name).name == name


def test_with_revalidates():
    p = Problem(name="p")
    assert p.with_(horizon=Horizon(N=20)).horizon.N == 20
    with pytest.raises(ProblemError, match="name"):
        p.with_(name="Bad")


# --- covering circles: warn when they cannot cover the chassis -----------------------------------


def _truck_problem(n: int, radius: str = "paper") -> Problem:
    return Problem(name="t", obstacles=CoveringCircles(n, radius=radius), opponents=Opponents(3, TRUCK))


@pytest.mark.parametrize("n", [4, 5, 6])
def test_too_few_circles_warn_for_the_truck(n):
    # 26 x 4 truck, circles of radius w/sqrt(2) cover an axial strip of length w = 4 each, so
    # (26 - 4) / spacing + 1 circles with spacing <= 4: (26 - 4) / 4 + 1 = 6.5 -> at least 7.
    with pytest.warns(UserWarning, match=r"opponents chassis \(26 x 4 m\); at least 7 are needed"):
        _truck_problem(n)
    with warnings.catch_warnings():  # the safe profile's covering radius: no gap, no warning
        warnings.simplefilter("error")
        _truck_problem(n, "cover")


@pytest.mark.parametrize("n", [7, 8, 20])
def test_enough_circles_do_not_warn(n):
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        p = _truck_problem(n)
    assert p.obstacles.n == n


def test_circles_cover_threshold_by_hand():
    # spacing (l - w) / (n - 1) must not exceed w
    assert not circles_cover(26.0, 4.0, 6)  # spacing 4.4
    assert circles_cover(26.0, 4.0, 7)  # spacing 3.67
    assert not circles_cover(4.0, 1.9, 2)  # spacing 2.1 > 1.9
    assert circles_cover(4.0, 1.9, 3)  # spacing 1.05
    assert circles_cover(26.0, 4.0, 1)  # one circle of radius sqrt(L^2 + W^2) always covers


def test_ego_circles_warning_names_the_ego():
    # a 12 x 1 ego with 2 circles: spacing 11 > 1
    long_ego = Vehicle(l_f_ch=6.0, l_r_ch=6.0, w_ch=1.0)
    with pytest.warns(UserWarning, match="ego chassis"):
        Problem(name="p", ego=long_ego, obstacles=CoveringCircles(7, n_ego=2, radius="paper"))


# --- loading a problem from a Python file ----------------------------------------------------------


def _write(tmp_path, name, body):
    path = tmp_path / name
    path.write_text(textwrap.dedent(body))
    return str(path)


def test_load_problem_file_defining_problem(tmp_path):
    path = _write(
        tmp_path,
        "my_truck.py",
        """
        from fcgen.dsl import Problem, Horizon, CoveringCircles, Opponents, Conventional
        from fcgen.presets import TRUCK
        problem = Problem(name="my_truck", formulation=Conventional(margin=0.25), obstacles=CoveringCircles(7),
                          opponents=Opponents(2, TRUCK), horizon=Horizon(N=20, dt=0.05))
    """,
    )
    p = load_problem(path)
    assert isinstance(p, Problem)
    assert p.name == "my_truck"
    assert isinstance(p.formulation, Conventional) and p.formulation.margin == 0.25
    assert p.obstacles.n == 7
    assert p.opponents.count == 2 and p.opponents.vehicle.l_ch == 26.0
    assert (p.horizon.N, p.horizon.dt) == (20, 0.05)


def test_load_problem_file_with_make_problem(tmp_path):
    path = _write(
        tmp_path,
        "factory.py",
        """
        from fcgen.dsl import Problem, DirectElimination
        def make_problem():
            return Problem(name="factory", formulation=DirectElimination())
    """,
    )
    p = load_problem(path)
    assert p.name == "factory" and isinstance(p.formulation, DirectElimination)


@pytest.mark.parametrize(
    "body, words",
    [
        ("raise RuntimeError('boom')\n", ["failed to load", "RuntimeError", "boom"]),
        ("problem = (\n", ["failed to load", "SyntaxError"]),
        ("import fcgen_no_such_module\n", ["failed to load", "ModuleNotFoundError"]),
        ("x = 1\n", ["must define", "problem"]),
        ("problem = 42\n", ["must define", "Problem("]),
    ],
)
def test_load_problem_file_errors_are_problem_errors(tmp_path, body, words):
    path = _write(tmp_path, "bad.py", body)
    with pytest.raises(ProblemError) as ei:
        load_problem(path)
    for w in words:
        assert w in str(ei.value)
    assert "bad.py" in str(ei.value)


def test_load_problem_file_with_invalid_value_names_the_field(tmp_path):
    path = _write(
        tmp_path,
        "invalid.py",
        """
        from fcgen.dsl import Problem, Horizon
        problem = Problem(name="invalid", horizon=Horizon(N=0))
    """,
    )
    with pytest.raises(ProblemError, match=r"horizon\.N = 0 is invalid: allowed an integer in \[1, 500\]"):
        load_problem(path)


def test_load_problem_make_problem_that_raises_is_a_problem_error(tmp_path):
    # A file whose make_problem() raises is a user's file that fails to load, exactly like a file that
    # raises at import: it must be reported as a ProblemError, not escape as a raw exception (traceback).
    path = _write(
        tmp_path,
        "bad_factory.py",
        """
        def make_problem():
            raise KeyError("no such setting")
    """,
    )
    with pytest.raises(ProblemError, match=r"bad_factory.py"):
        load_problem(path)


def test_load_problem_missing_file(tmp_path):
    with pytest.raises(ProblemError, match="does not exist"):
        load_problem(str(tmp_path / "nope.py"))


# --- presets ---------------------------------------------------------------------------------------


def test_eighteen_presets_all_load():
    names = preset_names()
    assert len(names) == 18 == len(set(names))
    expected = {
        f"{sc}_{f}_{o}"
        for sc in ("car", "truck")
        for f in ("conventional", "direct_elimination", "lifted")
        for o in ("ellipse", "circles", "hyperplane")
    }
    assert set(names) == expected
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # the paper's circle counts cover the chassis: no warning
        for n in names:
            p = preset(n)
            assert isinstance(p, Problem)
            assert load_problem(n).name == p.name


FORM_CLASS = {"conventional": Conventional, "direct_elimination": DirectElimination, "lifted": Lifted}
OBS_CLASS = {"ellipse": Ellipse, "circles": CoveringCircles, "hyperplane": SeparatingHyperplane}


@pytest.mark.parametrize("name", preset_names())
def test_preset_name_maps_to_classes_and_dimensions(name):
    sc, rest = name.split("_", 1)
    form, ob = rest.rsplit("_", 1)
    p = preset(name)
    assert type(p.formulation) is FORM_CLASS[form]
    assert type(p.obstacles) is OBS_CLASS[ob]
    if ob == "circles":
        assert p.obstacles.n == (7 if sc == "truck" else 3)  # C7 for trucks, C3 for cars
    if sc == "truck":
        assert (p.bounds.n_min, p.bounds.n_max) == (-10.0, 10.0)
        opp = p.opponents.vehicle
        assert (opp.l_ch, opp.w_ch) == (26.0, 4.0)
        assert opp.l == 20.0 and opp.m == 3000.0
    else:
        assert (p.bounds.n_min, p.bounds.n_max) == (-8.5, 8.5)
        assert (p.opponents.vehicle.l_ch, p.opponents.vehicle.w_ch) == (4.0, 1.9)
    # the ego is always the car of Table II, 3 opponents
    assert (p.ego.l, p.ego.l_ch, p.ego.w_ch, p.ego.m) == (3.4, 4.0, 1.9, 1160.0)
    assert p.opponents.count == 3
    assert (p.horizon.N, p.horizon.dt) == (40, 0.1)


def test_unknown_preset_lists_the_allowed_names():
    with pytest.raises(ProblemError) as ei:
        preset("truck_lifted_banana")
    assert "truck_lifted_banana" in str(ei.value)
    msg = str(ei.value)  # the grammar of the names, its parts listed (tests/test_error_messages.py parses it)
    assert "SCENARIO one of car, truck" in msg and "OBSTACLES one of ellipse, circles, hyperplane" in msg
    assert "`fcgen presets` lists them" in msg


def test_paper_problem_rejects_unknown_scenario_and_formulation():
    with pytest.raises(ProblemError, match="scenario"):
        paper_problem("bus")
    with pytest.raises(ProblemError, match="formulation"):
        paper_problem("truck", "cartesian")
    with pytest.raises(ProblemError, match="obstacles"):
        paper_problem("truck", "lifted", "polygon")


def test_preset_with_a_backend_suffix():
    from fcgen.presets import is_preset, preset

    pb = preset("truck_lifted_ellipse_ipm")
    base = preset("truck_lifted_ellipse")
    assert pb.qp.backend == "ipm" and base.qp.backend == "osqp"
    assert pb.name == base.name + "_ipm" and pb.formulation == base.formulation and pb.obstacles == base.obstacles
    assert not is_preset("truck_lifted_ellipse_qpoases") and not is_preset("truck_lifted_ipm")
    with pytest.raises(ProblemError, match="preset = 'truck_lifted_ellipse_x' is unknown"):
        preset("truck_lifted_ellipse_x")
