"""``fcgen regress``: what NEW and GOLDEN are (run log, golden suite, solver folder) and the comparison of the two;
a solver folder is built once and replays the golden inputs or runs the closed loops again."""

from __future__ import annotations

import hashlib
from pathlib import Path
from typing import Any

import numpy as np

from ..build import build
from ..csolver import CSolver
from ..ocp import build_ocp
from ..sim.closedloop import ReferenceController, run_closed_loop
from ..sim.plants import PlantSpec, plant_of
from ..sim.replay import plan_level, replay, scenario_of
from ..sim.runlog import RunLog
from ..solver_folder import SolverFolder, read_folder
from ..suite import cc_version, is_suite, load_log, load_suite, solver_info
from .compare import compare_logs
from .report import RegressReport
from .tolerances import ALL_FIELDS, REPLAY_FIELDS, Tol, UnusableInput, tolerances

MODES = ("replay", "closed-loop")


def _kind(path: Path) -> str:
    if path.is_dir():
        if any(path.glob("*_solver.h")):
            return "solver"
        if is_suite(path):
            return "suite"
        raise UnusableInput(
            f"{path}: neither a solver folder (no <name>_solver.h) nor a golden suite (no manifest.json); {_MAKE_ONE}"
        )
    if path.is_file():
        return "log"
    raise UnusableInput(f"{path}: no such file or folder; {_MAKE_ONE}")


_MAKE_ONE = "write a solver folder with `fcgen generate PRESET -o DIR`, a suite with `fcgen record DIR -o SUITE`"


def _unusable(fn, *args):
    try:
        return fn(*args)
    except UnusableInput:
        raise
    except (ValueError, FileNotFoundError) as exc:
        raise UnusableInput(str(exc).splitlines()[0]) from None


def _golden(path: Path) -> tuple[str, list[RunLog], dict[str, Any] | None]:
    """Precision, logs and manifest (None for a single log) of a GOLDEN argument."""
    if _kind(path) == "suite":
        man, logs = _unusable(load_suite, path)
        return man["precision"], logs, man
    if _kind(path) == "log":
        log = _unusable(load_log, path)
        return log.meta.get("precision", "double"), [log], None
    raise UnusableInput(f"{path}: GOLDEN must be a run log or a golden suite, not a solver folder")


def regress(
    new: Path | str,
    golden: Path | str,
    mode: str | None = None,
    preset: str | None = None,
    tol: dict[str, Tol] | None = None,
    timing: bool = False,
    controller: str = "c",
    build_kw: dict | None = None,
    progress: bool = False,
    plant: PlantSpec | None = None,
    traffic: str | None = None,
) -> RegressReport:
    """Compare NEW (log, suite or solver folder) with GOLDEN (log or suite); see the module docstring.

    ``mode``: for a solver folder ``"replay"`` or ``"closed-loop"`` (default: replay, a golden log of a perturbed
    run in closed loop: its states are the plant's, not what the controller measured); ``controller``: ``"c"`` (the
    folder's compiled solver, ``build_kw`` passed to ``fcgen.build.build``; ``verify`` defaults to the golden
    suite's) or ``"python"`` (its Python reference). ``plant``: the closed loop's plant and perturbations (default:
    what each golden log records in ``meta.extra.plant``, else fcgen's model). ``traffic``: a CommonRoad log's
    traffic mode (``recorded`` or ``reactive``; default: the golden log's).
    """
    new, golden = Path(new), Path(golden)
    kind_new = _kind(new)
    gold = _golden(golden)
    if mode is not None and mode not in MODES:
        raise UnusableInput(f"--mode {mode!r} is invalid: allowed {', '.join(MODES)}")
    if kind_new != "solver" and mode is not None:
        raise UnusableInput(f"--mode {mode} needs NEW to be a solver folder; {new} is a {kind_new}")
    if kind_new == "log":
        return _log_vs(new, golden, gold, preset, tol, timing)
    if kind_new == "suite":
        return _suite_vs(new, golden, gold, preset, tol, timing)
    return _folder_vs(
        new,
        golden,
        gold,
        mode,
        preset,
        tol,
        timing,
        controller,
        dict(build_kw or {}),
        progress,
        plant,
        traffic,
    )


def _log_vs(
    new: Path, golden: Path, gold: tuple, preset: str | None, tol: dict[str, Tol] | None, timing: bool
) -> RegressReport:
    """A run log vs a log, or vs the suite's log of the same scenario and seed."""
    prec_gold, gold_logs, man = gold
    new_log = _unusable(load_log, new)
    key = (new_log.meta["scenario"], new_log.meta["seed"])
    match = [g for g in gold_logs if (g.meta["scenario"], g.meta["seed"]) == key] if man else gold_logs
    if not match:
        raise UnusableInput(f"{golden}: the suite has no log of {key[0]} seed {key[1]} (the scenario of {new})")
    name, tols = tolerances(preset, (new_log.meta.get("precision", "double"), prec_gold), tol)
    rep = RegressReport("log vs log", str(new), str(golden), name, tols, timing)
    rep.logs.append(compare_logs(new_log, match[0], tols, timing=timing))
    return rep


def _suite_vs(
    new: Path, golden: Path, gold: tuple, preset: str | None, tol: dict[str, Tol] | None, timing: bool
) -> RegressReport:
    """A golden suite vs another, log by log (every golden scenario and seed must be in NEW)."""
    prec_gold, gold_logs, man = gold
    if man is None:
        raise UnusableInput(f"{new} is a suite but {golden} is a run log")
    man_new, new_logs = _unusable(load_suite, new)
    name, tols = tolerances(preset, (man_new["precision"], prec_gold), tol)
    rep = RegressReport(
        "suite vs suite",
        str(new),
        str(golden),
        name,
        tols,
        timing,
        notes=_record_notes(man_new["problem"], man["problem"], "NEW's suite"),
    )
    by_key = {(lg.meta["scenario"], lg.meta["seed"]): lg for lg in new_logs}
    for g in gold_logs:
        key = (g.meta["scenario"], g.meta["seed"])
        if key not in by_key:
            raise UnusableInput(f"{new}: has no log of {key[0]} seed {key[1]} (in {golden})")
        rep.logs.append(compare_logs(by_key[key], g, tols, timing=timing))
    return rep


def _folder_vs(
    new: Path,
    golden: Path,
    gold: tuple,
    mode: str | None,
    preset: str | None,
    tol: dict[str, Tol] | None,
    timing: bool,
    controller: str,
    build_kw: dict,
    progress: bool,
    plant: PlantSpec | None = None,
    traffic: str | None = None,
) -> RegressReport:
    """A solver folder (read once, built once) replayed on the golden inputs or run in closed loop again."""
    prec_gold, gold_logs, man = gold
    folder = _unusable(read_folder, new, False)  # build() checks it before compiling
    info = solver_info(folder)
    name, tols = tolerances(preset, (info["precision"] if controller == "c" else "double", prec_gold), tol)
    notes: list[str] = []
    if man is not None:
        _check_problem(info, man, new, golden)
        notes += _record_notes(info["problem"], man["problem"], "the solver")
    modes = [mode or _default_mode(g) for g in gold_logs]
    rep_mode = modes[0] if len(set(modes)) == 1 else "replay and closed-loop"
    rep = RegressReport(rep_mode, str(new), str(golden), name, tols, timing, notes=notes)
    if mode is None and "closed-loop" in modes:
        notes.append("golden logs of a perturbed run (meta.extra.plant) run in closed loop again, not replayed")
    notes += _plant_notes(plant, gold_logs, modes)
    if build_kw.get("verify") is None:  # by default the kind of build the golden suite was recorded with
        build_kw["verify"] = bool(man is not None and man.get("build", {}).get("verify"))
    runner = _Runner(folder, controller, build_kw, progress)
    runner.plant, runner.traffic = plant, traffic
    runner.golden_dir = golden if golden.is_dir() else golden.parent  # where a CommonRoad log's scenario file is
    if runner.lib is not None:
        stamp = runner.lib.parent / "flags.txt"
        notes.append(
            f"NEW built with: {stamp.read_text().strip() if stamp.is_file() else 'unknown flags'} "
            f"({cc_version(build_kw.get('cc'))})"
        )
    else:
        notes.append("NEW: the Python reference of the folder's problem.py")
    if man is not None:
        notes.append(
            f"GOLDEN built with: {man.get('build', {}).get('compile_line', 'unknown')} "
            f"({man.get('build', {}).get('cc_version', 'unknown compiler')}, {man['precision']})"
        )
    for g, m in zip(gold_logs, modes, strict=True):
        label = f"{g.meta['scenario']} seed {g.meta['seed']}"
        if g.meta["problem"] != info["name"]:
            raise UnusableInput(
                f"{label}: another problem: GOLDEN was recorded by {g.meta['problem']!r}, NEW is {info['name']!r}"
            )
        out = runner.run(g, m)
        fields = REPLAY_FIELDS if m == "replay" else ALL_FIELDS
        rep.logs.append(compare_logs(out, g, tols, fields=fields, timing=timing, label=label))
    return rep


def _default_mode(gold: RunLog) -> str:
    """Replay, but a golden log of a perturbed run (not a CommonRoad one) runs in closed loop again."""
    perturbed = not plant_of(gold).is_default and "commonroad" not in gold.meta.get("extra", {})
    return "closed-loop" if perturbed else "replay"


def _plant_notes(plant: PlantSpec | None, gold_logs: list[RunLog], modes: list[str]) -> list[str]:
    """A note per golden log whose recorded plant and perturbations the given ``plant`` replaces."""
    if plant is None:
        return []
    return [
        f"{g.meta['scenario']} seed {g.meta['seed']}: run with the plant {plant.label()}, "
        f"the golden log was recorded with {plant_of(g).label()}"
        for g, m in zip(gold_logs, modes, strict=True)
        if m == "closed-loop" and plant != plant_of(g)
    ]


def _record_notes(a: dict[str, Any], b: dict[str, Any], who: str) -> list[str]:
    """Notes where NEW's problem record (``a``) and GOLDEN's (``b``) differ in what may legitimately change between
    two versions (the problem.py source, the QP's sizes)."""
    notes = []
    if a.get("problem_py_sha256") != b.get("problem_py_sha256"):
        notes.append(
            f"{who}'s problem.py differs from the one the golden suite was recorded with (sha256 "
            f"{str(a.get('problem_py_sha256'))[:12]} vs {str(b.get('problem_py_sha256'))[:12]})"
        )
    sa, sb = a.get("sizes", {}), b.get("sizes", {})
    diff = [k for k in sorted(set(sa) | set(sb)) if sa.get(k) != sb.get(k)]
    if diff:
        notes.append(
            f"{who}'s sizes differ from the golden suite's: "
            + ", ".join(f"{k} {sa.get(k)} vs {sb.get(k)}" for k in diff)
        )
    return notes


def _check_problem(info: dict[str, Any], man: dict[str, Any], new: Path, golden: Path) -> None:
    if info["name"] != man["solver"]:
        raise UnusableInput(
            f"another problem: {new} is solver {info['name']!r}, {golden} was recorded by {man['solver']!r}"
        )
    a, b = info["problem"], man["problem"]
    for key in ("formulation", "obstacle_model", "N", "dt"):
        if a[key] != b.get(key):
            raise UnusableInput(f"another problem: {key} is {a[key]!r} in {new}, {b.get(key)!r} in {golden}")
    sa, sb = a["sizes"], b.get("sizes", {})
    diff = [k for k in ("N", "NX", "NU", "NOPP", "NOPP_PAR") if k in sa and k in sb and sa[k] != sb[k]]
    if diff:
        raise UnusableInput(
            f"another problem: sizes {', '.join(f'{k} {sa[k]} vs {sb[k]}' for k in diff)} ({new} vs {golden})"
        )


class _Runner:
    """Builds the new solver once and runs it (replay or closed loop) on each golden log."""

    golden_dir: Path = Path(".")
    plant: PlantSpec | None = None  # the closed loop's plant (None: each golden log's own)
    traffic: str | None = None  # a CommonRoad log's traffic mode (None: each golden log's own)

    def __init__(self, folder: SolverFolder, controller: str, build_kw: dict, progress: bool):
        if controller not in ("c", "python"):
            raise UnusableInput(f"--controller {controller!r} is invalid: allowed c, python")
        self.folder, self.problem = folder, folder.problem
        self.ocp = build_ocp(self.problem)
        self.controller, self.progress = controller, progress
        self.lib = build(folder, **build_kw) if controller == "c" else None

    def make(self):
        if self.lib is not None:
            return CSolver(self.lib, folder=self.folder)  # init(): a fresh workspace per log
        return ReferenceController(self.ocp)

    def run(self, gold: RunLog, mode: str) -> RunLog:
        if "commonroad" in gold.meta.get("extra", {}):
            return _unusable(self._commonroad, gold, mode)
        if mode == "replay":
            if not plant_of(gold).is_default:
                raise UnusableInput(
                    "a golden log of a perturbed run (meta.extra.plant: noise, latency or another plant) is "
                    "compared with --mode closed-loop, not replayed"
                )
            return _unusable(replay, self.problem, gold, self.make(), None, self.progress)
        sc = _unusable(scenario_of, gold, self.problem)
        spec = self.plant or plant_of(gold)
        return _unusable(
            lambda: run_closed_loop(
                self.problem,
                sc,
                controller=self.make(),
                ocp=self.ocp,
                progress=self.progress,
                exit_codes=gold.exit_code is not None,
                plan=plan_level(gold),
                plant=spec,
            )
        )

    def _commonroad(self, gold: RunLog, mode: str) -> RunLog:
        """A CommonRoad log: its scenario file (beside the golden log, by name and sha256) run again, in replay on
        the logged states."""
        from ..campaign.commonroad import load_for
        from ..sim.commonroad_run import run_commonroad

        cr = gold.meta["extra"]["commonroad"]
        path = self.golden_dir / cr.get("file", "")
        if not path.is_file() or hashlib.sha256(path.read_bytes()).hexdigest() != cr.get("sha256"):
            raise ValueError(
                f"{path}: the CommonRoad scenario of the golden log ({cr.get('scenario')}, sha256 "
                f"{str(cr.get('sha256'))[:12]}) is not there or differs"
            )
        sc = load_for(self.problem, path, cr.get("planning_problem"))
        states = np.asarray(gold.ego_frenet) if mode == "replay" else None
        return run_commonroad(
            self.problem,
            sc,
            controller=self.make(),
            ocp=self.ocp,
            plan=plan_level(gold),
            progress=self.progress,
            states=states,
            traffic=self.traffic or cr.get("traffic", {}).get("mode", "recorded"),
            band=cr.get("band", {}).get("rule", "road"),  # a log from before the band rules: the road's band
        ).log
