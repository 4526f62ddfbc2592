"""Tests of the run plot (fcgen.sim.plots) on small synthetic run logs."""

from __future__ import annotations

import numpy as np
import pytest

from fcgen.collision import collisions_over_run
from fcgen.sim.plots import plot_run, project_to_road
from fcgen.sim.runlog import RunLog, make_meta

CAR = {"l_f": 1.7, "l_r": 1.7, "l_r_ch": 2.0, "l_f_ch": 2.0, "w_ch": 1.9}


def make_road(kappa: float, length: float = 400.0, ds: float = 2.0) -> dict:
    s = np.arange(0.0, length + 1e-9, ds)
    if kappa == 0.0:
        gx, gy = s.copy(), np.zeros_like(s)
    else:
        gx, gy = np.sin(kappa * s) / kappa, (1 - np.cos(kappa * s)) / kappa
    return {"s": s, "kappa": np.full_like(s, kappa), "gamma_x": gx, "gamma_y": gy, "phi_gamma": kappa * s, "ds": ds}


def inverse_frenet(road: dict, s, n, alpha):
    phg = np.interp(s, road["s"], road["phi_gamma"])
    x = np.interp(s, road["s"], road["gamma_x"]) - n * np.sin(phg)
    y = np.interp(s, road["s"], road["gamma_y"]) + n * np.cos(phg)
    return np.stack([x, y, phg + alpha], axis=-1)


def make_log(kappa: float = 0.0, k: int = 100, dt: float = 0.1, opp_dims: dict | None = None) -> RunLog:
    """Ego overtakes one slower opponent with a lane change; states consistent across the two frames."""
    road = make_road(kappa)
    t = dt * np.arange(k + 1)
    s = 15.0 * t + 0.2 * t**2
    n = -2.5 + 5.0 / (1 + np.exp(-(t - 3.0) * 2))
    alpha = np.gradient(n, s)  # small-angle heading relative to the road
    v = np.gradient(s, t)
    delta = 0.05 * np.sin(t)
    ego_frenet = np.stack([s, n, alpha, v, delta], axis=-1)
    ego_cart = inverse_frenet(road, s, n, alpha)
    opp_frenet = np.stack([40.0 + 10.0 * t, np.full_like(t, -2.0), np.zeros_like(t)], axis=-1)[:, None, :]
    opp_cart = inverse_frenet(road, opp_frenet[..., 0], opp_frenet[..., 1], opp_frenet[..., 2])
    opp = [dict(opp_dims or CAR)]
    collision = collisions_over_run(ego_cart, CAR, opp_cart, opp).any(axis=1)
    rng = np.random.default_rng(1)
    return RunLog(
        meta=make_meta(
            problem="test",
            formulation="lifted",
            obstacle_model="EL",
            scenario="car",
            seed=1,
            N=40,
            dt=dt,
            controller="python-reference",
            n_bound=8.5,
        ),
        road=road,
        opponents=opp,
        ego=dict(CAR),
        t=t,
        ego_frenet=ego_frenet,
        ego_cartesian=ego_cart,
        opp_cartesian=opp_cart,
        opp_frenet=opp_frenet,
        collision=collision,
        a_lat=v**2 * np.tan(delta) / 3.4,
        control=np.zeros((k, 2)),
        time_prepare=np.full(k, 2e-4),
        time_feedback=rng.random(k) * 1e-3,
        time_total=np.full(k, 1e-3),
        qp_iter=np.full(k, 25),
        qp_status=np.ones(k, dtype=int),
        max_slack=np.zeros(k),
    )


@pytest.mark.parametrize("kappa", [0.0, 0.01])
def test_plot_run_writes_png(tmp_path, kappa):
    log = make_log(kappa=kappa)
    out = plot_run(log, tmp_path / f"run_{kappa}.png", every=10)
    assert out.exists()
    data = out.read_bytes()
    assert data[:8] == b"\x89PNG\r\n\x1a\n"
    assert len(data) > 30_000  # a real figure, not an empty canvas


def test_plot_run_truck_and_no_bounds(tmp_path):
    log = make_log(kappa=0.02, k=60, opp_dims={"l_f": 10.0, "l_r": 10.0, "l_r_ch": 13.0, "l_f_ch": 13.0, "w_ch": 4.0})
    meta = dict(log.meta)
    del meta["n_bound"]
    f = {name: getattr(log, name) for name in log.__dataclass_fields__}
    f["meta"] = meta
    f["collision"] = np.arange(log.n_states) % 3 == 0  # exercise the collision highlighting
    out = plot_run(RunLog(**f), tmp_path / "truck.png", every=7)
    assert out.stat().st_size > 30_000
    with pytest.raises(ValueError):
        plot_run(log, tmp_path / "bad.png", every=0)


@pytest.mark.parametrize("kappa", [0.0, 0.01])
def test_project_to_road_inverts_inverse_transform(kappa):
    road = make_road(kappa)
    s = np.array([10.0, 51.3, 123.45, 300.0])
    n = np.array([0.0, 3.0, -4.2, 8.0])
    xy = inverse_frenet(road, s, n, 0.0)[:, :2]
    sn = project_to_road(road, xy)
    tol = 1e-9 if kappa == 0.0 else 0.05  # nearest sample + linear projection on a curve: O(ds^2 kappa)
    np.testing.assert_allclose(sn[:, 0], s, atol=tol)
    np.testing.assert_allclose(sn[:, 1], n, atol=tol)


def _axes(fig, ylabel: str):
    (ax,) = [a for a in fig.axes if a.get_ylabel() == ylabel]
    return ax


def test_the_run_figure_draws_every_vehicle_at_the_same_few_instants_in_the_colour_of_its_time():
    from matplotlib.patches import Polygon as Poly

    from fcgen.sim.plots import INSTANTS, run_figure

    log = make_log(kappa=0.01, k=100)
    fig = run_figure(log)
    for ylabel in ("y [m]", "n [m]"):  # the Cartesian and the Frenet frame
        patches = [p for p in _axes(fig, ylabel).patches if isinstance(p, Poly)]
        assert len(patches) == INSTANTS * (1 + len(log.opponents))  # not one per sample: no bands
        fills = [tuple(p.get_facecolor()) for p in patches]
        per_instant = [fills[i : i + 2] for i in range(0, len(fills), 2)]  # the opponent, then the ego, per instant
        assert all(a == b for a, b in per_instant)  # the same instant, the same colour
        assert len({a for a, _ in per_instant}) == INSTANTS  # another instant, another colour


def test_the_run_figure_plots_a_lat_against_its_bound_and_the_largest_slack():
    from fcgen.sim.plots import run_figure

    log = make_log(kappa=0.01, k=100)
    slack = np.linspace(0.0, 2.0, 100)
    f = {name: getattr(log, name) for name in log.__dataclass_fields__}
    f["max_slack"] = slack
    fig = run_figure(RunLog(**f), a_lat_max=3.0)
    ax = _axes(fig, "|a_lat| [m/s^2]")
    lines = {ln.get_label(): ln for ln in ax.get_lines()}
    np.testing.assert_array_equal(lines["|a_lat|"].get_ydata(), np.abs(log.a_lat))
    assert set(lines["bound 3"].get_ydata()) == {3.0}
    assert np.abs(log.a_lat).max() > 3.0 and any("above" in c.get_label() for c in ax.collections)
    (ln,) = _axes(fig, "largest slack").get_lines()
    np.testing.assert_array_equal(ln.get_ydata(), slack)


def test_the_cartesian_view_is_fitted_to_the_road_the_run_covers():
    from fcgen.sim.plots import run_figure

    log = make_log(kappa=0.01, k=100)
    ax = _axes(run_figure(log), "y [m]")
    s = np.concatenate([log.ego_frenet[:, 0], log.opp_frenet[:, :, 0].ravel()])
    on = (log.road["s"] >= s.min() - 30) & (log.road["s"] <= s.max() + 30)
    pad = log.meta["n_bound"]
    gx, gy = log.road["gamma_x"][on], log.road["gamma_y"][on]
    np.testing.assert_allclose(ax.get_xlim(), (gx.min() - pad, gx.max() + pad))
    np.testing.assert_allclose(ax.get_ylim(), (gy.min() - pad, gy.max() + pad))
    assert ax.get_aspect() == 1.0  # equal axes: the box, not the data range, is adjusted
