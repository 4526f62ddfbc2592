"""The mapping between CommonRoad's vehicle-model states and inputs and fcgen's (pure functions on floats).

========================  ==========================================  ==========================================
quantity                  CommonRoad (``ks``: rear axle; ``st``,       fcgen (rear-axle Frenet state, SPEC 1-2)
                          ``std``, ``mb``: centre of gravity)
========================  ==========================================  ==========================================
position                  x_cg, y_cg (``ks``: x_r, y_r)               x_r = x_cg - b cos psi, y_r = y_cg - b sin psi,
                                                                      then (s, n) by the road's projection
heading                   yaw psi                                     alpha = psi - phi_gamma(s)
speed                     v_cg and slip angle beta (``mb``: v_x,       v = v_cg cos beta (the body's longitudinal
                          v_y; ``ks``: v at the rear axle)             speed, the same at every point of the body)
steering                  delta                                       delta
yaw rate                  psi' (state of ``st``, ``std``, ``mb``)     v tan(delta) / l (no state)
steering input            steering velocity v_delta                   r (rad/s), the same quantity
longitudinal input        acceleration a_x                            F_d: a_x = (F_d - c_air v_rel |v_rel| -
                                                                      c_roll) / m, v_rel = v + v_w cos(psi - phi_w)
lateral acceleration      v (beta' + psi') cos beta + v' sin beta      v^2 tan(delta) / l (rear axle, kinematic)
                          (``mb``: v_y' + v_x psi'; ``ks``: v psi')
========================  ==========================================  ==========================================

fcgen's measured state is the rear axle's, so a plant with slip is measured as fcgen would on a vehicle: its pose
and the body's longitudinal speed. Into a CommonRoad state (the first sample): the kinematic steady state of fcgen's,
beta = atan(b tan(delta) / l), v_cg = v / cos beta, psi' = v tan(delta) / l."""

from __future__ import annotations

import math


def rear_to_cog(x_r: float, y_r: float, psi: float, v: float, delta: float, a: float, b: float) -> list[float]:
    """fcgen's rear-axle pose, speed and steering -> the ``st`` state [x, y, delta, v, psi, psi', beta] of the same
    motion without slip (the kinematic steady state; ``a``, ``b``: centre of gravity to front and rear axle)."""
    lwb = a + b
    beta = math.atan(b * math.tan(delta) / lwb)
    return [
        x_r + b * math.cos(psi),
        y_r + b * math.sin(psi),
        delta,
        v / math.cos(beta),
        psi,
        v * math.tan(delta) / lwb,
        beta,
    ]


def cog_to_rear(x: float, y: float, psi: float, v_long: float, delta: float, b: float) -> tuple[float, ...]:
    """A centre-of-gravity pose (``b`` ahead of the rear axle), the body's longitudinal speed and the steering ->
    fcgen's Cartesian rear-axle state (x_r, y_r, phi, v, delta)."""
    return (x - b * math.cos(psi), y - b * math.sin(psi), psi, v_long, delta)


def drive_acceleration(F_d: float, v: float, psi: float, m: float, c_air: float, c_roll: float, wind) -> float:
    """fcgen's drive force, air drag (with wind) and rolling resistance on the plant -> its longitudinal acceleration
    (``models.longitudinal``'s formula on floats)."""
    v_rel = v + wind.v * math.cos(psi - wind.phi)
    return (F_d - c_air * v_rel * abs(v_rel) - c_roll) / m


def lateral_acceleration_slip(v: float, beta: float, dv: float, dbeta: float, dpsi: float) -> float:
    """The centre of gravity's acceleration across the body, from speed v, slip angle beta and their derivatives and
    the yaw rate: v (beta' + psi') cos beta + v' sin beta (``st``, ``std``)."""
    return v * (dbeta + dpsi) * math.cos(beta) + dv * math.sin(beta)


def lateral_acceleration_body(dv_y: float, v_x: float, dpsi: float) -> float:
    """The same from body-frame velocities (``mb``): v_y' + v_x psi'."""
    return dv_y + v_x * dpsi


def model_lateral_acceleration(v: float, delta: float, wheelbase: float) -> float:
    """fcgen's formula (the NLP's and the a_lat guard's): v^2 tan(delta) / l."""
    return v * v * math.tan(delta) / wheelbase
