"""The plant: one RK4 step of the 5-state Frenet model on a road window, the same formula as the NLP's (the closed
loop's plant, the generated C's ``<name>_plant`` and the solver's a_lat guard)."""

from __future__ import annotations

from functools import lru_cache

import casadi as ca
import numpy as np

from . import models
from .dsl import Problem
from .reactions import lag_error, lagged_rate
from .road import RoadWindowParams, casadi_road


def plant_function(problem: Problem, samples: int, step_input: bool = False) -> ca.Function:
    """One RK4 step of the 5-state Frenet model with a road window parameter (same formula as the NLP); built once per
    problem and window size in a process (a CasADi Function is immutable). ``step_input``: the step's length is a
    fourth input ``h`` (the standstill's part of a sample), else the sample ``dt``."""
    try:
        return _cached_plant(problem, samples, step_input)
    except TypeError:  # a problem that cannot be hashed (a hand-made field): built every time
        return _build_plant(problem, samples, step_input)


@lru_cache(maxsize=64)
def _cached_plant(problem: Problem, samples: int, step_input: bool) -> ca.Function:
    return _build_plant(problem, samples, step_input)


def _build_plant(problem: Problem, samples: int, step_input: bool) -> ca.Function:
    rp = RoadWindowParams(samples)
    x, u, p = ca.SX.sym("x", 5), ca.SX.sym("u", 2), ca.SX.sym("p", rp.size)
    f = models.ode("frenet", lambda s: casadi_road(s, p, samples)[:2], problem.ego, problem.wind)
    if step_input:
        h = ca.SX.sym("h")
        return ca.Function("plant_h", [x, u, p, h], [models.rk4(f, x, u, h)])
    return ca.Function("plant", [x, u, p], [models.rk4(f, x, u, problem.horizon.dt)])


class DelayLine:
    """The delay compensation's state (``Problem.delay`` = D): the D controls handed out last, oldest first (zeros
    before the first D), and the prediction over them (the generated C's ``delay_predict``, ``delay_push``); with
    ``lag = (tau, decay)`` (``plan_check.lag_constants``) the steering actuator's lag ``lag_e`` at the measurement
    and ``lag_plan`` at the plan's start; ``f_last``, the drive force handed out last (the a_lat guard's memory)."""

    def __init__(self, plant: ca.Function, delay: int, nu: int = 2, lag: tuple[float, float] | None = None, dt=0.1):
        self.plant, self.u_hist = plant, np.zeros((delay, nu))
        self.lag, self.dt = lag, dt
        self.lag_e = self.lag_plan = 0.0
        self.f_last = 0.0

    def predict(self, x0: np.ndarray, road_params) -> np.ndarray:
        """x0 stepped by the plant over the controls, each step on ``road_params(s)`` of its start, their steering
        rates through the lag (``lag_plan`` then holds the lag at the end); x0 itself (the same object) without a
        delay."""
        x, e = x0, self.lag_e
        for u in self.u_hist:
            if self.lag is not None:
                r = float(u[1])
                u = np.array([u[0], lagged_rate(r, e, *self.lag, self.dt)])
                e = lag_error(r, e, *self.lag)
            x = np.array(self.plant(x, u, road_params(float(x[0])))).ravel()
        self.lag_plan = e
        return x

    def applied(self, u: np.ndarray) -> np.ndarray:
        """The control ``u`` as the plant applies it from the plan's start: its steering rate through the lag."""
        if self.lag is None:
            return u
        return np.array([u[0], lagged_rate(float(u[1]), self.lag_plan, *self.lag, self.dt)])

    def push(self, u: np.ndarray) -> None:
        """The control just handed out joins the ones the plant has yet to apply (the oldest leaves); the lag moves on
        by the sample the plant now applies (the oldest, or ``u`` without a delay)."""
        if self.lag is not None:
            r = float(self.u_hist[0][1]) if len(self.u_hist) else float(u[1])
            self.lag_e = lag_error(r, self.lag_e, *self.lag)
        if len(self.u_hist):
            self.u_hist = np.vstack([self.u_hist[1:], u])
        self.f_last = float(u[0])
