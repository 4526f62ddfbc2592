"""OSQP embedded export: determinism, library restore, explicit zeros, C == Python, no malloc."""

from __future__ import annotations

import hashlib
import re
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import osqp
import pytest
import scipy.sparse as sp

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "generator"))
from fcgen.backends.osqp_const import CONST_ARRAYS
from fcgen.backends.osqp_export import OsqpExport, export_osqp, restore_osqp_library

pytestmark = pytest.mark.skipif(shutil.which("gcc") is None or shutil.which("nm") is None, reason="needs gcc and nm")

CFLAGS = ["-std=c99", "-pedantic", "-O2", "-ffp-contract=off", "-Wall", "-Wextra", "-Werror"]
PREFIX = "qp_"
SETTINGS = dict(
    rho=0.1,
    sigma=1e-6,
    alpha=1.6,
    max_iter=4000,
    eps_abs=1e-6,
    eps_rel=1e-6,
    check_termination=5,
    check_dualgap=False,
    adaptive_rho=1,
    adaptive_rho_interval=25,
    scaling=10,
    warm_starting=True,
)

MAIN_C = r"""
#include <stdio.h>
#include "osqp.h"
#include "@HEADER@"

@DATA@

static void dump(const char* tag, const OSQPSolver* s) {
  OSQPInt i;
  printf("%s status %d\n", tag, (int)s->info->status_val);
  printf("%s iter %d\n", tag, (int)s->info->iter);
  printf("%s obj %a\n", tag, (double)s->info->obj_val);
  for (i = 0; i < @N@; i++) printf("%s x %a\n", tag, (double)s->solution->x[i]);
  for (i = 0; i < @M@; i++) printf("%s y %a\n", tag, (double)s->solution->y[i]);
}

int main(void) {
  OSQPSolver* s = &@SOLVER@;
  OSQPInt flag;
  @PREFIX@workspace_reset(); /* the workspace is zero-initialized until then */
  flag = osqp_solve(s);
  dump("solve1", s);
  flag |= osqp_update_data_vec(s, q2, l2, u2);
  flag |= osqp_update_data_mat(s, Px2, OSQP_NULL, @PNNZ@, Ax2, OSQP_NULL, @ANNZ@);
  flag |= osqp_warm_start(s, xw, yw);
  flag |= osqp_solve(s);
  dump("solve2", s);
  /* runtime changes: rho (refactors) and settings copied from the live struct */
  flag |= osqp_update_rho(s, 0.3);
  {
    OSQPSettings st = *s->settings;
    st.eps_abs = 1e-8;
    st.eps_rel = 1e-8;
    st.check_termination = 10;
    flag |= osqp_update_settings(s, &st);
  }
  flag |= osqp_update_data_vec(s, q3, OSQP_NULL, OSQP_NULL);
  flag |= osqp_solve(s);
  dump("solve3", s);
  /* after all that, the reset workspace solves the exported QP exactly as the fresh one did */
  @PREFIX@workspace_reset();
  flag |= osqp_solve(s);
  dump("solve4", s);
  return (int)flag;
}
"""


def _csc(pattern: np.ndarray, values: np.ndarray) -> sp.csc_matrix:
    """CSC with every True of `pattern` structural (explicit zeros kept)."""
    cols, rows = np.nonzero(pattern.T)  # column-major order
    indptr = np.concatenate([[0], np.cumsum(pattern.sum(axis=0))])
    return sp.csc_matrix((values[rows, cols], rows.astype(np.int32), indptr.astype(np.int32)), shape=pattern.shape)


@pytest.fixture(scope="module")
def qp() -> dict[str, np.ndarray | sp.csc_matrix]:
    rng = np.random.default_rng(42)
    n, m = 20, 30
    M = rng.standard_normal((n, n)) * (rng.random((n, n)) < 0.2)
    Pd = M @ M.T + 0.1 * np.eye(n)
    pat_P = np.triu((Pd != 0) | (rng.random((n, n)) < 0.1))  # extra entries are explicit zeros
    P = _csc(pat_P, np.triu(Pd))
    pat_A = rng.random((m, n)) < 0.15
    pat_A[np.arange(m), rng.integers(0, n, m)] = True
    Ad = rng.standard_normal((m, n)) * pat_A
    Ad[pat_A & (rng.random((m, n)) < 0.2)] = 0.0  # explicit zeros in A
    A = _csc(pat_A, Ad)
    x0 = rng.standard_normal(n)
    Ax0 = A @ x0
    l = Ax0 - rng.random(m)
    u = Ax0 + rng.random(m)
    l[:4] = u[:4] = Ax0[:4]  # equalities (rho_vec)
    l[4:8] = -np.inf  # one-sided
    u[8:10] = np.inf
    q = rng.standard_normal(n)
    # second problem: same pattern, structural zeros become nonzero
    P2 = P.copy()
    P2.data = 1.3 * P.data + np.where(P2.data == 0.0, 0.02, 0.0)
    P2 = P2 + sp.diags(np.full(n, 1.0), format="csc")
    P2 = _csc(pat_P, P2.toarray())
    assert np.linalg.eigvalsh(P2.toarray() + np.triu(P2.toarray(), 1).T).min() > 0
    A2 = A.copy()
    A2.data = A.data + 0.1 * rng.standard_normal(A.nnz)
    Ax2 = A2 @ x0
    l2, u2 = Ax2 - rng.random(m), Ax2 + rng.random(m)
    l2[:4] = u2[:4] = Ax2[:4]
    l2[4:8] = -np.inf
    u2[8:10] = np.inf
    assert P.nnz > np.count_nonzero(P.data) and A.nnz > np.count_nonzero(A.data)
    return dict(
        P=P,
        A=A,
        q=q,
        l=l,
        u=u,
        P2=P2,
        A2=A2,
        q2=rng.standard_normal(n),
        q3=rng.standard_normal(n),
        l2=l2,
        u2=u2,
        xw=rng.standard_normal(n),
        yw=rng.standard_normal(m),
    )


def _export(qp: dict, out_dir: Path, use_float: bool = False) -> OsqpExport:
    return export_osqp(qp["P"], qp["A"], qp["q"], qp["l"], qp["u"], SETTINGS, out_dir, PREFIX, use_float)


def _hashes(root: Path) -> dict[str, str]:
    return {
        p.relative_to(root).as_posix(): hashlib.sha256(p.read_bytes()).hexdigest()
        for p in sorted(root.rglob("*"))
        if p.is_file()
    }


def _c_array(ctype: str, name: str, v: np.ndarray) -> str:
    def lit(x: float) -> str:
        return "OSQP_INFTY" if x == np.inf else "-OSQP_INFTY" if x == -np.inf else float(x).hex()

    return f"static const {ctype} {name}[{len(v)}] = {{{', '.join(lit(x) for x in v)}}};"


def _build(exp: OsqpExport, out_dir: Path, build: Path, qp: dict) -> tuple[Path, list[Path]]:
    """Compile workspace + library to objects (our flags) and link the test main."""
    build.mkdir()
    inc = [f"-I{out_dir / d}" for d in exp.include_dirs]
    private = [f"-I{out_dir / d}" for d in exp.private_include_dirs]
    objs = []
    for src in exp.workspace_sources + exp.library_sources:
        obj = build / (Path(src).stem + ".o")
        subprocess.run(
            ["gcc", *CFLAGS, *exp.cflags, *inc, *private, "-c", str(out_dir / src), "-o", str(obj)],
            check=True,
            capture_output=True,
            text=True,
        )
        objs.append(obj)
    data = "\n".join(
        [_c_array("OSQPFloat", k, qp[k]) for k in ("q2", "q3", "l2", "u2", "xw", "yw")]
        + [_c_array("OSQPFloat", "Px2", qp["P2"].data), _c_array("OSQPFloat", "Ax2", qp["A2"].data)]
    )
    main = MAIN_C
    for key, val in dict(
        HEADER=exp.workspace_header,
        DATA=data,
        N=exp.n,
        M=exp.m,
        SOLVER=exp.solver_name,
        PREFIX=exp.prefix,
        PNNZ=exp.P_nnz,
        ANNZ=exp.A_nnz,
    ).items():
        main = main.replace(f"@{key}@", str(val))
    (build / "main.c").write_text(main)
    exe = build / "main"
    # our own code: strict flags without OSQP's relaxations, public include dirs only
    subprocess.run(
        [
            "gcc",
            *CFLAGS,
            *inc,
            str(build / "main.c"),
            *map(str, objs),
            "-o",
            str(exe),
            *[f"-l{lib}" for lib in exp.link_libs],
        ],
        check=True,
        capture_output=True,
        text=True,
    )
    return exe, objs


def _run(exe: Path) -> dict[str, dict[str, np.ndarray | int | float]]:
    out = subprocess.run([str(exe)], check=True, capture_output=True, text=True).stdout
    res: dict[str, dict] = {}
    for line in out.splitlines():
        tag, key, *rest = line.split()
        r = res.setdefault(tag, {"x": [], "y": []})
        if key in ("x", "y"):
            r[key].append(float.fromhex(rest[0]))
        else:
            r[key] = int(rest[0]) if key in ("status", "iter") else float.fromhex(rest[0])
    for r in res.values():
        r["x"], r["y"] = np.array(r["x"]), np.array(r["y"])
    return res


def _python_reference(qp: dict, exp: OsqpExport) -> dict[str, object]:
    """The same call sequence as MAIN_C through the osqp Python package."""
    s = osqp.OSQP()
    s.setup(qp["P"], qp["q"], qp["A"], qp["l"], qp["u"], **dict(exp.settings))
    r1 = s.solve(raise_error=False)
    r1 = dict(status=r1.info.status_val, iter=r1.info.iter, obj=r1.info.obj_val, x=r1.x.copy(), y=r1.y.copy())
    s.update(q=qp["q2"], l=qp["l2"], u=qp["u2"], Px=qp["P2"].data, Ax=qp["A2"].data)  # vec, then mat
    s.warm_start(x=qp["xw"], y=qp["yw"])
    r2 = s.solve(raise_error=False)
    r2 = dict(status=r2.info.status_val, iter=r2.info.iter, obj=r2.info.obj_val, x=r2.x.copy(), y=r2.y.copy())
    s.update_settings(rho=0.3, eps_abs=1e-8, eps_rel=1e-8, check_termination=10)
    s.update(q=qp["q3"])
    r3 = s.solve(raise_error=False)
    r3 = dict(status=r3.info.status_val, iter=r3.info.iter, obj=r3.info.obj_val, x=r3.x.copy(), y=r3.y.copy())
    return {"solve1": r1, "solve2": r2, "solve3": r3}


def test_deterministic_and_restorable(qp: dict, tmp_path: Path) -> None:
    a, b = tmp_path / "a", tmp_path / "elsewhere" / "b"
    exp = _export(qp, a)
    _export(qp, b)
    ha, hb = _hashes(a), _hashes(b)
    assert ha == hb
    ws = {f"osqp/{PREFIX}workspace.c", f"osqp/{PREFIX}workspace.h", f"osqp/{PREFIX}osqp_rename.h"}
    assert set(exp.workspace_sources + exp.workspace_headers) == ws
    assert set(ha) == ws | set(exp.library_sources + exp.library_headers)
    assert all(f.startswith("osqp/lib/") for f in exp.library_sources + exp.library_headers)
    assert "osqp/lib/osqp_configure.h" in exp.library_headers
    for f in ha:
        text = (a / f).read_text()
        assert str(tmp_path) not in text and "/tmp" not in text
        assert not re.search(r"autogenerated by OSQP on", text)
    # the library does not depend on the problem: restore it from a dummy QP
    shutil.rmtree(a / "osqp" / "lib")
    restored = restore_osqp_library(a, use_float=False)
    assert sorted(restored) == sorted(exp.library_sources + exp.library_headers)
    assert _hashes(a) == ha
    # float differs only in osqp_configure.h
    restore_osqp_library(b, use_float=True)
    diff = {f for f, h in _hashes(b).items() if ha[f] != h}
    assert diff == {"osqp/lib/osqp_configure.h"}
    assert "#define OSQP_USE_FLOAT" in (b / "osqp/lib/osqp_configure.h").read_text()
    assert "#define OSQP_EMBEDDED_MODE 2" in (b / "osqp/lib/osqp_configure.h").read_text()
    assert f'#include "{PREFIX}osqp_rename.h"' in (b / "osqp/lib/osqp_configure.h").read_text()


def _c_ints(text: str, name: str) -> np.ndarray:
    body = re.search(rf"OSQPInt {name}(?:_init)?\[\d+\] = {{(.*?)}};", text, re.S)  # const (or a const copy)
    assert body is not None
    return np.array([int(t) for t in body.group(1).replace(",", " ").split()])


def test_explicit_zeros_are_structural(qp: dict, tmp_path: Path) -> None:
    exp = _export(qp, tmp_path)
    text = (tmp_path / exp.workspace_sources[0]).read_text()
    for name, M in (("P", qp["P"]), ("A", qp["A"])):
        assert np.array_equal(_c_ints(text, f"{PREFIX}data_{name}_csc_i"), M.indices)
        assert np.array_equal(_c_ints(text, f"{PREFIX}data_{name}_csc_p"), M.indptr)
    with pytest.raises(ValueError):
        export_osqp(qp["P"].T.tocsc(), qp["A"], qp["q"], qp["l"], qp["u"], SETTINGS, tmp_path / "x", PREFIX)
    with pytest.raises(ValueError):
        export_osqp(qp["P"], qp["A"], qp["q"], qp["l"], qp["u"], {"polishing": True}, tmp_path / "x", PREFIX)


def test_c_matches_python_and_no_malloc(qp: dict, tmp_path: Path) -> None:
    out = tmp_path / "gen"
    exp = _export(qp, out)
    exe, objs = _build(exp, out, tmp_path / "build", qp)
    c = _run(exe)
    py = _python_reference(qp, exp)
    assert set(c) == {"solve1", "solve2", "solve3", "solve4"}
    for tag in py:
        assert py[tag]["status"] == 1, tag  # OSQP_SOLVED
        assert c[tag]["status"] == py[tag]["status"] and c[tag]["iter"] == py[tag]["iter"], tag
        np.testing.assert_array_equal(c[tag]["x"], py[tag]["x"])  # bit-identical
        np.testing.assert_array_equal(c[tag]["y"], py[tag]["y"])
        assert c[tag]["obj"] == py[tag]["obj"]
    assert not np.allclose(c["solve1"]["x"], c["solve2"]["x"])  # the update path changed the problem
    # workspace_reset after three solves, updates and a rho change: bitwise the fresh workspace's solve
    for key in ("status", "iter", "obj"):
        assert c["solve4"][key] == c["solve1"][key]
    np.testing.assert_array_equal(c["solve4"]["x"], c["solve1"]["x"])
    np.testing.assert_array_equal(c["solve4"]["y"], c["solve1"]["y"])
    forbidden = {"malloc", "calloc", "realloc", "free", "printf", "puts", "putchar", "fprintf", "fwrite", "fputs"}
    for obj in objs:
        undefined = set(
            subprocess.run(["nm", "-u", str(obj)], check=True, capture_output=True, text=True).stdout.split()
        ) - {"U"}
        assert not (undefined & forbidden), (obj.name, undefined & forbidden)
        defined = subprocess.run(
            ["nm", "-g", "--defined-only", str(obj)], check=True, capture_output=True, text=True
        ).stdout.split("\n")
        names = [f[2] for f in (line.split() for line in defined) if len(f) == 3]
        assert [n for n in names if not n.startswith(PREFIX)] == [], obj.name  # OSQP's symbols carry the prefix
    # the arrays OSQP never writes are read-only data (a write would have crashed the solves above)
    ws_obj = next(o for o in objs if o.name == f"{PREFIX}workspace.o")
    kinds = {
        f[2]: f[1]
        for f in (
            line.split()
            for line in subprocess.run(
                ["nm", str(ws_obj)], check=True, capture_output=True, text=True
            ).stdout.splitlines()
        )
        if len(f) == 3
    }
    assert {kinds[PREFIX + a] for a in CONST_ARRAYS} == {"R"}
    assert kinds[f"{PREFIX}linsys_L_x"] in "DB" and kinds[f"{PREFIX}data_A_csc_x"] in "DB"


def test_float_build(qp: dict, tmp_path: Path) -> None:
    out = tmp_path / "gen"
    exp = _export(qp, out, use_float=True)
    assert "#define OSQP_USE_FLOAT" in (out / "osqp/lib/osqp_configure.h").read_text()
    exe, _ = _build(exp, out, tmp_path / "build", qp)
    c = _run(exe)
    py = _python_reference(qp, exp)
    for tag in py:
        scale = 1.0 + np.abs(py[tag]["x"]).max()
        assert np.abs(c[tag]["x"] - py[tag]["x"]).max() < 1e-2 * scale, tag


def test_workspace_initial_values_are_const(qp: dict, tmp_path: Path) -> None:
    """Every initialized workspace object is zero-initialized RAM plus a const copy; nothing is in .data."""
    out = tmp_path / "gen"
    exp = _export(qp, out)
    _, objs = _build(exp, out, tmp_path / "build", qp)
    ws_obj = next(o for o in objs if o.stem == f"{PREFIX}workspace")
    sections = {}
    for line in subprocess.run(
        ["size", "-A", str(ws_obj)], check=True, capture_output=True, text=True
    ).stdout.splitlines():
        parts = line.split()
        if len(parts) >= 2 and parts[0].startswith("."):
            sections[parts[0]] = int(parts[1])
    assert sections.get(".data", 0) == 0 and sections[".bss"] > 0 and sections[".rodata"] > 0
    text = (out / exp.workspace_sources[0]).read_text()
    assert f"void {PREFIX}workspace_reset(void)" in text
    assert f"void {PREFIX}workspace_reset(void);" in (out / exp.workspace_headers[0]).read_text()
    # one restore line per top-level object: memcpy for each initialized one, memset for the others
    n_init = text.count("static const ")
    assert n_init > 20 and text.count("  memcpy(&") == n_init
    n_objects = len(re.findall(r"^\w+\s+\w+(?:\[\d+\])?;$", text, re.M))  # every mutable object, declared once
    assert text.count("  memset(&") == n_objects - n_init > 0


def test_stale_library_copy_is_resynced(qp: dict, tmp_path: Path) -> None:
    """A library copy left by an older fcgen (here: QDLDL without the const-pattern patch, an unprefixed header) is
    brought up to date by the backend's restore, not trusted because it exists (it built and then crashed)."""
    from fcgen.backends.osqp import restore_library

    a = tmp_path / "a"
    _export(qp, a)
    good = _hashes(a)
    qdldl = next((a / "osqp" / "lib").rglob("qdldl.c"))
    qdldl.write_text(qdldl.read_text() + "\n/* stale */\n")
    (a / "osqp" / "lib" / "osqp_configure.h").write_text("/* an old configure header */\n")
    restore_library(a, use_float=False)
    assert _hashes(a) == good
