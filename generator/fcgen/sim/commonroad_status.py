"""A CommonRoad run's statuses for its log and its summary line: the goal, the samples without a solution, the
verdicts as plain JSON data."""

from __future__ import annotations

import math

import numpy as np

from ..road import Road


def goal_status(sc, road: Road, centres: np.ndarray, xs: np.ndarray) -> dict:
    """Whether and when the ego reached the planning problem's goal region (``commonroad.goal.first_reached``):
    ``reached``, ``sample`` / ``step`` / ``time_s`` (None without), ``v_ref_source``, ``n_ref_source`` (``road``:
    the band the solver gets)."""
    from ..commonroad.goal import first_reached, lateral_reference

    j = None if sc.planning_problem is None else first_reached(sc.planning_problem, sc.first_step, centres, xs[:, 3])
    return {
        "reached": j is not None,
        "sample": j,
        "step": None if j is None else sc.first_step + j,
        "time_s": None if j is None else j * sc.dt,
        "v_ref_source": sc.v_ref_source,
        "n_ref_source": lateral_reference(sc.goal_sn, road)[1],
    }


def goal_line(cr: dict) -> str:
    """One line of a run's goal, references and solution verdict (the log's ``extra.commonroad``)."""
    g, sol = cr["goal"], cr["solution"]
    reached = f"reached at step {g['step']} ({g['time_s']:.1f} s)" if g["reached"] else "not reached"
    parts = [k for k in ("starts_at_initial_state", "feasible", "goal_reached") if not sol[k]]
    parts += [k for k in ("obstacle_collision", "road_departure") if sol[k]]
    verdict = "valid" if sol["valid"] else "not valid (" + ", ".join(f"{k}" for k in parts) + ")"
    return (
        f"goal: {reached}; v_ref {cr['v_ref']:.1f} m/s ({g['v_ref_source']}); lateral reference "
        + ", ".join(f"{n:.2f} m at sample {j} ({why})" for j, n, why in cr["lane_changes"])
        + f"; solution (drivability checker): {verdict}"
    )


def unsolved_status(results: list) -> dict:
    """The samples without a solution (their slack is not finite: the exit code says why): ``samples`` (count),
    ``first_sample`` (None without one), ``exit_codes`` (name -> count)."""
    from ..contract import EXIT_CODES

    bad = [j for j, r in enumerate(results) if r.exit_code or not math.isfinite(r.max_slack)]
    codes: dict[str, int] = {}
    for j in bad:
        c = int(results[j].exit_code)
        name = EXIT_CODES[c] if 0 < c < len(EXIT_CODES) else ("OK but non-finite slack" if c == 0 else f"unknown({c})")
        codes[name] = codes.get(name, 0) + 1
    return {"samples": len(bad), "first_sample": bad[0] if bad else None, "exit_codes": dict(sorted(codes.items()))}


def _plain(d: dict) -> dict:
    """A verdict as plain JSON data (numpy scalars and None kept as numbers / null)."""
    out = {}
    for k, v in d.items():
        if isinstance(v, (np.integer, np.bool_)):
            v = v.item()
        elif isinstance(v, np.floating):
            v = float(v)
        elif isinstance(v, (list, tuple, np.ndarray)):
            v = [x.item() if hasattr(x, "item") else x for x in v]
        out[k] = v
    return out
