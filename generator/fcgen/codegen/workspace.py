"""The solver's workspace struct ``<name>_workspace_t`` and its status struct as the template writes them: members in
order, their dimensions (as the public size macros), and their sizeof on an LP64 target (natural padding)."""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import Any

import numpy as np

Dim = int | tuple[str, int]  # a dimension: a number, or (the C expression written, its value)
Member = tuple[str, str, list[Dim], tuple[int, int]]  # (C type with NAME_, name, dims, (size, align))

FIRST_STATE_MEMBER = "w"
"""The first workspace member reset() zeroes (the inputs and the clock come before it)."""

_I, _P = (4, 4), (8, 8)  # int, pointer (LP64)


def _struct_size(members: Sequence[tuple[int, int, int]]) -> int:
    """sizeof a C struct of (size, align, count) members, with natural padding."""
    off, align_max = 0, 1
    for size, align, count in members:
        off = -(-off // align) * align + size * count
        align_max = max(align_max, align)
    return -(-off // align_max) * align_max


def status_layout(real_size: int) -> tuple[int, int]:
    """sizeof and alignment of ``<name>_status_t``: 11 ints, 2 reals (u_violation, plan_clearance), 2 uint32 ticks."""
    members = [(4, 4, 11), (real_size, real_size, 2), (4, 4, 2)]
    return _struct_size(members), max(a for _, a, _ in members)


def _input_members(M: Callable[..., Dim], R: tuple[int, int], opp_dim: int, shape_dim: int) -> list[Member]:
    """The inputs (kept by reset) and the clock."""
    road = M("ROAD_MAX")
    return [
        ("NAME_real_t", "x0", [5], R),
        ("NAME_real_t", "road_s0", [], R),
        ("NAME_real_t", "road_ds", [], R),
        ("NAME_real_t", "road_kappa", [road], R),
        ("NAME_real_t", "road_phi", [road], R),
        ("NAME_real_t", "road_gx", [road], R),
        ("NAME_real_t", "road_gy", [road], R),
        ("NAME_real_t", "road_nmin", [road], R),
        ("NAME_real_t", "road_nmax", [road], R),
        ("NAME_real_t", "opp", [M("N", 1), ("OPP_DIM", opp_dim)], R),
        ("NAME_real_t", "opp_shape", [("SHAPE_DIM", shape_dim)], R),
        ("clock_fn_t", "clock", [], _P),
        ("int", "road_n", [], _I),
        ("int", "road_set", [], _I),
        ("NAME_real_t", "ref_v", [M("N", 1)], R),  # the reference per node (set_reference: every node alike)
        ("NAME_real_t", "ref_n", [M("N", 1)], R),
        ("NAME_real_t", "margin", [M("N", 1)], R),  # the obstacle margin per stage (set_obstacle_margins)
        ("int", "road_band", [], _I),
        ("int", "opp_shape_set", [], _I),
        ("int", "ref_set", [], _I),
        ("int", "have_x0", [], _I),
    ]


def _state_members(M: Callable[..., Dim], R: tuple[int, int], work: dict, n_band: int) -> list[Member]:
    """Everything reset() zeroes, from ``FIRST_STATE_MEMBER`` on: the plan, the QP's data, CasADi's work arrays."""
    n, m, nnz, window = M("QP_N"), M("QP_M"), M("QP_NNZ_A"), M("ROAD_WINDOW")
    assert isinstance(window, tuple)
    return [
        ("NAME_real_t", FIRST_STATE_MEMBER, [n], R),
        ("NAME_real_t", "y", [m], R),
        ("NAME_real_t", "s0_guess", [], R),
        ("NAME_real_t", "w_tmp", [n], R),
        ("NAME_real_t", "p", [M("NP")], R),
        ("NAME_real_t", "p_fb", [M("NP")], R),
        ("NAME_real_t", "g_init", [M("NX")], R),
        ("NAME_real_t", "jac", [nnz], R),
        ("NAME_real_t", "q", [n], R),
        ("NAME_real_t", "q_fb", [n], R),
        ("NAME_real_t", "l", [m], R),
        ("NAME_real_t", "u", [m], R),
        ("NAME_real_t", "u_applied", [M("NU")], R),
        ("NAME_real_t", "band_val", [("N_BAND", max(1, n_band))], R),
        ("NAME_real_t", "xa", [M("NX")], R),
        ("const casadi_real *", "arg", [("CASADI_SZ_ARG", work["sz_arg"])], _P),
        ("casadi_real *", "res", [("CASADI_SZ_RES", work["sz_res"])], _P),
        ("casadi_int", "iw", [("CASADI_SZ_IW", work["sz_iw"])], _I),
        ("casadi_real", "cw", [("CASADI_SZ_W", work["sz_w"])], R),
        ("const NAME_real_t *", "q_cur", [], _P),
        ("const NAME_real_t *", "qp_z", [], _P),
        ("NAME_status_t", "status", [], status_layout(R[0])),
        ("int", "have_guess", [], _I),
        ("int", "prepared", [], _I),
        ("int", "cold", [], _I),
        ("int", "qp_ready", [], _I),
        ("int", "fit_outside", [], _I),
        # the road window of each stage of the last preparation (the plan check's road: set_road may change in between)
        ("NAME_real_t", "plan_road", [M("N", 1), ("P_REF", 2 + 4 * window[1])], R),
    ]


def _fit_members(M: Callable[..., Dim], R: tuple[int, int], fit: dict, name: str, road_max: int) -> list[Member]:
    """The conventional opponent fit: fitted stage parameters and one opponent's scratch."""
    road = M("ROAD_MAX")
    out: list[Member] = [
        ("NAME_real_t", "opp_stage", [M("N", 1), fit["n_opp_stage"]], R),
        ("NAME_real_t", "opp_stage_kept", [M("N", 1), fit["n_opp_stage"]], R),  # restored by a refused prepare
        ("NAME_real_t", "fit_P", [2 * fit["npt"]], R),
        ("NAME_real_t", "fit_d", [fit["npt"]], R),
        ("NAME_real_t", "fit_fr", [3 * fit["npt"]], R),
        ("NAME_real_t", "fit_box", [fit["nbox"]], R),
        ("NAME_real_t", "fit_hmax", [], R),
        ("NAME_real_t", "fit_ihmax", [], R),
        ("NAME_real_t", "fit_skip", [], R),
        ("NAME_real_t", "fit_uni", [], R),
        ("NAME_real_t", "fit_cos", [road], R),
        ("NAME_real_t", "fit_sin", [road], R),
    ]
    out += [("NAME_real_t", f"fit_{d}_{q}", [road], R) for d in ("dd", "d3") for q in ("phi", "x", "y")]
    wide = (f"{name.upper()}_ROAD_MAX + {2 * fit['search']}", road_max + 2 * fit["search"])
    return [*out, ("NAME_real_t", "fit_rsq", [wide], R), ("NAME_real_t", "fit_beta", [wide], R)]


def workspace_members(
    name: str,
    sizes: dict[str, int],
    work: dict,
    real_size: int,
    opp_dim: int,
    fit: dict | None = None,
    n_band: int = 0,
    curve: bool = False,
    delay: int = 0,
    f_last: bool = False,
    steer_lag: bool = False,
) -> tuple[list[dict[str, Any]], int]:
    """Members of ``<name>_workspace_t`` for the template, and its sizeof on an LP64 target (natural padding)."""
    NAME = name.upper()
    R = (real_size, real_size)

    def M(key: str, extra: int = 0) -> Dim:  # a dimension written as the public size macro
        return (f"{NAME}_{key}" + (f" + {extra}" if extra else ""), sizes[key] + extra)

    shape_dim = max(1, sizes["NOPP"] * sizes["NOPP_SHAPE"])
    # the delay compensation's controls handed out last: an input (reset keeps it: the vehicle still has them)
    delayed = [("NAME_real_t", "u_hist", [delay, M("NU")], R)] if delay else []
    # the a_lat guard's memory of the drive force handed out last, the steering lag at the measurement and at the
    # plan's start: the actuator's (reset keeps them too)
    delayed += [("NAME_real_t", "f_last", [], R)] if f_last else []
    delayed += [("NAME_real_t", "lag_e", [], R), ("NAME_real_t", "lag_plan", [], R)] if steer_lag else []
    members = _input_members(M, R, opp_dim, shape_dim) + delayed + _state_members(M, R, work, n_band)
    if delay:  # the plan's start: x0 predicted over the delay
        members.append(("NAME_real_t", "x_plan", [5], R))
    if curve:  # the curve reference per node (Reference.curve_a_lat): a / |kappa| per road sample, s_ref, v_ref
        members += [
            ("NAME_real_t", "curve_c", [M("ROAD_MAX")], R),
            ("NAME_real_t", "curve_s", [M("N", 1)], R),
            ("NAME_real_t", "curve_v", [M("N", 1)], R),
        ]
    if fit:
        members += _fit_members(M, R, fit, name, sizes["ROAD_MAX"])
    size = _struct_size(
        [(sa[0], sa[1], int(np.prod([x[1] if isinstance(x, tuple) else x for x in d]))) for _, _, d, sa in members]
    )
    rendered = [
        {"ctype": t.replace("NAME_", f"{name}_"), "name": nm, "dims": [x[0] if isinstance(x, tuple) else x for x in d]}
        for t, nm, d, _ in members
    ]
    return rendered, size
