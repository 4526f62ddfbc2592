"""Cortex-M targets: cross builds, the closed loop on QEMU against the host's, instruction counts, footprint."""

from __future__ import annotations

import re
import shutil
import subprocess
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

from fcgen.bench import bench_target
from fcgen.build import build
from fcgen.cli import main
from fcgen.codegen.generate import GenerateInfo, generate
from fcgen.footprint import footprint, section_sizes
from fcgen.presets import preset
from fcgen.sim.harness import HarnessError, firmware_sim, linker_script
from fcgen.sim.runlog import compare
from fcgen.solver_folder import build_dir
from fcgen.targets import TARGETS, TargetError, get_target

TOOLS = ("arm-none-eabi-gcc", "arm-none-eabi-size", "qemu-system-arm", "make", "gcc")
needs_toolchain = pytest.mark.skipif(
    any(shutil.which(t) is None for t in TOOLS),
    reason="needs the arm-none-eabi toolchain, QEMU, gcc and make (setup.sh)",
)
PRESET = "truck_lifted_ellipse"
SAMPLES = 25
SEED = 3


# ----------------------------------------------------------------------------- targets as data


def test_target_table() -> None:
    m7, m4f = get_target("cortex-m7"), get_target("cortex-m4f")
    assert "-mfpu=fpv5-d16" in m7.cpu_flags and "-mfpu=fpv4-sp-d16" in m4f.cpu_flags
    assert "-mfloat-abi=hard" in m7.cpu_flags and "-mfloat-abi=hard" in m4f.cpu_flags
    assert (m7.qemu_machine, m4f.qemu_machine) == ("mps2-an500", "mps2-an386")
    assert m7.double_fpu and not m4f.double_fpu and not TARGETS["host"].bare_metal
    with pytest.raises(TargetError, match=r"--target: 'cortex-m9' is invalid: allowed host, cortex-m7, cortex-m4f"):
        get_target("cortex-m9")
    m4f.check_precision(True)
    with pytest.raises(TargetError) as exc:
        m4f.check_precision(False)
    assert "\n" not in str(exc.value) and "--float" in str(exc.value)


def test_linker_script_memory_map() -> None:
    """The mps2 boards as QEMU maps them: code SSRAM at 0, data SSRAM at 0x20000000 (512 KiB of it used, as an ECU's
    SRAM), PSRAM for the harness's buffers at 0x60000000 (AN500) / 0x21000000 (AN386)."""
    for name, xram in (("cortex-m7", "0x60000000"), ("cortex-m4f", "0x21000000")):
        text = linker_script(get_target(name))
        assert re.search(r"FLASH \(rx\) *: ORIGIN = 0x00000000, LENGTH = 4194304", text)
        assert re.search(r"RAM \(rwx\) *: ORIGIN = 0x20000000, LENGTH = 524288", text)
        assert re.search(rf"XRAM \(rw\) *: ORIGIN = {xram}, LENGTH = 16777216", text)
        assert "KEEP(*(.vectors))" in text and "> RAM AT > FLASH" in text and "*(.bss.fs_harness*)" in text


# ----------------------------------------------------------------------------- builds


@pytest.fixture(scope="module")
def gen_double(tmp_path_factory) -> GenerateInfo:
    return generate(preset(PRESET), tmp_path_factory.mktemp("tgt") / "double")


@pytest.fixture(scope="module")
def gen_float(tmp_path_factory) -> GenerateInfo:
    return generate(preset(PRESET), tmp_path_factory.mktemp("tgt") / "float", use_float=True)


def test_double_solver_refused_for_m4f(gen_double) -> None:
    res = CliRunner().invoke(main, ["build", str(gen_double.out_dir), "--target", "cortex-m4f"])
    assert res.exit_code == 1 and "Traceback" not in res.output
    assert res.output.count("\n") == 1 and "no double precision" in res.output and "--float" in res.output


def test_toolchain_files_shipped(gen_double, gen_float) -> None:
    assert sorted(p.name for p in (gen_double.out_dir / "cmake").iterdir()) == ["arm-none-eabi-cortex-m7.cmake"]
    assert sorted(p.name for p in (gen_float.out_dir / "cmake").iterdir()) == [
        "arm-none-eabi-cortex-m4f.cmake",
        "arm-none-eabi-cortex-m7.cmake",
    ]


@needs_toolchain
def test_cross_build_static_libraries_only(gen_double) -> None:
    lib = build(gen_double.out_dir, target="cortex-m7")
    out = lib.parent
    assert out == build_dir(gen_double.out_dir, target="cortex-m7")
    products = sorted(p.name for p in out.iterdir() if p.is_file() and p.name != "flags.txt")
    assert products == ["libtruck_lift_el.a", "libtruck_lift_el_osqp.a"]
    objs = sorted((out / "obj").rglob("*.o"))
    assert objs and not any("host" in o.name or o.name == "main.o" for o in objs)
    assert "-fPIC" not in (out / "flags.txt").read_text()
    hdr = subprocess.run(
        ["arm-none-eabi-readelf", "-hA", str(out / "obj" / "truck_lift_el_solver.o")],
        capture_output=True,
        text=True,
        check=True,
    ).stdout
    assert "Machine:                           ARM" in hdr
    assert 'Tag_CPU_name: "7E-M"' in hdr or "Cortex-M7" in hdr
    assert "Tag_FP_arch: FPv5/FP-D16 for ARMv8" in hdr and "Tag_ABI_VFP_args: VFP registers" in hdr


@needs_toolchain
def test_plain_make_without_osqp_sources_says_how_to_restore(gen_double, tmp_path) -> None:
    folder = tmp_path / "copy"
    shutil.copytree(gen_double.out_dir, folder, ignore=shutil.ignore_patterns("lib", "build"))
    assert not (folder / "osqp" / "lib").exists()
    res = subprocess.run(["make", "-C", str(folder), "lib"], capture_output=True, text=True)
    assert res.returncode != 0
    err = [ln for ln in res.stderr.splitlines() if "***" in ln]
    assert len(err) == 1 and "osqp/lib/src/" in err[0] and "fcgen build ." in err[0]
    if shutil.which("cmake"):
        res = subprocess.run(["cmake", "-S", str(folder), "-B", str(tmp_path / "cm")], capture_output=True, text=True)
        msg = " ".join(res.stderr.split())  # CMake wraps its messages
        assert res.returncode != 0 and "missing in osqp/lib/src/: restore them with `fcgen build" in msg


@needs_toolchain
@pytest.mark.skipif(shutil.which("cmake") is None, reason="needs cmake")
def test_cmake_toolchain_file_cross_build(gen_double, tmp_path) -> None:
    src = gen_double.out_dir
    bdir = tmp_path / "cmake-m7"
    subprocess.run(
        [
            "cmake",
            "-S",
            str(src),
            "-B",
            str(bdir),
            f"-DCMAKE_TOOLCHAIN_FILE={src / 'cmake' / 'arm-none-eabi-cortex-m7.cmake'}",
        ],
        capture_output=True,
        text=True,
        check=True,
    )
    cache = (bdir / "CMakeCache.txt").read_text()
    assert re.search(r"^CMAKE_C_FLAGS:STRING=-O2 -mcpu=cortex-m7 -mthumb -mfloat-abi=hard -mfpu=fpv5-d16$", cache, re.M)
    assert "TRUCK_LIFT_EL_HOST:BOOL=OFF" in cache
    subprocess.run(["cmake", "--build", str(bdir), "-j2"], capture_output=True, text=True, check=True)
    built = sorted(p.name for p in bdir.iterdir() if p.suffix in (".a", ".so"))
    assert built == ["libtruck_lift_el.a", "libtruck_lift_el_osqp.a"]
    sizes = subprocess.run(
        ["arm-none-eabi-size", str(bdir / "libtruck_lift_el.a")], capture_output=True, text=True, check=True
    ).stdout
    assert "truck_lift_el_solver.c.obj" in sizes


DOUBLE_ROUTINE = re.compile(r"__aeabi_(?:d[a-z0-9]+|[a-z0-9]+2d)|__[a-z]+df[a-z0-9]*")
"""The software double-precision routines of the Arm EABI (``__aeabi_dadd``, ``__aeabi_f2d``, ``__aeabi_i2d``, ...) and
libgcc's generic names (``__adddf3``, ``__extendsfdf2``)."""


def _undefined_symbols(libs: list[Path]) -> dict[str, set[str]]:
    """Per ``archive:object``, the symbols it references but does not define (``arm-none-eabi-nm -A -u``)."""
    out = subprocess.run(
        ["arm-none-eabi-nm", "-A", "-u", *map(str, libs)], capture_output=True, text=True, check=True
    ).stdout
    refs: dict[str, set[str]] = {}
    for where, _, sym in (ln.split() for ln in out.splitlines() if " U " in ln):
        refs.setdefault(where.rstrip(":").rsplit("/", 1)[-1], set()).add(sym)
    return refs


@needs_toolchain
@pytest.mark.parametrize(
    "formulation, obstacles, backend", [("lifted", "ellipse", "osqp"), ("conventional", "hyperplane", "ipm")]
)
def test_float_libraries_do_no_double_arithmetic_on_m4f(tmp_path, formulation, obstacles, backend) -> None:
    """--float on the Cortex-M4F (single-precision FPU): neither the solver and model library nor OSQP's references a
    software double routine, and every math call is the float variant (sinf, sqrtf, ...). The conventional IPM
    solver covers the opponent fit's C code. OSQP's sources need -fsingle-precision-constant for it (their unsuffixed
    literals): compiled without it, its library calls double routines again."""
    from dataclasses import replace as dc_replace

    from fcgen.codegen.model_code import C_MATH
    from fcgen.dsl import QpOptions
    from fcgen.presets import paper_problem

    p = paper_problem("car", formulation, obstacles, name=f"car_sp_{backend}")
    p = dc_replace(p, horizon=dc_replace(p.horizon, N=4), qp=QpOptions(backend=backend))
    info = generate(p, tmp_path / "f", use_float=True)
    lib = build(info.out_dir, target="cortex-m4f")
    libs = sorted(lib.parent.glob("*.a"))
    assert [x.name for x in libs] == [f"lib{info.name}.a", *([f"lib{info.name}_osqp.a"] if backend == "osqp" else [])]
    refs = _undefined_symbols(libs)
    assert f"lib{info.name}.a:{info.name}_solver.o" in refs and f"lib{info.name}.a:{info.name}_model.o" in refs
    doubles = {obj: sorted(s for s in syms if DOUBLE_ROUTINE.fullmatch(s)) for obj, syms in refs.items()}
    assert not {k: v for k, v in doubles.items() if v}, doubles
    math_calls = set().union(*refs.values()) & {*C_MATH, *(f"{f}f" for f in C_MATH)}
    assert {"sinf", "cosf", "sqrtf"} <= math_calls and not math_calls & set(C_MATH), sorted(math_calls)
    if backend == "osqp":  # the flag is what it takes: OSQP's library without it does double arithmetic
        tgt = get_target("cortex-m4f")
        subprocess.run(
            [
                "make",
                "-C",
                str(info.out_dir),
                "BUILD=build/no-sp",
                f"CC={tgt.cc}",
                f"CFLAGS={tgt.cflags('-O2')}",
                "QPLIBFLAGS=",
                *tgt.make_variables(),
            ],
            capture_output=True,
            text=True,
            check=True,
        )
        plain = _undefined_symbols([info.out_dir / "build/no-sp" / f"lib{info.name}_osqp.a"])
        assert any(DOUBLE_ROUTINE.fullmatch(s) for s in plain[f"lib{info.name}_osqp.a:auxil.o"])


# ----------------------------------------------------------------------------- closed loop under QEMU


def _close(log_t, log_h, atol_state: float, same_qp: bool = True) -> None:
    d = compare(log_t, log_h)
    print("target vs host, max abs differences:", {k: v for k, v in d.items() if not k.startswith("time")})
    assert log_t.n_controls == SAMPLES
    assert d["ego_frenet"] <= atol_state and d["ego_cartesian"] <= atol_state
    if same_qp:
        assert np.array_equal(log_t.qp_iter, log_h.qp_iter) and np.array_equal(log_t.qp_status, log_h.qp_status)
    assert np.array_equal(log_t.collision, log_h.collision) and not log_t.collision.any()
    assert log_t.meta["extra"]["exit_codes_nonzero"] == 0


@needs_toolchain
def test_closed_loop_double_on_m7_matches_host(gen_double, tmp_path) -> None:
    d = gen_double.out_dir
    log_t = firmware_sim(d, "truck", SEED, SAMPLES, tmp_path / "m7.json", target="cortex-m7", timeout=300)
    log_h = firmware_sim(d, "truck", SEED, SAMPLES, tmp_path / "host.json")
    _close(log_t, log_h, 1e-6)
    assert log_t.meta["precision"] == "double" and log_t.meta["extra"]["target"] == "cortex-m7"
    reg = CliRunner().invoke(
        main, ["regress", str(tmp_path / "m7.json"), str(tmp_path / "host.json"), "--preset", "host-vs-target"]
    )
    assert reg.exit_code == 0 and "PASS" in reg.output, reg.output
    # the image ran with the solver, the C library and the stack in 512 KiB of RAM (the harness's buffers elsewhere)
    image = build_dir(d, target="cortex-m7") / "firmware_sim" / "closed_loop.elf"
    sec = {
        ln.split()[0]: (int(ln.split()[1]), int(ln.split()[2]))
        for ln in subprocess.run(
            ["arm-none-eabi-size", "-A", str(image)], capture_output=True, text=True, check=True
        ).stdout.splitlines()
        if ln.startswith(".")
    }
    ram = [v for k, v in sec.items() if 0x20000000 <= v[1] < 0x20000000 + 512 * 1024]
    assert {".data", ".bss"} <= {k for k, v in sec.items() if v in ram}
    assert sum(size for size, _ in ram) + 16 * 1024 <= 512 * 1024
    assert sec[".fs_harness"][1] == 0x60000000
    # the solver's timing hook on the core reads SysTick: under -icount shift=0 a deterministic instruction count
    assert np.all(log_t.time_prepare > 1e-4) and np.all(log_t.time_feedback > log_t.time_prepare)
    # a shorter run of the same seed: the same counts up to one SysTick period (40 instructions = 40 ns: the tick's
    # phase differs, as the shorter data file takes fewer instructions to read)
    again = firmware_sim(d, "truck", SEED, 4, tmp_path / "m7b.json", target="cortex-m7", timeout=300)
    np.testing.assert_allclose(again.time_prepare, log_t.time_prepare[:4], rtol=0, atol=40.5e-9)
    np.testing.assert_allclose(again.time_feedback, log_t.time_feedback[:4], rtol=0, atol=40.5e-9)


@needs_toolchain
def test_perturbed_closed_loop_on_m7_matches_host(gen_double, tmp_path) -> None:
    """Latency (2 samples), steering lag and the seeded measurement noise run in the bare-metal image as on the host
    (the errors come in the scenario file); a CommonRoad plant, stepped by the host, is refused for the target."""
    from fcgen.sim.plants import DEFAULT_NOISE, PlantSpec

    d = gen_double.out_dir
    spec = PlantSpec(latency=2, steer_lag=0.1, noise=DEFAULT_NOISE)
    log_t = firmware_sim(d, "truck", SEED, SAMPLES, tmp_path / "m7.json", target="cortex-m7", timeout=300, plant=spec)
    log_h = firmware_sim(d, "truck", SEED, SAMPLES, tmp_path / "host.json", plant=spec)
    diff = compare(log_t, log_h)
    assert diff["ego_frenet"] <= 1e-6 and diff["control"] <= 1e-5 and diff["control_applied"] <= 1e-5, diff
    assert np.array_equal(log_t.qp_iter, log_h.qp_iter) and np.array_equal(log_t.qp_status, log_h.qp_status)
    assert log_t.meta["extra"]["exit_codes_nonzero"] == log_h.meta["extra"]["exit_codes_nonzero"]
    assert log_t.meta["extra"]["plant"] == spec.as_meta() == log_h.meta["extra"]["plant"]
    with pytest.raises(HarnessError, match="--plant st: the host steps the plant in lockstep"):
        firmware_sim(d, "truck", SEED, 2, tmp_path / "st.json", target="cortex-m7", plant=PlantSpec(kind="st"))


@needs_toolchain
def test_closed_loop_float_on_m4f_matches_host(gen_float, tmp_path) -> None:
    d = gen_float.out_dir
    log_t = firmware_sim(d, "truck", SEED, SAMPLES, tmp_path / "m4f.json", target="cortex-m4f", timeout=300)
    log_h = firmware_sim(d, "truck", SEED, SAMPLES, tmp_path / "host.json")
    # single precision: newlib's and glibc's sinf/cosf/... differ in the last bit. With OSQP's sigma = 1e-6 in float
    # (unstable KKT factorization, FLOAT_SIGMA_MIN) the cold-started first QP then stopped at another termination
    # check (160 vs 280 iterations) and the runs drifted apart by 0.1 m; with sigma = 1e-3 the QP iterations and
    # statuses are identical and the states differ by 2.4e-4 m over these 25 samples. The per-sample drift stays below
    # 3e-5 m up to sample 13; there a QP amplifies the two libraries' last bits (controls 1 N apart, then up to 38 N
    # at sample 18): 3.6e-4 m before the opponents' shapes became run-time data, 8.3e-3 m since (the same calls,
    # other float roundings; QP iterations and statuses still identical).
    _close(log_t, log_h, 1e-2, same_qp=True)
    assert np.array_equal(log_t.ego_frenet[0], log_h.ego_frenet[0])
    np.testing.assert_allclose(log_t.ego_frenet[-1, 0], log_h.ego_frenet[-1, 0], rtol=0, atol=1e-2)  # progress


@needs_toolchain
def test_firmware_sim_cli_target(gen_double, tmp_path) -> None:
    out = tmp_path / "run.json"
    res = CliRunner().invoke(
        main,
        [
            "firmware-sim",
            str(gen_double.out_dir),
            "--target",
            "cortex-m7",
            "--samples",
            "3",
            "--seed",
            "1",
            "--out",
            str(out),
            "--compare-host",
        ],
    )
    assert res.exit_code == 0, res.output
    assert "C firmware_sim on cortex-m7" in res.output and "cortex-m7 vs host" in res.output
    assert out.is_file() and (tmp_path / "run.host.json").is_file()


@needs_toolchain
def test_bench_target_instruction_counts(gen_double, tmp_path) -> None:
    res = bench_target(gen_double.out_dir, "cortex-m7", samples=4, timeout=300)
    ins = res["instructions"]
    assert res["granularity_instructions"] == 40.0
    for phase in ("prepare", "feedback"):
        assert 0 < ins[phase]["median"] <= ins[phase]["max"]
        assert ins[phase]["max"] % 40 == 0 and ins[phase]["min"] % 40 == 0  # whole SysTick periods
    assert ins["feedback"]["median"] > ins["prepare"]["median"]
    out = tmp_path / "b.json"
    cli = CliRunner().invoke(
        main, ["bench", str(gen_double.out_dir), "--target", "cortex-m7", "--samples", "4", "--out", str(out)]
    )
    assert cli.exit_code == 0, cli.output
    assert re.search(r"^prepare +[\d.]+ +[\d.]+", cli.output, re.M) and out.is_file()
    import json

    assert json.loads(out.read_text())["instructions"] == ins  # the same counts again: independent of load


# ----------------------------------------------------------------------------- the IPM backend: no extra library


@pytest.fixture(scope="module")
def gen_ipm(tmp_path_factory) -> GenerateInfo:
    from dataclasses import replace

    from fcgen.dsl import QpOptions

    return generate(replace(preset(PRESET), qp=QpOptions(backend="ipm")), tmp_path_factory.mktemp("tgt") / "ipm")


@needs_toolchain
def test_ipm_folder_builds_one_library_and_runs_on_m7(gen_ipm, tmp_path) -> None:
    """An IPM folder: lib<name>.a alone (host: + .so, example; no empty OSQP library), its build files never name
    OSQP; the closed loop on the Cortex-M7 under QEMU computes what the host computes; footprint and bench run."""
    d, name = gen_ipm.out_dir, gen_ipm.name
    for f in ("Makefile", "CMakeLists.txt", "README.md"):
        assert "osqp" not in (d / f).read_text().lower(), f
    host = build(d).parent
    assert sorted(p.name for p in host.iterdir() if p.is_file() and p.name != "flags.txt") == [
        f"lib{name}.a",
        f"lib{name}.so",
        f"{name}_example",
    ]
    lib = build(d, target="cortex-m7")
    assert sorted(p.name for p in lib.parent.iterdir() if p.is_file() and p.name != "flags.txt") == [f"lib{name}.a"]
    log_t = firmware_sim(d, "truck", SEED, SAMPLES, tmp_path / "m7.json", target="cortex-m7", timeout=300)
    log_h = firmware_sim(d, "truck", SEED, SAMPLES, tmp_path / "host.json")
    _close(log_t, log_h, 1e-6)
    assert set(log_t.qp_status) == {1}  # every QP solved
    res = CliRunner().invoke(
        main, ["firmware-sim", str(d), "--target", "cortex-m7", "--samples", "2", "--out", str(tmp_path / "cli.json")]
    )
    assert res.exit_code == 0 and "C firmware_sim on cortex-m7" in res.output, res.output
    fp = footprint(d, "cortex-m7")
    assert [r["object"] for r in fp["objects"]] == [f"{name}_model.o", f"{name}_solver.o"]
    solver = next(r for r in fp["objects"] if r["object"] == f"{name}_solver.o")
    assert abs(solver["bss"] - gen_ipm.workspace_bytes) < 256  # solver + IPM workspaces, all our .bss
    assert fp["stack"]["worst_bytes"] > 0 and "osqp" not in fp["stack"]["indirect_targets"]


# ----------------------------------------------------------------------------- footprint


@needs_toolchain
def test_footprint_matches_size_tool(gen_double) -> None:
    res = footprint(gen_double.out_dir, "cortex-m7")
    obj_dir = build_dir(gen_double.out_dir, target="cortex-m7", variant="footprint") / "obj"
    objs = [obj_dir / r["object"] for r in res["objects"]]
    out = subprocess.run(
        ["arm-none-eabi-size", "-B", *map(str, objs)], capture_output=True, text=True, check=True
    ).stdout.splitlines()[1:]
    for line, r in zip(out, res["objects"]):
        text, data, bss = (int(x) for x in line.split()[:3])
        assert (text, data, bss) == (r["text"] + r["rodata"], r["data"], r["bss"]), r["object"]
    tot = res["total"]
    assert tot["ram"] == sum(r["data"] + r["bss"] for r in res["objects"])
    assert tot["flash"] == sum(r["text"] + r["rodata"] + r["data"] for r in res["objects"])
    # the solver's workspace is its .bss: at least the struct size the generator computed for LP64 minus pointers
    solver = next(r for r in res["objects"] if r["object"] == "truck_lift_el_solver.o")
    assert abs(solver["bss"] - gen_double.solver_workspace_bytes) < 256
    st = res["stack"]
    assert st["worst_chain"][0] == st["worst_entry"] and st["worst_bytes"] > 0
    assert any(f.endswith("solve_linsys_qdldl") for f in st["indirect_targets"]["osqp"])
    assert "truck_lift_el_stage_middle" in st["indirect_targets"]["solver"]
    # the chain's sum equals its frames from GCC's .su files (independent of the call-graph parse)
    frames = {}
    for su in obj_dir.rglob("*.su"):
        for ln in su.read_text().splitlines():
            loc, size, _ = ln.split("\t")
            frames[loc.rsplit(":", 1)[-1]] = int(size)
    assert st["worst_bytes"] == sum(frames[f.split(":")[-1]] for f in st["worst_chain"])


def test_section_sizes_host_object(tmp_path) -> None:
    """The ELF reader on a host object: sizes as binutils' size reports them."""
    if shutil.which("gcc") is None or shutil.which("size") is None:
        pytest.skip("needs gcc and size")
    c = tmp_path / "x.c"
    c.write_text(
        "static int a[100]; int b[3] = {1, 2, 3}; const double k[5] = {1, 2, 3, 4, 5};\n"
        "int f(int i) { a[i] = i; return a[i / 2] + b[i % 3] + (int)k[i % 5]; }\n"
    )
    subprocess.run(["gcc", "-O2", "-c", str(c), "-o", str(tmp_path / "x.o")], check=True)
    s = section_sizes(tmp_path / "x.o")
    assert s["bss"] == 400 and s["data"] == 12 and s["rodata"] >= 40
    text, data, bss = (
        int(x)
        for x in subprocess.run(["size", "-B", str(tmp_path / "x.o")], capture_output=True, text=True, check=True)
        .stdout.splitlines()[1]
        .split()[:3]
    )
    assert (data, bss) == (s["data"], s["bss"]) and text >= s["text"] + s["rodata"]


# ----------------------------------------------------------------------------- two solvers in one firmware image

TWO_SOLVERS_C = Path(__file__).parent / "c" / "two_solvers.c"


@needs_toolchain
def test_two_solvers_one_image_on_m7(gen_double, tmp_path) -> None:
    """A double and a float solver (prefixed OSQP each) linked into one Cortex-M7 image run under QEMU: each computes
    there exactly what it computes in an image of its own."""
    from fcgen.presets import paper_problem
    from fcgen.sim.harness import harness_source_dir

    other = generate(paper_problem("car", "direct_elimination", "ellipse"), tmp_path / "car", use_float=True)
    tgt = get_target("cortex-m7")
    libs = {}
    for g in (gen_double, other):
        lib = build(g.out_dir, target=tgt.name)
        libs[g.name] = [str(lib), str(lib.parent / f"lib{g.name}_osqp.a")]
        nm = subprocess.run(
            ["arm-none-eabi-nm", "-g", "--defined-only", *libs[g.name]], capture_output=True, text=True, check=True
        ).stdout
        syms = [f[2] for f in (ln.split() for ln in nm.splitlines()) if len(f) == 3]
        assert syms and all(s.startswith(f"{g.name}_") for s in syms)
    # two solvers need the RAM of both (~0.7 MB): link with the board's whole 4 MiB data SSRAM
    from dataclasses import replace

    from fcgen.targets import Region

    ld = tmp_path / "m7.ld"
    ld.write_text(linker_script(replace(tgt, ram=Region(0x20000000, 4 * 1024 * 1024))))
    fw = harness_source_dir()
    runs = {}
    for tag, solvers in (("both", {"A": gen_double, "B": other}), ("a", {"A": gen_double}), ("b", {"B": other})):
        defs = [
            d for ab, g in solvers.items() for d in (f"-DSOLVER_{ab}={g.name}", f"-DSOLVER_{ab}_UP={g.name.upper()}")
        ]
        image = tmp_path / f"two_{tag}.elf"
        subprocess.run(
            [
                tgt.cc,
                "-O2",
                "-std=c99",
                "-Wall",
                "-Wextra",
                "-Werror",
                *tgt.cpu_flags,
                *defs,
                f"-DFS_SYSTICK_HZ={tgt.systick_hz}",
                f"-I{fw}",
                *(f"-I{g.out_dir}" for g in solvers.values()),
                str(TWO_SOLVERS_C),
                str(fw / "fs_baremetal.c"),
                *(x for g in solvers.values() for x in libs[g.name]),
                "-lm",
                "-T",
                str(ld),
                *tgt.link_flags,
                "-o",
                str(image),
            ],
            check=True,
            capture_output=True,
            text=True,
        )
        res = subprocess.run(
            tgt.qemu_command(image, [], icount=False), capture_output=True, text=True, timeout=120, cwd=tmp_path
        )
        assert res.returncode == 0, res.stdout + res.stderr
        runs[tag] = res.stdout.splitlines()
    assert runs["both"] == runs["a"] + runs["b"] and len(runs["both"]) == 6
    assert {ln.split()[0] for ln in runs["both"]} == {gen_double.name, other.name}
    assert all(ln.split()[2] == "0" for ln in runs["both"])
    # the solver ran: the samples' u0 differ (a drive force at its bound repeats: compare both inputs)
    assert len({tuple(ln.split()[3:5]) for ln in runs["a"]}) == 3, runs["a"]


@needs_toolchain
def test_footprint_cli_json_and_readme(gen_double, tmp_path) -> None:
    import json

    folder = tmp_path / "copy"
    shutil.copytree(gen_double.out_dir, folder, ignore=shutil.ignore_patterns("build"))
    out = tmp_path / "fp.json"
    res = CliRunner().invoke(main, ["footprint", str(folder), "--target", "cortex-m7", "--out", str(out), "--readme"])
    assert res.exit_code == 0, res.output
    data = json.loads(out.read_text())
    t = data["total"]
    assert re.search(
        rf"^total +{t['text']} +{t['rodata']} +{t['data']} +{t['bss']} +{t['flash']} +{t['ram']}$", res.output, re.M
    )
    readme = (folder / "README.md").read_text()
    assert f"flash {t['flash']} bytes" in readme and f"RAM {t['ram']} bytes" in readme
    assert f"worst stack {data['stack']['worst_bytes']:.0f} bytes" in readme and "Not measured yet" not in readme


@needs_toolchain
def test_clock_hook_counts_instructions(tmp_path) -> None:
    """Under -icount shift=0 the clock hook's time x 1e9 is the number of instructions executed: a loop of 2 x 10^6
    instructions (`subs; bne` written in assembly) measures 2 x 10^6, up to the hook's own call and one SysTick
    period (40 instructions)."""
    from fcgen.sim.harness import harness_source_dir

    for name in ("cortex-m7", "cortex-m4f"):
        tgt = get_target(name)
        ld = tmp_path / f"{name}.ld"
        ld.write_text(linker_script(tgt))
        fw = harness_source_dir()
        image = tmp_path / f"probe_{name}.elf"
        subprocess.run(
            [
                tgt.cc,
                "-O2",
                "-std=c99",
                "-Wall",
                "-Wextra",
                "-Werror",
                *tgt.cpu_flags,
                "-DFS_BAREMETAL",
                f"-DFS_SYSTICK_HZ={tgt.systick_hz}",
                f"-I{fw}",
                str(Path(__file__).parent / "c" / "icount_probe.c"),
                str(fw / "fs_baremetal.c"),
                "-T",
                str(ld),
                *tgt.link_flags,
                "-o",
                str(image),
            ],
            check=True,
            capture_output=True,
            text=True,
        )
        res = subprocess.run(tgt.qemu_command(image, []), capture_output=True, text=True, timeout=60, cwd=tmp_path)
        assert res.returncode == 0, res.stdout + res.stderr
        n, measured = (float(x) for x in res.stdout.split())
        assert abs(measured - 2 * n) <= 200, (name, measured)
