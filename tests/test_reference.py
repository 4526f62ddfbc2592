"""Tests of the OCP stage functions (fcgen.ocp), the QP layout (fcgen.qp) and the SQP-RTI reference (fcgen.reference).

Independent references: finite differences of the stage functions and costs, a dense block assembly of the stage
Jacobians, hand-written cost formulas, and IPOPT solving the same NLP (SPEC section 6: the full NLP solve is the
ground truth for the formulation).
"""

from __future__ import annotations

import re
from dataclasses import replace

import casadi as ca
import numpy as np
import pytest

from fcgen.dsl import Horizon, Opponents, QpOptions, RoadWindow
from fcgen.ocp import INF, build_ocp
from fcgen.presets import TRUCK, paper_problem
from fcgen.qp import build_layout
from fcgen.reference import RtiSolver, SolverError
from fcgen.road import random_road, straight_road

ROAD = random_road(3, length=600.0, s0=-50.0)
X0 = np.array([0.0, 0.0, 0.0, 15.0, 0.0])
TIGHT = QpOptions(eps_abs=1e-9, eps_rel=1e-9, max_iter=100000)


def short_problem(form="lifted", ob="ellipse", N=10, qp=TIGHT, n_opp=1):
    """A short-horizon truck problem with one opponent (validation allows N = 10: window 280 m >= 48 m)."""
    return paper_problem("truck", form, ob, horizon=Horizon(stride=1, N=N), qp=qp).with_(
        opponents=Opponents(n_opp, TRUCK)
    )


def static_opponent(ocp, s_opp, n_opp, road=ROAD):
    """Poses of a parked truck (rear axle at (s_opp, n_opp), alpha = 0), shape (N+1, 1, 3); the conventional
    solver fits its Frenet box itself."""
    pose = np.array(road.to_cartesian(s_opp, n_opp, 0.0))
    return np.tile(pose, (ocp.N + 1, 1, 1))


def make_solver(ocp, s_opp=24.0, n_opp=-4.0, x0=X0):
    sv = RtiSolver(ocp)
    sv.set_road(ROAD.window(x0[0] - 10.0, ocp.problem.road.samples))
    sv.set_opponents(static_opponent(ocp, s_opp, n_opp))
    sv.set_state(x0)
    return sv


# --- QP layout invariants ------------------------------------------------------------------------------

LAYOUT_CASES = [
    ("lifted", "ellipse", 40),
    ("conventional", "circles", 10),
    ("direct_elimination", "hyperplane", 12),
    ("lifted", "hyperplane", 3),
    ("lifted", "ellipse", 1),
]


@pytest.fixture(scope="module", params=LAYOUT_CASES, ids=[f"{a}-{b}-N{c}" for a, b, c in LAYOUT_CASES])
def ocp_layout(request):
    form, ob, N = request.param
    pb = paper_problem("truck", form, ob, horizon=Horizon(stride=1, N=N))
    ocp = build_ocp(pb)
    return ocp, build_layout(ocp)


def expected_entries(ocp, lay):
    """(row, col) of every stage-Jacobian non-zero in stacked order, computed from the stage sparsities."""
    out = []
    for k in range(ocp.N + 1):
        st = ocp.stage(k)
        sp = st.jac_sparsity
        assert sp.size1() == st.nrows and sp.size2() == st.nw + ocp.nx
        colind, rows = sp.colind(), sp.row()
        for c in range(sp.size2()):
            gc = lay.var_off[k] + c if c < st.nw else lay.var_off[k + 1] + c - st.nw
            for j in range(colind[c], colind[c + 1]):
                out.append((lay.row_off[k] + rows[j], gc))
    return out


def test_layout_sizes(ocp_layout):
    ocp, lay = ocp_layout
    stages = [ocp.stage(k) for k in range(ocp.N + 1)]
    assert lay.n == sum(st.nw for st in stages) == lay.var_off[-1]
    assert lay.m == sum(st.nrows for st in stages) == lay.row_off[-1]
    assert len(lay.var_names) == lay.n and len(lay.row_names) == lay.m
    assert len(lay.L) == len(lay.U) == lay.m and len(lay.P_diag) == len(lay.D) == len(lay.q_ds0) == lay.n
    # stage 0: x, u; middle: x, u, theta, sigma; last: x, theta, sigma
    assert ocp.first.nw == ocp.nx + ocp.nu
    assert ocp.middle.nw == ocp.nx + ocp.nu + ocp.n_theta + ocp.n_sigma
    assert ocp.last.nw == ocp.nx + ocp.n_theta + ocp.n_sigma
    assert [lay.var_names[i] for i in lay.s_vars] == [f"s[{k}]" for k in range(ocp.N + 1)]
    assert [lay.row_names[i] for i in lay.init_rows] == [
        f"init_{nm}[0]" for nm in ("s", "n", "alpha", "v", "delta", "x", "y", "phi")[: ocp.nx]
    ]


def test_A_pattern_has_no_duplicates_and_every_jacobian_entry_lands_once(ocp_layout):
    ocp, lay = ocp_layout
    A = lay.A_pattern()
    assert A.shape == (lay.m, lay.n)
    cols = np.repeat(np.arange(lay.n), np.diff(lay.A_indptr))
    for c in range(lay.n):
        idx = lay.A_indices[lay.A_indptr[c] : lay.A_indptr[c + 1]]
        assert np.all(np.diff(idx) > 0), f"column {c}: unsorted or duplicate rows"
    assert lay.nnz_A == lay.jac_off[-1]
    # a_src is a permutation of the stacked Jacobian non-zeros
    assert np.array_equal(np.sort(lay.a_src), np.arange(lay.jac_off[-1]))
    # and each A entry is where its source Jacobian entry belongs
    exp = expected_entries(ocp, lay)
    assert len(exp) == lay.nnz_A == len(set(exp))
    got = list(zip(lay.A_indices.tolist(), cols.tolist()))
    assert all(got[i] == exp[lay.a_src[i]] for i in range(lay.nnz_A))


def test_P_diagonal_and_bounds(ocp_layout):
    _ocp, lay = ocp_layout
    assert np.all(lay.P_diag >= 0) and np.max(lay.P_diag) == pytest.approx(1.0)  # cost scaled to max 1
    P = lay.P_matrix()
    assert P.nnz == lay.n and np.array_equal(P.diagonal(), lay.P_diag)
    assert np.all(lay.L <= lay.U)
    assert np.all(np.abs(lay.L) <= INF) and np.all(np.abs(lay.U) <= INF)
    assert np.all(lay.D > 0)
    # equality rows: dynamics, init, hyperplane normalization
    eq = lay.L == lay.U
    names = np.array([re.sub(r"\[\d+\]$", "", nm) for nm in lay.row_names])
    is_eq_name = np.array([nm.startswith(("dyn_", "init_")) or nm.endswith("hp_norm") for nm in names])
    assert np.array_equal(eq, is_eq_name)


def test_shift_maps_keep_the_stage_structure(ocp_layout):
    ocp, lay = ocp_layout
    N, nx, nu = ocp.N, ocp.nx, ocp.nu
    old = np.arange(lay.n) + 1000.0
    new = old[lay.var_shift]
    blk = lambda w, k: w[lay.var_off[k] : lay.var_off[k + 1]]
    for k in range(N):
        np.testing.assert_array_equal(blk(new, k)[:nx], blk(old, k + 1)[:nx])  # x_k <- x_{k+1}
    np.testing.assert_array_equal(blk(new, N), blk(old, N))  # last stage kept
    for k in range(N - 1):
        np.testing.assert_array_equal(blk(new, k)[nx : nx + nu], blk(old, k + 1)[nx : nx + nu])  # u_k <- u_{k+1}
    if N >= 2:
        np.testing.assert_array_equal(blk(new, N - 1)[nx : nx + nu], blk(old, N - 1)[nx : nx + nu])  # u_{N-1} kept
    for k in range(1, N):  # theta, sigma
        np.testing.assert_array_equal(
            blk(new, k)[nx + nu :], blk(old, k + 1)[nx:] if k + 1 == N else blk(old, k + 1)[nx + nu :]
        )
    base = lambda nm: re.sub(r"\[\d+\]$", "", nm)
    assert all(base(lay.var_names[i]) == base(lay.var_names[j]) for i, j in enumerate(lay.var_shift))
    assert all(base(lay.row_names[i]) == base(lay.row_names[j]) for i, j in enumerate(lay.row_shift))
    # rows shift by one stage too (where the next stage has the row)
    for k in range(N):
        for i in range(lay.row_off[k], lay.row_off[k + 1]):
            j = lay.row_shift[i]
            assert lay.row_off[min(k + 1, N)] <= j < lay.row_off[min(k + 1, N) + 1] or j == i


# --- the QP matrices are the linearization of the NLP ----------------------------------------------------


@pytest.fixture(scope="module")
def prepared():
    ocp = build_ocp(short_problem("lifted", "ellipse", N=10))
    sv = make_solver(ocp)
    sv.prepare()
    return ocp, sv


def stage_point(sv, k, rng):
    """Stage k's guess variables and parameters, perturbed randomly (a generic point, not only the guess)."""
    lay, ocp = sv.lay, sv.ocp
    w = sv.w_prep[lay.var_off[k] : lay.var_off[k + 1]].copy()  # the prepared guess (the linearization point)
    w += 0.05 * lay.D[lay.var_off[k] : lay.var_off[k + 1]] * rng.standard_normal(w.size)
    xn = sv.w_prep[lay.var_off[k + 1] : lay.var_off[k + 1] + ocp.nx].copy() if k < ocp.N else np.zeros(ocp.nx)
    xn += 0.05 * lay.D[: ocp.nx] * rng.standard_normal(ocp.nx)
    p = sv.stage_params(k, sv.w_prep[lay.s_vars[k]])
    return w, xn, p


@pytest.mark.parametrize("k", [0, 1, 6, 10])
def test_stage_jacobian_equals_finite_differences_in_scaled_variables(prepared, k):
    ocp, sv = prepared
    st = ocp.stage(k)
    rng = np.random.default_rng(k)
    w, xn, p = stage_point(sv, k, rng)
    _g0, J, _ = st.fun(w, xn, p)
    J = np.array(ca.DM(J).full())
    Dfull = np.r_[st.D, ocp.first.D[: ocp.nx]]  # scaled variables z = w / D (and x_next / D_x)
    z = np.r_[w, xn]
    Jfd = np.zeros_like(J)
    h = 1e-6
    for j in range(z.size):
        zp, zm = z.copy(), z.copy()
        zp[j] += h * Dfull[j]
        zm[j] -= h * Dfull[j]
        gp = np.array(st.fun(zp[: st.nw], zp[st.nw :], p)[0]).ravel()
        gm = np.array(st.fun(zm[: st.nw], zm[st.nw :], p)[0]).ravel()
        Jfd[:, j] = (gp - gm) / (2 * h)
    np.testing.assert_allclose(J, Jfd, rtol=1e-5, atol=1e-6)


@pytest.mark.parametrize("k", [0, 5, 10])
def test_qp_cost_gradient_and_hessian_are_the_scaled_cost_derivatives(prepared, k):
    ocp, sv = prepared
    st = ocp.stage(k)
    cost = ocp.cost[0 if k == 0 else 2 if k == ocp.N else 1]
    rng = np.random.default_rng(10 + k)
    w, xn, p = stage_point(sv, k, rng)
    q = np.array(st.fun(w, xn, p)[2]).ravel()
    c = lambda v: float(cost(v, p))
    h = 1e-3
    for j in range(st.nw):
        e = np.zeros(st.nw)
        e[j] = h * st.D[j]
        grad = (c(w + e) - c(w - e)) / (2 * h)  # d cost / d z_j
        hess = (c(w + e) - 2 * c(w) + c(w - e)) / h**2  # exact for a quadratic
        assert q[j] == pytest.approx(ocp.cost_scale * grad, rel=1e-6, abs=1e-9)
        assert st.P_diag[j] == pytest.approx(ocp.cost_scale * hess, rel=1e-5, abs=1e-9)


def test_cost_weights_apply_dt_exactly_once():
    pb = paper_problem("truck", "direct_elimination", "ellipse")
    ocp = build_ocp(pb)
    dt = 0.1
    rng = np.random.default_rng(0)
    p = np.zeros(ocp.np_stage)
    xref = np.array([12.0, 1.0, 0.0, 40.0, 0.0])
    p[ocp.p_ref] = xref
    x = xref + rng.standard_normal(5)
    u = np.array([2000.0, 0.1])
    sig = np.abs(rng.standard_normal(ocp.n_sigma))
    e = x - xref
    q, qN, r = np.array([1, 500, 1e3, 1e3, 1e4]), np.array([10, 90, 100, 10, 10]), np.array([1e-3, 2e6])
    l1 = np.r_[1e5, [1e7] * 3] * dt
    l2 = np.r_[1e4, [1e6] * 3] * dt
    assert float(ocp.cost[0](np.r_[x, u], p)) == pytest.approx(np.sum(q * dt * e**2) + np.sum(r * dt * u**2), rel=1e-12)
    assert float(ocp.cost[1](np.r_[x, u, sig], p)) == pytest.approx(
        np.sum(q * dt * e**2) + np.sum(r * dt * u**2) + np.sum(l1 * sig + l2 * sig**2), rel=1e-12
    )
    assert float(ocp.cost[2](np.r_[x, sig], p)) == pytest.approx(
        np.sum(qN * e**2) + np.sum(l1 * sig + l2 * sig**2), rel=1e-12
    )


def test_unequal_intervals_integrate_each_stages_length_and_weigh_the_first():
    """The safe grid (0.1 s, then 0.3 s intervals): a stage steps over the interval its parameters carry (a straight
    road, no steering: s advances the interval at the mean speed, the speed changes three times as much over 0.3 s
    as over 0.1 s); the costs weigh every stage like the first interval; the a_lat rows keep the margin inside the
    bound. An all-coarse uniform grid (stride 2) steps and weighs 0.2 s."""
    pb = paper_problem("truck", "direct_elimination", "ellipse", profile="safe")
    pb = pb.with_(
        horizon=Horizon(stride=3, fine=20), road=RoadWindow(length=340.0), bounds=replace(pb.bounds, a_lat_margin=0.15)
    )
    assert (pb.horizon.interval, pb.horizon.max_interval) == (0.1, 0.1 * 3)
    ocp = build_ocp(pb)
    x = np.array([10.0, 1.0, 0.0, 20.0, 0.0])
    p = np.zeros(ocp.np_stage)
    p[ocp.p_road] = ocp.road_params.pack(straight_road(400.0, s0=0.0), 0)
    step = {}
    for h in (0.1, 0.3):
        p[ocp.p_dt] = h
        step[h] = np.array(ocp.dynamics(x, np.zeros(2), p)).ravel() - x
        assert step[h][0] == pytest.approx(h * (20.0 + 0.5 * step[h][3]), abs=1e-4)  # nearly constant deceleration
        np.testing.assert_allclose(step[h][[1, 2, 4]], 0.0, atol=1e-12)
    assert step[0.1][3] < 0 and step[0.3][3] == pytest.approx(3 * step[0.1][3], rel=0.01)
    xref = np.array([12.0, 1.0, 0.0, 40.0, 0.0])
    p[ocp.p_ref] = xref
    u = np.array([2000.0, 0.1])
    e = x - xref
    q, r = np.array(pb.weights.q), np.array(pb.weights.r)
    for p_dt in (0.1, 0.3):  # the weight does not follow the stage's interval
        p[ocp.p_dt] = p_dt
        assert float(ocp.cost[0](np.r_[x, u], p)) == pytest.approx(
            np.sum(q * 0.1 * e**2) + np.sum(r * 0.1 * u**2), rel=1e-12
        )
    mid = ocp.middle
    lo, hi = mid.row_names.index("a_lat_lo"), mid.row_names.index("a_lat_hi")
    assert (mid.L[lo], mid.U[hi]) == (-(5.0 - 0.15) / 5.0, (5.0 - 0.15) / 5.0)
    coarse = build_ocp(pb.with_(horizon=Horizon(N=40, dt=0.1, stride=2, fine=0)))
    assert coarse.p_dt is None  # a uniform grid: the interval is a constant of the stage functions
    pc = np.zeros(coarse.np_stage)
    pc[coarse.p_ref] = xref
    assert float(coarse.cost[0](np.r_[x, u], pc)) == pytest.approx(
        np.sum(q * 0.2 * e**2) + np.sum(r * 0.2 * u**2), rel=1e-12
    )
    pc[coarse.p_road] = coarse.road_params.pack(straight_road(400.0, s0=0.0), 0)
    dx = np.array(coarse.dynamics(x, np.zeros(2), pc)).ravel() - x
    assert dx[0] == pytest.approx(0.2 * (20.0 + 0.5 * dx[3]), abs=1e-4)


def test_a_stride_shifts_the_plan_by_one_sample_interpolated(ocp_layout):
    """A plan whose every entry is linear in time t_k (node k's time): one sample later the shift is exactly the plan
    at t_k + dt for stages 0..N-1 (fine stages take the next stage's entry, coarse ones move 1 / stride of the way);
    on the paper's grid it is the index shift. Uniform grids of 1, 2, 3 samples an interval and the safe grid."""
    ocp, lay0 = ocp_layout
    pb = ocp.problem
    grids = [Horizon(N=pb.horizon.N, stride=s, fine=0) for s in (1, 2, 3)]
    grids.append(Horizon(N=pb.horizon.N, stride=3, fine=pb.horizon.N // 2))
    for hz in grids:
        lay = build_layout(build_ocp(pb.with_(horizon=hz, road=RoadWindow(length=40.0 * hz.length + 8.0))))
        assert np.array_equal(lay.var_shift, lay0.var_shift)  # the stages' layout does not depend on the grid
        stage_of = np.searchsorted(lay.var_off, np.arange(lay.n), side="right") - 1
        t = np.array(hz.times)[stage_of]
        names = [re.sub(r"\[\d+\]$", "", nm) for nm in lay.var_names]
        rate = {nm: 1.0 + i for i, nm in enumerate(dict.fromkeys(names))}
        slope = np.array([rate[nm] for nm in names])  # per variable its own rate
        w = 5.0 + slope * t
        new = lay.shift_vars(w)
        if hz.stride == 1:
            np.testing.assert_array_equal(new, w[lay.var_shift])
        moved = lay.var_shift != np.arange(lay.n)  # entries that have a next stage (not the last one's)
        np.testing.assert_allclose(new[moved], (5.0 + slope * (t + hz.dt))[moved], rtol=0, atol=1e-12)
        np.testing.assert_array_equal(new[~moved], w[~moved])


def test_assembled_A_equals_block_assembly_of_stage_jacobians(prepared):
    ocp, sv = prepared
    lay = sv.lay
    A = lay.A_pattern(sv.A_data).toarray()
    dense = np.zeros((lay.m, lay.n))
    g_all = []
    for k in range(ocp.N + 1):
        st = ocp.stage(k)
        w = sv.w_prep[lay.var_off[k] : lay.var_off[k + 1]]
        xn = sv.w_prep[lay.var_off[k + 1] : lay.var_off[k + 1] + ocp.nx] if k < ocp.N else np.zeros(ocp.nx)
        g, J, _ = st.fun(w, xn, sv.stage_params(k, sv.w_prep[lay.s_vars[k]]))
        J = np.array(ca.DM(J).full())
        r0, r1 = lay.row_off[k], lay.row_off[k + 1]
        dense[r0:r1, lay.var_off[k] : lay.var_off[k + 1]] += J[:, : st.nw]
        if k < ocp.N:
            dense[r0:r1, lay.var_off[k + 1] : lay.var_off[k + 1] + ocp.nx] += J[:, st.nw :]
        g_all.append(np.array(g).ravel())
    np.testing.assert_allclose(A, dense, rtol=0, atol=1e-14)
    np.testing.assert_allclose(sv.g, np.concatenate(g_all), rtol=0, atol=1e-14)
    np.testing.assert_allclose(sv.l, lay.L - sv.g)
    np.testing.assert_allclose(sv.u, lay.U - sv.g)


# --- converged SQP = IPOPT on the same NLP ------------------------------------------------------------------


def nlp(sv, s0=None):
    """The NLP of the solver's current parameters, written independently of the QP layout's index maps:
    variables W (all stage variables), objective = sum of ocp.cost, constraints = the stage rows g_k with bounds
    [L, U], the init rows fixed to x0 / D. The s-reference is s0 + k dt v_ref (s0 = the measured s by default)."""
    ocp, lay = sv.ocp, sv.lay
    N = ocp.N
    s0 = sv.x0[0] if s0 is None else s0
    W = ca.MX.sym("w", lay.n)
    wk = lambda k: W[int(lay.var_off[k]) : int(lay.var_off[k + 1])]
    P = []
    for k in range(N + 1):
        p = sv.stage_params(k, sv.w[lay.s_vars[k]]).copy()
        p[ocp.p_ref.start] = s0 + k * ocp.dt * ocp.problem.reference.v_ref
        P.append(p)
    g, f = [], 0
    for k in range(N + 1):
        xn = wk(k + 1)[: ocp.nx] if k < N else ca.DM.zeros(ocp.nx)
        g.append(ocp.stage(k).fun(wk(k), xn, P[k])[0])
        f += ocp.cost[0 if k == 0 else 2 if k == N else 1](wk(k), P[k])
    lbg, ubg = lay.L.copy(), lay.U.copy()
    x0_full = np.array(ocp.init_state(sv.x0, P[0])).ravel()
    lbg[lay.init_rows] = ubg[lay.init_rows] = x0_full / lay.D[: ocp.nx]
    lbg[lbg <= -INF] = -np.inf
    ubg[ubg >= INF] = np.inf
    return W, f, ca.vertcat(*g), lbg, ubg


IPOPT_OPTS = {
    "ipopt.tol": 1e-12,
    "ipopt.print_level": 0,
    "ipopt.sb": "yes",
    "print_time": False,
    "ipopt.max_iter": 1000,
}


def ipopt_solution(sv):
    """Solve the NLP of the solver's current parameters with IPOPT, started at the SQP's solution perturbed by 5 %
    of each variable's scale (seeded): IPOPT must converge back to it, which it does only if the SQP's fixed point
    is a local minimum of the same NLP. Not from the cold-start guess: the NLP is non-convex (passing an obstacle
    left or right, the hyperplanes), and from one start IPOPT and SQP may find different local minima."""
    W, f, g, lbg, ubg = nlp(sv)
    solver = ca.nlpsol("ipopt", "ipopt", {"x": W, "f": f, "g": g}, IPOPT_OPTS)
    w0 = sv.w + 0.05 * sv.lay.D * np.random.default_rng(0).standard_normal(sv.lay.n)
    res = solver(x0=w0, lbg=lbg, ubg=ubg)
    assert solver.stats()["success"], solver.stats()["return_status"]
    return np.array(res["x"]).ravel()


def not_theta(sv):
    return np.array([not nm.startswith("theta") for nm in sv.lay.var_names])


def obstacle_rows(sv):
    ocp, lay = sv.ocp, sv.lay
    idx = [
        lay.row_off[k] + i
        for k in range(1, ocp.N + 1)
        for i, nm in enumerate(ocp.stage(k).row_names)
        if re.fullmatch(r"opp\d+_h\d+", nm)
    ]
    return np.array(idx)


IPOPT_CASES = [  # formulation, obstacle model, ego speed, parked opponent (s, n)
    ("lifted", "ellipse", 10.0, 20.0, -5.0),  # obstacle row active, slack zero
    ("lifted", "ellipse", 15.0, 24.0, -4.0),  # obstacle rows active with positive slack (L1 saturated)
    ("direct_elimination", "ellipse", 10.0, 20.0, -5.0),
    ("lifted", "circles", 10.0, 20.0, -3.0),
    ("conventional", "ellipse", 10.0, 24.0, -5.0),
    ("lifted", "hyperplane", 10.0, 16.0, -2.5),
]


@pytest.mark.parametrize("form, ob, v0, s_opp, n_opp", IPOPT_CASES)
def test_converged_sqp_matches_ipopt(form, ob, v0, s_opp, n_opp):
    ocp = build_ocp(short_problem(form, ob, N=10))
    x0 = X0.copy()
    x0[3] = v0
    sv = make_solver(ocp, s_opp=s_opp, n_opp=n_opp, x0=x0)
    it = sv.solve_converged(x0, max_sqp=60, tol=1e-8)
    assert it < 60, "SQP did not converge"
    # at the fixed point a further full SQP step is zero
    sv.prepare(shift=False)
    sv.feedback()
    assert np.max(np.abs(sv.z)) < 1e-7
    # the opponent matters: some obstacle row is active and the solution differs from the one without it
    rows = obstacle_rows(sv)
    active = np.abs(sv.g[rows]) < 1e-6  # g = h + sigma at the converged point; lower bound 0
    assert np.any(active) and np.max(np.abs(sv.y[rows])) > 1e-3
    far = make_solver(ocp, s_opp=400.0, n_opp=n_opp, x0=x0)
    far.solve_converged(x0, max_sqp=60, tol=1e-8)
    assert np.max(np.abs(sv.states()[:, 1] - far.states()[:, 1])) > 0.1
    # IPOPT on the same NLP (stage functions, bounds, costs), from a perturbed SQP solution
    w_ip = ipopt_solution(sv)
    lay = sv.lay
    diff = (w_ip - sv.w) / lay.D
    xu = np.zeros(lay.n, dtype=bool)
    for k in range(ocp.N + 1):
        xu[lay.var_off[k] : lay.var_off[k] + ocp.nx + (ocp.nu if k < ocp.N else 0)] = True
    assert np.max(np.abs(diff[xu])) <= 1e-5, np.max(np.abs(diff[xu]))  # states and controls, scaled units
    # slacks too; hyperplane thetas are not unique (any separating plane of an inactive pair is optimal): not compared
    assert np.max(np.abs(diff[not_theta(sv)])) <= 1e-5
    # in SI units: positions to 1e-4 m, drive force to 0.1 N
    st_ip = np.stack([w_ip[lay.var_off[k] : lay.var_off[k] + ocp.nx] for k in range(ocp.N + 1)])
    np.testing.assert_allclose(st_ip, sv.states(), atol=1e-4)


@pytest.mark.parametrize("form, ob", [("lifted", "ellipse"), ("direct_elimination", "hyperplane")])
def test_rti_step_is_the_gauss_newton_sqp_step(form, ob):
    """One RTI sample (shift, prepare, new x0, feedback) takes exactly the SQP step of the NLP: the QP built
    here from CasADi's derivatives of the whole NLP (its own Jacobian, gradient and Hessian of the linear
    least-squares cost) and solved by IPOPT gives the same step."""
    ocp = build_ocp(short_problem(form, ob, N=10))
    x0 = np.array([0.0, 0.0, 0.0, 15.0, 0.0])
    sv = make_solver(ocp, s_opp=24.0, n_opp=-4.0, x0=x0)
    sv.solve_converged(x0, tol=1e-8)
    # the next sample: the plant moved a bit differently than predicted (s too, so the reference moves)
    x1 = sv.states()[1][:5] + np.array([0.3, 0.05, 0.01, -0.2, 0.003])
    sv.set_road(ROAD.window(x1[0] - 10.0, ocp.problem.road.samples))
    sv.prepare()  # shift + linearize at the shifted guess
    sv.set_state(x1)
    assert sv.s0_guess != x1[0]
    w_guess = sv.w_prep.copy()  # the shifted guess the QP is built at
    sv.feedback()
    step = sv.w - w_guess
    # the reference QP at w_guess
    W, f, g, lbg, ubg = nlp(sv, s0=x1[0])
    fn = ca.Function("lin", [W], [f, ca.gradient(f, W), ca.hessian(f, W)[0], g, ca.jacobian(g, W)])
    _, grad, H, g0, Jg = (np.array(ca.DM(v).full()) for v in fn(w_guess))
    dW = ca.MX.sym("dw", sv.lay.n)
    Hs, Js = ca.DM(ca.sparsify(ca.DM(H))), ca.DM(ca.sparsify(ca.DM(Jg)))
    qp = {"x": dW, "f": 0.5 * ca.bilin(Hs, dW, dW) + ca.dot(ca.DM(grad), dW), "g": ca.mtimes(Js, dW)}
    solver = ca.nlpsol("qp", "ipopt", qp, IPOPT_OPTS)
    res = solver(x0=np.zeros(sv.lay.n), lbg=lbg - g0.ravel(), ubg=ubg - g0.ravel())
    assert solver.stats()["success"]
    step_ref = np.array(res["x"]).ravel()
    assert np.max(np.abs(step_ref / sv.lay.D)) > 1e-2  # a real step, not a zero one
    # (thetas excluded: the QP has no curvature in them, so their step is not unique)
    m = not_theta(sv)
    np.testing.assert_allclose((step / sv.lay.D)[m], (step_ref / sv.lay.D)[m], atol=1e-6, rtol=0)


# --- errors ----------------------------------------------------------------------------------------------


def test_feedback_before_prepare_raises_and_solver_recovers():
    ocp = build_ocp(short_problem(N=10, qp=QpOptions()))
    sv = make_solver(ocp)
    with pytest.raises(SolverError, match="before prepare"):
        sv.feedback()
    u_a = sv.step(X0)
    with pytest.raises(SolverError, match="before prepare"):
        sv.feedback()  # prepare is needed again after every feedback
    with pytest.raises(SolverError, match="finite"):
        sv.set_state(np.array([0.0, np.nan, 0.0, 15.0, 0.0]))
    with pytest.raises(SolverError):
        sv.set_state(np.zeros(4))
    with pytest.raises(SolverError, match="shape"):
        sv.set_opponents(np.zeros((3, 1, 3)))
    bad = static_opponent(ocp, 24.0, -4.0)
    bad[3, 0, 1] = np.inf
    with pytest.raises(SolverError, match="NaN or infinite"):
        sv.set_opponents(bad)
    # the solver still works, and exactly as one that never saw the errors
    x1 = np.array(ocp.dynamics(np.r_[X0, ROAD.to_cartesian(0.0, 0.0, 0.0)], u_a, sv.stage_params(0, 0.0))).ravel()[:5]
    u_b = sv.step(x1)
    clean = make_solver(ocp)
    assert np.array_equal(clean.step(X0), u_a)
    assert np.array_equal(clean.step(x1), u_b)
    assert np.all(np.isfinite(u_b)) and sv.status.qp_status in (1, 2)  # solved (or to 10 eps within the cap)


def test_nan_state_in_the_first_step_raises_and_solver_recovers():
    ocp = build_ocp(short_problem(N=10, qp=QpOptions()))
    sv = make_solver(ocp)
    with pytest.raises(SolverError):
        sv.step(np.array([0.0, 0.0, 0.0, np.nan, 0.0]))
    assert np.all(np.isfinite(sv.step(X0)))


def test_state_outside_the_road_window_raises():
    ocp = build_ocp(short_problem(N=10, qp=QpOptions()))
    sv = make_solver(ocp)
    sv.step(X0)
    sv.set_state(np.array([900.0, 0.0, 0.0, 15.0, 0.0]))  # far beyond the 280 m window
    sv.prepare()
    with pytest.raises(SolverError, match="does not cover"):
        sv.feedback()
    with pytest.raises(SolverError, match="at most"):
        sv.set_road(ROAD)  # the whole road: more samples than the window holds
