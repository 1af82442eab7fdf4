"""The FMI 3.0 archive of every shipped scene (``<Name>_fmi3.fmu``, same library as the FMI 2
``<Name>.fmu``), from outside through fmpy's FMI 3 API (``fmpy.fmi3.FMU3Slave`` and
``simulate_fmu``, fmpy 0.3.32), with the FMI 3 items of the checklist in docs/fmu.md
section 8 (37, 52-55; item 51, other importers, is not available in CI) and the FMI 3 form of
items 4, 42 and 44.

Reference numbers: the FMI 2 archive of the same scene and ``velarium solve`` on the same load
table. The FMI 3 and FMI 2 runs call the same engine with the same f64 inputs in the same order,
so they must agree bit for bit (``np.array_equal``); against ``velarium solve`` the tolerance of
``test_fmus.py`` applies (RTOL = 1e-9, with the one-step lag of co-simulation).

Discard: FMI 3's DoStep Discard means "nothing happened" (the FMU keeps the state it had before
the call); fmpy's FMI 3 ``simulate_fmu`` raises ``FMICallException`` on it (unlike FMI 2, where
Discard with Terminated ends the run gracefully). The FMI 3 loop of docs/fmu.md ("FMI 3.0")
handles it; the test ``test_documented_loop_stops_at_the_discarded_step`` runs that very code
from docs/fmu.md.
"""

from __future__ import annotations

import re
import subprocess
import sys
import xml.etree.ElementTree as ET
import zipfile
from ctypes import byref, c_bool, c_double

import fmpy
import numpy as np
import pytest
from fmpy.fmi1 import FMICallException
from fmpy.validation import validate_fmu

import fmi3_support as f3
import fmi_support as fs
import velarium_run as vr
from test_conformance_robust import failure_time
from test_fmus import assert_rows_close, integer_outputs, real_outputs

TYPES = {"Real": "Float64", "Integer": "Int32"}


@pytest.fixture
def fmu3(fmu) -> vr.Path:
    path = f3.fmi3_path(fmu)
    if not path.is_file():
        pytest.skip(f"{path} is missing: run `bash .ci/run` (velarium pack writes both archives)")
    return path


@pytest.fixture
def md3(fmu3):
    return fmpy.read_model_description(str(fmu3), validate=True)


@pytest.fixture
def unzipdir3(fmu3, extract_root):
    return fs.extracted(fmu3, extract_root)


def step_sizes(table):
    return [(float(table["time"][k]), float(table["time"][k + 1] - table["time"][k])) for k in range(len(table) - 1)]


# -- The archive and its description (items 1, 2, 4, 52) -----------------------------------------


def test_archive_layout_and_binary(fmu3, fmu, md3, velarium):
    with zipfile.ZipFile(fmu3) as z:
        infos = z.infolist()
    identifier = md3.coSimulation.modelIdentifier
    assert [i.filename for i in infos] == [
        "modelDescription.xml",
        f"binaries/x86_64-linux/{identifier}.so",
        "resources/scene.json",
        "resources/mesh.vtu",
        "extra/org.fmi-standard.fmi-ls-ref/fmi-ls-manifest.xml",
        f"extra/org.fmi-standard.fmi-ls-ref/{identifier}_ref.csv",
        f"extra/org.fmi-standard.fmi-ls-ref/{identifier}_in.csv",
    ]
    assert all(i.compress_type == zipfile.ZIP_DEFLATED for i in infos)
    library = vr.default_library()  # what `velarium pack` ships: the portable build when current
    assert vr.fmu_member(fmu3, f"binaries/x86_64-linux/{identifier}.so") == library.read_bytes()
    assert vr.fmu_member(fmu3, "resources/scene.json") == vr.fmu_member(fmu, "resources/scene.json")
    assert vr.fmu_member(fmu3, "resources/mesh.vtu") == vr.fmu_member(fmu, "resources/mesh.vtu")
    # fmpy names the FMI 3 platform x86_64-linux "linux64" too.
    assert fmpy.supported_platforms(str(fmu3)) == ["linux64"]


def test_description_validates_and_matches_the_fmi2_one(fmu3, md3, model_description):
    """fmpy validate (XSD + semantic checks) and fmutool -check find nothing; fmiVersion 3.0; exactly one
    independent variable (time, value reference 0); the other variables are the FMI 2 ones with
    the same value references, causality, variability, unit, start, min, max; the token is not
    the FMI 2 GUID."""
    f3.skip_arrays(md3)
    assert validate_fmu(str(fmu3)) == []
    run = subprocess.run([str(vr.Path(sys.executable).with_name("fmpy")), "validate", str(fmu3)],
                         capture_output=True, text=True, timeout=300)
    assert run.returncode == 0 and "No problems found." in run.stdout, run.stdout + run.stderr
    fmutool = vr.Path(sys.executable).with_name("fmutool")
    run = subprocess.run([str(fmutool), "-input", str(fmu3), "-check"], capture_output=True, text=True, timeout=300)
    report = run.stdout + run.stderr
    assert run.returncode == 0 and "compliant with FMI-3.0" in report and "ERROR" not in report, report
    assert md3.fmiVersion == "3.0"
    independent = [v for v in md3.modelVariables if v.causality == "independent"]
    assert [(v.name, v.valueReference, v.type) for v in independent] == [("time", 0, "Float64")]
    refs = [v.valueReference for v in md3.modelVariables]
    assert len(refs) == len(set(refs))

    def key(v, types):
        return (v.name, v.valueReference, types.get(v.type, v.type), v.causality, v.variability, v.unit,
                v.start, v.min, v.max)

    assert [key(v, {}) for v in md3.modelVariables[1:]] == [key(v, TYPES) for v in model_description.modelVariables]
    assert md3.guid != model_description.guid


def test_capability_flags_and_model_structure(fmu3):
    """The CoSimulation flags state what the binary does; ModelStructure lists every output once
    as Output and as InitialUnknown (all initial="calculated"), in value-reference order."""
    root = ET.fromstring(vr.fmu_member(fmu3, "modelDescription.xml"))
    cs = root.find("CoSimulation").attrib
    assert cs["canGetAndSetFMUState"] == cs["canSerializeFMUState"] == "true"
    assert cs["canHandleVariableCommunicationStepSize"] == "true"
    for flag in ("hasEventMode", "canBeInstantiatedOnlyOncePerProcess"):
        assert cs[flag] == "false", flag
    assert cs["providesIntermediateUpdate"] == cs["mightReturnEarlyFromDoStep"] == "true"
    assert cs["canReturnEarlyAfterIntermediateUpdate"] == "true"
    assert cs["providesDirectionalDerivatives"] == cs["providesAdjointDerivatives"] == "true"
    variables = list(root.find("ModelVariables"))
    outputs = [int(v.get("valueReference")) for v in variables if v.get("causality") == "output"]
    structure = root.find("ModelStructure")
    assert [int(u.get("valueReference")) for u in structure.findall("Output")] == outputs
    assert [int(u.get("valueReference")) for u in structure.findall("InitialUnknown")] == sorted(outputs)
    assert all(v.get("initial") is None and v.get("start") is None for v in variables if v.get("causality") == "output")
    defined = {u.get("name") for u in root.iter("Unit")}
    assert all(v.get("unit") in defined for v in variables if v.get("unit"))


def test_item55_exports_all_75_fmi3_functions(fmu3, md3, tmp_path):
    """The library exports exactly the 34 FMI 2 and the 75 FMI 3 functions (nm), and fmpy's
    FMU3Slave, which resolves every fmi3* function at load time, loads it."""
    from test_conformance_static import FMI2_FUNCTIONS, tool

    so = tmp_path / "lib.so"
    so.write_bytes(vr.fmu_member(fmu3, f"binaries/x86_64-linux/{md3.coSimulation.modelIdentifier}.so"))
    nm = subprocess.run([tool("nm"), "-D", "--defined-only", str(so)], capture_output=True, text=True, check=True)
    exported = sorted(line.split()[-1] for line in nm.stdout.splitlines() if line.strip())
    assert exported == sorted(FMI2_FUNCTIONS + f3.FMI3_FUNCTIONS)


# -- The numbers (item 53) ---------------------------------------------------------------------


def test_item53_simulate_fmu_equals_fmi2_and_velarium_solve(fmu3, fmu, scene, md3, model_description, velarium, tmp_path):
    f3.skip_arrays(md3)
    steps = 4
    table = vr.ramp_table(model_description, steps)
    rows3 = vr.simulate(fmu3, table)
    rows2 = vr.simulate(fmu, table)
    assert rows3.dtype.names == rows2.dtype.names
    for name in rows2.dtype.names:
        assert np.array_equal(rows3[name], rows2[name]), f"{name}:\n{rows3[name]}\n{rows2[name]}"
    cli_rows = vr.solve(scene, table, tmp_path, velarium)
    reals = real_outputs(model_description)
    ints = integer_outputs(model_description)
    assert_rows_close(rows3[:1], cli_rows[:1], reals + ints, "t_0 vs solve row 0")
    assert_rows_close(rows3[1:], cli_rows[:-1], reals, "t_(k+1) vs solve row k")


def test_low_level_loop_out_arguments_and_time(unzipdir3, md3, model_description):
    """FMU3Slave with earlyReturnAllowed=True: every doStep returns eventHandlingNeeded,
    terminateSimulation and earlyReturn false (item 54: earlyReturn is never true) and
    lastSuccessfulTime = t + h; `time` (value reference 0) follows; the outputs equal the FMI 2
    archive's simulate_fmu rows."""
    f3.skip_arrays(md3)
    table = vr.ramp_table(md3, 4)
    reference = vr.simulate(vr.FMU_DIR / f"{md3.modelName}.fmu", table)
    with f3.slave(unzipdir3, md3, earlyReturnAllowed=True) as s:
        f3.initialize(s, md3)
        assert s.getFloat64([0]) == [vr.experiment(md3)[0]]
        rows = [f3.read_outputs(s, md3)]
        for k, (t, h) in enumerate(step_sizes(table)):
            f3.set_inputs(s, md3, table[k])
            assert s.doStep(t, h) == (False, False, False, t + h)
            assert s.getFloat64([0]) == [t + h]
            rows.append(f3.read_outputs(s, md3))
        s.terminate()
        assert f3.read_outputs(s, md3) == rows[-1], "getters after terminate give the final values"
    names = [v.name for v in f3.outputs(md3)] + [v.name for v in f3.outputs(md3, ("Int32",))]
    expected = [[float(reference[n][i]) for n in names] for i in range(len(reference))]
    assert rows == expected


# -- Argument checks and unsupported functions (items 52, 54, 55) -------------------------------


def test_item52_wrong_n_values_is_an_error(unzipdir3, md3):
    """Every variable is a scalar: nValues != nValueReferences -> fmi3Error with a message;
    nothing changed. (Array variables, the rest of item 52, are not declared yet.)"""
    f3.skip_arrays(md3)
    out = f3.outputs(md3)[0]
    with f3.slave(unzipdir3, md3) as s:
        f3.initialize(s, md3)
        before = f3.read_outputs(s, md3)
        f3.clear_log()
        with pytest.raises(FMICallException) as e:
            s.getFloat64([out.valueReference], nValues=2)
        assert e.value.status == f3.ERROR
        assert any("fmi3GetFloat64: nValues = 2, expected 1" in m for m in f3.messages(f3.ERROR)), f3.RECORDS
        assert f3.read_outputs(s, md3) == before


def test_item54_event_mode_is_refused(unzipdir3, md3):
    """eventModeUsed=True with hasEventMode="false": instantiation returns NULL (fmpy raises
    "Failed to instantiate FMU") and the log says why."""
    f3.clear_log()
    with f3.slave(unzipdir3, md3, instantiate=False) as s:
        with pytest.raises(Exception, match="Failed to instantiate"):
            s.instantiate(eventModeUsed=True, logMessage=f3.record)
    assert any("eventModeUsed = true" in m for m in f3.messages(f3.ERROR)), f3.RECORDS


def test_item55_model_exchange_and_other_functions_are_errors(unzipdir3, md3):
    """ME, SE, event-mode and clock functions on the CS instance: fmi3Error and a
    message naming the function; ME and SE instantiation: NULL and a message; the instance
    goes on stepping afterwards."""
    with f3.slave(unzipdir3, md3) as s:
        f3.initialize(s, md3)
        c = s.component
        b, d = c_bool(), c_double()
        vrs = (fmpy.fmi3.fmi3ValueReference * 1)(0)
        calls = {
            "fmi3EnterContinuousTimeMode": lambda: s.fmi3EnterContinuousTimeMode(c),
            "fmi3SetTime": lambda: s.fmi3SetTime(c, 0.5),
            "fmi3CompletedIntegratorStep": lambda: s.fmi3CompletedIntegratorStep(c, True, byref(b), byref(b)),
            "fmi3EnterEventMode": lambda: s.fmi3EnterEventMode(c),
            "fmi3EnterStepMode": lambda: s.fmi3EnterStepMode(c),
            "fmi3UpdateDiscreteStates": lambda: s.fmi3UpdateDiscreteStates(
                c, byref(b), byref(b), byref(b), byref(b), byref(b), byref(d)),
            "fmi3ActivateModelPartition": lambda: s.fmi3ActivateModelPartition(c, 0, 0.0),
            "fmi3GetIntervalDecimal": lambda: s.fmi3GetIntervalDecimal(c, vrs, 1, byref(d), None),
        }
        for name, call in calls.items():
            f3.clear_log()
            assert fs.status_of(call) == f3.ERROR, name
            assert any(m.startswith(f"{name}: not supported: ") for m in f3.messages(f3.ERROR)), (name, f3.RECORDS)
        f3.clear_log()
        for name in ("fmi3InstantiateModelExchange", "fmi3InstantiateScheduledExecution"):
            args = [b"me", md3.guid.encode(), str(unzipdir3 / "resources").encode() + b"/", False, False, None,
                    s.logMessage]
            if name.endswith("ScheduledExecution"):
                args += [fmpy.fmi3.fmi3ClockUpdateCallback(), fmpy.fmi3.fmi3LockPreemptionCallback(),
                         fmpy.fmi3.fmi3UnlockPreemptionCallback()]
            assert not getattr(s, name)(*args)
            assert any(m.startswith(f"{name}: ") for m in f3.messages(f3.ERROR)), (name, f3.RECORDS)
        t, h = vr.experiment(md3)[0], (vr.experiment(md3)[1] - vr.experiment(md3)[0]) / 10
        assert s.doStep(t, h)[3] == t + h


# -- FMU state (items 42-44 in FMI 3 form) ------------------------------------------------------


def test_state_get_set_and_serialize_reproduce_the_run(unzipdir3, md3):
    """Save at t_2 of a 4-step ramp (handle and bytes), run to the end; set the handle back and
    run again; deserialize the bytes into a fresh, not initialized instance and run again: all
    three continuations are bit-identical."""
    f3.skip_arrays(md3)
    table = vr.ramp_table(md3, 4)
    grid = step_sizes(table)

    def run_from(s, k0):
        rows = []
        for k in range(k0, len(grid)):
            f3.set_inputs(s, md3, table[k])
            s.doStep(*grid[k])
            rows.append(f3.read_outputs(s, md3))
        return rows

    with f3.slave(unzipdir3, md3) as s:
        f3.initialize(s, md3)
        for k in range(2):
            f3.set_inputs(s, md3, table[k])
            s.doStep(*grid[k])
        state = s.getFMUState()
        data = s.serializeFMUState(state)
        first = run_from(s, 2)
        s.setFMUState(state)
        assert s.getFloat64([0]) == [grid[1][0] + grid[1][1]]
        again = run_from(s, 2)
        s.freeFMUState(state)
        assert not state.value
    with f3.slave(unzipdir3, md3, name="fresh") as fresh:
        state = fresh.deserializeFMUState(data)
        fresh.setFMUState(state)
        fresh.freeFMUState(state)
        run_from_two = run_from(fresh, 2)
    assert first == again == run_from_two


def test_state_bytes_of_the_fmi2_archive_are_rejected(unzipdir, unzipdir3, model_description, md3):
    """An FMI 2 state carries the FMI 2 GUID: fmi3DeserializeFMUState refuses it with a
    message, and the instance stays usable."""
    with fs.slave(unzipdir, model_description) as s2:
        fs.initialize(s2, model_description)
        state = s2.getFMUState()
        data = s2.serializeFMUState(state)
        s2.freeFMUState(state)
    with f3.slave(unzipdir3, md3) as s:
        f3.initialize(s, md3)
        f3.clear_log()
        with pytest.raises(FMICallException) as e:
            s.deserializeFMUState(data)
        assert e.value.status == f3.ERROR
        assert any("fmi3DeserializeFMUState: GUID check failed" in m for m in f3.messages(f3.ERROR)), f3.RECORDS
        t0, t1 = vr.experiment(md3)
        assert s.doStep(t0, (t1 - t0) / 10)[3] == t0 + (t1 - t0) / 10


# -- Failure policy (item 37) -------------------------------------------------------------------


def fmi3_variant(debug_fmus, model, tmp_path, **switches):
    fmu2 = debug_fmus(model, **switches)
    fmu3 = f3.fmi3_path(fmu2)
    md = fmpy.read_model_description(str(fmu3))
    return fmu3, md, fs.extracted(fmu3, tmp_path)


def raw_do_step(s, t, h):
    """fmi3DoStep with its out-arguments readable even when fmpy raises on the status."""
    event, terminate, early, last = c_bool(True), c_bool(True), c_bool(True), c_double(float("nan"))
    try:
        s.fmi3DoStep(s.component, t, h, True, byref(event), byref(terminate), byref(early), byref(last))
        status = f3.OK
    except FMICallException as e:
        status = e.status
    return status, (event.value, terminate.value, early.value, last.value)


def test_item37_forced_non_convergence_is_a_discard_with_the_state_unchanged(model, debug_fmus, tmp_path):
    """The debug variant fails the step that passes 0.55 of the experiment: fmi3DoStep returns
    fmi3Discard with lastSuccessfulTime = currentCommunicationPoint, earlyReturn false; the
    outputs, `time` and the whole serialized FMU state are as before the call; the log says why;
    the instance is still in Step Mode, so a shorter step ending before the failure time
    succeeds."""
    f3.skip_array_model(model)
    md2 = fmpy.read_model_description(str(vr.FMU_DIR / f"{model}.fmu"))
    t_fail = failure_time(md2)
    fmu3, md, unzipdir = fmi3_variant(debug_fmus, model, tmp_path, fail_after_time=t_fail)
    table = vr.ramp_table(md, 10)
    with f3.slave(unzipdir, md) as s:
        f3.initialize(s, md)
        for k, (t, h) in enumerate(step_sizes(table)):
            f3.set_inputs(s, md, table[k])
            before = (f3.read_outputs(s, md), s.getFloat64([0]), bytes(s.serializeFMUState(state := s.getFMUState())))
            s.freeFMUState(state)
            f3.clear_log()
            status, (event, terminate, early, last) = raw_do_step(s, t, h)
            if status == f3.OK:
                assert t + h <= t_fail * (1 + 1e-12)
                continue
            assert status == f3.DISCARD
            assert t < t_fail < t + h
            assert last == t and not early and not event and not terminate
            after = (f3.read_outputs(s, md), s.getFloat64([0]), bytes(s.serializeFMUState(state := s.getFMUState())))
            s.freeFMUState(state)
            assert after == before
            assert any("did not converge" in m and "state is unchanged" in m for m in f3.messages(f3.DISCARD)), f3.RECORDS
            short = 0.5 * (t_fail - t)
            assert s.doStep(t, short) == (False, False, False, t + short)
            break
        else:
            raise AssertionError("no step was discarded")


SIMULATE_RAISES = """
import sys
import fmpy, numpy as np
from fmpy.fmi1 import FMICallException
import velarium_run as vr
md = fmpy.read_model_description(sys.argv[1])
table = vr.ramp_table(md, 10)
try:
    fmpy.simulate_fmu(sys.argv[1], input=table, output_interval=float(table["time"][1] - table["time"][0]), timeout=60)
except FMICallException as e:
    print("raised", e.status)
else:
    print("returned")
"""


def test_item37_simulate_fmu_raises_on_discard(model, debug_fmus, tmp_path):
    """fmpy's FMI 3 simulate_fmu raises FMICallException (status 2) on the discarded step (run
    in a subprocess: simulate_fmu leaks the instance after an exception)."""
    f3.skip_array_model(model)
    md2 = fmpy.read_model_description(str(vr.FMU_DIR / f"{model}.fmu"))
    fmu3, _, _ = fmi3_variant(debug_fmus, model, tmp_path, fail_after_time=failure_time(md2))
    run = fs.run_python(SIMULATE_RAISES, str(fmu3))
    assert run.returncode == 0, run.stdout + run.stderr
    assert run.stdout.strip().splitlines()[-1] == "raised 2", run.stdout


def documented_loop():
    """The FMI 3 loop of docs/fmu.md, section "FMI 3.0" (the code block after the marker line)."""
    text = (vr.ROOT / "docs" / "fmu.md").read_text()
    match = re.search(r"<!-- fmi3-discard-loop -->\s*```python\n(.*?)```", text, re.S)
    assert match, "docs/fmu.md has no <!-- fmi3-discard-loop --> python block"
    namespace: dict = {}
    exec(compile(match.group(1), "docs/fmu.md", "exec"), namespace)
    return namespace["simulate_fmi3"]


def test_documented_loop_stops_at_the_discarded_step(model, debug_fmus, tmp_path):
    """The low-level FMI 3 loop of docs/fmu.md ends gracefully at the last converged time where
    simulate_fmu raises, and without a failure gives simulate_fmu's rows."""
    f3.skip_array_model(model)
    simulate_fmi3 = documented_loop()
    md2 = fmpy.read_model_description(str(vr.FMU_DIR / f"{model}.fmu"))
    t_fail = failure_time(md2)
    fmu3, md, _ = fmi3_variant(debug_fmus, model, tmp_path, fail_after_time=t_fail)
    table = vr.ramp_table(md, 10)
    rows = simulate_fmi3(str(fmu3), table)
    h = float(table["time"][1] - table["time"][0])
    assert t_fail - h < rows["time"][-1] < t_fail
    full = simulate_fmi3(str(f3.fmi3_path(vr.FMU_DIR / f"{model}.fmu")), table)
    reference = vr.simulate(f3.fmi3_path(vr.FMU_DIR / f"{model}.fmu"), table)
    for name in reference.dtype.names:
        assert np.array_equal(full[name], reference[name]), name
    n = len(rows)
    for name in reference.dtype.names:
        assert np.array_equal(rows[name], reference[name][:n]), name
