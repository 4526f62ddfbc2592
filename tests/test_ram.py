"""Static RAM of truck_lifted_ellipse cross-compiled for a Cortex-M7: .data + .bss of solver, model and OSQP
(lib<name>.a + lib<name>_osqp.a) within an ECU's SRAM: <= 512 KiB in double, <= 256 KiB in float."""
from __future__ import annotations

import shutil
import subprocess
from pathlib import Path

import pytest

from fcgen.codegen.generate import generate
from fcgen.presets import preset

pytestmark = pytest.mark.skipif(any(shutil.which(t) is None for t in ("arm-none-eabi-gcc", "arm-none-eabi-size",
                                                                      "make")),
                                reason="needs arm-none-eabi-gcc (Debian: gcc-arm-none-eabi libnewlib-arm-none-eabi)")

M7_CFLAGS = "-O2 -mcpu=cortex-m7 -mthumb -mfloat-abi=hard -mfpu=fpv5-d16"
LIMIT = {False: 512 * 1024, True: 256 * 1024}


def static_ram(folder: Path, name: str) -> dict[str, int]:
    """.data + .bss per object of the solver's two static libraries built for the M7."""
    subprocess.run(["make", "-C", str(folder), "-j2", "BUILD=build/m7", "CC=arm-none-eabi-gcc", "AR=arm-none-eabi-ar",
                    f"CFLAGS={M7_CFLAGS}", "PICFLAGS=", "lib"], check=True, capture_output=True, text=True)
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
