"""Array variables through fmpy (FMI 3 arrays, FMI 2 scalars ``name[i,j]``), on
``modelDescription/ZonedCushion/scene.json`` (zone pressures ``wind`` [2], corner support displacements
``corners`` [4, 3], the displacement field ``u`` [81, 3], ``corner_x`` [4, 3], ``edge_tension``
[8], ``stress`` [128, 2], ``wrinkle`` [128] of UInt8).

Reference numbers: ``velarium solve`` on ``examples/ZonedCushion-loads.csv``. The FMI 3 archive
(arrays), the FMI 2 archive (scalars) and ``velarium solve`` call the same engine with the same
f64 inputs in the same order, so every element must agree bit for bit (``np.array_equal``).
Item 52 of the checklist (row-major arrays, wrong ``nValues`` -> fmi3Error) and item 53 (array
inputs as structured-array fields with a shape in ``simulate_fmu``).
"""

from __future__ import annotations

import subprocess
from pathlib import Path

import fmpy
import numpy as np
import pytest
from fmpy.fmi2 import FMU2Slave
from fmpy.validation import validate_fmu

import fmi3_support as f3
import velarium_run as vr

SCENE = vr.SCENES / "ZonedCushion" / "scene.json"
LOADS = vr.ROOT / "examples" / "ZonedCushion-loads.csv"

SHAPES = {
    "wind": (2,),
    "corners": (4, 3),
    "u": (81, 3),
    "corner_x": (4, 3),
    "edge_tension": (8,),
    "stress": (128, 2),
    "wrinkle": (128,),
}


@pytest.fixture(scope="module")
def archives(tmp_path_factory) -> tuple[Path, Path]:
    out = tmp_path_factory.mktemp("arrays")
    run = subprocess.run([str(vr.VELARIUM), "pack", str(SCENE), "--out", str(out)], capture_output=True, text=True)
    assert run.returncode == 0, run.stderr
    return out / "ZonedCushion.fmu", out / "ZonedCushion_fmi3.fmu"


@pytest.fixture(scope="module")
def solved(tmp_path_factory) -> np.ndarray:
    out = tmp_path_factory.mktemp("arrays_solve") / "solve.csv"
    run = subprocess.run([str(vr.VELARIUM), "solve", str(SCENE), "--loads", str(LOADS), "--out", str(out)],
                         capture_output=True, text=True)
    assert run.returncode == 0, run.stderr
    return vr.read_csv(out)


def loads() -> np.ndarray:
    return vr.read_csv(LOADS)


def subscripts(shape: tuple[int, ...]) -> list[str]:
    """FMI 2 element suffixes in row-major order, 1-based: ["[1]", ...] or ["[1,1]", ...]."""
    return ["[" + ",".join(str(i + 1) for i in index) + "]" for index in np.ndindex(*shape)]


def test_both_archives_validate(archives):
    for fmu in archives:
        assert validate_fmu(str(fmu)) == [], fmu.name


def test_fmi3_declares_the_shapes_and_fmi2_the_scalars(archives):
    fmi2, fmi3 = (fmpy.read_model_description(str(f)) for f in archives)
    by_name3 = {v.name: v for v in fmi3.modelVariables}
    by_name2 = {v.name: v for v in fmi2.modelVariables}
    for name, shape in SHAPES.items():
        v = by_name3[name]
        assert tuple(int(d.start) for d in v.dimensions) == shape, name
        assert v.type == ("UInt8" if name == "wrinkle" else "Float64")
        # FMI 2: one scalar per element, value references counting up from the array's.
        for k, suffix in enumerate(subscripts(shape)):
            s = by_name2[name + suffix]
            assert s.valueReference == v.valueReference + k
            assert s.type == ("Integer" if name == "wrinkle" else "Real")
    assert by_name3["center_uz"].dimensions == []


def fmi3_run(fmu: Path, table: np.ndarray) -> list[dict[str, np.ndarray]]:
    """Row k: every array after setting row k's loads and stepping (row 0: the initial
    equilibrium under row 0's loads), read with one getFloat64/getUInt8 call per array."""
    md = fmpy.read_model_description(str(fmu))
    unzipdir = Path(fmpy.extract(str(fmu)))
    refs = {v.name: v.valueReference for v in md.modelVariables}
    rows = []

    def read(s) -> dict[str, np.ndarray]:
        out = {}
        for name, shape in SHAPES.items():
            n = int(np.prod(shape))
            get = s.getUInt8 if name == "wrinkle" else s.getFloat64
            out[name] = np.array(get([refs[name]], nValues=n), dtype=float).reshape(shape)
        out["center_uz"] = np.array(s.getFloat64([refs["center_uz"]]))
        return out

    def apply(s, row) -> None:
        wind = [row[f"wind[{i}]"] for i in (1, 2)]
        corners = np.zeros((4, 3))
        for i in range(4):
            corners[i, 2] = row[f"corners[{i + 1},3]"]
        s.setFloat64([refs["wind"], refs["corners"]], wind + list(corners.ravel()))

    with f3.slave(unzipdir, md) as s:
        s.enterInitializationMode(startTime=float(table["time"][0]))
        apply(s, table[0])
        s.exitInitializationMode()
        rows.append(read(s))
        for k in range(1, len(table)):
            apply(s, table[k])
            t = float(table["time"][k - 1])
            s.doStep(t, float(table["time"][k]) - t)
            rows.append(read(s))
    return rows


def test_fmi3_arrays_equal_velarium_solve(archives, solved):
    rows = fmi3_run(archives[1], loads())
    assert len(rows) == len(solved)
    for k, row in enumerate(rows):
        for name, shape in SHAPES.items():
            if name in ("wind", "corners"):
                continue
            expected = np.array([solved[name + s][k] for s in subscripts(shape)]).reshape(shape)
            assert np.array_equal(row[name], expected), (k, name)
    # The loads did something: the wind lifts the centre, the wrinkle states change.
    assert rows[-2]["center_uz"][0] > 0.1
    assert {0.0, 1.0} <= set(np.unique(rows[-1]["wrinkle"]))


def test_fmi2_scalars_equal_velarium_solve(archives, solved):
    fmu = archives[0]
    md = fmpy.read_model_description(str(fmu))
    unzipdir = fmpy.extract(str(fmu))
    table = loads()
    refs = {v.name: v.valueReference for v in md.modelVariables}
    real = [n for n in solved.dtype.names if n != "time" and not n.startswith(("wrinkle[", "newton"))]
    ints = [n for n in solved.dtype.names if n.startswith("wrinkle[")]
    s = FMU2Slave(guid=md.guid, unzipDirectory=unzipdir, modelIdentifier=md.coSimulation.modelIdentifier,
                  instanceName="a")
    try:
        s.instantiate()
        s.setupExperiment(startTime=float(table["time"][0]))
        s.enterInitializationMode()
        inputs = [n for n in table.dtype.names if n != "time"]
        for k in range(len(table)):
            s.setReal([refs[n] for n in inputs], [float(table[n][k]) for n in inputs])
            if k == 0:
                s.exitInitializationMode()
            else:
                t = float(table["time"][k - 1])
                s.doStep(t, float(table["time"][k]) - t)
            got = s.getReal([refs[n] for n in real])
            assert np.array_equal(got, [solved[n][k] for n in real]), k
            got = s.getInteger([refs[n] for n in ints])
            assert np.array_equal(got, [solved[n][k] for n in ints]), k
        s.terminate()
    finally:
        s.freeInstance()


def test_wrong_n_values_is_an_error(archives):
    fmu = archives[1]
    md = fmpy.read_model_description(str(fmu))
    unzipdir = Path(fmpy.extract(str(fmu)))
    ref = next(v.valueReference for v in md.modelVariables if v.name == "u")
    with f3.slave(unzipdir, md) as s:
        s.enterInitializationMode()
        s.exitInitializationMode()
        f3.clear_log()
        with pytest.raises(fmpy.fmi1.FMICallException) as e:
            s.getFloat64([ref], nValues=3)
        assert e.value.status == f3.ERROR
        assert any("nValues = 3, expected 243" in m for m in f3.messages())


def test_simulate_fmu_takes_array_inputs_with_a_shape(archives, tmp_path):
    """fmpy 0.3.32 stacks all continuous inputs of one type into one table (``np.stack`` in
    ``Input.__init__``), so they must share a shape: the table drives ``wind`` [2] alone and
    the corners keep their start values (fmpy warns that ``corners`` is missing)."""
    table = loads()
    wind_only = tmp_path / "wind.csv"
    wind_only.write_text("time,wind[1],wind[2]\n" + "".join(
        f"{float(t)!r},{float(a)!r},{float(b)!r}\n"
        for t, a, b in zip(table["time"], table["wind[1]"], table["wind[2]"])))
    out = tmp_path / "solve.csv"
    run = subprocess.run([str(vr.VELARIUM), "solve", str(SCENE), "--loads", str(wind_only), "--out", str(out)],
                         capture_output=True, text=True)
    assert run.returncode == 0, run.stderr
    solved = vr.read_csv(out)
    rows = np.zeros(len(table), dtype=[("time", np.float64), ("wind", np.float64, (2,))])
    rows["time"] = table["time"]
    rows["wind"][:, 0], rows["wind"][:, 1] = table["wind[1]"], table["wind[2]"]
    # The one-step lag: the row recorded at t_{k+1} carries the loads of t_k.
    result = vr.simulate(archives[1], vr.extend_by_one_step(rows), output=["u", "center_uz"])
    assert result["u"].shape == (len(table) + 1, 81, 3)
    for k in range(len(table)):
        expected = np.array([solved["u" + s][k] for s in subscripts((81, 3))]).reshape(81, 3)
        assert np.array_equal(result["u"][k + 1], expected), k
    assert result["center_uz"][-1] > 0.1
