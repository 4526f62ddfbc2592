"""The plant of a CommonRoad run (``run_commonroad(plant=...)``): fcgen's own model, or what a ``PlantSpec`` names
(``sim.plants``): a CommonRoad vehicle model (``--plant ks|st|std|mb``) and the perturbations between controller and
plant (noise on the measured state, latency, steering lag). A spec's prediction is the loop's (``sim.cr_prediction``);
its ``prediction_margin`` is refused."""

from __future__ import annotations

import numpy as np

from ..dsl import Problem
from ..road import Road
from .closedloop import Plant
from .plants import PlantSpec
from .plants.actuation import Actuation


class ScenarioPlant:
    """``measure`` (the state the controller gets) and ``step`` (the plant's next state) of one run; with the default
    spec, the state itself and fcgen's model (``Plant.step``), bit for bit."""

    def __init__(self, problem: Problem, spec: PlantSpec, model: Plant, x0: np.ndarray, road: Road):
        if spec.prediction_margin:
            raise ValueError("prediction_margin is not for a CommonRoad run (its margins are the paper road's)")
        self.spec, self.model = spec, model
        self.act = Actuation(spec, 0, problem.horizon.dt)
        self.vm = None
        self.cut: list[int] = []  # per sample the CommonRoad model's input-limit flags (CUT_*; none for the model)
        if spec.kind != "model":
            from .plants.commonroad_vm import CommonRoadPlant

            self.vm = CommonRoadPlant(problem, spec.kind, spec.params)
            self.vm.reset(tuple(float(c) for c in x0), road)

    def measure(self, x: np.ndarray) -> np.ndarray:
        """The state the controller gets (``x`` plus the spec's noise; ``x`` itself without)."""
        return self.act.measure(x)

    def step(self, x: np.ndarray, u: np.ndarray, road: Road) -> np.ndarray:
        """The plant's state one sample after ``x`` under the controller's ``u`` (through latency and lag)."""
        applied = self.act.actuate(u, float(x[4]))
        if self.vm is None:
            return self.model.step(x, applied, road)
        xn, info = self.vm.step((float(applied[0]), float(applied[1])))
        self.cut.append(int(info.cut))
        return np.asarray(xn, dtype=float)
