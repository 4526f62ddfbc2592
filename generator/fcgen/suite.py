"""Golden suites (``fcgen record``): the run logs of a compiled solver on a set of seeded scenarios plus a manifest.

A suite is a folder::

    manifest.json                   format "fcgen-suite/1": problem record, build, settings, one entry per log
    <scenario>_seed<seed>.json.xz   one run log (fcgen-runlog/1, xz-compressed) per scenario

The manifest records what produced the logs (generator version, compiler and its version, the exact compile line,
target, precision, QP backend, run-log schema) and a SHA-256 of every log's JSON text, so a damaged or hand-edited
log is refused instead of compared. Written deterministically: with ``timing=False`` (timing fields zeroed, as for
the checked-in goldens) recording an unchanged solver again reproduces the files byte for byte (except
``meta.versions`` when packages change).
"""

from __future__ import annotations

import hashlib
import json
import os
import platform
import re
import subprocess
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np

from .atomic import carry, check_folder_target, describe, staged_folder, write_text
from .build import DEFAULT_BUILD, VERIFY_BUILD, build
from .csolver import CSolver
from .sim.closedloop import PLAN_LEVELS, run_closed_loop
from .sim.plants import PlantSpec, plant_from_meta
from .sim.runlog import FORMAT_VERSION, RunLog, package_versions, read_text
from .sim.scenario import make_scenario
from .solver_folder import FolderLike, SolverFolder, as_folder
from .testhook import pause_point
from .verify import infer_scenario

SUITE_FORMAT = "fcgen-suite/1"
MANIFEST = "manifest.json"
GOLDEN_DIR = "golden"


@dataclass(frozen=True)
class SuiteSettings:
    """What to record: scenario kind (None: the problem's own), seeds, samples, how much plan, which build."""

    scenario: str | None = None
    seeds: tuple[int, ...] = tuple(range(20))
    samples: int = 200
    plan: str = "controls"
    verify: bool = False
    cc: str | None = None
    cflags: str | None = None
    timing: bool = True
    commonroad: str | None = None  # a CommonRoad scenario file instead of the seeds (its copy joins the suite)
    planning_problem: int | None = None
    traffic: str = "recorded"  # with ``commonroad``: recorded or reactive traffic (commonroad.reactive)
    plant: PlantSpec = field(default_factory=PlantSpec)  # the plant and perturbations of the runs (docs/plants.md)


#: the settings of the checked-in goldens ``generated/<x>/golden`` (``fcgen record --golden-for generated --force``):
#: verification build (no FP contraction: the least compiler-dependent), no timings (re-recording is reproducible)
GOLDEN_SETTINGS = SuiteSettings(seeds=(0, 1), samples=200, plan="controls", verify=True, timing=False)


def parse_seeds(text: str) -> tuple[int, ...]:
    """``"0-19"``, ``"0,3,7"`` or ``"0-3,9"`` -> sorted unique seeds; ValueError naming the allowed form."""
    seeds: set[int] = set()
    for part in str(text).split(","):
        part = part.strip()
        m = re.fullmatch(r"(\d+)(?:-(\d+))?", part)
        if not m or (m.group(2) is not None and int(m.group(2)) < int(m.group(1))):
            raise ValueError(
                f"--seeds {text!r} is invalid: allowed a range A-B (A <= B), a list A,B,C of "
                f"integers >= 0, or both (0-3,9)"
            )
        lo = int(m.group(1))
        seeds.update(range(lo, int(m.group(2) or lo) + 1))
    if len(seeds) > 10000:
        raise ValueError(f"--seeds {text!r}: {len(seeds)} seeds; allowed at most 10000")
    return tuple(sorted(seeds))


def log_name(scenario: str, seed: int) -> str:
    return f"{scenario}_seed{seed}.json.xz"


def text_sha256(log: RunLog) -> str:
    """SHA-256 of the log's JSON text (independent of the compression)."""
    return hashlib.sha256(log.to_json_string().encode("utf-8")).hexdigest()


# ----------------------------------------------------------------------------- what built the solver


def solver_info(folder: SolverFolder) -> dict[str, Any]:
    """Name, problem record (sizes, problem.py hash), precision and QP backend of a generated folder."""
    pb, macros = folder.problem, folder.sizes
    sizes = {k: macros[k] for k in ("N", "NX", "NU", "NOPP", "NOPP_PAR", "QP_N", "QP_M", "QP_NNZ_A") if k in macros}
    return {
        "name": folder.name,
        "problem": {
            "name": pb.name,
            "formulation": pb.formulation.kind,
            "obstacle_model": pb.obstacles.kind,
            "N": pb.horizon.N,
            "dt": pb.horizon.dt,
            "sizes": sizes,
            "problem_py_sha256": hashlib.sha256(folder.problem_file.read_bytes()).hexdigest(),
        },
        "precision": folder.precision,
        "qp_backend": "osqp" if (folder.path / "osqp").is_dir() else "unknown",
    }


def cc_version(cc: str | None = None) -> str:
    """The first line of ``CC --version`` (``cc``, else $CC, else ``cc``); ``'unknown'`` if it cannot be run."""
    cc = cc or os.environ.get("CC") or "cc"
    try:
        res = subprocess.run([cc, "--version"], capture_output=True, text=True, timeout=30)
    except (OSError, subprocess.TimeoutExpired):
        return "unknown"
    out = res.stdout or res.stderr
    return out.splitlines()[0].strip() if out else "unknown"


def compiler_info(gen_dir: Path, build_dir: str, cc: str | None, cflags: str | None) -> dict[str, Any]:
    """Compiler, its version line, CFLAGS and the exact compile line of the build (the Makefile's flags stamp)."""
    cc = cc or os.environ.get("CC") or "cc"
    version = cc_version(cc)
    if cflags is None:
        cflags = os.environ.get("CFLAGS")
    if cflags is None:
        m = re.search(r"^CFLAGS \?= ?(.*)$", (gen_dir / "Makefile").read_text(), re.M)
        cflags = m.group(1).strip() if m else ""
    stamp = gen_dir / build_dir / "flags.txt"
    return {
        "cc": cc,
        "cc_version": version,
        "cflags": cflags,
        "compile_line": stamp.read_text().strip() if stamp.is_file() else "unknown",
        "target": f"host-{platform.machine() or 'unknown'}",
    }


# ----------------------------------------------------------------------------- record


def check_suite_target(out: Path | str, force: bool = False) -> None:
    """Fail (ValueError, one line) unless ``out`` can take a new suite: a new or empty folder, or (with ``force``)
    a golden suite. The refusal names what would be lost; a folder of other files is never replaced."""
    out = Path(out)
    check_folder_target(out, "a golden suite folder", option="-o")
    if not out.is_dir() or not any(out.iterdir()):
        return
    if not is_suite(out):
        raise ValueError(
            f"-o {out}: not empty and not a golden suite (holds {describe(out)}): nothing recorded; "
            f"choose a new or empty folder"
        )
    if force:
        return
    try:
        man = json.loads(read_text(out / MANIFEST))
        logs = [e["file"] for e in man["logs"]]
        what = (
            f"the golden suite of {man.get('solver')!r}: {len(logs)} run log(s) "
            f"({', '.join(logs[:4])}{', ...' if len(logs) > 4 else ''})"
        )
    except (ValueError, KeyError, TypeError):
        what = f"a golden suite ({describe(out)})"
    raise ValueError(f"-o {out}: holds {what}; nothing recorded: add --force to replace it, or choose another folder")


def _is_suite_file(p: Path) -> bool:
    return p.name == MANIFEST or p.name.endswith(".json.xz") or p.suffix.lower() == ".xml"


def record_suite(
    folder: FolderLike,
    out: Path | str,
    settings: SuiteSettings = SuiteSettings(),
    progress: bool = False,
    echo=None,
    force: bool = False,
) -> dict[str, Any]:
    """Build ``folder`` (a :class:`~.solver_folder.SolverFolder` or its path; ``settings``' build), run the C closed
    loop on every seed, write logs + manifest.

    ``out`` must be new or empty, or (with ``force``) hold a golden suite; the suite is written into a temporary
    folder beside ``out`` and swapped in when complete (``fcgen.atomic``): a kill at any moment leaves the old
    suite or the new one, whole. With ``force`` files of ``out`` that are no suite's are kept."""
    out = Path(out)
    check_suite_target(out, force)
    if settings.plan not in PLAN_LEVELS:
        raise ValueError(f"--plan {settings.plan!r} is invalid: allowed {', '.join(PLAN_LEVELS)}")
    if settings.samples < 1:
        raise ValueError(f"--samples {settings.samples} is invalid: allowed >= 1")
    if not settings.seeds and settings.commonroad is None:
        raise ValueError("--seeds: allowed at least one seed")
    folder = as_folder(folder, check=False)  # build() checks it before compiling
    info = solver_info(folder)
    scenario = settings.scenario or infer_scenario(folder.problem)
    lib = build(folder, verify=settings.verify, cc=settings.cc, cflags=settings.cflags)
    comp = compiler_info(folder.path, VERIFY_BUILD if settings.verify else DEFAULT_BUILD, settings.cc, settings.cflags)
    with staged_folder(out) as tmp:
        if out.is_dir():  # --force: the folder's files that are no suite's stay
            for p in out.iterdir():
                if not _is_suite_file(p):
                    carry(p, tmp / p.name)
        manifest = _record_into(tmp, folder, lib, info, comp, scenario, settings, progress, echo)
        pause_point("record:before-swap")
    pause_point("record:after-swap")
    return manifest


def _record_into(
    out: Path, folder: SolverFolder, lib: Path, info, comp, scenario, settings, progress, echo
) -> dict[str, Any]:
    pb, entries = folder.problem, []
    if settings.commonroad is not None:  # one CommonRoad scenario: its run log and a copy of its file
        from .campaign.commonroad import load_for
        from .sim.commonroad_run import run_commonroad

        sc = load_for(pb, settings.commonroad, settings.planning_problem)
        log = run_commonroad(
            pb,
            sc,
            controller=CSolver(lib, folder=folder),
            plan=settings.plan,
            progress=progress,
            traffic=settings.traffic,
        ).log
        log = _finish(log, info["precision"], settings.timing)
        fname = f"cr_{sc.name}.json.xz"
        log.to_json(out / fname)
        import shutil

        shutil.copyfile(settings.commonroad, out / sc.file)
        entries.append(
            {
                "file": fname,
                "scenario": sc.name,
                "seed": 0,
                "samples": log.n_controls,
                "sha256": text_sha256(log),
                "commonroad": {"file": sc.file, "sha256": sc.sha256, "planning_problem": sc.planning_problem_id},
            }
        )
        scenario = sc.name
        settings = SuiteSettings(**{**settings.__dict__, "seeds": (0,), "samples": log.n_controls})
    for seed in settings.seeds if settings.commonroad is None else ():
        sc = make_scenario(scenario, seed, n_opp=pb.opponents.count, samples=settings.samples, dt=pb.horizon.dt)
        log = run_closed_loop(
            pb,
            sc,
            controller=CSolver(lib, folder=folder),
            exit_codes=True,
            plan=settings.plan,
            progress=progress,
            plant=settings.plant,
        )
        log = _finish(log, info["precision"], settings.timing)
        fname = log_name(scenario, seed)
        log.to_json(out / fname)
        entries.append(
            {"file": fname, "scenario": scenario, "seed": seed, "samples": log.n_controls, "sha256": text_sha256(log)}
        )
        if echo:
            echo(f"  {fname}: {(out / fname).stat().st_size / 1024:.1f} KiB")
        pause_point("record:log")
    manifest = {
        "format": SUITE_FORMAT,
        "solver": info["name"],
        "problem": info["problem"],
        "generator": {"fcgen": package_versions()["fcgen"], "versions": package_versions()},
        "build": {**comp, "verify": settings.verify},
        "precision": info["precision"],
        "qp_backend": info["qp_backend"],
        "runlog_format": FORMAT_VERSION,
        "settings": {
            "scenario": scenario,
            "seeds": list(settings.seeds),
            "samples": settings.samples,
            "plan": settings.plan,
            "timing": settings.timing,
            "controller": "c",
            **({} if settings.plant.is_default else {"plant": settings.plant.as_meta()}),
            **({"commonroad": entries[0]["commonroad"]} if settings.commonroad is not None else {}),
        },
        "logs": entries,
    }
    write_text(out / MANIFEST, json.dumps(manifest, indent=1, sort_keys=True) + "\n")
    return manifest


def _finish(log: RunLog, precision: str, timing: bool) -> RunLog:
    """The log with ``meta.precision`` set and, unless ``timing``, the timing fields zeroed."""
    meta = {**log.meta, "precision": precision}
    kw: dict[str, Any] = {"meta": meta}
    if not timing:
        z = np.zeros(log.n_controls)
        kw.update(time_prepare=z, time_feedback=z, time_total=z)
    return replace(log, **kw)


def record_goldens(
    root: Path | str,
    settings: SuiteSettings = GOLDEN_SETTINGS,
    echo=None,
    force: bool = False,
    plant: PlantSpec | None = None,
) -> list[Path]:
    """Re-record ``<root>/<solver>/golden`` for every generated solver folder under ``root`` (existing suites only
    with ``force``; every target is checked before the first is recorded). ``plant``: the runs' plant and
    perturbations; None: each suite's own (its manifest's ``settings.plant``; a new suite: fcgen's model)."""
    root = Path(root)
    folders = sorted(p for p in root.iterdir() if p.is_dir() and any(p.glob("*_solver.h"))) if root.is_dir() else []
    if not folders:
        raise FileNotFoundError(f"{root}: no generated solver folders (with a <name>_solver.h) found")
    for d in folders:
        check_suite_target(d / GOLDEN_DIR, force)
    out = []
    for d in folders:
        if echo:
            echo(f"{d / GOLDEN_DIR}:")
        spec = suite_plant(d / GOLDEN_DIR) if plant is None else plant
        record_suite(d, d / GOLDEN_DIR, replace(settings, plant=spec), echo=echo, force=force)
        out.append(d / GOLDEN_DIR)
    return out


def suite_plant(path: Path | str) -> PlantSpec:
    """The plant and perturbations a golden suite was recorded with (``settings.plant`` of its manifest; no suite,
    or none recorded: fcgen's model)."""
    if not is_suite(path):
        return PlantSpec()
    return plant_from_meta(load_manifest(path).get("settings", {}).get("plant"))


# ----------------------------------------------------------------------------- read


def is_suite(path: Path | str) -> bool:
    return Path(path).is_dir() and (Path(path) / MANIFEST).is_file()


def load_manifest(path: Path | str) -> dict[str, Any]:
    """The manifest of a suite folder; ValueError (one line) if it is missing or not a suite manifest."""
    path = Path(path)
    try:
        data = json.loads(read_text(path / MANIFEST))
    except FileNotFoundError:
        raise ValueError(f"{path}: not a golden suite (no {MANIFEST})") from None
    except (json.JSONDecodeError, ValueError) as exc:
        raise ValueError(f"{path / MANIFEST}: not a suite manifest ({str(exc).splitlines()[0]})") from None
    if not isinstance(data, dict) or data.get("format") != SUITE_FORMAT:
        got = data.get("format") if isinstance(data, dict) else None
        raise ValueError(f"{path / MANIFEST}: suite format {got!r}, this fcgen reads {SUITE_FORMAT!r}")
    for key in ("solver", "problem", "precision", "settings", "logs", "runlog_format"):
        if key not in data:
            raise ValueError(f"{path / MANIFEST}: missing key {key!r}")
    return data


def load_log(path: Path | str) -> RunLog:
    """A run log file; ValueError (one line, naming the file) for a file that is not a readable run log."""
    path = Path(path)
    if not path.is_file():
        raise ValueError(f"{path}: no such run log")
    try:
        text = read_text(path)
        data = json.loads(text)
    except (ValueError, json.JSONDecodeError) as exc:
        raise ValueError(f"{path}: not a run log (not JSON: {str(exc).splitlines()[0]})") from None
    if not isinstance(data, dict) or "format" not in data:
        raise ValueError(f"{path}: not a run log (no 'format' field)")
    if data["format"] != FORMAT_VERSION:
        raise ValueError(f"{path}: run log of format {data['format']!r}, this fcgen reads {FORMAT_VERSION!r}")
    try:
        return RunLog.from_json_string(text)
    except ValueError as exc:
        raise ValueError(f"{path}: invalid run log: {str(exc).splitlines()[0]}") from None


def load_suite(path: Path | str) -> tuple[dict[str, Any], list[RunLog]]:
    """Manifest and logs of a suite, each log checked against its manifest entry (hash, scenario, seed, length)."""
    path = Path(path)
    man = load_manifest(path)
    if man["runlog_format"] != FORMAT_VERSION:
        raise ValueError(
            f"{path}: suite of run-log format {man['runlog_format']!r}, this fcgen reads {FORMAT_VERSION!r}"
        )
    logs = []
    for e in man["logs"]:
        log = load_log(path / e["file"])
        if text_sha256(log) != e["sha256"]:
            raise ValueError(f"{path / e['file']}: checksum does not match the manifest (file changed or damaged)")
        if (log.meta["scenario"], log.meta["seed"], log.n_controls) != (e["scenario"], e["seed"], e["samples"]):
            raise ValueError(f"{path / e['file']}: scenario/seed/length differ from the manifest entry")
        logs.append(log)
    if not logs:
        raise ValueError(f"{path}: suite holds no run logs")
    check_manifest(path, man, logs)
    return man, logs


def manifest_facts(logs: list[RunLog]) -> dict[str, Any]:
    """What the run logs themselves say about the suite (manifest field -> value; one value over all logs, or a
    ValueError naming the field when the logs disagree among themselves)."""
    from .sim.replay import plan_level

    per_log = {
        "solver": lambda lg: lg.meta.get("problem"),
        "problem.name": lambda lg: lg.meta.get("problem"),
        "problem.formulation": lambda lg: lg.meta.get("formulation"),
        "problem.obstacle_model": lambda lg: lg.meta.get("obstacle_model"),
        "problem.N": lambda lg: lg.meta.get("N"),
        "problem.dt": lambda lg: lg.meta.get("dt"),
        "precision": lambda lg: lg.meta.get("precision", "double"),
        "settings.scenario": lambda lg: lg.meta.get("scenario"),
        "settings.samples": lambda lg: lg.n_controls,
        "settings.plan": plan_level,
        "settings.controller": lambda lg: lg.meta.get("controller"),
        "problem.sizes.N": lambda lg: lg.meta.get("N"),
        "problem.sizes.NU": lambda lg: int(np.shape(lg.control)[-1]),
        "problem.sizes.NOPP": lambda lg: (
            len(lg.meta["extra"]["commonroad"]["slots"][0])  # the solver's slots
            if "commonroad" in lg.meta.get("extra", {})
            else len(lg.opponents)
        ),
    }
    facts: dict[str, Any] = {}
    for key, fn in per_log.items():
        vals = {json.dumps(fn(lg)) for lg in logs}
        if len(vals) > 1:
            raise ValueError(f"the suite's run logs disagree on {key}: {', '.join(sorted(vals))}")
        facts[key] = json.loads(vals.pop())
    facts["settings.seeds"] = sorted(lg.meta.get("seed") for lg in logs)
    plans = [lg.plan_states for lg in logs if lg.plan_states is not None]
    if len(plans) == len(logs):
        facts["problem.sizes.NX"] = int(plans[0].shape[-1])
    return facts


def check_manifest(path: Path | str, man: dict[str, Any], logs: list[RunLog]) -> None:
    """ValueError (one line naming the field) when a manifest field disagrees with what the logs say (precision,
    solver, problem record, sizes, settings): a hand-edited manifest must not change how the logs are compared."""
    where = Path(path) / MANIFEST
    try:
        facts = manifest_facts(logs)
    except ValueError as exc:
        raise ValueError(f"{Path(path)}: {exc}") from None
    for key, want in facts.items():
        got: Any = man
        for part in key.split("."):
            got = got.get(part, _MISSING) if isinstance(got, dict) else _MISSING
        if key == "settings.seeds" and isinstance(got, list):
            got = sorted(got)
        if got is _MISSING:
            if key.startswith("problem.sizes.") or key == "settings.controller":
                continue  # older manifests may lack a size; nothing to disagree with
            raise ValueError(f"{where}: field {key} is missing (the run logs say {want!r})")
        if got != want:
            raise ValueError(
                f"{where}: field {key} is {got!r} but the run logs say {want!r} (hand-edited?); "
                f"refused: record the suite again"
            )


_MISSING = object()
