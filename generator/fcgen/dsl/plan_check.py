"""The check of each feedback's plan against the opponents' true rectangles, its reaction and the a_lat guard."""

from __future__ import annotations

from dataclasses import dataclass, field

from .validation import check, finite, known_fields


@known_fields
@dataclass(frozen=True)
class PlanCheck:
    """After each feedback: the plan's clearance to every opponent's true rectangle (separating axes), and a reaction.

    ``react_stages``: where an opponent's first overlap among stages 1..min(react_stages, N) has its centre ahead of
    the ego's there or now (stage 0), the solver brakes instead of applying the plan's u0 (status.plan_reaction = 1;
    F_d = -min(F_d_max, m v0 / dt), the plan's steering rate); 0: report only (the paper's presets); the default, 500,
    is the whole horizon of any problem (measured on the full grid: docs/safe_profile.md).

    ``a_lat_guard``: the control to apply keeps the next sample's |a_lat| within ``bounds.a_lat_max``: where the plant's
    step with it would exceed the bound, the steering rate is the one that ends at ``a_lat_max - a_lat_margin``
    (status.a_lat_guard = 1), and where the step with that rate still exceeds the bound (the rate bound cut it short),
    the solver brakes as above too (2). The plan is not changed. It needs ``bounds.a_lat_margin > 0``: with wind the
    speed, and so the end, moves a little with the steering rate (the scenarios' 20 m/s wind: up to 4e-5 m/s^2). A
    guarantee at the actuator behind the plan's soft a_lat rows (docs/safe_profile.md "The a_lat guard"). False: the
    paper's presets, and the conventional formulation's safe ones (``presets.SAFE_PLAN_CHECK_CONVENTIONAL``).

    ``tyre_stiffness`` (1/rad: the tyres' cornering stiffness per unit normal load, mu C_S) and ``h_cg`` (m: the centre
    of gravity's height) make the guard test a tyre-aware |a_lat|: the formula's divided by the steady-state yaw gain
    of a single-track model with those tyres under the control's braking (``reactions.load_transfer_gain``: braking
    moves load onto the front axle and the vehicle turns more than the kinematic formula says; never less). The
    defaults are CommonRoad's BMW 320i's (docs/plants.md "The tyre-aware guard"); ``tyre_stiffness = 0``: the formula.
    ``drive_limit``: driving makes a vehicle with tyres turn less than the formula says, out of the bend; the guard
    then also limits a positive drive force: where it sets the steering rate, to a friction ellipse with the step's
    lateral acceleration (``reactions.drive_limit``; none at its target), elsewhere to where the tyres turn at most
    ``reactions.DRIVE_SLACK`` less than the formula (``reactions.understeer_drive_limit``; status.a_lat_guard = 3
    where only that acted). ``drive_rows`` (with ``drive_limit``): the plan keeps that second limit too
    (``fcgen.drive_rows``: a hard row on u_0, soft rows on the a_lat slack at 1..N-1), so that it does not plan a
    drive force the guard will cut; off by default and in the safe profile (measured: docs/safe_profile.md "The
    plan's drive rows").
    ``bend_brake`` (m/s^2, with ``drive_limit``): where the guard steers and the plan holds a
    slack above ``reactions.BEND_SLACK``, the ego is too fast for the path the plan turns onto at the guard's target;
    the drive force is then also capped to brake towards that path's speed within one sample, at most at
    ``bend_brake`` (``reactions.bend_brake_limit``); 0 (the default, also in the safe profile: measured, it traded
    an ego-caused collision for two of a truck into the braking ego, docs/safe_profile.md): off.

    ``brake_memory``: the tyre-aware |a_lat| takes the load transfer of the harder of the control's and the last
    handed-out control's braking (a tyre's yaw rate and slip angle still carry the braking of the sample before when
    the braking eases). ``drive_rise`` (m/s^2 per sample, with ``drive_limit``): the drive force rises by at most
    ``m drive_rise`` above the last handed-out one per sample (a switch from braking to driving in one sample turns
    a vehicle with tyres more than the formula says); 0: off. Braking harder is never limited, easing it is. Both off
    by default (a folder's problem.py names them only when set); the safe presets set them
    (``presets.SAFE_PLAN_CHECK``).
    """

    react_stages: int = 500
    a_lat_guard: bool = True
    tyre_stiffness: float = 21.92
    h_cg: float = 0.614
    drive_limit: bool = True
    bend_brake: float = 0.0
    brake_memory: bool = field(default=False, metadata={"omit_default": True})
    drive_rise: float = field(default=0.0, metadata={"omit_default": True})
    drive_rows: bool = field(default=False, metadata={"omit_default": True})

    def __post_init__(self) -> None:
        check(
            type(self.react_stages) is int and 0 <= self.react_stages <= 500,
            "plan_check.react_stages",
            self.react_stages,
            "an integer in [0, 500] (0: report only)",
        )
        check(type(self.a_lat_guard) is bool, "plan_check.a_lat_guard", self.a_lat_guard, "True or False")
        check(
            0.0 <= finite("plan_check.tyre_stiffness", self.tyre_stiffness) <= 100.0,
            "plan_check.tyre_stiffness",
            self.tyre_stiffness,
            "[0, 100] 1/rad (0: the kinematic formula)",
        )
        check(0.0 <= finite("plan_check.h_cg", self.h_cg) <= 3.0, "plan_check.h_cg", self.h_cg, "[0, 3] m")
        check(type(self.drive_limit) is bool, "plan_check.drive_limit", self.drive_limit, "True or False")
        check(
            0.0 <= finite("plan_check.bend_brake", self.bend_brake) <= 10.0,
            "plan_check.bend_brake",
            self.bend_brake,
            "[0, 10] m/s^2 (0: off)",
        )
        check(
            self.bend_brake == 0.0 or self.drive_limit,
            "plan_check.bend_brake",
            self.bend_brake,
            "0 without plan_check.drive_limit (it caps the drive force where the drive limit does)",
        )
        check(type(self.drive_rows) is bool, "plan_check.drive_rows", self.drive_rows, "True or False")
        check(
            not self.drive_rows or self.drive_limit,
            "plan_check.drive_rows",
            self.drive_rows,
            "False without plan_check.drive_limit (the rows are the drive limit's)",
        )
        check(type(self.brake_memory) is bool, "plan_check.brake_memory", self.brake_memory, "True or False")
        check(
            0.0 <= finite("plan_check.drive_rise", self.drive_rise) <= 100.0,
            "plan_check.drive_rise",
            self.drive_rise,
            "[0, 100] m/s^2 per sample (0: off)",
        )
        check(
            self.drive_rise == 0.0 or self.drive_limit,
            "plan_check.drive_rise",
            self.drive_rise,
            "0 without plan_check.drive_limit (it caps the drive force where the drive limit does)",
        )
