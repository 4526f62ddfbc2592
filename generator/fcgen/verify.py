"""Verify a generated solver folder against the Python reference (``fcgen verify``).

Two comparisons on one seeded scenario:

1. **Lockstep**: the Python closed loop (Python plant driven by the Python reference) runs ``samples`` samples; at
   every sample the C solver (verification build: no floating-point contraction) gets exactly the same measured state,
   road window and opponent poses and performs the same calls. After preparation the stage parameters (for the
   conventional formulation with the opponent boxes its prepare phase fitted) and the QP data (``P``, ``q``,
   ``A`` values, ``l``, ``u``) are compared, after feedback the QP data with ``x0`` embedded, the QP's primal and dual
   solution ``z``, ``y``, the SQP iterate (states and controls over the horizon) and ``u0``, plus the exit code, QP
   status and QP iteration count. Then the reference takes over the C's committed plan and duals (``_resync``), so
   every sample compares the one-step map from the same start over the whole run: a backend whose C and Python agree
   to rounding only (the IPM) cannot drift into a different run where the problem amplifies rounding. Where such a
   backend's solution parts beyond its tolerance on a sample, the sample is held to twice the reference's own move
   on that QP under a rounding-level change of its measured state (``verify_envelope.solution_envelope``).
2. **Independent closed loops**: the Python plant driven by the C controller vs driven by the Python controller, each
   on its own: the ego's trajectory (each Frenet state relative to ``max(1, max |state|)`` over the run), the applied
   controls, QP iterations and statuses, exit codes. Where these part beyond the tolerances, the reference runs again
   with its measured state perturbed at rounding level (``ENVELOPE_EPS``); the C passes if it stays within
   ``ENVELOPE_FACTOR`` times how far the reference parts from itself (the paper's free hyperplanes: no implementation
   that is not bit-identical can keep these runs equal).

Differences of arrays are relative: ``max |c - r| / max(1, max |r|)`` with ``r`` the reference; bounds are clipped
to OSQP's infinity (1e30) on both sides first, as the osqp Python interface does.
"""

from __future__ import annotations

import math
from dataclasses import replace
from pathlib import Path

import numpy as np

from .backends import backend_module
from .codegen.folder import edits_note
from .contract import StepResult
from .csolver import CSolver
from .dsl import Problem, ProblemError
from .ocp import INF, build_ocp
from .presets import CAR, SCENARIOS, TRUCK
from .reference import RtiSolver
from .sim.closedloop import PlantSpec, ReferenceController, run_closed_loop
from .sim.runlog import summary
from .sim.scenario import make_scenario
from .solver_folder import FolderLike, SolverFolder, as_folder, read_folder
from .verify_envelope import ENVELOPE_EPS, SOLUTION_KEYS, clearance_diff, rel_diff, solution_envelope
from .verify_report import ENVELOPE_FACTOR, Check, VerifyReport, iterations_differ

TOL_QP_DATA = 1e-12
TOL_SOLUTION = 1e-9
TOL_TRAJECTORY = 1e-6
STRAIGHT_SAMPLES = 10
"""Samples of the straight-road lockstep (``_straight_probe``)."""
CLOSED_LOOP = ("trajectory", "cl_control", "cl_qp_iter", "cl_exit_code")

# (key, group, tolerance, description) in table order
QUANTITIES: tuple[tuple[str, str, float, str], ...] = (
    ("params", "prepare", TOL_QP_DATA, "stage parameters"),
    ("P_x", "prepare", TOL_QP_DATA, "P values"),
    ("q", "prepare", TOL_QP_DATA, "q (before x0)"),
    ("A_x", "prepare", TOL_QP_DATA, "A values"),
    ("l", "prepare", TOL_QP_DATA, "l (before x0)"),
    ("u", "prepare", TOL_QP_DATA, "u (before x0)"),
    ("q_fb", "feedback", TOL_QP_DATA, "q with x0"),
    ("l_fb", "feedback", TOL_QP_DATA, "l with x0"),
    ("u_fb", "feedback", TOL_QP_DATA, "u with x0"),
    ("z", "feedback", TOL_SOLUTION, "QP primal z"),
    ("z_free", "feedback", TOL_SOLUTION, "QP primal z, no curvature"),
    ("y", "feedback", TOL_SOLUTION, "QP dual y"),
    ("w", "feedback", TOL_SOLUTION, "iterate x, u"),
    ("u0", "feedback", TOL_SOLUTION, "first control u0"),
    ("max_slack", "feedback", TOL_SOLUTION, "max slack"),
    ("plan_clearance", "feedback", TOL_SOLUTION, "plan check clearance"),
    ("exit_code", "status", 0, "exit code mismatches"),
    ("plan_check", "status", 0, "plan check stage/reaction, a_lat guard mismatches"),
    ("qp_status", "status", 0, "QP status mismatches"),
    ("qp_iter", "status", 0, "QP iteration mismatches"),
    ("straight_q", "straight road", TOL_QP_DATA, "q, no curve cap (V_REF, N_REF)"),
    ("straight_u0", "straight road", TOL_SOLUTION, "first control u0, no curve cap"),
    ("stage_params", "stage inputs", TOL_QP_DATA, "stage parameters, reference and margin per stage"),
    ("stage_q", "stage inputs", TOL_QP_DATA, "q, reference and margin per stage"),
    ("stage_u0", "stage inputs", TOL_SOLUTION, "first control u0, reference and margin per stage"),
    ("trajectory", "closed-loop", TOL_TRAJECTORY, "ego states"),
    ("cl_control", "closed-loop", TOL_TRAJECTORY, "applied controls"),
    ("cl_qp_iter", "closed-loop", 0, "QP iter/status mismatches"),
    ("cl_exit_code", "closed-loop", 0, "non-zero exit codes, C minus Python"),
)


def _clip(a) -> np.ndarray:
    return np.clip(np.asarray(a, dtype=float), -INF, INF)


# --- the problem and scenario of a folder ------------------------------------------------------------------------


def infer_scenario(problem: Problem) -> str:
    """``'truck'`` or ``'car'``: the preset opponent vehicle, else the name prefix, else the opponent length."""
    v = problem.opponents.vehicle
    if v == TRUCK:
        return "truck"
    if v == CAR:
        return "car"
    for sc in SCENARIOS:
        if problem.name.startswith(sc + "_") or problem.name == sc:
            return sc
    ego = problem.ego
    return "truck" if v.l_f_ch + v.l_r_ch > 1.5 * (ego.l_f_ch + ego.l_r_ch) else "car"


def load_solver_problem(gen_dir: Path | str) -> tuple[str, Problem]:
    """The solver name and the Problem of a generated folder (its ``problem.py``); clear errors otherwise."""
    folder = read_folder(gen_dir, check=False)
    return folder.name, folder.problem


def check_sizes(folder: SolverFolder, ref: RtiSolver) -> None:
    """The sizes in ``<name>_solver.h`` must be those of the problem rebuilt from ``problem.py``."""
    s, name, lay = folder.sizes, folder.name, ref.lay
    c = tuple(s.get(k) for k in ("N", "QP_N", "QP_M", "QP_NNZ_A"))
    if c != (ref.ocp.N, lay.n, lay.m, lay.nnz_A):
        raise ProblemError(
            f"solver {name}: C sizes N={c[0]}, n={c[1]}, m={c[2]}, nnz(A)={c[3]} do not match "
            f"its problem.py (N={ref.ocp.N}, n={lay.n}, m={lay.m}, nnz(A)={lay.nnz_A}); regenerate"
        )


# --- lockstep -----------------------------------------------------------------------------------------------------


def _same_minimiser(k_c: int, k_py: int, per_stage: np.ndarray, tol: float) -> bool:
    """The C's stage of the smallest clearance is the reference's, or (two stages whose clearances tie to rounding)
    a stage where the reference's clearance is the smallest within ``tol`` (relative to ``max(1, |smallest|)``)."""
    if k_c == k_py:
        return True
    if not (0 <= k_c < len(per_stage) and 0 <= k_py < len(per_stage)):
        return False
    best = float(per_stage[k_py])
    return bool(abs(float(per_stage[k_c]) - best) <= tol * max(1.0, abs(best)))


class _Lockstep:
    """A closed-loop controller: the Python reference drives the plant; the C solver repeats every call in lockstep."""

    kind = "python-reference"

    def __init__(self, ref: RtiSolver, cs, checks: dict[str, Check]):
        self.ref, self.cs, self.checks = ref, cs, checks
        self.ref_ctrl = ReferenceController(ref.ocp, ref)
        self.j = 0
        self.envelope = bool(getattr(backend_module(ref.qp_opts.backend), "VERIFY_ENVELOPE", False))

    def _upd(self, key: str, diff: float) -> None:
        self.checks[key].update(diff, self.j)

    def set_obstacle_margins(self, margins) -> int:
        """Both solvers' margins (the prediction's, ``sim.prediction.MARGIN_RULE``); the C's exit code."""
        self.ref.set_obstacle_margins(margins)
        return self.cs.set_obstacle_margins(margins)

    def step(self, x0: np.ndarray, road, opp: np.ndarray) -> StepResult:
        sv, cs = self.ref, self.cs
        # both controllers' own phases, so the call order is the one the closed loop uses
        rc_py = self.ref_ctrl.prepare_phase(x0, road, opp)
        rc = cs.prepare_phase(x0, road, opp)
        if not rc and not rc_py:
            qp = cs.get_qp()
            # conventional: with the fitted opponent boxes
            self._upd("params", rel_diff(cs.get_opp_params(), sv.P[:, sv.ocp.p_opp]))
            for key, r in (
                ("P_x", sv.lay.P_diag),
                ("q", sv.q),
                ("A_x", sv.A_data),
                ("l", _clip(sv.l)),
                ("u", _clip(sv.u)),
            ):
                self._upd(key, rel_diff(qp[key], r))
        res = self.ref_ctrl.feedback_phase(x0, rc_py)
        c_res = cs.feedback_phase(x0, rc)
        self._upd("exit_code", float(c_res.exit_code != res.exit_code))  # the reference and C share EXIT_CODES
        self._upd("qp_status", float(c_res.qp_status != res.qp_status))
        st_c, st_py = cs.status(), sv.status
        iterate = {}  # what is computed from the iterate: held to the sample's envelope with the solution
        if c_res.exit_code == res.exit_code:  # the same outcome: the same plan check (or none, kept as it was)
            both_inf = math.isinf(st_c.plan_clearance) and math.isinf(st_py.plan_clearance)
            clr_tol = self.checks["plan_clearance"].tol
            self._upd(
                "plan_check",
                float(
                    st_c.plan_reaction != st_py.plan_reaction
                    or st_c.a_lat_guard != st_py.a_lat_guard
                    or not _same_minimiser(
                        st_c.plan_clearance_stage, st_py.plan_clearance_stage, sv.stage_clearance, clr_tol
                    )
                ),
            )
            iterate["plan_clearance"] = (
                0.0 if both_inf else clearance_diff(st_c.plan_clearance, st_py.plan_clearance, sv.states())
            )
        if not c_res.exit_code and not res.exit_code:
            qp = cs.get_qp()
            self._upd("q_fb", rel_diff(qp["q"], sv.q_fb))
            self._upd("l_fb", rel_diff(qp["l"], _clip(sv.l)))
            self._upd("u_fb", rel_diff(qp["u"], _clip(sv.u)))
            iterate["max_slack"] = rel_diff(c_res.max_slack, res.max_slack)
            spread = self._solution(qp, c_res, res, iterate)
        else:
            spread = 0.0
            for k, d in iterate.items():
                self._upd(k, d)
        # an iteration count the reference's own moves by under rounding-level changes (this sample's envelope)
        self._upd("qp_iter", float(iterations_differ(c_res.qp_iter, res.qp_iter, spread)))
        if not rc and not rc_py:
            self._resync(c_res.exit_code == 0, st_c)
        self.j += 1
        return res

    def _solution(self, qp: dict, c_res: StepResult, res: StepResult, iterate: dict[str, float]) -> float:
        """The QP's solution, the iterate and u0, C vs reference, and ``iterate``'s differences of what is computed
        from the iterate (largest slack, plan clearance); where one parts beyond its tolerance and the backend allows
        it (``VERIFY_ENVELOPE``), each held to ``ENVELOPE_FACTOR`` times this sample's envelope if larger. Returns
        how far that envelope moves the reference's iteration count (0 where it was not measured)."""
        sv, cs = self.ref, self.cs
        free, z = sv.lay.P_diag == 0.0, np.asarray(sv.z)
        c_plan = np.concatenate([cs.states().ravel(), cs.controls().ravel()])
        diffs = {
            "z": rel_diff(qp["z"][~free], z[~free]),
            "z_free": rel_diff(qp["z"][free], z[free]),
            "y": rel_diff(qp["y"], sv.y),
            "w": rel_diff(c_plan, np.concatenate([sv.states().ravel(), sv.controls().ravel()])),
            "u0": rel_diff(c_res.u, res.u),
            **iterate,
        }
        env = dict.fromkeys((*diffs, "qp_iter"), 0.0)
        if self.envelope and any(d > self.checks[k].tol for k, d in diffs.items()):
            env = solution_envelope(sv)
        for k, d in diffs.items():
            self.checks[k].update(d, self.j, env[k])
        return env["qp_iter"]

    def _resync(self, c_ok: bool, st_c) -> None:
        """The reference continues from the C's committed plan, duals and unusable-QP count, as the C computed them
        (``w = w_prep + D z``, the same operations): each sample then compares the one-step map from one start, and
        rounding differences cannot accumulate into a different run where the problem amplifies them (free
        hyperplanes, the conventional fit's boxes). Where they agree bit for bit (OSQP) nothing changes."""
        sv, cs = self.ref, self.cs
        qp = cs.get_qp()
        sv.w = sv.w_prep + sv.lay.D * qp["z"] if c_ok else sv.w_prep.copy()
        sv.y = qp["y"]
        sv.status.qp_unusable_run, sv.status.cold_restarts = st_c.qp_unusable_run, st_c.cold_restarts


class _PerturbedReference(ReferenceController):
    """The reference with its measured state scaled by ``1 + eps``: the plant is not perturbed, only what it reports."""

    def __init__(self, ocp, eps: float):
        super().__init__(ocp)
        self.eps = eps

    def prepare_phase(self, x0: np.ndarray, road, opp: np.ndarray) -> int:
        return super().prepare_phase(x0 * (1.0 + self.eps), road, opp)

    def feedback_phase(self, x0: np.ndarray, rc: int = 0) -> StepResult:
        return super().feedback_phase(x0 * (1.0 + self.eps), rc)


def _closed_loop_diffs(log_c, log_py) -> dict[str, tuple[float, int, int, int]]:
    """Two closed loops' differences, per ``CLOSED_LOOP`` key: (max_diff, sample, count, compared). States and
    controls relative to ``max(1, max |reference|)`` per component; counts of samples whose QP iterations or status
    differ; the difference of the numbers of non-zero exit codes."""
    out = {}
    scale = np.maximum(1.0, np.max(np.abs(log_py.ego_frenet), axis=0))
    d = np.abs(log_c.ego_frenet - log_py.ego_frenet) / scale
    per_sample = np.max(np.where(np.isnan(d), np.inf, d), axis=1)
    mx = float(np.max(per_sample))
    out["trajectory"] = (mx, int(np.argmax(per_sample)) if mx > 0 else -1, 0, len(per_sample))
    scale_u = np.maximum(1.0, np.max(np.abs(log_py.control), axis=0))
    du = np.max(np.abs(log_c.control - log_py.control) / scale_u, axis=1)
    du = np.where(np.isnan(du), np.inf, du)
    mx = float(np.max(du, initial=0.0))
    out["cl_control"] = (mx, int(np.argmax(du)) if mx > 0 else -1, 0, len(du))
    bad = np.flatnonzero((log_c.qp_iter != log_py.qp_iter) | (log_c.qp_status != log_py.qp_status))
    out["cl_qp_iter"] = (float(len(bad)), int(bad[0]) if len(bad) else -1, len(bad), len(log_c.qp_iter))
    # run logs keep only the number of non-zero exit codes
    n = abs(log_c.meta["extra"]["exit_codes_nonzero"] - log_py.meta["extra"]["exit_codes_nonzero"])
    out["cl_exit_code"] = (float(n), -1, n, 1)
    return out


def _checks(backend: str) -> dict[str, Check]:
    """A fresh check per quantity with the backend's tolerances: a backend that is not bit-exact C vs Python (the IPM:
    numpy vs C loops) has its own; the variables without cost curvature (P_ii = 0: the paper's free hyperplanes) are
    fixed by the rows and the backend's regularization only, so their rounding may part more (VERIFY_FREE_TOL)."""
    bmod = backend_module(backend)
    tols = {
        TOL_QP_DATA: getattr(bmod, "VERIFY_QP_DATA_TOL", TOL_QP_DATA),
        TOL_SOLUTION: getattr(bmod, "VERIFY_SOLUTION_TOL", TOL_SOLUTION),
    }
    checks = {k: Check(k, g, d, tols.get(t, t)) for k, g, t, d in QUANTITIES}
    checks["z_free"].tol = getattr(bmod, "VERIFY_FREE_TOL", checks["z"].tol)
    return checks


def _lockstep(pb: Problem, sc, ocp, cs, checks: dict[str, Check], plant: PlantSpec | None = None):
    """The lockstep comparison of ``cs`` with a fresh reference over scenario ``sc`` (on ``plant``); returns the
    reference's log."""
    if cs.init() != 0:
        raise RuntimeError(f"{pb.name}_init() failed")
    return run_closed_loop(pb, sc, controller=_Lockstep(RtiSolver(ocp), cs, checks), ocp=ocp, plant=plant)


def _straight_probe(pb: Problem, sc, ocp, cs, checks: dict[str, Check]) -> None:
    """The lockstep on the scenario's road made straight (curvature 0) for ``STRAIGHT_SAMPLES`` samples: no curve
    speed caps the reference there, so the solver's default reference speed and offset (``V_REF``, ``N_REF``) enter
    every stage's costs, which a bendy road's curve reference may hide."""
    road = replace(sc.road, kappa=np.zeros_like(sc.road.kappa))
    probe = _checks(pb.qp.backend)
    _lockstep(pb, replace(sc, road=road, samples=min(sc.samples, STRAIGHT_SAMPLES)), ocp, cs, probe)
    _take(checks, probe, (("straight_q", "q"), ("straight_u0", "u0")))


def stage_probe_inputs(pb: Problem) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """v_ref, n_ref and obstacle margins that differ at every stage: 60-100 % of the problem's v_ref, n_ref across
    the middle fifth of the band, margins 0-0.5 m."""
    k = np.arange(pb.horizon.N + 1) / pb.horizon.N
    lo, hi = pb.bounds.n_min, pb.bounds.n_max
    return pb.reference.v_ref * (0.6 + 0.4 * k), lo + (hi - lo) * (0.4 + 0.2 * k), 0.5 * k


def _stage_probe(pb: Problem, sc, ocp, cs, checks: dict[str, Check]) -> None:
    """The lockstep for ``STRAIGHT_SAMPLES`` samples with a reference per node and an obstacle margin per stage that
    differ at every stage (``set_reference_stages``, ``set_obstacle_margins``): the C's per-stage paths."""
    v, n, m = stage_probe_inputs(pb)
    sv = RtiSolver(ocp)
    sv.set_reference_stages(v, n)
    sv.set_obstacle_margins(m)
    if cs.init() != 0 or cs.set_reference_stages(v, n) != 0 or cs.set_obstacle_margins(m) != 0:
        raise RuntimeError(f"{pb.name}: init or the per-stage inputs refused")
    probe = _checks(pb.qp.backend)
    short = replace(sc, samples=min(sc.samples, STRAIGHT_SAMPLES))
    run_closed_loop(pb, short, controller=_Lockstep(sv, cs, probe), ocp=ocp)
    _take(checks, probe, (("stage_params", "params"), ("stage_q", "q"), ("stage_u0", "u0")))


def _take(checks: dict[str, Check], probe: dict[str, Check], pairs) -> None:
    """A probe's results into the report's rows: ``checks[key]`` gets ``probe[src]``'s for each ``(key, src)``."""
    for key, src in pairs:
        ch, p = checks[key], probe[src]
        ch.max_diff, ch.sample, ch.compared = p.max_diff, p.sample, p.compared
        ch.envelope, ch.beyond = p.envelope, p.beyond


_SUMMARY_KEYS = (("progress", "progress"), ("collisions", "n_collision_samples"), ("qp_iter_mean", "qp_iter_mean"))


def _closed_loops(
    pb: Problem, sc, ocp, cs, checks: dict[str, Check], rep: VerifyReport, plant: PlantSpec | None = None
) -> None:
    """The independent closed loops (C vs Python, each driving ``plant``), with the reference's rounding envelope
    where they part beyond the tolerance."""
    if cs.init() != 0:
        raise RuntimeError(f"{pb.name}_init() failed")
    log_c = run_closed_loop(pb, sc, controller=cs, ocp=ocp, plant=plant)
    log_py = run_closed_loop(pb, sc, controller=ReferenceController(ocp), ocp=ocp, plant=plant)
    for key, (max_diff, sample, count, compared) in _closed_loop_diffs(log_c, log_py).items():
        ch = checks[key]
        ch.max_diff, ch.sample, ch.count, ch.compared = max_diff, sample, count, compared
    if not all(checks[k].passed for k in CLOSED_LOOP):
        for eps in ENVELOPE_EPS:
            log_e = run_closed_loop(pb, sc, controller=_PerturbedReference(ocp, eps), ocp=ocp, plant=plant)
            for key, d in _closed_loop_diffs(log_e, log_py).items():
                checks[key].envelope = max(checks[key].envelope, d[0])
        rep.notes.append(
            "the closed loops part beyond the tolerance; the reference itself, its measured state changed by a "
            f"relative {', '.join(f'{e:+.0e}' for e in ENVELOPE_EPS)}, parts from its own run by up to the "
            f"'envelope' (this problem amplifies rounding): allowed {ENVELOPE_FACTOR:g}x that"
        )
    s_c, s_py = summary(log_c), summary(log_py)
    rep.extra = {
        f"{key}_{side}": s[src]
        for key, src in (
            ("progress", "progress"),
            ("collisions", "n_collision_samples"),
            ("qp_iter_mean", "qp_iter_mean"),
        )
        for side, s in (("c", s_c), ("python", s_py))
    }


def verify(
    folder: FolderLike,
    scenario: str | None = None,
    seed: int = 0,
    samples: int = 200,
    closed_loop: bool = True,
    build_kw: dict | None = None,
    plant: PlantSpec | None = None,
) -> VerifyReport:
    """Compare the generated C (verification build) with the Python reference on one seeded scenario.

    ``folder``: a :class:`~.solver_folder.SolverFolder` or its path. ``scenario``: ``'car'`` or ``'truck'``; default
    from the problem (``infer_scenario``). ``closed_loop=False`` skips the second comparison (two independent closed
    loops). The report notes the folder's files that differ from what ``fcgen generate`` wrote. ``plant``: the
    closed loops' plant and perturbations (docs/plants.md; the same seeded noise for C and Python).
    """
    folder = as_folder(folder, check=False)  # the sizes checked in the lockstep's terms below, the rest by build
    name, pb = folder.name, folder.problem
    if scenario is None:
        scenario = infer_scenario(pb)
    if samples < 1:
        raise ValueError(f"samples = {samples!r} is invalid: allowed an integer >= 1")
    sc = make_scenario(scenario, seed, n_opp=pb.opponents.count, samples=samples, dt=pb.horizon.dt)
    ocp = build_ocp(pb)
    check_sizes(folder, RtiSolver(ocp))
    cs = CSolver.from_dir(folder, verify=True, **(build_kw or {}))
    rep = VerifyReport(
        solver=name, gen_dir=str(folder.path), problem=pb.name, scenario=scenario, seed=seed, samples=samples
    )
    edits = edits_note(folder.path)
    if edits:
        rep.notes.append(edits)
    checks = _checks(pb.qp.backend)
    log_py = _lockstep(pb, sc, ocp, cs, checks, plant)
    nz = int(log_py.meta["extra"]["exit_codes_nonzero"])
    if any(checks[k].envelope for k in SOLUTION_KEYS):
        rep.notes.append(
            "the lockstep's QP solutions part beyond the tolerance on some samples; there the reference solved that "
            f"QP again with its measured state scaled by 1 {', '.join(f'{e:+.0e}' for e in ENVELOPE_EPS)} and each "
            f"such sample is allowed {ENVELOPE_FACTOR:g}x how far that moved its own solution (its 'envelope')"
        )
    _straight_probe(pb, sc, ocp, cs, checks)
    _stage_probe(pb, sc, ocp, cs, checks)
    if closed_loop:
        _closed_loops(pb, sc, ocp, cs, checks, rep, plant)
    else:
        for k in CLOSED_LOOP:
            del checks[k]
        rep.notes.append("independent closed loops skipped")
    rep.checks = list(checks.values())
    if nz:
        rep.notes.append(f"the Python reference reported a non-zero exit code on {nz} samples")
    for k in ("q", "z"):
        if checks[k].compared < samples:
            rep.notes.append(
                f"{checks[k].description}: compared on {checks[k].compared} of {samples} samples "
                f"(a solver call failed on the others)"
            )
    return rep
