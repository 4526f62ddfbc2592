"""The QP backend and its settings, the same for the Python reference and the generated C."""

from __future__ import annotations

from dataclasses import dataclass

from .validation import check, finite, known_fields, positive

BACKENDS = ("osqp", "ipm")
"""Names ``QpOptions.backend`` accepts; each is a module of ``fcgen.backends`` (the DSL owns the names, the backends
import them: imports run one way)."""

RTI_BUDGET_DEFAULT: dict[str, int | None] = {"osqp": None, "ipm": 60}
"""The RTI budget of ``QpOptions.rti_budget = None``, per backend (None: no cap beyond ``max_iter`` and
``max_iter_cold``). IPM 60: no IPM QP of the committed paper grid (12,000 runs) ran more than 60 iterations, 3 of the
safe grid's 12,000 runs had one (two unconverged cold starts at 400, one solved at 118); on 20 truck seeds x 200
samples of six presets (``benchmarks/rti_budget.py``) 60 is identical to no budget, 40 moves a seed's progress by up to
0.08 %, 25-30 up to 9.5 %, 20 up to 19 % (docs/wcet.md, "The RTI budget"). OSQP: no extra cap (its cold starts keep
``max_iter_cold``). Presets of configurations measured to afford less set it (``fcgen.presets.IPM_RTI_BUDGET``)."""


@known_fields
@dataclass(frozen=True)
class QpOptions:
    """QP backend and its settings (OSQP's names), used identically by the Python reference and the generated C.

    ``max_iter_cold``: the budget of a cold-started QP (the first after init/reset, no shifted guess; at least
    ``max_iter``): capped at 60 it left |r| up to 1.6 % beyond its bound at sample 0.
    ``cold_restart_after``: after this many feedbacks in a row whose QP was unusable (any ERR_QP_* outcome), the next
    prepare builds the cold-start guess from the state instead of shifting the kept plan (zero duals, a reset QP
    backend, ``max_iter_cold``): what reset() would give, without the caller; 0: never. A kept plan that no longer
    meets the state is refused sample after sample (truck conventional hyperplane, seed 6, OSQP capped at 60: 113
    refusals in a row from sample 14, then the plan shifted past its end braked the ego into reverse); with 3 it
    cold-starts at samples 17 and 34 and finishes its 200 samples at 396.7 m.
    Defaults are the real-time mode (a fixed iteration budget, as RTI uses it): ``max_iter = 60`` (the OSQP presets
    and campaign runs cap at ``fcgen.presets.OSQP_MAX_ITER``: 35 with the ellipse),
    ``rho = 0.2``, ``check_termination = 40`` (a check costs about one iteration), ``scaling = 1`` (one Ruiz
    pass: prepare 0.4 -> 0.15 ms, same convergence as 10 here). ``QpOptions.converged()`` is the quality reference.
    rho is what decides how good a capped solve is: on truck_lifted_ellipse (20 seeds, cap 60) rho = 1 left the
    closed loop 3.7 % (up to 14 % per seed) behind the converged progress, rho = 0.2 within 0.15 % (at most 1 %),
    with no larger slacks or lateral accelerations; rho <= 0.15 undershoots the soft constraints (larger slacks).
    ``sigma``: a float build raises it to ``fcgen.backends.osqp.FLOAT_SIGMA_MIN`` (1e-3): with 1e-6 float's
    factorization of OSQP's KKT matrix is unstable (docs/performance.md, "Single precision in closed loop").
    ``rti_budget``: the most QP iterations any feedback runs, cold starts included (the caps are
    ``min(max_iter, budget)`` warm, ``min(max(max_iter, max_iter_cold), budget)`` cold): what `fcgen wcet`'s bound
    multiplies. Reaching it is QP_MAX_ITER (a finite step inside the input box's margin is taken, else the fallback).
    None: the backend's ``RTI_BUDGET_DEFAULT``.
    ``ipm_scaled_start``: the IPM starts each side's multiplier at ``lam = max(lw, lam_min / max(1, -b))`` (lw its
    warm multiplier, -b its slack at z = 0) and each soft row's slack bound at ``t = max(-b, t_min / max(1, lam))``
    (every other side at ``max(-b, t_min)``), so that no floored initial product t lam exceeds lam_min or t_min: a
    far inactive side started at t lam = lam_min (-b) set the start's mean product, and a slack bound carries a
    multiplier near its row's L1 weight; 5.61 -> 4.62 iterations a QP over the safe grid at `9fbfbba`
    (docs/safe_profile.md). A slack's bound without a warm multiplier (a cold start) starts at the slack's cost over
    the bound's coefficient, the multiplier it carries while the slack's row is inactive, and its t as a soft row's
    slack bound's: the safe presets' cold starts take 4-5 iterations instead of 13-23. The paper's presets keep
    ``False`` (their results as published here before).
    """

    max_iter: int = 60
    eps_abs: float = 1e-3
    eps_rel: float = 1e-3
    rho: float = 0.2
    sigma: float = 1e-6
    alpha: float = 1.6
    adaptive_rho: bool = False
    scaling: int = 1
    check_termination: int = 40
    warm_start: bool = True
    max_iter_cold: int = 400
    cold_restart_after: int = 3
    rti_budget: int | None = None  # QP iterations any feedback may run (None: the backend's RTI_BUDGET_DEFAULT)
    backend: str = "osqp"  # the QP backend (BACKENDS)
    ipm_tol: float = 1e-4  # backend "ipm": stationarity, primal residuals, each t*lam (scaled QP)
    ipm_scaled_start: bool = True  # backend "ipm": floors of the initial lam and t scaled (docstring)

    @property
    def budget(self) -> int | None:
        """The RTI budget in force: ``rti_budget``, or the backend's default (None: no cap beyond the two caps)."""
        return self.rti_budget if self.rti_budget is not None else RTI_BUDGET_DEFAULT.get(self.backend)

    @property
    def caps(self) -> tuple[int, int]:
        """(warm, cold) QP iteration caps: ``min(max_iter, budget)``, ``min(max(max_iter, max_iter_cold), budget)``."""
        b = self.budget if self.budget is not None else 1_000_000
        return min(self.max_iter, b), min(max(self.max_iter, self.max_iter_cold), b)

    @classmethod
    def converged(cls) -> QpOptions:
        """Solve every QP to eps = 1e-5 (up to 4000 iterations): the quality reference for the real-time mode."""
        return cls(max_iter=4000, eps_abs=1e-5, eps_rel=1e-5, rho=1.0, check_termination=5)

    def __post_init__(self) -> None:
        check(
            isinstance(self.max_iter, int) and 1 <= self.max_iter <= 1_000_000,
            "qp.max_iter",
            self.max_iter,
            "an integer in [1, 1e6]",
        )
        check(
            isinstance(self.max_iter_cold, int) and 1 <= self.max_iter_cold <= 1_000_000,
            "qp.max_iter_cold",
            self.max_iter_cold,
            "an integer in [1, 1e6]",
        )
        check(
            type(self.cold_restart_after) is int and 0 <= self.cold_restart_after <= 1_000_000,
            "qp.cold_restart_after",
            self.cold_restart_after,
            "an integer in [0, 1e6] (0: never)",
        )
        check(
            self.rti_budget is None or (type(self.rti_budget) is int and 1 <= self.rti_budget <= 1_000_000),
            "qp.rti_budget",
            self.rti_budget,
            "an integer in [1, 1e6], or None (the backend's default)",
        )
        for f in ("eps_abs", "eps_rel"):
            check(0 <= finite(f"qp.{f}", getattr(self, f)) < 1, f"qp.{f}", getattr(self, f), "[0, 1)")
        check(self.eps_abs > 0 or self.eps_rel > 0, "qp.eps_abs", self.eps_abs, "> 0 when eps_rel = 0")
        positive("qp.rho", self.rho)
        positive("qp.sigma", self.sigma)
        check(0 < finite("qp.alpha", self.alpha) < 2, "qp.alpha", self.alpha, "(0, 2)")
        check(
            isinstance(self.scaling, int) and 0 <= self.scaling <= 100,
            "qp.scaling",
            self.scaling,
            "an integer in [0, 100]",
        )
        check(
            isinstance(self.check_termination, int) and 1 <= self.check_termination <= 1000,
            "qp.check_termination",
            self.check_termination,
            "an integer in [1, 1000]",
        )
        check(0 < finite("qp.ipm_tol", self.ipm_tol) < 1, "qp.ipm_tol", self.ipm_tol, "(0, 1)")
        check(self.backend in BACKENDS, "qp.backend", self.backend, "one of " + ", ".join(BACKENDS))
        check(isinstance(self.ipm_scaled_start, bool), "qp.ipm_scaled_start", self.ipm_scaled_start, "True or False")
