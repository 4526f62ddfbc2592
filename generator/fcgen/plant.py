"""The plant: one RK4 step of the 5-state Frenet model on a road window, the same formula as the NLP's (the closed
loop's plant, the generated C's ``<name>_plant`` and the solver's a_lat guard)."""

from __future__ import annotations

from functools import lru_cache

import casadi as ca
import numpy as np

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


class DelayLine:
    """The delay compensation's state (``Problem.delay`` = D): the D controls handed out last, oldest first (zeros
    before the first D), and the prediction over them (the generated C's ``delay_predict``, ``delay_push``)."""

    def __init__(self, plant: ca.Function, delay: int, nu: int = 2):
        self.plant, self.u_hist = plant, np.zeros((delay, nu))

    def predict(self, x0: np.ndarray, road_params) -> np.ndarray:
        """x0 stepped by the plant over the controls, each step on ``road_params(s)`` of its start; x0 itself (the
        same object) without a delay."""
        x = x0
        for u in self.u_hist:
            x = np.array(self.plant(x, u, road_params(float(x[0])))).ravel()
        return x

    def push(self, u: np.ndarray) -> None:
        """The control just handed out joins the ones the plant has yet to apply (the oldest leaves)."""
        if len(self.u_hist):
            self.u_hist = np.vstack([self.u_hist[1:], u])
