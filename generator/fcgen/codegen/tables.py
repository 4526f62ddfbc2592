"""The solver's constant tables and constants of one problem: the stage descriptors, the slacks, the opponent fit's and
the curve speed's constants, the A permutation's cycles (rendered by ``templates/solver.c.j2``)."""

from __future__ import annotations

from typing import Any

import numpy as np

from ..c_literals import c_real
from ..dsl import Problem
from ..ocp import Ocp
from ..qp import QpLayout


def curve_speed_constants(problem: Problem) -> dict | None:
    """The curve speed's literals (``fcgen.road.curve_speed``): a_lat, its value in traffic (a_lat when that is off)
    and the clearance that means traffic, 2 decel, v_max^2; None when it is off."""
    ref, v_max = problem.reference, problem.bounds.v_max
    if ref.curve_a_lat <= 0.0:
        return None
    traffic = ref.curve_traffic_clearance > 0.0
    return {
        "a_lat": c_real(ref.curve_a_lat),
        "two_decel": c_real(2.0 * ref.curve_decel),
        "a_lat_traffic": c_real(ref.curve_a_lat_traffic if traffic else ref.curve_a_lat),
        "traffic_clearance": c_real(ref.curve_traffic_clearance),
        "v2_max": c_real(v_max * v_max),
        "along": ref.curve_along_horizon,
    }


def stage_table(ocp: Ocp, lay: QpLayout) -> list[dict[str, Any]]:
    """Per-stage descriptors: function kind and the offsets of its variables, rows, Jacobian, successor state."""
    N, nx, nu = ocp.N, ocp.nx, ocp.nu
    v_ref = ocp.problem.reference.v_ref
    times = ocp.problem.horizon.times
    out = []
    for k in range(N + 1):
        st = ocp.stage(k)
        var = int(lay.var_off[k])
        names = st.var_names
        out.append(
            {
                "k": k,
                "kind": "STAGE_" + st.name.upper(),
                "var": var,
                "row": int(lay.row_off[k]),
                "jac": int(lay.jac_off[k]),
                "next": int(lay.var_off[k + 1]) if k < N else -1,
                "s": int(lay.s_vars[k]),
                "u": var + names.index("F_d") if k < N else -1,
                "theta": var + nx + nu * (k < N) if (k >= 1 and ocp.n_theta) else -1,
                "sigma": var + names.index("sigma0") if "sigma0" in names else -1,
                "s_ref": c_real(times[k] * v_ref),  # the reference's s_ref offset, same rounding
                "t": c_real(times[k]),  # the node's time (Horizon.times), also the cold-start guess's
            }
        )
        assert names[0] == "s" and out[-1]["s"] == var
        if k < N:
            assert names[nx : nx + nu] == ("F_d", "r") and out[-1]["u"] == var + nx
    return out


def slack_vars(ocp: Ocp, lay: QpLayout) -> np.ndarray:
    """Indices of the slack variables of stages 1..N (the reference's ``slacks()``)."""
    return np.concatenate(
        [np.arange(lay.var_off[k + 1] - ocp.n_sigma, lay.var_off[k + 1]) for k in range(1, ocp.N + 1)]
    ).astype(np.int64)


def far_opponent_row(ocp: Ocp) -> np.ndarray:
    """Parameters of one opponent far away from any ego position on the example's straight road."""
    return np.array([-1000.0, 500.0, 0.0])  # every formulation takes poses; the conventional one leaves it out


def fit_context(ocp: Ocp) -> dict[str, Any] | None:
    """Constants of the conventional opponent fit for the template (``None`` for the other formulations)."""
    from .. import oppfit

    f = ocp.fit
    if f is None:
        return None
    if oppfit.FULL_EVALS < 1:
        raise AssertionError("the C fit takes n and phi_gamma from a road evaluation: FULL_EVALS >= 1")
    return {
        "npt": f.npt,
        "ref": f.ref_point,
        "search": oppfit.SEARCH,
        "window": oppfit.FOOT_WINDOW,
        "nbox": len(oppfit.BOX),
        "nedge": f.n_edge,
        "nev": len(oppfit.EVAL),
        "par": ocp.n_opp_stage,
        "sixth": c_real(1.0 / 6.0),
        "full": oppfit.FULL_EVALS,
        "rot_max": c_real(oppfit.ROT_MAX),
        "sin_c": [c_real(c) for c in oppfit.SIN_C],
        "cos_c": [c_real(c) for c in oppfit.COS_C],
        "dg_min": c_real(oppfit.NEWTON_DG_MIN),
        "counts": f.counts,
        "margin": c_real(f.margin),
        "reach": c_real(f.reach),
        "far_base": c_real(f.far_base),
        "sag_safety": c_real(oppfit.SAG_SAFETY),
        "n_opp_stage": max(1, ocp.problem.opponents.count * ocp.n_opp_stage),
        "stretch_max": c_real(oppfit.STRETCH_MAX),
        "n_min": c_real(f.n_min),
        "n_max": c_real(f.n_max),
        "neutral": [c_real(v) for v in oppfit.neutral(0.0)],
    }


def permutation_cycles(src: np.ndarray) -> np.ndarray:
    """One start index per non-trivial cycle of the permutation ``i -> src[i]`` (to apply ``v[i] = v[src[i]]`` in
    place: follow each cycle from its start, one saved value per cycle)."""
    src = np.asarray(src, dtype=np.int64)
    if sorted(src.tolist()) != list(range(len(src))):
        raise AssertionError("A_SRC is no permutation of the stacked Jacobian: A_x cannot share its memory")
    seen = np.zeros(len(src), dtype=bool)
    starts = []
    for i0 in range(len(src)):
        if seen[i0] or src[i0] == i0:
            seen[i0] = True
            continue
        starts.append(i0)
        i = i0
        while not seen[i]:
            seen[i] = True
            i = int(src[i])
    return np.array(starts, dtype=np.int64)
