"""The Python reference: SQP real-time iterations (prepare/feedback) on the shared QpLayout, plus converged solves.

It performs exactly the steps the generated C performs, in the same order, with CasADi's functions, scipy sparse
matrices and the QP backend's Python side (``fcgen.backends``), so C and reference can be compared number for number.
The jobs it calls live apart: the QP outcome contract and the iteration caps (``fcgen.qp_outcome``), the plan check
and the a_lat guard after the QP (``fcgen.plan_check``, with the formulas of ``fcgen.reactions``), the hyperplanes'
cold-start guess (``fcgen.hyperplane_guess``).
"""

from __future__ import annotations

import math
import time

import numpy as np

from . import obstacles as obs
from .backends import QP_NONFINITE, QP_STATUSES, QP_USABLE, make_backend
from .contract import EXIT_CODES, INT_MAX, SolverError, Status, reference_outside
from .dsl import QpOptions
from .guess import cold_start_frenet, last_window_s
from .hyperplane_guess import theta_init
from .ocp import Ocp, build_ocp
from .oppfit import STRETCH_MAX, OppFitter
from .plan_check import a_lat_guard, braking_control, lag_constants, plan_verdict
from .plant import DelayLine, plant_function
from .qp import QpLayout, build_layout
from .qp_outcome import (
    COLD_RESTART_NOTE,
    MAX_INPUT_VIOLATION,
    QP_CONTRACT,
    QP_EXIT,
    cold_max_iter,
    input_box,
    project_control,
    warm_max_iter,
)
from .road import Road, band_outside, curve_reference
from .stage_inputs import StageInputsMixin, grow_opponents, margin_terms, stage_xref

__all__ = [
    "COLD_RESTART_NOTE",
    "EXIT_CODES",
    "INT_MAX",
    "MAX_INPUT_VIOLATION",
    "QP_CONTRACT",
    "QP_EXIT",
    "RtiSolver",
    "SolverError",
    "Status",
    "cold_max_iter",
    "input_box",
    "make_reference",
    "project_control",
    "theta_init",
    "warm_max_iter",
]
"""The outcome contract (``fcgen.qp_outcome``) and ``theta_init`` are re-exported: importers read them here, and
feedback() reads MAX_INPUT_VIOLATION from this module's namespace (a test may patch it here)."""


class RtiSolver(StageInputsMixin):
    """SQP-RTI: ``prepare()`` linearizes at the shifted guess, ``feedback()`` embeds x0 and solves one QP.

    The same contract as the generated C (see its header): a rejected call raises :class:`SolverError` and changes
    nothing but ``status.exit_code``; ``prepare()`` while prepared is a no-op; an unusable QP raises with its code
    (``QP_EXIT``; ``ERR_QP_INPUT_BOUNDS`` for a usable one whose u0 is far outside the input box), the step is not
    taken, the plan becomes the prepared (shifted) guess and ``u0()`` is its first control projected on the input box
    (the fallback). After ``qp.cold_restart_after`` unusable QPs in a row the next ``prepare()`` cold-starts
    (:data:`COLD_RESTART_NOTE`).
    """

    def __init__(self, ocp: Ocp, layout: QpLayout | None = None, qp: QpOptions | None = None):
        self.ocp = ocp
        self.lay = layout or build_layout(ocp)
        self.qp_opts = qp or ocp.problem.qp
        N = ocp.N
        hz = ocp.problem.horizon
        self._times = hz.times  # node k's time: s_ref,k = s0 + t_k v_ref (no curve speed)
        self._stage_dt = ocp.stage_dt()  # a stage's interval (unequal grids)
        self._fun_first = ocp.first.fun
        self._fun_mid = ocp.middle.fun.map(N - 1) if N > 1 else None
        self._fun_last = ocp.last.fun
        self._theta_init = theta_init(ocp)
        self._plan_clearance = ocp.plan_clearance.map(N + 1)  # the plan check: every stage in one call
        self._box = input_box(ocp.problem)
        self._plant = plant_function(ocp.problem, ocp.road_params.samples)  # the a_lat guard's step
        self.qp = make_backend(self.lay, self.qp_opts)
        self._fitter = OppFitter(ocp.fit, N + 1, ocp.problem.opponents.count) if ocp.fit else None
        self._margin_terms = margin_terms(ocp)
        self.init()

    def init(self) -> None:
        """Everything back to a freshly constructed solver: inputs, plan, preparation, status, QP backend."""
        self.road: Road | None = None
        self.opp = np.zeros((self.ocp.N + 1, self.ocp.problem.opponents.count * self.ocp.n_opp_par))
        self.opp_shape = self.ocp.default_shapes()  # (n_opp, n_opp_shape): set_opponent_shapes
        self.ref: tuple[np.ndarray, np.ndarray] | None = None  # (v_ref, n_ref) per node; None: the problem's
        self.ref_stages = False  # set by set_reference_stages (s_ref per stage), not set_reference (s0 + t_k v_ref)
        self.margins = np.full(self.ocp.N + 1, self.ocp.problem.obstacle_margin)  # set_obstacle_margins
        # conventional: the opponents' part of the stage parameters, fitted by prepare (private until it commits)
        self.opp_stage = np.zeros((self.ocp.N + 1, self.ocp.problem.opponents.count * self.ocp.n_opp_stage))
        self.x0: np.ndarray | None = None
        self.x_plan: np.ndarray = np.zeros(5)  # where the plan starts: x0, or x0 predicted over Problem.delay samples
        pb = self.ocp.problem  # the actuator's memory: reset keeps it (the plant has those controls)
        self.delay_line = DelayLine(self._plant, pb.delay, self.ocp.nu, lag_constants(pb), pb.horizon.dt)
        self.reset()

    def reset(self) -> None:
        """Forget plan, duals, preparation, status, QP data and backend state; keep the inputs (state, road, opp)."""
        lay = self.lay
        self.w: np.ndarray | None = None  # the plan (None: no guess; the next prepare builds one)
        self.y = np.zeros(lay.m)
        self.w_prep = np.zeros(lay.n)  # the prepared guess (shifted plan or initial guess)
        self.y_prep = np.zeros(lay.m)
        self.prepared = False
        self.cold = False
        self.status = Status()
        self.q, self.q_fb = np.zeros(lay.n), np.zeros(lay.n)
        self.l, self.u, self.g = np.zeros(lay.m), np.zeros(lay.m), np.zeros(lay.m)
        self.A_data = np.zeros(lay.nnz_A)
        self.z: np.ndarray | None = None
        self.s0_guess = 0.0
        self.curve_ref: tuple[list[float], list[float]] | None = None  # (s_ref, v_ref) per node, with s0_guess
        self.u_applied = np.zeros(self.ocp.nu)
        self.stage_clearance = np.full(self.ocp.N + 1, math.inf)  # the plan check's, per stage (verify)
        self.qp.reset()

    def _fail(self, code: str, message: str) -> SolverError:
        self.status.exit_code = EXIT_CODES.index(code)
        return SolverError(code, message)

    # -- inputs -----------------------------------------------------------------------------------
    def set_road(self, road: Road) -> None:
        """The road (window); its drivable band ``road.n_min``/``n_max`` (if given) must lie within the problem's
        ``Bounds`` (the C: set_road, then set_road_bounds)."""
        if road.size > self.ocp.problem.road.samples:
            raise self._fail(
                "ERR_ROAD_SIZE", f"road window has {road.size} samples; allowed at most {self.ocp.problem.road.samples}"
            )
        outside = band_outside(road, self.ocp.problem.bounds)
        if outside:
            raise self._fail("ERR_ROAD_BOUNDS", outside)
        self.road = road
        self.status.exit_code = 0  # an accepted call (the C's ok())

    def set_reference(self, v_ref: float, n_ref: float) -> None:
        """The tracking reference's speed and lateral offset from now on (``init``: the problem's ``Reference``):
        a road's speed limit, a lane's centre."""
        b, n = self.ocp.problem.bounds, self.ocp.N + 1
        if why := reference_outside(v_ref, n_ref, b.n_min, b.n_max):
            raise self._fail("ERR_REFERENCE", why)
        self.ref, self.ref_stages = (np.full(n, float(v_ref)), np.full(n, float(n_ref))), False
        self.status.exit_code = 0  # an accepted call (the C's ok())

    def set_opponent_shapes(self, shapes: np.ndarray) -> None:
        """Every opponent's shape values, shape (n_opp, n_opp_shape) (``obstacles.shape_names``); kept until set
        again (``init`` restores the problem's opponent vehicle)."""
        shapes = np.asarray(shapes, dtype=float)
        ocp = self.ocp
        want = (ocp.problem.opponents.count, ocp.n_opp_shape)
        if shapes.shape != want:
            raise self._fail("ERR_OPP_SHAPE", f"opponent shapes: shape {shapes.shape}, expected {want}")
        for j, v in enumerate(shapes):
            try:
                obs.check_opponent_shape(ocp.problem.obstacles, ocp.problem.ego, v)
            except ValueError as e:
                raise self._fail("ERR_OPP_SHAPE", f"opponent {j}: {e}") from None
        self.opp_shape = shapes.copy()
        self.status.exit_code = 0  # an accepted call (the C's ok())

    def set_opponents(self, params: np.ndarray) -> None:
        """Per-stage opponent parameters, shape (N+1, n_opp, n_opp_par)."""
        params = np.asarray(params, dtype=float)
        n_opp = self.ocp.problem.opponents.count
        if params.shape != (self.ocp.N + 1, n_opp, self.ocp.n_opp_par):
            raise self._fail(
                "ERR_NONFINITE_OPPONENTS",
                f"opponents: shape {params.shape}, expected {(self.ocp.N + 1, n_opp, self.ocp.n_opp_par)}",
            )
        if not np.all(np.isfinite(params)):
            raise self._fail("ERR_NONFINITE_OPPONENTS", "opponents: NaN or infinite pose")
        self.opp = params.reshape(self.ocp.N + 1, -1)
        self.status.exit_code = 0  # an accepted call (the C's ok())

    def set_state(self, x0) -> None:
        x0 = np.asarray(x0, dtype=float)
        if x0.shape != (5,) or not np.all(np.isfinite(x0)):
            raise self._fail("ERR_NONFINITE_STATE", "state: expected 5 finite values [s, n, alpha, v, delta]")
        self.x0 = x0
        self.status.exit_code = 0  # an accepted call (the C's ok())

    # -- parameters --------------------------------------------------------------------------------
    def _window_start(self, road: Road, s: float) -> int | None:
        """First road sample of the stage window around s (the C window_start), or None if the road does not cover
        it (``s`` finite)."""
        i0 = math.floor((s - road.s0) / road.ds) - 1
        return i0 if i0 >= 0 and i0 + self.ocp.road_params.samples <= road.size else None

    def _road_params(self, s: float) -> np.ndarray:
        road = self.road
        if road is None:
            raise self._fail("ERR_ROAD_WINDOW", "road window not set")
        if not math.isfinite(s):
            raise self._fail("ERR_ROAD_WINDOW", "non-finite s in the guess")
        i0 = self._window_start(road, s)
        if i0 is None:
            raise self._fail(
                "ERR_ROAD_WINDOW", f"road window [{road.s0:.1f}, {road.s_end:.1f}] does not cover s = {s:.1f}"
            )
        return self.ocp.road_params.pack(road, i0)

    def _set_curve_speed(self) -> None:
        """The reference along the horizon capped by the curve speed (``Reference.curve_a_lat``,
        ``road.curve_reference``; None when off or without a road); with traffic near the plan (the last plan check's
        clearance) at ``curve_a_lat_traffic``."""
        pb = self.ocp.problem
        ref, bnd = pb.reference, pb.bounds
        self.curve_ref = None
        if ref.curve_a_lat > 0.0 and self.road is not None:
            traffic = ref.curve_traffic_clearance > 0.0 and self.status.plan_clearance < ref.curve_traffic_clearance
            a_lat = ref.curve_a_lat_traffic if traffic else ref.curve_a_lat
            v_set = self.ref[0] if self.ref is not None else np.full(self.ocp.N + 1, ref.v_ref)
            s0, along = float(self.s0_guess), ref.curve_along_horizon
            self.curve_ref = curve_reference(
                self.road, s0, self._times, v_set, a_lat, ref.curve_decel, bnd.v_max, along, self.ref_stages
            )

    def stage_params(self, k: int, s: float) -> np.ndarray:
        return np.concatenate([self._road_params(s), self._stage_rest(k)])

    def _stage_rest(self, k: int) -> np.ndarray:
        ocp, default = self.ocp, (self.ocp.problem.reference.v_ref, self.ocp.problem.reference.n_ref)
        xref = stage_xref(k, self.s0_guess, self._times, self.ref, self.ref_stages, default, self.curve_ref)
        if self._fitter is None:  # per opponent its pose at stage k, then its shape
            n = ocp.problem.opponents.count
            opp = np.concatenate([self.opp[k].reshape(n, -1), self.opp_shape], axis=1).ravel()
        else:
            opp = self.opp_stage[k]
        opp = grow_opponents(opp, ocp.n_opp_stage, self._margin_terms, float(self.margins[k]))
        dt = [] if self.ocp.p_dt is None else [self._stage_dt[k]]
        return np.concatenate([xref, opp, dt])

    def _fit_opponents(self) -> int:
        """Conventional: the opponents' poses -> their fitted Frenet boxes in ``opp_stage`` (``fcgen.oppfit``), as the
        C does; returns how many (stage, opponent) pairs were left out (0 for the other formulations)."""
        if self._fitter is None:
            return 0
        if self.road is None:
            raise self._fail("ERR_ROAD_WINDOW", "road window not set")
        out, outside, singular = self._fitter(self.road, self.opp.reshape(self.ocp.N + 1, -1, 3), self.opp_shape)
        if singular:
            k, j = singular[0]
            raise self._fail(
                "ERR_OPP_FRENET",
                f"opponent {j} at stage {k} cannot be mapped into the Frenet frame "
                f"(|n| kappa >= {STRETCH_MAX} next to it, or a point too far from the road)",
            )
        self.opp_stage = out
        return outside

    @staticmethod
    def _stage(w: np.ndarray, lay: QpLayout, k: int) -> np.ndarray:
        return w[lay.var_off[k] : lay.var_off[k + 1]]

    def _stage_w(self, k: int, w: np.ndarray | None = None) -> np.ndarray:
        w = self.w if w is None else w
        assert w is not None, "no plan yet"
        return self._stage(w, self.lay, k)

    # -- initial guess -----------------------------------------------------------------------------
    def initial_guess(self) -> tuple[np.ndarray, np.ndarray]:
        """The cold-start guess (``fcgen.guess``): the road-following Frenet plan, lifted by ``init_state`` on each
        stage's road window; hyperplanes between ego and opponents; zero inputs, slacks, duals."""
        if self.x0 is None:
            raise self._fail("ERR_NO_STATE", "state not set before the first prepare")
        ocp, lay = self.ocp, self.lay
        w = np.zeros(lay.n)
        self.s0_guess = self.x0[0]
        self._set_curve_speed()
        self.stage_params(0, self.x0[0])  # no road or x0 off it: ERR_ROAD_WINDOW before anything else
        assert self.road is not None  # stage_params checked it
        s_last = last_window_s(self.road, ocp.road_params.samples)
        xf = cold_start_frenet(self.x0, list(ocp.problem.horizon.times), s_last)
        for k in range(ocp.N + 1):
            o = lay.var_off[k]
            p = self.stage_params(k, xf[k, 0])
            x = np.array(ocp.init_state(xf[k], p)).ravel()
            w[o : o + ocp.nx] = x
            if k >= 1 and ocp.n_theta:
                w[o + ocp.nx + ocp.nu * (k < ocp.N) :][: ocp.n_theta] = np.array(self._theta_init(x, p)).ravel()
        return w, np.zeros(lay.m)

    # -- the two phases -----------------------------------------------------------------------------
    def prepare(self, shift: bool = True) -> None:
        """Shift the plan (or build the guess), linearize, build the QP, load the backend; transactional (fit too)."""
        if self.prepared:
            self.status.exit_code = 0  # an accepted call (the C's ok())
            return
        kept = self.opp_stage
        try:
            self._prepare(shift, time.perf_counter())
        except SolverError as e:
            self.opp_stage = self.opp_stage if e.code == "ERR_QP_NUMERICAL" else kept
            raise

    def _prepare(self, shift: bool, t0: float) -> None:
        ocp, lay = self.ocp, self.lay
        opp_outside = self._fit_opponents()
        K = self.qp_opts.cold_restart_after
        restart = self.w is not None and K > 0 and self.status.qp_unusable_run >= K
        cold = self.w is None or restart
        if cold:
            w, y = self.initial_guess()
        elif self.w is None or self.y is None:
            raise AssertionError("a warm prepare without a plan")
        elif shift:
            w, y = lay.shift_vars(self.w), lay.shift_duals(self.y)
        else:
            w, y = self.w.copy(), self.y.copy()
        N = ocp.N
        self.s0_guess = w[lay.s_vars[0]]
        self._set_curve_speed()
        P = np.stack([self.stage_params(k, w[lay.s_vars[k]]) for k in range(N + 1)], axis=1)
        Xn = np.stack([w[lay.var_off[k + 1] : lay.var_off[k + 1] + ocp.nx] for k in range(N)], axis=1)
        outs = [self._fun_first(self._stage(w, lay, 0), Xn[:, 0], P[:, 0])]
        if self._fun_mid is not None:  # N > 1
            Wm = np.stack([self._stage(w, lay, k) for k in range(1, N)], axis=1)
            outs.append(self._fun_mid(Wm, Xn[:, 1:], P[:, 1:N]))
        outs.append(self._fun_last(self._stage(w, lay, N), np.zeros(ocp.nx), P[:, N]))
        g = np.concatenate([np.array(out[0]).ravel(order="F") for out in outs])
        jac = np.concatenate([np.array(out[1].nonzeros()) for out in outs])
        q = np.concatenate([np.array(out[2]).ravel(order="F") for out in outs])
        if not (np.all(np.isfinite(g)) and np.all(np.isfinite(jac)) and np.all(np.isfinite(q))):
            raise self._fail("ERR_QP_NONFINITE", "non-finite linearization (constraints, Jacobian or cost)")
        # commit
        self.w_prep, self.y_prep, self.g, self.q, self.cold = w, y, g, q, cold
        self.P = P.T  # the stage parameters (verification: the C get_opp_params)
        self.A_data = jac[lay.a_src]
        self.l = lay.L - g
        self.u = lay.U - g
        road = self.road
        assert road is not None  # stage_params checked it
        if road.n_min is not None:  # the road's band at each stage's s (held for the QP: no d/ds)
            for (row, k, side), ds in zip(lay.band_rows, lay.band_ds, strict=True):
                band = road.band_at(float(w[lay.s_vars[k]]) + float(ds))
                assert band is not None
                (self.l if side == 0 else self.u)[row] = band[side] / lay.band_scale - g[row]
        if restart:  # as reset() would: the backend restored before its use
            self.qp.reset()
        self.qp.set_matrices(lay.P_diag, self.A_data, self.q)
        self.prepared = True
        st = self.status
        self.status = Status(
            time_prepare=time.perf_counter() - t0,
            u_projected=st.u_projected,
            u_violation=st.u_violation,
            opp_outside=opp_outside,
            plan_clearance=st.plan_clearance,
            plan_clearance_stage=st.plan_clearance_stage,
            plan_reaction=st.plan_reaction,
            qp_unusable_run=0 if restart else st.qp_unusable_run,
            cold_restarts=min(st.cold_restarts + int(restart), INT_MAX),
        )

    def feedback(self) -> np.ndarray:
        """Embed the measured x0, solve the QP, take the full step (usable QP) or fall back; returns the control."""
        t0 = time.perf_counter()
        if not self.prepared:
            raise self._fail("ERR_NOT_PREPARED", "feedback called before prepare")
        if self.x0 is None:
            raise self._fail("ERR_NO_STATE", "state not set")
        ocp, lay = self.ocp, self.lay
        self.x_plan = self.delay_line.predict(self.x0, self._road_params)  # x0 itself without a delay
        if not np.all(np.isfinite(self.x_plan)):
            raise self._fail("ERR_NONFINITE_STATE", "the delay compensation's prediction is not finite")
        p0 = self.stage_params(0, self.x_plan[0])
        x0_full, q, cap = self.embedding(self.x_plan, p0)
        if not (np.all(np.isfinite(x0_full)) and np.all(np.isfinite(q))):
            raise self._fail("ERR_NONFINITE_STATE", "the state gives a non-finite QP (embedding or cost)")
        # commit: the sample is consumed
        ir = lay.init_rows
        self.l[ir] = x0_full / lay.D[: ocp.nx] - self.g[ir]
        self.u[ir] = self.l[ir]
        self.q_fb = q
        self.prepared = False
        res = self.qp.solve(q, self.l, self.u, self.y_prep, cap)
        qs = res.status
        if res.z is not None:
            self.z = res.z
        if qs in QP_USABLE and (
            res.z is None or res.y is None or not np.all(np.isfinite(res.z)) or not np.all(np.isfinite(res.y))
        ):
            qs = QP_NONFINITE
        st = self.status
        st.qp_status, st.qp_raw_status, st.qp_iter = qs, res.raw_status, res.iter
        code = QP_EXIT.get(qs, "ERR_QP")
        if code == "OK":
            self.w = self.w_prep + lay.D * res.z
            if project_control(self.w[lay.var_off[0] + ocp.nx :][: ocp.nu], *self._box)[1] > MAX_INPUT_VIOLATION:
                code = "ERR_QP_INPUT_BOUNDS"  # a usable status, but the step is far outside the input box
        if code == "OK" and res.y is not None:  # (a usable status has y: else QP_NONFINITE above)
            self.y = res.y
        else:  # the step is not taken: the plan becomes the prepared (shifted) guess
            self.w, self.y = self.w_prep.copy(), self.y_prep.copy()
        assert self.w is not None
        self.u_applied, st.u_violation = project_control(self.w[lay.var_off[0] + ocp.nx :][: ocp.nu], *self._box)
        st.u_projected = int(st.u_violation > 0.0)
        self._a_lat_guard(st, p0[ocp.p_road])
        self._plan_check(st)
        self.delay_line.push(self.u_applied)
        st.exit_code = EXIT_CODES.index(code)
        st.qp_unusable_run = 0 if code == "OK" else min(st.qp_unusable_run + 1, INT_MAX)
        st.time_feedback = time.perf_counter() - t0
        if code != "OK":
            why = ", u0 far outside the input box" if code == "ERR_QP_INPUT_BOUNDS" else ""
            raise SolverError(
                code,
                f"QP unusable ({QP_STATUSES[qs - 1] if qs else 'none'}, raw status "
                f"{res.raw_status}{why}): step not taken, fallback control",
            )
        return self.u0()

    def embedding(self, x: np.ndarray, p0: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray, int]:
        """``feedback``'s QP data for the measured state x (stage parameters p0 if known): x lifted, q, the cap."""
        x0_full = np.array(self.ocp.init_state(x, self.stage_params(0, x[0]) if p0 is None else p0)).ravel()
        cap = cold_max_iter(self.qp_opts) if self.cold else warm_max_iter(self.qp_opts)
        return x0_full, self.q + self.lay.q_ds0 * (x[0] - self.s0_guess), cap

    def _a_lat_guard(self, st: Status, p_road: np.ndarray) -> None:
        """The a_lat guard on get_u0 (``plan_check.a_lat_guard``) with the plant's step from the plan's start."""
        lo, hi = float(self._box[0][1]), float(self._box[1][1])
        slack = max(float(np.max(self.slacks())), 0.0)  # the C's max_slack(): a NaN stays NaN
        step = lambda: self._plant_step(p_road)  # noqa: E731
        f_last, lag = self.delay_line.f_last, self.delay_line.lag_plan
        st.a_lat_guard = a_lat_guard(self.ocp.problem, self.x_plan, self.u_applied, lo, hi, step, slack, f_last, lag)

    def _plant_step(self, p_road: np.ndarray) -> list[float]:
        """The plant's state one sample after the plan's start under get_u0 (the C's ``<name>_plant``), its steering
        rate through the steering lag (``Problem.steer_lag``)."""
        u = self.delay_line.applied(self.u_applied)
        return np.array(self._plant(self.x_plan, u, p_road)).ravel().tolist()

    def _plan_check(self, st: Status) -> None:
        """The plan's clearances (``plan_clearances``), their verdict (``plan_verdict``), braking where it says so."""
        ocp, pb = self.ocp, self.ocp.problem
        best, best_k, react = math.inf, -1, False
        if pb.opponents.count:
            C, A = self.plan_clearances()
            self.stage_clearance = np.min(C, axis=0)
            best, best_k, react = plan_verdict(C, A, [True] * (ocp.N + 1), min(pb.plan_check.react_stages, ocp.N))
        st.plan_clearance, st.plan_clearance_stage, st.plan_reaction = best, best_k, int(react)
        if react:
            self.u_applied[0] = braking_control(pb, self.x_plan)

    def plan_clearances(self, w: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
        """Each opponent's clearance to the plan (or the iterate ``w``) and its ``ahead``, (n_opp, N + 1) each
        (``Ocp.plan_clearance`` on the road the preparation planned with, ``self.P``; ``states(w)`` likewise)."""
        ocp = self.ocp
        P = np.stack([np.concatenate([self.P[k][ocp.p_road], self._stage_rest(k)]) for k in range(ocp.N + 1)], 1)
        shape = np.tile(self.opp_shape.reshape(-1, 1), (1, ocp.N + 1))
        C, A = self._plan_clearance(self.states(w).T, P, self.opp.T, shape)
        return np.array(C), np.array(A)

    # -- outputs ------------------------------------------------------------------------------------
    def u0(self) -> np.ndarray:
        """The control to apply (the C get_u0): the plan's u0 projected on the input box; zeros before any."""
        return self.u_applied.copy()

    def states(self, w: np.ndarray | None = None) -> np.ndarray:
        return np.stack([self._stage_w(k, w)[: self.ocp.nx] for k in range(self.ocp.N + 1)])

    def controls(self, w: np.ndarray | None = None) -> np.ndarray:
        return np.stack([self._stage_w(k, w)[self.ocp.nx : self.ocp.nx + self.ocp.nu] for k in range(self.ocp.N)])

    def slacks(self, w: np.ndarray | None = None) -> np.ndarray:
        return np.stack([self._stage_w(k, w)[-self.ocp.n_sigma :] for k in range(1, self.ocp.N + 1)])

    def step(self, x0) -> np.ndarray:
        """One RTI sample: prepare (first time with the given state), then feedback with it."""
        if self.w is None:
            self.set_state(x0)
        self.prepare()
        self.set_state(x0)
        return self.feedback()

    def solve_converged(self, x0, max_sqp: int = 100, tol: float = 1e-9) -> int:
        """Iterate SQP (no shift) at a fixed x0 until the step is below tol; returns the iteration count."""
        self.set_state(x0)
        for it in range(1, max_sqp + 1):
            self.prepare(shift=False)
            self.feedback()
            if self.z is not None and np.max(np.abs(self.z)) < tol:
                return it
        return max_sqp


def make_reference(problem) -> RtiSolver:
    """Build the OCP, layout and reference solver of a problem."""
    return RtiSolver(build_ocp(problem))
