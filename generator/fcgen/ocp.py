"""A formulation assembled: stage variables, scaled constraint rows, costs and per-stage parameters as CasADi functions.

Stage k holds the variables ``[x_k, u_k, theta_k, sigma_k]`` (no u at N, no theta/sigma at 0). Each stage function
maps ``(w_k, x_{k+1}, p_k)`` to its rows ``g`` (scaled, so the QP row is ``J z in [L - g, U - g]``), the Jacobian
``J`` of ``g`` with respect to the *scaled* variables ``z = (w - w_guess) / D`` of stage k and ``x_{k+1}``, and the
scaled cost gradient ``q``. The QP Hessian is constant (Gauss-Newton of a linear least-squares cost).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import casadi as ca
import numpy as np

from . import models
from . import obstacles as obs
from .drive_rows import drive_rows
from .dsl import Conventional, Lifted, Problem
from .oppfit import OppFit, build_oppfit
from .road import RoadWindowParams, casadi_road, casadi_to_cartesian
from .road_rows import BAND_SCALE, road_rows

INF = 1e30  # OSQP_INFTY: OSQP treats bounds at or beyond it as infinite

# Typical ranges: the QP is solved in variables divided by these (SPEC section 8: scaling matters most).
STATE_SCALE = {"s": 10.0, "n": BAND_SCALE, "alpha": 0.5, "v": 10.0, "delta": 0.3, "x": 10.0, "y": 10.0, "phi": 0.5}
CONTROL_SCALE = {"F_d": 1e4, "r": 0.39}


@dataclass(frozen=True)
class StageType:
    """One of the three stage shapes: first (k = 0), middle (1..N-1), last (N)."""

    name: str
    var_names: tuple[str, ...]
    row_names: tuple[str, ...]
    L: np.ndarray
    U: np.ndarray
    D: np.ndarray  # variable scale of w_k
    P_diag: np.ndarray  # constant scaled Hessian diagonal of w_k
    q_ds0: np.ndarray  # d q / d s0 (the s-reference moves with the measured s0)
    fun: ca.Function  # (w, x_next, p) -> (g, J, q)
    jac_sparsity: ca.Sparsity

    @property
    def nw(self) -> int:
        return len(self.var_names)

    @property
    def nrows(self) -> int:
        return len(self.row_names)


@dataclass(frozen=True)
class Ocp:
    """Everything the reference and the code generator need to know about one problem."""

    problem: Problem
    state_kind: str
    nx: int
    nu: int
    n_theta: int
    n_sigma: int
    road_params: RoadWindowParams
    n_opp_par: int  # per opponent and stage given to set_opponents: its pose [x, y, phi]
    n_opp_stage: int  # per opponent in a stage's parameters (pose + shape; conventional: the fitted
    #                            FRENET_SHAPE)
    n_opp_shape: int  # per opponent given to set_opponent_shapes (obstacles.shape_names)
    np_stage: int
    cost_scale: float
    first: StageType
    middle: StageType
    last: StageType
    dynamics: ca.Function  # (x, u, p) -> x_next: one RK4 step (shift, plant, tests)
    init_state: ca.Function  # (x0 Frenet, p) -> x_0 of the formulation (lifted: append F^-1)
    a_lat: ca.Function  # (x) -> lateral acceleration
    plan_clearance: ca.Function  # (x, p, opp poses) -> per opponent the SAT clearance (plan check)
    cost: tuple = field(default=())  # (first, middle, last) unscaled cost functions (w, p) -> J, for IPOPT
    fit: OppFit | None = None  # conventional: the prepare phase's opponent fit (pose -> FRENET_SHAPE)

    @property
    def N(self) -> int:
        return self.problem.horizon.N

    @property
    def dt(self) -> float:
        """The sample time (s)."""
        return self.problem.horizon.dt

    @property
    def interval(self) -> float:
        """The (first) shooting interval (s), which weighs the stages' costs (``Horizon.interval``)."""
        return self.problem.horizon.interval

    def stage(self, k: int) -> StageType:
        return self.first if k == 0 else self.last if k == self.N else self.middle

    # -- parameter vector of one stage: [road window | x_ref (5) | opponents] --------------------
    @property
    def p_road(self) -> slice:
        return slice(0, self.road_params.size)

    @property
    def p_ref(self) -> slice:
        return slice(self.road_params.size, self.road_params.size + 5)

    @property
    def p_opp(self) -> slice:
        start = self.road_params.size + 5
        return slice(start, start + self.problem.opponents.count * self.n_opp_stage)

    @property
    def p_dt(self) -> int | None:
        """Index of the stage's interval length in its parameters (a grid of unequal intervals; else None)."""
        return None if self.problem.horizon.uniform else self.np_stage - 1

    def stage_dt(self) -> list[float]:
        """The value at ``p_dt`` of stages 0..N: each interval's length (s), 0 at the last stage (no dynamics)."""
        hz = self.problem.horizon
        return [m * hz.dt for m in hz.stage_samples] + [0.0]

    def default_shapes(self) -> np.ndarray:
        """Every opponent's shape values until ``set_opponent_shapes``: the problem's opponent vehicle at a rear-axle
        pose, shape (n_opp, n_opp_shape)."""
        pb = self.problem
        one = obs.vehicle_shape(pb.obstacles, pb.ego, pb.opponents.vehicle)
        return np.tile(one, (pb.opponents.count, 1))


def road_window_samples(problem: Problem) -> int:
    """Samples of the per-stage local road window: from one ds behind s_k to twice the farthest RK4 reach."""
    reach = 2.0 * problem.bounds.v_max * problem.horizon.max_interval
    return math.ceil((reach + 2 * problem.road.ds) / problem.road.ds) + 1


@dataclass(frozen=True, eq=False)
class _Stage:
    """The symbols of a stage and the sizes and scales they follow from: what the parts of ``build_ocp`` share."""

    kind: str  # the state representation: "lifted" or "frenet"
    lifted: bool
    conventional: bool
    nx: int
    nu: int
    n_opp: int
    n_theta: int
    n_sigma: int
    n_obs_rows: int
    n_shape: int
    n_opp_stage: int
    np_stage: int
    uniform: bool
    dt: float  # the (first) shooting interval: the costs' weight, the uniform grid's step
    rp: RoadWindowParams
    xs: ca.SX
    us: ca.SX
    ths: ca.SX
    sgs: ca.SX
    xn: ca.SX
    p: ca.SX
    Dx: np.ndarray
    Du: np.ndarray
    Dth: np.ndarray
    Dsg: np.ndarray

    @property
    def names_x(self) -> tuple[str, ...]:
        return models.STATE_NAMES[self.kind]

    @property
    def p_road(self) -> ca.SX:
        return self.p[0 : self.rp.size]

    @property
    def xref(self) -> ca.SX:
        return self.p[self.rp.size : self.rp.size + 5]

    @property
    def p_opp(self) -> ca.SX:
        return self.p[self.rp.size + 5 : self.rp.size + 5 + self.n_opp * self.n_opp_stage]


def _stage_symbols(pb: Problem) -> _Stage:
    """The sizes of a problem's stages, their CasADi symbols and the variables' scales."""
    form, model = pb.formulation, pb.obstacles
    lifted, conventional = isinstance(form, Lifted), isinstance(form, Conventional)
    kind = "lifted" if lifted else "frenet"
    nx, nu = models.NX[kind], models.NU
    n_opp = pb.opponents.count
    n_theta = n_opp * obs.thetas_per_opponent(model)
    # slacks: a_lat, (road), obstacles
    n_obs_rows = n_opp * obs.rows_per_opponent(model)
    n_sigma = 1 + (1 if pb.soft.soft_road else 0) + n_obs_rows
    rp = RoadWindowParams(road_window_samples(pb))
    n_shape = len(obs.shape_names(model))
    n_opp_stage = len(obs.FRENET_SHAPE) if conventional else len(obs.CARTESIAN_POSE) + n_shape
    uniform = pb.horizon.uniform
    np_stage = rp.size + 5 + n_opp * n_opp_stage + (0 if uniform else 1)  # [road | x_ref | opponents | (interval)]
    return _Stage(
        kind,
        lifted,
        conventional,
        nx,
        nu,
        n_opp,
        n_theta,
        n_sigma,
        n_obs_rows,
        n_shape,
        n_opp_stage,
        np_stage,
        uniform,
        pb.horizon.interval,
        rp,
        ca.SX.sym("x", nx),
        ca.SX.sym("u", nu),
        ca.SX.sym("theta", n_theta),
        ca.SX.sym("sigma", n_sigma),
        ca.SX.sym("x_next", nx),
        ca.SX.sym("p", np_stage),
        np.array([STATE_SCALE[n] for n in models.STATE_NAMES[kind]]),
        np.array([CONTROL_SCALE[n] for n in models.CONTROL_NAMES]),
        np.ones(n_theta),
        np.ones(n_sigma),
    )


def _dynamics(pb: Problem, st: _Stage) -> ca.SX:
    """x_{k+1} of one RK4 step of the formulation's ODE on the stage's road window (a non-uniform grid: the
    interval from the stage's parameters)."""
    p_road = st.p_road

    def road(s):
        kappa, phi_g, *_ = casadi_road(s, p_road, st.rp.samples)
        return kappa, phi_g

    f = models.ode(st.kind, road, pb.ego, pb.wind)
    return models.rk4(f, st.xs, st.us, st.dt if st.uniform else st.p[st.np_stage - 1])


def _a_lat_and_road_rows(pb: Problem, st: _Stage, a: ca.SX) -> list[tuple]:
    """The soft rows of the lateral acceleration (inside ``a_lat_max - a_lat_margin``, slack 0) and the road's rows
    (``road_rows``: with ``soft_road`` on slack 1)."""
    bnd, xs, sgs = pb.bounds, st.xs, st.sgs
    lim = (bnd.a_lat_max - bnd.a_lat_margin) / bnd.a_lat_max  # the planned bound (1.0 without a margin)
    rows = [
        ("a_lat_lo", (a + sgs[0]) / bnd.a_lat_max, -lim, INF),
        ("a_lat_hi", (a - sgs[0]) / bnd.a_lat_max, -INF, lim),
    ]
    if bnd.road_bound != "corners":
        return rows + road_rows(pb, xs[1], xs[2], sgs[1] if pb.soft.soft_road else None, 0.0)

    def kappa_at(d):  # the road's curvature d metres ahead of the rear axle's s
        return casadi_road(xs[0] + d, st.p_road, st.rp.samples)[0]

    sigma = sgs[1] if pb.soft.soft_road else None
    return rows + road_rows(pb, xs[1], xs[2], sigma, kappa_at(0.0), kappa_at)


def _ego_pose(st: _Stage) -> tuple[Any, Any, Any]:
    """The ego's pose the obstacle rows use: (s, n, alpha) for the conventional formulation, else [x, y, phi] (the
    lifted states, or F^-1 on the stage's road window)."""
    xs = st.xs
    if st.conventional:
        return (xs[0], xs[1], xs[2])
    if st.lifted:
        return (xs[5], xs[6], xs[7])
    return casadi_to_cartesian(xs[0], xs[1], xs[2], st.p_road, st.rp.samples)


def _obstacle_rows(pb: Problem, st: _Stage, first_slack: int) -> tuple[list[tuple], list[tuple], list]:
    """Per opponent the obstacle model's soft rows (one slack each, from ``first_slack``), its equality rows (the
    hyperplanes' norm) and the midpoint plane that anchors its hyperplane variables (the safe profile)."""
    ego, model, conventional = pb.ego, pb.obstacles, st.conventional
    ego_pose = _ego_pose(st)
    p_opp, ths, sgs = st.p_opp, st.ths, st.sgs
    soft_rows, eq_rows = [], []
    theta_mid: list = []  # per opponent the plane halfway between the centres (the anchor of the safe profile)
    isg = first_slack
    for j in range(st.n_opp):
        pj = p_opp[j * st.n_opp_stage : (j + 1) * st.n_opp_stage]
        axes = None
        if conventional:
            opp = obs.Shape(pj[0], pj[1], pj[2], pj[3], pj[4])
            ego_sh = obs.frenet_ego_shape(*ego_pose, pj[5], ego)
        else:
            opp = obs.shape_of(pj[0], pj[1], pj[2], pj[3:])
            ego_sh = obs.chassis_shape(*ego_pose, ego)
            if st.n_shape > len(obs.OPP_SHAPE):
                axes = (pj[6], pj[7])
        th = ths[3 * j : 3 * j + 3] if st.n_theta else None
        if st.n_theta:
            mid_sh = obs.frenet_ego_shape(*ego_pose, 1.0, ego) if conventional else ego_sh
            theta_mid += obs.midpoint_plane(mid_sh, opp)
        rows, eqs = obs.constraint_rows(model, ego_sh, opp, th, cover=conventional, length=ego.l_ch, axes=axes)
        for r_i, h in enumerate(rows):
            soft_rows.append((f"opp{j}_h{r_i}", h + sgs[isg], 0.0, INF))
            isg += 1
        for e in eqs:
            eq_rows.append((f"opp{j}_hp_norm", e, 0.0, 0.0))
    assert isg == st.n_sigma
    return soft_rows, eq_rows, theta_mid


def _box_rows(pb: Problem, st: _Stage, x_next: ca.SX) -> dict[str, list[tuple]]:
    """The one-variable rows (state bounds at stages 1..N-1 and N, input and slack bounds), the dynamics rows and the
    init rows, scaled: (name, g, lower, upper)."""
    bnd, xs, us, sgs = pb.bounds, st.xs, st.us, st.sgs
    Dx, Du, Dsg = st.Dx, st.Du, st.Dsg
    soft_road, corners = pb.soft.soft_road, bnd.road_bound == "corners"

    def state_bounds(terminal: bool):
        out = []
        for i, nm in enumerate(st.names_x):
            lo, hi = {
                "n": (bnd.n_min, bnd.n_max) if not (soft_road or corners) else None,
                "alpha": (-bnd.alpha_max, bnd.alpha_max),
                "v": (bnd.v_min, bnd.v_N_max if terminal else bnd.v_max),
                "delta": (-bnd.delta_max, bnd.delta_max),
            }.get(nm) or (None, None)
            if lo is not None:
                out.append((f"bound_{nm}", xs[i] / Dx[i], lo / Dx[i], hi / Dx[i]))
        return out

    return {
        "state": state_bounds(False),
        "state_N": state_bounds(True),
        "u": [
            (f"bound_{nm}", us[i] / Du[i], -lim / Du[i], lim / Du[i])
            for i, (nm, lim) in enumerate(zip(models.CONTROL_NAMES, (bnd.F_d_max, bnd.r_max)))
        ],
        "sigma": [(f"bound_sigma{i}", sgs[i] / Dsg[i], 0.0, INF) for i in range(st.n_sigma)],
        "dyn": [(f"dyn_{nm}", (x_next[i] - st.xn[i]) / Dx[i], 0.0, 0.0) for i, nm in enumerate(st.names_x)],
        "init": [(f"init_{nm}", xs[i] / Dx[i], 0.0, 0.0) for i, nm in enumerate(st.names_x)],
    }


def _costs(pb: Problem, st: _Stage) -> dict[str, ca.SX]:
    """The unscaled least-squares costs: tracking of stages 0..N-1 and of N, inputs, slacks (L1 + L2 per slack);
    stage weights times the interval."""
    w, soft, dt = pb.weights, pb.soft, st.dt
    q_stage = np.array(w.q) * dt
    r_stage = np.array(w.r) * dt
    road_l1, road_l2 = ([soft.road_l1], [soft.road_l2]) if soft.soft_road else ([], [])
    l1 = np.array([soft.a_lat_l1] + road_l1 + [soft.obstacle_l1] * st.n_obs_rows) * dt
    l2 = np.array([soft.a_lat_l2] + road_l2 + [soft.obstacle_l2] * st.n_obs_rows) * dt
    ex = st.xs[0:5] - st.xref
    return {
        "track": ca.sum1(q_stage * ex * ex),
        "track_N": ca.sum1(np.array(w.q_N) * ex * ex),
        "u": ca.sum1(r_stage * st.us * st.us),
        "sigma": ca.sum1(l1 * st.sgs + l2 * st.sgs * st.sgs),
    }


def _stage_specs(
    st: _Stage, soft_rows: list, eq_rows: list, box: dict, cost: dict, drive: dict[str, list]
) -> dict[str, tuple]:
    """Per stage shape (first, middle, last): its variables, its row groups in order, its cost, its variables'
    scales and names (``drive``: the drive rows on (x, u), none at N)."""
    xs, us, ths, sgs = st.xs, st.us, st.ths, st.sgs
    names_u = list(models.CONTROL_NAMES)
    names_th = [f"theta{i}" for i in range(st.n_theta)]
    names_sg = [f"sigma{i}" for i in range(st.n_sigma)]
    return {
        "first": (
            ca.vertcat(xs, us),
            [box["init"], box["dyn"], drive["first"], box["u"]],
            cost["track"] + cost["u"],
            np.r_[st.Dx, st.Du],
            list(st.names_x) + names_u,
        ),
        "middle": (
            ca.vertcat(xs, us, ths, sgs),
            [box["dyn"], soft_rows + drive["middle"], eq_rows, box["state"], box["u"], box["sigma"]],
            cost["track"] + cost["u"] + cost["sigma"],
            np.r_[st.Dx, st.Du, st.Dth, st.Dsg],
            list(st.names_x) + names_u + names_th + names_sg,
        ),
        "last": (
            ca.vertcat(xs, ths, sgs),
            [soft_rows, eq_rows, box["state_N"], box["sigma"]],
            cost["track_N"] + cost["sigma"],
            np.r_[st.Dx, st.Dth, st.Dsg],
            list(st.names_x) + names_th + names_sg,
        ),
    }


def _scaled_hessians(st: _Stage, specs: dict[str, tuple]) -> tuple[dict[str, np.ndarray], float]:
    """Each stage's scaled cost Hessian diagonal (the cost must have a constant diagonal Hessian), and the cost scale
    that makes the largest entry over all stages 1."""
    hess_diag = {}
    for key, (wk, _, cost, D, _) in specs.items():
        H = np.array(
            ca.Function("H", [wk, st.p], [ca.hessian(cost, wk)[0]])(np.zeros(wk.numel()), np.zeros(st.np_stage))
        )
        if np.count_nonzero(H - np.diag(np.diag(H))):
            raise AssertionError("cost Hessian must be diagonal")
        hess_diag[key] = np.diag(H) * D * D
    return hess_diag, 1.0 / max(float(h.max()) for h in hess_diag.values())


def _stage_type(
    pb: Problem, st: _Stage, key: str, spec: tuple, hess_diag: np.ndarray, cost_scale: float, theta_mid: list
) -> tuple[StageType, ca.Function]:
    """One stage shape's function (w, x_next, p) -> (g, J, q) in the scaled variables, its bounds and constant
    Hessian; and its unscaled cost function (for IPOPT)."""
    wk, groups, cost, D, var_names = spec
    rows = [r for g in groups for r in g]
    g = ca.vertcat(*[r[1] for r in rows])
    J = ca.jacobian(g, ca.vertcat(wk, st.xn))
    J = ca.mtimes(J, ca.diag(ca.DM(np.r_[D, st.Dx])))
    q = cost_scale * ca.gradient(cost, wk) * D
    P_diag = cost_scale * hess_diag
    anchor = getattr(pb.obstacles, "anchor", 0.0)
    n_theta = st.n_theta
    i_theta = st.nx + (st.nu if key == "middle" else 0)  # the stage's first hyperplane variable (none at k = 0)
    if n_theta and anchor > 0 and key != "first":  # the hyperplanes' anchor (theta's scale is 1): Hessian +
        # anchor, gradient anchor * (theta - theta_mid(x, p)) with theta_mid held at the linearization point
        q[i_theta : i_theta + n_theta] += anchor * (st.ths - ca.vertcat(*theta_mid))
        P_diag[i_theta : i_theta + n_theta] += anchor
    fun = ca.Function(f"stage_{key}", [wk, st.xn, st.p], [g, J, q], ["w", "x_next", "p"], ["g", "J", "q"])
    q_ds0 = np.zeros(len(D))
    # d q_s / d s0: q_s = c * D_s * 2 * Q_s * (s - s_ref), s_ref = s0 + t_k v_ref
    s_idx = 0  # s is the first state in both representations
    qs = (np.array(pb.weights.q_N) if key == "last" else np.array(pb.weights.q) * st.dt)[0]
    q_ds0[s_idx] = -cost_scale * D[s_idx] * 2 * qs
    stage = StageType(
        key,
        tuple(var_names),
        tuple(r[0] for r in rows),
        np.array([r[2] for r in rows], dtype=float),
        np.array([r[3] for r in rows], dtype=float),
        D,
        P_diag,
        q_ds0,
        fun,
        fun.sparsity_out(1),
    )
    return stage, ca.Function(f"cost_{key}", [wk, st.p], [cost])


def _init_state_function(st: _Stage) -> ca.Function:
    """(x0 Frenet, p) -> x_0 of the formulation: the lifted one appends F^-1 on the stage's road window."""
    x0F = ca.SX.sym("x0", 5)
    if st.lifted:
        cart = casadi_to_cartesian(x0F[0], x0F[1], x0F[2], st.p_road, st.rp.samples)
        x0_full = ca.vertcat(x0F, *cart)
    else:
        x0_full = x0F
    return ca.Function("init_state", [x0F, st.p], [x0_full], ["x0", "p"], ["x"])


def build_ocp(problem: Problem) -> Ocp:
    """Assemble the CasADi stage functions of a problem (built once; both reference and C use them)."""
    pb = problem
    st = _stage_symbols(pb)
    x_next = _dynamics(pb, st)
    # path constraints at stages 1..N: soft rows (with slack index), equality rows
    a = models.a_lat(st.xs[3], st.xs[4], pb.ego)
    soft_rows = _a_lat_and_road_rows(pb, st, a)
    obstacle_rows, eq_rows, theta_mid = _obstacle_rows(pb, st, first_slack=1 + int(pb.soft.soft_road))  # a_lat, road
    box = _box_rows(pb, st, x_next)
    specs = _stage_specs(
        st, soft_rows + obstacle_rows, eq_rows, box, _costs(pb, st), drive_rows(pb, st.xs, st.us, st.sgs[0], a)
    )
    hess_diag, cost_scale = _scaled_hessians(st, specs)
    stages, costs = {}, {}
    for key, spec in specs.items():
        stages[key], costs[key] = _stage_type(pb, st, key, spec, hess_diag[key], cost_scale, theta_mid)
    dyn = ca.Function("dynamics", [st.xs, st.us, st.p], [x_next], ["x", "u", "p"], ["x_next"])
    alat = ca.Function("a_lat", [st.xs], [a])
    return Ocp(
        pb,
        st.kind,
        st.nx,
        st.nu,
        st.n_theta,
        st.n_sigma,
        st.rp,
        len(obs.CARTESIAN_POSE),
        st.n_opp_stage,
        st.n_shape,
        st.np_stage,
        cost_scale,
        stages["first"],
        stages["middle"],
        stages["last"],
        dyn,
        _init_state_function(st),
        alat,
        obs.plan_clearance_function(pb, st.xs, st.p, st.p_road, st.rp.samples, st.lifted),
        (costs["first"], costs["middle"], costs["last"]),
        build_oppfit(pb),
    )
