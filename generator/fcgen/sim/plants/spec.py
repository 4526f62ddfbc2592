"""What closes a loop besides the controller: the plant (fcgen's model or a CommonRoad vehicle model), its parameter
set, and the actuation and sensing between them (latency, steering lag, measurement noise)."""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass

from ...dsl import ProblemError
from ...dsl.validation import check, finite

#: ``model``: fcgen's own RK4 Frenet model (the NLP's formula); the others are CommonRoad's vehicle models
PLANT_KINDS: tuple[str, ...] = ("model", "ks", "st", "std", "mb")
#: ``paper``: the BMW 320i with fcgen's ego geometry and mass; ``matched``: the BMW 320i as shipped, the controller's
#: wheelbase and mass set to it
PLANT_PARAMS: tuple[str, ...] = ("paper", "matched")
#: the default measurement noise's std on (s, n, alpha, v, delta): m, m, rad, m/s, rad
DEFAULT_NOISE: tuple[float, ...] = (0.05, 0.05, 0.005, 0.05, 0.002)
#: the opponents' futures the solver is given: the truth (``oracle``) or a prediction (``fcgen.sim.prediction``)
PREDICTIONS: tuple[str, ...] = ("oracle", "constant-velocity", "constant-acceleration", "lane-following")
PREDICTION_LABELS = {"constant-velocity": "cv", "constant-acceleration": "ca", "lane-following": "lane"}
#: the largest latency in samples the closed loop takes (``Problem.delay``'s range is the same)
MAX_LATENCY = 8
#: the largest steering lag time constant (s)
MAX_STEER_LAG = 2.0
#: the largest factor c of the prediction's margin rule
MAX_PREDICTION_MARGIN = 10.0


@dataclass(frozen=True)
class PlantSpec:
    """The plant and the perturbations of one closed loop; ``PlantSpec()`` is fcgen's own world (the default)."""

    kind: str = "model"
    params: str = "paper"
    latency: int = 0  # samples between measurement and actuation
    steer_lag: float = 0.0  # s, time constant of a first-order steering actuator (0: none)
    noise: tuple[float, ...] = (0.0,) * 5  # std of the Gaussian noise on the measured (s, n, alpha, v, delta)
    prediction: str = "oracle"  # the opponents' futures the solver is given (sim.prediction.PREDICTIONS)
    # c of the obstacle margin per stage that grows with the prediction's expected error (sim.prediction.MARGIN_RULE;
    # 0: none, the problem's own margin)
    prediction_margin: float = 0.0

    def __post_init__(self) -> None:
        check(self.kind in PLANT_KINDS, "plant", self.kind, f"one of {', '.join(PLANT_KINDS)}")
        check(self.params in PLANT_PARAMS, "plant_params", self.params, f"one of {', '.join(PLANT_PARAMS)}")
        check(
            isinstance(self.latency, int) and not isinstance(self.latency, bool) and 0 <= self.latency <= MAX_LATENCY,
            "latency",
            self.latency,
            f"an integer in [0, {MAX_LATENCY}] samples",
        )
        check(
            0 <= finite("steer_lag", self.steer_lag) <= MAX_STEER_LAG,
            "steer_lag",
            self.steer_lag,
            f"[0, {MAX_STEER_LAG}] s",
        )
        check(self.prediction in PREDICTIONS, "prediction", self.prediction, f"one of {', '.join(PREDICTIONS)}")
        check(
            0 <= finite("prediction_margin", self.prediction_margin) <= MAX_PREDICTION_MARGIN,
            "prediction_margin",
            self.prediction_margin,
            f"[0, {MAX_PREDICTION_MARGIN}] (0: none)",
        )
        check(
            self.prediction_margin == 0 or self.prediction != "oracle",
            "prediction_margin",
            self.prediction_margin,
            "0 with the oracle (a margin grows with a prediction's error: give --prediction)",
        )
        check(isinstance(self.noise, tuple) and len(self.noise) == 5, "noise", self.noise, "a tuple of 5 stds")
        for i, v in enumerate(self.noise):
            check(0 <= finite(f"noise[{i}]", v) <= 10, f"noise[{i}]", v, "[0, 10]")

    @property
    def is_default(self) -> bool:
        """Whether this is fcgen's own world: its model, no latency, no lag, no noise, the true traffic."""
        return self == PlantSpec()

    @property
    def noisy(self) -> bool:
        return any(v > 0 for v in self.noise)

    def label(self) -> str:
        """A short name for tables and run ids: ``model``, ``st+lat1+lag0.1+noise`` ..."""
        parts = [self.kind if self.params == "paper" else f"{self.kind}-matched"]
        if self.latency:
            parts.append(f"lat{self.latency}")
        if self.steer_lag:
            parts.append(f"lag{self.steer_lag:g}")
        if self.noisy:
            parts.append("noise" if self.noise == DEFAULT_NOISE else "noise" + ":".join(f"{v:g}" for v in self.noise))
        if self.prediction != "oracle":
            parts.append(PREDICTION_LABELS[self.prediction])
        if self.prediction_margin:
            parts.append(f"pm{self.prediction_margin:g}")
        return "+".join(parts)

    def as_meta(self) -> dict:
        """The run log's ``meta.extra.plant`` and a campaign row's plant columns."""
        d = asdict(self)
        d["noise"] = list(self.noise)
        if not self.prediction_margin:  # a log or suite without the margin: as before it
            del d["prediction_margin"]
        return d


def parse_noise(text: str | None) -> tuple[float, ...]:
    """``--noise``: ``default``, five comma-separated stds, or none (zeros)."""
    if text is None or text.strip() in ("", "0", "none"):
        return (0.0,) * 5
    if text.strip() == "default":
        return DEFAULT_NOISE
    try:
        vals = tuple(float(x) for x in text.split(","))
    except ValueError:
        raise ProblemError(f"noise = {text!r} is invalid: allowed 'default' or 5 comma-separated stds") from None
    if len(vals) != 5 or not all(math.isfinite(v) and v >= 0 for v in vals):
        raise ProblemError(f"noise = {text!r} is invalid: allowed 'default' or 5 comma-separated stds >= 0")
    return vals


def plant_from_meta(meta: dict | None) -> PlantSpec:
    """The ``PlantSpec`` of ``as_meta()``'s dict (a run log's ``meta.extra.plant``, a suite's ``settings.plant``;
    none or empty: fcgen's model)."""
    d = dict(meta or {})
    if not d:
        return PlantSpec()
    d["noise"] = tuple(float(v) for v in d.get("noise", (0.0,) * 5))
    return PlantSpec(**d)


def plant_of(log) -> PlantSpec:
    """The plant and perturbations a run log records (``meta.extra.plant``; none: fcgen's model)."""
    return plant_from_meta(log.meta.get("extra", {}).get("plant"))
