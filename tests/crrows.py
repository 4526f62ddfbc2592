"""Hand-made rows of a CommonRoad campaign (``fcgen.campaign.commonroad.ROW_KEYS``) for the report's tests."""

from __future__ import annotations

from fcgen.campaign.commonroad import ROW_KEYS
from fcgen.commonroad.catalog import dataset_of


def cr_row(scenario: str, traffic: str, status: str = "ran", **kw) -> dict:
    """One row: a run of fcgen's safe profile (compiled C) without a collision or departure, the goal reached when it
    ran, its solution not valid, RTI 0.3 ms, 2 s of wall time; ``kw`` replaces any field."""
    row = dict.fromkeys(ROW_KEYS)
    row.update(
        scenario=scenario,
        dataset=dataset_of(scenario),
        file=f"{scenario}.xml",
        problem="car_lifted_ellipse_ipm_safe",
        controller="c",
        traffic=traffic,
        status=status,
        reason="",
        collision_fcgen=False,
        collision_checker=False,
        road_departure=False,
        start_off_road=False,
        responsibility="",
        goal_reached=status == "ran",
        solution_valid=False,
        reacted=0,
        reacted_to_ego=0,
        criticality_error="",
        rti_ms_median=0.3,
        wall_s=2.0,
        cpu_s=None,
    )
    row.update(kw)
    return row
