"""A closed-loop controller that drives an fcgen FMU through FMPy (``--controller fmu``), and the problem an FMU was
generated from."""

from __future__ import annotations

import tempfile
import zipfile
from pathlib import Path

import numpy as np

from ..contract import StepResult
from ..extras import require
from .package import FmuError


def fmu_problem(path: Path | str):
    """The Problem an fcgen FMU was generated from (its ``resources/problem.py``)."""
    from ..presets import load_problem

    with zipfile.ZipFile(path) as z:
        if "resources/problem.py" not in z.namelist():
            raise FmuError(f"{path}: no resources/problem.py: not an FMU written by fcgen fmu (give --problem)")
        with tempfile.TemporaryDirectory() as tmp:
            f = Path(tmp) / "problem.py"
            f.write_bytes(z.read("resources/problem.py"))
            return load_problem(str(f))


class FmuController:
    """A closed-loop controller that runs an fcgen FMU through FMPy: one ``doStep`` of ``dt`` per sample, on the
    inputs the C library would get (the same calls inside, so the same results bit for bit)."""

    kind = "c-fmu"

    def __init__(self, path: Path | str, problem=None):
        with require("fmu", "an FMU controller"):
            from fmpy import extract, read_model_description

        self.path = Path(path)
        md = read_model_description(str(self.path))
        if problem is not None and md.coSimulation.modelIdentifier != problem.name:
            raise FmuError(
                f"--fmu {path}: the FMU's solver is {md.coSimulation.modelIdentifier!r}, the problem is "
                f"{problem.name!r}"
            )
        self.fmi = 3 if md.fmiVersion.startswith("3") else 2
        self._dir = extract(str(self.path))
        self.dt = float(md.defaultExperiment.stepSize)
        ident = md.coSimulation.modelIdentifier
        self.vr = {}
        if self.fmi == 3:
            with require("fmu", "an FMU controller"):
                from fmpy.fmi3 import FMU3Slave

            self.fmu = FMU3Slave(guid=md.guid, unzipDirectory=self._dir, modelIdentifier=ident, instanceName="fcgen")
            for v in md.modelVariables:
                self.vr[v.name] = v.valueReference
            self.fmu.instantiate()
        else:
            with require("fmu", "an FMU controller"):
                from fmpy.fmi2 import FMU2Slave

            self.fmu = FMU2Slave(guid=md.guid, unzipDirectory=self._dir, modelIdentifier=ident, instanceName="fcgen")
            groups: dict[str, list[int]] = {}
            for v in md.modelVariables:
                groups.setdefault(v.name.split("[")[0], []).append(v.valueReference)
            self.vr = groups
            self.fmu.instantiate()
            self.fmu.setupExperiment(startTime=0.0)
        self.fmu.enterInitializationMode()
        self.fmu.exitInitializationMode()
        self.count = (
            {
                v.name: int(np.prod([int(d.start) for d in v.dimensions])) if v.dimensions else 1
                for v in md.modelVariables
            }
            if self.fmi == 3
            else {k: len(v) for k, v in self.vr.items()}
        )
        self.t = 0.0
        self._last = None

    def _set(self, name: str, values, integer: bool = False) -> None:
        vals = np.asarray(values, dtype=float).ravel()
        if len(vals) < self.count[name]:  # a road window shorter than ROAD_MAX: the rest is not read
            vals = np.concatenate([vals, np.zeros(self.count[name] - len(vals))])
        if self.fmi == 3:
            if integer:
                self.fmu.setInt32([self.vr[name]], [int(v) for v in vals])
            else:
                self.fmu.setFloat64([self.vr[name]], list(vals))
        elif integer:
            self.fmu.setInteger(self.vr[name], [int(v) for v in vals])
        else:
            self.fmu.setReal(self.vr[name], list(vals))

    def _get(self, name: str, n: int = 1, integer: bool = False) -> np.ndarray:
        if self.fmi == 3:
            vals = self.fmu.getInt32([self.vr[name]], n) if integer else self.fmu.getFloat64([self.vr[name]], n)
        else:
            vals = self.fmu.getInteger(self.vr[name]) if integer else self.fmu.getReal(self.vr[name])
        return np.asarray(vals, dtype=np.int64 if integer else float)

    def step(self, x0: np.ndarray, road, opp: np.ndarray):
        self._set("state", x0)
        self._set("road_s0", [road.s0])
        self._set("road_ds", [road.ds])
        self._set("road_n", [road.size], integer=True)
        for nm, arr in (("road_kappa", road.kappa), ("road_phi", road.phi), ("road_x", road.gx), ("road_y", road.gy)):
            self._set(nm, arr)
        self._set("opponents", opp)
        self.fmu.doStep(currentCommunicationPoint=self.t, communicationStepSize=self.dt)
        self.t += self.dt
        rc = int(self._get("exit_code", integer=True)[0])
        u0 = self._get("u0", 2)
        slack = float(self._get("max_slack")[0])
        return StepResult(
            u0,
            rc,
            int(self._get("qp_status", integer=True)[0]),
            int(self._get("qp_iter", integer=True)[0]),
            float(self._get("time_prepare")[0]),
            float(self._get("time_feedback")[0]),
            float("nan") if rc else slack,
            int(self._get("plan_reaction", integer=True)[0]),
            int(self._get("a_lat_guard", integer=True)[0]),
        )

    def close(self) -> None:
        self.fmu.terminate()
        self.fmu.freeInstance()
