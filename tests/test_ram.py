"""Static RAM of truck_lifted_ellipse cross-compiled for a Cortex-M7: .data + .bss of solver, model and OSQP
(lib<name>.a + lib<name>_osqp.a) within an ECU's SRAM: <= 512 KiB in double, <= 256 KiB in float."""

from __future__ import annotations

import re
import shutil
import subprocess
from pathlib import Path

import pytest

from fcgen.codegen.generate import generate
from fcgen.presets import preset

pytestmark = pytest.mark.skipif(
    any(shutil.which(t) is None for t in ("arm-none-eabi-gcc", "arm-none-eabi-size", "arm-none-eabi-nm", "make")),
    reason="needs arm-none-eabi-gcc (Debian: gcc-arm-none-eabi libnewlib-arm-none-eabi)",
)

M7_CFLAGS = "-O2 -mcpu=cortex-m7 -mthumb -mfloat-abi=hard -mfpu=fpv5-d16"
LIMIT = {False: 512 * 1024, True: 256 * 1024}


def static_ram(folder: Path, name: str) -> dict[str, int]:
    """.data + .bss per object of the solver's two static libraries built for the M7."""
    subprocess.run(
        [
            "make",
            "-C",
            str(folder),
            "-j2",
            "BUILD=build/m7",
            "CC=arm-none-eabi-gcc",
            "AR=arm-none-eabi-ar",
            f"CFLAGS={M7_CFLAGS}",
            "PICFLAGS=",
            "lib",
        ],
        check=True,
        capture_output=True,
        text=True,
    )
    libs = [str(folder / "build/m7" / f"lib{name}{s}.a") for s in ("", "_osqp")]
    out = subprocess.run(["arm-none-eabi-size", *libs], check=True, capture_output=True, text=True).stdout
    rows = [line.split() for line in out.splitlines()[1:]]
    return {r[5]: int(r[1]) + int(r[2]) for r in rows}


@pytest.mark.parametrize("use_float", [False, True], ids=["double", "float"])
def test_static_ram_fits(use_float: bool, tmp_path: Path) -> None:
    info = generate(preset("truck_lifted_ellipse"), tmp_path / "g", use_float=use_float)
    ram = static_ram(info.out_dir, info.name)
    total = sum(ram.values())
    assert total <= LIMIT[use_float], ram
    # the big parts: our workspace (solver) and OSQP's mutable arrays; everything else is (almost) nothing
    assert ram[f"{info.name}_solver.o"] + ram[f"{info.name}_workspace.o"] > 0.99 * total
    assert ram[f"{info.name}_model.o"] == 0


def test_indices_are_32_bit(tmp_path: Path) -> None:
    """OSQP's and QDLDL's indices (OSQPInt, QDLDL_int) and CasADi's (casadi_int) are 32-bit on the M7: OSQP is
    configured without OSQP_USE_LONG, and the objects' index arrays take 4 bytes per entry."""
    info = generate(preset("truck_lifted_ellipse"), tmp_path / "g")
    assert "OSQP_USE_LONG" not in (info.out_dir / "osqp/lib/osqp_configure.h").read_text()
    ws_c = (info.out_dir / info.qp_files.sources[0]).read_text()
    counts = {m[1]: int(m[2]) for m in re.finditer(r"^(?:const )?(?:OSQPInt|QDLDL_int) (\w+)\[(\d+)\]", ws_c, re.M)}
    assert len(counts) >= 12
    obj = tmp_path / "ws.o"
    subprocess.run(
        [
            "arm-none-eabi-gcc",
            *M7_CFLAGS.split(),
            "-std=c99",
            "-I" + str(info.out_dir / "osqp"),
            *(f"-I{info.out_dir / d}" for d in info.qp_files.include_dirs + info.qp_files.private_include_dirs),
            "-c",
            str(info.out_dir / info.qp_files.sources[0]),
            "-o",
            str(obj),
        ],
        check=True,
        capture_output=True,
        text=True,
    )
    out = subprocess.run(["arm-none-eabi-nm", "-S", str(obj)], check=True, capture_output=True, text=True).stdout
    sizes = {f[3]: int(f[1], 16) for f in (line.split() for line in out.splitlines()) if len(f) == 4}
    assert {name: sizes[name] for name in counts} == {name: 4 * n for name, n in counts.items()}
    assert "casadi_int int" in (info.out_dir / f"{info.name}_model.c").read_text().replace("#define ", "")
