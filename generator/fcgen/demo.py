"""The main job: generate the default solver, build it, run it in the C firmware harness and compare with Python."""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from .codegen.generate import generate
from .presets import preset
from .sim.closedloop import run_closed_loop
from .sim.export import firmware_sim
from .sim.runlog import RunLog, compare, summary
from .sim.scenario import make_scenario

DEFAULT_PRESET = "truck_lifted_ellipse"
TRAJECTORY_TOL = 1e-6
"""Largest allowed difference of the C and Python closed-loop states and controls (SI units)."""

_COMPARED = ("ego_frenet", "ego_cartesian", "control", "collision", "qp_iter", "qp_status")


@dataclass(frozen=True)
class DemoResult:
    """Both run logs, their summaries and the largest C-vs-Python differences."""

    c_log: RunLog
    py_log: RunLog
    c_summary: dict
    py_summary: dict
    differences: dict[str, float]
    workspace_bytes: int
    out_dir: Path

    @property
    def matches(self) -> bool:
        return all(self.differences[k] <= TRAJECTORY_TOL for k in _COMPARED)

    def format(self) -> str:
        c, p = self.c_summary, self.py_summary
        rows = [("", "C (firmware_sim)", "Python reference")]

        def both(label, f):
            rows.append((label, f(c), f(p)))

        both("progress [m]", lambda s: f"{s['progress']:.2f}")
        both("collision samples", lambda s: f"{s['n_collision_samples']}")
        for ph in ("prepare", "feedback", "total"):
            both(f"{ph} median / p99 / max [ms]", lambda s, ph=ph: "{median:.3f} / {p99:.3f} / {max:.3f}".format(
                **s[f"time_{ph}_ms"]))
        both("QP iterations mean / max", lambda s: f"{s['qp_iter_mean']:.1f} / {s['qp_iter_max']}")
        both("QP status counts", lambda s: str(s["qp_status_counts"]))
        both("max slack / max |a_lat| [m/s^2]", lambda s: f"{s['max_slack']:.3g} / {s['max_abs_a_lat']:.2f}")
        w = [max(len(r[i]) for r in rows) for i in range(3)]
        lines = [" | ".join(r[i].ljust(w[i]) for i in range(3)) for r in rows]
        lines.insert(1, "-+-".join("-" * x for x in w))
        speed = p["time_total_ms"]["median"] / c["time_total_ms"]["median"]
        worst = max(_COMPARED, key=lambda k: self.differences[k])
        lines += ["",
                  f"C vs Python: largest difference {self.differences[worst]:.3g} ({worst}; tolerance "
                  f"{TRAJECTORY_TOL:g}) -> {'MATCH' if self.matches else 'MISMATCH'}",
                  f"C median total time is {speed:.1f}x faster than the Python reference; solver RAM "
                  f"{self.workspace_bytes} bytes ({self.workspace_bytes / 1024:.1f} KiB)",
                  f"logs and plot in {self.out_dir}/"]
        return "\n".join(lines)


def run_demo(out_dir: Path | str = "runs/demo", problem_name: str = DEFAULT_PRESET, seed: int = 3,
             samples: int = 200, plot: bool = True, echo=print) -> DemoResult:
    """Generate ``problem_name`` into ``out_dir``, run C and Python closed loops on one truck/car scenario."""
    out_dir = Path(out_dir)
    pb = preset(problem_name)
    scenario = problem_name.split("_", 1)[0]
    gen_dir = out_dir / problem_name
    echo(f"[1/4] generate {problem_name} -> {gen_dir}")
    info = generate(pb, gen_dir)
    echo(f"[2/4] build the solver and the firmware harness; closed loop in C ({scenario}, seed {seed}, "
         f"{samples} samples)")
    c_log = firmware_sim(gen_dir, scenario, seed, samples, out=out_dir / "run_c.json", problem=pb)
    echo("[3/4] closed loop with the Python reference")
    sc = make_scenario(scenario, seed, n_opp=pb.opponents.count, samples=samples, dt=pb.horizon.dt)
    py_log = run_closed_loop(pb, sc)
    py_log.to_json(out_dir / "run_python.json")
    echo("[4/4] compare")
    if plot:
        from .sim.plots import plot_run
        plot_run(c_log, out_dir / "run_c.png")
    return DemoResult(c_log, py_log, summary(c_log), summary(py_log), compare(c_log, py_log),
                      info.workspace_bytes, out_dir)
