"""The interior-point QP backend (``qp.backend = "ipm"``): the stage view, the Python IPM against OSQP on the QPs of
closed-loop runs, its statuses, and the generated C against the Python reference (``fcgen verify``)."""

from __future__ import annotations

import shutil

import numpy as np
import osqp
import pytest

from fcgen.backends import QP_NONFINITE, QP_PRIMAL_INFEASIBLE, QP_SOLVED, make_backend
from fcgen.backends.ipm import Backend as IpmBackend
from fcgen.backends.ipm import IpmSettings
from fcgen.backends.osqp import osqp_settings
from fcgen.dsl import Horizon, QpOptions
from fcgen.ocp import INF, build_ocp
from fcgen.presets import FORMULATIONS, OBSTACLES, SCENARIOS, paper_problem
from fcgen.qp import build_layout, split_soft_rows, stage_view
from fcgen.reference import RtiSolver
from fcgen.sim.closedloop import ReferenceController, run_closed_loop
from fcgen.sim.scenario import make_scenario
from fcgen.verify import infer_scenario

IPM = QpOptions(backend="ipm")
IPM_TIGHT = QpOptions(backend="ipm", ipm_tol=1e-8)  # the cross-check's IPM: its fixed point, not the real-time stop
# OSQP solving every QP to eps 1e-7 (the second method of the cross-check)
OSQP_TIGHT = QpOptions(max_iter=100_000, eps_abs=1e-7, eps_rel=1e-7, rho=1.0, check_termination=5, adaptive_rho=True)
CASES = [(sc, f, o) for sc in SCENARIOS for f in FORMULATIONS for o in OBSTACLES]
# C builds are the slow part: the default run builds a Latin square (each formulation, each obstacle model once,
# both scenarios); the remaining presets are marked slow
FAST_C = {
    ("car", "conventional", "hyperplane"),
    ("truck", "direct_elimination", "circles"),
    ("truck", "lifted", "ellipse"),
}
C_CASES = [c if c in FAST_C else pytest.param(*c, marks=pytest.mark.slow) for c in CASES]


def short(sc: str, form: str, ob: str, N: int = 10, qp: QpOptions = IPM):
    return paper_problem(sc, form, ob, horizon=Horizon(N=N), qp=qp)


def closed_loop_qps(pb, samples: int = 3, seed: int = 1) -> tuple[RtiSolver, list[tuple]]:
    """Run the reference RTI with the IPM; return the QPs it solved: (P_x, A_x, q, l, u, y_warm, result)."""
    ocp = build_ocp(pb)
    ref = RtiSolver(ocp)
    qps = []
    inner = ref.qp

    class Recorder:
        name = "recorder"

        def reset(self):
            inner.reset()

        def set_matrices(self, P_x, A_x, q):
            self.mat = (np.array(P_x), np.array(A_x))
            inner.set_matrices(P_x, A_x, q)

        def solve(self, q, l, u, y_warm, max_iter):
            res = inner.solve(q, l, u, y_warm, max_iter)
            qps.append((*self.mat, q.copy(), l.copy(), u.copy(), y_warm.copy(), res))
            return res

    ref.qp = Recorder()
    run_closed_loop(pb, make_scenario(infer_scenario(pb), seed, samples=samples), ReferenceController(ocp, ref), ocp)
    return ref, qps


def kkt(lay, P_x, A_x, q, l, u, z, y) -> tuple[float, float, float]:
    """Stationarity, bound violation and complementarity (|y| times the distance to its bound) of (z, y)."""
    A = lay.A_pattern(A_x)
    Az = A @ z
    r_d = P_x * z + q + A.T @ y
    viol = np.maximum(Az - u, 0) + np.maximum(l - Az, 0)
    comp = np.maximum(y, 0) * np.minimum(np.abs(u - Az), 1.0) + np.maximum(-y, 0) * np.minimum(np.abs(Az - l), 1.0)
    return float(np.max(np.abs(r_d))), float(np.max(viol)), float(np.max(comp))


# -- the stage view ---------------------------------------------------------------------------------------------


@pytest.mark.parametrize("split", [False, True], ids=["stage_view", "split_soft_rows"])
@pytest.mark.parametrize(
    "sc,form,ob",
    [("car", "conventional", "hyperplane"), ("truck", "lifted", "circles"), ("car", "direct_elimination", "ellipse")],
)
def test_stage_view_reassembles_A(sc, form, ob, split):
    """Every non-zero of A sits in exactly one block of the stage view (and, split, of its soft rows); the blocks
    rebuild A entry for entry."""
    lay = build_layout(build_ocp(short(sc, form, ob)))
    sv = stage_view(lay)
    sr = None
    if split:
        sv, sr = split_soft_rows(lay, sv)
    A = lay.A_pattern(np.arange(1.0, lay.nnz_A + 1)).toarray()
    B = np.zeros_like(A)
    val = np.arange(1.0, lay.nnz_A + 1)
    seen = np.zeros(lay.nnz_A, dtype=int)

    def put(r, c, a):
        B[r, c] += val[a]
        seen[a] += 1

    for k in range(sv.N):
        for e in range(sv.dyn_ptr[k], sv.dyn_ptr[k + 1]):
            put(sv.dyn_rows[k, sv.dyn_i[e]], sv.vmap[k, sv.dyn_j[e]], sv.dyn_a[e])
        for i in range(sv.nx):
            put(sv.dyn_rows[k, i], lay.var_off[k + 1] + i, sv.dyn_next[k, i])
    for i in range(sv.nx):
        put(lay.init_rows[i], lay.var_off[0] + i, sv.init_a[i])
    for k in range(sv.N + 1):
        for g in range(sv.NG):
            s = k * sv.NG + g
            for v, a in zip(sv.gen_v[sv.gen_ptr[s] : sv.gen_ptr[s + 1]], sv.gen_a[sv.gen_ptr[s] : sv.gen_ptr[s + 1]]):
                put(sv.gen_rows[k, g], sv.vmap[k, v], a)
        for e in range(sv.NE):
            s = k * sv.NE + e
            for j, a in zip(sv.eq_j[sv.eq_ptr[s] : sv.eq_ptr[s + 1]], sv.eq_a[sv.eq_ptr[s] : sv.eq_ptr[s + 1]]):
                put(sv.eq_rows[k, e], sv.vmap[k, sv.nx + j], a)
    for r, c, a in zip(sv.box_rows, sv.box_var, sv.box_a):
        put(r, c, a)
    sides = list(zip(sv.side_row.tolist(), sv.side_sign.tolist()))
    used = sv.vmap[sv.vmap >= 0].tolist()
    if split:
        for k in range(sv.N + 1):
            assert sr.rptr[k] <= sr.rptr[k + 1] and sr.run_ptr[sr.rptr[k]] == sr.ptr[k]
            for r in range(sr.rptr[k], sr.rptr[k + 1]):
                js = range(sr.run_ptr[r], sr.run_ptr[r + 1])
                assert all(np.array_equal(sr.v[j], sr.run_v[r]) for j in js)  # a run: rows on the same slots
                assert list(sr.row[list(js)]) == sorted(sr.row[list(js)])
                for j in js:
                    for v, a in zip(sr.v[j], sr.a[j]):
                        if a >= 0:
                            put(sr.row[j], sv.vmap[k, v], a)
                    put(sr.row[j], sr.svar[j], sr.e[j])
                    put(sr.brow[j], sr.svar[j], sr.ba[j])
        sides += list(zip(sr.row.tolist(), sr.sign.tolist())) + list(zip(sr.brow.tolist(), sr.bsign.tolist()))
        used += sr.svar.tolist()
        assert sr.run_ptr[-1] == sr.count == len(set(sr.row.tolist())) > 0
    assert np.all(seen == 1)
    np.testing.assert_array_equal(A, B)
    # every variable in one slot; sides exactly at the finite bounds of the inequality rows
    assert sorted(used) == list(range(lay.n))
    ineq = np.setdiff1d(np.arange(lay.m), sv.eq_all)
    expect = sorted([(r, 1) for r in ineq if lay.L[r] > -INF] + [(r, -1) for r in ineq if lay.U[r] < INF])
    assert sorted(sides) == expect
    assert np.all(lay.L[sv.eq_all] == lay.U[sv.eq_all])


def test_soft_rows_are_the_obstacle_rows():
    """The soft rows of truck_lifted_circles (C7) are its 147 obstacle rows per stage 1..N, each with its own slack
    bounded below; the a_lat rows (two rows sharing one slack) stay generic rows."""
    lay = build_layout(build_ocp(short("truck", "lifted", "circles")))
    sv, sr = split_soft_rows(lay, stage_view(lay))
    names = [lay.row_names[r] for r in sr.row]
    assert sr.count == 10 * 7 * 7 * 3 and all(nm.startswith("opp") for nm in names), set(names)
    assert np.all(sr.sign == 1) and np.all(sr.bsign == 1) and sr.NA == 3
    assert len(set(sr.svar.tolist())) == sr.count
    assert sv.NG == 2 and sv.NS == 1  # a_lat: two rows, one slack
    assert all(lay.row_names[r].startswith("a_lat") for r in sv.gen_rows[sv.gen_rows >= 0])


def test_soft_row_storage_pads_long_runs_to_whole_lanes():
    """The C's soft-row storage: C7's runs of 147 rows (one per stage) read 4 rows at a time, so each is padded to 148
    with one row of no data at its end; the ellipse's runs of 3 rows would gain 33 % padding, so they keep one lane
    and no padding."""
    from fcgen.codegen.ipm_layout import padded_runs, sr_lanes

    lay = build_layout(build_ocp(short("truck", "lifted", "circles")))
    _sv, sr = split_soft_rows(lay, stage_view(lay))
    assert sr_lanes(sr) == 4
    ptr, pad = padded_runs(sr)
    np.testing.assert_array_equal(ptr, 148 * np.arange(11))
    rows = pad(sr.row)
    assert rows.shape == (1480,) and np.all(rows[147::148] == -1) and np.count_nonzero(rows == -1) == 10
    np.testing.assert_array_equal(rows[rows >= 0], sr.row)  # the rows in their order, runs contiguous
    np.testing.assert_array_equal(pad(sr.a)[147], -np.ones(sr.NA))  # a padding row has no data
    assert np.all(pad(sr.sign, 0)[147::148] == 0)
    lay = build_layout(build_ocp(short("truck", "lifted", "ellipse")))
    _sv, sr = split_soft_rows(lay, stage_view(lay))
    assert set(np.diff(sr.run_ptr).tolist()) == {3} and sr_lanes(sr) == 1
    ptr, pad = padded_runs(sr)
    np.testing.assert_array_equal(ptr, sr.run_ptr)
    np.testing.assert_array_equal(pad(sr.row), sr.row)


# -- the Python IPM against OSQP -----------------------------------------------------------------------------------


@pytest.mark.parametrize("sc,form,ob", CASES)
def test_ipm_equals_osqp_on_closed_loop_qps(sc, form, ob):
    """On the QPs of a closed loop driven by the IPM: the same primal as OSQP at eps 1e-7 (hyperplane variables
    aside: they are not unique when no obstacle row is active), the same objective and the same active set."""
    ref, qps = closed_loop_qps(short(sc, form, ob, qp=IPM_TIGHT))
    lay = ref.lay
    free = np.array([nm.startswith("theta") for nm in lay.var_names])
    compared = 0
    for P_x, A_x, q, l, u, y_warm, res in qps:
        assert res.status == QP_SOLVED and res.iter <= 40
        r_d, viol, comp = kkt(lay, P_x, A_x, q, l, u, res.z, res.y)
        assert r_d < 1e-7 and viol < 1e-7 and comp < 1e-6, (r_d, viol, comp)
        s = osqp.OSQP()
        s.setup(lay.P_matrix(), q, lay.A_pattern(A_x), l, u, **osqp_settings(OSQP_TIGHT))
        s.warm_start(y=y_warm)
        o = s.solve(raise_error=False)
        assert o.info.status_val == 1, o.info.status
        scale = max(1.0, float(np.max(np.abs(o.x))))
        assert np.max(np.abs(res.z - o.x)[~free]) / scale < 1e-5
        obj = [0.5 * z @ (P_x * z) + q @ z for z in (res.z, o.x)]
        assert abs(obj[0] - obj[1]) <= 1e-5 * max(1.0, abs(obj[1]))
        for a, b in ((res.y, o.y), (o.y, res.y)):  # a row clearly active in one is active, same side, in the other
            act = np.abs(a) > 1e-3
            assert np.all(np.sign(b[act]) == np.sign(a[act])) and np.all(np.abs(b[act]) > 1e-5)
        compared += 1
    assert compared == len(qps) >= 3


def test_ipm_scaled_start_by_hand():
    """The scaled start on a closed-loop QP's sides, by hand (the centring off): lam0 = max(lw, lam_min / max(1, -b))
    on every side (lw its warm multiplier, -b its slack at z = 0), t0 = max(-b, t_min / max(1, lam0)) on a soft row's
    slack bound and max(-b, t_min) elsewhere; the floor start lam0 = max(lw, lam_min), t0 = max(-b, t_min). The
    slack's floor is what sets some sides' lam0 (the test is not vacuous). From a cold start (no warm multiplier) the
    scaled start gives a slack's bound (a row of A with one entry, c, on a slack variable) lw = q_s / c, and that side
    the slack bound's t0; the floor start keeps lw = 0."""
    pb = paper_problem("truck", "lifted", "ellipse", profile="safe", qp=IPM)
    ref, qps = closed_loop_qps(pb, samples=3)
    P_x, A_x, q, l, u, y_warm = qps[-1][:6]
    A = ref.lay.A_pattern(A_x).tocsr()
    sv0 = stage_view(ref.lay)
    slack_vars = {int(v) for v in sv0.vmap[:, sv0.nx + sv0.NU :].ravel() if v >= 0}  # a stage's [x, u, slacks]
    for scaled in (False, True):
        be = IpmBackend(ref.lay, IPM, IpmSettings(scaled_start=scaled, lam_center=0.0))
        be.set_matrices(P_x, A_x, q)
        sv = be.sv
        sign = sv.side_sign.astype(float)
        b = np.where(sign > 0, l[sv.side_row], -u[sv.side_row])
        for warm in (True, False):
            yw = y_warm if warm else np.zeros_like(y_warm)
            _, t, lam, _ = be._start(q, b, yw)
            by_slack = cold = 0
            for j in range(len(b)):
                lw, slack = float(-sign[j] * yw[sv.side_row[j]]), float(-b[j])
                cols = A.indices[A.indptr[sv.side_row[j]] : A.indptr[sv.side_row[j] + 1]]
                bound = len(cols) == 1 and int(cols[0]) in slack_vars
                c = sign[j] * A[sv.side_row[j], cols[0]] if bound else 0.0
                if scaled and bound and lw == 0.0 and c > 0.0:
                    lw, cold = q[cols[0]] / c, cold + 1
                floor = 0.1 / max(1.0, slack) if scaled else 0.1
                by_slack += scaled and lw < floor < 0.1
                assert lam[j] == max(lw, floor)
                scaled_t = scaled and (be.slack_bound_side[j] or (bound and not warm and c > 0.0))
                assert t[j] == max(slack, 0.1 / max(1.0, lam[j]) if scaled_t else 0.1)
            assert by_slack > 0 if scaled else by_slack == 0
            assert cold == (0 if warm or not scaled else 160)  # the 120 soft rows' and the 40 a_lat rows' slacks


def test_ipm_scaled_start_same_solution_fewer_iterations():
    """The scaled start (``test_ipm_scaled_start_by_hand``: no floored initial t lam above t_min or lam_min) and the
    floor start (every side at lam >= lam_min, t >= max(-b, t_min)) reach the same QP optimum (at ipm_tol 1e-8: KKT
    points of one objective value); on the safe profile's QPs, whose soft rows' slack bounds carry multipliers near
    their L1 weights (1e8, 1e6), the scaled start needs fewer iterations in all from the warm duals (the closed loop's
    start). From a cold start (no warm multiplier) both reach the optimum too, and the scaled start's slack bounds at
    their slacks' costs (``test_ipm_scaled_start_by_hand``) take most of the floor start's iterations away (38 against
    200 on these 12 QPs, as many as from the warm duals)."""
    pb = paper_problem("truck", "lifted", "ellipse", profile="safe", qp=IPM)
    ref, qps = closed_loop_qps(pb, samples=12)
    lay = ref.lay
    tight = {s: IpmBackend(lay, QpOptions(backend="ipm", ipm_tol=1e-8, ipm_scaled_start=s)) for s in (False, True)}
    rt = {s: IpmBackend(lay, QpOptions(backend="ipm", ipm_scaled_start=s)) for s in (False, True)}
    iters = {(s, w): 0 for s in (False, True) for w in ("warm", "cold")}
    for P_x, A_x, q, l, u, y_warm, _ in qps:
        for s in (False, True):
            for be in (tight[s], rt[s]):
                be.set_matrices(P_x, A_x, q)
        for w, y0 in (("warm", y_warm), ("cold", np.zeros_like(y_warm))):
            res = {s: tight[s].solve(q, l, u, y0, 200) for s in (False, True)}
            for s, r in res.items():  # both KKT points of the QP, of the same objective (its primal need not be unique)
                assert r.status == QP_SOLVED
                r_d, viol, comp = kkt(lay, P_x, A_x, q, l, u, r.z, r.y)
                assert r_d < 1e-7 and viol < 1e-7 and comp < 1e-6, (r_d, viol, comp)
                iters[s, w] += rt[s].solve(q, l, u, y0, 60).iter
            obj = [0.5 * r.z @ (P_x * r.z) + q @ r.z for r in res.values()]
            assert abs(obj[0] - obj[1]) <= 1e-5 * max(1.0, abs(obj[1]))  # the gap: ~400 pairs of t lam <= 1e-8
    assert iters[True, "warm"] < iters[False, "warm"], iters
    assert 2 * iters[True, "cold"] < iters[False, "cold"], iters


def test_ipm_through_make_backend_and_reset():
    """make_backend selects the IPM; a reset backend and a fresh one give bit-identical results."""
    ref, qps = closed_loop_qps(short("truck", "lifted", "ellipse"), samples=2)
    P_x, A_x, q, l, u, y_warm, res = qps[-1]
    a = make_backend(ref.lay, IPM)
    assert isinstance(a, IpmBackend)
    a.set_matrices(P_x, A_x * 1.1, q)
    a.solve(q, l, u, y_warm, 60)
    a.reset()
    b = make_backend(ref.lay, IPM)
    for be in (a, b):
        be.set_matrices(P_x, A_x, q)
    ra, rb = a.solve(q, l, u, y_warm, 60), b.solve(q, l, u, y_warm, 60)
    assert ra.iter == rb.iter == res.iter
    np.testing.assert_array_equal(ra.z, rb.z)
    np.testing.assert_array_equal(ra.z, res.z)


def test_ipm_statuses_infeasible_and_nonfinite():
    """A box row on u_0 outside the reach of its bounds' complement: primal infeasible; NaN data: non-finite."""
    ref, qps = closed_loop_qps(short("truck", "lifted", "ellipse"), samples=1)
    P_x, A_x, q, l, u, y_warm, _ = qps[0]
    lay = ref.lay
    be = IpmBackend(lay, IPM)
    be.set_matrices(P_x, A_x, q)
    # x_1 is fixed by x_0 and u_0 (|u_0| <= 1 in scaled units); demand v_1 far beyond any reachable value
    r = lay.row_names.index("bound_v[1]")
    l2, u2 = l.copy(), u.copy()
    l2[r], u2[r] = 1e3, 1e3 + 1
    res = be.solve(q, l2, u2, y_warm, 200)
    assert res.status == QP_PRIMAL_INFEASIBLE, res
    q2 = q.copy()
    q2[3] = np.nan
    res = be.solve(q2, l, u, y_warm, 60)
    assert res.status == QP_NONFINITE and res.z is None


# -- generated C against the Python reference ---------------------------------------------------------------------

needs_cc = pytest.mark.skipif(any(shutil.which(t) is None for t in ("gcc", "make")), reason="needs gcc and make")


@needs_cc
@pytest.mark.parametrize("sc,form,ob", C_CASES)
def test_ipm_generates_and_verifies(tmp_path, sc, form, ob):
    """Every formulation and obstacle model, car and truck: the generated IPM (verification build) equals the Python
    IPM sample by sample (fcgen verify's tolerances: QP solution 1e-9 relative), and the folder has no OSQP file."""
    from fcgen.codegen.generate import generate
    from fcgen.verify import verify

    info = generate(short(sc, form, ob), tmp_path / "g")
    assert not (tmp_path / "g" / "osqp").exists() and info.library_files == ()
    rep = verify(tmp_path / "g", samples=3)
    assert rep.passed, rep.format()
    z = next(c for c in rep.checks if c.key == "z")
    assert z.compared == 3 and z.max_diff < 1e-9


@needs_cc
def test_ipm_single_precision_closed_loop(tmp_path):
    """A float build (ipm_tol 1e-3: float's ~1e-7 resolution times the QP's scaling) runs a closed loop: every QP
    solved to its tolerance, no error exit, the same progress as the double Python reference to 0.1 %."""
    from fcgen.build import build
    from fcgen.codegen.generate import generate
    from fcgen.csolver import CSolver
    from fcgen.sim.runlog import summary

    pb = short("truck", "lifted", "ellipse", N=20, qp=QpOptions(backend="ipm", ipm_tol=1e-3))
    generate(pb, tmp_path / "f", use_float=True)
    cs = CSolver(build(tmp_path / "f"))
    assert cs.dtype == np.float32
    sc = make_scenario("truck", 2, samples=40)
    log = run_closed_loop(pb, sc, controller=cs)
    assert np.all(log.qp_status == QP_SOLVED), np.unique(log.qp_status, return_counts=True)
    assert log.meta["extra"]["exit_codes_nonzero"] == 0 and not log.collision.any()
    ref = run_closed_loop(pb, sc)
    p_c, p_py = summary(log)["progress"], summary(ref)["progress"]
    assert abs(p_c - p_py) <= 1e-3 * p_py


@needs_cc
def test_cli_bench_backends(tmp_path):
    """fcgen bench --backends: OSQP real-time and the IPM in one run, ratios and figures in the results file."""
    import json

    from click.testing import CliRunner

    from fcgen.cli import main
    from fcgen.codegen.generate import generate

    generate(short("car", "lifted", "ellipse", qp=QpOptions()), tmp_path / "g")
    out = tmp_path / "b.json"
    res = CliRunner().invoke(
        main,
        [
            "bench",
            str(tmp_path / "g"),
            "--backends",
            "osqp,ipm",
            "--seeds",
            "1",
            "--samples",
            "4",
            "--clock",
            "cpu",
            "--out",
            str(out),
        ],
    )
    assert res.exit_code == 0, res.output
    r = json.loads(out.read_text())
    assert r["variants"] == ["osqp", "ipm"] and r["clock"] == "cpu"
    ipm, osq = r["results"]["ipm"], r["results"]["osqp"]
    assert ipm["qp"]["backend"] == "ipm" and osq["qp"]["backend"] == "osqp"
    assert ipm["samples"] == osq["samples"] == 4
    assert ipm["speedup_vs_osqp"] == pytest.approx(
        osq["time_ms"]["total"]["median"] / ipm["time_ms"]["total"]["median"]
    )
    assert ipm["static_ram_bytes"] < osq["static_ram_bytes"]
    assert "x vs osqp" in res.output and "ipm" in res.output
    bad = CliRunner().invoke(main, ["bench", str(tmp_path / "g"), "--backends", "osqp,hpipm"])
    assert bad.exit_code != 0 and "hpipm" in bad.output and "Traceback" not in bad.output
