"""Every shipped FMU from outside, the way importers use it: the archive is what `velarium
pack` makes today, and the FMU's numbers are `velarium solve`'s. The FMI conformance checklist
(docs/fmu.md, "The conformance checklist", items 1-50) is in test_conformance_*.py.

The central test, ``test_ramp_matches_velarium_solve``, runs an input ramp through
``fmpy.simulate_fmu`` and the same table through ``velarium solve`` and compares them row by
row with the one-step lag of FMI co-simulation (fmpy's row at t_{k+1} is solve's row k).
"""

from __future__ import annotations

import subprocess
import zipfile

import fmpy
import numpy as np

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


# -- The archive --------------------------------------------------------------------------------


def test_archive_layout_and_contents(fmu, scene, model_description, velarium):
    with zipfile.ZipFile(fmu) as z:
        infos = z.infolist()
    identifier = model_description.coSimulation.modelIdentifier
    assert [i.filename for i in infos] == [
        "modelDescription.xml",
        f"binaries/linux64/{identifier}.so",
        "resources/scene.json",
        "resources/mesh.vtu",
        "extra/org.fmi-standard.fmi-ls-ref/fmi-ls-manifest.xml",
        f"extra/org.fmi-standard.fmi-ls-ref/{identifier}_ref.csv",
        f"extra/org.fmi-standard.fmi-ls-ref/{identifier}_in.csv",
    ]
    assert all(i.compress_type == zipfile.ZIP_DEFLATED for i in infos)
    assert fmpy.supported_platforms(str(fmu)) == ["linux64"]

    described = subprocess.run([str(velarium), "describe", str(scene)], capture_output=True, text=True, check=True)
    xml = vr.fmu_member(fmu, "modelDescription.xml").decode()
    assert xml == described.stdout, "the FMU is stale: repack it (bash .ci/run)"
    committed = scene.parent / "modelDescription.xml"
    if committed.is_file():
        assert xml == committed.read_text(), f"{committed} is stale"
    library = vr.default_library()  # what `velarium pack` ships: the portable build when current
    assert vr.fmu_member(fmu, f"binaries/linux64/{identifier}.so") == library.read_bytes(), (
        f"the FMU's binary is not {library}: repack it (bash .ci/run)"
    )


# -- The numbers -------------------------------------------------------------------------------


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


