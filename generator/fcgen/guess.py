"""The cold-start guess: the Frenet plan the first prepare linearizes at when there is no previous solution.

The guess follows the road (a zero-input rollout from x0 is a straight line, which on a bend crosses the Frenet
singularity 1 - n kappa = 0 and leaves the road window): every stage keeps x0's lateral offset n0, speed v0 and
steering angle delta0, has road-relative heading alpha = 0 for k >= 1 (x0's own alpha at k = 0, which the feedback
embeds anyway), and advances along the centre line at the current speed, ``s_k = s0 + k dt v0``. The arc length on
the centre line, not the vehicle's path length ``k dt v0 / (1 - n0 kappa)``: the solver's window is sized for
``v_max N dt`` of centre line ahead, and this choice never needs kappa (no road evaluation, no division that grows
near the singularity). ``s_k`` is clipped to ``[s0, s_last]``: ``s_last`` is the last s whose stage window lies on
the road the solver holds, so a guess that would run past the road's end stops there instead of failing with
ERR_ROAD_WINDOW (a later, shifted plan meets the road's end as before); ``v0 < 0`` keeps ``s_k = s0``.

The formulation's full stage state is the lifting ``init_state`` of the guessed Frenet state (lifted: the Cartesian
pose F^-1(s_k, n0, alpha_k) on the stage's road window), so the guess satisfies the lifting's consistency. The
generated C performs the same arithmetic (``initial_guess`` in solver.c.j2, ``STAGES[k].t = k dt``).
"""

from __future__ import annotations

import numpy as np

from .road import Road


def last_window_s(road: Road, window: int) -> float:
    """The largest s (on the sample grid) whose ``window``-sample stage window lies on ``road``: the prepare phase
    accepts s while ``floor((s - s0) / ds) <= size - window + 1`` (``RtiSolver._road_params``, C ``window_start``)."""
    return road.s0 + float(road.size - window + 1) * road.ds


def cold_start_frenet(x0, times, s_last: float) -> np.ndarray:
    """The guessed Frenet states ``[s_k, n0, alpha_k, v0, delta0]``, one row per stage time in ``times``.

    ``s_k = min(s0 + t_k v0, s_last)``, never below ``s0``; ``alpha_k = 0`` for k >= 1, x0's at k = 0."""
    x0 = np.asarray(x0, dtype=float)
    s0, v0 = float(x0[0]), float(x0[3])
    out = np.tile(x0, (len(times), 1))
    for k, t in enumerate(times):
        if k == 0:
            continue
        s = s0 + float(t) * v0
        s = s if s < s_last else s_last
        out[k, 0] = s if s > s0 else s0
        out[k, 2] = 0.0
    return out
