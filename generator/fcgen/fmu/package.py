"""``fcgen fmu``: a generated solver folder packaged as a co-simulation FMU (FMI 3.0 or 2.0).

The FMU holds ``modelDescription.xml``, the sources (the solver folder's C and the wrapper fcgen renders from
``templates/fmu/``: one core, two thin FMI layers), a binary for this platform built from them, and the folder's
README under ``documentation/``. The FMI headers come from the installed ``fmpy`` package.
"""

from __future__ import annotations

import re
import shutil
import subprocess
import tempfile
import uuid
import zipfile
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from xml.sax.saxutils import escape

import numpy as np

from .. import __version__
from ..build import build
from ..codegen.render import render_template
from ..contract import EXIT_CODES
from ..extras import require
from ..reference import QP_EXIT
from ..solver_folder import FolderLike, SolverFolder, as_folder

PLATFORM = {3: "x86_64-linux", 2: "linux64"}
"""The folder of this platform's binary under ``binaries/`` (FMI 3.0 and 2.0 name it differently)."""
FMI_VERSIONS = (3, 2)


class FmuError(ValueError):
    """An FMU that cannot be built or driven (one line)."""


@dataclass(frozen=True)
class Var:
    """One FMU variable: an array (``dims``) or a scalar of Float64 or Int32."""

    name: str
    type: str  # "Float64" or "Int32"
    input: bool
    dims: tuple[int, ...]
    doc: str

    @property
    def count(self) -> int:
        return int(np.prod(self.dims)) if self.dims else 1


def fmi_headers() -> Path:
    """The folder of FMI's C headers shipped inside the installed fmpy package."""
    with require("fmu", "fcgen fmu"):
        import fmpy
    return Path(fmpy.__file__).parent / "c-code"


def variables(sizes: dict[str, int]) -> list[Var]:
    """The FMU's variables, in value-reference order (FMI 3.0: variable i has value reference i + 1)."""
    N, NX, NU, RM = sizes["N"], sizes["NX"], sizes["NU"], sizes["ROAD_MAX"]
    opp = (N + 1, sizes["NOPP"], sizes["NOPP_PAR"])
    return [
        Var("state", "Float64", True, (5,), "measured Frenet state [s, n, alpha, v, delta] (m, m, rad, m/s, rad)"),
        Var("road_s0", "Float64", True, (), "arc length of the first road sample (m)"),
        Var("road_ds", "Float64", True, (), "road sample spacing (m)"),
        Var("road_n", "Int32", True, (), f"road samples used, 2..{RM}"),
        Var("road_kappa", "Float64", True, (RM,), "curvature at each sample (1/m)"),
        Var("road_phi", "Float64", True, (RM,), "heading of the reference path at each sample (rad)"),
        Var("road_x", "Float64", True, (RM,), "x of the reference path at each sample (m)"),
        Var("road_y", "Float64", True, (RM,), "y of the reference path at each sample (m)"),
        Var(
            "opponents",
            "Float64",
            True,
            opp,
            "opponents' predicted rear-axle poses [x, y, phi] per stage 0..N, row-major as set_opponents (m, m, rad)",
        ),
        Var("u0", "Float64", False, (2,), "control to apply [F_d, r] (N, rad/s), inside the input box"),
        Var("exit_code", "Int32", False, (), "the solver's exit code of the step (0: OK)"),
        Var("qp_status", "Int32", False, (), "generic QP status (1 solved, 2 solved inaccurate, 3 max iter, ...)"),
        Var("qp_iter", "Int32", False, (), "QP iterations of the step"),
        Var("u_projected", "Int32", False, (), "1: u0 is the plan's u0 projected on the input box"),
        Var("max_slack", "Float64", False, (), "largest soft-constraint slack of the plan"),
        Var("states", "Float64", False, (N + 1, NX), "planned states, stages 0..N"),
        Var("controls", "Float64", False, (N, NU), "planned controls, stages 0..N-1"),
        Var("time_prepare", "Float64", False, (), "time of the preparation phase (s, host clock)"),
        Var("time_feedback", "Float64", False, (), "time of the feedback phase (s, host clock)"),
        Var(
            "plan_clearance",
            "Float64",
            False,
            (),
            "the plan's smallest clearance to an opponent's true rectangle "
            "over stages 0..N (m; < 0: overlapping; +inf without opponents)",
        ),
        Var("plan_clearance_stage", "Int32", False, (), "the stage of plan_clearance (-1: no opponent)"),
        Var("plan_reaction", "Int32", False, (), "1: the plan check braked (u0 is the braking control)"),
        Var(
            "a_lat_guard",
            "Int32",
            False,
            (),
            "1: the a_lat guard set u0's steering rate, 2: it braked too, 3: it limited the drive force only",
        ),
    ]


def fmi2_bases(vs: list[Var]) -> list[int]:
    """FMI 2.0 value reference of each variable's first element (1-based, elements consecutive), and one past."""
    out, vr = [], 1
    for v in vs:
        out.append(vr)
        vr += v.count
    return [*out, vr]


def _named(name: str) -> Callable[[re.Match], str]:
    """re.sub's replacement that puts ``name`` before a parameter's array brackets (if any)."""
    return lambda m: f" {name}" + (m.group(1) or "")


def _c_stubs(header: Path, prefix: str, implemented: set[str]) -> str:
    """C definitions of the functions an FMI function-types header declares and this FMU does not offer: each
    returns the error status (NULL for an instance, nothing for void)."""
    text = re.sub(r"/\*.*?\*/", "", header.read_text(), flags=re.S)
    out = []
    for ret, name, params in re.findall(r"typedef\s+([\w*]+\s*\**)\s*(\w+)TYPE\s*\(([^;]*?)\)\s*;", text):
        fn, ret = name, ret.strip()
        if fn in implemented or not fn.startswith(prefix):
            continue
        plist = [p.strip() for p in params.replace("\n", " ").split(",") if p.strip() and p.strip() != "void"]
        pnames = []
        for i, p in enumerate(plist):
            m = re.search(r"(\w+)\s*(\[\s*\])?$", p)
            last = m.group(1) if m else ""
            if not last or re.match(r"^(fmi[23][A-Z]\w*|size_t|int|char|double|const)$", last):  # an unnamed parameter
                last = f"p{i}"
                plist[i] = re.sub(r"(\[\s*\])?$", _named(last), p, count=1)
            pnames.append(last)
        body = " ".join(f"(void){n};" for n in pnames if n and n != "...")
        if ret.endswith("Status"):
            val = f" return {prefix}Error;"
        elif ret == "void":
            val = ""
        else:
            val = " return NULL;"
        out.append(f"{ret} {fn}({', '.join(plist) or 'void'}) {{ {body}{val} }}")
    return "\n".join(out) + "\n"


_FMI3_DONE = {
    "fmi3GetVersion",
    "fmi3SetDebugLogging",
    "fmi3InstantiateCoSimulation",
    "fmi3FreeInstance",
    "fmi3EnterInitializationMode",
    "fmi3ExitInitializationMode",
    "fmi3EnterStepMode",
    "fmi3Terminate",
    "fmi3Reset",
    "fmi3GetFloat64",
    "fmi3SetFloat64",
    "fmi3GetInt32",
    "fmi3SetInt32",
    "fmi3DoStep",
}
_FMI2_DONE = {
    "fmi2GetTypesPlatform",
    "fmi2GetVersion",
    "fmi2SetDebugLogging",
    "fmi2Instantiate",
    "fmi2FreeInstance",
    "fmi2SetupExperiment",
    "fmi2EnterInitializationMode",
    "fmi2ExitInitializationMode",
    "fmi2Terminate",
    "fmi2Reset",
    "fmi2GetReal",
    "fmi2SetReal",
    "fmi2GetInteger",
    "fmi2SetInteger",
    "fmi2DoStep",
}


def _start(v: Var, fmi: int) -> str:
    if v.name == "road_ds":
        return "1"
    if v.name == "road_n":
        return "2"
    return "0"


def build_description(name: str, sources: list[str], includes: list[str]) -> str:
    """FMI 3.0's ``sources/buildDescription.xml``: the C files and include folders of the source-code FMU."""
    lines = [
        '<?xml version="1.0" encoding="UTF-8"?>',
        '<fmiBuildDescription fmiVersion="3.0">',
        f'  <BuildConfiguration modelIdentifier="{name}">',
        '    <SourceFileSet language="C99">',
    ]
    lines += [f'      <SourceFile name="{s}"/>' for s in sources]
    lines += [f'      <IncludeDirectory name="{i}"/>' for i in includes]
    lines += ["    </SourceFileSet>", "  </BuildConfiguration>", "</fmiBuildDescription>", ""]
    return "\n".join(lines)


def model_description(
    name: str, dt: float, vs: list[Var], token: str, fmi: int, description: str, sources: Sequence[str] = ()
) -> str:
    """``modelDescription.xml`` of the FMU (no timestamps: the same solver gives the same bytes)."""
    gen = f'generationTool="fcgen {__version__}"'
    if fmi == 3:
        lines = [
            '<?xml version="1.0" encoding="UTF-8"?>',
            f'<fmiModelDescription fmiVersion="3.0" modelName="{name}" instantiationToken="{token}" {gen} '
            f'description="{escape(description)}" variableNamingConvention="structured">',
            f'  <CoSimulation modelIdentifier="{name}" canHandleVariableCommunicationStepSize="false" '
            f'fixedInternalStepSize="{dt!r}" canGetAndSetFMUState="false" canSerializeFMUState="false"/>',
            f'  <DefaultExperiment startTime="0" stepSize="{dt!r}"/>',
            "  <ModelVariables>",
            '    <Float64 name="time" valueReference="0" causality="independent" variability="continuous" '
            'description="communication time (s)"/>',
        ]
        for i, v in enumerate(vs):
            caus = "input" if v.input else "output"
            start = f' start="{" ".join([_start(v, 3)] * v.count)}"' if v.input else ""
            dims = "".join(f'<Dimension start="{d}"/>' for d in v.dims)
            lines.append(
                f'    <{v.type} name="{v.name}" valueReference="{i + 1}" causality="{caus}" '
                f'variability="discrete" description="{escape(v.doc)}"{start}'
                + (f">{dims}</{v.type}>" if dims else "/>")
            )
        lines += ["  </ModelVariables>", "  <ModelStructure>"]
        lines += [f'    <Output valueReference="{i + 1}"/>' for i, v in enumerate(vs) if not v.input]
        lines += [f'    <InitialUnknown valueReference="{i + 1}"/>' for i, v in enumerate(vs) if not v.input]
        lines += ["  </ModelStructure>", "</fmiModelDescription>", ""]
        return "\n".join(lines)
    bases = fmi2_bases(vs)
    lines = [
        '<?xml version="1.0" encoding="UTF-8"?>',
        f'<fmiModelDescription fmiVersion="2.0" modelName="{name}" guid="{token}" {gen} '
        f'description="{escape(description)}" variableNamingConvention="structured" numberOfEventIndicators="0">',
        f'  <CoSimulation modelIdentifier="{name}" canHandleVariableCommunicationStepSize="false" '
        f'canGetAndSetFMUstate="false" canSerializeFMUstate="false">',
        "    <SourceFiles>",
        *[f'      <File name="{s}"/>' for s in sources],
        "    </SourceFiles>",
        "  </CoSimulation>",
        f'  <DefaultExperiment startTime="0" stepSize="{dt!r}"/>',
        "  <ModelVariables>",
    ]
    outputs = []
    index = 0
    for v, base in zip(vs, bases):
        for e, idx in enumerate(np.ndindex(*v.dims) if v.dims else [()]):
            index += 1
            nm = v.name + ("[" + ",".join(str(k + 1) for k in idx) + "]" if idx else "")
            caus = "input" if v.input else "output"
            typ = "Real" if v.type == "Float64" else "Integer"
            start = f' start="{_start(v, 2)}"' if v.input else ""
            lines.append(
                f'    <ScalarVariable name="{nm}" valueReference="{base + e}" causality="{caus}" '
                f'variability="discrete" description="{escape(v.doc)}"><{typ}{start}/></ScalarVariable>'
            )
            if not v.input:
                outputs.append(index)
    lines += ["  </ModelVariables>", "  <ModelStructure>", "    <Outputs>"]
    lines += [f'      <Unknown index="{i}"/>' for i in outputs]
    lines += ["    </Outputs>", "    <InitialUnknowns>"]
    lines += [f'      <Unknown index="{i}"/>' for i in outputs]
    lines += ["    </InitialUnknowns>", "  </ModelStructure>", "</fmiModelDescription>", ""]
    return "\n".join(lines)


def _solver_sources(gen_dir: Path, name: str) -> list[Path]:
    """The C sources the folder's Makefile compiles into its libraries (host parts for the clock included)."""
    mk = (gen_dir / "Makefile").read_text()
    srcs = []
    for var in ("SOLVER_SRC", "MODEL_SRC", "WORKSPACE_SRC", "QPLIB_SRC", "HOST_SRC"):
        m = re.search(rf"^{var} = ((?:.*\\\n)*.*)$", mk, re.M)
        if m:
            srcs += [s for s in m.group(1).replace("\\\n", " ").split() if s.endswith(".c")]
    return [gen_dir / s for s in srcs]


def build_fmu(folder: FolderLike, out: Path | str, fmi: int = 3, cc: str = "cc") -> Path:
    """Package a generated solver folder (a :class:`~.solver_folder.SolverFolder` or its path) as a co-simulation
    FMU at ``out``; returns ``out``."""
    if fmi not in FMI_VERSIONS:
        raise FmuError(f"--fmi {fmi}: allowed 3 or 2")
    out = Path(out)
    if out.suffix != ".fmu":
        raise FmuError(f"-o {out}: allowed a file name ending in .fmu")
    folder = as_folder(folder)
    build(folder)  # restores OSQP's library sources
    vs = variables(folder.sizes)
    token = "{" + str(uuid.uuid5(uuid.NAMESPACE_URL, "fcgen:" + folder.problem_file.read_text())) + "}"
    wrapper = wrapper_sources(folder, vs, token, fmi)
    pb = folder.problem
    desc = (
        f"fcgen NMPC controller {folder.name} ({pb.formulation.kind}, {pb.obstacles.kind}, N = {pb.horizon.N}, "
        f"dt = {pb.horizon.dt} s): one SQP real-time iteration per doStep"
    )
    with tempfile.TemporaryDirectory(prefix=".fcgen-fmu-", dir=out.parent if out.parent.is_dir() else None) as tmp:
        root = Path(tmp) / "fmu"
        all_srcs = _write_sources(folder, root / "sources", wrapper, fmi)
        _compile_binary(folder, root, wrapper, fmi, cc)
        (root / "modelDescription.xml").write_text(
            model_description(folder.name, pb.horizon.dt, vs, token, fmi, desc, sources=all_srcs)
        )
        _write_documents(folder, root)
        tmp_fmu = Path(tmp) / "out.fmu"
        _zip_folder(root, tmp_fmu)
        out.parent.mkdir(parents=True, exist_ok=True)
        shutil.move(str(tmp_fmu), out)
    return out


def wrapper_sources(folder: SolverFolder, vs: list[Var], token: str, fmi: int) -> dict[str, str]:
    """The FMU's own C (file name -> text): the core over the solver's API and the FMI layer of version ``fmi``."""
    name, hdr = folder.name, fmi_headers()
    fallback = sorted({c for c in QP_EXIT.values() if c != "OK"} | {"ERR_QP_INPUT_BOUNDS"})
    ctx = dict(
        name=name,
        NAME=name.upper(),
        dt=repr(folder.problem.horizon.dt),
        token=token,
        exit_codes=EXIT_CODES,
        fallback_codes=fallback,
        variables=[
            dict(
                name=v.name,
                ctype="double" if v.type == "Float64" else "int",
                type="FMU_F64" if v.type == "Float64" else "FMU_I32",
                input=int(v.input),
                count=v.count,
            )
            for v in vs
        ],
    )
    wrapper = {
        "fmu_core.h": render_template("fmu/fmu_core.h.j2", **ctx),
        "fmu_core.c": render_template("fmu/fmu_core.c.j2", **ctx),
    }
    if fmi == 3:
        wrapper["fmi3.c"] = render_template(
            "fmu/fmi3.c.j2", **ctx, stubs=_c_stubs(hdr / "fmi3FunctionTypes.h", "fmi3", _FMI3_DONE)
        )
    else:
        wrapper["fmi2.c"] = render_template(
            "fmu/fmi2.c.j2",
            **ctx,
            bases=", ".join(map(str, fmi2_bases(vs))),
            stubs=_c_stubs(hdr / "fmi2FunctionTypes.h", "fmi2", _FMI2_DONE),
        )
    return wrapper


def _write_sources(folder: SolverFolder, src: Path, wrapper: dict[str, str], fmi: int) -> list[str]:
    """The solver's sources and headers and the wrapper under ``sources/`` (FMI 3.0: with its build description);
    returns the C files, relative to ``sources/``."""
    gen_dir = folder.path
    src.mkdir(parents=True)
    solver_srcs = _solver_sources(gen_dir, folder.name)
    headers = list(gen_dir.glob("*.h")) + list(gen_dir.glob("osqp/**/*.h"))
    for f in solver_srcs + headers:
        dst = src / f.relative_to(gen_dir)
        dst.parent.mkdir(parents=True, exist_ok=True)
        shutil.copy2(f, dst)
    for fname, text in wrapper.items():
        (src / fname).write_text(text)
    all_srcs = [str(f.relative_to(gen_dir)) for f in solver_srcs] + sorted(f for f in wrapper if f.endswith(".c"))
    incs = ["."] + (
        ["osqp", "osqp/lib", "osqp/lib/inc/public", "osqp/lib/inc/private"] if (gen_dir / "osqp").is_dir() else []
    )
    if fmi == 3:
        (src / "buildDescription.xml").write_text(build_description(folder.name, all_srcs, incs))
    return all_srcs


def _compile_binary(folder: SolverFolder, root: Path, wrapper: dict[str, str], fmi: int, cc: str) -> Path:
    """The binary for this platform: the wrapper and the host clock compiled here, the solver from the folder's own
    static libraries (the objects of lib<name>.so: the same code as the C library fcgen's closed loops load)."""
    name, src, lib_dir = folder.name, root / "sources", folder.build_dir()
    libs = [lib_dir / f"lib{name}.a"] + (
        [lib_dir / f"lib{name}_osqp.a"] if (lib_dir / f"lib{name}_osqp.a").is_file() else []
    )
    bindir = root / "binaries" / PLATFORM[fmi]
    bindir.mkdir(parents=True)
    so = bindir / f"{name}.so"
    cmd = [
        cc,
        "-std=c99",
        "-shared",
        "-fPIC",
        "-O2",
        "-Wall",
        "-Wextra",
        "-Werror",
        f"-I{src}",
        f"-I{fmi_headers()}",
        *[str(src / f) for f in wrapper if f.endswith(".c")],
        str(folder.path / f"{name}_host.c"),
        *map(str, libs),
        "-o",
        str(so),
        "-lm",
    ]
    res = subprocess.run(cmd, capture_output=True, text=True)
    if res.returncode != 0:
        raise FmuError(f"compiling the FMU's binary failed:\n{res.stderr[-3000:]}")
    return so


def _write_documents(folder: SolverFolder, root: Path) -> None:
    """``resources/problem.py`` (the problem an FMU user can load) and the folder's README under ``documentation/``."""
    (root / "resources").mkdir()
    shutil.copy2(folder.problem_file, root / "resources" / "problem.py")
    doc = root / "documentation"
    doc.mkdir()
    readme = (folder.path / "README.md").read_text()
    (doc / "README.md").write_text(readme)
    (doc / "index.html").write_text(
        f'<!DOCTYPE html><html><head><meta charset="utf-8"><title>{folder.name}</title>'
        f"</head><body><pre>{escape(readme)}</pre></body></html>\n"
    )


def _zip_folder(root: Path, path: Path) -> None:
    """The FMU archive of ``root``: sorted entries, fixed dates and modes (the same solver gives the same bytes)."""
    with zipfile.ZipFile(path, "w", zipfile.ZIP_DEFLATED) as z:
        for p in sorted(root.rglob("*")):
            if p.is_file():
                info = zipfile.ZipInfo(str(p.relative_to(root)), date_time=(1980, 1, 1, 0, 0, 0))
                info.compress_type = zipfile.ZIP_DEFLATED
                info.external_attr = 0o644 << 16
                z.writestr(info, p.read_bytes())
