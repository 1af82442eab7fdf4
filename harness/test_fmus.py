"""Every shipped FMU from outside, the way importers use it (FMI.md checklist 1-5, 21-28).

The central test, ``test_ramp_matches_velarium_solve``, runs an input ramp through
``fmpy.simulate_fmu`` and the same table through ``velarium solve`` and compares them row by
row with the one-step lag of FMI co-simulation (fmpy's row at t_{k+1} is solve's row k).
"""

from __future__ import annotations

import subprocess
import sys
import xml.etree.ElementTree as ET
import zipfile

import fmpy
import numpy as np
import pytest
from fmpy.fmi2 import FMU2Slave
from fmpy.validation import validate_fmu

import velarium_run as vr

# Both runs call the same engine with the same f64 inputs in the same order, so they agree to
# the last bit today; 1e-9 leaves room for a solver that starts Newton from a slightly
# different iterate (e.g. the FMU's no-op first DoStep) while still catching any real
# difference (the solver's own tolerance is 1e-9 relative to the load, far above round-off).
RTOL = 1e-9


def real_outputs(md) -> list[str]:
    return [v.name for v in vr.outputs(md) if v.type == "Real"]


def integer_outputs(md) -> list[str]:
    return [v.name for v in vr.outputs(md) if v.type == "Integer"]


def assert_rows_close(actual, expected, names, what):
    for name in names:
        a, e = np.asarray(actual[name], float), np.asarray(expected[name], float)
        scale = max(np.max(np.abs(a)), np.max(np.abs(e)), 1e-300)
        bad = np.abs(a - e) > RTOL * scale
        assert not bad.any(), f"{what}: {name} differs in rows {np.flatnonzero(bad)}:\n{a}\n{e}"


# -- Packaging and static checks (checklist 1-5) -------------------------------------------------


def test_validate_fmu_finds_no_problem(fmu):
    assert validate_fmu(str(fmu)) == []


def test_fmutool_check_passes(fmu):
    fmutool = vr.Path(sys.executable).with_name("fmutool")
    run = subprocess.run([str(fmutool), "-input", str(fmu), "-check"], capture_output=True, text=True, timeout=300)
    report = run.stdout + run.stderr
    assert run.returncode == 0, report
    assert "ERROR" not in report, report


def test_archive_layout_and_contents(fmu, scene, model_description, velarium):
    with zipfile.ZipFile(fmu) as z:
        infos = z.infolist()
    identifier = model_description.coSimulation.modelIdentifier
    assert [i.filename for i in infos] == [
        "modelDescription.xml",
        f"binaries/linux64/{identifier}.so",
        "resources/scene.json",
    ]
    assert all(i.compress_type == zipfile.ZIP_DEFLATED for i in infos)
    assert fmpy.supported_platforms(str(fmu)) == ["linux64"]

    described = subprocess.run([str(velarium), "describe", str(scene)], capture_output=True, text=True, check=True)
    xml = vr.fmu_member(fmu, "modelDescription.xml").decode()
    assert xml == described.stdout, "the FMU is stale: repack it (bash .ci/run)"
    committed = scene.parent / "modelDescription.xml"
    if committed.is_file():
        assert xml == committed.read_text(), f"{committed} is stale"
    library = velarium.with_name("libvelarium.so")
    assert vr.fmu_member(fmu, f"binaries/linux64/{identifier}.so") == library.read_bytes(), (
        f"the FMU's binary is not {library}: repack it (bash .ci/run)"
    )


def test_model_structure_lists_exactly_the_outputs(fmu):
    root = ET.fromstring(vr.fmu_member(fmu, "modelDescription.xml"))
    variables = root.find("ModelVariables").findall("ScalarVariable")
    outputs = [i + 1 for i, v in enumerate(variables) if v.get("causality") == "output"]
    structure = root.find("ModelStructure")
    for section in ("Outputs", "InitialUnknowns"):
        listed = [int(u.get("index")) for u in structure.find(section).findall("Unknown")] if outputs else []
        assert listed == outputs, section
    defined = {u.get("name") for u in root.iter("Unit")}
    for v in variables:
        value = v[0]
        assert value.get("unit") is None or value.get("unit") in defined, v.get("name")
        causality = v.get("causality")
        if causality == "parameter":
            assert v.get("variability") in ("fixed", "tunable") and value.get("start") is not None
        if causality == "input":
            assert v.get("initial") is None and value.get("start") is not None
        if causality == "output":
            assert value.get("start") is None and v.get("initial") in (None, "calculated")


def test_a_wrong_guid_is_rejected_with_a_message(fmu, model_description, tmp_path, capfd):
    # fmpy's default logger prints the FMU's messages. A custom logger would have to go through
    # fmpy.logging.addLoggerProxy, whose native proxy keeps ONE process-wide pointer to the last
    # Python callback: once that callback is garbage-collected, the next FMU message from any
    # run in the process jumps to freed memory (segfault). So the harness never installs one.
    unzipped = fmpy.extract(str(fmu), str(tmp_path / "unzipped"))
    wrong = "{00000000-0000-0000-0000-000000000000}"
    slave = FMU2Slave(
        guid=wrong,
        unzipDirectory=unzipped,
        modelIdentifier=model_description.coSimulation.modelIdentifier,
        instanceName="wrong_guid",
    )
    try:
        with pytest.raises(Exception, match="Failed to instantiate"):
            slave.instantiate()
    finally:
        slave.freeLibrary()
    printed = capfd.readouterr()
    log = printed.out + printed.err
    assert model_description.guid in log and wrong in log, log


# -- Initialization, start values, units (checklist 21-25) ---------------------------------------


def test_default_experiment_runs_to_stop_time(fmu, model_description):
    start, stop = vr.experiment(model_description)
    step = float(model_description.defaultExperiment.stepSize)
    result = vr.simulate(fmu)
    assert len(result) == round((stop - start) / step) + 1
    assert result["time"][-1] == pytest.approx(stop, rel=1e-12, abs=1e-12)


def test_inputs_never_set_take_their_start_values(fmu, model_description):
    table = vr.ramp_table(model_description, 4)
    for v in vr.inputs(model_description):
        table[v.name] = float(v.start)
    given = vr.simulate(fmu, table)
    never_set = vr.simulate(fmu, start_time=float(table["time"][0]), stop_time=float(table["time"][-1]),
                            output_interval=float(table["time"][1] - table["time"][0]))
    for v in vr.outputs(model_description):
        assert np.array_equal(given[v.name], never_set[v.name]), v.name


def test_start_values_in_display_units(fmu, model_description):
    units = {u.name: u for u in model_description.unitDefinitions}
    candidates = [
        (v, units[v.unit].displayUnits[0])
        for v in model_description.modelVariables
        if v.causality == "parameter" and v.unit in units and units[v.unit].displayUnits
    ]
    if not candidates:
        pytest.skip("no parameter has a unit with a display unit")
    parameter, display = candidates[0]
    value = float(parameter.start)
    table = vr.ramp_table(model_description, 4)
    plain = vr.simulate(fmu, table, start_values={parameter.name: value})
    displayed = vr.simulate(fmu, table, start_values={parameter.name: (value * display.factor, display.name)})
    assert_rows_close(displayed, plain, real_outputs(model_description), f"{parameter.name} in {display.name}")


def test_an_unknown_start_value_raises(fmu):
    with pytest.raises(Exception, match="no_such_var"):
        vr.simulate(fmu, start_values={"no_such_var": 1.0})


# -- Stepping semantics (checklist 26-28) --------------------------------------------------------


def test_ramp_matches_velarium_solve(fmu, scene, model_description, velarium, tmp_path):
    """fmpy row t_0 == solve row 0 (equilibrium after initialization); fmpy row t_{k+1} == solve
    row k (u(t_k) is set before DoStep(t_k, h)). Solve's last row (under u(t_n)) has no fmpy
    counterpart: the run stops at t_n."""
    steps = 4
    table = vr.ramp_table(model_description, steps)
    cli_rows = vr.solve(scene, table, tmp_path, velarium)
    fmu_rows = vr.simulate(fmu, table)
    assert len(fmu_rows) == steps + 1
    assert fmu_rows["time"][-1] == table["time"][-1]
    assert len(cli_rows) == steps + 1
    assert np.array_equal(cli_rows["time"], table["time"])

    reals = real_outputs(model_description)
    assert_rows_close(fmu_rows[:1], cli_rows[:1], reals + integer_outputs(model_description), "t_0 vs solve row 0")
    assert_rows_close(fmu_rows[1:], cli_rows[:-1], reals, "t_(k+1) vs solve row k")
    # Iteration counts agree from the second step on; the first DoStep re-solves the initial
    # loads from their own equilibrium, so it reports its own (small) count.
    for name in integer_outputs(model_description):
        assert np.array_equal(fmu_rows[name][2:], cli_rows[name][1:-1]), name


def test_a_constant_load_does_not_drift(fmu, model_description):
    """The load is reached at initialization; steps of any size then keep that equilibrium."""
    finals = []
    for steps in (2, 8):
        table = vr.ramp_table(model_description, steps)
        for v in vr.inputs(model_description):
            table[v.name] = vr.ramp_target(v)
        rows = vr.simulate(fmu, table)
        first = rows[:1].repeat(len(rows))
        assert_rows_close(rows, first, real_outputs(model_description), f"h = 1/{steps}")
        finals.append(rows[-1:])
    assert_rows_close(finals[0], finals[1], real_outputs(model_description), "h vs h/4")


def test_the_last_step_ends_exactly_at_stop_time(fmu, model_description):
    table = vr.ramp_table(model_description, 4)
    start, stop = vr.experiment(model_description)
    rows = vr.simulate(fmu, table, output_interval=(stop - start) / 3.5)
    assert len(rows) == 5
    assert rows["time"][-1] == pytest.approx(stop, rel=1e-12, abs=1e-12)


def test_an_input_event_gets_its_own_communication_point(fmu, model_description):
    start, stop = vr.experiment(model_description)
    event = start + 0.3 * (stop - start)
    names = [v.name for v in vr.inputs(model_description)]
    table = np.zeros(4, dtype=[("time", np.float64)] + [(n, np.float64) for n in names])
    table["time"] = [start, event, event, stop]
    for v in vr.inputs(model_description):
        u0, u1 = float(v.start), vr.ramp_target(v)
        table[v.name] = [u0, u0, u1, u1]
    rows = vr.simulate(fmu, table, output_interval=(stop - start) / 4)
    assert np.isclose(rows["time"], event).any(), rows["time"]
    assert rows["time"][-1] == pytest.approx(stop, rel=1e-12, abs=1e-12)
