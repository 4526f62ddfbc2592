"""The IPM's gather maps of the stage view (``qp.stage_view``), padded to fixed sizes: what the Python IPM
(``backends/ipm.py``) indexes with and what the C's tables (``codegen/ipm_header.py``) are made of."""

from __future__ import annotations

import itertools

import numpy as np

from ..qp import QpLayout, StageView


class IpmTables:
    """Gather maps of the stage view, padded to fixed sizes (dummy index = one past the end)."""

    def __init__(self, lay: QpLayout, sv: StageView):
        nxu = sv.nx + sv.NU
        self.vmap_xu = np.where(sv.vmap[:, :nxu] >= 0, sv.vmap[:, :nxu], lay.n)
        self.vmap_s = np.where(sv.vmap[:, nxu:] >= 0, sv.vmap[:, nxu:], lay.n)
        self.gen_row = np.where(sv.gen_rows >= 0, sv.gen_rows, lay.m)
        self._general_slots(lay, sv)
        self._inequality_entries(sv)
        self._slack_groups(sv)
        self._inequality_rows(sv)
        self._dynamics_and_equalities(lay, sv)
        # inputs without cost (hyperplane variables): 1 where the proximal weight applies
        self.free_inputs = np.zeros(lay.n)
        for k in range(sv.N + 1):
            v = sv.vmap[k, sv.nx : sv.nx + sv.nu[k]]
            self.free_inputs[v[lay.P_diag[v] == 0]] = 1.0

    def _general_slots(self, lay: QpLayout, sv: StageView) -> None:
        """Per general slot (k, g): the data index of each (x, u) slot, of its slack entry, and its slack."""
        N, NS, NG, nxu = sv.N, sv.NS, sv.NG, sv.nx + sv.NU
        self.gen_xu = np.full((N + 1, NG, nxu), lay.nnz_A, dtype=np.int64)
        self.gen_e = np.full((N + 1, NG), lay.nnz_A, dtype=np.int64)
        self.gen_s = np.full((N + 1, NG), NS, dtype=np.int64)
        for k in range(N + 1):
            for g in range(NG):
                slot = k * NG + g
                for v, a in zip(
                    sv.gen_v[sv.gen_ptr[slot] : sv.gen_ptr[slot + 1]], sv.gen_a[sv.gen_ptr[slot] : sv.gen_ptr[slot + 1]]
                ):
                    if v < nxu:
                        self.gen_xu[k, g, v] = a
                    else:
                        self.gen_e[k, g], self.gen_s[k, g] = a, v - nxu

    def _inequality_entries(self, sv: StageView) -> None:
        """The inequality rows' entries in the C's order (general slots: inputs/states, then the slack; then box
        rows), and the general slots' (x, u) entries as lists."""
        nxu = sv.nx + sv.NU
        gptr, gv, ga, gvar, svar = [0], [], [], [], []
        ent_row, ent_var, ent_a = [], [], []
        for k in range(sv.N + 1):
            for g in range(sv.NG):
                slot = k * sv.NG + g
                sl = slice(sv.gen_ptr[slot], sv.gen_ptr[slot + 1])
                row, s_var = sv.gen_rows[k, g], -1
                for v, a in zip(sv.gen_v[sl], sv.gen_a[sl]):
                    if v < nxu:
                        gv.append(int(v))
                        ga.append(int(a))
                        gvar.append(int(sv.vmap[k, v]))
                        ent_row.append(row)
                        ent_var.append(int(sv.vmap[k, v]))
                        ent_a.append(int(a))
                    else:
                        s_var, s_a = int(sv.vmap[k, v]), int(a)
                if s_var >= 0:
                    ent_row.append(row)
                    ent_var.append(s_var)
                    ent_a.append(s_a)
                gptr.append(len(gv))
                svar.append(s_var)
        ent_row += sv.box_rows.tolist()
        ent_var += sv.box_var.tolist()
        ent_a += sv.box_a.tolist()
        self.gen_xu_ptr, self.gen_xu_v, self.gen_xu_a, self.gen_var = gptr, gv, ga, gvar
        if any(gv[i] >= gv[i + 1] for p0, p1 in itertools.pairwise(gptr) for i in range(p0, p1 - 1)):
            raise AssertionError("stage view: a general row's stage slots must ascend")
        self.gen_svar = svar
        self.ent_row, self.ent_var, self.ent_a = (np.array(x, dtype=np.int64) for x in (ent_row, ent_var, ent_a))

    def _slack_groups(self, sv: StageView) -> None:
        """Each slack's general slots (its group), padded (``slack_rows``) and compact (``sg_g``, ``sg_ptr``)."""
        N, NS, NG = sv.N, sv.NS, sv.NG
        groups = [[[g for g in range(NG) if self.gen_s[k, g] == j] for j in range(NS)] for k in range(N + 1)]
        RS = max([1] + [len(gr) for gk in groups for gr in gk])
        self.slack_rows = np.full((N + 1, NS, RS), NG, dtype=np.int64)  # general slots of slack j; NG: none
        for k in range(N + 1):
            for j in range(NS):
                self.slack_rows[k, j, : len(groups[k][j])] = groups[k][j]
        # the same compactly (the C's loops): slack j of stage k holds the general slots sg_g[sg_ptr[k NS + j]:...]
        self.sg_g = np.array([g for gk in groups for gr in gk for g in gr], dtype=np.int64)
        self.sg_ptr = np.r_[0, np.cumsum([len(gr) for gk in groups for gr in gk])].astype(np.int64)

    def _inequality_rows(self, sv: StageView) -> None:
        """Inequality rows (ascending): their sides are ``in_ptr[i]:in_ptr[i + 1]`` (the sides are sorted by row)."""
        self.in_rows, counts = np.unique(sv.side_row, return_counts=True)
        self.in_ptr = np.r_[0, np.cumsum(counts)].astype(np.int64)
        pos = {int(r): i for i, r in enumerate(self.in_rows)}
        self.gen_in = np.array([pos.get(int(r), -1) for r in sv.gen_rows.ravel()], dtype=np.int64)
        self.box_in = np.array([pos[int(r)] for r in sv.box_rows], dtype=np.int64)

    def _dynamics_and_equalities(self, lay: QpLayout, sv: StageView) -> None:
        """The data indices of each stage's [A B] and of its stage equalities' D, dense."""
        N, nx, NU, NE = sv.N, sv.nx, sv.NU, sv.NE
        self.dyn_ab = np.full((N, nx, nx + NU), lay.nnz_A, dtype=np.int64)
        for k in range(N):
            sl = slice(sv.dyn_ptr[k], sv.dyn_ptr[k + 1])
            self.dyn_ab[k, sv.dyn_i[sl], sv.dyn_j[sl]] = sv.dyn_a[sl]
        self.eq_d = np.full((N + 1, NE, NU), lay.nnz_A, dtype=np.int64)
        self.eq_row = np.where(sv.eq_rows >= 0, sv.eq_rows, lay.m)
        for k in range(N + 1):
            for e in range(NE):
                slot = k * NE + e
                sl = slice(sv.eq_ptr[slot], sv.eq_ptr[slot + 1])
                self.eq_d[k, e, sv.eq_j[sl]] = sv.eq_a[sl]
        self.eq_pad = (sv.eq_rows < 0).astype(float)
