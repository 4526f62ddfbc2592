"""Compilation targets as data: the host and the emulated Cortex-M boards.

A :class:`Target` holds everything a command needs to build and run for it: compiler and binutils, CPU/FPU flags,
whether it can run a double-precision solver, the QEMU machine that emulates it, the memory map of the linker
script (rendered by ``fcgen.sim.harness.linker_script``), the link flags of the bare-metal harness (startup,
semihosting) and the tick rate of its SysTick under QEMU.
``build``, ``firmware-sim``, ``bench`` and ``footprint`` take a target name, look it up here and use its fields;
none of them branches on a target name.
"""

from __future__ import annotations

import shutil
from dataclasses import dataclass
from pathlib import Path


class TargetError(ValueError):
    """A target cannot do what was asked (unknown name, double solver without a double FPU, missing tool)."""


@dataclass(frozen=True)
class Region:
    """A memory region of the linker script."""

    origin: int
    length: int


@dataclass(frozen=True)
class Target:
    """One compilation target (see the module docstring)."""

    name: str
    description: str
    cc: str | None  # None: $CC or cc (the host)
    ar: str | None
    cpu_flags: tuple[str, ...]  # -mcpu/-mthumb/-mfloat-abi/-mfpu
    fpu: str  # a human-readable description
    double_fpu: bool  # double arithmetic in hardware: double solvers allowed
    bare_metal: bool  # no OS: static libraries only, harness with our startup + semihosting
    qemu_machine: str | None = None
    qemu_cpu: str | None = None
    flash: Region | None = None
    ram: Region | None = None  # on-chip RAM as an ECU has it: solver, C library, heap, stack
    xram: Region | None = None  # the board's external RAM: the harness's own buffers
    systick_hz: int = 0  # SysTick clock under QEMU (with -icount shift=0: 1 instruction per ns)
    binutils_prefix: str = ""  # arm-none-eabi- for size/nm/objdump
    link_flags: tuple[str, ...] = ()  # the bare-metal harness image: semihosting libc, our startup
    harness_defines: tuple[str, ...] = ()  # extra -D flags of the harness image
    platform: str = "host"  # the harness's platform file firmware_sim/fs_<platform>.c (startup, clock)
    linker_template: str = ""  # templates/ file of the image's linker script

    # -- precision ----------------------------------------------------------------------------------------------
    def check_precision(self, use_float: bool) -> None:
        """Refuse a double-precision solver on a single-precision FPU (one line: what to do instead)."""
        if not use_float and not self.double_fpu:
            ok = ", ".join(t.name for t in TARGETS.values() if t.double_fpu)
            raise TargetError(
                f"--target {self.name}: its FPU ({self.fpu}) has no double precision; generate the "
                f"solver with --float, or use a target with a double FPU: {ok}"
            )

    # -- build ---------------------------------------------------------------------------------------------------
    @property
    def build_subdir(self) -> str:
        """The solver folder's build directory for this target (relative)."""
        return "build" if not self.bare_metal else f"build/{self.name}"

    def cflags(self, base: str = "-O2") -> str:
        return " ".join([base, *self.cpu_flags]).strip()

    def make_variables(self) -> list[str]:
        """Make variables of the solver library build (``lib`` goal, no -fPIC) for a bare-metal target (CC and
        CFLAGS are passed separately: ``cc`` and ``cflags()``)."""
        if not self.bare_metal:
            return []
        return [f"AR={self.ar}", "PICFLAGS=", "lib"]

    def tool(self, name: str) -> str:
        """A binutils program of the target (``size``, ``nm``, ``objdump``); raises if not installed."""
        exe = f"{self.binutils_prefix}{name}"
        if shutil.which(exe) is None:
            raise TargetError(
                f"--target {self.name}: {exe} not found; install the toolchain (apt-get install {APT_PACKAGES})"
            )
        return exe

    def check_tools(self, qemu: bool = False) -> None:
        """Raise a one-line error naming the missing compiler or emulator."""
        need = [self.cc] if self.cc else []
        if qemu and self.qemu_machine:
            need.append(QEMU)
        for exe in need:
            if shutil.which(exe) is None:
                raise TargetError(
                    f"--target {self.name}: {exe} not found; install the toolchain (apt-get install {APT_PACKAGES})"
                )

    # -- emulation -----------------------------------------------------------------------------------------------
    def qemu_command(self, image: Path | str, args: list[str], icount: bool = True) -> list[str]:
        """The QEMU command that runs a semihosting image; ``args`` become its argv[1:]."""
        if not self.qemu_machine:
            raise TargetError(f"--target {self.name}: not an emulated target")
        sh = ",".join(["enable=on", "target=native", *(f"arg={a}" for a in [Path(image).name, *args])])
        cmd = [
            QEMU,
            "-M",
            self.qemu_machine,
            *(["-cpu", self.qemu_cpu] if self.qemu_cpu else []),
            "-nographic",
            "-monitor",
            "none",
            "-serial",
            "none",
            "-semihosting-config",
            sh,
            "-kernel",
            str(image),
        ]
        return cmd + (["-icount", "shift=0"] if icount else [])

    @property
    def instructions_per_second(self) -> float:
        """Instructions per second of the clock hook's time under ``-icount shift=0`` (one instruction per ns)."""
        return 1e9

    @property
    def harness_executable(self) -> str:
        """The file name firmware_sim/Makefile gives the harness for this target's platform."""
        return "closed_loop.elf" if self.bare_metal else "closed_loop"

    def harness_make_variables(self, linker_script: Path) -> list[str]:
        """Make variables of firmware_sim/ for the bare-metal image."""
        defs = ["-DFS_BAREMETAL", *self.harness_defines, f"-DFS_SYSTICK_HZ={self.systick_hz}"]
        return [
            f"PLATFORM={self.platform}",
            f"TARGET_FLAGS={' '.join(self.cpu_flags)}",
            f"LDSCRIPT={linker_script}",
            f"PLATFORM_LDFLAGS={' '.join(self.link_flags)}",
            f"PLATFORM_DEFS={' '.join(defs)}",
        ]


QEMU: str = "qemu-system-arm"
README_BEGIN = "<!-- fcgen footprint: begin -->"
README_END = "<!-- fcgen footprint: end -->"
"""Markers of the generated README's footprint line (``fcgen footprint --readme`` fills it)."""
APT_PACKAGES = "gcc-arm-none-eabi libnewlib-arm-none-eabi qemu-system-arm"

# The mps2 boards as QEMU maps them: ZBT SSRAM1 (4 MiB, code) at 0, ZBT SSRAM2/3 (4 MiB) at 0x20000000, of which the
# image uses the first 512 KiB as the on-chip RAM of an ECU-sized part; 16 MiB PSRAM at 0x60000000 (AN500) or
# 0x21000000 (AN386) for the harness's buffers.
_MPS2_FLASH = Region(0x00000000, 4 * 1024 * 1024)
_MPS2_RAM = Region(0x20000000, 512 * 1024)
HARNESS_STACK = 16 * 1024
"""Stack reserved in the RAM region (the solver's worst chain is ~1.2 KiB; newlib's printf/strtod a few KiB)."""
_SEMIHOSTING = ("--specs=rdimon.specs", "-nostartfiles")
_CORTEXM_LD = "targets/cortexm.ld.j2"

TARGETS: dict[str, Target] = {
    t.name: t
    for t in (
        Target(
            "host",
            "the build machine (shared library + static libraries + example)",
            None,
            None,
            (),
            "host",
            True,
            False,
        ),
        Target(
            "cortex-m7",
            "Arm Cortex-M7 with double-precision FPU (QEMU mps2-an500)",
            "arm-none-eabi-gcc",
            "arm-none-eabi-ar",
            ("-mcpu=cortex-m7", "-mthumb", "-mfloat-abi=hard", "-mfpu=fpv5-d16"),
            "fpv5-d16, single + double",
            True,
            True,
            "mps2-an500",
            "cortex-m7",
            _MPS2_FLASH,
            _MPS2_RAM,
            Region(0x60000000, 16 * 1024 * 1024),
            25_000_000,
            "arm-none-eabi-",
            _SEMIHOSTING,
            (),
            "baremetal",
            _CORTEXM_LD,
        ),
        Target(
            "cortex-m4f",
            "Arm Cortex-M4F with single-precision FPU (QEMU mps2-an386)",
            "arm-none-eabi-gcc",
            "arm-none-eabi-ar",
            ("-mcpu=cortex-m4", "-mthumb", "-mfloat-abi=hard", "-mfpu=fpv4-sp-d16"),
            "fpv4-sp-d16, single only",
            False,
            True,
            "mps2-an386",
            "cortex-m4",
            _MPS2_FLASH,
            _MPS2_RAM,
            Region(0x21000000, 16 * 1024 * 1024),
            25_000_000,
            "arm-none-eabi-",
            _SEMIHOSTING,
            (),
            "baremetal",
            _CORTEXM_LD,
        ),
    )
}


def get_target(name: str) -> Target:
    """The target of that name; a one-line error listing the allowed names otherwise."""
    try:
        return TARGETS[name]
    except KeyError:
        raise TargetError(f"--target: {name!r} is invalid: allowed {', '.join(TARGETS)}") from None


def cross_targets(use_float: bool) -> list[Target]:
    """The bare-metal targets that can run a solver of this precision."""
    return [t for t in TARGETS.values() if t.bare_metal and (use_float or t.double_fpu)]
