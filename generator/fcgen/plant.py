"""The plant: one RK4 step of the 5-state Frenet model on a road window, the same formula as the NLP's (the closed
loop's plant, the generated C's ``<name>_plant`` and the solver's a_lat guard)."""

from __future__ import annotations

from functools import lru_cache

import casadi as ca

from . import models
from .dsl import Problem
from .road import RoadWindowParams, casadi_road


def plant_function(problem: Problem, samples: int) -> ca.Function:
    """One RK4 step of the 5-state Frenet model with a road window parameter (same formula as the NLP); built once per
    problem and window size in a process (a CasADi Function is immutable)."""
    try:
        return _cached_plant(problem, samples)
    except TypeError:  # a problem that cannot be hashed (a hand-made field): built every time
        return _build_plant(problem, samples)


@lru_cache(maxsize=64)
def _cached_plant(problem: Problem, samples: int) -> ca.Function:
    return _build_plant(problem, samples)


def _build_plant(problem: Problem, samples: int) -> ca.Function:
    rp = RoadWindowParams(samples)
    x, u, p = ca.SX.sym("x", 5), ca.SX.sym("u", 2), ca.SX.sym("p", rp.size)
    f = models.ode("frenet", lambda s: casadi_road(s, p, samples)[:2], problem.ego, problem.wind)
    return ca.Function("plant", [x, u, p], [models.rk4(f, x, u, problem.horizon.dt)])
