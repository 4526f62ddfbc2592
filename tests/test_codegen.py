"""Generated C solver: static memory, prefixed symbols, determinism, C == Python reference, bad inputs, linking."""

from __future__ import annotations

import dataclasses
import hashlib
import math
import re
import shutil
import subprocess
from pathlib import Path

import numpy as np
import pytest

from fcgen.build import build
from fcgen.codegen.generate import GenerateInfo, generate
from fcgen.codegen.model_code import float_math
from fcgen.contract import EXIT_CODES
from fcgen.csolver import CSolver
from fcgen.dsl import QpOptions
from fcgen.ocp import build_ocp
from fcgen.presets import paper_problem, preset
from fcgen.reference import RtiSolver
from fcgen.road import straight_road
from fcgen.sim.closedloop import WINDOW_BEHIND, plant_function, run_closed_loop
from fcgen.sim.scenario import OpponentParams, make_scenario

pytestmark = pytest.mark.skipif(
    any(shutil.which(t) is None for t in ("gcc", "make", "nm")), reason="needs gcc, make and nm"
)

PRESET = "truck_lifted_ellipse"
FORBIDDEN = {
    "malloc",
    "calloc",
    "realloc",
    "free",
    "printf",
    "fprintf",
    "fopen",
    "puts",
    "putchar",
    "fputs",
    "fwrite",
    "sprintf",
    "snprintf",
}
CODE = {c: i for i, c in enumerate(EXIT_CODES)}


@pytest.fixture(scope="module")
def gen(tmp_path_factory) -> GenerateInfo:
    return generate(preset(PRESET), tmp_path_factory.mktemp("gen") / "a")


@pytest.fixture(scope="module")
def default_build(gen: GenerateInfo) -> Path:
    build(gen.out_dir)
    return gen.out_dir / "build"


@pytest.fixture(scope="module")
def cs(gen: GenerateInfo) -> CSolver:
    return CSolver(build(gen.out_dir, verify=True))


def _hashes(root: Path) -> dict[str, str]:
    return {
        p.relative_to(root).as_posix(): hashlib.sha256(p.read_bytes()).hexdigest()
        for p in sorted(root.rglob("*"))
        if p.is_file() and "build" not in p.relative_to(root).parts and p.name != ".fcgen-generated.json"
    }  # the record of what generate wrote, not generator output


def _nm(args: list[str], obj: Path) -> list[str]:
    out = subprocess.run(["nm", *args, str(obj)], check=True, capture_output=True, text=True).stdout
    return [line.split()[-1] for line in out.splitlines() if line.strip()]


def _our_objects(gen: GenerateInfo, build_dir: Path) -> list[Path]:
    obj = build_dir / "obj"
    return [
        obj / f"{gen.name}_solver.o",
        obj / f"{gen.name}_model.o",
        *(obj / Path(s).with_suffix(".o") for s in gen.qp_files.sources),
    ]


# --- static properties ------------------------------------------------------------------------------------------


def test_no_heap_no_stdio(gen: GenerateInfo, default_build: Path) -> None:
    for obj in _our_objects(gen, default_build):
        bad = set(_nm(["-u"], obj)) & FORBIDDEN
        assert not bad, (obj.name, bad)


def test_global_symbols_prefixed(gen: GenerateInfo, default_build: Path) -> None:
    for obj in _our_objects(gen, default_build):
        names = _nm(["-g", "--defined-only"], obj)
        assert names, obj.name
        assert all(n.startswith(f"{gen.name}_") for n in names), (
            obj.name,
            [n for n in names if not n.startswith(gen.name)],
        )


def test_workspace_bytes_match_objects(gen: GenerateInfo, default_build: Path) -> None:
    """NAME_WORKSPACE_BYTES = static RAM of the solver and OSQP workspace objects (x86-64)."""
    objs = _our_objects(gen, default_build)
    out = subprocess.run(["size", *map(str, objs)], check=True, capture_output=True, text=True).stdout
    rows = {Path(line.split()[-1]).name: [int(v) for v in line.split()[:3]] for line in out.splitlines()[1:]}
    solver = rows[f"{gen.name}_solver.o"]
    ws = rows[Path(gen.qp_files.sources[0]).with_suffix(".o").name]
    assert solver[2] == gen.solver_workspace_bytes  # .bss: the workspace struct
    # the backend's RAM: all of it zero-initialized (.bss; initial values are const copies), no .data; the compiler
    # may pad between objects (x86-64 aligns arrays of 32 bytes or more to 32)
    sections = {}
    ws_obj = next(o for o in objs if o.name == Path(gen.qp_files.sources[0]).with_suffix(".o").name)
    for line in subprocess.run(
        ["size", "-A", str(ws_obj)], check=True, capture_output=True, text=True
    ).stdout.splitlines():
        parts = line.split()
        if len(parts) >= 2 and parts[0].startswith("."):
            sections[parts[0]] = int(parts[1])
    assert sections.get(".data", 0) == 0 and sections.get(".data.rel", 0) == 0
    n_objects = len(re.findall(r"^\w+\s+\w+(?:\[\d+\])?;$", (gen.out_dir / gen.qp_files.sources[0]).read_text(), re.M))
    assert 0 <= sections[".bss"] - (gen.qp_array_bytes + gen.qp_struct_bytes) < 32 * n_objects
    assert ws[0] > 0  # the const copies (text + rodata)
    assert (
        f"#define {gen.name.upper()}_WORKSPACE_BYTES {gen.workspace_bytes} "
        in (gen.out_dir / f"{gen.name}_solver.h").read_text()
    )


def test_deterministic(gen: GenerateInfo, tmp_path: Path) -> None:
    other = generate(preset(PRESET), tmp_path / "elsewhere" / "b")
    ha, hb = _hashes(gen.out_dir), _hashes(other.out_dir)
    assert ha == hb
    assert set(gen.files) | set(gen.library_files) == set(ha)
    for f in gen.files:
        text = (other.out_dir / f).read_text()
        assert str(tmp_path) not in text and "/tmp" not in text, f


def test_example_runs(gen: GenerateInfo, default_build: Path) -> None:
    res = subprocess.run([str(default_build / f"{gen.name}_example")], capture_output=True, text=True, timeout=60)
    assert res.returncode == 0, res.stdout + res.stderr
    assert "exit 0" in res.stdout


# --- C == Python reference ---------------------------------------------------------------------------------------


def _rel(c: np.ndarray, r: np.ndarray) -> float:
    return float(np.max(np.abs(c - r) / np.maximum(np.abs(r), 1.0), initial=0.0))


def test_matches_reference(cs: CSolver) -> None:
    """Same inputs, sample after sample (shifted guesses): QP data to 1e-12, u0 to 1e-9 (measured: bit-identical)."""
    pb = preset(PRESET)
    ocp = build_ocp(pb)
    ref = RtiSolver(ocp)
    sc = make_scenario("truck", 3)
    opp = OpponentParams(pb, sc)
    plant = plant_function(pb, ocp.road_params.samples)
    assert cs.init() == 0
    x, road = sc.x0.copy(), sc.road
    worst = {}
    for j in range(8):
        win, op = road.window(x[0] - WINDOW_BEHIND, pb.road.samples), opp.horizon(j)
        ref.set_road(win)
        ref.set_opponents(op)
        if ref.w is None:
            ref.set_state(x)
        ref.prepare()
        assert cs.set_road(win) == 0 and cs.set_opponents(op) == 0
        if not cs.has_guess():
            assert cs.set_state(x) == 0
        assert cs.prepare() == 0, cs.status()
        qp = cs.get_qp()
        for key, r in (("q", ref.q), ("l", ref.l), ("u", ref.u), ("A_x", ref.A_data), ("P_x", ref.lay.P_diag)):
            worst[key] = max(worst.get(key, 0.0), _rel(qp[key], r))
        ref.set_state(x)
        u_ref = ref.feedback()
        assert cs.set_state(x) == 0 and cs.feedback() == 0, cs.status()
        st = cs.status()
        assert st.exit_code == 0 and st.qp_status == ref.status.qp_status and st.qp_iter == ref.status.qp_iter
        worst["q_fb"] = max(worst.get("q_fb", 0.0), _rel(cs.get_qp()["q"], ref.q_fb))
        worst["u0"] = max(worst.get("u0", 0.0), _rel(cs.u0(), u_ref))
        np.testing.assert_allclose(cs.states(), ref.states(), rtol=1e-9, atol=1e-9)
        np.testing.assert_allclose(cs.controls(), ref.controls(), rtol=1e-9, atol=1e-9)
        assert cs.max_slack() == pytest.approx(float(np.max(ref.slacks(), initial=0.0)), rel=1e-9, abs=1e-12)
        i0 = math.floor((x[0] - road.s0) / road.ds) - 1
        x = np.array(plant(x, u_ref, ocp.road_params.pack(road, i0))).ravel()
    print("max relative differences C vs Python:", worst)
    assert all(worst[k] <= 1e-12 for k in ("q", "l", "u", "A_x", "P_x", "q_fb")), worst
    assert worst["u0"] <= 1e-9, worst


def test_controller_protocol(cs: CSolver) -> None:
    """CSolver.step in the closed loop gives the reference's controls."""
    pb = preset(PRESET)
    ocp = build_ocp(pb)
    sc = make_scenario("truck", 5, samples=6)
    assert cs.init() == 0
    log_c = run_closed_loop(pb, sc, controller=cs, ocp=ocp)
    log_py = run_closed_loop(pb, sc, ocp=ocp)
    assert log_c.meta["controller"] == "c"
    assert np.all(log_c.qp_status == log_py.qp_status)
    np.testing.assert_allclose(log_c.control, log_py.control, rtol=1e-9, atol=1e-9)
    assert np.all(log_c.time_feedback > 0)


def _same_result(a, b) -> bool:
    """Two StepResults bit for bit, the solver's own times left out."""
    return (
        a.u.dtype == b.u.dtype
        and a.u.tobytes() == b.u.tobytes()
        and (a.exit_code, a.qp_status, a.qp_iter) == (b.exit_code, b.qp_status, b.qp_iter)
        and (a.max_slack == b.max_slack or (math.isnan(a.max_slack) and math.isnan(b.max_slack)))
    )


def test_window_stepper_is_step(cs: CSolver) -> None:
    """CSolver.window_stepper (the closed loop's C path: no window built) gives step's results on built windows bit
    for bit, its error codes and its errors; a subclass that overrides a part of step gets step itself."""
    pb = preset(PRESET)
    sc = make_scenario("truck", 5, samples=8)

    class Plain:  # the Controller protocol without window_stepper: run_closed_loop builds the windows
        kind = "c"

        def step(self, x0, road, opp):
            return cs.step(x0, road, opp)

    logs = []
    for ctrl in (cs, Plain()):
        assert cs.init() == 0
        logs.append(run_closed_loop(pb, sc, controller=ctrl, exit_codes=True))
    for name in logs[0].sample_fields():
        if not name.startswith("time_"):
            a, b = (np.asarray(getattr(log, name)) for log in logs)
            assert a.dtype == b.dtype and a.tobytes() == b.tobytes(), name
    # sample by sample, with bad opponents and a state that is not finite
    road, x0, opp = _inputs(cs)
    bad_opp, bad_x = opp.copy(), x0.copy()
    bad_opp[3, 1, 2], bad_x[2] = math.nan, math.inf
    results = []
    for way in ("stepper", "step"):
        assert cs.init() == 0
        step = cs.window_stepper(road, road.size)
        for x, o in ((x0, opp), (x0, bad_opp), (bad_x, opp), (x0, opp), (x0, opp)):
            results.append(step(x, road.s0, o) if way == "stepper" else cs.step(x, road, o))
    assert [r.exit_code for r in results[:5]] == [0, CODE["ERR_NONFINITE_OPPONENTS"], CODE["ERR_NONFINITE_STATE"], 0, 0]
    assert all(_same_result(a, b) for a, b in zip(results[:5], results[5:]))
    step = cs.window_stepper(road, road.size)
    with pytest.raises(ValueError, match="outside the road"):
        step(x0, road.s0 + 2.0 * road.ds, opp)
    with pytest.raises(ValueError, match="expected"):
        step(x0, road.s0, opp[:-1])
    # a subclass that overrides a part of step: step on a built window (its own prepare_phase runs)
    calls = []

    class Counting(CSolver):
        def prepare_phase(self, x0, road, opp):
            calls.append(road.size)
            return super().prepare_phase(x0, road, opp)

    sub = Counting(cs.lib._name)
    assert sub.init() == 0
    assert _same_result(sub.window_stepper(road, road.size)(x0, road.s0, opp), results[5]) and calls == [road.size]


# --- bad inputs ----------------------------------------------------------------------------------------------------


def _inputs(cs: CSolver, s_ego: float = 0.0):
    pb = preset(PRESET)
    road = straight_road(length=(pb.road.samples - 1) * pb.road.ds, ds=pb.road.ds, s0=s_ego - 20.0)
    x0 = np.array([s_ego, 1.0, 0.0, 15.0, 0.0])
    opp = np.zeros((cs.N + 1, cs.n_opp, cs.n_opp_par))
    opp[..., 0], opp[..., 1] = -1000.0, 500.0  # far away
    return road, x0, opp


def _step_ok(cs: CSolver) -> None:
    assert cs.prepare() == CODE["OK"]
    assert cs.feedback() == CODE["OK"]
    assert np.all(np.isfinite(cs.u0())) and cs.status().exit_code == 0


def test_bad_inputs(cs: CSolver) -> None:
    road, x0, opp = _inputs(cs)
    assert cs.init() == 0 and not cs.has_guess()
    # call order
    assert cs.feedback() == CODE["ERR_NOT_PREPARED"] and cs.status().exit_code == CODE["ERR_NOT_PREPARED"]
    assert cs.set_road(road) == 0 and cs.set_opponents(opp) == 0
    assert cs.prepare() == CODE["ERR_NO_STATE"] and cs.status().exit_code == CODE["ERR_NO_STATE"]
    # non-finite state, then a valid one
    assert cs.set_state([0.0, math.nan, 0.0, 15.0, 0.0]) == CODE["ERR_NONFINITE_STATE"]
    assert cs.status().exit_code == CODE["ERR_NONFINITE_STATE"]
    assert cs.prepare() == CODE["ERR_NO_STATE"]
    assert cs.set_state(x0) == 0
    # infinite opponent pose, then valid opponents
    bad = opp.copy()
    bad[7, 1, 0] = math.inf
    assert cs.set_opponents(bad) == CODE["ERR_NONFINITE_OPPONENTS"]
    assert cs.status().exit_code == CODE["ERR_NONFINITE_OPPONENTS"]
    assert cs.set_opponents(opp) == 0
    # a road that starts ahead of the ego: the window does not cover the horizon
    ahead, _, _ = _inputs(cs, s_ego=30.0)
    assert cs.set_road(ahead) == 0
    assert cs.prepare() == CODE["ERR_ROAD_WINDOW"] and cs.status().exit_code == CODE["ERR_ROAD_WINDOW"]
    assert not cs.has_guess()
    assert cs.feedback() == CODE["ERR_NOT_PREPARED"]
    # invalid roads are rejected and the previous one kept
    n = cs.sizes["ROAD_MAX"]
    assert cs.set_road_raw(0.0, 2.0, *[np.zeros(n + 1)] * 4) == CODE["ERR_ROAD_SIZE"]
    kappa = np.zeros(n)
    kappa[3] = math.nan
    assert cs.set_road_raw(0.0, 2.0, kappa, np.zeros(n), np.arange(n) * 2.0, np.zeros(n)) == CODE["ERR_NONFINITE_ROAD"]
    assert cs.set_road_raw(0.0, -2.0, *[np.zeros(n)] * 4) == CODE["ERR_ROAD_SIZE"]
    # a correct call works
    assert cs.set_road(road) == 0
    _step_ok(cs)
    assert cs.has_guess()
    # after a solve: a bad road for the next sample, then a good one
    assert cs.set_road(ahead) == 0
    assert cs.prepare() == CODE["ERR_ROAD_WINDOW"]
    assert cs.set_road(road) == 0
    _step_ok(cs)
    # feedback twice without prepare
    assert cs.feedback() == CODE["ERR_NOT_PREPARED"]
    cs.reset()
    assert not cs.has_guess()
    _step_ok(cs)


def test_step_reports_errors(cs: CSolver) -> None:
    road, x0, opp = _inputs(cs)
    assert cs.init() == 0
    bad = opp.copy()
    bad[0, 0, 2] = math.nan
    r = cs.step(x0, road, bad)
    assert r.exit_code == CODE["ERR_NONFINITE_OPPONENTS"] and np.all(r.u == 0) and math.isnan(r.max_slack)
    r = cs.step(x0, road, opp)
    assert r.exit_code == 0 and np.all(np.isfinite(r.u))


# --- linking ---------------------------------------------------------------------------------------------------------

TWO_SOLVERS_C = Path(__file__).parent / "c" / "two_solvers.c"


def _libs(g: GenerateInfo, sub: str) -> list[str]:
    return [str(g.out_dir / sub / f"lib{g.name}.a"), str(g.out_dir / sub / f"lib{g.name}_osqp.a")]


def _unprefixed(g: GenerateInfo, sub: str) -> list[str]:
    """Global symbols defined in lib<name>.a + lib<name>_osqp.a that do not carry the solver's prefix."""
    out = subprocess.run(
        ["nm", "-g", "--defined-only", *_libs(g, sub)], check=True, capture_output=True, text=True
    ).stdout
    return [
        f[2]
        for f in (line.split() for line in out.splitlines())
        if len(f) == 3 and f[1] in "TDBRCVWtdbr" and not f[2].startswith(f"{g.name}_")
    ]


def test_two_solvers_one_image(gen: GenerateInfo, tmp_path: Path) -> None:
    """A double and a float solver, each with its own (prefixed) OSQP, link into one executable and both run: every
    symbol of both libraries carries its solver's prefix, and each solver computes in the two-solver image exactly
    what it computes alone."""
    other = generate(paper_problem("car", "direct_elimination", "ellipse"), tmp_path / "car", use_float=True)
    assert other.name == "car_de_el"
    for g in (gen, other):
        subprocess.run(
            ["make", "-C", str(g.out_dir), "-j2", "BUILD=build/lib", "lib"], check=True, capture_output=True, text=True
        )
        assert _unprefixed(g, "build/lib") == []
    runs = {}
    for tag, solvers in (("both", {"A": gen, "B": other}), ("a", {"A": gen}), ("b", {"B": other})):
        defs = [
            d for ab, g in solvers.items() for d in (f"-DSOLVER_{ab}={g.name}", f"-DSOLVER_{ab}_UP={g.name.upper()}")
        ]
        solvers = list(solvers.values())
        exe = tmp_path / f"two_{tag}"
        subprocess.run(
            [
                "gcc",
                "-std=c99",
                "-Wall",
                "-Wextra",
                "-Werror",
                *defs,
                *(f"-I{g.out_dir}" for g in solvers),
                str(TWO_SOLVERS_C),
                *(lib for g in solvers for lib in _libs(g, "build/lib")),
                "-lm",
                "-o",
                str(exe),
            ],
            check=True,
            capture_output=True,
            text=True,
        )
        res = subprocess.run([str(exe)], capture_output=True, text=True, timeout=60)
        assert res.returncode == 0, res.stdout + res.stderr
        runs[tag] = res.stdout.splitlines()
    assert runs["both"] == runs["a"] + runs["b"]
    assert len(runs["both"]) == 6 and {line.split()[0] for line in runs["both"]} == {gen.name, other.name}
    for line in runs["both"]:
        _, _, rc, u0, u1 = line.split()
        assert rc == "0" and math.isfinite(float(u0)) and math.isfinite(float(u1))
    a0 = [tuple(float(x) for x in line.split()[3:5]) for line in runs["a"]]
    # the samples differ: the solver ran, it did not return a constant (a drive force at its bound repeats: both
    # inputs compared)
    assert len(set(a0)) == 3, a0


@pytest.mark.skipif(shutil.which("cmake") is None, reason="needs cmake")
def test_cmake_build(gen: GenerateInfo, tmp_path: Path) -> None:
    b = tmp_path / "cmake-build"
    subprocess.run(
        ["cmake", "-S", str(gen.out_dir), "-B", str(b), f"-D{gen.name.upper()}_VERIFY=ON"],
        check=True,
        capture_output=True,
        text=True,
    )
    subprocess.run(["cmake", "--build", str(b), "-j8"], check=True, capture_output=True, text=True)
    assert {f"lib{gen.name}.a", f"lib{gen.name}_osqp.a", f"lib{gen.name}.so"} <= {p.name for p in b.iterdir()}
    assert subprocess.run([str(b / f"{gen.name}_example")], capture_output=True, timeout=60).returncode == 0


def test_float_build(tmp_path: Path) -> None:
    """use_float: float API, float OSQP, builds with -Werror and solves the example."""
    info = generate(preset(PRESET), tmp_path / "f", use_float=True)
    assert "typedef float truck_lift_el_real_t;" in (info.out_dir / "truck_lift_el_solver.h").read_text()
    assert "#define OSQP_USE_FLOAT" in (info.out_dir / "osqp/lib/osqp_configure.h").read_text()
    lib = build(info.out_dir)
    res = subprocess.run([str(info.out_dir / "build" / "truck_lift_el_example")], capture_output=True, timeout=60)
    assert res.returncode == 0
    # the closed loop's window_stepper on float inputs (the road converted once, kept alive): step's results
    fs, pb = CSolver(lib), preset(PRESET)
    sc = make_scenario("truck", 2, samples=5)
    opp = OpponentParams(pb, sc)
    results = []
    for way in ("stepper", "step"):
        assert fs.init() == 0
        step, x = fs.window_stepper(sc.road, pb.road.samples), sc.x0
        for j in range(5):
            s_start = x[0] - WINDOW_BEHIND
            r = (
                step(x, s_start, opp.horizon(j))
                if way == "stepper"
                else fs.step(x, sc.road.window(s_start, pb.road.samples), opp.horizon(j))
            )
            results.append(r)
            x = x + np.array([1.5, 0.0, 0.0, 0.0, 0.0])
    assert all(r.exit_code == 0 for r in results)
    assert all(_same_result(a, b) for a, b in zip(results[:5], results[5:]))


def test_float_math_rewrites_literals_and_calls_only() -> None:
    src = (
        "/* CasADi 3.8.2: sin(x) 2. */\nstatic float casadi_fmin(float x, float y) { return fmin(x, y); }\n"
        "a001=10.; a2=(2.*a004); a3=2.9999999999999999e-01; a4=1e-3+.5; a5=sqrt (a6)+floor(a7); a008=a9[2];\n"
    )
    out = float_math(src)
    assert out == (
        "/* CasADi 3.8.2: sin(x) 2. */\nstatic float casadi_fmin(float x, float y) { return fminf(x, y); }\n"
        "a001=10.f; a2=(2.f*a004); a3=2.9999999999999999e-01f; a4=1e-3f+.5f; a5=sqrtf (a6)+floorf(a7); "
        "a008=a9[2];\n"
    )


def test_float_model_is_single_precision(tmp_path: Path) -> None:
    """--float: CasADi's model code calls the float math functions; model and solver compile with
    -Wdouble-promotion -Werror (no float -> double promotion: single-precision arithmetic throughout)."""
    info = generate(paper_problem("car", "lifted", "circles", name="car_fm"), tmp_path / "f", use_float=True)
    src = (info.out_dir / "car_fm_model.c").read_text()
    assert re.search(r"\b(sin|cos|tan|sqrt|fabs|fmin|fmax|floor)\(", src) is None
    assert "sinf(" in src and "cosf(" in src
    objs = [f"build/sp/obj/car_fm_{part}.o" for part in ("model", "solver")]
    res = subprocess.run(
        [
            "make",
            "-C",
            str(info.out_dir),
            "BUILD=build/sp",
            "WARNFLAGS=-Wall -Wextra -Werror -Wdouble-promotion",
            *objs,
        ],
        capture_output=True,
        text=True,
    )
    assert res.returncode == 0, res.stdout[-3000:] + res.stderr[-3000:]
    assert all((info.out_dir / o).is_file() for o in objs)


@pytest.mark.parametrize("obstacles", ["ellipse", "hyperplane"])  # the IPM's code without / with stage equalities
def test_float_ipm_solver_is_single_precision(tmp_path: Path, obstacles: str) -> None:
    """--float with the IPM backend: its C calls the float math functions and compiles with -Wdouble-promotion
    -Werror; the folder builds lib<name>.a alone (no QP library)."""
    p = paper_problem("car", "conventional", obstacles, name="car_ipmf")
    p = dataclasses.replace(p, horizon=dataclasses.replace(p.horizon, N=4), qp=QpOptions(backend="ipm"))
    info = generate(p, tmp_path / "f", use_float=True)
    src = re.sub(r"/\*.*?\*/", "", (info.out_dir / "car_ipmf_solver.c").read_text(), flags=re.S)  # code only
    assert re.search(r"\b(sqrt|fabs|floor|sin|cos)\(", src) is None and "sqrtf" in src and "fabsf" in src
    res = subprocess.run(
        [
            "make",
            "-C",
            str(info.out_dir),
            "BUILD=build/sp",
            "WARNFLAGS=-Wall -Wextra -Werror -Wdouble-promotion",
            "lib",
        ],
        capture_output=True,
        text=True,
    )
    assert res.returncode == 0, res.stdout[-3000:] + res.stderr[-3000:]
    assert sorted(p.name for p in (info.out_dir / "build/sp").glob("*.a")) == ["libcar_ipmf.a"]


def test_build_restores_osqp_library(tmp_path: Path) -> None:
    info = generate(paper_problem("car", "lifted", "ellipse", name="car_restore"), tmp_path / "r")
    shutil.rmtree(info.out_dir / "osqp" / "lib")
    lib = build(info.out_dir)
    assert lib.is_file() and (info.out_dir / "osqp/lib/osqp_configure.h").is_file()


def _fake_clock(start: int, step: int):
    """A clock hook returning start, start + step, start + 2 step, ... modulo 2^32 (one reading per call)."""
    import ctypes

    state = {"t": start % 2**32}

    @ctypes.CFUNCTYPE(ctypes.c_uint32)
    def clock() -> int:
        t = state["t"]
        state["t"] = (t + step) % 2**32
        return t

    return clock


@pytest.mark.parametrize("use_float", [False, True])
def test_status_layout_and_tick_clock(tmp_path: Path, use_float: bool) -> None:
    """The status struct: C's layout (sizeof, offsetof) is the binding's and the generator's for either precision;
    u_violation and plan_clearance have the real type. The clock hook returns integer ticks: each phase reads it twice,
    so a fake clock advancing STEP ticks a reading gives ticks_prepare = ticks_feedback = STEP, also when the counter
    wraps past 2^32 within the phase; the binding reports them in seconds (ticks / ticks_per_second)."""
    import ctypes

    from fcgen.codegen.workspace import status_layout
    from fcgen.contract import STATUS_FIELDS, STATUS_STRUCTS

    p = paper_problem("car", "lifted", "ellipse", name="car_tick")
    p = dataclasses.replace(p, horizon=dataclasses.replace(p.horizon, N=4))
    info = generate(p, tmp_path / "t", use_float=use_float)
    header = (info.out_dir / "car_tick_solver.h").read_text()
    real = "float" if use_float else "double"
    assert "  car_tick_real_t u_violation;" in header and "  car_tick_real_t plan_clearance;" in header
    assert f"typedef {real} car_tick_real_t;" in header and "  uint32_t ticks_prepare;" in header
    # the layout as C compiles it
    probe = tmp_path / "layout.c"
    probe.write_text(
        '#include <stddef.h>\n#include <stdio.h>\n#include "car_tick_solver.h"\nint main(void) {\n'
        '  printf("sizeof %zu\\n", sizeof(car_tick_status_t));\n'
        + "".join(f'  printf("{f} %zu\\n", offsetof(car_tick_status_t, {f}));\n' for f in STATUS_FIELDS)
        + "  return 0;\n}\n"
    )
    exe = tmp_path / "layout"
    subprocess.run(
        ["gcc", "-std=c99", "-Wall", "-Werror", f"-I{info.out_dir}", str(probe), "-o", str(exe)],
        check=True,
        capture_output=True,
        text=True,
    )
    c_layout = dict(
        (k, int(v))
        for k, v in (
            ln.split()
            for ln in subprocess.run([str(exe)], check=True, capture_output=True, text=True).stdout.splitlines()
        )
    )
    cls, packed = STATUS_STRUCTS[use_float]
    assert c_layout == {"sizeof": ctypes.sizeof(cls), **{f: getattr(cls, f).offset for f in STATUS_FIELDS}}
    assert c_layout["sizeof"] == packed.size == status_layout(4 if use_float else 8)[0] == (60 if use_float else 72)
    # the tick clock: exact differences, across a wrap of the counter too
    cs = CSolver(build(info.out_dir))
    cs.ticks_per_second = 1000
    sc = make_scenario("car", 0, samples=8)
    opp = OpponentParams(p, sc)
    stepper = cs.window_stepper(sc.road, p.road.samples)  # the closed loop's fast path: its own conversion
    step, j, x = 123_457, 0, sc.x0
    for start in (5, 2**32 - step // 2, 2**32 - 2 * step - step // 2):  # no wrap, a wrap in prepare, in feedback
        for fast in (False, True):
            clock = _fake_clock(start, step)
            cs._f("set_clock")(ctypes.cast(clock, ctypes.c_void_p))
            s_start = x[0] - WINDOW_BEHIND
            r = (
                stepper(x, s_start, opp.horizon(j))
                if fast
                else cs.step(x, sc.road.window(s_start, p.road.samples), opp.horizon(j))
            )
            st, raw = cs.status(), cs._status
            assert r.exit_code == 0 and (raw.ticks_prepare, raw.ticks_feedback) == (step, step), (start, fast)
            assert r.time_prepare == r.time_feedback == st.time_prepare == st.time_feedback == step / 1000
            x, j = x + np.array([1.0, 0.0, 0.0, 0.0, 0.0]), j + 1
    cs._f("set_clock")(None)  # no clock: no timing
    r = cs.step(x, sc.road.window(x[0] - WINDOW_BEHIND, p.road.samples), opp.horizon(j))
    assert r.exit_code == 0 and (cs._status.ticks_prepare, cs._status.ticks_feedback) == (0, 0)


def test_the_header_gives_the_stages_samples(tmp_path: Path) -> None:
    """<NAME>_STAGE_OFFSETS: the sample of each node, what set_opponents' stages are predicted at; compiled into an
    array by a C program, it prints the grid's offsets (20 fine intervals, then every third sample to 80)."""
    from fcgen.dsl import Horizon, RoadWindow

    pb = paper_problem("car", "lifted", "ellipse", profile="safe").with_(
        horizon=Horizon(stride=3, fine=20), road=RoadWindow(length=340.0)
    )
    info = generate(pb, tmp_path / "g")
    name = pb.name
    prog = tmp_path / "off.c"
    prog.write_text(
        f'#include <stdio.h>\n#include "{name}_solver.h"\n'
        f"static const int off[{name.upper()}_N + 1] = {name.upper()}_STAGE_OFFSETS;\n"
        f'int main(void) {{ int k; for (k = 0; k <= {name.upper()}_N; ++k) printf("%d ", off[k]); '
        "return 0; }\n"
    )
    exe = tmp_path / "off"
    subprocess.run(
        ["gcc", "-std=c99", "-Wall", "-Wextra", "-Werror", f"-I{info.out_dir}", str(prog), "-o", str(exe)], check=True
    )
    got = [int(v) for v in subprocess.run([str(exe)], check=True, capture_output=True, text=True).stdout.split()]
    assert got == list(range(21)) + list(range(23, 81, 3)) == list(pb.horizon.offsets)
