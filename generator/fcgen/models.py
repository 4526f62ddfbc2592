"""Vehicle models (SPEC section 2): Cartesian, Frenet and lifted ODEs with air drag, wind and rolling resistance.

Each ODE is a pure function of CasADi expressions; ``road`` is a callable s -> (kappa, phi_gamma) so the same
equations serve the NLP (road from a parameter window) and tests (road from a closed form).
"""

from __future__ import annotations

from collections.abc import Callable

import casadi as ca

from .dsl import Vehicle, Wind

NX = {"cartesian": 5, "frenet": 5, "lifted": 8}
NU = 2
STATE_NAMES = {
    "cartesian": ("x", "y", "phi", "v", "delta"),
    "frenet": ("s", "n", "alpha", "v", "delta"),
    "lifted": ("s", "n", "alpha", "v", "delta", "x", "y", "phi"),
}
CONTROL_NAMES = ("F_d", "r")

RoadFn = Callable[[ca.SX], tuple]


def longitudinal(v, phi, F_d, veh: Vehicle, wind: Wind):
    """v' = (F_d - F_air - c_roll)/m with F_air = c_air v_rel |v_rel|, v_rel = v + v_wind cos(phi - phi_wind)."""
    v_rel = v + wind.v * ca.cos(phi - wind.phi)
    return (F_d - veh.c_air * v_rel * ca.fabs(v_rel) - veh.c_roll) / veh.m


def a_lat(v, delta, veh: Vehicle):
    """Lateral acceleration at the rear axle: v^2 tan(delta) / l."""
    return v * v * ca.tan(delta) / veh.l


CORNERS = ("front_left", "rear_left", "front_right", "rear_right")
"""The chassis' corners in the order of ``corner_n`` (left: towards +n)."""


def corner_n(n, alpha, veh: Vehicle, kappa=0.0, kappa_at=None) -> list:
    """The lateral offsets of the chassis' four corners (``CORNERS``) for a rear axle at ``n`` with heading ``alpha``
    to a road of curvature ``kappa`` (at the rear axle's ``s``): ``m - k d_t^2 / (2 (1 - k m))``,
    ``m = n + d_n``, with the corner at
    ``d_t = x_c cos(alpha) -+ (w_ch/2) sin(alpha)`` along the road's tangent and ``d_n = x_c sin(alpha) +-
    (w_ch/2) cos(alpha)`` along its normal, the front and rear of the chassis at ``x_c = l/2 +- l_ch/2`` ahead of the
    rear axle. ``k``: the road's curvature over the chassis; ``kappa`` alone (``kappa_at`` None): the road a circle,
    its curvature at the rear axle (error ``kappa^3 d_t^4 / 8``: 0.2 mm at 3.7 m on a radius of 50 m); with
    ``kappa_at(d)``, the curvature ``d`` metres ahead: Simpson's ``(kappa + 2 kappa_at(x_c / 2)) / 3``, the road's
    offset from its tangent ``int_0^d (d - u) kappa(u) du`` exact for a curvature linear along the chassis."""
    half_w = veh.w_ch / 2
    s_a, c_a = ca.sin(alpha), ca.cos(alpha)
    x_front, x_rear = veh.l / 2 + veh.l_ch / 2, veh.l / 2 - veh.l_ch / 2
    k_of = {x: kappa if kappa_at is None else (kappa + 2 * kappa_at(x / 2)) / 3 for x in (x_front, x_rear)}
    out = []
    for side in (1, -1):
        for x_c in (x_front, x_rear):
            d_t = x_c * c_a - side * half_w * s_a
            m = n + x_c * s_a + side * half_w * c_a
            k = k_of[x_c]
            out.append(m - k * d_t * d_t / (2 * (1 - k * m)))
    return out


def cartesian_ode(x, u, veh: Vehicle, wind: Wind):
    """x^C = [x, y, phi, v, delta]."""
    _, _, phi, v, delta = ca.vertsplit(x)
    F_d, r = ca.vertsplit(u)
    return ca.vertcat(
        v * ca.cos(phi), v * ca.sin(phi), v * ca.tan(delta) / veh.l, longitudinal(v, phi, F_d, veh, wind), r
    )


def frenet_ode(x, u, road: RoadFn, veh: Vehicle, wind: Wind):
    """x^F = [s, n, alpha, v, delta]; the wind sees the heading phi_gamma(s) + alpha."""
    s, n, alpha, v, delta = ca.vertsplit(x)
    F_d, r = ca.vertsplit(u)
    kappa, phi_g = road(s)
    sdot = v * ca.cos(alpha) / (1 - n * kappa)
    return ca.vertcat(
        sdot,
        v * ca.sin(alpha),
        v * ca.tan(delta) / veh.l - kappa * sdot,
        longitudinal(v, phi_g + alpha, F_d, veh, wind),
        r,
    )


def lifted_ode(x, u, road: RoadFn, veh: Vehicle, wind: Wind):
    """x^d = [s, n, alpha, v, delta, x, y, phi]: Frenet kinematics plus Cartesian pose; wind uses Cartesian phi."""
    s, n, alpha, v, delta, _px, _py, phi = ca.vertsplit(x)
    F_d, r = ca.vertsplit(u)
    kappa, _ = road(s)
    sdot = v * ca.cos(alpha) / (1 - n * kappa)
    yaw_rate = v * ca.tan(delta) / veh.l
    return ca.vertcat(
        sdot,
        v * ca.sin(alpha),
        yaw_rate - kappa * sdot,
        longitudinal(v, phi, F_d, veh, wind),
        r,
        v * ca.cos(phi),
        v * ca.sin(phi),
        yaw_rate,
    )


def rk4(f: Callable, x, u, dt: float | ca.SX):
    """One explicit RK4 step of x' = f(x, u)."""
    k1 = f(x, u)
    k2 = f(x + dt / 2 * k1, u)
    k3 = f(x + dt / 2 * k2, u)
    k4 = f(x + dt * k3, u)
    return x + dt / 6 * (k1 + 2 * k2 + 2 * k3 + k4)


def ode(kind: str, road: RoadFn | None, veh: Vehicle, wind: Wind) -> Callable:
    """The ODE right-hand side f(x, u) of a state representation by name."""
    if kind == "cartesian":
        return lambda x, u: cartesian_ode(x, u, veh, wind)
    if kind in ("frenet", "lifted"):
        if road is None:
            raise ValueError(f"ode({kind!r}): the {kind} model needs the road's functions")
        rf: RoadFn = road
        road_ode = frenet_ode if kind == "frenet" else lifted_ode
        return lambda x, u: road_ode(x, u, rf, veh, wind)
    raise ValueError(f"model kind = {kind!r} is invalid: allowed 'cartesian', 'frenet', 'lifted'")
