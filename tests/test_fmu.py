"""`fcgen fmu`: the generated controller as a co-simulation FMU (FMI 3.0 and 2.0). FMPy validates it, a closed loop
through it equals the C library's bit for bit (OSQP and IPM, double and float), and its FMI semantics hold: one
instance at a time, doStep of exactly dt, the solver's rejections as FMI errors naming the solver's error."""

from __future__ import annotations

import shutil
import zipfile
from pathlib import Path

import numpy as np
import pytest
from fmpy import extract, read_model_description
from fmpy.fmi1 import FMICallException
from fmpy.fmi3 import FMU3Slave
from fmpy.validation import validate_fmu

from fcgen.build import build
from fcgen.codegen.generate import generate
from fcgen.csolver import CSolver
from fcgen.fmu import FmuController, build_fmu, variables
from fcgen.presets import preset
from fcgen.sim.closedloop import run_closed_loop
from fcgen.sim.runlog import compare
from fcgen.sim.scenario import make_scenario

ROOT = Path(__file__).resolve().parent.parent


@pytest.fixture(scope="module")
def folders(tmp_path_factory):
    """Solver folders: the checked-in IPM example (double) and OSQP example (double), and float builds of both."""
    base = tmp_path_factory.mktemp("fmu")
    out = {}
    for key, src in (("ipm", "truck_lifted_ellipse_ipm"), ("osqp", "truck_lifted_ellipse")):
        shutil.copytree(ROOT / "generated" / src, base / key, ignore=shutil.ignore_patterns("build", "golden"))
        out[key] = base / key
        generate(preset(src), base / f"{key}_float", use_float=True)
        out[f"{key}_float"] = base / f"{key}_float"
    return out


def closed_loops(gen: Path, fmu: Path, samples: int = 15, seed: int = 2):
    pb = preset("truck_lifted_ellipse_ipm" if "ipm" in gen.name else "truck_lifted_ellipse")
    sc = make_scenario("truck", seed, n_opp=pb.opponents.count, samples=samples, dt=pb.horizon.dt)
    lib = run_closed_loop(pb, sc, controller=CSolver(build(gen)))
    ctrl = FmuController(fmu, pb)
    try:
        via_fmu = run_closed_loop(pb, sc, controller=ctrl)
    finally:
        ctrl.close()
    return lib, via_fmu


@pytest.mark.parametrize("key,fmi", [("ipm", 3), ("ipm", 2), ("osqp", 3), ("osqp_float", 2), ("ipm_float", 3)])
def test_fmu_validates_and_equals_the_c_library(folders, key, fmi, tmp_path):
    fmu = build_fmu(folders[key], tmp_path / f"{key}.fmu", fmi)
    assert validate_fmu(str(fmu)) == []
    md = read_model_description(str(fmu))
    assert md.fmiVersion == f"{fmi}.0"
    names = {v.name for v in md.modelVariables}
    if fmi == 3:
        assert {"state", "road_kappa", "opponents", "u0", "states", "controls", "exit_code"} <= names
    else:
        assert {"state[1]", "state[5]", "u0[2]", "opponents[41,3,3]", "states[41,8]"} <= names
    with zipfile.ZipFile(fmu) as z:
        files = set(z.namelist())
    assert "documentation/README.md" in files and any(
        f.startswith("sources/") and f.endswith("_solver.c") for f in files
    )
    assert any(f.startswith("binaries/") and f.endswith(".so") for f in files)
    lib, via_fmu = closed_loops(folders[key], fmu)
    assert via_fmu.meta["controller"] == "c-fmu"
    diff = {k: v for k, v in compare(lib, via_fmu).items() if not k.startswith("time")}
    assert diff and all(v == 0 for v in diff.values()), diff  # bit for bit
    assert np.array_equal(lib.control, via_fmu.control) and np.array_equal(lib.qp_iter, via_fmu.qp_iter)


def _slave(fmu: Path, log: list):
    md = read_model_description(str(fmu))
    s = FMU3Slave(
        guid=md.guid,
        unzipDirectory=extract(str(fmu)),
        modelIdentifier=md.coSimulation.modelIdentifier,
        instanceName="t",
    )
    s.instantiate(logMessage=lambda env, status, cat, msg: log.append(msg.decode()))
    return s, md


def test_fmi_semantics(folders, tmp_path):
    fmu = build_fmu(folders["ipm"], tmp_path / "ipm.fmu", 3)
    log: list[str] = []
    a, md = _slave(fmu, log)
    vr = {v.name: v.valueReference for v in md.modelVariables}
    # a second instance of the same FMU (the same binary) is refused, with the reason in the log
    b = FMU3Slave(
        guid=md.guid,
        unzipDirectory=a.unzipDirectory,
        modelIdentifier=md.coSimulation.modelIdentifier,
        instanceName="second",
    )
    with pytest.raises(Exception, match="Failed to instantiate"):
        b.instantiate(logMessage=lambda env, status, cat, msg: log.append(msg.decode()))
    assert any("one instance at a time" in m for m in log)
    a.enterInitializationMode()
    a.exitInitializationMode()
    # a step size other than dt is refused, naming both
    with pytest.raises(FMICallException):
        a.doStep(0.0, 0.05)
    assert any("communicationStepSize 0.050000000000000003 refused" in m for m in log)
    # the solver's rejection (a non-finite state) is an FMI error naming the solver's error code
    a.setFloat64([vr["state"]], [0.0, float("nan"), 0.0, 10.0, 0.0])
    with pytest.raises(FMICallException):
        a.doStep(0.0, float(md.defaultExperiment.stepSize))
    assert any("TRUCK_LIFT_EL_IPM_ERR_NONFINITE_STATE" in m for m in log)
    # outputs cannot be set; the sizes are the header's
    with pytest.raises(FMICallException):
        a.setFloat64([vr["u0"]], [1.0, 2.0])
    assert len(a.getFloat64([vr["states"]], 41 * 8)) == 41 * 8
    a.terminate()
    a.freeInstance()
    # freed: a new instance may be made
    c, _ = _slave(fmu, log)
    c.freeInstance()


def test_variables_are_the_headers_sizes():
    vs = {v.name: v for v in variables({"N": 40, "NX": 8, "NU": 2, "ROAD_MAX": 141, "NOPP": 3, "NOPP_PAR": 3})}
    assert vs["opponents"].dims == (41, 3, 3) and vs["road_kappa"].count == 141 and vs["states"].count == 41 * 8
    assert [v.name for v in vs.values() if v.input] == [
        "state",
        "road_s0",
        "road_ds",
        "road_n",
        "road_kappa",
        "road_phi",
        "road_x",
        "road_y",
        "opponents",
    ]


def test_fmi2_semantics(folders, tmp_path, capfd):
    """FMI 2.0's layer: the same refusals (a second instance, another step size), the same log lines."""
    from fmpy.fmi2 import FMU2Slave

    fmu = build_fmu(folders["ipm"], tmp_path / "ipm2.fmu", 2)
    md = read_model_description(str(fmu))
    d = extract(str(fmu))
    a = FMU2Slave(guid=md.guid, unzipDirectory=d, modelIdentifier=md.coSimulation.modelIdentifier, instanceName="a")
    a.instantiate()
    b = FMU2Slave(guid=md.guid, unzipDirectory=d, modelIdentifier=md.coSimulation.modelIdentifier, instanceName="b")
    with pytest.raises(Exception, match="Failed to instantiate"):
        b.instantiate()
    a.setupExperiment(startTime=0.0)
    a.enterInitializationMode()
    a.exitInitializationMode()
    with pytest.raises(FMICallException):
        a.doStep(0.0, 0.2)
    out = capfd.readouterr().out
    assert "one instance at a time" in out and "communicationStepSize 0.20000000000000001 refused" in out
    a.terminate()
    a.freeInstance()
