"""The main job: generate the default solver, build it, run it in the C firmware harness and compare with Python."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from .codegen.generate import generate
from .presets import preset
from .sim.closedloop import run_closed_loop
from .sim.harness import firmware_sim
from .sim.runlog import RunLog, compare, fmt_slack, summary
from .sim.scenario import make_scenario
from .solver_folder import read_folder

DEFAULT_PRESET = "truck_lifted_ellipse"
TRAJECTORY_TOL = 1e-6
"""Largest allowed difference of the C and Python closed-loop states and controls (SI units)."""

_COMPARED = ("ego_frenet", "ego_cartesian", "control", "collision", "qp_iter", "qp_status")


STATUS_NOTES = {
    "solved": "solved to the backend's tolerance",
    "solved_inaccurate": "OSQP stopped at its real-time iteration cap with residuals within its looser tolerance: "
    "the real-time mode's normal outcome, the step is used",
    "max_iter": "the iteration cap reached outside even that tolerance: the step is used when finite and within the "
    "input box (the safety contract), else the braking fallback",
}
"""One line per QP status the summary shows, printed under the table the first time a status appears."""


@dataclass(frozen=True)
class Column:
    """One more closed loop in C on the same scenario: another backend or profile of the problem."""

    label: str
    log: RunLog
    summary: dict
    workspace_bytes: int


@dataclass(frozen=True)
class DemoResult:
    """The run logs (C with the asked-for solver, the Python reference), their summaries, the C-vs-Python differences,
    and the extra C columns (the IPM backend, the safe profile)."""

    c_log: RunLog
    py_log: RunLog
    c_summary: dict
    py_summary: dict
    differences: dict[str, float]
    workspace_bytes: int
    out_dir: Path
    extra: tuple[Column, ...] = ()

    @property
    def matches(self) -> bool:
        return all(self.differences[k] <= TRAJECTORY_TOL for k in _COMPARED)

    def format(self) -> str:
        cols = [
            ("C, OSQP (asked for)", self.c_summary),
            ("Python reference, OSQP", self.py_summary),
            *((x.label, x.summary) for x in self.extra),
        ]
        rows = [("", *(c[0] for c in cols))]

        def row(label, f):
            rows.append((label, *(f(c[1]) for c in cols)))

        row("progress [m]", lambda s: f"{s['progress']:.2f}")
        row("samples in collision (true shapes)", lambda s: f"{s['n_collision_samples']}")
        for ph in ("prepare", "feedback", "total"):
            row(
                f"{ph} time median / p99 / max [ms]",
                lambda s, ph=ph: "{median:.3f} / {p99:.3f} / {max:.3f}".format(**s[f"time_{ph}_ms"]),
            )
        row("QP iterations per sample, mean / max", lambda s: f"{s['qp_iter_mean']:.1f} / {s['qp_iter_max']}")
        statuses = sorted({k for _, c in cols for k in c["qp_status_counts"]})
        for st in statuses:
            row(f"QP status {st} [samples]", lambda s, st=st: f"{s['qp_status_counts'].get(st, 0)}")
        row("largest soft-constraint slack [row's unit]", lambda s: fmt_slack(s["max_slack"]))
        row("largest |a_lat| [m/s^2] (bound 5)", lambda s: f"{s['max_abs_a_lat']:.2f}")
        n = len(rows[0])
        w = [max(len(r[i]) for r in rows) for i in range(n)]
        lines = [" | ".join(r[i].ljust(w[i]) for i in range(n)).rstrip() for r in rows]
        lines.insert(1, "-+-".join("-" * x for x in w))
        lines += [f"  {st}: {STATUS_NOTES[st]}" for st in statuses if st in STATUS_NOTES]
        c, p = self.c_summary, self.py_summary
        speed = p["time_total_ms"]["median"] / c["time_total_ms"]["median"]
        worst = max(_COMPARED, key=lambda k: self.differences[k])
        lines += [
            "",
            f"C vs Python (OSQP): largest difference {self.differences[worst]:.3g} ({worst}; tolerance "
            f"{TRAJECTORY_TOL:g}) -> {'MATCH' if self.matches else 'MISMATCH'}",
            f"C median total time is {speed:.1f}x faster than the Python reference",
            f"solver workspace (static RAM on a 64-bit host, whole solver): OSQP {_kib(self.workspace_bytes)}"
            + "".join(f", {x.label.removeprefix('C, ')} {_kib(x.workspace_bytes)}" for x in self.extra),
        ]
        for x in self.extra:
            ratio = x.summary["time_total_ms"]["median"] / c["time_total_ms"]["median"]
            if x.label == IPM_LABEL:
                lines.append(
                    f"which to pick: the IPM takes {ratio:.2f}x OSQP's median time here and solves its QPs "
                    f"to its tolerance (QpOptions(backend='ipm'), presets '_ipm'); OSQP is what was asked "
                    f"for, with a fixed iteration budget per sample"
                )
            else:
                xs = x.summary
                lines.append(
                    f"for an actuator: the safe profile (Problem()'s defaults, presets '_ipm_safe'; "
                    f"docs/safe_profile.md): largest |a_lat| {xs['max_abs_a_lat']:.2f} m/s^2 (bound 5), "
                    f"{xs['n_collision_samples']} samples in collision, {xs['progress'] / c['progress']:.2f}x "
                    f"the progress and {ratio:.2f}x the median time of the paper's settings (kept for the "
                    f"paper's experiment)"
                )
        lines.append(f"logs and plot in {self.out_dir}/")
        return "\n".join(lines)


def _kib(n: int) -> str:
    return f"{n:,} bytes ({n / 1024:.1f} KiB)"


IPM_LABEL = "C, IPM"
SAFE_LABEL = "C, IPM, safe profile"


def run_demo(
    out_dir: Path | str = "runs/demo",
    problem_name: str = DEFAULT_PRESET,
    seed: int = 3,
    samples: int = 200,
    plot: bool = True,
    echo=print,
    ipm: bool = True,
    safe: bool = True,
) -> DemoResult:
    """Generate ``problem_name`` into ``out_dir``, run C and Python closed loops on one truck/car scenario, and in C on
    the same scenario (``ipm``) the same problem with the IPM backend and (``safe``) its safe profile with the IPM,
    our recommended settings."""
    out_dir = Path(out_dir)
    pb = preset(problem_name)
    scenario = problem_name.split("_", 1)[0]
    more = [(IPM_LABEL, preset(f"{problem_name}_ipm"), "run_c_ipm.json")] if ipm and pb.qp.backend != "ipm" else []
    if safe and not problem_name.endswith("_safe"):
        more.append((SAFE_LABEL, preset(f"{problem_name.removesuffix('_ipm')}_ipm_safe"), "run_c_safe.json"))
    steps = 4 + len(more)
    gen_dir = out_dir / problem_name
    echo(f"[1/{steps}] generate {problem_name} -> {gen_dir}")
    info = generate(pb, gen_dir)
    echo(
        f"[2/{steps}] build the solver and the firmware harness; closed loop in C ({scenario}, seed {seed}, "
        f"{samples} samples)"
    )
    c_log = firmware_sim(read_folder(info.out_dir), scenario, seed, samples, out=out_dir / "run_c.json", problem=pb)
    echo(f"[3/{steps}] closed loop with the Python reference")
    sc = make_scenario(scenario, seed, n_opp=pb.opponents.count, samples=samples, dt=pb.horizon.dt)
    py_log = run_closed_loop(pb, sc)
    py_log.to_json(out_dir / "run_python.json")
    extra = []
    for i, (label, x_pb, log_name) in enumerate(more):
        x_dir = out_dir / x_pb.name
        what = "with the IPM backend" if label == IPM_LABEL else "in the safe profile with the IPM"
        echo(f"[{4 + i}/{steps}] the same problem {what} -> {x_dir}, closed loop in C")
        x_info = generate(x_pb, x_dir)
        x_log = firmware_sim(read_folder(x_info.out_dir), scenario, seed, samples, out=out_dir / log_name, problem=x_pb)
        extra.append(Column(label, x_log, summary(x_log), x_info.workspace_bytes))
    echo(f"[{steps}/{steps}] compare")
    if plot:
        from .sim.plots import plot_run

        plot_run(c_log, out_dir / "run_c.png", a_lat_max=pb.bounds.a_lat_max)
    return DemoResult(
        c_log,
        py_log,
        summary(c_log),
        summary(py_log),
        compare(c_log, py_log),
        info.workspace_bytes,
        out_dir,
        tuple(extra),
    )
