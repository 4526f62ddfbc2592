"""A plant that does not roll backwards: rolling resistance, air drag and the brakes oppose motion and never move a
vehicle that stands. The model's ``v' = (F_d - F_air - c_roll) / m`` (the NLP's, smooth) keeps decelerating through
``v = 0``; the plant, where one RK4 sample from ``v >= 0`` ends at ``v < 0``, stops the vehicle at the time the
same RK4 step of that length reaches ``v = 0`` (bisection) and keeps it standing for the rest of the sample: its pose
as at the stop, ``v = 0``, the steering angle moved by the steering rate over the whole sample (``delta' = r``)."""

from __future__ import annotations

import numpy as np

from ..dsl import Problem
from ..plant import plant_function

V, DELTA = 3, 4  # the speed's and the steering angle's index in the Frenet state [s, n, alpha, v, delta]
BISECTIONS = 40  # halvings of the sample: the stop time to dt / 2**40 (~1e-13 s at 0.1 s)


def rolls_back(x: np.ndarray, xn: np.ndarray) -> bool:
    """Whether a sample from ``x`` to ``xn`` takes a vehicle that moved forwards or stood (v >= 0) to v < 0."""
    return bool(x[V] >= 0.0 > xn[V])


def stopped(problem: Problem, samples: int, x: np.ndarray, u: np.ndarray, p: np.ndarray, xn: np.ndarray):
    """The plant's state one sample after ``x`` when the model's step ``xn`` rolls back (``rolls_back``): the state at
    the stop (the largest RK4 step length with ``v >= 0``), standing (``v = 0``), with ``xn``'s steering angle."""
    step = plant_function(problem, samples, step_input=True)  # f(x, u, p, h)
    lo, hi = 0.0, float(problem.horizon.dt)
    at_lo = np.asarray(x, dtype=float).copy()
    for _ in range(BISECTIONS):
        mid = 0.5 * (lo + hi)
        xm = np.array(step(x, u, p, mid)).ravel()
        if xm[V] >= 0.0:
            lo, at_lo = mid, xm
        else:
            hi = mid
    out = at_lo.copy()
    out[V] = 0.0
    out[DELTA] = xn[DELTA]
    return out
