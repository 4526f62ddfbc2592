"""``fcgen wcet``'s results as a text table (millions of instructions; raw counts in the JSON)."""

from __future__ import annotations

from collections.abc import Sequence

PHASE_ORDER = (
    "prepare",
    "prepare_rest",
    "fit_scan_step",
    "feedback",
    "head",
    "check",
    "step",
    "qp",
    "qp_tail",
    "feedback_tail",
    "feedback_no_qp",
)


def _m(v: float) -> str:
    return f"{v / 1e6:.4f}"


def format_wcet(res: dict) -> str:
    """The bound, the phases it is made of, the caps and the validation."""
    caps, b = res["caps"], res["bound"]
    pr = res["probe"]
    lines = [
        f"wcet {res['solver']} ({res['backend']}, {res['precision']}) on {res['target']}, {res['cflags']}: "
        f"probe runs {pr['scenario']} seeds {pr['seeds'][0]}..{pr['seeds'][-1]} x {pr['samples']} samples "
        f"(reset every {pr['reset_every']}: {pr['cold_starts']} cold starts), granularity "
        f"{res['tick_instructions']} instructions"
    ]
    val = res["validated"]
    rows = [("", "bound Minstr", "observed max", "max / bound")]
    for k in ("prepare", "feedback", "rti"):
        obs = "-" if not val["observed_max"] else _m(val["observed_max"][k])
        frac = "-" if not val["fraction_of_bound"] else f"{val['fraction_of_bound'][k]:.3f}"
        rows.append((k, _m(b[k]), obs, frac))
    lines += _grid(rows)
    lines.append("")
    rows = [("phase", "min instr", "max instr", "instances")]
    for k in PHASE_ORDER:
        if k in res["phases"]:
            p = res["phases"][k]
            rows.append((k, f"{p['min']:,}", f"{p['max']:,}", str(p["count"])))
    lines += _grid(rows)
    extra = [
        f"QP iterations charged {caps['qp_iterations']} (RTI budget {caps['rti_budget']}: warm cap "
        f"{caps['warm']}, cold cap {caps['cold']}"
        + (f"; OSQP checks every {caps['check_termination']}" if caps["check_termination"] else "")
        + ")",
        f"per QP iteration {_m(res['per_iteration'])} Minstr",
    ]
    if caps["fit_scans"]:
        extra.append(f"fit: {caps['fit_scans']} scans per prepare of at most {caps['fit_scan_cap']} samples each")
    lines.append("")
    lines.append(" | ".join(extra))
    if val["observed_max"]:
        n = sum(val["exceeding_samples"].values())
        lines.append(
            f"validated on seeds {val['seeds'][0]}..{val['seeds'][-1]} x {val['samples']} samples (normal "
            f"build): "
            + (
                "every sample within the bound"
                if val["passed"]
                else f"{n} sample phase(s) ABOVE the bound: "
                + ", ".join(f"{k} {v}" for k, v in val["exceeding_samples"].items() if v)
            )
        )
    return "\n".join(lines)


def _grid(rows: Sequence[tuple[str, ...]]) -> list[str]:
    w = [max(len(r[i]) for r in rows) for i in range(len(rows[0]))]
    out = []
    for i, r in enumerate(rows):
        out.append("  ".join(c.ljust(w[j]) if j == 0 else c.rjust(w[j]) for j, c in enumerate(r)))
        if i == 0:
            out.append("  ".join("-" * v for v in w))
    return out
