"""The tracking reference per node, and the curve speed that caps it ahead of bends."""

from __future__ import annotations

from dataclasses import dataclass

from .validation import check, finite, known_fields, nonneg


@known_fields
@dataclass(frozen=True)
class Reference:
    """Tracking reference per node k: s_ref,k, v_ref,k (v_ref, capped by the curve speed), n_ref, alpha = delta = 0.

    Without the curve speed s_ref,k = s0 + t_k v_ref and v_ref,k = v_ref; with it v_ref,k = min(v_ref, curve speed at
    s_ref,k) and s_ref,k = s_ref,k-1 + (t_k - t_k-1) v_ref,k-1 (s_ref,0 = s0); with ``curve_along_horizon = False``
    the curve speed at the plan's start only, v_ref,k = min(v_ref, curve speed at s0) and s_ref,k = s0 + t_k v_ref,k
    (the safe profile's conventional formulation). t_k is node k's time (k dt on the paper's grid).

    The **curve speed** of the road ahead (the safe profile's; ``curve_a_lat = 0`` turns it off, as the paper's
    presets do) is the largest speed from which the ego, decelerating at ``curve_decel``, reaches every road sample
    ahead no faster than ``sqrt(curve_a_lat / |kappa|)``, so that following the centre line needs at most
    ``curve_a_lat``. Without it the reference asks for 40 m/s into a hairpin, and the plan accelerates towards a bend
    and then pays the a_lat slack or brakes into trouble (docs/safe_profile.md "The curve speed"); taken at each
    node's own s the reference itself brakes for the bend (docs/safe_profile.md "The curve reference along the
    horizon").

    ``curve_a_lat`` above the a_lat bound counts on a line straighter than the centre line across the road's width;
    with traffic near the plan (the last plan check's clearance to an opponent below ``curve_traffic_clearance``)
    that line may not be free, and the cap uses ``curve_a_lat_traffic`` instead (``curve_traffic_clearance = 0``:
    never; docs/safe_profile.md "The curve speed in traffic").
    """

    v_ref: float = 40.0
    n_ref: float = 0.0
    curve_a_lat: float = 8.0
    curve_decel: float = 7.0
    curve_a_lat_traffic: float = 6.5
    curve_traffic_clearance: float = 6.0
    curve_along_horizon: bool = True

    def __post_init__(self) -> None:
        nonneg("reference.v_ref", self.v_ref)
        finite("reference.n_ref", self.n_ref)
        check(
            0 <= finite("reference.curve_a_lat", self.curve_a_lat) <= 50,
            "reference.curve_a_lat",
            self.curve_a_lat,
            "[0, 50] m/s^2 (0: no curve speed)",
        )
        check(
            0 < finite("reference.curve_decel", self.curve_decel) <= 50,
            "reference.curve_decel",
            self.curve_decel,
            "(0, 50] m/s^2",
        )
        check(
            0 < finite("reference.curve_a_lat_traffic", self.curve_a_lat_traffic) <= 50,
            "reference.curve_a_lat_traffic",
            self.curve_a_lat_traffic,
            "(0, 50] m/s^2",
        )
        check(
            0 <= finite("reference.curve_traffic_clearance", self.curve_traffic_clearance) <= 100,
            "reference.curve_traffic_clearance",
            self.curve_traffic_clearance,
            "[0, 100] m (0: never)",
        )
        check(
            isinstance(self.curve_along_horizon, bool),
            "reference.curve_along_horizon",
            self.curve_along_horizon,
            "True or False",
        )
