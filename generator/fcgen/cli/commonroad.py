"""The CommonRoad parts of ``fcgen simulate`` and ``fcgen campaign`` (docs/commonroad.md): one scenario run and
printed, a folder of scenarios run into rows; the ``--traffic`` option (``simulate``, ``campaign``, ``record``,
``regress``)."""

from __future__ import annotations

import sys
from collections.abc import Callable
from pathlib import Path
from typing import Any

import click

from .options import fail, fmt_summary


def traffic_option(default: str | None = "recorded", what: str = "") -> Callable[[Callable[..., Any]], Any]:
    """``--traffic recorded|reactive`` (docs/commonroad.md); an unknown mode: one line naming the allowed ones."""

    def check(ctx, param, value):
        if value is None:
            return None
        from ..commonroad.reactive import check_traffic

        try:
            return check_traffic(value)
        except ValueError as exc:
            raise click.BadParameter(str(exc)) from None

    return click.option(
        "--traffic",
        default=default,
        show_default=default is not None,
        callback=check,
        metavar="recorded|reactive",
        help="with --commonroad: the recorded vehicles follow their recordings (recorded), or follow them until the "
        "IDM would brake harder for the vehicle ahead (the ego included) and the IDM from then on (reactive)" + what,
    )


def campaign_cr_options(f: Callable[..., Any]) -> Any:
    """``campaign``'s ``--scenario-list`` and ``--criticality/--no-criticality`` (with ``--commonroad``)."""
    f = click.option(
        "--criticality/--no-criticality",
        default=True,
        show_default=True,
        help="with --commonroad: the criticality measures (commonroad-crime; most of a run's time)",
    )(f)
    return click.option(
        "--scenario-list",
        type=click.Path(dir_okay=False, exists=True),
        default=None,
        help="with --commonroad DIR: run the files of this list (CSV: file, dataset, sha256, ...; "
        "docs/commonroad/commonroad_search_scenarios.csv) found in DIR; a file missing or with another hash is "
        "refused and counted",
    )(f)


def simulate_commonroad(
    pb,
    cr_file,
    cr_pp,
    samples,
    ctrl,
    out,
    plot,
    solution,
    traffic: str = "recorded",
    animate: str | None = None,
    plant=None,
) -> None:
    """``simulate --commonroad``: one CommonRoad scenario; its verdicts printed; a refused scenario: one line,
    exit 1. The picture and the animation show the traffic as it drove (reactive: not the recording). ``plant``: the
    plant options' ``PlantSpec`` (default fcgen's model)."""
    from dataclasses import replace as dc_replace

    from ..campaign.commonroad import load_for
    from ..commonroad import ScenarioRefused, plot_run, write_solution
    from ..sim.commonroad_run import goal_line, run_commonroad
    from ..sim.runlog import summary

    try:
        sc = load_for(pb, cr_file, cr_pp)
        if samples < sc.samples:
            sc = dc_replace(sc, samples=samples)
        run = run_commonroad(pb, sc, controller=ctrl, progress=sys.stderr.isatty(), traffic=traffic, plant=plant)
    except ScenarioRefused as exc:
        fail(f"refused: {exc}")
    except FloatingPointError as exc:  # the plant left its domain (sim.plants.commonroad_vm): a status, not a trace
        fail(f"the run stopped: {exc}")
    log = run.log
    click.echo(
        f"{pb.name} | CommonRoad {sc.name} ({sc.samples} samples, v_ref {sc.v_ref:.1f} m/s) | "
        f"{fmt_summary(summary(log))}"
    )
    ck, own = run.checker, run.fcgen
    click.echo(
        f"collision: fcgen {_verdict(own)}, drivability checker {_verdict(ck)}"
        f"{'' if run.agree else ' (DISAGREE)'}; road departure (checker): "
        f"{_verdict({'collision': ck.get('road_departure'), 'collision_step': ck.get('departure_step')})}"
        + (f"; responsibility: {run.responsibility}" if run.responsibility else "")
    )
    click.echo(goal_line(log.meta["extra"]["commonroad"]))
    click.echo(traffic_line(log.meta["extra"]["commonroad"]))
    click.echo(band_line(log.meta["extra"]["commonroad"]))
    if "plant" in log.meta["extra"]:
        ex = log.meta["extra"]
        click.echo(
            f"plant {plant.label()} | samples whose control the plant's input limits cut: {ex['plant_cut_samples']}"
        )
    if out:
        log.to_json(out)
        click.echo(f"run log written to {out}")
    if solution:
        write_solution(sc, run.ego_states, solution)
        click.echo(f"CommonRoad solution written to {solution}")
    if plot:
        plot_run(run.scenario, run.ego_centres, plot)
        click.echo(f"plot written to {plot}")
    if animate:
        from ..commonroad.animate import animate_run

        try:
            animate_run(run.scenario, run.ego_centres, animate)
        except ValueError as exc:
            fail(f"--animate: {exc}")
        click.echo(f"animation written to {animate}")


def band_line(cr: dict) -> str:
    """One line of a run's band rule and the samples whose band the way back widened (``commonroad.band``)."""
    b = cr.get("band", {"rule": "road", "way_back_samples": []})
    back = b["way_back_samples"]
    where = f" (the first sample {back[0]}, the last {back[-1]})" if back else ""
    return f"band: {b['rule']}; the way back widened it at {len(back)} samples{where}"


def traffic_line(cr: dict) -> str:
    """One line of a run's traffic mode (the reactions) and criticality measures (the log's ``extra.commonroad``)."""
    tr, c = cr["traffic"], cr["criticality"]
    rx = tr["reactions"]
    line = f"traffic: {tr['mode']}"
    if tr["mode"] == "reactive":
        line += f" ({len(rx)} vehicles reacted, {sum(r[3] == 'ego' for r in rx)} to the ego)"
    if c["error"]:
        return f"{line}; criticality: not measured ({c['error']})"
    parts = []
    for m in ("ttc_ahead", "ttc_behind", "thw_ahead", "thw_behind"):
        v = c[m]
        what = "none" if v["min"] is None else f"{v['min']:.2f} s (vehicle {v['obstacle']}, sample {v['sample']})"
        parts.append(f"{m.replace('_', ' ').upper().replace(' AHEAD', ' ahead').replace(' BEHIND', ' behind')} {what}")
    return f"{line}; criticality (minimum): " + ", ".join(parts)


def _verdict(v: dict) -> str:
    return f"yes (step {v.get('collision_step')})" if v.get("collision") else "none"


def commonroad_campaign(
    configs: list,
    cr_dir: str,
    out: str,
    cache_dir: str,
    jobs: int,
    traffic: str = "recorded",
    scheduler: str | None = None,
    scenario_list: str | None = None,
    criticality: bool = True,
) -> None:
    """``campaign --commonroad``: every scenario of the folder (or of the list) in every configuration, resumable;
    the agreement and the refusals by reason printed."""
    from collections import Counter

    from ..campaign.cr_run import run_cr_campaign

    try:
        rows = run_cr_campaign(
            configs,
            cr_dir,
            out,
            str(Path(cache_dir).resolve()),
            jobs=jobs,
            echo=click.echo,
            traffic=traffic,
            scenario_list=scenario_list,
            scheduler=scheduler,
            criticality=criticality,
        )
    except ValueError as exc:
        fail(str(exc))
    ran = [r for r in rows if r["status"] == "ran"]
    why = Counter(r["refusal"] or "other" for r in rows if r["status"] != "ran")
    click.echo(
        f"{len(ran)} runs, {len(rows) - len(ran)} refused or failed"
        + (f" ({', '.join(f'{k} {v}' for k, v in why.most_common())})" if why else "")
        + f"; collisions fcgen {sum(bool(r['collision_fcgen']) for r in ran)}, "
        f"checker {sum(bool(r['collision_checker']) for r in ran)}, agreement {sum(bool(r['agree']) for r in ran)} "
        f"of {len(ran)}; summary {Path(out) / 'commonroad.md'}"
    )
