"""The IPM's algorithm as plain C (csrc/ipm/ipm_core.c and its parts), compiled on its own with a problem header
rendered by fcgen, on the QPs a Python closed loop solved: the same statuses, iterations and solutions as the Python
IPM, and (an independent check) its solutions satisfy the QP's optimality conditions."""

from __future__ import annotations

import subprocess
from pathlib import Path

import numpy as np
import pytest
from test_ipm import kkt

from fcgen.backends import QP_SOLVED
from fcgen.codegen.ipm_header import codegen_context, core_files
from fcgen.codegen.render import csrc_dir, render_template
from fcgen.dsl import Horizon, QpOptions
from fcgen.ocp import build_ocp
from fcgen.presets import paper_problem
from fcgen.reference import RtiSolver
from fcgen.sim.closedloop import ReferenceController, run_closed_loop
from fcgen.sim.scenario import make_scenario

HARNESS = Path(__file__).parent / "c" / "ipm_core_test.c"


def record_events(pb, samples: int, seed: int = 1):
    """The backend calls of a Python closed loop, in order: ('R',), ('M', P, A, q), ('S', q, l, u, y, it, result)."""
    ocp = build_ocp(pb)
    ref = RtiSolver(ocp)
    inner, events = ref.qp, []

    class Recorder:
        name = "recorder"

        def reset(self):
            events.append(("R",))
            inner.reset()

        def set_matrices(self, P_x, A_x, q):
            events.append(("M", np.array(P_x, float), np.array(A_x, float), np.array(q, float)))
            inner.set_matrices(P_x, A_x, q)

        def solve(self, q, l, u, y_warm, max_iter):
            res = inner.solve(q, l, u, y_warm, max_iter)
            events.append(("S", *(np.array(a, float) for a in (q, l, u, y_warm)), max_iter, res))
            return res

    ref.qp = Recorder()
    run_closed_loop(pb, make_scenario(pb.name.split("_")[0], seed, samples=samples), ReferenceController(ocp, ref), ocp)
    return ocp, ref.lay, events


def build_harness(ocp, lay, opts, tmp: Path, generic_rows: bool = False) -> Path:
    ctx = codegen_context(ocp, lay, opts)
    if generic_rows:  # every stage's general rows by the generic loops (no IPM_GEN_PAT table, no written-out kernels)
        ctx = {**ctx, "GEN_WRITTEN": 0, "tables": [t for t in ctx["tables"] if t["name"] != "IPM_GEN_PAT"]}
    (tmp / "ipm_problem.h").write_text(
        render_template(
            "backends/ipm_problem.h.j2",
            name="tipm",
            NAME="TIPM",
            backend=ctx,
            c_sqrt="sqrt",
            c_fabs="fabs",
            c_fmin="fmin",
        )
    )
    exe = tmp / ("ipm_core_test_generic" if generic_rows else "ipm_core_test")
    subprocess.run(
        [
            "cc",
            "-std=c99",
            "-O2",
            "-Wall",
            "-Wextra",
            "-Werror",
            "-Wno-unused-function",
            "-ffp-contract=off",
            "-fno-tree-slp-vectorize",
            f"-I{tmp}",
            f"-I{csrc_dir() / 'ipm'}",
            str(HARNESS),
            "-o",
            str(exe),
            "-lm",
        ],
        check=True,
        capture_output=True,
        text=True,
    )
    return exe


def run_harness(exe: Path, lay, events, tmp: Path) -> np.ndarray:
    """The harness on the recorded backend calls: per solve, status, raw status, iterations, the probes, z, y."""
    with open(tmp / "events.bin", "wb") as f:
        for e in events:
            f.write(e[0].encode())
            if e[0] == "M":
                f.write(np.concatenate(e[1:4]).tobytes())
            elif e[0] == "S":
                f.write(np.concatenate([*e[1:5], [float(e[5])]]).tobytes())
    out = tmp / f"out_{exe.name}.bin"
    subprocess.run([str(exe), str(lay.n), str(lay.m), str(lay.nnz_A), str(tmp / "events.bin"), str(out)], check=True)
    return np.fromfile(out).reshape(-1, 7 + lay.n + lay.m)


@pytest.mark.parametrize(
    "sc,form,ob",
    [("truck", "lifted", "ellipse"), ("car", "conventional", "hyperplane")],
    ids=["no_equalities", "stage_equalities"],
)
def test_ipm_core_alone_equals_the_python_ipm(sc, form, ob, tmp_path):
    pb = paper_problem(sc, form, ob, horizon=Horizon(N=10), qp=QpOptions(backend="ipm"))
    ocp, lay, events = record_events(pb.with_(name=f"{sc}_x"), samples=6)
    ctx = codegen_context(ocp, lay, pb.qp)
    assert (ctx["NE"] > 0) == (form == "conventional")  # both branches of the core's #if IPM_NE > 0
    assert (ctx["NE"] == 0 and ctx["U_DENSE"] == 1) == (form == "lifted")  # and of #if IPM_U_FUSED
    exe = build_harness(ocp, lay, pb.qp, tmp_path)
    n = lay.n
    out = run_harness(exe, lay, events, tmp_path)
    solves = [e for e in events if e[0] == "S"]
    assert len(out) == len(solves) >= 6
    P = next(e for e in events if e[0] == "M")
    for row, (_, _q, _l, _u, _y_warm, _it, res) in zip(out, solves):
        status, raw, iters, start, checks, steps, end = (int(v) for v in row[:7])
        z, y = row[7 : 7 + n], row[7 + n :]
        assert (status, raw, iters) == (res.status, res.raw_status, res.iter)
        # the timing probe (fcgen wcet): each phase once per iteration, a solved QP's last check stops it
        assert (start, checks, steps, end) == (1, iters + 1, iters, 1)
        assert status == QP_SOLVED
        scale = max(1.0, float(np.max(np.abs(res.z))))
        assert np.max(np.abs(z - res.z)) <= 1e-9 * scale
        assert np.max(np.abs(y - res.y)) <= 1e-9 * max(1.0, float(np.max(np.abs(res.y))))
    # optimality of the last QP's C solution, independent of the Python IPM (stopping tolerance 1e-4, scaled QP)
    last_M = [e for e in events if e[0] == "M"][-1]
    r_d, viol, comp = kkt(lay, last_M[1], last_M[2], solves[-1][1], solves[-1][2], solves[-1][3], z, y)
    assert r_d < 1e-2 and viol < 1e-2 and comp < 1e-2, (r_d, viol, comp)
    assert P is not None


def test_written_out_general_rows_equal_the_generic_loops(tmp_path):
    """The general rows of the stages of the commonest pattern (gen_kernels: the a_lat rows, two rows on (v, delta)
    sharing one slack) written out give the generic loops' results bit for bit, over whole closed-loop QPs."""
    pb = paper_problem("truck", "lifted", "ellipse", horizon=Horizon(N=10), qp=QpOptions(backend="ipm"))
    ocp, lay, events = record_events(pb.with_(name="truck_x"), samples=6)
    ctx = codegen_context(ocp, lay, pb.qp)
    flags = [f.strip() for f in next(t for t in ctx["tables"] if t["name"] == "IPM_GEN_PAT")["body"].split(",")]
    assert ctx["GEN_WRITTEN"] == 1 and flags == ["0"] + ["1"] * 10  # stage 0 has no a_lat rows
    assert "IPM_W.H[3][4] +=" in ctx["kernels"]["gen_h"]  # rows on slots 3, 4 (v, delta), written out
    written = run_harness(build_harness(ocp, lay, pb.qp, tmp_path), lay, events, tmp_path)
    generic = run_harness(build_harness(ocp, lay, pb.qp, tmp_path, generic_rows=True), lay, events, tmp_path)
    assert len(written) >= 6 and np.array_equal(written, generic)


def test_the_core_is_not_a_template():
    files = core_files()
    assert files[0].name == "ipm_core.c" and len(files) > 2
    src = "".join(f.read_text() for f in files)
    assert "{{" not in src and "{%" not in src and "{#" not in src
    assert "qpb_solve" in src and "#if IPM_NE > 0" in src
